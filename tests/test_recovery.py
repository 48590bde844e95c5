"""Recoveries, as Nav2's default navigation trees retry a goal: a navigate_to_pose drive whose
robot makes no progress (controller_server's progress checker: neither moved
`required_movement_radius` nor turned `required_movement_angle` within
`movement_time_allowance`) stops, waits `recovery.wait_duration` and plans again from where the
robot is, up to `recovery.number_of_retries` times, each counted in the feedback's
number_of_recoveries. The test itself is the robot: it publishes /odom, standing still while it
is "blocked" and otherwise moving as /cmd_vel tells it (a unicycle at the node's rate).

- Blocked for good: the goal ends aborted with FAILED_TO_MAKE_PROGRESS (105) after exactly the
  retries, its message saying the robot made no progress, and the robot is told to stop.
- Blocked until the first recovery, then free: the goal succeeds, with one recovery reported.
- A goal inside an obstacle (GOAL_OCCUPIED, 206) is not retried: no recovery helps it.
- A /goal_pose whose robot makes no progress is given up: the robot is told to stop."""
import math
import time

import numpy as np
import pytest
import rclpy
from action_msgs.msg import GoalStatus
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from nav_msgs.srv import GetPlan
from rclpy.action import ActionClient

from nav2_msgs.action import NavigateToPose

from conftest import Ros, call_service, domain_id, stamped, start_node, stop_binary
from test_node import grid_msg

RATE_HZ = 20.0
START = (0.5, 1.5)
GOAL = (4.5, 1.5)
# Allowance: the follower slows to 0.6 m/s per metre left over its last metre, so its last
# 0.5 m take up to 3 s; a shorter allowance would call the approach no progress.
RETRIES, ALLOWANCE, WAIT = 2, 4.0, 0.5


class Robot:
    """The robot the node drives: stands still while `blocked`, else follows /cmd_vel."""

    def __init__(self, ros):
        self.x, self.y, self.yaw = START[0], START[1], 0.0
        self.blocked = True
        self.cmds = []
        ros.node.create_subscription(Twist, "/cmd_vel", self.cmds.append, 100)
        self.pub = ros.node.create_publisher(Odometry, "/odom", 10)
        self.clock = ros.node.get_clock()
        ros.node.create_timer(1.0 / RATE_HZ, self.tick)

    def tick(self):
        if not self.blocked and self.cmds:
            v, w, dt = self.cmds[-1].linear.x, self.cmds[-1].angular.z, 1.0 / RATE_HZ
            self.x += v * math.cos(self.yaw) * dt
            self.y += v * math.sin(self.yaw) * dt
            self.yaw += w * dt
        m = Odometry()
        m.header.stamp = self.clock.now().to_msg()
        m.header.frame_id, m.child_frame_id = "odom", "base_link"
        m.pose.pose.position.x, m.pose.pose.position.y = self.x, self.y
        m.pose.pose.orientation.z, m.pose.pose.orientation.w = math.sin(self.yaw / 2), math.cos(self.yaw / 2)
        self.pub.publish(m)


@pytest.fixture
def rig(tmp_path):
    domain = domain_id(70)  # away from the session node's and the other modules'
    params = tmp_path / "planner.yaml"
    params.write_text(
        "patrol_planner:\n  ros__parameters:\n"
        '    map_yaml: ""\n    planner: astar\n'
        f"    progress_checker: {{movement_time_allowance: {ALLOWANCE}}}\n"
        f"    recovery: {{number_of_retries: {RETRIES}, wait_duration: {WAIT}}}\n"
    )
    proc = start_node(domain, params, "patrol_planner_recovery_test.log")
    ros = Ros(domain, context=rclpy.Context())
    robot = Robot(ros)
    # A 6 m x 3 m room (0.1 m cells) with a pillar at x 2.5-3.0 m, y 2-3 m.
    grid = np.zeros((30, 60), dtype=np.int8)
    grid[20:30, 25:30] = 100
    ros.map_pub.publish(grid_msg(grid, (0.0, 0.0), 0.1))
    client = ActionClient(ros.node, NavigateToPose, "navigate_to_pose")
    probe = NavigateToPose.Goal(pose=stamped(*GOAL, frame="nowhere"))
    ros.wait_action_answers(client, probe, "the navigate_to_pose action")

    def planned():
        req = GetPlan.Request(start=stamped(*START), goal=stamped(*GOAL), tolerance=0.0)
        return len(call_service(ros, GetPlan, "/patrol_planner/make_plan", req).plan.poses) > 0

    ros.spin_until(planned, 30, "the node to plan on the room map")
    try:
        yield ros, robot, client
    finally:
        ros.close()
        stop_binary(proc)


def navigate(ros, client, goal, on_feedback, timeout):
    feedback = []

    def seen(f):
        feedback.append(f.feedback)
        on_feedback(f.feedback)

    sent = client.send_goal_async(NavigateToPose.Goal(pose=stamped(*goal)), feedback_callback=seen)
    handle = ros.spin_until(lambda: sent.done() and sent.result(), 30, "the goal's acceptance")
    assert handle.accepted
    result = handle.get_result_async()
    ros.spin_until(result.done, timeout, "the goal's result")
    return result.result(), feedback


def test_a_robot_that_makes_no_progress_is_recovered_then_given_up_on(rig):
    ros, robot, client = rig
    t0 = time.time()
    r, feedback = navigate(ros, client, GOAL, lambda f: None, 60)
    took = time.time() - t0
    assert r.status == GoalStatus.STATUS_ABORTED, r.status
    assert r.result.error_code == 105, (r.result.error_code, r.result.error_msg)
    assert "no progress" in r.result.error_msg, r.result.error_msg
    assert max(f.number_of_recoveries for f in feedback) == RETRIES
    # Three tries of ALLOWANCE s each and two waits, not a drive's whole time limit.
    assert took >= (RETRIES + 1) * ALLOWANCE + RETRIES * WAIT - 0.5, took
    assert took < 30, took
    assert any(c.linear.x != 0.0 or c.angular.z != 0.0 for c in robot.cmds), "the node never drove"
    ros.spin_until(lambda: robot.cmds[-1].linear.x == 0.0 and robot.cmds[-1].angular.z == 0.0, 5, "a stop")

    # Blocked until the first recovery, then free: reached, one recovery reported.
    robot.cmds.clear()

    def free_after_a_recovery(f):
        if f.number_of_recoveries >= 1:
            robot.blocked = False

    r, feedback = navigate(ros, client, GOAL, free_after_a_recovery, 90)
    assert r.status == GoalStatus.STATUS_SUCCEEDED, (r.status, r.result.error_msg)
    assert max(f.number_of_recoveries for f in feedback) == 1
    assert math.hypot(robot.x - GOAL[0], robot.y - GOAL[1]) <= 0.2, (robot.x, robot.y)

    # A goal in the pillar: GOAL_OCCUPIED at once, no recovery tried (each is reported in the
    # feedback, a plan or not, and costs a wait).
    t0 = time.time()
    r, feedback = navigate(ros, client, (2.7, 2.5), lambda f: None, 10)
    assert (r.status, r.result.error_code) == (GoalStatus.STATUS_ABORTED, 206), r.result.error_msg
    assert all(f.number_of_recoveries == 0 for f in feedback)
    assert time.time() - t0 < 3.0

    # A /goal_pose whose robot makes no progress is given up too (no recoveries: no action to
    # report them to): the robot is told to stop, and stays stopped.
    robot.blocked = True
    robot.cmds.clear()
    ros.wait_matched(ros.goal_pub, "/goal_pose")
    ros.goal_pub.publish(stamped(*START))
    ros.spin_until(lambda: any(c.linear.x != 0.0 or c.angular.z != 0.0 for c in robot.cmds), 20, "the node to drive")
    ros.spin_until(lambda: robot.cmds[-1].linear.x == 0.0 and robot.cmds[-1].angular.z == 0.0, ALLOWANCE + 5, "a stop")
    stopped = len(robot.cmds)
    ros.spin_for(1.5)
    assert all(c.linear.x == 0.0 and c.angular.z == 0.0 for c in robot.cmds[stopped:]), "driving again"
