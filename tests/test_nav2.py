"""The node as a Nav2 stack uses planner_server, with nav2_msgs built into the test venv
(tests/build_interfaces.sh): ComputePathToPose as nav2_simple_commander's getPath calls it,
ComputePathThroughPoses as getPathThroughPoses does, Nav2's error codes, cancel during a slow
plan, planner_server's one pending goal (a newer goal waits for the running one, an older waiting
one is aborted), planner ids, results asked for late and out of order, and is_path_valid; with
`follow_plan: false`, as beside a Nav2 stack, none of the actions that drive (bt_navigator's,
waypoint_follower's, behavior_server's) is served, so none of that stack's goals can reach it. The node runs on a domain of its own, with the test map of
test_node.py published on /map (collisions checked with this suite's own code)."""
import math

import rclpy
from rclpy.action import ActionClient, get_action_server_names_and_types_by_node

from nav2_msgs.action import ComputePathThroughPoses, ComputePathToPose
from nav2_msgs.srv import IsPathValid
from nav_msgs.msg import Path as PathMsg

from conftest import LATCHED, Ros, domain_id, stamped, start_node, stop_binary
from test_node import assert_collision_free, build_test_map, grid_msg, world

PARAMS = (
    "patrol_planner:\n  ros__parameters:\n"
    "    map_yaml: ''\n    follow_plan: false\n    planner: astar\n    max_planning_time: 60.0\n"
    # A swarm slow enough to cancel: a million iterations, no patience rule to end it early.
    "    swarm: {iterations: 1000000, patience: 0}\n"
    # Nav2's plugin ids, as its behaviour trees send them: its own C++ plugin's block answers
    # with `planner`, an id of ours with the planner it names.
    "    planner_plugins: [GridBased, Smooth]\n"
    "    GridBased: {plugin: nav2_navfn_planner/NavfnPlanner, tolerance: 0.5}\n"
    "    Smooth: {plugin: any_angle}\n"
)


class Nav2Client:
    def __init__(self, ros):
        self.ros = ros
        self.to_pose = ActionClient(ros.node, ComputePathToPose, "compute_path_to_pose")
        self.through = ActionClient(ros.node, ComputePathThroughPoses, "compute_path_through_poses")
        self.valid = ros.node.create_client(IsPathValid, "is_path_valid")

    def send(self, client, goal, cancel_after=None, timeout=30):
        """Sends a goal the way nav2_simple_commander does; returns (status, result)."""
        ros = self.ros
        ros.spin_until(lambda: client.server_is_ready(), 45, "the action server")
        accepted = client.send_goal_async(goal)
        handle = ros.spin_until(lambda: accepted.done() and accepted.result(), 20, "the goal's acceptance")
        assert handle.accepted, "the goal was rejected"
        result = handle.get_result_async()
        if cancel_after is not None:
            ros.spin_for(cancel_after)
            cancel = handle.cancel_goal_async()
            ros.spin_until(cancel.done, 10, "the cancel's answer")
        ros.spin_until(result.done, timeout, "the action's result")
        return result.result().status, result.result().result

    def get_path(self, start, goal, planner_id=""):
        g = ComputePathToPose.Goal()
        g.start, g.goal, g.use_start, g.planner_id = stamped(*start), stamped(*goal), True, planner_id
        return self.send(self.to_pose, g)

    def is_valid(self, points):
        path = PathMsg()
        path.header.frame_id = "map"
        path.poses = [stamped(x, y) for x, y in points]
        self.ros.spin_until(lambda: self.valid.service_is_ready(), 20, "is_path_valid")
        future = self.valid.call_async(IsPathValid.Request(path=path))
        self.ros.spin_until(future.done, 20, "is_path_valid's answer")
        return future.result()


def goal_to(start, end, planner_id):
    g = ComputePathToPose.Goal()
    g.start, g.goal, g.use_start, g.planner_id = stamped(*start), stamped(*end), True, planner_id
    return g


def accept(nav2, goal):
    """Sends `goal` on ComputePathToPose; returns its handle once accepted."""
    sent = nav2.to_pose.send_goal_async(goal)
    handle = nav2.ros.spin_until(lambda: sent.done() and sent.result(), 20, "the goal's acceptance")
    assert handle.accepted
    return handle


def near(pose, point, tol):
    return math.hypot(pose.pose.position.x - point[0], pose.pose.position.y - point[1]) <= tol


def test_planner_server_actions_and_is_path_valid(tmp_path):
    params = tmp_path / "params.yaml"
    params.write_text(PARAMS)
    domain = domain_id(95)
    proc = start_node(domain, params, "nav2_test.log")
    context = rclpy.Context()
    ros = Ros(domain, context=context)
    try:
        grid = build_test_map()
        ros.wait_matched(ros.map_pub, "/map")
        ros.map_pub.publish(grid_msg(grid))
        nav2 = Nav2Client(ros)
        start, goal = world(1.0, 1.0), world(10.0, 5.0)

        # getPath: a path from the start to the goal, round the wall, planning_time set.
        def planned():
            status, result = nav2.get_path(start, goal)
            return (status, result) if result.error_code == 0 else None

        status, result = ros.spin_until(planned, 30, "ComputePathToPose to plan on the test map")
        assert status == 4, f"status {status}"  # SUCCEEDED
        assert near(result.path.poses[0], start, 1e-6) and near(result.path.poses[-1], goal, 1e-6)
        assert_collision_free(result.path, grid)
        assert result.planning_time.sec > 0 or result.planning_time.nanosec > 0
        # The plan also went out on /plan.
        ros.spin_until(lambda: ros.plans and near(ros.plans[-1].poses[-1], goal, 1e-6), 10, "the action's plan on /plan")

        # planner_id names another planner: /diagnostics says which answered.
        before = len(ros.diagnostics)
        status, result = nav2.get_path(start, goal, planner_id="any_angle")
        assert result.error_code == 0
        ros.spin_until(
            lambda: any(code == "NONE" and v.get("planner") == "any_angle" for code, _, v in ros.diagnostics_since(before)),
            10, "/diagnostics naming any_angle",
        )
        status, result = nav2.get_path(start, goal, planner_id="dijkstra")
        assert (status, result.error_code) == (6, 201) and "dijkstra" in result.error_msg  # ABORTED
        assert "GridBased" in result.error_msg
        # planner_plugins' ids: Nav2's GridBased (its navfn block) answers with `planner`, an id
        # naming one of ours with that one.
        for planner_id, answered in [("GridBased", "astar"), ("Smooth", "any_angle")]:
            before = len(ros.diagnostics)
            status, result = nav2.get_path(start, goal, planner_id=planner_id)
            assert (status, result.error_code) == (4, 0), f"{planner_id}: {result.error_msg}"
            ros.spin_until(
                lambda: any(code == "NONE" and v.get("planner") == answered for code, _, v in ros.diagnostics_since(before)),
                10, f"/diagnostics naming {answered} for {planner_id}",
            )

        # Nav2's codes: occupied goal 206, goal outside 204, unreachable 208.
        status, result = nav2.get_path(start, world(5.5, 3.0))
        assert (status, result.error_code) == (6, 206) and result.error_msg
        status, result = nav2.get_path(start, (-5.0, -5.0))
        assert (status, result.error_code) == (6, 204) and result.error_msg
        status, result = nav2.get_path(start, world(10.0, 2.0))
        assert (status, result.error_code) == (6, 208), result.error_msg

        # Cancel during a slow plan (a million swarm iterations): canceled, quickly.
        g = ComputePathToPose.Goal()
        g.start, g.goal, g.use_start, g.planner_id = stamped(*start), stamped(*goal), True, "mocmcso"
        status, result = nav2.send(nav2.to_pose, g, cancel_after=1.0, timeout=15)
        assert status == 5, f"status {status}, {result.error_msg}"  # CANCELED

        # planner_server's one pending goal: a slow plan runs on while newer goals come (it
        # ends here only when cancelled); of two sent meanwhile the older waiting one is
        # replaced (ABORTED, an empty result), the newer waits and then plans.
        slow_handle = accept(nav2, g)
        slow_result = slow_handle.get_result_async()
        ros.spin_for(0.5)
        replaced = accept(nav2, goal_to(start, goal, ""))
        pending = accept(nav2, goal_to(start, world(3.0, 7.0), "any_angle"))
        replaced_result = replaced.get_result_async()
        ros.spin_until(replaced_result.done, 10, "the replaced goal's result")
        r = replaced_result.result()
        assert (r.status, r.result.error_code, len(r.result.path.poses)) == (6, 0, 0), r.result.error_msg
        pending_result = pending.get_result_async()
        ros.spin_for(1.0)
        # Both facts rest on the slow plan still running: a million iterations, 60 s allowed.
        assert not slow_result.done(), f"the slow plan ended early: {slow_result.result().status}"
        assert not pending_result.done(), "the pending goal ran beside the slow one"
        cancel = slow_handle.cancel_goal_async()
        ros.spin_until(cancel.done, 10, "the cancel's answer")
        ros.spin_until(slow_result.done, 15, "the slow goal's result")
        assert slow_result.result().status == 5, slow_result.result().status  # CANCELED
        ros.spin_until(pending_result.done, 15, "the pending goal's result")
        r = pending_result.result()
        assert r.status == 4 and near(r.result.path.poses[-1], world(3.0, 7.0), 1e-6), r.result.error_msg

        # Through three poses: one joined path passing each of them.
        vias = [world(3.0, 7.0), world(8.0, 7.0), world(10.0, 5.0)]
        t = ComputePathThroughPoses.Goal()
        t.start, t.use_start = stamped(*start), True
        t.goals = [stamped(*p) for p in vias]
        status, result = nav2.send(nav2.through, t)
        assert (status, result.error_code) == (4, 0), result.error_msg
        assert near(result.path.poses[0], start, 1e-6)
        for p in vias:
            assert any(near(q, p, 0.05) for q in result.path.poses), f"the path misses {p}"
        assert_collision_free(result.path, grid)
        t.goals = []
        status, result = nav2.send(nav2.through, t)
        assert (status, result.error_code) == (6, 309)

        # Only planner_server's actions: the ones that drive are the stack's own servers'.
        # (Listed once the planner actions are: the node creates them all before it spins.)
        # Asked of the node itself: the whole graph's names would count this test's own
        # clients of the planner actions and of is_path_valid too.
        served = {name for name, _ in get_action_server_names_and_types_by_node(ros.node, "patrol_planner", "/")}
        assert {"/compute_path_to_pose", "/compute_path_through_poses"} <= served, served
        driving = {"/navigate_to_pose", "/navigate_through_poses", "/follow_waypoints", "/spin", "/backup",
                   "/drive_on_heading", "/wait", "/assisted_teleop", "/follow_path"}
        assert not served & driving, served
        services = {name for name, _ in ros.node.get_service_names_and_types_by_node("patrol_planner", "/")}
        assert "/is_path_valid" in services and not any("costmap" in s for s in services), services

        # A goal whose client never asks for its result (a crashed script) does not hold up the
        # next: the turn passes on when a plan ends, not when its result is fetched.
        accept(nav2, goal_to(start, goal, ""))
        nxt = accept(nav2, goal_to(start, world(3.0, 7.0), "")).get_result_async()
        ros.spin_until(nxt.done, 10, "the next goal's result")
        assert nxt.result().status == 4, nxt.result().result.error_msg

        # Two goals that end before their clients ask for the results, asked for in the other
        # order: each client gets its own (ros2-client reads result requests only while sending
        # a result; the node's tries look among those another goal's try has read).
        ros.spin_until(lambda: nav2.to_pose.server_is_ready(), 45, "the action server")
        # Each goal has its own end, so a result handed to the other client is seen.
        handles, ends = [], [goal, world(3.0, 7.0)]
        for planner_id, end in zip(("", "any_angle"), ends):
            handles.append(accept(nav2, goal_to(start, end, planner_id)))
        ros.spin_for(2.0)  # both planned, one after the other, and their results waiting
        results = [h.get_result_async() for h in reversed(handles)]
        ros.spin_until(lambda: all(r.done() for r in results), 10, "both results, asked for late")
        newer, older = results[0].result(), results[1].result()
        # A newer plan goal waits for the running one, as planner_server's: both succeed.
        assert (newer.status, older.status) == (4, 4), (newer.result.error_msg, older.result.error_msg)
        assert near(newer.result.path.poses[-1], ends[1], 1e-6), "the newer goal got the older's result"
        assert near(older.result.path.poses[-1], ends[0], 1e-6), "the older goal got the newer's result"

        # is_path_valid: through the wall invalid with its indices, in free space valid.
        crossing = [world(4.0, 3.0), world(5.5, 3.0), world(7.0, 3.0)]
        answer = nav2.is_valid(crossing)
        assert not answer.is_valid and list(answer.invalid_pose_indices) == [1]
        answer = nav2.is_valid([world(1.0, 1.0), world(3.0, 1.0), world(3.0, 7.0)])
        assert answer.is_valid and list(answer.invalid_pose_indices) == []
        # An empty path is invalid, as planner_server answers it.
        answer = nav2.is_valid([])
        assert not answer.is_valid and list(answer.invalid_pose_indices) == []
    finally:
        ros.close()
        stop_binary(proc)



def test_with_use_sim_time_the_node_stamps_with_the_simulations_clock(tmp_path):
    """A simulated Nav2 stack (Gazebo, `ros2 bag play --clock`) runs every node with
    `use_sim_time`: the node stamps its answers and /plan with the latest rosgraph_msgs/Clock
    on /clock (published here as Gazebo's bridge does, reliable), not the system clock, and
    says so when its use_sim_time parameter is asked for."""
    from rcl_interfaces.srv import GetParameters
    from rosgraph_msgs.msg import Clock

    from conftest import call_service

    params = tmp_path / "params.yaml"
    params.write_text(PARAMS + "    use_sim_time: true\n")
    domain = domain_id(96)
    proc = start_node(domain, params, "nav2_sim_time_test.log")
    ros = Ros(domain, context=rclpy.Context())
    try:
        clock_pub = ros.node.create_publisher(Clock, "/clock", 10)
        sim = Clock()
        sim.clock.sec, sim.clock.nanosec = 1234, 500000000
        ros.node.create_timer(0.05, lambda: clock_pub.publish(sim))
        grid = build_test_map()
        ros.wait_matched(ros.map_pub, "/map")
        ros.map_pub.publish(grid_msg(grid))
        nav2 = Nav2Client(ros)

        # Stamps are zero until the node's /clock reader has matched and read a first Clock
        # (DDS discovery may match it after the map's): a plan stamped zero is asked again.
        # Wall time (or anything but the simulation's 1234.5 s) fails below.
        def planned():
            status, result = nav2.get_path(world(1.0, 1.0), world(10.0, 5.0))
            stamp = result.path.header.stamp
            return result if result.error_code == 0 and (stamp.sec, stamp.nanosec) != (0, 0) else None

        result = ros.spin_until(planned, 30, "ComputePathToPose to plan under sim time, stamped")
        stamp = result.path.header.stamp
        assert (stamp.sec, stamp.nanosec) == (1234, 500000000), stamp
        ros.spin_until(lambda: ros.plans and ros.plans[-1].header.stamp.sec == 1234, 10, "/plan stamped 1234 s")
        asked = call_service(ros, GetParameters, "/patrol_planner/get_parameters",
                             GetParameters.Request(names=["use_sim_time"]))
        assert asked.values[0].bool_value, asked.values
    finally:
        ros.close()
        stop_binary(proc)


def test_params_files_and_p_rules_apply_with_rclcpps_precedence(tmp_path):
    """launch_ros turns `parameters=[nav2_params.yaml, {...}]` into one --params-file each, and
    `ros2 run ... --ros-args -p name:=value` adds rules: the node applies them as rclcpp does
    (rclcpp#1094), every `/**` value (a file's `/**` block, a -p without a node name) in
    command-line order, then the node's own (its block in a file, a -p with its name) over them.
    Asked through the node's parameter services, as `ros2 param get` asks; the -p that its own
    block overrides is named in a warning, as a user would otherwise not learn why it did
    nothing."""
    from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
    from rcl_interfaces.srv import GetParameters, SetParameters

    from conftest import ROOT, call_service

    params = tmp_path / "params.yaml"
    params.write_text(PARAMS.replace("patience: 0}", "patience: 0, safety_weight: 0.1}"))
    launch = tmp_path / "launch_params.yaml"
    launch.write_text("/**:\n  ros__parameters:\n    tolerance: 0.4\n"
                      "patrol_planner:\n  ros__parameters:\n    swarm: {safety_weight: 0.25}\n")
    domain = domain_id(97)
    log = "nav2_params_files_test.log"
    proc = start_node(domain, params, log,
                      ["--params-file", str(launch), "-p", "tolerance:=0.45", "-p", "planner:=any_angle",
                       "-p", "patrol_planner:swarm.safety_weight:=0.5"])
    ros = Ros(domain, context=rclpy.Context())
    try:
        asked = call_service(ros, GetParameters, "/patrol_planner/get_parameters",
                             GetParameters.Request(names=["planner", "tolerance", "swarm.safety_weight"]))
        planner, tolerance, safety = asked.values
        assert tolerance.double_value == 0.45, "a plain -p after the second file's /** value"
        assert planner.string_value == "astar", "the node's own block over a plain -p, as rclcpp"
        assert safety.double_value == 0.5, "the node's -p over both files' node blocks"
        warned = (ROOT / "target" / log).read_text()
        assert "`-p planner:=any_angle` does nothing" in warned, warned
        # What is read at start only is there too (`ros2 param dump` shows the whole), and a
        # set of it to another value is refused, saying why.
        iterations, plugins = call_service(
            ros, GetParameters, "/patrol_planner/get_parameters",
            GetParameters.Request(names=["swarm.iterations", "planner_plugins"])).values
        assert iterations.type == ParameterType.PARAMETER_INTEGER and iterations.integer_value == 1000000
        assert list(plugins.string_array_value) == ["GridBased", "Smooth"], plugins
        fewer = ParameterValue(type=ParameterType.PARAMETER_INTEGER, integer_value=10)
        refused = call_service(ros, SetParameters, "/patrol_planner/set_parameters", SetParameters.Request(
            parameters=[Parameter(name="swarm.iterations", value=fewer)])).results[0]
        assert not refused.successful and "read at start only" in refused.reason, refused
    finally:
        ros.close()
        stop_binary(proc)


assert LATCHED  # the latched profile the session uses (kept imported for pyflakes' sake)
