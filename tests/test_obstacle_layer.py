"""The node's obstacle layer, as Nav2's global costmap runs its ObstacleLayer: a laser scan
(sensor_msgs/LaserScan on `scan`, in a `laser` frame placed on the robot through /tf_static)
that sees a block across the direct route gets plans that go round it, inflated as the map's
walls are; a later scan whose rays pass through where the block was clears it, and plans go
straight again. Returns beyond obstacle_max_range (2.5 m) mark nothing; a scan with numbers that
are not finite is skipped and the node goes on. costmap_2d's clearing services clear what the
scans marked, in their regions (a square round the robot, all but it), at once; so does a
recovery, the first of Nav2's round robin. A depth camera's sensor_msgs/PointCloud2 works the
same way, its floor and ceiling dropped by height; a scanner and a camera mark one layer."""
import contextlib
import math
import time

import numpy as np
import pytest
from nav_msgs.srv import GetPlan
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import LaserScan, PointCloud2, PointField

from conftest import ROOT, call_service, initial_pose, node_rig, stamped, static_transforms, transform
from test_node import grid_msg

# A 6 m x 3 m room (0.1 m cells, origin at 0, 0), empty. The robot at (0.5, 1.5) facing +x, its
# laser 0.1 m ahead of it; the block the laser sees: x 2.8-3.1 m, y 1.0-2.0 m.
START, GOAL = (0.5, 1.5), (5.5, 1.5)
LASER_X = START[0] + 0.1
BLOCK_X, BLOCK_Y = (2.8, 3.1), (1.0, 2.0)
RAYS = 181  # -90 .. 90 degrees, a degree apart
RATE_HZ = 10


def scan_ranges(block, span=BLOCK_Y):
    """Each ray's range: to the block's near face where it hits it (`block`; the face spans
    `span` in y), else 4 m (past obstacle_max_range, so the ray clears up to
    raytrace_max_range and marks nothing)."""
    ranges = []
    for i in range(RAYS):
        a = math.radians(-90 + i)
        hit = None
        if block and math.cos(a) > 1e-6:
            r = (BLOCK_X[0] - LASER_X) / math.cos(a)
            if span[0] <= START[1] + r * math.sin(a) <= span[1]:
                hit = r
        ranges.append(hit if hit is not None else 4.0)
    return ranges


class Sensor:
    """A sensor on the robot (`frame` on /tf_static at `xyz` from base_link) publishing at
    RATE_HZ, best effort as drivers do, what `reading()` makes, while `on`, stamped in
    `stamp_frame` (the driver's frame: its own unless told otherwise)."""

    def __init__(self, ros, kind, topic, frame, xyz, stamp_frame=None):
        self.ros, self.frame, self.stamp_frame, self.on = ros, frame, stamp_frame or frame, True
        self.pub = ros.node.create_publisher(kind, topic, QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT))
        ros.wait_matched(self.pub, topic)
        static_transforms(ros, transform("base_link", frame, xyz))
        ros.node.create_timer(1.0 / RATE_HZ, self.tick)

    def tick(self):
        if not self.on:
            return
        m = self.reading()
        m.header.stamp = self.ros.node.get_clock().now().to_msg()
        m.header.frame_id = self.stamp_frame
        self.pub.publish(m)


class Laser(Sensor):
    """A scan that sees the block while `block`, else one that does not; its angle increment
    NaN while `bad`."""

    def __init__(self, ros):
        self.block, self.bad, self.span = True, False, BLOCK_Y
        super().__init__(ros, LaserScan, "/scan", "laser", (0.1, 0.0, 0.2))

    def reading(self):
        m = LaserScan()
        m.angle_min, m.angle_max, m.angle_increment = -math.pi / 2, math.pi / 2, math.radians(1.0)
        m.range_min, m.range_max = 0.05, 10.0
        m.ranges = scan_ranges(self.block, self.span)
        if self.bad:
            m.angle_increment = float("nan")
        return m


@contextlib.contextmanager
def room(tmp_path, layer):
    """The node on the empty room, its obstacle layer set by `layer` (a YAML flow mapping), the
    robot at START."""
    params = tmp_path / "planner.yaml"
    params.write_text('patrol_planner:\n  ros__parameters:\n    map_yaml: ""\n    planner: astar\n'
                      f"    obstacle_layer: {layer}\n")
    # A domain away from the `ros` fixture's node and the other modules'.
    with node_rig(76, params, "obstacle_layer") as ros:
        ros.wait_matched(ros.map_pub, "/map")
        ros.wait_matched(ros.initial_pub, "/initialpose")
        ros.map_pub.publish(grid_msg(np.zeros((30, 60), dtype=np.int8), (0.0, 0.0), 0.1))
        ros.initial_pub.publish(initial_pose(*START))
        yield ros


@pytest.fixture
def rig(tmp_path):
    with room(tmp_path, "{update_frequency: 5.0}") as ros:
        yield ros, Laser(ros)


def plan(ros):
    req = GetPlan.Request(start=stamped(*START), goal=stamped(*GOAL), tolerance=0.0)
    return [(p.pose.position.x, p.pose.position.y)
            for p in call_service(ros, GetPlan, "/patrol_planner/make_plan", req).plan.poses]


def swerve(points):
    """How far the plan strays from the straight line y = 1.5 (m); None for no plan."""
    return max(abs(y - START[1]) for _, y in points) if points else None


def crosses_block(points):
    for (x0, y0), (x1, y1) in zip(points, points[1:]):
        for k in range(21):
            x, y = x0 + (x1 - x0) * k / 20, y0 + (y1 - y0) * k / 20
            if BLOCK_X[0] <= x <= BLOCK_X[1] and BLOCK_Y[0] <= y <= BLOCK_Y[1]:
                return True
    return False


def test_a_scanned_obstacle_is_planned_round_until_a_scan_clears_it(rig):
    from nav2_msgs.srv import ClearCostmapAroundRobot, ClearCostmapExceptRegion

    ros, laser = rig

    def goes_round():
        p = plan(ros)
        return p if (swerve(p) or 0) > 0.5 else None

    def goes_straight():
        p = plan(ros)
        return p if swerve(p) is not None and swerve(p) < 0.05 else None

    around = ros.spin_until(goes_round, 30, "a plan round the block the scan shows")
    assert not crosses_block(around)
    # Round it by the robot's inflated radius (0.45 m): through the gap above or below.
    assert swerve(around) > (BLOCK_Y[1] - START[1]) + 0.4, around
    # A scan with a NaN increment is skipped; the block stays as the last good scans left it.
    laser.bad = True
    ros.spin_for(1.0)
    assert goes_round()

    def stop_and_clear(srv, name, reset_distance):
        """The scans stop; costmap_2d's clearing service `name` clears what they marked."""
        laser.on, laser.bad = False, False
        ros.spin_for(0.3)
        call_service(ros, srv, f"/global_costmap/{name}_global_costmap", srv.Request(reset_distance=reset_distance))

    # A 1 m square round the robot (at 0.5, 1.5) leaves the block (2.8 m on) as it is; all but
    # that square clears it, and the next plan goes straight.
    stop_and_clear(ClearCostmapAroundRobot, "clear_around", 1.0)
    assert goes_round(), "the block is outside the square cleared"
    stop_and_clear(ClearCostmapExceptRegion, "clear_except", 1.0)
    assert goes_straight(), "the block is outside the square kept"

    # Seen again; a 6 m square round the robot takes the block in, and clears it.
    laser.on = True
    ros.spin_until(goes_round, 30, "a plan round the block seen again")
    stop_and_clear(ClearCostmapAroundRobot, "clear_around", 6.0)
    assert goes_straight(), "the block is inside the square cleared"

    # Seen again, then a scan whose rays pass where it was: round it, then straight again.
    laser.on = True
    ros.spin_until(goes_round, 30, "a plan round the block seen a third time")
    laser.block = False
    straight = ros.spin_until(goes_straight, 30, "a straight plan once the scan's rays pass where the block was")
    assert straight[-1] == pytest.approx(GOAL)


def test_the_layer_is_switched_off_and_on_at_run_time(rig):
    """`ros2 param set /patrol_planner obstacle_layer.enabled false`, as Nav2's ObstacleLayer
    takes it at run time (a lift, a dock the lidar would see as a wall): the next plans go
    straight through the block the laser still sees; the scans that come while it is off (the
    block gone) are passed over; set true, the block is back at once (what was seen before is
    kept). A value that is not a bool is refused, naming it; the parameter reads back as set."""
    from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
    from rcl_interfaces.srv import GetParameters, SetParameters

    ros, laser = rig

    def set_enabled(value):
        request = SetParameters.Request(parameters=[Parameter(name="obstacle_layer.enabled", value=value)])
        return call_service(ros, SetParameters, "/patrol_planner/set_parameters", request).results[0]

    def enabled():
        request = GetParameters.Request(names=["obstacle_layer.enabled"])
        return call_service(ros, GetParameters, "/patrol_planner/get_parameters", request).values[0].bool_value

    def straight():
        p = plan(ros)
        return p if swerve(p) is not None and swerve(p) < 0.05 else None

    ros.spin_until(lambda: goes_round(ros), 30, "a plan round the block the scan shows")
    assert set_enabled(ParameterValue(type=ParameterType.PARAMETER_BOOL, bool_value=False)).successful
    assert not enabled()
    ros.spin_until(straight, 10, "a straight plan with the layer off, the laser still on")
    # While off, the laser sees the block gone: those scans are passed over, not kept.
    laser.block = False
    ros.spin_for(1.5)
    assert straight(), "the layer stays off"
    refused = set_enabled(ParameterValue(type=ParameterType.PARAMETER_STRING, string_value="yes"))
    assert not refused.successful and "obstacle_layer.enabled" in refused.reason, refused
    laser.on = False
    ros.spin_for(0.3)
    assert set_enabled(ParameterValue(type=ParameterType.PARAMETER_BOOL, bool_value=True)).successful
    assert enabled()
    ros.spin_until(lambda: goes_round(ros), 10, "the block kept while off, laid again once on")
    ros.spin_for(1.0)
    assert goes_round(ros), "no scan taken while off clears it"


def test_a_recovery_clears_what_the_scans_marked(rig):
    """A wall the scan saw across the whole room (the person who stood there has gone out of
    the scanner's view): a /goal_pose beyond it finds no path, and its recovery, first of the
    round robin, clears the layer as Nav2's ClearingActions do; the goal is planned again."""
    ros, laser = rig
    laser.span = (0.0, 3.0)
    ros.spin_until(lambda: not plan(ros), 30, "no path through the wall the scan shows")
    laser.on = False
    ros.spin_for(0.3)
    assert not plan(ros), "the wall stays while nothing clears it"
    ros.wait_matched(ros.goal_pub, "/goal_pose")
    before = len(ros.plans)
    ros.goal_pub.publish(stamped(*GOAL))
    path = ros.spin_until(lambda: next((p for p in ros.plans[before:] if p.poses), None), 30,
                          "a /plan to the goal after the recovery")
    end = path.poses[-1].pose.position
    assert (end.x, end.y) == pytest.approx(GOAL)
    log = (ROOT / "target" / "patrol_planner_obstacle_layer_test.log").read_text()
    assert "recovery: the obstacles seen cleared" in log, log[-2000:]


class Camera(Sensor):
    """A depth camera 0.1 m ahead of the robot and 0.5 m up (`camera`): the map points in
    `points` as a sensor_msgs/PointCloud2 on /camera/points, stamped in `frame`."""

    def __init__(self, ros, frame="camera"):
        self.points, self.at = [], (LASER_X, START[1], 0.5)  # at: in the map
        super().__init__(ros, PointCloud2, "/camera/points", "camera", (0.1, 0.0, 0.5), frame)

    def reading(self):
        m = PointCloud2()
        in_camera = np.array(self.points, dtype="<f4").reshape(-1, 3) - np.array(self.at, dtype="<f4")
        m.height, m.width = 1, len(in_camera)
        m.fields = [PointField(name=n, offset=4 * i, datatype=PointField.FLOAT32, count=1) for i, n in enumerate("xyz")]
        m.is_bigendian, m.point_step, m.row_step, m.is_dense = False, 12, 12 * len(in_camera), True
        m.data = in_camera.tobytes()
        return m


def goes_round(ros):
    p = plan(ros)
    return p if (swerve(p) or 0) > 0.5 else None


def test_a_point_cloud_marks_what_lies_between_the_floor_and_the_ceiling(tmp_path):
    """A depth camera, the layer's one source (Nav2's `observation_sources: camera` and its
    block), sees the block's face as points from 0.1 m to 1.0 m high, a ceiling 2.3 m up across
    the whole room 0.6 m ahead (within obstacle_max_range: only max_obstacle_height, 2 m, keeps
    it from closing the room) and the floor up to the block, 2 cm below the robot's plane (only
    min_obstacle_height, 0, keeps it off the straight route): the plan goes round the block.
    Points far beyond it clear it (raytraced on the plane), and the plan goes straight."""
    layer = "{update_frequency: 5.0, observation_sources: camera, camera: {topic: /camera/points, data_type: PointCloud2}}"
    with room(tmp_path, layer) as ros:
        camera = Camera(ros)
        steps = np.linspace(0.0, 1.0, 21)
        block = [(BLOCK_X[0], BLOCK_Y[0] + (BLOCK_Y[1] - BLOCK_Y[0]) * a, 0.1 + 0.9 * b) for a in steps for b in steps]
        ceiling = [(1.2, 3.0 * a, 2.3) for a in steps]  # 2.4 m from the camera at most
        # The floor as a depth camera sees it, a little below the robot's plane (its noise).
        floor = [(LASER_X + 2.0 * a, START[1], -0.02) for a in steps[1:]]
        # Far beyond the block, spread so that the rays to them cross all of it.
        beyond = [(5.9, 0.2 + 2.6 * a, 0.5) for a in steps]
        camera.points = block + ceiling + floor
        around = ros.spin_until(lambda: goes_round(ros), 30, "a plan round the block the camera sees")
        assert not crosses_block(around)
        camera.points = beyond
        ros.spin_until(lambda: (lambda p: swerve(p) is not None and swerve(p) < 0.05)(plan(ros)), 30,
                       "a straight plan once the camera sees past where the block was")


def test_a_scanner_and_a_camera_mark_one_layer(tmp_path):
    """Two sources, as a Nav2 block lists them (`observation_sources: scan camera`): the laser
    sees the block across the direct route, and the plan goes round it on one side; then the
    camera, a source that marks and does not clear, whose driver stamps its clouds in the wrong
    frame (`sensor_frame: camera` corrects it) and whose obstacle_max_range (4 m) reaches past
    the laser's raytrace range, sees a wall 3.3 m ahead across that side. The plan goes round
    the other side: both sources' marks are in the one layer the grid is made from, and a low
    box the camera sees under the laser's rays stays marked through every update (clearing
    first, then marking, as Nav2's layer updates). When the camera goes quiet beyond its
    expected_update_rate the log says so, and plans fail with TIMEOUT after
    costmap_update_timeout, as planner_server's on a costmap that is not current, until it
    reads again."""
    from nav2_msgs.srv import GetCostmap

    layer = ("{update_frequency: 5.0, observation_sources: scan camera, "
             "camera: {topic: /camera/points, data_type: PointCloud2, clearing: false, "
             "sensor_frame: camera, obstacle_max_range: 4.0, expected_update_rate: 0.5}}")
    with room(tmp_path, layer) as ros:
        Laser(ros)
        camera = Camera(ros, frame="camera_driver_typo")
        first = ros.spin_until(lambda: goes_round(ros), 30, "a plan round the block the laser sees")
        side = 1 if max(y for _, y in first) > START[1] + 0.5 else -1
        # A wall 0.2 m thick at x 3.9-4.1 m (past the laser's 3 m: it cannot clear it), 0.1 m
        # to 1.0 m high, from the room's wall on the plan's side to 0.3 m past the middle: the
        # plan's way past the block is shut (inflated, it meets the block's inflation). The
        # camera's rays to it cross the block: were they to clear, the block would go.
        edge, far = (1.2, 3.0) if side > 0 else (0.0, 1.8)
        steps = np.linspace(0.0, 1.0, 21)
        wall = [(3.9 + 0.2 * t, edge + (far - edge) * a, 0.1 + 0.9 * b)
                for t in (0.0, 0.5, 1.0) for a in steps for b in steps]
        # A box 10 cm high at x 1.6 m on the straight line, below the laser's plane (0.2 m up):
        # the laser's rays, every tenth of a second, pass over its cell and clear it; the
        # camera's reading marks it again in each update, after every source's clearing.
        box = [(1.65, START[1], 0.05 + 0.05 * b) for b in steps]
        camera.points = wall + box

        def other_side():
            p = goes_round(ros)
            return p if p and all((y - START[1]) * side < 0.5 for _, y in p) else None

        other = ros.spin_until(other_side, 30, "a plan round the block on the other side of the camera's wall")
        assert not crosses_block(other)
        # getGlobalCostmap(): the laser's block face (x 2.8 m, cells 27-28) lethal all along;
        # the camera's wall (cells 39-40) lethal.
        cost = np.array(call_service(ros, GetCostmap, "global_costmap/get_costmap", GetCostmap.Request()).map.data,
                        dtype=np.uint8).reshape(30, 60)
        assert (cost[11:20, 27:29] == 254).any(axis=1).all(), cost[8:23, 26:30]
        assert (cost[round((edge + far) * 5), 39:41] == 254).any()
        for _ in range(5):  # the box, under the laser's rays, through several updates
            cost = np.array(call_service(ros, GetCostmap, "global_costmap/get_costmap", GetCostmap.Request()).map.data,
                            dtype=np.uint8).reshape(30, 60)
            # The box's cell: x 1.6-1.7 m, y 1.5 m on a cell's edge (row 14 or 15).
            assert (cost[14:16, 16] == 254).any(), cost[13:18, 14:19]
            ros.spin_for(0.3)
        log = ROOT / "target" / "patrol_planner_obstacle_layer_test.log"
        quiet = "obstacle_layer.camera (`/camera/points`): no reading for"
        before = log.read_text().count(quiet)  # the node may have started before the camera
        camera.on = False
        ros.spin_until(lambda: log.read_text().count(quiet) > before, 10,
                       "the log's word that the camera went quiet")
        # The costmap is not current: a plan waits costmap_update_timeout (1 s) for the camera,
        # then fails with TIMEOUT, as planner_server's does; with the camera back, the plan is
        # round its wall again (kept while it was quiet).
        started = time.time()
        assert plan(ros) == []
        assert time.time() - started >= 0.9
        stale = "no plan: the costmap is not current: obstacle_layer.camera (`/camera/points`): no reading for"
        ros.spin_until(lambda: stale in log.read_text(), 5, "the log's word why there is no plan")
        camera.on = True
        ros.spin_until(other_side, 10, "a plan round the camera's wall once the camera reads again")
