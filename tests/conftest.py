"""Fixtures for the rclpy integration tests: the real patrol_planner binary on its own
ROS_DOMAIN_ID, and an rclpy node that talks to it the way a ROS 2 user's stack would. Tests wait
for discovery and answers, never for fixed sleeps."""
import contextlib
import functools
import math
import os
import signal
import subprocess
import time
from pathlib import Path

import pytest
import rclpy
import rclpy.executors
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped, PoseWithCovarianceStamped
from nav_msgs.msg import OccupancyGrid, Path as PathMsg

ROOT = Path(__file__).resolve().parent.parent
# The binaries under test: the release build (`cargo build --release`), or the directory
# PATROL_BIN_DIR names (scripts/test-all: target/debug, the optimised builds `cargo test` made
# with debug assertions and overflow checks on).
BIN_DIR = Path(os.environ.get("PATROL_BIN_DIR") or ROOT / "target" / "release")
BINARY = BIN_DIR / "patrol_planner"
LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL, reliability=ReliabilityPolicy.RELIABLE)


def _domains_in_use():
    """The ROS_DOMAIN_IDs in other running processes' environments (a soak, another test run)."""
    used = set()
    for environ in Path("/proc").glob("[0-9]*/environ"):
        if environ.parent.name == str(os.getpid()):
            continue
        try:
            for item in environ.read_bytes().split(b"\0"):
                if item.startswith(b"ROS_DOMAIN_ID="):
                    used.add(int(item.split(b"=", 1)[1] or 0))
        except (OSError, ValueError):
            pass
    return used


# The domains handed out in this process, so that two offsets never share one.
_handed_out = set()


@functools.lru_cache(maxsize=None)
def domain_id(offset=0):
    """One domain per test run; a test module that starts binaries of its own uses `offset` to
    keep them apart from the `ros` fixture's node, and no two offsets get the same domain.

    Only domains 1-101: a domain's DDS ports are 7400 + 250 x domain and up, and from domain 102
    they fall inside Linux's ephemeral port range (32768-60999), where any process's outgoing
    socket can take a participant's port (the ROS 2 documentation's "Domain ID" concept page
    says so; 0 is everyone's default). TEST_DOMAIN_BASE and TEST_DOMAIN_SPAN (default 1 and 90:
    domains 1-90) give a pytest run that goes beside another one a range of its own
    (scripts/test-all runs test_patrol.py on 91-101); pytest-xdist's workers share the range out
    (two: 1-45 and 46-90). A domain another process on this machine already uses (a soak, a
    second test run) is skipped; the answer is kept for the run, so a module asking again gets
    the same."""
    base = int(os.environ.get("TEST_DOMAIN_BASE", "1"))
    span = int(os.environ.get("TEST_DOMAIN_SPAN", "90"))
    # pytest-xdist's workers (gw0, gw1, ...) split the range, each its own part of it.
    worker = os.environ.get("PYTEST_XDIST_WORKER", "")
    workers = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
    if worker.startswith("gw") and workers > 1:
        span //= workers
        base += int(worker[2:]) * span
    used = _domains_in_use() | _handed_out
    candidates = [base + (os.getpid() + offset + k) % span for k in range(span)]
    domain = next((d for d in candidates if d not in used), None)
    if domain is None:
        domain = next((d for d in candidates if d not in _handed_out), None)
    if domain is None:
        raise RuntimeError(f"every domain of {base}-{base + span - 1} is taken by this test run")
    _handed_out.add(domain)
    return domain


class Ros:
    """An rclpy node with the subscriptions, publishers and clients the tests use."""

    def __init__(self, domain, context=None):
        # The `ros` fixture's node uses rclpy's default context; a test that needs a second domain
        # passes its own context.
        self.context = context
        if context is None:
            rclpy.init(domain_id=domain)
        else:
            rclpy.init(domain_id=domain, context=context)
        self.executor = rclpy.executors.SingleThreadedExecutor(context=context)
        self.node = rclpy.create_node(f"patrol_planner_test_{os.getpid()}", context=context)
        self.executor.add_node(self.node)
        self.plans, self.diagnostics, self.maps = [], [], []
        self.plan_sub = self.node.create_subscription(PathMsg, "/plan", self.plans.append, LATCHED)
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self.diagnostics.append, 50)
        self.map_pub = self.node.create_publisher(OccupancyGrid, "/map", LATCHED)
        self.goal_pub = self.node.create_publisher(PoseStamped, "/goal_pose", 10)
        self.initial_pub = self.node.create_publisher(PoseWithCovarianceStamped, "/initialpose", 10)

    def spin_until(self, predicate, timeout, what):
        deadline = time.time() + timeout
        while time.time() < deadline:
            self.executor.spin_once(timeout_sec=0.05)
            value = predicate()
            if value:
                return value
        raise AssertionError(f"timed out after {timeout} s waiting for {what}")

    def wait_matched(self, publisher, what):
        self.spin_until(lambda: publisher.get_subscription_count() > 0, 20, f"the node to subscribe {what}")

    def diagnostics_since(self, index):
        """(result code, message, values) of every status that arrived after `index`."""
        out = []
        for array in self.diagnostics[index:]:
            for st in array.status:
                values = {kv.key: kv.value for kv in st.values}
                out.append((values.get("result"), st.message, values))
        return out

    def wait_code(self, index, code, timeout=20):
        return self.spin_until(
            lambda: next((d for d in self.diagnostics_since(index) if d[0] == code), None), timeout, f"result {code} on /diagnostics"
        )

    def send_goal_until_planned(self, goal, timeout=45):
        """Publishes the PoseStamped `goal` once a second until a non-empty /plan answers (a goal
        that overtakes the node's map or odometry on the wire gets an error: ask again). Both
        directions are matched first: RustDDS announces its participants every 10 s, so one lost
        discovery exchange under load delays a match by 10-20 s (tests/test_replan.py once timed out
        after 30 s while the node planned every second and no /plan arrived)."""
        self.wait_matched(self.goal_pub, "/goal_pose")
        self.spin_until(lambda: self.plan_sub.get_publisher_count() > 0, 45, "the node's /plan to match")

        def planned():
            before = len(self.plans)
            self.goal_pub.publish(goal)
            self.spin_for(1.0)
            return any(p.poses for p in self.plans[before:])

        self.spin_until(planned, timeout, "a plan to the goal")

    def wait_action_answers(self, client, probe, what, timeout=45):
        """Waits until `client`'s goals are answered: sends the goal `probe` (one the node
        accepts and aborts at once without touching the robot) until its acceptance arrives, then
        waits for its result. `server_is_ready` says the client's requests reach the server, not that the
        server's replies reach the client: a goal sent in between is run by the node, but its
        acceptance is lost and the client waits for ever (seen 2 of 7 runs of test_navigate)."""
        deadline = time.time() + timeout
        self.spin_until(lambda: client.server_is_ready(), timeout, what)
        while time.time() < deadline:
            sent = client.send_goal_async(probe)
            asked = time.time()
            while not sent.done() and time.time() - asked < 3.0:
                self.executor.spin_once(timeout_sec=0.05)
            if not sent.done():
                continue  # its acceptance was lost: ask again
            handle = sent.result()
            # A rejected probe means the node refuses goals (not active, busy): every goal the
            # test sends next would be refused too, so say so here.
            assert handle.accepted, f"{what} rejected the probe goal: the node refuses goals"
            result = handle.get_result_async()
            self.spin_until(result.done, 30, f"{what}: the probe goal's result")
            return
        raise AssertionError(f"timed out after {timeout} s waiting for {what} to answer a goal")

    def spin_for(self, seconds):
        deadline = time.time() + seconds
        while time.time() < deadline:
            self.executor.spin_once(timeout_sec=0.05)

    def close(self):
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.shutdown(context=self.context)


def call_service(ros, srv_type, name, request, timeout=20):
    """One call of the service `name` with a fresh rclpy client, as `ros2 service call` makes it."""
    client = ros.node.create_client(srv_type, name)
    try:
        ros.spin_until(lambda: client.service_is_ready(), 20, f"the service {name}")
        future = client.call_async(request)
        ros.spin_until(future.done, timeout, f"the answer of {name}")
        return future.result()
    finally:
        ros.node.destroy_client(client)


BRIDGE = BIN_DIR / "chassis_bridge"


def start_binary(binary, domain, params_file, log_name, rust_log, ros_args=()):
    """A real binary (BIN_DIR) on `domain`, its output in target/`log_name`; `ros_args` go after
    `--ros-args` (remaps such as `-r __node:=planner_server`)."""
    assert binary.exists(), f"{binary} is missing: build it with `cargo build --release` (or set PATROL_BIN_DIR)"
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), RUST_LOG=rust_log)
    log = open(ROOT / "target" / log_name, "w")
    args = [str(binary), "--params-file", str(params_file)]
    if ros_args:
        args += ["--ros-args", *ros_args]
    proc = subprocess.Popen(args, env=env, stdout=log, stderr=log)
    proc.log = log
    return proc


def stop_binary(proc):
    """Ctrl-C, as a user would; the binary must exit cleanly and soon. On failure the message
    carries the end of its log, so that a CI report says why."""
    name = Path(proc.args[0]).name
    proc.send_signal(signal.SIGINT)
    try:
        code = proc.wait(timeout=15)
        problem = None if code == 0 else f"{name} exited with {code}"
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
        problem = f"{name} did not stop within 15 s of Ctrl-C"
    finally:
        proc.log.close()
    if problem:
        tail = "\n".join(Path(proc.log.name).read_text(errors="replace").splitlines()[-15:])
        raise AssertionError(f"{problem}; the end of {proc.log.name}:\n{tail}")


def start_node(domain, params_file, log_name, ros_args=()):
    """The real patrol_planner on `domain`, its output in target/`log_name`."""
    return start_binary(BINARY, domain, params_file, log_name, "patrol_planner=info,warn", ros_args)


def start_bridge(domain, params_file, log_name, rust_log="chassis_bridge=info,warn", ros_args=()):
    """The real chassis_bridge on `domain`, its output in target/`log_name`; `ros_args` as
    `start_binary` takes them."""
    return start_binary(BRIDGE, domain, params_file, log_name, rust_log, ros_args)


@contextlib.contextmanager
def node_rig(offset, node_params, name):
    """The real node alone on a domain of its own (`offset`, as `domain_id` takes it), its
    output in target/patrol_planner_`name`_test.log, and a client beside it; both stopped
    afterwards."""
    domain = domain_id(offset)
    node = start_node(domain, node_params, f"patrol_planner_{name}_test.log")
    ros = Ros(domain, context=rclpy.Context())
    try:
        yield ros
    finally:
        ros.close()
        stop_binary(node)


@contextlib.contextmanager
def driving_rig(offset, node_params, bridge_params, name, bridge_args=()):
    """The real node and chassis_bridge (the simulated car) on a domain of their own (`offset`,
    as `domain_id` takes it; the bridge's `bridge_args` after `--ros-args`), their output in
    target/patrol_planner_`name`_test.log and target/chassis_bridge_`name`_test.log, and a
    client beside them; all stopped afterwards."""
    domain = domain_id(offset)
    node = start_node(domain, node_params, f"patrol_planner_{name}_test.log")
    try:
        bridge = start_bridge(domain, bridge_params, f"chassis_bridge_{name}_test.log", ros_args=bridge_args)
    except BaseException:
        stop_binary(node)
        raise
    ros = Ros(domain, context=rclpy.Context())
    try:
        yield ros
    finally:
        ros.close()
        try:
            stop_binary(bridge)
        finally:
            stop_binary(node)


# A node of its own for each test file that uses it, so that no file depends on what another did
# to it before (the test files run in any order on pytest-xdist's two workers: scripts/test-all),
# and test_node's first tests see the node as it starts (its bundled map, no start pose yet).
@pytest.fixture(scope="module")
def ros():
    domain = domain_id()
    proc = start_node(domain, ROOT / "config" / "planner.yaml", "patrol_planner_test.log")
    r = Ros(domain)
    try:
        yield r
    finally:
        r.close()
        stop_binary(proc)


def stamped(x, y, yaw=0.0, frame="map"):
    p = PoseStamped()
    p.header.frame_id = frame
    p.pose.position.x, p.pose.position.y = float(x), float(y)
    p.pose.orientation.z, p.pose.orientation.w = math.sin(yaw / 2), math.cos(yaw / 2)
    return p


def yaw_quaternion(yaw):
    """The (x, y, z, w) of a turn by `yaw` about z."""
    return 0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)


def transform(parent, child, xyz=(0.0, 0.0, 0.0), q=(0.0, 0.0, 0.0, 1.0), stamp=0.0):
    """geometry_msgs/TransformStamped `parent` -> `child`: translation `xyz`, rotation `q`
    (x, y, z, w), `stamp` in seconds or a builtin_interfaces/Time."""
    from geometry_msgs.msg import TransformStamped

    t = TransformStamped()
    t.header.frame_id, t.child_frame_id = parent, child
    if isinstance(stamp, (int, float)):
        t.header.stamp.sec, t.header.stamp.nanosec = int(stamp), int(round((stamp % 1) * 1e9))
    else:
        t.header.stamp = stamp
    (t.transform.translation.x, t.transform.translation.y, t.transform.translation.z) = map(float, xyz)
    (t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z, t.transform.rotation.w) = q
    return t


# tf2's listener QoS: /tf reliable and volatile, /tf_static reliable and transient local.
TF = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
TF_STATIC = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)


def static_transforms(ros, *transforms):
    """Latches `transforms` on /tf_static, as a static broadcaster does, once the node reads
    it; the test node keeps the publisher, and so the transforms, until it is destroyed or
    destroys it (the returned publisher)."""
    from tf2_msgs.msg import TFMessage

    pub = ros.node.create_publisher(TFMessage, "/tf_static", TF_STATIC)
    ros.wait_matched(pub, "/tf_static")
    pub.publish(TFMessage(transforms=list(transforms)))
    return pub


def initial_pose(x, y, frame="map"):
    p = PoseWithCovarianceStamped()
    p.header.frame_id = frame
    p.pose.pose.position.x, p.pose.pose.position.y = float(x), float(y)
    p.pose.pose.orientation.w = 1.0
    return p
