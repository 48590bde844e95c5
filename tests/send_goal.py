"""Send goals to a running patrol_planner and print each plan, as a ROS 2 user would from rclpy:

    .venv/bin/python tests/send_goal.py --start 0.1 0.1 --goal 19.9 19.9
    .venv/bin/python tests/send_goal.py --start 0.1 0.1 --goal 19.9 19.9 --repeat 20   # latency
    .venv/bin/python tests/send_goal.py --start 0.1 0.1 --goal 19.9 19.9 --repeat 20 --service
    .venv/bin/python tests/send_goal.py --start 0.1 0.1 --goal 19.9 19.9 --repeat 30 --service --fresh
    .venv/bin/python tests/send_goal.py --start 0.1 0.1 --goal 19.9 19.9 --repeat 20 --action
    .venv/bin/python tests/send_goal.py --route config/routes/datacenter_patrol.yaml --loops 1

It publishes the start (if given) on /initialpose, the goal on /goal_pose (what RViz's 2D Goal Pose sends)
and waits for /plan and /diagnostics; with --service it asks /patrol_planner/make_plan (GetPlan)
instead and times the call; --fresh makes a new client for every call, as each `ros2 service
call` does, so discovery is part of the time; --action sends Nav2's ComputePathToPose (as
nav2_simple_commander's getPath does; needs nav2_msgs from tests/build_interfaces.sh) and times
goal -> result; --route sends a route file's points to Nav2's FollowWaypoints action (the node
orders, drives, pauses and loops; it prints each waypoint as it is driven to and the missed ones).
Use the node's ROS_DOMAIN_ID."""
import argparse
import statistics
import time

import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped, PoseWithCovarianceStamped
from nav_msgs.msg import Path
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy


def ok(status):
    # rclpy gives a `byte` field back as bytes.
    level = status.level[0] if isinstance(status.level, bytes) else status.level
    return level == 0


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--start", nargs=2, type=float, metavar=("X", "Y"),
                    help="publish this start on /initialpose first (leave it out when /odom or AMCL already tells the node where the robot is)")
    ap.add_argument("--goal", nargs=2, type=float, metavar=("X", "Y"))
    ap.add_argument("--route", help="a route file (config/routes/*.yaml): drive its points with follow_waypoints")
    ap.add_argument("--loops", type=int, default=0, help="with --route: passes after the first")
    ap.add_argument("--repeat", type=int, default=1, help="send the goal this many times and report the median latency")
    ap.add_argument("--service", action="store_true", help="call /patrol_planner/make_plan instead of publishing goals")
    ap.add_argument("--fresh", action="store_true", help="with --service: a new client for every call")
    ap.add_argument("--action", action="store_true", help="send Nav2's ComputePathToPose instead of publishing goals")
    args = ap.parse_args()
    if (args.goal is None) == (args.route is None):
        ap.error("give --goal or --route")
    rclpy.init()
    node = rclpy.create_node("send_goal")
    if args.route:
        follow_route(node, args)
        node.destroy_node()
        rclpy.shutdown()
        return
    if args.action:
        call_action(node, args)
        node.destroy_node()
        rclpy.shutdown()
        return
    if args.service:
        call_service(node, args)
        node.destroy_node()
        rclpy.shutdown()
        return
    latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL, reliability=ReliabilityPolicy.RELIABLE)
    plans, diags = [], []
    node.create_subscription(Path, "/plan", lambda m: plans.append((time.monotonic(), m)), latched)
    node.create_subscription(DiagnosticArray, "/diagnostics", diags.append, 10)
    start_pub = node.create_publisher(PoseWithCovarianceStamped, "/initialpose", 10)
    goal_pub = node.create_publisher(PoseStamped, "/goal_pose", 10)
    t0 = time.monotonic()
    while (goal_pub.get_subscription_count() == 0 or start_pub.get_subscription_count() == 0) and time.monotonic() - t0 < 20:
        rclpy.spin_once(node, timeout_sec=0.1)
    if goal_pub.get_subscription_count() == 0:
        raise SystemExit("no patrol_planner found (same ROS_DOMAIN_ID?)")
    # Our side sees the node's subscriptions before the node has matched our publishers: give
    # discovery a moment to settle both ways.
    settle = time.monotonic()
    while time.monotonic() - settle < 1.0:
        rclpy.spin_once(node, timeout_sec=0.05)
    if args.start is not None:
        publish_start(node, start_pub, args.start)
    send_goals(node, goal_pub, plans, diags, args)
    node.destroy_node()
    rclpy.shutdown()


def publish_start(node, start_pub, xy):
    start = PoseWithCovarianceStamped()
    start.header.frame_id = "map"
    start.pose.pose.position.x, start.pose.pose.position.y = xy
    start.pose.pose.orientation.w = 1.0
    # Twice, to be safe.
    for _ in range(2):
        start_pub.publish(start)
        for _ in range(4):
            rclpy.spin_once(node, timeout_sec=0.05)


def send_goals(node, goal_pub, plans, diags, args):
    latencies = []
    for _ in range(args.repeat):
        before_plans, before_diags = len(plans), len(diags)
        goal = PoseStamped()
        goal.header.frame_id = "map"
        goal.pose.position.x, goal.pose.position.y = args.goal
        goal.pose.orientation.w = 1.0
        sent = time.monotonic()
        goal_pub.publish(goal)
        while len(diags) == before_diags and time.monotonic() - sent < 30:
            rclpy.spin_once(node, timeout_sec=0.01)
        while len(plans) == before_plans and time.monotonic() - sent < 2 and diags and ok(diags[-1].status[0]):
            rclpy.spin_once(node, timeout_sec=0.01)
        status = diags[-1].status[0] if len(diags) > before_diags else None
        if status is None or not ok(status):
            print("failed:", status and status.message)
            continue
        received, path = plans[-1]
        latencies.append(received - sent)
        values = {kv.key: kv.value for kv in status.values}
        if args.repeat == 1:
            print(f"{values['planner']}: {len(path.poses)} poses, {values['length_m']} m, {values['turning_rad']} rad, "
                  f"seed {values['seed']}, {1e3 * (received - sent):.1f} ms from goal to /plan")
            for p in path.poses[:: max(1, len(path.poses) // 10)]:
                print(f"  ({p.pose.position.x:.2f}, {p.pose.position.y:.2f})")
    if args.repeat > 1 and latencies:
        print(f"goal -> /plan latency over {len(latencies)} goals: median {1e3 * statistics.median(latencies):.1f} ms, "
              f"max {1e3 * max(latencies):.1f} ms")


def call_service(node, args):
    from nav_msgs.srv import GetPlan

    def new_client():
        client = node.create_client(GetPlan, "/patrol_planner/make_plan")
        if not client.wait_for_service(timeout_sec=20):
            raise SystemExit("no /patrol_planner/make_plan (same ROS_DOMAIN_ID?)")
        return client

    client = new_client()
    req = GetPlan.Request()
    for pose, xy in [(req.start, args.start), (req.goal, args.goal)]:
        pose.pose.orientation.w = 1.0
        if xy is not None:  # a start with an empty frame means "from the current pose"
            pose.header.frame_id = "map"
            pose.pose.position.x, pose.pose.position.y = xy
    latencies = []
    for _ in range(args.repeat):
        if args.fresh:
            node.destroy_client(client)
            client = new_client()
        sent = time.monotonic()
        future = client.call_async(req)
        rclpy.spin_until_future_complete(node, future, timeout_sec=30)
        if not future.done():
            print("no answer within 30 s")
            continue
        latencies.append(time.monotonic() - sent)
        plan = future.result().plan
        if args.repeat == 1:
            print(f"make_plan: {len(plan.poses)} poses in {1e3 * latencies[-1]:.1f} ms" + ("" if plan.poses else " (empty: see /diagnostics)"))
    if args.repeat > 1 and latencies:
        print(f"GetPlan round trip over {len(latencies)} calls: median {1e3 * statistics.median(latencies):.1f} ms, "
              f"max {1e3 * max(latencies):.1f} ms")


def call_action(node, args):
    from nav2_msgs.action import ComputePathToPose
    from rclpy.action import ActionClient

    client = ActionClient(node, ComputePathToPose, "compute_path_to_pose")
    if not client.wait_for_server(timeout_sec=20):
        raise SystemExit("no compute_path_to_pose action (same ROS_DOMAIN_ID?)")
    goal = ComputePathToPose.Goal()
    goal.goal.header.frame_id = "map"
    goal.goal.pose.position.x, goal.goal.pose.position.y = args.goal
    goal.goal.pose.orientation.w = 1.0
    if args.start is not None:
        goal.use_start = True
        goal.start.header.frame_id = "map"
        goal.start.pose.position.x, goal.start.pose.position.y = args.start
        goal.start.pose.orientation.w = 1.0
    latencies = []
    for _ in range(args.repeat):
        sent = time.monotonic()
        accepted = client.send_goal_async(goal)
        rclpy.spin_until_future_complete(node, accepted, timeout_sec=30)
        handle = accepted.result()
        if handle is None or not handle.accepted:
            print("goal rejected")
            continue
        result = handle.get_result_async()
        rclpy.spin_until_future_complete(node, result, timeout_sec=30)
        if not result.done():
            print("no result within 30 s")
            continue
        latencies.append(time.monotonic() - sent)
        r = result.result().result
        if args.repeat == 1:
            print(f"compute_path_to_pose: {len(r.path.poses)} poses, error_code {r.error_code} {r.error_msg!r}, "
                  f"{1e3 * latencies[-1]:.1f} ms")
    if args.repeat > 1 and latencies:
        print(f"ComputePathToPose goal -> result over {len(latencies)} goals: median {1e3 * statistics.median(latencies):.1f} ms, "
              f"max {1e3 * max(latencies):.1f} ms")


def follow_route(node, args):
    import math

    import yaml
    from nav2_msgs.action import FollowWaypoints
    from rclpy.action import ActionClient

    route = yaml.safe_load(open(args.route))
    client = ActionClient(node, FollowWaypoints, "follow_waypoints")
    if not client.wait_for_server(timeout_sec=20):
        raise SystemExit("no follow_waypoints action (same ROS_DOMAIN_ID?)")
    goal = FollowWaypoints.Goal()
    goal.number_of_loops = args.loops
    names = [p["name"] for p in route["points"]]
    for p in route["points"]:
        pose = PoseStamped()
        pose.header.frame_id = "map"
        pose.pose.position.x, pose.pose.position.y = float(p["x"]), float(p["y"])
        pose.pose.orientation.z, pose.pose.orientation.w = math.sin(p["yaw"] / 2), math.cos(p["yaw"] / 2)
        goal.poses.append(pose)
    started = time.monotonic()

    def feedback(msg):
        i = msg.feedback.current_waypoint
        print(f"{time.monotonic() - started:7.1f} s  driving to {names[i]}")

    accepted = client.send_goal_async(goal, feedback_callback=feedback)
    rclpy.spin_until_future_complete(node, accepted, timeout_sec=30)
    handle = accepted.result()
    if handle is None or not handle.accepted:
        raise SystemExit("the patrol was rejected (is the node active?)")
    result = handle.get_result_async()
    rclpy.spin_until_future_complete(node, result)
    r = result.result().result
    missed = [f"{names[m.index]} ({m.error_code})" for m in r.missed_waypoints]
    print(f"patrol done in {time.monotonic() - started:.1f} s; missed: {', '.join(missed) or 'none'}")


if __name__ == "__main__":
    main()
