"""Replanning while following, as Nav2 does it (navigation2 PR 2841): the node and the simulated
car on a domain of their own, the bundled map published by this test. While the car follows its
plan, a new map that blocks the path ahead makes the node plan again (a new /plan that avoids the
block, and the car drives on); a new map that does not touch the path leaves the plan as it was.
Then the same for a NavigateToPose goal: its path planned again round a new block, the action
still succeeds. And for a NavigateThroughPoses goal blocked after its first via pose: the path
planned again goes through the poses still ahead only (not back to the one passed), and the
action succeeds."""
import math

from action_msgs.msg import GoalStatus
from nav_msgs.msg import OccupancyGrid, Odometry
from rclpy.action import ActionClient

from nav2_msgs.action import NavigateThroughPoses, NavigateToPose

from conftest import LATCHED, ROOT, driving_rig, stamped
from test_node import assert_collision_free, grid_msg
from test_vehicle import bundled_map

GOAL = (8.1, 6.9)
RES = 0.2  # the bundled map's resolution


def blocked(grid, x, y, half=0.5):
    """A copy of `grid` with a square obstacle of side 2 * `half` m centred at (x, y)."""
    g = grid.copy()
    c0, c1 = int((x - half) / RES), int((x + half) / RES) + 1
    r0, r1 = int((y - half) / RES), int((y + half) / RES) + 1
    g[max(r0, 0):r1, max(c0, 0):c1] = 100
    return g


def test_a_map_that_blocks_the_path_replans_one_that_does_not_keeps_it(tmp_path):
    params = tmp_path / "planner.yaml"
    params.write_text("patrol_planner:\n  ros__parameters:\n    map_yaml: ''\n    planner: astar\n")
    with driving_rig(40, params, ROOT / "config" / "chassis.yaml", "replan") as ros:
        odom, costmaps = [], []
        ros.node.create_subscription(Odometry, "/odom", odom.append, 100)
        ros.node.create_subscription(OccupancyGrid, "/patrol_planner/costmap", costmaps.append, LATCHED)
        grid = bundled_map()
        ros.wait_matched(ros.map_pub, "/map")
        ros.map_pub.publish(grid_msg(grid, origin=(0.0, 0.0), res=RES))
        ros.spin_until(lambda: odom, 45, "/odom from the simulated chassis")
        ros.send_goal_until_planned(stamped(*GOAL))
        first = [p for p in ros.plans if p.poses][-1]
        pts = [(p.pose.position.x, p.pose.position.y) for p in first.poses]

        # A map far from the path: nothing changes.
        ros.spin_for(2.0)
        far = (19.5, 0.5)
        assert min(math.hypot(x - far[0], y - far[1]) for x, y in pts) > 3.0
        before = len(ros.plans)
        ros.map_pub.publish(grid_msg(blocked(grid, *far), origin=(0.0, 0.0), res=RES))

        def far_block_in_force():
            # The node's own costmap shows the block (lethal 100) once it plans on that map.
            if not costmaps:
                return False
            m = costmaps[-1]
            c, r = int(far[0] / RES), int(far[1] / RES)
            return m.info.width == grid.shape[1] and m.data[r * m.info.width + c] == 100

        ros.spin_until(far_block_in_force, 15, "the far block in the node's costmap")
        ros.spin_for(2.0)
        assert len(ros.plans) == before, "a map that does not touch the path replanned it"

        # A block on the path well ahead of the car: a new plan round it, and the car drives on.
        car = odom[-1].pose.pose.position
        ahead = [p for p in pts if math.hypot(p[0] - car.x, p[1] - car.y) > 2.5 and math.hypot(p[0] - GOAL[0], p[1] - GOAL[1]) > 1.5]
        assert ahead, "no stretch of the path left to block"
        bx, by = ahead[len(ahead) // 2]
        new_grid = blocked(grid, bx, by, half=0.3)
        before = len(ros.plans)
        ros.map_pub.publish(grid_msg(new_grid, origin=(0.0, 0.0), res=RES))
        replanned = ros.spin_until(lambda: [p for p in ros.plans[before:] if p.poses], 15, "a new /plan after the blocking map")
        assert_collision_free(replanned[-1], new_grid, origin=(0.0, 0.0), res=RES)

        def arrived():
            p = odom[-1].pose.pose.position
            return math.hypot(p.x - GOAL[0], p.y - GOAL[1]) <= 0.15 and abs(odom[-1].twist.twist.linear.x) < 1e-3

        ros.spin_until(arrived, 90, "the car to reach the goal round the new block")

        # The same for a NavigateToPose goal (drive.rs): the path planned again is still the
        # action's, which goes on and succeeds, not aborted as if a newer goal had come.
        client = ActionClient(ros.node, NavigateToPose, "navigate_to_pose")
        ros.spin_until(lambda: client.server_is_ready(), 45, "the navigate_to_pose action")
        home = (0.5, 0.5)
        before = len(ros.plans)
        sent = client.send_goal_async(NavigateToPose.Goal(pose=stamped(*home)))
        handle = ros.spin_until(lambda: sent.done() and sent.result(), 30, "the action goal's acceptance")
        assert handle.accepted
        result = handle.get_result_async()
        plan = ros.spin_until(lambda: next((p for p in ros.plans[before:] if p.poses), None), 30, "the action's /plan")
        pts = [(p.pose.position.x, p.pose.position.y) for p in plan.poses]
        car = odom[-1].pose.pose.position
        ahead = [p for p in pts if math.hypot(p[0] - car.x, p[1] - car.y) > 2.5 and math.hypot(p[0] - home[0], p[1] - home[1]) > 1.5]
        assert ahead, "no stretch of the action's path left to block"
        bx, by = ahead[len(ahead) // 2]
        before = len(ros.plans)
        g2 = blocked(new_grid, bx, by, half=0.3)
        ros.map_pub.publish(grid_msg(g2, origin=(0.0, 0.0), res=RES))
        again = ros.spin_until(lambda: [p for p in ros.plans[before:] if p.poses], 15, "a new /plan for the action's goal")
        # Round the block, not the rest of the old path (the simulated car has no map to hit).
        assert_collision_free(again[-1], g2, origin=(0.0, 0.0), res=RES)
        ros.spin_until(result.done, 90, "the action's result")
        r = result.result()
        assert r.status == GoalStatus.STATUS_SUCCEEDED, f"status {r.status}: {r.result.error_msg}"

        # NavigateThroughPoses along the bottom aisle: once the car has passed the first via
        # pose, a block between it and the second; the new path goes round it through the poses
        # still ahead.
        via1, via2, end = (3.0, 0.8), (12.0, 0.8), (16.0, 0.8)
        through = ActionClient(ros.node, NavigateThroughPoses, "navigate_through_poses")
        ros.spin_until(lambda: through.server_is_ready(), 45, "the navigate_through_poses action")
        feedback = []
        sent = through.send_goal_async(NavigateThroughPoses.Goal(poses=[stamped(*via1), stamped(*via2), stamped(*end)]),
                                       feedback_callback=lambda f: feedback.append(f.feedback))
        handle = ros.spin_until(lambda: sent.done() and sent.result(), 30, "the through-poses goal's acceptance")
        assert handle.accepted
        result = handle.get_result_async()
        ros.spin_until(lambda: any(f.number_of_poses_remaining == 2 for f in feedback), 60, "the car past the first via pose")
        before, seen = len(ros.plans), len(feedback)
        g3 = blocked(new_grid, 7.0, 0.6, half=0.4)
        ros.map_pub.publish(grid_msg(g3, origin=(0.0, 0.0), res=RES))
        replanned = ros.spin_until(lambda: [p for p in ros.plans[before:] if p.poses], 15, "a new /plan for the through-poses goal")[-1]
        assert_collision_free(replanned, g3, origin=(0.0, 0.0), res=RES)

        def passes(plan, q):
            return any(math.hypot(p.pose.position.x - q[0], p.pose.position.y - q[1]) < 1e-6 for p in plan.poses)

        assert passes(replanned, via2) and not passes(replanned, via1), "the new path goes through the poses ahead only"
        ros.spin_until(result.done, 120, "the through-poses goal's result")
        r = result.result()
        assert r.status == GoalStatus.STATUS_SUCCEEDED, f"status {r.status}: {r.result.error_msg}"
        assert all(f.number_of_poses_remaining <= 2 for f in feedback[seen:]), [f.number_of_poses_remaining for f in feedback]
