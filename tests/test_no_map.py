"""A node that starts with no map (no `map_yaml`, no map server yet), checked from outside on its
own ROS_DOMAIN_ID: goals and GetPlan get NO_MAP with a reason, and the node plans as soon as a
map arrives on /map."""
import math
import os

import numpy as np
import pytest
import rclpy

from conftest import Ros, domain_id, initial_pose, start_node, stamped, stop_node
from test_node import assert_collision_free, grid_msg, plan_to
from test_services import get_plan


@pytest.fixture(scope="module")
def bare(tmp_path_factory):
    domain = domain_id(50)  # away from the session node's
    params = tmp_path_factory.mktemp("no_map") / "planner.yaml"
    params.write_text('patrol_planner:\n  ros__parameters:\n    map_yaml: ""\n    planner: astar\n    follow_plan: false\n')
    proc = start_node(domain, params, "patrol_planner_no_map_test.log")
    r = Ros(domain, context=rclpy.Context())
    try:
        yield r
    finally:
        r.close()
        stop_node(proc)


def test_no_map_yet_then_a_map(bare):
    ros = bare
    ros.wait_matched(ros.initial_pub, "/initialpose")
    ros.wait_matched(ros.goal_pub, "/goal_pose")

    def no_map():
        ros.initial_pub.publish(initial_pose(1.0, 1.0))
        i = len(ros.diagnostics)
        ros.goal_pub.publish(stamped(4.0, 1.0))
        try:
            return ros.wait_code(i, "NO_MAP", timeout=2)
        except AssertionError:
            return None

    _, message, _ = ros.spin_until(no_map, 30, "NO_MAP for a goal")
    assert "no map" in message and "/map" in message
    i = len(ros.diagnostics)
    assert get_plan(ros, (1.0, 1.0), (4.0, 1.0)).poses == []
    ros.wait_code(i, "NO_MAP")
    # A 6 m x 3 m room with a pillar; the node plans in it as soon as it arrives.
    grid = np.zeros((30, 60), dtype=np.int8)
    grid[0:20, 25:30] = 100
    ros.map_pub.publish(grid_msg(grid, (0.0, 0.0), 0.1))

    def planned():  # a goal that overtakes the map on the wire still gets NO_MAP: ask again
        try:
            return plan_to(ros, (5.5, 1.0), timeout=2)
        except AssertionError:
            return None

    path = ros.spin_until(planned, 30, "a plan once the map is there")
    first = path.poses[0].pose.position
    assert math.hypot(first.x - 1.0, first.y - 1.0) < 1e-6
    assert_collision_free(path, grid, (0.0, 0.0), 0.1)
