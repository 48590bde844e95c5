"""The node's obstacle layer, as Nav2's global costmap runs its ObstacleLayer: a laser scan
(sensor_msgs/LaserScan on `scan`, in a `laser` frame placed on the robot through /tf_static)
that sees a block across the direct route gets plans that go round it, inflated as the map's
walls are; a later scan whose rays pass through where the block was clears it, and plans go
straight again. Returns beyond obstacle_max_range (2.5 m) mark nothing; a scan with numbers that
are not finite is skipped and the node goes on."""
import math

import numpy as np
import pytest
import rclpy
from geometry_msgs.msg import TransformStamped
from nav_msgs.srv import GetPlan
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import LaserScan
from tf2_msgs.msg import TFMessage

from conftest import Ros, call_service, domain_id, initial_pose, start_node, stamped, stop_binary
from test_node import grid_msg

# A 6 m x 3 m room (0.1 m cells, origin at 0, 0), empty. The robot at (0.5, 1.5) facing +x, its
# laser 0.1 m ahead of it; the block the laser sees: x 2.8-3.1 m, y 1.0-2.0 m.
START, GOAL = (0.5, 1.5), (5.5, 1.5)
LASER_X = START[0] + 0.1
BLOCK_X, BLOCK_Y = (2.8, 3.1), (1.0, 2.0)
RAYS = 181  # -90 .. 90 degrees, a degree apart
RATE_HZ = 10


def scan_ranges(block):
    """Each ray's range: to the block's near face where it hits it (`block`), else 4 m (past
    obstacle_max_range, so the ray clears up to raytrace_max_range and marks nothing)."""
    ranges = []
    for i in range(RAYS):
        a = math.radians(-90 + i)
        hit = None
        if block and math.cos(a) > 1e-6:
            r = (BLOCK_X[0] - LASER_X) / math.cos(a)
            if BLOCK_Y[0] <= START[1] + r * math.sin(a) <= BLOCK_Y[1]:
                hit = r
        ranges.append(hit if hit is not None else 4.0)
    return ranges


class Laser:
    """Publishes at RATE_HZ a scan that sees the block while `block`, else one that does not."""

    def __init__(self, ros):
        self.ros, self.block, self.bad = ros, True, False
        self.pub = ros.node.create_publisher(LaserScan, "/scan", QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT))
        static = ros.node.create_publisher(TFMessage, "/tf_static", QoSProfile(
            depth=100, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL))
        for pub, what in [(self.pub, "/scan"), (static, "/tf_static")]:
            ros.wait_matched(pub, what)
        t = TransformStamped()
        t.header.frame_id, t.child_frame_id = "base_link", "laser"
        t.transform.translation.x, t.transform.translation.z = 0.1, 0.2
        t.transform.rotation.w = 1.0
        static.publish(TFMessage(transforms=[t]))
        ros.node.create_timer(1.0 / RATE_HZ, self.tick)

    def tick(self):
        m = LaserScan()
        m.header.stamp = self.ros.node.get_clock().now().to_msg()
        m.header.frame_id = "laser"
        m.angle_min, m.angle_max, m.angle_increment = -math.pi / 2, math.pi / 2, math.radians(1.0)
        m.range_min, m.range_max = 0.05, 10.0
        m.ranges = scan_ranges(self.block)
        if self.bad:
            m.angle_increment = float("nan")
        self.pub.publish(m)


@pytest.fixture
def rig(tmp_path):
    domain = domain_id(76)  # away from the `ros` fixture's node and the other modules'
    params = tmp_path / "planner.yaml"
    params.write_text('patrol_planner:\n  ros__parameters:\n    map_yaml: ""\n    planner: astar\n'
                      "    obstacle_layer: {update_frequency: 5.0}\n")
    proc = start_node(domain, params, "patrol_planner_obstacle_layer_test.log")
    ros = Ros(domain, context=rclpy.Context())
    try:
        ros.wait_matched(ros.map_pub, "/map")
        ros.wait_matched(ros.initial_pub, "/initialpose")
        ros.map_pub.publish(grid_msg(np.zeros((30, 60), dtype=np.int8), (0.0, 0.0), 0.1))
        ros.initial_pub.publish(initial_pose(*START))
        yield ros, Laser(ros)
    finally:
        ros.close()
        stop_binary(proc)


def plan(ros):
    req = GetPlan.Request(start=stamped(*START), goal=stamped(*GOAL), tolerance=0.0)
    return [(p.pose.position.x, p.pose.position.y)
            for p in call_service(ros, GetPlan, "/patrol_planner/make_plan", req).plan.poses]


def swerve(points):
    """How far the plan strays from the straight line y = 1.5 (m); None for no plan."""
    return max(abs(y - START[1]) for _, y in points) if points else None


def crosses_block(points):
    for (x0, y0), (x1, y1) in zip(points, points[1:]):
        for k in range(21):
            x, y = x0 + (x1 - x0) * k / 20, y0 + (y1 - y0) * k / 20
            if BLOCK_X[0] <= x <= BLOCK_X[1] and BLOCK_Y[0] <= y <= BLOCK_Y[1]:
                return True
    return False


def test_a_scanned_obstacle_is_planned_round_until_a_scan_clears_it(rig):
    ros, laser = rig
    around = ros.spin_until(lambda: (lambda p: p if (swerve(p) or 0) > 0.5 else None)(plan(ros)), 30,
                            "a plan round the block the scan shows")
    assert not crosses_block(around)
    # Round it by the robot's inflated radius (0.45 m): through the gap above or below.
    assert swerve(around) > (BLOCK_Y[1] - START[1]) + 0.4, around
    # A scan with a NaN increment is skipped; the block stays as the last good scans left it.
    laser.bad = True
    ros.spin_for(1.0)
    assert swerve(plan(ros)) > 0.5
    laser.bad, laser.block = False, False
    straight = ros.spin_until(lambda: (lambda p: p if swerve(p) is not None and swerve(p) < 0.05 else None)(plan(ros)),
                              30, "a straight plan once the scan's rays pass where the block was")
    assert straight[-1] == pytest.approx(GOAL)
