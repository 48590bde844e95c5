"""The node as Nav2's lifecycle_manager drives planner_server: started with `autostart: false`
under a remapped name and namespace (`-r __node:=planner_server -r __ns:=/robot1`, the params
block keyed by that name as in a Nav2 params file), it is found there, refuses to plan until it
is configured and activated, ends a plan under way and refuses again once deactivated, plans
again after activate, and ends finalized after shutdown. The lifecycle services are called with rclpy's own clients and
lifecycle_msgs, exactly as the lifecycle manager calls them."""
import rclpy
from lifecycle_msgs.msg import State, Transition
from lifecycle_msgs.srv import ChangeState, GetAvailableTransitions, GetState
from nav2_msgs.action import ComputePathToPose
from nav_msgs.srv import GetPlan
from rclpy.action import ActionClient

from conftest import ROOT, Ros, call_service, domain_id, stamped, start_node, stop_binary

NODE = "/robot1/planner_server"


def state(ros):
    return call_service(ros, GetState, f"{NODE}/get_state", GetState.Request()).current_state


def change(ros, transition_id):
    req = ChangeState.Request()
    req.transition.id = transition_id
    return call_service(ros, ChangeState, f"{NODE}/change_state", req).success


def get_plan(ros):
    req = GetPlan.Request()
    req.start, req.goal = stamped(0.1, 0.1), stamped(8.1, 6.9)
    return call_service(ros, GetPlan, f"{NODE}/make_plan", req).plan


def test_lifecycle_transitions_gate_planning_under_a_remapped_name(tmp_path):
    params = tmp_path / "nav2_params.yaml"
    params.write_text(
        "planner_server:\n  ros__parameters:\n"
        f"    map_yaml: {ROOT / 'config' / 'maps' / 'datacenter_100.yaml'}\n"
        "    autostart: false\n    follow_plan: false\n    planner: astar\n"
        # A swarm slow enough to be deactivated under: a million iterations, no early end.
        "    max_planning_time: 60.0\n    swarm: {iterations: 1000000, patience: 0}\n"
    )
    domain = domain_id(85)
    proc = start_node(domain, params, "lifecycle_test.log", ["-r", "__node:=planner_server", "-r", "__ns:=/robot1"])
    context = rclpy.Context()
    ros = Ros(domain, context=context)
    try:
        ros.spin_until(
            lambda: ("planner_server", "/robot1") in ros.node.get_node_names_and_namespaces(), 20,
            "planner_server in /robot1 on the ROS graph",
        )
        assert state(ros).id == State.PRIMARY_STATE_UNCONFIGURED
        before = len(ros.diagnostics)
        assert get_plan(ros).poses == [], "an unconfigured node planned"
        code, message, _ = ros.wait_code(before, "NOT_ACTIVE")
        assert "unconfigured" in message
        # Not allowed from unconfigured: refused, and nothing changes.
        assert not change(ros, Transition.TRANSITION_ACTIVATE)
        assert state(ros).id == State.PRIMARY_STATE_UNCONFIGURED

        assert change(ros, Transition.TRANSITION_CONFIGURE)
        assert state(ros).label == "inactive"
        labels = {t.transition.label for t in call_service(
            ros, GetAvailableTransitions, f"{NODE}/get_available_transitions", GetAvailableTransitions.Request()
        ).available_transitions}
        assert labels == {"cleanup", "activate", "shutdown"}
        assert get_plan(ros).poses == [], "an inactive node planned"

        assert change(ros, Transition.TRANSITION_ACTIVATE)
        assert state(ros).id == State.PRIMARY_STATE_ACTIVE
        assert len(get_plan(ros).poses) > 10

        # Deactivating ends a plan under way, as planner_server's deactivated action server
        # ends its goal: aborted at once (UNKNOWN 200, the reason given), no plan.
        client = ActionClient(ros.node, ComputePathToPose, "/robot1/compute_path_to_pose")
        ros.spin_until(client.server_is_ready, 20, "compute_path_to_pose")
        goal = ComputePathToPose.Goal(start=stamped(0.1, 0.1), goal=stamped(8.1, 6.9), use_start=True,
                                      planner_id="mocmcso")
        sent = client.send_goal_async(goal)
        handle = ros.spin_until(lambda: sent.done() and sent.result(), 20, "the slow goal's acceptance")
        assert handle.accepted
        result = handle.get_result_async()
        ros.spin_for(1.0)
        assert not result.done(), "the slow plan ended before the deactivation"
        assert change(ros, Transition.TRANSITION_DEACTIVATE)
        ros.spin_until(result.done, 5, "the slow goal's end after the deactivation")
        r = result.result()
        assert (r.status, r.result.error_code, len(r.result.path.poses)) == (6, 200, 0), r.result.error_msg
        assert "inactive" in r.result.error_msg, r.result.error_msg
        before = len(ros.diagnostics)
        assert get_plan(ros).poses == []
        ros.wait_code(before, "NOT_ACTIVE")

        assert change(ros, Transition.TRANSITION_ACTIVATE)
        assert len(get_plan(ros).poses) > 10

        assert change(ros, Transition.TRANSITION_ACTIVE_SHUTDOWN)
        assert state(ros).id == State.PRIMARY_STATE_FINALIZED
        assert get_plan(ros).poses == []
    finally:
        ros.close()
        stop_binary(proc)
