"""The patrol car paper's Table 5 "total time": how long the simulated car takes to drive from
the start to the goal along each planner's path. Starts its own node (with the planner given)
and chassis_bridge on a private ROS_DOMAIN_ID; needs the release binaries.

    .venv/bin/python tests/drive_time.py --planners mocmcso,astar --goal 19.9 19.9
"""
import argparse
import math
import os
import signal
import subprocess
import tempfile
import time
from pathlib import Path

import rclpy
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Odometry, Path as PathMsg
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

ROOT = Path(__file__).resolve().parent.parent


def drive(planner, goal, domain):
    cfg = (ROOT / "config" / "planner.yaml").read_text().replace("    planner: mocmcso", f"    planner: {planner}")
    params = Path(tempfile.mkdtemp()) / "planner.yaml"
    params.write_text(cfg.replace("map_yaml: maps/", f"map_yaml: {ROOT}/config/maps/"))
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), RUST_LOG="warn")
    procs = [
        subprocess.Popen([str(ROOT / "target/release/chassis_bridge"), "--params-file", str(ROOT / "config/chassis.yaml")], env=env, stderr=subprocess.DEVNULL),
        subprocess.Popen([str(ROOT / "target/release/patrol_planner"), "--params-file", str(params)], env=env, stderr=subprocess.DEVNULL),
    ]
    ctx = rclpy.Context()
    rclpy.init(context=ctx, domain_id=domain)
    node = rclpy.create_node("drive_time", context=ctx)
    ex = rclpy.executors.SingleThreadedExecutor(context=ctx)
    ex.add_node(node)
    odom, plans = [], []
    latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL, reliability=ReliabilityPolicy.RELIABLE)
    node.create_subscription(Odometry, "/odom", odom.append, 10)
    node.create_subscription(PathMsg, "/plan", plans.append, latched)
    pub = node.create_publisher(PoseStamped, "/goal_pose", 10)
    t0 = time.time()
    while (pub.get_subscription_count() == 0 or len(odom) < 20) and time.time() - t0 < 20:
        ex.spin_once(timeout_sec=0.05)
    for _ in range(20):
        ex.spin_once(timeout_sec=0.05)
    g = PoseStamped()
    g.header.frame_id = "map"
    g.pose.position.x, g.pose.position.y = goal
    g.pose.orientation.w = 1.0
    # Until the node has heard /odom itself it answers NO_START_POSE: ask until a plan comes.
    first = time.time()
    while not plans and time.time() - first < 30:
        sent = time.time()  # the driving time counts from the goal that was planned
        pub.publish(g)
        deadline = time.time() + 2
        while not plans and time.time() < deadline:
            ex.spin_once(timeout_sec=0.05)
    result = None
    while time.time() - sent < 300:
        ex.spin_once(timeout_sec=0.05)
        if plans and odom:
            p = odom[-1].pose.pose.position
            v = odom[-1].twist.twist
            if math.hypot(p.x - goal[0], p.y - goal[1]) <= 0.15 and abs(v.linear.x) < 1e-3 and abs(v.angular.z) < 1e-3:
                path = plans[-1].poses
                length = sum(math.hypot(b.pose.position.x - a.pose.position.x, b.pose.position.y - a.pose.position.y) for a, b in zip(path, path[1:]))
                result = (time.time() - sent, length)
                break
    node.destroy_node()
    rclpy.shutdown(context=ctx)
    for proc in procs:
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=15)
    return result


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--planners", default="mocmcso,astar")
    ap.add_argument("--goal", nargs=2, type=float, default=[19.9, 19.9])
    args = ap.parse_args()
    for k, planner in enumerate(args.planners.split(",")):
        # Domains 1-101 only: above them the DDS ports fall in the ephemeral range (conftest.domain_id).
        r = drive(planner, tuple(args.goal), 1 + (os.getpid() + k) % 101)
        print(f"{planner}: " + (f"path {r[1]:.2f} m, driven in {r[0]:.1f} s" if r else "did not arrive within 300 s"))


if __name__ == "__main__":
    main()
