"""Where the node takes the robot's pose from, as Nav2 does: the odometry's `odom -> base_link`
on /tf (here `odom -> base_footprint` under robot_state_publisher's static
`base_footprint -> base_link`), which in a robot_localization stack is the filtered pose while
/odom stays the raw wheel odometry. So the transform wins over /odom while it keeps coming, and
/odom is the pose again once it has not come for `pose_timeout` (0.5 s); transforms of other
frames (a cart's) do not keep a stopped odometry alive. The plan GetPlan makes from the robot's
pose starts where the node thinks the robot is."""
import math

import numpy as np
import pytest
from nav_msgs.msg import Odometry
from nav_msgs.srv import GetPlan
from tf2_msgs.msg import TFMessage

from conftest import TF, call_service, node_rig, stamped, static_transforms, transform, yaw_quaternion
from test_node import grid_msg

# A 6 m x 3 m room (0.1 m cells, origin at 0, 0), empty.
ODOM_POSE = (1.0, 1.5)  # where the raw /odom says the robot is
FOOTPRINT = (3.5, 1.0, math.pi / 2)  # odom -> base_footprint on /tf, facing +y
LINK_OFFSET = 0.2  # base_footprint -> base_link, along base_footprint's x (static)
TF_POSE = (FOOTPRINT[0], FOOTPRINT[1] + LINK_OFFSET)  # base_link in odom (and in map)
GOAL = (5.0, 2.5)
RATE_HZ = 20


class Odometries:
    """Publishes, at RATE_HZ, /odom at ODOM_POSE always, `odom -> base_footprint` at FOOTPRINT
    while `tf_on`, and a cart's `map -> cart` while `cart_on`."""

    def __init__(self, ros):
        self.ros, self.tf_on, self.cart_on = ros, False, False
        self.odom_pub = ros.node.create_publisher(Odometry, "/odom", 10)
        self.tf_pub = ros.node.create_publisher(TFMessage, "/tf", TF)
        for pub, what in [(self.odom_pub, "/odom"), (self.tf_pub, "/tf")]:
            ros.wait_matched(pub, what)
        static_transforms(ros, transform("base_footprint", "base_link", (LINK_OFFSET, 0.0, 0.0)))
        ros.node.create_timer(1.0 / RATE_HZ, self.tick)

    def tick(self):
        now = self.ros.node.get_clock().now().to_msg()
        m = Odometry()
        m.header.stamp = now
        m.header.frame_id, m.child_frame_id = "odom", "base_footprint"
        m.pose.pose.position.x, m.pose.pose.position.y = ODOM_POSE
        m.pose.pose.orientation.w = 1.0
        self.odom_pub.publish(m)
        moved = []
        if self.tf_on:
            x, y, yaw = FOOTPRINT
            moved.append(transform("odom", "base_footprint", (x, y, 0.0), yaw_quaternion(yaw), now))
        if self.cart_on:
            moved.append(transform("map", "cart", (2.0, 2.0, 0.0), stamp=now))
        if moved:
            self.tf_pub.publish(TFMessage(transforms=moved))


@pytest.fixture
def rig(tmp_path):
    params = tmp_path / "planner.yaml"
    params.write_text('patrol_planner:\n  ros__parameters:\n    map_yaml: ""\n    planner: astar\n')
    # A domain away from the `ros` fixture's node and the other modules'.
    with node_rig(75, params, "odometry") as ros:
        ros.wait_matched(ros.map_pub, "/map")
        ros.map_pub.publish(grid_msg(np.zeros((30, 60), dtype=np.int8), (0.0, 0.0), 0.1))
        yield ros, Odometries(ros)


def start_of_plan(ros):
    """The first pose of a plan from the robot's pose to GOAL, or None."""
    req = GetPlan.Request(goal=stamped(*GOAL), tolerance=0.0)
    req.start.header.frame_id = ""  # from the robot's pose
    poses = call_service(ros, GetPlan, "/patrol_planner/make_plan", req).plan.poses
    return (poses[0].pose.position.x, poses[0].pose.position.y) if poses else None


def at(point):
    return lambda ros: (lambda s: s is not None and math.dist(s, point) < 1e-3)(start_of_plan(ros))


def test_the_robots_pose_comes_from_odom_to_base_link_on_tf_before_odom(rig):
    ros, odometries = rig
    ros.spin_until(lambda: at(ODOM_POSE)(ros), 30, "a plan from /odom's pose while /tf has no odometry")
    odometries.tf_on = True
    ros.spin_until(lambda: at(TF_POSE)(ros), 10, "a plan from odom -> base_footprint -> base_link on /tf")
    # /odom goes on at 20 Hz: while the transform keeps coming, it is not the pose.
    for _ in range(10):
        ros.spin_for(0.1)
        assert at(TF_POSE)(ros), f"the plan started at {start_of_plan(ros)}, not at the /tf pose"
    # The odometry's transform stops while a cart's goes on: after pose_timeout, /odom again.
    odometries.tf_on, odometries.cart_on = False, True
    ros.spin_until(lambda: at(ODOM_POSE)(ros), 10, "a plan from /odom's pose once /tf's odometry stopped")
