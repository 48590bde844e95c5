"""Self-test of the nav2_msgs interfaces that tests/build_interfaces.sh builds into the venv.

Runs, on a private ROS_DOMAIN_ID (101 unless --domain or NAV2_MSGS_SELFTEST_DOMAIN says
otherwise), in two processes (--one-process: in one), rclpy action servers and clients for
nav2_msgs/action/ComputePathToPose, ComputePathThroughPoses and FollowWaypoints and a service
server and client for nav2_msgs/srv/IsPathValid, called the way Nav2's own clients call them
(nav2_simple_commander's getPath, getPathThroughPoses and followWaypoints; the IsPathValid BT
node). Needs no patrol_planner. Ends with 'N passed, N failed'; exits 1 on any failure.

    .venv/bin/python tests/interfaces/selftest.py
    .venv/bin/python tests/interfaces/selftest.py --one-process
    .venv/bin/python tests/interfaces/selftest.py --layout

--layout also prints, for every type the four interfaces put on the wire: the ROS type name, the
DDS type name rmw_fastrtps registers, its RIHS01 type hash (from the type description JSON that
rosidl installed beside the interface files; rmw_fastrtps announces it in the endpoint's
USER_DATA as "typehash=RIHS01_...;"), the fields in wire order, and the CDR bytes of a sample
message as rclpy serializes it (4-byte encapsulation header 00 01 00 00, CDR little endian;
alignment padding bytes are whatever Fast CDR left in its buffer, not necessarily zero).
"""
import argparse
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path as FsPath

import rclpy
from rclpy.action import ActionClient, ActionServer, GoalResponse
from rclpy.executors import SingleThreadedExecutor
from rclpy.serialization import serialize_message

from action_msgs.msg import GoalStatus
from builtin_interfaces.msg import Duration, Time
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Path
from nav2_msgs.action import ComputePathThroughPoses, ComputePathToPose, FollowWaypoints
from nav2_msgs.msg import MissedWaypoint
from nav2_msgs.srv import IsPathValid
from unique_identifier_msgs.msg import UUID

TIMEOUT = 20.0


def pose(x, y, frame="map"):
    p = PoseStamped()
    p.header.frame_id = frame
    p.pose.position.x = float(x)
    p.pose.position.y = float(y)
    p.pose.orientation.w = 1.0
    return p


def straight_path(a, b, n=5):
    path = Path()
    path.header.frame_id = "map"
    for i in range(n):
        t = i / (n - 1)
        path.poses.append(pose(a.pose.position.x + t * (b.pose.position.x - a.pose.position.x),
                               a.pose.position.y + t * (b.pose.position.y - a.pose.position.y)))
    return path


class Servers:
    """What a planner server offers, with canned answers: a straight line, or NO_VALID_PATH
    when the planner_id is "fail"."""

    def __init__(self, node):
        self.node = node
        self.to_pose = ActionServer(node, ComputePathToPose, "compute_path_to_pose", self.compute_to_pose,
                                    goal_callback=lambda goal: GoalResponse.ACCEPT)
        self.through = ActionServer(node, ComputePathThroughPoses, "compute_path_through_poses", self.compute_through)
        self.waypoints = ActionServer(node, FollowWaypoints, "follow_waypoints", self.follow)
        self.valid = node.create_service(IsPathValid, "is_path_valid", self.is_path_valid)

    def compute_to_pose(self, handle):
        goal = handle.request
        result = ComputePathToPose.Result()
        if goal.planner_id == "fail":
            result.error_code = ComputePathToPose.Result.NO_VALID_PATH
            result.error_msg = "no valid path (selftest)"
            handle.abort()
            return result
        start = goal.start if goal.use_start else pose(0, 0)
        result.path = straight_path(start, goal.goal)
        result.planning_time = Duration(sec=0, nanosec=1_500_000)
        result.error_code = ComputePathToPose.Result.NONE
        handle.succeed()
        return result

    def compute_through(self, handle):
        goal = handle.request
        result = ComputePathThroughPoses.Result()
        if not goal.goals:
            result.error_code = ComputePathThroughPoses.Result.NO_VIAPOINTS_GIVEN
            result.error_msg = "no goals"
            handle.abort()
            return result
        path = Path()
        path.header.frame_id = "map"
        previous = goal.start if goal.use_start else pose(0, 0)
        for g in goal.goals:
            path.poses.extend(straight_path(previous, g).poses)
            previous = g
        result.path = path
        handle.succeed()
        return result

    def follow(self, handle):
        goal = handle.request
        for i in range(len(goal.poses)):
            handle.publish_feedback(FollowWaypoints.Feedback(current_waypoint=i))
        result = FollowWaypoints.Result()
        if goal.poses:
            result.missed_waypoints = [MissedWaypoint(index=len(goal.poses) - 1, goal=goal.poses[-1],
                                                      error_code=FollowWaypoints.Result.TASK_EXECUTOR_FAILED)]
            result.error_code = FollowWaypoints.Result.TASK_EXECUTOR_FAILED
            result.error_msg = "missed the last waypoint (selftest)"
        handle.succeed()
        return result

    def is_path_valid(self, request, response):
        # Invalid wherever a pose has x < 0.
        bad = [i for i, p in enumerate(request.path.poses) if p.pose.position.x < 0]
        response.is_valid = not bad
        response.invalid_pose_indices = bad
        return response


class Checks:
    def __init__(self):
        self.passed = 0
        self.failed = 0

    def check(self, what, ok, detail=""):
        if ok:
            self.passed += 1
            print(f"ok    {what}")
        else:
            self.failed += 1
            print(f"FAIL  {what} {detail}")


def spin_until(executor, future, what):
    deadline = time.monotonic() + TIMEOUT
    while not future.done():
        if time.monotonic() > deadline:
            raise TimeoutError(f"timed out after {TIMEOUT} s waiting for {what}")
        executor.spin_once(timeout_sec=0.05)
    return future.result()


def call_action(executor, client, goal, what, feedback=None, feedback_count=0):
    """Sends `goal` and returns the result. With `feedback_count`, first waits (up to 5 s) for
    that many feedback messages: rclpy's ActionClient drops a goal's feedback once its result
    has been taken, so asking for the result straight away would race with late feedback."""
    if not client.wait_for_server(timeout_sec=TIMEOUT):
        raise TimeoutError(f"no action server for {what}")
    received = []

    def on_feedback(msg):
        received.append(msg)
        if feedback is not None:
            feedback(msg)

    handle = spin_until(executor, client.send_goal_async(goal, feedback_callback=on_feedback), f"{what}: goal response")
    if not handle.accepted:
        raise RuntimeError(f"{what}: goal rejected")
    deadline = time.monotonic() + 5
    while len(received) < feedback_count and time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.05)
    return spin_until(executor, handle.get_result_async(), f"{what}: result")


def serve(domain, parent):
    """The servers alone, until SIGTERM or SIGINT or until `parent` (the pid of the two-process
    run that started this child) is gone."""
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(0))
    rclpy.init(domain_id=domain)
    node = rclpy.create_node("nav2_msgs_selftest_server")
    Servers(node)

    def orphaned():
        if os.getppid() != parent:
            raise SystemExit(0)

    node.create_timer(1.0, orphaned)
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, SystemExit):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


def round_trips(domain, one_process):
    checks = Checks()
    child = None
    if not one_process:
        child = subprocess.Popen([sys.executable, __file__, "--serve", str(os.getpid()), "--domain", str(domain)])
    context = rclpy.Context()
    rclpy.init(domain_id=domain, context=context)
    try:
        executor = SingleThreadedExecutor(context=context)
        client_node = rclpy.create_node("nav2_msgs_selftest_client", context=context)
        executor.add_node(client_node)
        if one_process:
            server_node = rclpy.create_node("nav2_msgs_selftest_server", context=context)
            executor.add_node(server_node)
            Servers(server_node)

        # ComputePathToPose, as nav2_simple_commander's getPath(start, goal, planner_id, use_start).
        to_pose = ActionClient(client_node, ComputePathToPose, "compute_path_to_pose")
        goal = ComputePathToPose.Goal(goal=pose(3, 4), start=pose(1, 1), planner_id="GridBased", use_start=True)
        res = call_action(executor, to_pose, goal, "ComputePathToPose")
        checks.check("ComputePathToPose: SUCCEEDED", res.status == GoalStatus.STATUS_SUCCEEDED, res.status)
        r = res.result
        checks.check("ComputePathToPose: error_code NONE, error_msg empty",
                     r.error_code == ComputePathToPose.Result.NONE and r.error_msg == "", (r.error_code, r.error_msg))
        checks.check("ComputePathToPose: path from start to goal",
                     len(r.path.poses) == 5 and r.path.poses[0].pose.position.x == 1.0
                     and r.path.poses[-1].pose.position.y == 4.0, r.path)
        checks.check("ComputePathToPose: planning_time", r.planning_time.nanosec == 1_500_000, r.planning_time)
        res = call_action(executor, to_pose, ComputePathToPose.Goal(goal=pose(3, 4), planner_id="fail"),
                          "ComputePathToPose (failing)")
        checks.check("ComputePathToPose: ABORTED with NO_VALID_PATH=208 and error_msg",
                     res.status == GoalStatus.STATUS_ABORTED and res.result.error_code == 208
                     and res.result.error_msg == "no valid path (selftest)", (res.status, res.result))

        # ComputePathThroughPoses, as getPathThroughPoses(start, goals, planner_id, use_start).
        through = ActionClient(client_node, ComputePathThroughPoses, "compute_path_through_poses")
        res = call_action(executor, through, ComputePathThroughPoses.Goal(goals=[pose(1, 0), pose(1, 1)]),
                          "ComputePathThroughPoses")
        checks.check("ComputePathThroughPoses: SUCCEEDED with a path through both goals",
                     res.status == GoalStatus.STATUS_SUCCEEDED and len(res.result.path.poses) == 10
                     and res.result.path.poses[-1].pose.position.y == 1.0, (res.status, res.result))
        res = call_action(executor, through, ComputePathThroughPoses.Goal(), "ComputePathThroughPoses (empty)")
        checks.check("ComputePathThroughPoses: NO_VIAPOINTS_GIVEN=309",
                     res.status == GoalStatus.STATUS_ABORTED and res.result.error_code == 309, (res.status, res.result))

        # FollowWaypoints, as followWaypoints(poses), with feedback.
        follow = ActionClient(client_node, FollowWaypoints, "follow_waypoints")
        feedback = []
        res = call_action(executor, follow, FollowWaypoints.Goal(poses=[pose(1, 0), pose(2, 0), pose(3, 0)]),
                          "FollowWaypoints", feedback=lambda msg: feedback.append(msg.feedback.current_waypoint),
                          feedback_count=3)
        r = res.result
        checks.check("FollowWaypoints: result with one MissedWaypoint and TASK_EXECUTOR_FAILED=601",
                     res.status == GoalStatus.STATUS_SUCCEEDED and len(r.missed_waypoints) == 1
                     and r.missed_waypoints[0].index == 2 and r.missed_waypoints[0].goal.pose.position.x == 3.0
                     and r.error_code == 601, (res.status, r))
        checks.check("FollowWaypoints: feedback current_waypoint 0, 1, 2", feedback == [0, 1, 2], feedback)
        checks.check("FollowWaypoints.Goal defaults: number_of_loops 0, goal_index 0",
                     FollowWaypoints.Goal().number_of_loops == 0 and FollowWaypoints.Goal().goal_index == 0)

        # IsPathValid, as Nav2's IsPathValid BT condition calls it.
        valid = client_node.create_client(IsPathValid, "is_path_valid")
        if not valid.wait_for_service(timeout_sec=TIMEOUT):
            raise TimeoutError("no IsPathValid service")
        request = IsPathValid.Request(path=straight_path(pose(-1, 0), pose(3, 0)))
        response = spin_until(executor, valid.call_async(request), "IsPathValid")
        checks.check("IsPathValid: is_valid false, invalid_pose_indices [0]",
                     response.is_valid is False and list(response.invalid_pose_indices) == [0], response)
        request = IsPathValid.Request(path=straight_path(pose(0, 0), pose(3, 0)))
        response = spin_until(executor, valid.call_async(request), "IsPathValid")
        checks.check("IsPathValid: is_valid true, no indices",
                     response.is_valid is True and len(response.invalid_pose_indices) == 0, response)
        executor.shutdown()
    finally:
        rclpy.shutdown(context=context)
        if child is not None:
            child.terminate()
            try:
                child.wait(timeout=10)
            except subprocess.TimeoutExpired:
                child.kill()
                child.wait()
    return checks


def dds_type_name(msg_class):
    """rmw_fastrtps's DDS type name: <package>::<msg|srv|action>::dds_::<Type>_."""
    package, kind = msg_class.__module__.split(".")[:2]
    return f"{package}::{kind}::dds_::{msg_class.__name__}_"


def fields(msg_class):
    out = []
    for name, kind in msg_class.get_fields_and_field_types().items():
        out.append(f"{name}: {kind}")
    return out or ["(no fields: rosidl adds 'uint8 structure_needs_at_least_one_member', 1 byte on the wire)"]


def layout():
    # build_interfaces.sh installs into the venv's prefix (no AMENT_PREFIX_PATH is set there).
    share = FsPath(sys.prefix) / "share" / "nav2_msgs"
    hashes = {}
    for f in sorted(share.glob("*/*.json")):
        for entry in json.loads(f.read_text())["type_hashes"]:
            hashes[entry["type_name"]] = entry["hash_string"]

    def show(msg_class, sample=None):
        package, kind = msg_class.__module__.split(".")[:2]
        ros_name = f"{package}/{kind}/{msg_class.__name__}"
        print(f"\n{ros_name}")
        print(f"  DDS type  {dds_type_name(msg_class)}")
        print(f"  hash      {hashes.get(ros_name, '(not a nav2_msgs type: see its own package)')}")
        for line in fields(msg_class):
            print(f"  field     {line}")
        if sample is not None:
            print(f"  CDR       {serialize_message(sample).hex(' ')}")

    uuid = UUID(uuid=list(range(1, 17)))
    # Samples with recognisable values for ComputePathToPose; the other types are shown empty.
    samples = {
        ComputePathToPose: (
            ComputePathToPose.Goal(goal=pose(1.5, -2), planner_id="GridBased", use_start=False),
            ComputePathToPose.Result(path=straight_path(pose(0, 0), pose(1, 1), n=2),
                                     planning_time=Duration(sec=1, nanosec=2), error_code=208, error_msg="x")),
    }
    print("Topic and service names for an action at /compute_path_to_pose (DDS topic names):")
    for suffix in ("rq/compute_path_to_pose/_action/send_goalRequest", "rr/compute_path_to_pose/_action/send_goalReply",
                   "rq/compute_path_to_pose/_action/get_resultRequest",
                   "rr/compute_path_to_pose/_action/get_resultReply",
                   "rq/compute_path_to_pose/_action/cancel_goalRequest",
                   "rr/compute_path_to_pose/_action/cancel_goalReply",
                   "rt/compute_path_to_pose/_action/feedback", "rt/compute_path_to_pose/_action/status"):
        print(f"  {suffix}")
    for action in (ComputePathToPose, ComputePathThroughPoses, FollowWaypoints):
        print(f"\n=== {action.__module__.split('.')[0]}/action/{action.__name__}"
              f"  {hashes[f'nav2_msgs/action/{action.__name__}']}")
        goal, result = samples.get(action, (action.Goal(), action.Result()))
        show(action.Impl.SendGoalService.Request, action.Impl.SendGoalService.Request(goal_id=uuid, goal=goal))
        show(action.Impl.SendGoalService.Response, action.Impl.SendGoalService.Response(
            accepted=True, stamp=Time(sec=1700000000, nanosec=5)))
        show(action.Impl.GetResultService.Request, action.Impl.GetResultService.Request(goal_id=uuid))
        show(action.Impl.GetResultService.Response,
             action.Impl.GetResultService.Response(status=GoalStatus.STATUS_ABORTED, result=result))
        show(action.Impl.FeedbackMessage, action.Impl.FeedbackMessage(goal_id=uuid))
        show(action.Goal)
        show(action.Result)
        show(action.Feedback, action.Feedback())
    print(f"\n=== nav2_msgs/srv/IsPathValid  {hashes['nav2_msgs/srv/IsPathValid']}")
    show(IsPathValid.Request, IsPathValid.Request())
    show(IsPathValid.Response, IsPathValid.Response(is_valid=False, invalid_pose_indices=[3, 4]))
    show(MissedWaypoint)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--domain", type=int, default=int(os.environ.get("NAV2_MSGS_SELFTEST_DOMAIN", "101")))
    parser.add_argument("--layout", action="store_true", help="also print type names, hashes and wire layouts")
    parser.add_argument("--one-process", action="store_true",
                        help="servers and clients in this process (default: the servers run in a child process)")
    parser.add_argument("--serve", type=int, metavar="PARENT_PID", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.serve:
        return serve(args.domain, args.serve)
    started = time.monotonic()
    checks = round_trips(args.domain, args.one_process)
    if args.layout:
        layout()
    mode = "one process" if args.one_process else "two processes"
    print(f"\nnav2_msgs selftest on ROS_DOMAIN_ID {args.domain} ({mode}), {time.monotonic() - started:.1f} s")
    print(f"{checks.passed} passed, {checks.failed} failed")
    return 1 if checks.failed else 0


if __name__ == "__main__":
    sys.exit(main())
