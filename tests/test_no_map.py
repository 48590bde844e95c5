"""A node that starts with no map (no `map_yaml`, no map server yet), checked from outside on its
own ROS_DOMAIN_ID: goals and GetPlan get NO_MAP with a reason, the node plans as soon as a map
arrives on /map; then, given odometry, an initial pose re-anchors map -> odom as AMCL would, and
plans start where odometry has carried the robot since."""
import math

import numpy as np
import pytest

from nav_msgs.msg import Odometry

from conftest import initial_pose, node_rig, stamped
from test_node import assert_collision_free, grid_msg, plan_to
from test_services import get_plan


@pytest.fixture(scope="module")
def bare(tmp_path_factory):
    params = tmp_path_factory.mktemp("no_map") / "planner.yaml"
    params.write_text('patrol_planner:\n  ros__parameters:\n    map_yaml: ""\n    planner: astar\n    follow_plan: false\n')
    with node_rig(55, params, "no_map") as r:  # a domain away from the `ros` fixture's node
        yield r


def test_no_map_yet_then_a_map(bare):
    ros = bare
    ros.wait_matched(ros.initial_pub, "/initialpose")
    ros.wait_matched(ros.goal_pub, "/goal_pose")

    def no_map():
        ros.initial_pub.publish(initial_pose(1.0, 1.0))
        i = len(ros.diagnostics)
        ros.goal_pub.publish(stamped(4.0, 1.0))
        try:
            return ros.wait_code(i, "NO_MAP", timeout=2)
        except AssertionError:
            return None

    _, message, _ = ros.spin_until(no_map, 30, "NO_MAP for a goal")
    assert "no map" in message and "/map" in message
    i = len(ros.diagnostics)
    assert get_plan(ros, (1.0, 1.0), (4.0, 1.0)).poses == []
    ros.wait_code(i, "NO_MAP")
    # A 6 m x 3 m room with a pillar; the node plans in it as soon as it arrives.
    grid = np.zeros((30, 60), dtype=np.int8)
    grid[0:20, 25:30] = 100
    ros.map_pub.publish(grid_msg(grid, (0.0, 0.0), 0.1))

    def planned():  # a goal that overtakes the map on the wire still gets NO_MAP: ask again
        try:
            return plan_to(ros, (5.5, 1.0), timeout=2)
        except AssertionError:
            return None

    path = ros.spin_until(planned, 30, "a plan once the map is there")
    first = path.poses[0].pose.position
    assert math.hypot(first.x - 1.0, first.y - 1.0) < 1e-6
    assert_collision_free(path, grid, (0.0, 0.0), 0.1)


def odometry(x, y, yaw=0.0):
    m = Odometry()
    m.header.frame_id, m.child_frame_id = "odom", "base_link"
    m.pose.pose.position.x, m.pose.pose.position.y = float(x), float(y)
    m.pose.pose.orientation.z, m.pose.pose.orientation.w = math.sin(yaw / 2), math.cos(yaw / 2)
    return m


def test_an_initial_pose_reanchors_odometry(bare):
    ros = bare  # runs after test_no_map_yet_then_a_map: the room map is in place
    odom_pub = ros.node.create_publisher(Odometry, "/odom", 10)
    ros.wait_matched(odom_pub, "/odom")

    def start_of_plan():
        path = plan_to(ros, (5.5, 1.0), timeout=5)
        return path.poses[0].pose.position

    def settle(publish):  # topics are not ordered with each other: let each one land
        for _ in range(3):
            publish()
            ros.spin_for(0.2)

    # Odometry says (0, 0); the user clicks "2D Pose Estimate" at (1.5, 1) facing +y (not where
    # the test before left the robot, (1, 1), so that an ignored pose cannot pass).
    settle(lambda: odom_pub.publish(odometry(0.0, 0.0)))
    p = initial_pose(1.5, 1.0)
    p.pose.pose.orientation.z, p.pose.pose.orientation.w = math.sin(math.pi / 4), math.cos(math.pi / 4)
    settle(lambda: ros.initial_pub.publish(p))
    first = start_of_plan()
    assert math.hypot(first.x - 1.5, first.y - 1.0) < 1e-6, f"the plan starts at the initial pose, not ({first.x}, {first.y})"
    # The robot drives 0.5 m forward in odom (+x): in the map that is +y from the initial pose.
    settle(lambda: odom_pub.publish(odometry(0.5, 0.0)))
    moved = start_of_plan()
    assert math.hypot(moved.x - 1.5, moved.y - 1.5) < 1e-6, f"odometry carried the pose to ({moved.x}, {moved.y}), not (1.5, 1.5)"
