"""patrol_planner checked from outside, as a ROS 2 user's stack would use it: the bundled map,
goals in and /plan out, bad input with its /diagnostics code, a flood of goals, and a
1000 x 1000 map over DDS (GetPlan and the parameters: test_services.py; no map yet:
test_no_map.py). Collisions are checked with this file's own code against the map this file
published, not with the node's."""
import math

import numpy as np
from nav_msgs.msg import OccupancyGrid

from conftest import initial_pose, stamped

# The test map: 12 m x 8 m at 0.1 m, placed at (-30, -30), far from the bundled map ([0, 20]^2),
# so a plan inside it proves the node uses the map this test published.
ORIGIN, RES, W, H = (-30.0, -30.0), 0.1, 120, 80


def build_test_map():
    grid = np.zeros((H, W), dtype=np.int8)  # row-major from the origin, like OccupancyGrid.data

    def block(u0, u1, v0, v1, value=100):
        grid[int(round(v0 / RES)):int(round(v1 / RES)), int(round(u0 / RES)):int(round(u1 / RES))] = value

    block(5.0, 6.0, 0.0, 6.0)  # a wall; the way round is over its top (v 6..8)
    for u0, u1, v0, v1 in [(9.0, 11.0, 1.0, 1.3), (9.0, 11.0, 2.7, 3.0), (9.0, 9.3, 1.0, 3.0), (10.7, 11.0, 1.0, 3.0)]:
        block(u0, u1, v0, v1)  # a closed box: its inside is unreachable
    block(0.0, 2.0, 7.5, 8.0, value=-1)  # an unknown strip
    return grid


def world(u, v):
    return ORIGIN[0] + u, ORIGIN[1] + v


def grid_msg(grid, origin=ORIGIN, res=RES):
    m = OccupancyGrid()
    m.header.frame_id = "map"
    m.info.resolution = res
    m.info.height, m.info.width = grid.shape
    m.info.origin.position.x, m.info.origin.position.y = origin
    m.info.origin.orientation.w = 1.0
    m.data = grid.flatten().tolist()
    return m


def assert_collision_free(path, grid, origin=ORIGIN, res=RES):
    pts = [(p.pose.position.x, p.pose.position.y) for p in path.poses]
    for (x0, y0), (x1, y1) in zip(pts, pts[1:]):
        n = max(1, int(math.hypot(x1 - x0, y1 - y0) / (res / 5)))
        for k in range(n + 1):
            x, y = x0 + (x1 - x0) * k / n, y0 + (y1 - y0) * k / n
            c, r = int(math.floor((x - origin[0]) / res)), int(math.floor((y - origin[1]) / res))
            assert 0 <= c < grid.shape[1] and 0 <= r < grid.shape[0], f"({x:.2f}, {y:.2f}) is off the map"
            v = grid[r, c]
            assert 0 <= v < 65, f"the path crosses cell ({c}, {r}) = {v} at ({x:.2f}, {y:.2f})"


def plan_to(ros, goal, timeout=30, yaw=0.0):
    """Publishes a goal and returns the /plan that ends there."""
    before = len(ros.plans)
    ros.goal_pub.publish(stamped(*goal, yaw=yaw))
    return ros.spin_until(
        lambda: next((p for p in ros.plans[before:] if p.poses and abs(p.poses[-1].pose.position.x - goal[0]) < 1e-6
                      and abs(p.poses[-1].pose.position.y - goal[1]) < 1e-6), None), timeout, f"/plan to {goal}")


def refused(ros, goal, code, frame="map", orientation=None):
    """Publishes a bad goal and waits for its result code on /diagnostics."""
    i = len(ros.diagnostics)
    msg = stamped(*goal, frame=frame)
    if orientation is not None:
        msg.pose.orientation.x, msg.pose.orientation.y, msg.pose.orientation.z, msg.pose.orientation.w = orientation
    ros.goal_pub.publish(msg)
    return ros.wait_code(i, code)


def use_test_map(ros, start=(1.0, 1.0)):
    """Publishes the test map and a start pose in it, and waits until the node plans in it."""
    grid = build_test_map()
    ros.wait_matched(ros.map_pub, "/map")
    ros.wait_matched(ros.initial_pub, "/initialpose")
    ros.wait_matched(ros.goal_pub, "/goal_pose")
    ros.map_pub.publish(grid_msg(grid))
    goal = world(11.0, 6.5)

    def planned():
        ros.initial_pub.publish(initial_pose(*world(*start)))
        try:
            return plan_to(ros, goal, timeout=3)
        except AssertionError:
            return None

    ros.spin_until(planned, 40, "a plan in the test map")
    return grid


def test_01_bundled_map_arrives_for_a_late_subscriber(ros):
    got = []
    ros.node.create_subscription(OccupancyGrid, "/map", got.append, __import__("conftest").LATCHED)
    ros.spin_until(lambda: got, 20, "the bundled map on /map")
    m = got[0]
    assert (m.info.width, m.info.height) == (100, 100) and abs(m.info.resolution - 0.2) < 1e-6
    assert len(m.data) == 100 * 100 and 0 in m.data and 100 in m.data


def test_02_no_start_pose_yet(ros):
    ros.wait_matched(ros.goal_pub, "/goal_pose")
    code, message, _ = refused(ros, (10.0, 10.0), "NO_START_POSE")
    assert "start pose" in message


def test_03_goal_gives_a_collision_free_plan(ros):
    grid = use_test_map(ros)
    goal = world(11.5, 7.0)
    path = plan_to(ros, goal, yaw=1.0)
    assert path.header.frame_id == "map"
    first, last = path.poses[0].pose, path.poses[-1].pose
    assert math.hypot(first.position.x - world(1.0, 1.0)[0], first.position.y - world(1.0, 1.0)[1]) < 1e-6
    assert abs(2 * math.atan2(last.orientation.z, last.orientation.w) - 1.0) < 1e-6, "the last pose has the goal's heading"
    # It must go over the wall's top (v > 6): the straight line would cross the wall.
    assert max(p.pose.position.y for p in path.poses) > ORIGIN[1] + 6.0
    assert_collision_free(path, grid)


def test_04_bad_requests_get_their_codes_and_the_node_keeps_serving(ros):
    grid = use_test_map(ros)
    refused(ros, (-5.0, -5.0), "GOAL_OUTSIDE_MAP")
    refused(ros, world(5.5, 3.0), "GOAL_OCCUPIED")
    refused(ros, world(10.0, 2.0), "NO_VALID_PATH")
    refused(ros, world(3.0, 3.0), "TF_ERROR", frame="camera_link")
    refused(ros, (float("nan"), 1.0), "INVALID_INPUT")
    refused(ros, (float("inf"), 1.0), "INVALID_INPUT")
    refused(ros, world(3.0, 3.0), "INVALID_INPUT", orientation=(0.0, 0.0, 0.0, 0.0))
    # A start inside the wall, then outside the map.
    ros.initial_pub.publish(initial_pose(*world(5.5, 3.0)))
    ros.spin_until(lambda: refused(ros, world(3.0, 3.0), "START_OCCUPIED"), 20, "START_OCCUPIED")
    ros.initial_pub.publish(initial_pose(100.0, 0.0))
    ros.spin_until(lambda: refused(ros, world(3.0, 3.0), "START_OUTSIDE_MAP"), 20, "START_OUTSIDE_MAP")
    ros.initial_pub.publish(initial_pose(*world(1.0, 1.0)))
    # Malformed maps are refused and the last good map stays.
    for bad in ["length", "nan", "zero"]:
        msg = grid_msg(grid)
        if bad == "length":
            msg.data = msg.data[:-7]
        elif bad == "nan":
            msg.info.resolution = float("nan")
        else:
            msg.info.resolution = 0.0
        i = len(ros.diagnostics)
        ros.map_pub.publish(msg)
        _, message, _ = ros.wait_code(i, "INVALID_INPUT")
        assert "keeping the last good one" in message
    path = ros.spin_until(lambda: plan_to(ros, world(11.0, 6.5)), 30, "a good plan after the bad input")
    assert_collision_free(path, grid)


def test_05_a_flood_of_goals(ros):
    grid = use_test_map(ros)
    goals = [world(11.0, 6.5), world(3.0, 6.0), world(11.5, 0.5), world(2.0, 4.0)]
    for k in range(100):
        ros.goal_pub.publish(stamped(*goals[k % len(goals)]))
    path = plan_to(ros, world(8.0, 7.0), timeout=60)
    assert_collision_free(path, grid)
    assert_collision_free(plan_to(ros, world(11.0, 6.5)), grid)


def test_06_a_1000_by_1000_map_crosses_dds_intact(ros):
    # 50 m x 50 m at 0.05 m, at (100, 100): a wall at x = 125 m with one 2 m gap at y 140..142.
    grid = np.zeros((1000, 1000), dtype=np.int8)
    grid[:, 495:505] = 100
    grid[800:840, 495:505] = 0
    origin = (100.0, 100.0)
    ros.map_pub.publish(grid_msg(grid, origin, 0.05))

    def planned():
        ros.initial_pub.publish(initial_pose(105.0, 105.0))
        try:
            return plan_to(ros, (145.0, 105.0), timeout=5)
        except AssertionError:
            return None

    path = ros.spin_until(planned, 90, "a plan on the 1 MB map")
    ys = [p.pose.position.y for p in path.poses if 124.9 < p.pose.position.x < 125.1]
    assert ys and all(140.0 < y < 142.0 for y in ys), "the path does not use the one gap: the map arrived corrupted"
    assert_collision_free(path, grid, origin, 0.05)
