"""Fault injection (issue 16): every class of bad input the node can meet, each answered with its
result code (on /diagnostics, the GetPlan reply, an action's result or a refused parameter)
within about a second (10 s for the large-map classes), and the node still serving a good
request afterwards. One node of this module's own runs with the bundled map (`map_yaml`), astar,
no following; a second one with no map answers NO_MAP and NO_START_POSE. Each class prints one
line (`pytest -s`) and the last test asserts that every class passed, naming the ones that did
not; it also checks that both nodes are alive and stop cleanly on Ctrl-C."""
import array
import math
import random
import time

import numpy as np
import pytest
import rclpy
from rclpy.action import ActionClient
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from geometry_msgs.msg import PoseStamped
from nav2_msgs.action import ComputePathToPose
from nav_msgs.srv import GetPlan
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
from rcl_interfaces.srv import GetParameters, SetParameters

from conftest import ROOT, Ros, domain_id, initial_pose, stamped, start_node, stop_binary
from test_node import build_test_map, grid_msg, world
from test_vehicle import bundled_map

QUICK = 1.5  # s: "within about a second", with some slack for a loaded 2-core CI machine
BIG = 10.0  # s: the large-map classes (a 16 MB map over DDS, inflated, then planned on)
RES = 0.2  # the bundled map's resolution
CABINET = (3.2, 2.5)  # the middle of a cabinet on the bundled map: deep inside an obstacle
HOME, AWAY = (1.1, 1.1), (8.1, 6.9)  # free cells on the bundled map (datacenter_100.scen.yaml)
MAKE_PLAN = "/patrol_planner/make_plan"

PARAMS = (
    "patrol_planner:\n  ros__parameters:\n"
    f"    map_yaml: {ROOT / 'config' / 'maps' / 'datacenter_100.yaml'}\n"
    "    follow_plan: false\n    planner: astar\n    tolerance: 0.0\n    max_planning_time: 5.0\n"
    # A swarm that runs until max_planning_time: the slow plan the mid-plan map classes need
    # (a million iterations, and no patience rule to end it early).
    "    swarm: {iterations: 1000000, patience: 0}\n"
)
BARE_PARAMS = "patrol_planner:\n  ros__parameters:\n    map_yaml: ''\n    follow_plan: false\n    planner: astar\n"


def clear_cells(grid, res, clearance):
    """World centres (origin at 0, 0) of the free cells at least `clearance` m from every
    obstacle or unknown cell."""
    blocked = np.argwhere(grid != 0).astype(float)
    free = np.argwhere(grid == 0).astype(float)
    out = []
    for chunk in np.array_split(free, max(1, len(free) // 500)):
        d2 = ((chunk[:, None, :] - blocked[None, :, :]) ** 2).sum(axis=2).min(axis=1)
        out.extend((c * res + res / 2, r * res + res / 2) for r, c in chunk[d2 * res * res >= clearance ** 2])
    return out


def fast_map(grid, origin, res):
    """An OccupancyGrid from a numpy grid without a Python list of its cells (16 M of them)."""
    m = grid_msg(np.zeros((1, 1), np.int8), origin, res)
    m.info.height, m.info.width = grid.shape
    m.data = array.array("b", np.ascontiguousarray(grid, dtype=np.int8).tobytes())
    return m


class Faults:
    """Both nodes, their rclpy sides and the clients the classes share."""

    def __init__(self, tmp):
        (tmp / "planner.yaml").write_text(PARAMS)
        (tmp / "bare.yaml").write_text(BARE_PARAMS)
        self.domain, self.bare_domain = domain_id(15), domain_id(16)
        self.proc = start_node(self.domain, tmp / "planner.yaml", "patrol_planner_faults_test.log")
        self.bare_proc = start_node(self.bare_domain, tmp / "bare.yaml", "patrol_planner_faults_bare_test.log")
        self.ros = Ros(self.domain, context=rclpy.Context())
        self.bare = Ros(self.bare_domain, context=rclpy.Context())
        node = self.ros.node
        self.plan_client = node.create_client(GetPlan, MAKE_PLAN)
        self.set_client = node.create_client(SetParameters, "/patrol_planner/set_parameters")
        self.get_client = node.create_client(GetParameters, "/patrol_planner/get_parameters")
        self.action = ActionClient(node, ComputePathToPose, "compute_path_to_pose")
        self.bare_plan_client = self.bare.node.create_client(GetPlan, MAKE_PLAN)
        self.map = "bundled"  # what the node plans on: bundled, test, big, unknown (after a failed class)
        self.warmed_up = False

    def close(self):
        for r in (self.ros, self.bare):
            r.close()
        for p in (self.proc, self.bare_proc):
            if p.poll() is None:
                stop_binary(p)

    # --- requests -----------------------------------------------------------------------------

    def call(self, client, request, timeout, ros=None):
        """Calls a service; returns (response, seconds from the call to the reply)."""
        ros = ros or self.ros
        ros.spin_until(client.service_is_ready, 20, f"the service {client.srv_name}")
        t0 = time.monotonic()
        future = client.call_async(request)
        ros.spin_until(future.done, timeout, f"the answer of {client.srv_name}")
        return future.result(), time.monotonic() - t0

    def get_plan(self, start, goal, tolerance=0.0, timeout=QUICK + 10, ros=None, client=None):
        """GetPlan; `start` and `goal` are (x, y) in `map` or PoseStamped. Returns (plan, s)."""
        req = GetPlan.Request()
        req.start = start if isinstance(start, PoseStamped) else stamped(*start)
        req.goal = goal if isinstance(goal, PoseStamped) else stamped(*goal)
        req.tolerance = float(tolerance)
        response, dt = self.call(client or self.plan_client, req, timeout, ros)
        return response.plan, dt

    def set_param(self, name, value):
        if isinstance(value, str):
            v = ParameterValue(type=ParameterType.PARAMETER_STRING, string_value=value)
        elif isinstance(value, bool):
            v = ParameterValue(type=ParameterType.PARAMETER_BOOL, bool_value=value)
        elif isinstance(value, int):
            v = ParameterValue(type=ParameterType.PARAMETER_INTEGER, integer_value=value)
        else:
            v = ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=float(value))
        req = SetParameters.Request(parameters=[Parameter(name=name, value=v)])
        response, dt = self.call(self.set_client, req, QUICK + 10)
        return response.results[0], dt

    def get_param(self, name):
        response, _ = self.call(self.get_client, GetParameters.Request(names=[name]), 20)
        return response.values[0]

    def expect(self, send, code, budget=QUICK, ros=None):
        """Runs `send()` and waits for `code` on /diagnostics; fails if it took over `budget`.
        Returns (message, values, seconds)."""
        ros = ros or self.ros
        i = len(ros.diagnostics)
        t0 = time.monotonic()
        send()
        _, message, values = ros.wait_code(i, code, timeout=budget + 3)
        dt = time.monotonic() - t0
        assert dt <= budget, f"{code} came after {dt:.2f} s, over the {budget} s allowed"
        return message, values, dt

    def expect_plan_code(self, start, goal, code, tolerance=0.0):
        """A GetPlan that must fail with `code`: an empty plan, the code on /diagnostics."""
        got = {}

        def send():
            got["plan"], got["dt"] = self.get_plan(start, goal, tolerance)

        message, _, dt = self.expect(send, code)
        assert got["plan"].poses == [], "a failed GetPlan answers an empty plan"
        assert got["dt"] <= QUICK, f"the reply took {got['dt']:.2f} s"
        return f"{code} in {dt * 1e3:.0f} ms ({message})"

    def publish_goal(self, goal):
        self.ros.goal_pub.publish(goal)

    def expect_goal_code(self, goal, code):
        message, _, dt = self.expect(lambda: self.publish_goal(goal), code)
        return f"{code} in {dt * 1e3:.0f} ms ({message})"

    # --- state --------------------------------------------------------------------------------

    def warm_up(self):
        """Discovery done, a start pose in place, and the bundled map planned on."""
        if self.warmed_up:
            return
        ros = self.ros
        for pub, what in [(ros.goal_pub, "/goal_pose"), (ros.initial_pub, "/initialpose"), (ros.map_pub, "/map")]:
            ros.wait_matched(pub, what)
        ros.spin_until(lambda: self.get_plan(HOME, AWAY, timeout=20)[0].poses, 30, "a plan on the bundled map")

        def started():
            ros.initial_pub.publish(initial_pose(*HOME))
            ros.spin_for(0.2)
            return self.get_plan(PoseStamped(), AWAY)[0].poses  # empty frame: from the current pose

        ros.spin_until(started, 20, "the start pose to arrive")
        ros.send_goal_until_planned(stamped(*AWAY))
        self.warmed_up = True

    def use_test_map(self):
        """test_node.py's map (a wall, a closed box) in place of the current one."""
        self.warm_up()
        if self.map == "test":
            return
        self.ros.map_pub.publish(grid_msg(build_test_map()))
        self.ros.spin_until(self.test_map_plans, 30, "a plan on the test map")
        self.map = "test"

    def test_map_plans(self):
        plan, dt = self.get_plan(world(1.0, 1.0), world(11.0, 6.5))
        return plan.poses and (plan, dt)

    def install_big(self, n, res, origin=(0.0, 0.0), through_gap=False):
        """An n x n map: free, with one wall across it and a gap near its top. Returns the first
        plan on it from one side of the wall to the other (round by the gap, or straight through
        it), the time from publishing the map to that plan, its start and its goal."""
        grid = np.zeros((n, n), np.int8)
        grid[:, n // 2:n // 2 + 10] = 100
        grid[n - 100:n - 60, n // 2:n // 2 + 10] = 0
        side = n * res
        y = (n - 80) * res if through_gap else 1.0
        start, goal = (origin[0] + 1.0, origin[1] + y), (origin[0] + side - 1.0, origin[1] + y)
        msg = fast_map(grid, origin, res)
        t0 = time.monotonic()
        self.ros.map_pub.publish(msg)
        self.map = "big"

        def planned():
            plan, _ = self.get_plan(start, goal, timeout=60)
            return plan.poses and plan

        plan = self.ros.spin_until(planned, 60, f"a plan on the {n} x {n} map")
        return plan, time.monotonic() - t0, start, goal


@pytest.fixture(scope="module")
def faults(tmp_path_factory):
    f = Faults(tmp_path_factory.mktemp("faults"))
    try:
        yield f
    finally:
        f.close()


# --- the classes ------------------------------------------------------------------------------

CLASSES = []


def fault(name, xfail=None):
    def register(fn):
        CLASSES.append((name, fn, xfail))
        return fn

    return register


def bad_quaternion(x, y, q):
    p = stamped(x, y)
    p.pose.orientation.x, p.pose.orientation.y, p.pose.orientation.z, p.pose.orientation.w = q
    return p


@fault("goal_nan")
def goal_nan(f):
    return f.expect_goal_code(stamped(float("nan"), 1.0), "INVALID_INPUT")


@fault("goal_inf")
def goal_inf(f):
    return f.expect_goal_code(stamped(1.0, float("-inf")), "INVALID_INPUT")


@fault("get_plan_goal_nan")
def get_plan_goal_nan(f):
    return f.expect_plan_code(HOME, (float("nan"), 1.0), "INVALID_INPUT")


@fault("start_nan")
def start_nan(f):
    return f.expect_plan_code((float("nan"), 1.0), AWAY, "INVALID_INPUT")


@fault("start_inf")
def start_inf(f):
    return f.expect_plan_code((1.0, float("inf")), AWAY, "INVALID_INPUT")


@fault("initial_pose_nan_ignored")
def initial_pose_nan_ignored(f):
    # A pose topic has no answer: the node logs it and keeps the last good start pose.
    log = ROOT / "target" / "patrol_planner_faults_test.log"
    seen = log.read_text().count("/initialpose ignored")
    f.ros.initial_pub.publish(initial_pose(float("nan"), 1.0))
    # The pose has reached the node (and been refused) before the plan is asked for.
    f.ros.spin_until(lambda: log.read_text().count("/initialpose ignored") > seen, 10, "the NaN pose refused in the log")
    plan, dt = f.get_plan(PoseStamped(), AWAY)  # empty frame: from the current start pose
    assert plan.poses and dt <= QUICK, "no plan from the last good start pose"
    first = plan.poses[0].pose.position
    assert math.hypot(first.x - HOME[0], first.y - HOME[1]) < 1e-6, f"the plan starts at ({first.x}, {first.y})"
    return f"ignored: the next plan starts at the last good pose, answered in {dt * 1e3:.0f} ms"


@fault("quaternion_zero")
def quaternion_zero(f):
    return f.expect_goal_code(bad_quaternion(*AWAY, (0.0, 0.0, 0.0, 0.0)), "INVALID_INPUT")


@fault("quaternion_nan")
def quaternion_nan(f):
    return f.expect_goal_code(bad_quaternion(*AWAY, (0.0, 0.0, float("nan"), 1.0)), "INVALID_INPUT")


@fault("foreign_frame_goal")
def foreign_frame_goal(f):
    return f.expect_goal_code(stamped(*AWAY, frame="camera_link"), "TF_ERROR")


@fault("foreign_frame_get_plan_start")
def foreign_frame_get_plan_start(f):
    return f.expect_plan_code(stamped(*HOME, frame="laser"), AWAY, "TF_ERROR")


@fault("goal_outside_map")
def goal_outside_map(f):
    return f.expect_plan_code(HOME, (-5.0, 25.0), "GOAL_OUTSIDE_MAP")


@fault("goal_occupied")
def goal_occupied(f):
    return f.expect_plan_code(HOME, CABINET, "GOAL_OCCUPIED")


@fault("start_occupied")
def start_occupied(f):
    return f.expect_plan_code(CABINET, AWAY, "START_OCCUPIED")


@fault("start_outside_map")
def start_outside_map(f):
    return f.expect_plan_code((30.0, 1.0), AWAY, "START_OUTSIDE_MAP")


def trivial(f, goal):
    got = {}

    def send():
        got["plan"], got["dt"] = f.get_plan(HOME, goal)

    _, values, dt = f.expect(send, "NONE")
    poses = got["plan"].poses
    assert 1 <= len(poses) <= 2, f"{len(poses)} poses"
    last = poses[-1].pose.position
    assert math.hypot(last.x - goal[0], last.y - goal[1]) < 1e-6, "the path ends at the goal"
    return f"NONE in {dt * 1e3:.0f} ms, {len(poses)} poses, {values['length_m']} m"


@fault("goal_in_start_cell")
def goal_in_start_cell(f):
    return trivial(f, (HOME[0] + 0.05, HOME[1] + 0.02))  # the same 0.2 m cell


@fault("goal_equals_start")
def goal_equals_start(f):
    return trivial(f, HOME)


@fault("tolerance_1e9_parameter")
def tolerance_1e9_parameter(f):
    result, _ = f.set_param("tolerance", 1e9)
    assert result.successful, result.reason
    try:
        plan, dt = f.get_plan(HOME, CABINET)  # request tolerance 0: the node's 1e9 m applies
        assert plan.poses, "an occupied goal with a 1e9 m tolerance moves to the nearest free cell"
        assert dt <= QUICK, f"answered after {dt:.2f} s"
        end = plan.poses[-1].pose.position
        moved = math.hypot(end.x - CABINET[0], end.y - CABINET[1])
        assert moved < 2.0, f"the goal moved {moved:.2f} m, not to the nearest free cell"
        out = f"accepted; GetPlan into a cabinet answered in {dt * 1e3:.0f} ms, goal moved {moved:.2f} m"
    finally:
        result, _ = f.set_param("tolerance", 0.0)
        assert result.successful, result.reason
    return out


@fault("tolerance_1e9_get_plan")
def tolerance_1e9_get_plan(f):
    plan, dt = f.get_plan(HOME, CABINET, tolerance=1e9)
    assert plan.poses and dt <= QUICK, f"{len(plan.poses)} poses after {dt:.2f} s"
    # Refused as outside the map, not for any other reason: a 1e9 m tolerance does not bring
    # an outside goal in.
    refused = f.expect_plan_code(HOME, (-50.0, -50.0), "GOAL_OUTSIDE_MAP", tolerance=1e9)
    return f"planned in {dt * 1e3:.0f} ms ({len(plan.poses)} poses); outside goal: {refused}"


@fault("time_budget_1us")
def time_budget_1us(f):
    result, _ = f.set_param("max_planning_time", 1e-6)
    assert result.successful, result.reason
    try:
        out = f.expect_plan_code((0.1, 0.1), (19.9, 19.9), "TIMEOUT")
    finally:
        result, _ = f.set_param("max_planning_time", 5.0)
        assert result.successful, result.reason
    return out


def refused_param(f, name, value, must_mention):
    result, dt = f.set_param(name, value)
    assert not result.successful, f"{name} = {value!r} was accepted"
    assert result.reason and must_mention in result.reason, f"reason: {result.reason!r}"
    assert dt <= QUICK, f"answered after {dt:.2f} s"
    return f"refused in {dt * 1e3:.0f} ms ({result.reason})"


@fault("param_unknown_planner")
def param_unknown_planner(f):
    out = refused_param(f, "planner", "dijkstra", "astar")
    assert f.get_param("planner").string_value == "astar", "a refused value changes nothing"
    return out


@fault("param_negative_max_planning_time")
def param_negative_max_planning_time(f):
    return refused_param(f, "max_planning_time", -1.0, "max_planning_time")


@fault("param_nan_max_planning_time")
def param_nan_max_planning_time(f):
    out = refused_param(f, "max_planning_time", float("nan"), "max_planning_time")
    assert f.get_param("max_planning_time").double_value == 5.0
    return out


@fault("param_huge_max_planning_time")
def param_huge_max_planning_time(f):
    # A deadline 1e19 s away overflows the clock: every plan would have failed.
    out = refused_param(f, "max_planning_time", 1e19, "max_planning_time")
    assert f.get_param("max_planning_time").double_value == 5.0
    return out


@fault("param_negative_tolerance")
def param_negative_tolerance(f):
    return refused_param(f, "tolerance", -0.5, "tolerance")


@fault("param_wrong_type")
def param_wrong_type(f):
    a = refused_param(f, "planner", 3, "planner")
    b = refused_param(f, "max_planning_time", "fast", "max_planning_time")
    return f"planner = 3: {a}; max_planning_time = 'fast': {b}"


@fault("goal_flood_1000_in_1s")
def goal_flood(f):
    rng = random.Random(16)
    last = (19.9, 19.9)
    cells = [c for c in clear_cells(bundled_map(), RES, 1.0) if math.hypot(c[0] - last[0], c[1] - last[1]) > 0.5]
    goals = [rng.choice(cells) for _ in range(999)] + [last]
    before = len(f.ros.plans)
    t0 = time.monotonic()
    for k, g in enumerate(goals):
        f.publish_goal(stamped(*g))
        while time.monotonic() < t0 + (k + 1) / 1000:
            time.sleep(0.0002)
    sent = time.monotonic() - t0

    def last_planned():
        return any(p.poses and math.hypot(p.poses[-1].pose.position.x - last[0], p.poses[-1].pose.position.y - last[1]) < 1e-6
                   for p in f.ros.plans[before:])

    f.ros.spin_until(last_planned, QUICK + 10, "the /plan to the flood's last goal")
    dt = time.monotonic() - t0 - sent
    assert dt <= QUICK, f"the last goal was planned {dt:.2f} s after the flood"
    return f"1000 goals sent in {sent:.2f} s, the last one planned {dt * 1e3:.0f} ms after"


@fault("get_plan_200_concurrent")
def get_plan_200_concurrent(f):
    # A client whose reply queue holds them all: with rclpy's default service QoS (keep last 10)
    # Fast DDS drops the replies Python has not taken yet (the node answers all 200 either way).
    deep = QoSProfile(depth=256, history=HistoryPolicy.KEEP_LAST, reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.VOLATILE)
    client = f.ros.node.create_client(GetPlan, MAKE_PLAN, qos_profile=deep)
    try:
        return burst(f, client)
    finally:
        f.ros.node.destroy_client(client)


def burst(f, client):
    f.ros.spin_until(client.service_is_ready, 20, "make_plan")
    futures = []
    t0 = time.monotonic()
    for k in range(200):
        req = GetPlan.Request()
        req.start, req.goal = stamped(*HOME), stamped(*(AWAY if k % 2 else (19.9, 19.9)))
        futures.append(client.call_async(req))
    try:
        f.ros.spin_until(lambda: all(fu.done() for fu in futures), 60, "200 answers")
    except AssertionError as e:
        raise AssertionError(f"{e}: {sum(fu.done() for fu in futures)} answered") from None
    dt = time.monotonic() - t0
    empty = sum(not fu.result().plan.poses for fu in futures)
    assert empty == 0, f"{empty} of 200 answers were empty"
    return f"200 of 200 answered with a plan in {dt:.2f} s"


def nav2_get_path(f, start, goal, planner_id=""):
    ros = f.ros
    ros.spin_until(f.action.server_is_ready, 45, "compute_path_to_pose")
    g = ComputePathToPose.Goal()
    g.start, g.goal, g.use_start, g.planner_id = start, goal, True, planner_id
    t0 = time.monotonic()
    accepted = f.action.send_goal_async(g)
    handle = ros.spin_until(lambda: accepted.done() and accepted.result(), QUICK + 10, "the goal's acceptance")
    assert handle.accepted
    result = handle.get_result_async()
    ros.spin_until(result.done, QUICK + 10, "the action's result")
    dt = time.monotonic() - t0
    assert dt <= QUICK, f"the result came after {dt:.2f} s"
    return result.result().status, result.result().result, dt


@fault("nav2_unknown_planner_id")
def nav2_unknown_planner_id(f):
    status, result, dt = nav2_get_path(f, stamped(*HOME), stamped(*AWAY), planner_id="dijkstra")
    assert (status, result.error_code) == (6, 201), (status, result.error_code, result.error_msg)
    return f"ABORTED with 201 in {dt * 1e3:.0f} ms ({result.error_msg})"


@fault("nav2_nan_goal")
def nav2_nan_goal(f):
    status, result, dt = nav2_get_path(f, stamped(*HOME), stamped(float("nan"), 1.0))
    assert status == 6 and result.error_code == 200 and "finite" in result.error_msg, (status, result.error_code, result.error_msg)
    return f"ABORTED with 200 (UNKNOWN) in {dt * 1e3:.0f} ms ({result.error_msg})"


@fault("nav2_goal_occupied")
def nav2_goal_occupied(f):
    status, result, dt = nav2_get_path(f, stamped(*HOME), stamped(*CABINET))
    assert (status, result.error_code) == (6, 206), (status, result.error_code, result.error_msg)
    return f"ABORTED with 206 in {dt * 1e3:.0f} ms"


@fault("no_valid_path")
def no_valid_path(f):
    f.use_test_map()
    return f.expect_plan_code(world(1.0, 1.0), world(10.0, 2.0), "NO_VALID_PATH")  # inside the closed box


def bad_map(f, mutate):
    f.use_test_map()
    msg = grid_msg(build_test_map())
    mutate(msg)
    message, _, dt = f.expect(lambda: f.ros.map_pub.publish(msg), "INVALID_INPUT")
    assert "keeping the last good one" in message, message
    plan, dt2 = f.test_map_plans() or (None, None)
    assert plan is not None, "no plan on the last good map after the bad one"
    assert dt2 <= QUICK, f"the good request took {dt2:.2f} s"
    return f"INVALID_INPUT in {dt * 1e3:.0f} ms ({message.split(': ', 1)[-1]}); the last good map still plans"


def with_resolution(res):
    def mutate(m):
        m.info.resolution = res

    return mutate


def with_size(w, h):
    def mutate(m):
        m.info.width, m.info.height = w, h
        m.data = [0] * (w * h)

    return mutate


def short_data(m):
    m.data = m.data[:-7]


def nan_origin(m):
    m.info.origin.position.x = float("nan")


for _name, _mutate, _xfail in [
    ("map_wrong_data_length", short_data, None),
    ("map_resolution_nan", with_resolution(float("nan")), None),
    ("map_resolution_zero", with_resolution(0.0), None),
    ("map_resolution_negative", with_resolution(-0.05), None),
    ("map_resolution_1e-6", with_resolution(1e-6), None),
    ("map_resolution_1e4", with_resolution(1e4), None),
    ("map_origin_nan", nan_origin, None),
    ("map_0x0", with_size(0, 0), None),
]:
    fault(_name, _xfail)(lambda f, m=_mutate: bad_map(f, m))


@fault("map_1x1")
def map_1x1(f):
    """A 1 x 1 free map is well formed: taken, and a GetPlan inside its one cell gets the trivial
    path (it used to come back NO_VALID_PATH 'task panicked'); the test map is put back after."""
    f.use_test_map()
    msg = grid_msg(build_test_map())
    with_size(1, 1)(msg)
    msg.info.resolution = 1.0
    ox, oy = msg.info.origin.position.x, msg.info.origin.position.y
    ros = f.ros
    ros.map_pub.publish(msg)

    def trivial():
        plan, dt = f.get_plan((ox + 0.3, oy + 0.3), (ox + 0.7, oy + 0.6))
        return plan.poses and (plan, dt)

    plan, dt = ros.spin_until(trivial, 10, "a plan inside the 1 x 1 map")
    assert 1 <= len(plan.poses) <= 2, len(plan.poses)
    f.map = None
    f.use_test_map()
    return f"taken; GetPlan inside its cell answered in {dt * 1e3:.0f} ms with {len(plan.poses)} poses"


@fault("map_4000x4000")
def map_4000(f):
    f.warm_up()
    plan, dt, _, _ = f.install_big(4000, 0.05, origin=(1000.0, 1000.0), through_gap=True)
    assert dt <= BIG, f"the first plan on it came {dt:.1f} s after the map"
    return f"accepted and planned on {dt:.1f} s after publishing it ({len(plan.poses)} poses)"


def slow_goal_then_map(f, replacement, replacement_code):
    """A 2000 x 2000 map, a slow plan (mocmcso for max_planning_time) for a goal across it, and
    `replacement` published while it runs. Returns (the /plan of the slow goal, its /diagnostics
    values, seconds until the replacement's answer)."""
    f.warm_up()
    _, _, start, goal = f.install_big(2000, 0.05)
    ros = f.ros

    def started():
        ros.initial_pub.publish(initial_pose(*start))
        ros.spin_for(0.2)
        plan, _ = f.get_plan(PoseStamped(), (start[0] + 1.0, start[1]))
        return plan.poses and math.hypot(plan.poses[0].pose.position.x - start[0], plan.poses[0].pose.position.y - start[1]) < 1e-6

    ros.spin_until(started, 20, "the start pose on the 2000 x 2000 map")
    for name, value in [("planner", "mocmcso"), ("max_planning_time", 3.0)]:
        assert f.set_param(name, value)[0].successful
    try:
        before, i = len(ros.plans), len(ros.diagnostics)
        t_goal = time.monotonic()
        f.publish_goal(stamped(*goal))
        ros.spin_for(0.7)
        assert not ros.diagnostics_since(i), "the slow plan ended before the map was replaced"
        t0 = time.monotonic()
        if replacement_code:
            f.expect(lambda: ros.map_pub.publish(replacement), replacement_code)
        else:
            ros.map_pub.publish(replacement)
        dt = time.monotonic() - t0
        plan = ros.spin_until(lambda: next((p for p in ros.plans[before:] if p.poses), None), 15, "the slow plan's /plan")
        _, _, values = ros.wait_code(i, "NONE", timeout=5)
        assert time.monotonic() - t_goal >= 2.5, "the plan was not slow"
    finally:
        for name, value in [("planner", "astar"), ("max_planning_time", 5.0)]:
            assert f.set_param(name, value)[0].successful
    assert f.proc.poll() is None, "the node died"
    return plan, values, dt


@fault("map_replaced_mid_plan_by_10x10_at_1e-6")
def map_replaced_by_tiny(f):
    tiny = fast_map(np.zeros((10, 10), np.int8), (0.0, 0.0), 1e-6)
    plan, values, dt = slow_goal_then_map(f, tiny, "INVALID_INPUT")
    # The refused map left the 2000 x 2000 one in place.
    again, _ = f.get_plan((1.0, 1.0), (99.0, 1.0), timeout=BIG)
    assert again.poses, "the 2000 x 2000 map is gone"
    return (f"the tiny map refused in {dt * 1e3:.0f} ms while planning; the plan finished "
            f"({len(plan.poses)} poses, {values['planning_time_ms']} ms); the big map still plans")


@fault("map_replaced_mid_plan_by_1000x1000_at_1mm")
def map_replaced_by_finer(f):
    # 1 m x 1 m at 1 mm: a path densified at the new map's resolution would be ~200 000 poses.
    finer = fast_map(np.zeros((1000, 1000), np.int8), (500.0, 500.0), 0.001)
    plan, values, _ = slow_goal_then_map(f, finer, None)
    assert len(plan.poses) <= 100_000, f"{len(plan.poses)} poses"
    # The spacing of the first two poses, whichever way the path sets off (it was the x step
    # alone, which a path leaving northwards fails at any spacing).
    a, b = plan.poses[0].pose.position, plan.poses[1].pose.position
    assert math.hypot(b.x - a.x, b.y - a.y) > 0.01, "densified at the new map's 1 mm"
    # The new map is the node's now.
    ros = f.ros
    ros.spin_until(lambda: f.get_plan((500.1, 500.1), (500.9, 500.9))[0].poses, BIG, "a plan on the 1 mm map")
    return f"/plan of the finished plan has {len(plan.poses)} poses (<= 100k); the 1 mm map plans next"


@fault("no_start_pose")
def no_start_pose(f):
    bare = f.bare
    bare.wait_matched(bare.goal_pub, "/goal_pose")
    message, _, dt = f.expect(lambda: bare.goal_pub.publish(stamped(*AWAY)), "NO_START_POSE", ros=bare)
    return f"NO_START_POSE in {dt * 1e3:.0f} ms ({message})"


@fault("no_map")
def no_map(f):
    bare = f.bare
    got = {}

    def send():
        got["plan"], got["dt"] = f.get_plan(HOME, AWAY, ros=bare, client=f.bare_plan_client)

    message, _, dt = f.expect(send, "NO_MAP", ros=bare)
    assert got["plan"].poses == [] and got["dt"] <= QUICK
    return f"NO_MAP in {dt * 1e3:.0f} ms ({message})"


OUTCOMES = {}


@pytest.mark.parametrize(
    "name", [pytest.param(n, marks=pytest.mark.xfail(reason=x, strict=True)) if x else n for n, _, x in CLASSES]
)
def test_fault_class(faults, name):
    fn, xfail = next((fn, x) for n, fn, x in CLASSES if n == name)
    if name not in ("no_start_pose", "no_map"):
        faults.warm_up()
    try:
        outcome = fn(faults)
        if faults.proc.poll() is not None:
            raise AssertionError(f"the node exited with {faults.proc.returncode}")
        # The node still serves a good request on whatever map it has now.
        if faults.map == "bundled":
            plan, dt = faults.get_plan(HOME, AWAY)
            assert plan.poses and dt <= QUICK, "no good plan after the fault"
        elif faults.map == "test":
            assert faults.test_map_plans(), "no good plan after the fault"
    except BaseException as e:
        faults.map = "unknown"  # whatever the class left: the next class that needs a map installs it
        OUTCOMES[name] = ("xfail" if xfail else "FAILED", f"{type(e).__name__}: {e}".splitlines()[0])
        print(f"{name}: {OUTCOMES[name][0]}: {OUTCOMES[name][1]}" + (f" [{xfail}]" if xfail else ""))
        raise
    OUTCOMES[name] = ("ok", outcome)
    print(f"{name}: {outcome}")


def test_every_class_passed_and_the_nodes_stop_cleanly(faults):
    assert len(CLASSES) >= 25
    missing = [n for n, _, _ in CLASSES if n not in OUTCOMES]
    failed = [f"{n}: {OUTCOMES[n][1]}" for n, _, _ in CLASSES if OUTCOMES.get(n, ("",))[0] == "FAILED"]
    xfailed = [n for n, _, _ in CLASSES if OUTCOMES.get(n, ("",))[0] == "xfail"]
    print(f"{len(CLASSES)} classes: {len(CLASSES) - len(missing) - len(failed) - len(xfailed)} passed, "
          f"{len(xfailed)} expected failures ({', '.join(xfailed) or 'none'}), {len(failed)} failed, {len(missing)} not run")
    for p, what in [(faults.proc, "the node"), (faults.bare_proc, "the node without a map")]:
        assert p.poll() is None, f"{what} exited with {p.returncode}"
    stop_binary(faults.proc)
    stop_binary(faults.bare_proc)
    assert not failed and not missing, "classes that failed or did not run:\n" + "\n".join(failed + missing)

