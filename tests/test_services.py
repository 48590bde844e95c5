"""patrol_planner's services from outside, with rclpy's own clients (Fast DDS), as `ros2 service
call` and `ros2 param set` use them: GetPlan on /patrol_planner/make_plan (a plan well over one
datagram, so the reply is fragmented on the wire), the parameter services switching the planner
at run time and refusing bad values with a reason, the inflation set at run time and the costmap
the node publishes of it, and the node's own log lines on /rosout.
Runs after test_node.py, on the same node, and leaves the planner as it found it."""
import math

import numpy as np

from rcl_interfaces.msg import Log, Parameter, ParameterType, ParameterValue
from rcl_interfaces.srv import GetParameters, ListParameters, SetParameters
from rclpy.serialization import serialize_message
from nav_msgs.msg import OccupancyGrid, Odometry
from nav_msgs.srv import GetPlan
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from conftest import ROOT, TF, TF_STATIC, call_service, initial_pose, stamped, transform, yaw_quaternion
from test_node import ORIGIN, RES, H, W, assert_collision_free, plan_to, use_test_map, world

MAKE_PLAN = "/patrol_planner/make_plan"


def get_plan(ros, start, goal, tolerance=0.0):
    req = GetPlan.Request()
    req.start, req.goal, req.tolerance = stamped(*start), stamped(*goal), float(tolerance)
    return call_service(ros, GetPlan, MAKE_PLAN, req).plan


def set_param(ros, name, value):
    if isinstance(value, str):
        v = ParameterValue(type=ParameterType.PARAMETER_STRING, string_value=value)
    else:
        v = ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=float(value))
    req = SetParameters.Request(parameters=[Parameter(name=name, value=v)])
    return call_service(ros, SetParameters, "/patrol_planner/set_parameters", req).results[0]


def get_param(ros, name):
    return call_service(ros, GetParameters, "/patrol_planner/get_parameters", GetParameters.Request(names=[name])).values[0]


def test_get_plan_answers_with_a_collision_free_plan(ros):
    grid = use_test_map(ros)
    start, goal = world(1.0, 1.0), world(11.5, 7.0)
    plan = get_plan(ros, start, goal)
    assert plan.header.frame_id == "map" and plan.poses
    first, last = plan.poses[0].pose.position, plan.poses[-1].pose.position
    assert math.hypot(first.x - start[0], first.y - start[1]) < 1e-6, "the plan starts at the request's start"
    assert math.hypot(last.x - goal[0], last.y - goal[1]) < 1e-6, "the plan ends at the request's goal"
    assert max(p.pose.position.y for p in plan.poses) > ORIGIN[1] + 6.0, "the plan goes round the wall"
    assert_collision_free(plan, grid)
    # The reply went out in fragments (RustDDS fragments anything over ~1.4 KB): this is what
    # third_party/rustdds's patch makes work.
    assert len(serialize_message(GetPlan.Response(plan=plan))) > 4000


def test_get_plan_failure_is_an_empty_plan_with_its_code(ros):
    use_test_map(ros)
    i = len(ros.diagnostics)
    plan = get_plan(ros, world(1.0, 1.0), world(5.5, 3.0))  # inside the wall
    assert plan.poses == []
    ros.wait_code(i, "GOAL_OCCUPIED")
    i = len(ros.diagnostics)
    assert get_plan(ros, world(1.0, 1.0), (float("nan"), 0.0)).poses == []
    ros.wait_code(i, "INVALID_INPUT")
    # And the service keeps answering.
    assert get_plan(ros, world(1.0, 1.0), world(3.0, 6.0)).poses


def test_parameters_switch_the_planner_and_refuse_bad_values(ros):
    grid = use_test_map(ros)
    names = call_service(ros, ListParameters, "/patrol_planner/list_parameters", ListParameters.Request()).result.names
    assert {"planner", "max_planning_time", "tolerance"} <= set(names)
    default = get_param(ros, "planner").string_value
    assert default == "mocmcso", "config/planner.yaml's planner"
    try:
        for name in ["astar", "imga"]:
            assert set_param(ros, "planner", name).successful
            assert get_param(ros, "planner").string_value == name
            i = len(ros.diagnostics)
            path = plan_to(ros, world(11.0, 6.5))
            assert_collision_free(path, grid)
            _, _, values = ros.wait_code(i, "NONE")
            assert values["planner"] == name, "the next plan uses the planner just set"
        refused = set_param(ros, "planner", "no_such_planner")
        assert not refused.successful and "unknown planner" in refused.reason and "mocmcso" in refused.reason
        assert get_param(ros, "planner").string_value == "imga", "a refused value changes nothing"
        refused = set_param(ros, "max_planning_time", -1.0)
        assert not refused.successful and refused.reason
    finally:
        assert set_param(ros, "planner", default).successful


def test_the_inflation_set_at_run_time_reshapes_the_next_plan(ros):
    """`ros2 param set /patrol_planner costmap.safety_margin 0.5`, as a Nav2 user tunes costmap_2d's
    inflation live: the node makes its grid again and the next plan keeps the wider distance."""
    use_test_map(ros)
    names = call_service(ros, ListParameters, "/patrol_planner/list_parameters", ListParameters.Request()).result.names
    inflation = {"costmap.robot_radius", "costmap.safety_margin", "costmap.inflation_radius", "costmap.cost_scaling_factor"}
    assert inflation <= set(names)
    planner = get_param(ros, "planner").string_value
    margin = get_param(ros, "costmap.safety_margin").double_value
    assert margin == 0.2, "config/planner.yaml's safety_margin"
    start, goal = world(1.0, 1.0), world(11.5, 7.0)  # round the wall's end

    def min_clearance():
        i = len(ros.diagnostics)
        assert get_plan(ros, start, goal).poses
        _, _, values = ros.wait_code(i, "NONE")
        return float(values["min_clearance_m"])

    try:
        assert set_param(ros, "planner", "astar").successful  # A* grazes the inflated band
        tight = min_clearance()
        assert tight < 0.6, tight
        assert set_param(ros, "costmap.safety_margin", 0.5).successful
        wide = min_clearance()
        print(f"minimum clearance {tight:.3f} m -> {wide:.3f} m with the robot radius 0.25 + margin 0.5")
        assert wide >= 0.75 - 0.05, f"the next plan keeps 0.75 m off the walls, not {wide}"
        refused = set_param(ros, "costmap.inflation_radius", -1.0)
        assert not refused.successful and "`costmap.inflation_radius`" in refused.reason, refused.reason
        assert get_param(ros, "costmap.inflation_radius").double_value == 1.75, "a refused value changes nothing"
        assert set_param(ros, "costmap.safety_margin", margin).successful
        assert abs(min_clearance() - tight) < 1e-9, "the old margin gives the old plan back"
    finally:
        assert set_param(ros, "costmap.safety_margin", margin).successful
        assert set_param(ros, "planner", planner).successful


def test_the_planning_grid_is_published_as_a_costmap(ros):
    """/patrol_planner/costmap is the grid the planners weigh, as costmap_2d publishes a costmap (what
    RViz's "costmap" colour scheme draws): walls lethal (100), the inflated band inscribed (99), the
    graded costs below, unknown cells unknown (-1); a new inflation set at run time is published
    again, once made."""
    grid = use_test_map(ros)
    costmaps = []
    latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL, reliability=ReliabilityPolicy.RELIABLE)
    sub = ros.node.create_subscription(OccupancyGrid, "/patrol_planner/costmap", costmaps.append, latched)
    margin = get_param(ros, "costmap.safety_margin").double_value

    def test_map_costmaps(after):
        for c in costmaps[after:]:
            if (c.info.width, c.info.height) == (W, H):  # not an earlier test's map
                assert c.header.frame_id == "map" and abs(c.info.resolution - RES) < 1e-6
                assert (c.info.origin.position.x, c.info.origin.position.y) == ORIGIN
                yield np.array(c.data, dtype=np.int8).reshape(H, W)

    def costmap(after, ok, what):
        """The first costmap of the test map received after the `after`-th for which `ok` holds."""
        ros.spin_until(lambda: any(ok(c) for c in test_map_costmaps(after)), 20, what)
        return next(c for c in test_map_costmaps(after) if ok(c))

    try:
        first = costmap(0, lambda c: True, "the test map's costmap")
        assert set(np.unique(first)) <= {-1, *range(0, 101)}
        assert (first[grid == 100] == 100).all(), "the walls are lethal"
        assert (first[grid == -1] == -1).all(), "unknown cells stay unknown"
        inscribed = int((first == 99).sum())
        graded = (first > 0) & (first < 99)
        assert inscribed > 0 and graded.any() and (first == 0).any(), np.unique(first)
        # Along a row off the wall's right face (u 6.0 to 7.5, v 3.0): inscribed, then falling.
        row = first[int(3.0 / RES), int(6.0 / RES):int(7.5 / RES)]
        assert row[0] == 99 and row[-1] < row[6] and (np.diff(row.astype(int)) <= 0).all(), row
        n = len(costmaps)
        assert set_param(ros, "costmap.safety_margin", 0.5).successful
        costmap(n, lambda c: (c == 99).sum() > inscribed, "a costmap with the wider inscribed band")
        n = len(costmaps)
        assert set_param(ros, "costmap.safety_margin", margin).successful
        costmap(n, lambda c: (c == first).all(), "the old inflation's costmap back")
    finally:
        assert set_param(ros, "costmap.safety_margin", margin).successful
        ros.node.destroy_subscription(sub)


def test_the_nodes_own_log_lines_reach_rosout(ros):
    use_test_map(ros)
    logs = []
    ros.node.create_subscription(Log, "/rosout", logs.append, 100)
    ros.wait_matched(ros.goal_pub, "/goal_pose")

    def warned():
        ros.goal_pub.publish(stamped(*world(5.5, 3.0)))  # in the wall: the node logs a warning
        ros.spin_for(1.0)
        return next((m for m in logs if m.name == "patrol_planner" and m.level == Log.WARN and "GOAL_OCCUPIED" in m.msg), None)

    line = ros.spin_until(warned, 30, "a WARN from patrol_planner on /rosout")
    assert line.file.endswith(".rs") and line.line > 0


def test_goals_in_odom_and_base_link_are_carried_into_the_map(ros):
    """A goal stamped in `odom` goes through the node's map -> odom, one in `base_link` through
    the robot's pose (as planner_server transforms a goal to its global frame); another frame is
    TF_ERROR. map -> odom is made non-trivial first: odometry at (2, 0) in odom, then an initial
    pose at world(1, 1) facing +x, which anchors map -> odom = world(1, 1) - (2, 0). It is put
    back to the identity at the end (an initial pose at (2, 0)): the chassis tests that run on
    this node after it drive with odometry in the map frame."""
    use_test_map(ros)
    odom_pub = ros.node.create_publisher(Odometry, "/odom", 10)
    odometry = Odometry()
    odometry.header.frame_id = "odom"
    odometry.pose.pose.position.x = 2.0
    odometry.pose.pose.orientation.w = 1.0
    target = world(11.5, 7.0)

    def plan_in(frame, x, y, start=None):
        req = GetPlan.Request(goal=stamped(x, y, frame=frame), tolerance=0.0)
        if start is None:
            req.start.header.frame_id = ""  # from the robot's pose
        else:
            req.start = stamped(*start)
        return call_service(ros, GetPlan, MAKE_PLAN, req).plan

    def ends_at(plan, end, start=world(1.0, 1.0)):
        if not plan.poses:
            return False
        first, last = plan.poses[0].pose.position, plan.poses[-1].pose.position
        return (math.hypot(first.x - start[0], first.y - start[1]) < 1e-6
                and math.hypot(last.x - end[0], last.y - end[1]) < 1e-6)

    def anchor_at(x, y, then):
        odom_pub.publish(odometry)
        ros.spin_for(0.2)
        ros.initial_pub.publish(initial_pose(x, y))
        ros.spin_for(0.3)
        return then()

    try:
        ros.wait_matched(odom_pub, "/odom")
        # The target in odom: map -> odom is a shift by world(1, 1) - (2, 0).
        in_odom = (target[0] - world(1.0, 1.0)[0] + 2.0, target[1] - world(1.0, 1.0)[1])
        ros.spin_until(lambda: anchor_at(*world(1.0, 1.0), lambda: ends_at(plan_in("odom", *in_odom), target)),
                       30, "a goal in odom planned to its place in the map")
        # The robot is at world(1, 1) facing +x: the target is (10.5, 6) ahead and to the left.
        assert ends_at(plan_in("base_link", 10.5, 6.0), target)
        i = len(ros.diagnostics)
        assert not plan_in("camera_link", 1.0, 0.0).poses
        code, why, _ = ros.wait_code(i, "TF_ERROR")
        assert "`camera_link`" in why, why
    finally:
        # map -> odom back to the identity: odom's target is the map's again.
        ros.spin_until(lambda: anchor_at(2.0, 0.0, lambda: ends_at(plan_in("odom", *target, start=world(1.0, 1.0)), target)),
                       30, "map -> odom back to the identity")
        ros.node.destroy_publisher(odom_pub)


def test_goals_in_frames_of_the_tf_tree_are_placed_through_it(ros):
    """Goals stamped in frames the node knows only from /tf and /tf_static, as planner_server
    transforms them with tf2: a camera's optical frame two static steps under base_link (z ahead,
    x right, y down, as robot_state_publisher gives it; not named camera_link, which other
    tests on this node expect to be unknown), a docking frame fixed in the map, and a
    frame that moves on /tf, taken at the goal's stamp (interpolated between the transforms
    around it) or at the latest for stamp 0. A stamp the transforms do not reach, and a frame
    nothing publishes, are TF_ERROR once transform_tolerance has passed. The robot is at
    world(1, 1) facing +x (use_test_map); each goal below is world(11.5, 7) in its frame."""
    from tf2_msgs.msg import TFMessage

    use_test_map(ros)
    static_pub = ros.node.create_publisher(TFMessage, "/tf_static", TF_STATIC)
    tf_pub = ros.node.create_publisher(TFMessage, "/tf", TF)
    target = world(11.5, 7.0)

    def plan_in(frame, x, y, z=0.0, stamp=0.0):
        goal = stamped(x, y, frame=frame)
        goal.pose.position.z = float(z)
        goal.header.stamp.sec, goal.header.stamp.nanosec = int(stamp), int(round((stamp % 1) * 1e9))
        req = GetPlan.Request(goal=goal, tolerance=0.0)
        req.start.header.frame_id = ""  # from the robot's pose
        return call_service(ros, GetPlan, MAKE_PLAN, req).plan

    def ends_at_target(plan):
        if not plan.poses:
            return False
        last = plan.poses[-1].pose.position
        return math.hypot(last.x - target[0], last.y - target[1]) < 1e-6

    dock_yaw = math.pi / 2
    try:
        ros.wait_matched(static_pub, "/tf_static")
        ros.wait_matched(tf_pub, "/tf")
        static_pub.publish(TFMessage(transforms=[
            transform("base_link", "mast_camera", (0.2, 0.0, 0.5)),
            transform("mast_camera", "mast_camera_optical", (0.0, 0.0, 0.0), (-0.5, 0.5, -0.5, 0.5)),
            transform("map", "dock", (*world(11.5, 6.0), 0.0), yaw_quaternion(dock_yaw)),
        ]))
        # The dock faces +y: one metre ahead of it is the target.
        ros.spin_until(lambda: ends_at_target(plan_in("dock", 1.0, 0.0)), 20, "a goal in `dock` planned to its place")
        # 10.3 m along the optical axis, 6 m to its left (optical -x), at the floor (0.5 m below
        # the camera, optical +y): 10.5 m ahead of the robot and 6 m to its left.
        assert ends_at_target(plan_in("mast_camera_optical", -6.0, 0.5, z=10.3))
        # A cart moving along +y on /tf: at 1000 s at world(11.5, 5), at 1002 s at world(11.5, 9).
        tf_pub.publish(TFMessage(transforms=[transform("map", "cart", (*world(11.5, 5.0), 0.0), stamp=1000.0)]))
        tf_pub.publish(TFMessage(transforms=[transform("map", "cart", (*world(11.5, 9.0), 0.0), stamp=1002.0)]))
        ros.spin_until(lambda: ends_at_target(plan_in("cart", 0.0, 0.0, stamp=1001.0)), 20,
                       "a goal in `cart` stamped between its transforms, planned to the interpolated place")
        assert ends_at_target(plan_in("cart", 0.0, -2.0, stamp=0.0)), "stamp 0: the latest transform"
        for frame, stamp, why_has in [("cart", 1003.0, "not at 1003.000 s"), ("nowhere", 0.0, "`nowhere`")]:
            i = len(ros.diagnostics)
            assert not plan_in(frame, 0.0, 0.0, stamp=stamp).poses
            code, why, _ = ros.wait_code(i, "TF_ERROR")
            assert why_has in why, why
    finally:
        ros.node.destroy_publisher(static_pub)
        ros.node.destroy_publisher(tf_pub)


def test_load_map_switches_maps_as_map_server_does(ros, tmp_path):
    """The node loads its own map (`map_yaml`), so it serves map_server's `map_server/load_map`
    (nav2_simple_commander's changeMap()): another floor's map is loaded, latched on /map,
    returned and planned on at once; a missing file, a YAML with bad fields, an unreadable image
    and a URL that is not a path get map_server's result codes (1, 3, 2, 1), and the loaded map
    stays. The bundled map is loaded back at the end, by a file:// URL. All along,
    `map_server/map` (nav_msgs GetMap) answers with the map in force, as map_server does."""
    from nav2_msgs.srv import LoadMap
    from nav_msgs.srv import GetMap

    def served():
        return call_service(ros, GetMap, "/map_server/map", GetMap.Request()).map.info

    assert (served().width, served().height) == (100, 100), "GetMap before any load_map: the bundled map"

    # Another floor: 6 m x 3 m at 0.1 m, origin (-1, -2), a block across the middle, open at
    # the top (map_server's PGM: white free, black occupied; rows from the top).
    img = np.full((30, 60), 254, dtype=np.uint8)
    img[10:30, 28:32] = 0
    (tmp_path / "floor2.pgm").write_bytes(b"P5\n60 30\n255\n" + img.tobytes())
    yaml = "image: floor2.pgm\nresolution: 0.1\norigin: [-1.0, -2.0, 0.0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n"
    (tmp_path / "floor2.yaml").write_text(yaml)
    (tmp_path / "bad_fields.yaml").write_text(yaml.replace("resolution: 0.1", "resolution: -0.1"))
    (tmp_path / "bad_image.pgm").write_bytes(b"P5\n60 30\n255\n" + img.tobytes()[:100])
    (tmp_path / "bad_image.yaml").write_text(yaml.replace("floor2.pgm", "bad_image.pgm"))
    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    maps = []
    sub = ros.node.create_subscription(OccupancyGrid, "/map", maps.append, latched)

    def load(url):
        return call_service(ros, LoadMap, "/map_server/load_map", LoadMap.Request(map_url=url), timeout=30)

    def across():
        # From the left of the block to its right: over its top, inside the new map.
        return get_plan(ros, (-0.5, -1.5), (4.5, -1.5))

    try:
        r = load(str(tmp_path / "floor2.yaml"))
        assert r.result == LoadMap.Response.RESULT_SUCCESS
        info = r.map.info
        assert (info.width, info.height) == (60, 30) and abs(info.resolution - 0.1) < 1e-6, info
        assert (info.origin.position.x, info.origin.position.y) == (-1.0, -2.0)
        assert r.map.header.frame_id == "map" and list(r.map.data).count(100) == 20 * 4
        ros.spin_until(lambda: any(m.info.width == 60 and m.info.height == 30 for m in maps), 10, "the loaded map on /map")
        got = served()
        assert (got.width, got.height, got.origin.position.x) == (60, 30, -1.0), got
        path = across()
        assert path.poses, "no plan on the loaded map"
        assert max(p.pose.position.y for p in path.poses) > -2.0 + 2.0, "the plan went through the block"
        assert all(-1.0 <= p.pose.position.x <= 5.0 and -2.0 <= p.pose.position.y <= 1.0 for p in path.poses)

        for url, code in [
            (str(tmp_path / "absent.yaml"), LoadMap.Response.RESULT_MAP_DOES_NOT_EXIST),
            (str(tmp_path / "bad_fields.yaml"), LoadMap.Response.RESULT_INVALID_MAP_METADATA),
            (str(tmp_path / "bad_image.yaml"), LoadMap.Response.RESULT_INVALID_MAP_DATA),
            ("package://patrol/maps/floor2.yaml", LoadMap.Response.RESULT_MAP_DOES_NOT_EXIST),
        ]:
            assert load(url).result == code, url
            assert across().poses, f"the loaded map did not stay after {url}"
        assert (served().width, served().height) == (60, 30), "GetMap after refused loads: the loaded map"
    finally:
        r = load("file://" + str(ROOT / "config" / "maps" / "datacenter_100.yaml"))
        ros.node.destroy_subscription(sub)
    assert r.result == LoadMap.Response.RESULT_SUCCESS
    assert (r.map.info.width, r.map.info.height) == (100, 100)
    assert (served().width, served().height) == (100, 100)
