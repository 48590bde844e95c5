"""How the node's drives end, from outside: every one ends on an exact zero /cmd_vel, as Nav2's
controller ends one, instead of leaving the chassis on its last command until the bridge's
watchdog trips. A goal that fails mid-drive brakes the robot within the acceleration limits down
to that stop; Ctrl-C while driving sends it too. The test itself is the robot: it publishes a
stationary /odom, so the follower keeps asking to move, and watches /cmd_vel."""
import signal

import numpy as np
import pytest
import rclpy
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry

from conftest import Ros, domain_id, stamped, start_node, stop_binary
from test_node import grid_msg

# config/planner.yaml's follower limits and rate, which the node below runs with.
MAX_LINEAR_ACCEL, MAX_ANGULAR_ACCEL, RATE_HZ = 0.5, 1.0, 20.0
START = (0.5, 2.5)


def room():
    """A 6 m x 3 m room (0.1 m cells) with a pillar at x 2.5-3.0 m, y 0-2 m."""
    grid = np.zeros((30, 60), dtype=np.int8)
    grid[0:20, 25:30] = 100
    return grid


@pytest.fixture
def driving(tmp_path):
    domain = domain_id(60)  # away from the `ros` fixture's node and the other modules'
    params = tmp_path / "planner.yaml"
    params.write_text('patrol_planner:\n  ros__parameters:\n    map_yaml: ""\n    planner: astar\n')
    proc = start_node(domain, params, "patrol_planner_stopping_test.log")
    ros = Ros(domain, context=rclpy.Context())
    cmds = []
    ros.node.create_subscription(Twist, "/cmd_vel", cmds.append, 100)
    odom_pub = ros.node.create_publisher(Odometry, "/odom", 10)

    def publish_odom():
        m = Odometry()
        m.header.stamp = ros.node.get_clock().now().to_msg()
        m.header.frame_id, m.child_frame_id = "odom", "base_link"
        m.pose.pose.position.x, m.pose.pose.position.y = START
        m.pose.pose.orientation.w = 1.0
        odom_pub.publish(m)

    ros.node.create_timer(1.0 / RATE_HZ, publish_odom)
    ros.map_pub.publish(grid_msg(room(), (0.0, 0.0), 0.1))
    try:
        yield ros, proc, cmds
    finally:
        ros.close()
        stop_binary(proc)


def moving(t):
    return t.linear.x != 0.0 or t.angular.z != 0.0


def drive_to(ros, cmds, goal):
    """Sends `goal` until the node answers with a plan, then waits until it drives."""
    ros.send_goal_until_planned(stamped(*goal))
    before = len(cmds)
    ros.spin_until(lambda: any(moving(t) for t in cmds[before:]), 10, "the node to drive")
    ros.spin_for(1.0)  # up to speed (or turning)


def test_a_failed_goal_brakes_to_an_exact_stop(driving):
    ros, _, cmds = driving
    drive_to(ros, cmds, (5.5, 2.5))
    driving_from = len(cmds) - 1
    i = len(ros.diagnostics)
    ros.goal_pub.publish(stamped(2.7, 1.0))  # inside the pillar
    ros.wait_code(i, "GOAL_OCCUPIED")
    failed_at = len(cmds)
    assert moving(cmds[failed_at - 1]), "the robot was not moving when the goal failed"
    ros.spin_until(lambda: not moving(cmds[-1]), 5, "a zero /cmd_vel")
    # Each step within the acceleration limits (a stop dropped at once would break them), and
    # after the failure (one drive command may still have been on its way) only ever slower.
    steps = cmds[driving_from:]
    for a, b in zip(steps, steps[1:]):
        assert abs(b.linear.x - a.linear.x) <= MAX_LINEAR_ACCEL / RATE_HZ + 1e-6, (a, b)
        assert abs(b.angular.z - a.angular.z) <= MAX_ANGULAR_ACCEL / RATE_HZ + 1e-6, (a, b)
    braking = cmds[failed_at + 1:]
    for a, b in zip(braking, braking[1:]):
        assert abs(b.linear.x) <= abs(a.linear.x) + 1e-9 and abs(b.angular.z) <= abs(a.angular.z) + 1e-9, (a, b)
    # And then quiet: /cmd_vel is left to whoever else drives the robot.
    count = len(cmds)
    ros.spin_for(1.0)
    assert len(cmds) == count, f"the node kept publishing after its stop: {cmds[count:]}"


def test_ctrl_c_while_driving_sends_a_stop(driving):
    ros, proc, cmds = driving
    drive_to(ros, cmds, (5.5, 2.5))
    assert moving(cmds[-1])
    proc.send_signal(signal.SIGINT)
    ros.spin_until(lambda: proc.poll() is not None, 15, "the node to exit")
    ros.spin_for(0.5)  # anything still on the wire
    assert not moving(cmds[-1]), f"the node's last /cmd_vel was {cmds[-1]}"
