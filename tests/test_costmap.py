"""Planning on Nav2's costmap: with `costmap_topic` set, the node takes a nav_msgs/OccupancyGrid
as costmap_2d publishes it (0 free, 1..98 graded, 99 inscribed, 100 lethal) as its planning grid,
and cost-aware A* (`search.cost_travel_multiplier`) goes round a band of high (not lethal) cost
across the direct route, through the gap beside it. /diagnostics reports the plan's clearance and
cost. The node runs on a domain of its own; nothing is published on /map.

And the safety weight set at run time: the same GetPlan on the bundled map, first in the paper's
two-objective mode (swarm.safety_weight 0), then after `ros2 param set /patrol_planner
swarm.safety_weight 0.5`, comes back with a larger mean clearance on /diagnostics. A
SetParametersAtomically request with one value out of range then changes nothing.

And costmap_2d's partial updates (map_msgs/OccupancyGridUpdate on `<costmap>_updates`, what it
sends between full costmaps unless `always_send_full_costmap`): a band written by an update is
avoided by the next plan; an update outside the costmap is refused on /diagnostics and changes
nothing; and `costmap.inflation_radius`, which shapes only the node's own inflation of a map, is
refused a new value on a costmap topic, with the reason."""
import numpy as np
import rclpy
from map_msgs.msg import OccupancyGridUpdate
from nav_msgs.msg import OccupancyGrid
from nav_msgs.srv import GetPlan
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
from rcl_interfaces.srv import GetParameters, SetParameters, SetParametersAtomically

from conftest import LATCHED, ROOT, Ros, call_service, domain_id, initial_pose, stamped, start_node, static_transforms, stop_binary, transform
from test_node import grid_msg

TOPIC = "/global_costmap/costmap"
RES = 0.1


def costmap_node(tmp_path, offset, log):
    """The node planning with cost-aware A* on TOPIC (nothing on /map), and a client beside it."""
    params = tmp_path / "planner.yaml"
    params.write_text(
        "patrol_planner:\n  ros__parameters:\n    map_yaml: ''\n    follow_plan: false\n    planner: astar\n"
        f"    costmap_topic: {TOPIC}\n    search: {{cost_travel_multiplier: 2.0}}\n"
    )
    domain = domain_id(offset)
    proc = start_node(domain, params, log)
    return proc, Ros(domain, context=rclpy.Context())


def test_a_high_cost_band_on_the_costmap_is_avoided(tmp_path):
    proc, ros = costmap_node(tmp_path, 30, "costmap_test.log")
    try:
        # 10 m x 6 m; a 3 m band at x 3.5..6.5 m from y 0 to 4.5 m, free above it. Its value, 60,
        # is a graded cost (about 153 of 252) on a costmap, but below the occupancy threshold (65)
        # of a map: planned as a map, the band would be free and the plan would run straight.
        grid = np.zeros((60, 100), dtype=np.int8)
        grid[0:45, 35:65] = 60
        costmap_pub = ros.node.create_publisher(OccupancyGrid, TOPIC, LATCHED)
        ros.wait_matched(costmap_pub, TOPIC)
        costmap_pub.publish(grid_msg(grid, origin=(0.0, 0.0), res=RES))
        ros.wait_matched(ros.initial_pub, "/initialpose")
        ros.initial_pub.publish(initial_pose(1.0, 2.0))
        ros.send_goal_until_planned(stamped(9.0, 2.0))
        plan = [p for p in ros.plans if p.poses][-1]
        crossing = [
            (p.pose.position.x, p.pose.position.y) for p in plan.poses
            if grid[int(p.pose.position.y / RES), int(p.pose.position.x / RES)] > 0
        ]
        assert not crossing, f"the plan crosses the high-cost band at {crossing[:3]}"
        assert max(p.pose.position.y for p in plan.poses) >= 4.5, "the plan should go through the gap"
        statuses = [d for d in ros.diagnostics_since(0) if d[0] == "NONE"]
        assert statuses and float(statuses[-1][2]["path_cost"]) < 0.5
        assert float(statuses[-1][2]["mean_clearance_m"]) > 0.3
    finally:
        ros.close()
        stop_binary(proc)


def test_costmap_updates_are_written_into_the_costmap(tmp_path):
    proc, ros = costmap_node(tmp_path, 32, "costmap_updates_test.log")
    try:
        # The same 10 m x 6 m costmap as above, all free at first.
        grid = np.zeros((60, 100), dtype=np.int8)
        costmap_pub = ros.node.create_publisher(OccupancyGrid, TOPIC, LATCHED)
        updates_pub = ros.node.create_publisher(OccupancyGridUpdate, TOPIC + "_updates", LATCHED)
        ros.wait_matched(costmap_pub, TOPIC)
        ros.wait_matched(updates_pub, TOPIC + "_updates")
        costmap_pub.publish(grid_msg(grid, origin=(0.0, 0.0), res=RES))

        def plan():
            req = GetPlan.Request(start=stamped(1.0, 2.0), goal=stamped(9.0, 2.0), tolerance=0.0)
            response = call_service(ros, GetPlan, "/patrol_planner/make_plan", req)
            return [(p.pose.position.x, p.pose.position.y) for p in response.plan.poses]

        # Free: straight along y = 2.
        ros.spin_until(lambda: (p := plan()) and max(y for _, y in p) < 2.1, 30, "a straight plan on the free costmap")

        # The band of the test above (x 3.5..6.5 m, y 0..4.5 m, cost 60) as an update: its window.
        band = OccupancyGridUpdate(x=35, y=0, width=30, height=45, data=[60] * (30 * 45))
        band.header.frame_id = "map"
        updates_pub.publish(band)

        def off_band(x, y):
            return not (3.5 <= x < 6.5 and y < 4.5)

        def avoids():
            p = plan()
            return p and all(off_band(x, y) for x, y in p) and max(y for _, y in p) >= 4.5

        ros.spin_until(avoids, 30, "a plan round the band the update wrote")

        # A window over the band's top rows that runs past the costmap's edge: refused on
        # /diagnostics, the band kept whole (written in part, it would open a shorter way through
        # y 4.0..4.5 m).
        before = len(ros.diagnostics)
        outside = OccupancyGridUpdate(x=35, y=40, width=70, height=5, data=[0] * (70 * 5))
        outside.header.frame_id = "map"
        updates_pub.publish(outside)
        refused = ros.wait_code(before, "INVALID_INPUT")
        assert "not inside" in refused[1], refused
        assert avoids(), "the refused update changed the costmap"

        # On a costmap taken as it is, the node's own inflation settings would change nothing:
        # a new value is refused with the reason, the value held is taken, and a setting the
        # plans still read (cost_travel_multiplier) is taken.
        def set_double(name, v):
            value = ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=v)
            request = SetParameters.Request(parameters=[Parameter(name=name, value=value)])
            return call_service(ros, SetParameters, "/patrol_planner/set_parameters", request).results[0]

        held = call_service(
            ros, GetParameters, "/patrol_planner/get_parameters",
            GetParameters.Request(names=["costmap.inflation_radius"]),
        ).values[0].double_value
        unused = set_double("costmap.inflation_radius", held + 1.0)
        assert not unused.successful
        assert TOPIC in unused.reason and "costmap_topic" in unused.reason, unused.reason
        assert set_double("costmap.inflation_radius", held).successful
        taken = set_double("search.cost_travel_multiplier", 3.0)
        assert taken.successful, taken.reason
        # The node's own obstacle layer does not run on Nav2's costmap: switching it is refused
        # (its value at start, declared, passed: the node came up).
        off = ParameterValue(type=ParameterType.PARAMETER_BOOL, bool_value=False)
        request = SetParameters.Request(parameters=[Parameter(name="obstacle_layer.enabled", value=off)])
        switched = call_service(ros, SetParameters, "/patrol_planner/set_parameters", request).results[0]
        assert not switched.successful and "own obstacle layer" in switched.reason, switched
    finally:
        ros.close()
        stop_binary(proc)


def test_the_safety_weight_set_at_run_time_moves_the_next_plan_off_the_walls(tmp_path):
    params = tmp_path / "planner.yaml"
    params.write_text(
        "patrol_planner:\n  ros__parameters:\n"
        f"    map_yaml: {ROOT / 'config' / 'maps' / 'datacenter_100.yaml'}\n"
        "    follow_plan: false\n    planner: mocmcso\n    seed: 7\n"
        "    swarm: {safety_weight: 0.0}\n"
    )
    domain = domain_id(31)
    proc = start_node(domain, params, "safety_weight_test.log")
    ros = Ros(domain, context=rclpy.Context())
    try:
        def clearance():
            before = len(ros.diagnostics)
            # The bench's aisle_run: along an aisle between cabinet rows, across the room.
            req = GetPlan.Request(start=stamped(0.5, 6.1), goal=stamped(19.5, 14.9), tolerance=0.0)
            response = call_service(ros, GetPlan, "/patrol_planner/make_plan", req)
            assert response.plan.poses, "no plan"
            done = ros.wait_code(before, "NONE")
            return float(done[2]["mean_clearance_m"]), float(done[2]["length_m"])

        paper, paper_length = clearance()
        value = ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=0.5)
        request = SetParameters.Request(parameters=[Parameter(name="swarm.safety_weight", value=value)])
        result = call_service(ros, SetParameters, "/patrol_planner/set_parameters", request)
        assert result.results[0].successful, result.results[0].reason
        safe, safe_length = clearance()
        print(f"mean clearance {paper:.3f} m ({paper_length:.2f} m long) -> {safe:.3f} m ({safe_length:.2f} m long)")
        assert safe > paper + 0.1, f"mean clearance {paper} -> {safe}"
        assert safe_length < 1.15 * paper_length

        # All or nothing: a safety weight in range beside a length weight out of it (a share).
        def double(name, v):
            return Parameter(name=name, value=ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=v))

        atomic = SetParametersAtomically.Request(
            parameters=[double("swarm.safety_weight", 0.0), double("swarm.length_weight", 2.0)]
        )
        result = call_service(ros, SetParametersAtomically, "/patrol_planner/set_parameters_atomically", atomic)
        assert not result.result.successful
        assert "length_weight" in result.result.reason, result.result.reason
        got = call_service(
            ros, GetParameters, "/patrol_planner/get_parameters",
            GetParameters.Request(names=["swarm.safety_weight", "swarm.length_weight"]),
        )
        assert [v.double_value for v in got.values] == [0.5, 0.5]
    finally:
        ros.close()
        stop_binary(proc)


def keepout_node(tmp_path, line, offset, log):
    """A node planning with A* on its own costmap, `line` its keepout parameter, on a domain
    of its own; an open 10 m x 6 m map published to it. Returns the process and the client."""
    params = tmp_path / "planner.yaml"
    params.write_text(
        "patrol_planner:\n  ros__parameters:\n    map_yaml: ''\n    follow_plan: false\n    planner: astar\n"
        f"    {line}\n"
    )
    domain = domain_id(offset)
    proc = start_node(domain, params, log)
    ros = Ros(domain, context=rclpy.Context())
    ros.wait_matched(ros.map_pub, "/map")
    ros.map_pub.publish(grid_msg(np.zeros((60, 100), dtype=np.int8), origin=(0.0, 0.0), res=RES))
    return proc, ros


def plan_across(ros):
    """The plan from (1, 2) to (9, 2) m, straight through the keepout zone below when open."""
    req = GetPlan.Request(start=stamped(1.0, 2.0), goal=stamped(9.0, 2.0), tolerance=0.0)
    return call_service(ros, GetPlan, "/patrol_planner/make_plan", req).plan.poses


def through_zone(poses):
    """The poses inside the zone of [`zone_mask`]."""
    return [p for p in poses if 4.0 <= p.pose.position.x <= 6.0 and p.pose.position.y <= 4.5]


def zone_mask(value=100):
    """A 0.2 m mask from (3, 0): the zone x 4..6 m, y 0..4.6 m at `value`, the rest 0."""
    zone = np.zeros((30, 25), dtype=np.int8)
    zone[0:23, 5:15] = value
    return grid_msg(zone, origin=(3.0, 0.0), res=0.2)


def test_a_keepout_mask_is_laid_over_the_nodes_own_costmap(tmp_path):
    """Nav2's keepout filter, for the node's own costmap (`keepout_mask_topic`): a mask (as a
    filter mask server latches it, of its own resolution and origin) keeps the plans out of its
    zone at once, and the published costmap shows it lethal; a mask in a frame TF cannot place
    is refused on /diagnostics and the last good one stays; one in another frame of the TF tree
    is placed through it, also when its transform comes after it; an empty mask frees the way
    again."""
    mask_topic = "/keepout_filter_mask"
    proc, ros = keepout_node(tmp_path, f"keepout_mask_topic: {mask_topic}", 34, "keepout_test.log")
    try:
        costmaps = []
        ros.node.create_subscription(OccupancyGrid, "/patrol_planner/costmap", costmaps.append, LATCHED)
        mask_pub = ros.node.create_publisher(OccupancyGrid, mask_topic, LATCHED)

        def plan():
            return plan_across(ros)

        ros.spin_until(lambda: plan(), 30, "a plan on the open map")
        assert through_zone(plan()), "on the open map the plan runs straight through"
        ros.wait_matched(mask_pub, mask_topic)
        mask_pub.publish(zone_mask())
        poses = ros.spin_until(lambda: (lambda p: p if p and not through_zone(p) else None)(plan()), 20,
                               "a plan round the keepout zone")
        assert max(p.pose.position.y for p in poses) > 4.6, "round the zone's top"

        def lethal_in_costmap():
            if not costmaps:
                return False
            c = np.array(costmaps[-1].data, dtype=np.int8).reshape(60, 100)
            return (c[0:46, 41:59] == 100).all() and (c[50:60, :] == 0).all()

        ros.spin_until(lethal_in_costmap, 10, "the zone lethal on /patrol_planner/costmap")

        i = len(ros.diagnostics)
        other = zone_mask(0)
        other.header.frame_id = "nowhere"
        mask_pub.publish(other)
        code, why, _ = ros.wait_code(i, "INVALID_INPUT")
        assert "keepout mask" in why and "`nowhere`" in why, why
        assert plan() and not through_zone(plan()), "the last good mask stays"

        # A mask in another frame is placed through TF (Nav2's filters transform theirs): the
        # same zone in `zones`, 2 m to the map's -x (/tf_static), keeps the plan out of x 2..4.
        # The mask comes first, its frame's transform a second later: the node tries again.
        moved = zone_mask()
        moved.header.frame_id = "zones"
        i = len(ros.diagnostics)
        mask_pub.publish(moved)
        code, why, _ = ros.wait_code(i, "INVALID_INPUT")
        assert "not placed yet" in why and "`zones`" in why, why
        static_transforms(ros, transform("map", "zones", (-2.0, 0.0, 0.0)))

        def round_moved_zone():
            poses = plan()
            inside = [p for p in poses if 2.0 <= p.pose.position.x <= 4.0 and p.pose.position.y <= 4.5]
            return poses if poses and not inside and through_zone(poses) else None

        ros.spin_until(round_moved_zone, 20, "a plan round the zone placed through TF, through where it was")

        mask_pub.publish(zone_mask(0))
        ros.spin_until(lambda: through_zone(plan()), 20, "the way free again under an empty mask")
    finally:
        ros.close()
        stop_binary(proc)


def test_the_keepout_mask_is_found_through_nav2s_filter_info(tmp_path):
    """Nav2's keepout filter finds its mask through `filter_info_topic` (a CostmapFilterInfo
    latched by costmap_filter_info_server): the node follows the info to its mask topic, refuses
    a speed filter's info on /diagnostics (staying on the topic it had), and moves to a new
    info's topic, keeping the last good mask until that topic's first mask arrives."""
    from nav2_msgs.msg import CostmapFilterInfo

    info_topic = "/costmap_filter_info"
    proc, ros = keepout_node(tmp_path, f"keepout_filter_info_topic: {info_topic}", 36, "keepout_info_test.log")
    try:
        info_pub = ros.node.create_publisher(CostmapFilterInfo, info_topic, LATCHED)
        first = ros.node.create_publisher(OccupancyGrid, "/keepout_first", LATCHED)
        second = ros.node.create_publisher(OccupancyGrid, "/keepout_second", LATCHED)

        def plan():
            return plan_across(ros)

        def info(kind, topic):
            return CostmapFilterInfo(type=kind, filter_mask_topic=topic, base=0.0, multiplier=1.0)

        ros.spin_until(lambda: plan(), 30, "a plan on the open map")
        # The zone of the test above on the first mask topic; nothing on it yet reaches the node
        # until the info names the topic.
        first.publish(zone_mask())
        assert through_zone(plan()), "no info yet: no mask"
        ros.spin_for(1.0)
        assert first.get_subscription_count() == 0, "a mask topic read before any info named it"
        ros.wait_matched(info_pub, info_topic)
        info_pub.publish(info(0, "/keepout_first"))
        ros.spin_until(lambda: (lambda p: p if p and not through_zone(p) else None)(plan()), 20,
                       "a plan round the zone of the mask the info names")

        i = len(ros.diagnostics)
        info_pub.publish(info(1, "/speed_filter_mask"))
        code, why, _ = ros.wait_code(i, "INVALID_INPUT")
        assert "filter info" in why and "speed filter" in why, why
        assert plan() and not through_zone(plan()), "the mask topic it had stays"
        # Not followed to the speed info's topic: an empty mask there opens nothing.
        probe = ros.node.create_publisher(OccupancyGrid, "/speed_filter_mask", LATCHED)
        probe.publish(zone_mask(0))
        ros.spin_for(1.5)
        assert probe.get_subscription_count() == 0, "the speed filter's mask topic is read"
        assert plan() and not through_zone(plan()), "the mask topic it had stays"

        # A new info: the first topic's mask stays in force until the second topic's arrives.
        info_pub.publish(info(0, "/keepout_second"))
        ros.spin_until(lambda: second.get_subscription_count() > 0, 20, "the node on the second topic")
        assert plan() and not through_zone(plan()), "the last good mask until the new topic's first"
        second.publish(zone_mask(0))
        ros.spin_until(lambda: through_zone(plan()), 20, "the way free under the second topic's empty mask")
        first.publish(zone_mask())
        ros.spin_for(1.0)
        assert through_zone(plan()), "the first topic no longer read"
    finally:
        ros.close()
        stop_binary(proc)
