"""Serialises each message with rclpy (the reference implementation) and prints the CDR bytes as
Rust constants for golden.rs. Run from the repository root with the test venv:
    .venv/bin/python msgs/tests/make_golden.py > msgs/tests/data/golden_bytes.rs
The values here must match the ones golden.rs builds."""
from rclpy.serialization import serialize_message
from builtin_interfaces.msg import Time
from std_msgs.msg import Bool, Header, ColorRGBA, Empty, Float64MultiArray, MultiArrayDimension
from geometry_msgs.msg import (Point, Pose, PoseStamped, PoseWithCovarianceStamped, Quaternion,
                               Transform, TransformStamped, Twist, TwistStamped, Vector3)
from nav_msgs.msg import OccupancyGrid, Path, Odometry
from nav_msgs.srv import GetMap, GetPlan
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from visualization_msgs.msg import Marker, MarkerArray
from lifecycle_msgs.msg import State, Transition, TransitionDescription, TransitionEvent
from lifecycle_msgs.srv import ChangeState, GetAvailableTransitions, GetState
# nav2_msgs has no wheel: tests/build_interfaces.sh builds it into the venv first.
from nav2_msgs.action import (AssistedTeleop, BackUp, ComputePathThroughPoses, ComputePathToPose, FollowPath,
                              DriveOnHeading, FollowWaypoints, NavigateThroughPoses, NavigateToPose,
                              Spin, Wait)
from nav2_msgs.msg import MissedWaypoint
from nav2_msgs.srv import ClearCostmapAroundPose, ClearEntireCostmap, GetCostmap, IsPathValid, LoadMap
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Image, LaserScan, PointCloud2, PointField
from nav2_msgs.msg import Costmap, CostmapFilterInfo, CostmapMetaData, SpeedLimit


def header(frame="map"):
    h = Header()
    h.stamp = Time(sec=7, nanosec=500)
    h.frame_id = frame
    return h


def pose(x=1.5, y=-2.25):
    p = Pose()
    p.position = Point(x=x, y=y, z=0.125)
    p.orientation = Quaternion(x=0.0, y=0.0, z=0.6, w=0.8)
    return p


def pose_stamped(x=1.5, y=-2.25):
    return PoseStamped(header=header(), pose=pose(x, y))


def twist():
    return Twist(linear=Vector3(x=0.5, y=0.0, z=0.0), angular=Vector3(x=0.0, y=0.0, z=-0.25))


def messages():
    out = {}
    out["HEADER"] = header()
    out["POSE_STAMPED"] = pose_stamped()
    pwc = PoseWithCovarianceStamped(header=header())
    pwc.pose.pose = pose()
    pwc.pose.covariance = [i * 0.5 for i in range(36)]
    out["POSE_WITH_COVARIANCE_STAMPED"] = pwc
    out["TWIST"] = twist()
    out["TWIST_STAMPED"] = TwistStamped(header=header("base_link"), twist=twist())
    grid = OccupancyGrid(header=header())
    grid.info.map_load_time = Time(sec=3, nanosec=4)
    grid.info.resolution = 0.05
    grid.info.width = 3
    grid.info.height = 2
    grid.info.origin = pose(-10.0, -5.0)
    grid.data = [-1, 0, 100, 50, 0, -1]
    out["OCCUPANCY_GRID"] = grid
    out["PATH"] = Path(header=header(), poses=[pose_stamped(1.0, 2.0), pose_stamped(3.0, 4.0)])
    odom = Odometry(header=header("odom"), child_frame_id="base_link")
    odom.pose.pose = pose()
    odom.pose.covariance = [float(i) for i in range(36)]
    odom.twist.twist = twist()
    odom.twist.covariance = [-float(i) for i in range(36)]
    out["ODOMETRY"] = odom
    out["LASER_SCAN"] = LaserScan(header=header("laser"), angle_min=-1.5, angle_max=1.5, angle_increment=0.75,
                                  time_increment=0.001, scan_time=0.1, range_min=0.05, range_max=12.0,
                                  ranges=[1.0, 2.5, float("inf"), 0.25, 12.0], intensities=[])
    out["POINT_CLOUD2"] = PointCloud2(header=header("camera"), height=1, width=2,
                                      fields=[PointField(name="x", offset=0, datatype=7, count=1),
                                              PointField(name="y", offset=4, datatype=7, count=1),
                                              PointField(name="z", offset=8, datatype=7, count=1)],
                                      is_bigendian=False, point_step=12, row_step=24,
                                      data=bytes(range(24)), is_dense=True)
    out["IMAGE"] = Image(header=header("camera"), height=2, width=3, encoding="rgb8", is_bigendian=0,
                         step=9, data=bytes(range(18)))
    out["GET_PLAN_REQUEST"] = GetPlan.Request(start=pose_stamped(0.5, 0.5), goal=pose_stamped(9.5, 3.5), tolerance=0.25)
    out["GET_PLAN_RESPONSE"] = GetPlan.Response(plan=Path(header=header(), poses=[pose_stamped(0.5, 0.5)]))
    st = DiagnosticStatus(level=b'\x02', name="patrol_planner: plan", message="GOAL_OCCUPIED", hardware_id="",
                          values=[KeyValue(key="planner", value="astar"), KeyValue(key="seed", value="42")])
    out["DIAGNOSTIC_ARRAY"] = DiagnosticArray(header=header(), status=[st])
    m = Marker(header=header(), ns="pareto", id=3, type=Marker.LINE_STRIP, action=Marker.ADD, pose=pose())
    m.scale = Vector3(x=0.05, y=0.0, z=0.0)
    m.color = ColorRGBA(r=1.0, g=0.5, b=0.25, a=1.0)
    m.lifetime.sec = 2
    m.frame_locked = True
    m.points = [Point(x=1.0, y=2.0, z=0.0), Point(x=3.0, y=4.0, z=0.0)]
    m.text = "front"
    out["MARKER_ARRAY"] = MarkerArray(markers=[m])
    arr = Float64MultiArray(data=[1.5, -2.5])
    arr.layout.dim = [MultiArrayDimension(label="wheels", size=2, stride=2)]
    out["FLOAT64_MULTI_ARRAY"] = arr
    out["TRANSFORM_STAMPED"] = TransformStamped(
        header=header("odom"), child_frame_id="base_link",
        transform=Transform(translation=Vector3(x=1.5, y=-2.25, z=0.0), rotation=Quaternion(x=0.0, y=0.0, z=0.6, w=0.8)))
    out["TRANSITION_EVENT"] = TransitionEvent(
        timestamp=1234567890123, transition=Transition(id=3, label="activate"),
        start_state=State(id=2, label="inactive"), goal_state=State(id=3, label="active"))
    out["CHANGE_STATE_REQUEST"] = ChangeState.Request(transition=Transition(id=1, label="configure"))
    out["CHANGE_STATE_RESPONSE"] = ChangeState.Response(success=True)
    out["GET_STATE_REQUEST"] = GetState.Request()
    out["GET_STATE_RESPONSE"] = GetState.Response(current_state=State(id=3, label="active"))
    out["GET_AVAILABLE_TRANSITIONS_RESPONSE"] = GetAvailableTransitions.Response(available_transitions=[
        TransitionDescription(transition=Transition(id=4, label="deactivate"),
                              start_state=State(id=3, label="active"), goal_state=State(id=2, label="inactive"))])
    out["COMPUTE_PATH_TO_POSE_GOAL"] = ComputePathToPose.Goal(
        goal=pose_stamped(9.5, 3.5), start=pose_stamped(0.5, 0.5), planner_id="mocmcso", use_start=True)
    r = ComputePathToPose.Result(path=Path(header=header(), poses=[pose_stamped(0.5, 0.5)]), error_code=206,
                                 error_msg="goal occupied")
    r.planning_time.sec, r.planning_time.nanosec = 2, 500
    out["COMPUTE_PATH_RESULT"] = r
    out["COMPUTE_PATH_FEEDBACK"] = ComputePathToPose.Feedback()
    out["COMPUTE_PATH_THROUGH_POSES_GOAL"] = ComputePathThroughPoses.Goal(
        goals=[pose_stamped(1.0, 2.0), pose_stamped(3.0, 4.0)], start=pose_stamped(0.5, 0.5), planner_id="", use_start=False)
    out["IS_PATH_VALID_REQUEST"] = IsPathValid.Request(path=Path(header=header(), poses=[pose_stamped(1.0, 2.0)]))
    out["IS_PATH_VALID_RESPONSE"] = IsPathValid.Response(is_valid=False, invalid_pose_indices=[3, 7])
    out["FOLLOW_WAYPOINTS_GOAL"] = FollowWaypoints.Goal(
        number_of_loops=2, goal_index=1, poses=[pose_stamped(1.0, 2.0), pose_stamped(3.0, 4.0)])
    out["FOLLOW_WAYPOINTS_RESULT"] = FollowWaypoints.Result(
        missed_waypoints=[MissedWaypoint(index=1, goal=pose_stamped(3.0, 4.0), error_code=206)],
        error_code=0, error_msg="")
    out["FOLLOW_WAYPOINTS_FEEDBACK"] = FollowWaypoints.Feedback(current_waypoint=3)
    out["NAVIGATE_TO_POSE_GOAL"] = NavigateToPose.Goal(pose=pose_stamped(3.0, 4.0), behavior_tree="")
    out["NAVIGATE_TO_POSE_RESULT"] = NavigateToPose.Result(error_code=208, error_msg="no valid path")
    f = NavigateToPose.Feedback(current_pose=pose_stamped(1.0, 2.0), number_of_recoveries=0, distance_remaining=4.5)
    f.navigation_time.sec, f.navigation_time.nanosec = 3, 250
    f.estimated_time_remaining.sec, f.estimated_time_remaining.nanosec = 7, 500
    out["NAVIGATE_TO_POSE_FEEDBACK"] = f
    out["NAVIGATE_THROUGH_POSES_GOAL"] = NavigateThroughPoses.Goal(
        poses=[pose_stamped(1.0, 2.0), pose_stamped(3.0, 4.0)], behavior_tree="")
    out["NAVIGATE_THROUGH_POSES_RESULT"] = NavigateThroughPoses.Result(error_code=308, error_msg="no valid path")
    f = NavigateThroughPoses.Feedback(current_pose=pose_stamped(1.0, 2.0), number_of_recoveries=0,
                                      distance_remaining=4.5, number_of_poses_remaining=2)
    f.navigation_time.sec, f.navigation_time.nanosec = 3, 250
    f.estimated_time_remaining.sec, f.estimated_time_remaining.nanosec = 7, 500
    out["NAVIGATE_THROUGH_POSES_FEEDBACK"] = f
    g = Spin.Goal(target_yaw=1.5)
    g.time_allowance.sec, g.time_allowance.nanosec = 10, 20
    out["SPIN_GOAL"] = g
    r = Spin.Result(error_code=703, error_msg="collision ahead")
    r.total_elapsed_time.sec, r.total_elapsed_time.nanosec = 4, 30
    out["SPIN_RESULT"] = r
    out["SPIN_FEEDBACK"] = Spin.Feedback(angular_distance_traveled=0.75)
    g = BackUp.Goal(target=Point(x=0.3, y=0.0, z=0.0), speed=0.15)
    g.time_allowance.sec, g.time_allowance.nanosec = 10, 40
    out["BACKUP_GOAL"] = g
    r = BackUp.Result(error_code=714, error_msg="collision ahead")
    r.total_elapsed_time.sec, r.total_elapsed_time.nanosec = 2, 50
    out["BACKUP_RESULT"] = r
    out["BACKUP_FEEDBACK"] = BackUp.Feedback(distance_traveled=0.25)
    g = DriveOnHeading.Goal(target=Point(x=-0.5, y=0.0, z=0.0), speed=-0.2)
    g.time_allowance.sec, g.time_allowance.nanosec = 12, 90
    out["DRIVE_ON_HEADING_GOAL"] = g
    meta = CostmapMetaData(layer="master", resolution=0.05, size_x=3, size_y=2, origin=pose())
    meta.map_load_time.sec, meta.update_time.sec, meta.update_time.nanosec = 11, 12, 13
    out["GET_COSTMAP_RESPONSE"] = GetCostmap.Response(
        map=Costmap(header=header(), metadata=meta, data=[0, 1, 252, 253, 254, 255]))
    out["CLEAR_ENTIRE_COSTMAP_REQUEST"] = ClearEntireCostmap.Request()
    out["CLEAR_ENTIRE_COSTMAP_RESPONSE"] = ClearEntireCostmap.Response()
    out["CLEAR_COSTMAP_AROUND_POSE_REQUEST"] = ClearCostmapAroundPose.Request(
        pose=pose_stamped(1.0, 2.0), reset_distance=3.5)
    g = Wait.Goal()
    g.time.sec, g.time.nanosec = 5, 60
    out["WAIT_GOAL"] = g
    r = Wait.Result(error_code=0, error_msg="")
    r.total_elapsed_time.sec, r.total_elapsed_time.nanosec = 5, 70
    out["WAIT_RESULT"] = r
    f = Wait.Feedback()
    f.time_left.sec, f.time_left.nanosec = 3, 80
    out["WAIT_FEEDBACK"] = f
    g = AssistedTeleop.Goal()
    g.time_allowance.sec, g.time_allowance.nanosec = 30, 5
    out["ASSISTED_TELEOP_GOAL"] = g
    r = AssistedTeleop.Result(error_code=AssistedTeleop.Result.TIMEOUT, error_msg="past its time")
    r.total_elapsed_time.sec, r.total_elapsed_time.nanosec = 30, 6
    out["ASSISTED_TELEOP_RESULT"] = r
    f = AssistedTeleop.Feedback()
    f.current_teleop_duration.sec, f.current_teleop_duration.nanosec = 12, 7
    out["ASSISTED_TELEOP_FEEDBACK"] = f
    out["FOLLOW_PATH_GOAL"] = FollowPath.Goal(
        path=Path(header=header(), poses=[pose_stamped(1.0, 2.0), pose_stamped(3.0, 4.0)]),
        controller_id="FollowPath", goal_checker_id="general_goal_checker", progress_checker_id="")
    out["FOLLOW_PATH_RESULT"] = FollowPath.Result(error_code=FollowPath.Result.INVALID_PATH,
                                                  error_msg="through an obstacle")
    out["FOLLOW_PATH_FEEDBACK"] = FollowPath.Feedback(distance_to_goal=2.5, speed=0.375)
    out["SPEED_LIMIT"] = SpeedLimit(header=header(), percentage=True, speed_limit=42.5)
    out["LOAD_MAP_REQUEST"] = LoadMap.Request(map_url="/maps/floor2.yaml")
    grid = OccupancyGrid(header=header())
    grid.info.resolution, grid.info.width, grid.info.height = 0.05, 3, 1
    grid.info.origin = pose()
    grid.data = [0, 100, -1]
    out["LOAD_MAP_RESPONSE"] = LoadMap.Response(map=grid, result=LoadMap.Response.RESULT_INVALID_MAP_DATA)
    out["GET_MAP_REQUEST"] = GetMap.Request()
    out["GET_MAP_RESPONSE"] = GetMap.Response(map=grid)
    out["EMPTY"] = Empty()
    out["BOOL"] = Bool(data=True)
    clock = Clock()
    clock.clock.sec, clock.clock.nanosec = 1234, 500000000
    out["CLOCK"] = clock
    out["COSTMAP_FILTER_INFO"] = CostmapFilterInfo(
        header=header(), type=1, filter_mask_topic="/speed_filter_mask", base=100.0, multiplier=-1.0)
    return out


if __name__ == "__main__":
    print("// Generated by msgs/tests/make_golden.py from rclpy's serialize_message (ROS 2 Jazzy).")
    print("// Each constant is the CDR payload after rclpy's 4-byte encapsulation header.")
    for name, msg in messages().items():
        raw = serialize_message(msg)
        assert raw[:4] == b"\x00\x01\x00\x00", "expected little-endian CDR"
        print(f'pub const {name}: &str = "{raw[4:].hex()}";')
