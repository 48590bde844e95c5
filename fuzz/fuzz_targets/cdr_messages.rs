//! CDR (little endian, after the 4-byte encapsulation header, as RustDDS hands it to serde) of
//! every message the node and chassis_bridge subscribe to or serve. The first byte chooses the
//! type, the rest is the payload.
//!
//! Checked: a decoded message re-encodes, and that encoding decodes to the same encoding again
//! (byte-for-byte, so NaN payloads compare too); decoding never reads past the input; for
//! OccupancyGrid the node's conversion into a grid (`grid_from_msg` in crates/planner-node's
//! convert.rs, a binary crate, mirrored here) never yields a grid past the cell cap or of another
//! size than the message's data.
#![no_main]

use byteorder::LittleEndian;
use libfuzzer_sys::fuzz_target;
use patrol_msgs::geometry_msgs::{
    PoseStamped, PoseWithCovarianceStamped, Quaternion, Twist, TwistStamped,
};
use patrol_msgs::lifecycle_msgs::ChangeStateRequest;
use patrol_msgs::map_msgs::OccupancyGridUpdate;
use patrol_msgs::nav2_msgs::{
    BackUpGoal, ClearCostmapAroundPoseRequest, ClearCostmapAroundRobotRequest,
    ClearCostmapExceptRegionRequest, ClearEntireCostmapRequest, ComputePathThroughPosesGoal, ComputePathToPoseGoal, CostmapFilterInfo,
    DriveOnHeadingGoal, FollowPathGoal, FollowWaypointsGoal, GetCostmapRequest, IsPathValidRequest,
    LoadMapRequest, NavigateThroughPosesGoal, NavigateToPoseGoal, SpeedLimit, SpinGoal, WaitGoal,
};
use patrol_msgs::nav_msgs::{GetMapRequest, GetPlanRequest, OccupancyGrid, Odometry};
use patrol_msgs::sensor_msgs::{Image, LaserScan, PointCloud2};
use patrol_msgs::tf2_msgs::TFMessage;
use planner_core::geometry::Pose2;
use planner_core::grid::map::DEFAULT_MAX_CELLS;
use planner_core::grid::{GridMap, MapError, MapInfo};
use serde::{de::DeserializeOwned, Serialize};

fn round_trip<T: Serialize + DeserializeOwned>(bytes: &[u8]) -> Option<T> {
    let (msg, used) = cdr_encoding::from_bytes::<T, LittleEndian>(bytes).ok()?;
    assert!(used <= bytes.len(), "read {used} of {} bytes", bytes.len());
    let ours = cdr_encoding::to_vec::<T, LittleEndian>(&msg).expect("a decoded message encodes");
    let (back, _) =
        cdr_encoding::from_bytes::<T, LittleEndian>(&ours).expect("our encoding decodes");
    let again = cdr_encoding::to_vec::<T, LittleEndian>(&back).unwrap();
    assert_eq!(ours, again, "encoding is not stable");
    Some(msg)
}

/// convert.rs's `yaw_from_quaternion` (the node refuses a quaternion it cannot normalise).
fn yaw(q: &Quaternion) -> Option<f64> {
    let n = (q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w).sqrt();
    if !n.is_finite() || n < 1e-9 {
        return None;
    }
    let (x, y, z, w) = (q.x / n, q.y / n, q.z / n, q.w / n);
    Some((2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z)))
}

/// convert.rs's `grid_from_msg`.
fn grid_from_msg(msg: &OccupancyGrid) -> Result<GridMap, MapError> {
    let p = &msg.info.origin.position;
    if !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite()) {
        return Err(MapError::Format("map origin is not finite".into()));
    }
    let yaw = yaw(&msg.info.origin.orientation)
        .ok_or_else(|| MapError::Format("map origin: bad quaternion".into()))?;
    let info = MapInfo {
        width: msg.info.width,
        height: msg.info.height,
        resolution: msg.info.resolution as f64,
        origin: Pose2::new(p.x, p.y, yaw),
    };
    GridMap::new(info, msg.data.clone())
}

fuzz_target!(|data: &[u8]| {
    let Some((&selector, payload)) = data.split_first() else {
        return;
    };
    match selector % 33 {
        0 => {
            if let Some(msg) = round_trip::<OccupancyGrid>(payload) {
                assert!(msg.data.len() <= payload.len());
                if let Ok(grid) = grid_from_msg(&msg) {
                    let cells = grid.width() as u64 * grid.height() as u64;
                    assert!(cells <= DEFAULT_MAX_CELLS);
                    assert_eq!(cells, msg.data.len() as u64);
                }
            }
        }
        1 => drop(round_trip::<GetPlanRequest>(payload)),
        2 => drop(round_trip::<Odometry>(payload)),
        3 => drop(round_trip::<PoseStamped>(payload)),
        4 => drop(round_trip::<PoseWithCovarianceStamped>(payload)),
        5 => drop(round_trip::<Twist>(payload)),
        6 => drop(round_trip::<TwistStamped>(payload)),
        7 => {
            if let Some(tf) = round_trip::<TFMessage>(payload) {
                assert!(tf.transforms.len() <= payload.len());
            }
        }
        8 => drop(round_trip::<ComputePathToPoseGoal>(payload)),
        9 => {
            if let Some(goal) = round_trip::<ComputePathThroughPosesGoal>(payload) {
                assert!(goal.goals.len() <= payload.len());
            }
        }
        10 => {
            if let Some(req) = round_trip::<IsPathValidRequest>(payload) {
                assert!(req.path.poses.len() <= payload.len());
            }
        }
        11 => {
            if let Some(u) = round_trip::<OccupancyGridUpdate>(payload) {
                assert!(u.data.len() <= payload.len());
            }
        }
        12 => drop(round_trip::<NavigateToPoseGoal>(payload)),
        13 => {
            if let Some(goal) = round_trip::<NavigateThroughPosesGoal>(payload) {
                assert!(goal.poses.len() <= payload.len());
            }
        }
        14 => {
            if let Some(goal) = round_trip::<FollowWaypointsGoal>(payload) {
                assert!(goal.poses.len() <= payload.len());
            }
        }
        15 => drop(round_trip::<SpinGoal>(payload)),
        16 => drop(round_trip::<BackUpGoal>(payload)),
        17 => drop(round_trip::<DriveOnHeadingGoal>(payload)),
        18 => drop(round_trip::<WaitGoal>(payload)),
        19 => drop(round_trip::<GetCostmapRequest>(payload)),
        20 => {
            if let Some(req) = round_trip::<LoadMapRequest>(payload) {
                assert!(req.map_url.len() <= payload.len());
            }
        }
        21 => drop(round_trip::<SpeedLimit>(payload)),
        22 => drop(round_trip::<GetMapRequest>(payload)),
        23 => {
            if let Some(info) = round_trip::<CostmapFilterInfo>(payload) {
                assert!(info.filter_mask_topic.len() <= payload.len());
            }
        }
        24 => {
            if let Some(goal) = round_trip::<FollowPathGoal>(payload) {
                assert!(goal.path.poses.len() <= payload.len());
            }
        }
        25 => drop(round_trip::<ChangeStateRequest>(payload)),
        26 => drop(round_trip::<ClearEntireCostmapRequest>(payload)),
        27 => drop(round_trip::<ClearCostmapAroundRobotRequest>(payload)),
        28 => drop(round_trip::<ClearCostmapExceptRegionRequest>(payload)),
        29 => drop(round_trip::<ClearCostmapAroundPoseRequest>(payload)),
        30 => {
            if let Some(scan) = round_trip::<LaserScan>(payload) {
                assert!(scan.ranges.len() + scan.intensities.len() <= payload.len());
            }
        }
        31 => {
            if let Some(frame) = round_trip::<Image>(payload) {
                assert!(frame.data.len() + frame.encoding.len() <= payload.len());
            }
        }
        _ => {
            if let Some(cloud) = round_trip::<PointCloud2>(payload) {
                assert!(cloud.data.len() + cloud.fields.len() <= payload.len());
            }
        }
    }
});
