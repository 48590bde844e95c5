//! Conversions between ROS messages and planner-core, as free functions (Nav2's planner plugins
//! keep the same split): frames and quaternions checked here, paths densified, failures mapped to
//! the Nav2 result code names that `/diagnostics` reports.

use crate::result::{Failure, ResultCode};
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3 as Vector3n};
use patrol_msgs::builtin_interfaces::{Duration, Time};
use patrol_msgs::diagnostic_msgs::{DiagnosticArray, DiagnosticStatus, KeyValue};
use patrol_msgs::geometry_msgs::{Point, Pose, PoseStamped, Quaternion, Transform, Twist, Vector3};
use patrol_msgs::map_msgs::OccupancyGridUpdate;
use patrol_msgs::nav2_msgs::{Costmap, CostmapMetaData};
use patrol_msgs::nav_msgs::{MapMetaData, OccupancyGrid, Path};
use patrol_msgs::sensor_msgs::PointCloud2;
use patrol_msgs::std_msgs::{ColorRGBA, Header};
use patrol_msgs::visualization_msgs::{Marker, MarkerArray};
use planner_core::geometry::{Point2, Pose2};
use planner_core::grid::inflation::occupancy_from_cost;
use planner_core::grid::{GridMap, MapError, MapInfo, PlanningGrid};
use planner_core::planner::Plan;
use planner_core::PlannerName;
use ros_edge::quaternion_from_yaw;

/// The heading of a quaternion (rotation about z), normalising it first. A quaternion that is
/// not finite or has (almost) zero length is refused.
pub fn yaw_from_quaternion(q: &Quaternion) -> Result<f64, Failure> {
    let n = (q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w).sqrt();
    if !n.is_finite() || n < 1e-9 {
        return Err(Failure::new(
            ResultCode::InvalidInput,
            format!(
                "quaternion ({}, {}, {}, {}) cannot be normalised",
                q.x, q.y, q.z, q.w
            ),
        ));
    }
    Ok(yaw_of_unit(q.x / n, q.y / n, q.z / n, q.w / n))
}

/// The heading (rotation about z) of the unit quaternion (x, y, z, w).
fn yaw_of_unit(x: f64, y: f64, z: f64, w: f64) -> f64 {
    (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z))
}

/// Position and heading of a stamped pose in the global frame: the frame must be the global one
/// or empty (Nav2 treats empty as the global frame), the numbers finite.
pub fn pose_in_frame(msg: &PoseStamped, global_frame: &str) -> Result<Pose2, Failure> {
    let frame = frame_name(&msg.header.frame_id);
    if !frame.is_empty() && frame != global_frame {
        return Err(Failure::new(
            ResultCode::TfError,
            format!("pose is in frame `{frame}`; this node plans in `{global_frame}` and has no transform from `{frame}`"),
        ));
    }
    pose2(&msg.pose)
}

/// A frame id without the one leading slash ROS 1 allowed (`/map` is `map`). Only one: a
/// frame id of a million slashes and `map` is no frame's name, and is refused as unknown at
/// once instead of being carried, a megabyte a copy, into every missed waypoint of a patrol.
pub fn frame_name(frame_id: &str) -> &str {
    frame_id.strip_prefix('/').unwrap_or(frame_id)
}

/// A header stamp in seconds.
pub fn seconds(t: &Time) -> f64 {
    f64::from(t.sec) + f64::from(t.nanosec) * 1e-9
}

/// A pose's position and heading, refusing NaN and infinities.
pub fn pose2(p: &Pose) -> Result<Pose2, Failure> {
    let (x, y) = (p.position.x, p.position.y);
    if !(x.is_finite() && y.is_finite() && p.position.z.is_finite()) {
        return Err(Failure::new(
            ResultCode::InvalidInput,
            format!("position ({x}, {y}, {}) is not finite", p.position.z),
        ));
    }
    Ok(Pose2::new(x, y, yaw_from_quaternion(&p.orientation)?))
}

/// A pose in three dimensions (a pose in a camera's or another tilted frame is carried through
/// its frame's rotation whole before it is laid on the plane), refusing what [`pose2`] refuses.
pub fn pose3(p: &Pose) -> Result<Isometry3<f64>, Failure> {
    pose2(p)?;
    let q = &p.orientation;
    Ok(Isometry3::from_parts(
        Translation3::new(p.position.x, p.position.y, p.position.z),
        UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(q.w, q.x, q.y, q.z)),
    ))
}

/// A planar pose as a transform in three dimensions (about z, at height 0).
pub fn iso3(p: Pose2) -> Isometry3<f64> {
    Isometry3::new(Vector3n::new(p.x, p.y, 0.0), Vector3n::z() * p.yaw)
}

/// A transform laid on the plane: its position's x and y, its heading (rotation about z).
pub fn planar(t: &Isometry3<f64>) -> Pose2 {
    let q = t.rotation.quaternion();
    Pose2::new(
        t.translation.x,
        t.translation.y,
        yaw_of_unit(q.i, q.j, q.k, q.w),
    )
}

/// A transform's planar part (translation and heading), refusing NaN and infinities.
pub fn transform2(t: &Transform) -> Result<Pose2, Failure> {
    let v = &t.translation;
    if !(v.x.is_finite() && v.y.is_finite() && v.z.is_finite()) {
        return Err(Failure::new(
            ResultCode::InvalidInput,
            format!("translation ({}, {}, {}) is not finite", v.x, v.y, v.z),
        ));
    }
    Ok(Pose2::new(v.x, v.y, yaw_from_quaternion(&t.rotation)?))
}

/// costmap_2d's partial update (`<costmap>_updates`, map_msgs/OccupancyGridUpdate) written into
/// the full costmap it belongs to: its window of cells, row by row, as Nav2's own
/// CostmapSubscriber applies it. A window that does not lie inside the costmap, or whose data is
/// not its size, is refused and the costmap left as it was.
pub fn apply_update(costmap: &mut OccupancyGrid, u: &OccupancyGridUpdate) -> Result<(), String> {
    let (w, h) = (
        u64::from(costmap.info.width),
        u64::from(costmap.info.height),
    );
    let (uw, uh) = (u64::from(u.width), u64::from(u.height));
    let inside = u.x >= 0
        && u.y >= 0
        && u.x as u64 + uw <= w
        && u.y as u64 + uh <= h
        && costmap.data.len() as u64 == w * h;
    if !inside {
        return Err(format!(
            "update window {}x{} at ({}, {}) is not inside the {w}x{h} costmap",
            u.width, u.height, u.x, u.y
        ));
    }
    if u.data.len() as u64 != uw * uh {
        return Err(format!(
            "update window {}x{} carries {} cells",
            u.width,
            u.height,
            u.data.len()
        ));
    }
    let (x, y, uw) = (u.x as usize, u.y as usize, uw as usize);
    for (row, cells) in u.data.chunks_exact(uw.max(1)).enumerate() {
        let start = (y + row) * w as usize + x;
        costmap.data[start..start + uw].copy_from_slice(cells);
    }
    Ok(())
}

/// A received map, validated like every other map.
pub fn grid_from_msg(msg: &OccupancyGrid) -> Result<GridMap, MapError> {
    let origin = pose2(&msg.info.origin)
        .map_err(|f| MapError::Format(format!("map origin: {}", f.message)))?;
    let info = MapInfo {
        width: msg.info.width,
        height: msg.info.height,
        resolution: msg.info.resolution as f64,
        origin,
    };
    GridMap::new(info, msg.data.clone())
}

/// The map as a message (what the node publishes when it loads `map_yaml` itself).
pub fn msg_from_grid(map: &GridMap, frame: &str, stamp: Time) -> OccupancyGrid {
    grid_msg(map.info(), frame, stamp, map.data().to_vec())
}

/// The planning grid as costmap_2d publishes its costmap: each cell's cost through
/// costmap_2d's translation table (lethal 100, inscribed 99, the graded costs 1..98, free 0),
/// and the cells `unknown(i)` says nothing is known of -1, as costmap_2d marks them with
/// `track_unknown_space` (Nav2's default for the global costmap). RViz's "costmap" colour
/// scheme draws it: a user sees the obstacles and inflation the planners weigh, as Nav2 users
/// look at `/global_costmap/costmap`.
pub fn costmap_msg(
    info: &MapInfo,
    grid: &PlanningGrid,
    unknown: impl Fn(usize) -> bool,
    frame: &str,
    stamp: Time,
) -> OccupancyGrid {
    let data = grid
        .costs()
        .iter()
        .enumerate()
        .map(|(i, &cost)| {
            if unknown(i) {
                -1
            } else {
                occupancy_from_cost(cost)
            }
        })
        .collect();
    grid_msg(info, frame, stamp, data)
}

/// The planning grid as costmap_2d's GetCostmap service answers (nav2_msgs/Costmap, Nav2's
/// `getGlobalCostmap()`): each cell's own cost on costmap_2d's scale, and the cells
/// `unknown(i)` says nothing is known of 255 (NO_INFORMATION), as the global costmap tracks
/// unknown space; the layer `master`.
pub fn costmap_costs(
    info: &MapInfo,
    grid: &PlanningGrid,
    unknown: impl Fn(usize) -> bool,
    frame: &str,
    stamp: Time,
) -> Costmap {
    let data = (0..grid.costs().len())
        .map(|i| cost_of(grid, &unknown, i))
        .collect();
    costmap(info, frame, stamp, data)
}

/// The most cells a side of [`costmap_window`] holds: 4096 x 4096 cells (16 MB) however small
/// the map's cells, so a wide window on a fine map cannot exhaust memory.
pub const MAX_WINDOW_CELLS: i64 = 4096;

/// The part of the planning grid a rolling-window costmap of `width` x `height` metres around
/// `centre` holds, as costmap_2d's local costmap keeps one round the robot: the window's cells
/// are the grid's (its origin on a grid cell's corner, `centre` in its middle cell), each
/// cell's cost as [`costmap_costs`] gives it, NO_INFORMATION off the map. A side has
/// `size / resolution` cells, rounded, 1 to [`MAX_WINDOW_CELLS`].
#[allow(clippy::too_many_arguments)]
pub fn costmap_window(
    info: &MapInfo,
    grid: &PlanningGrid,
    unknown: impl Fn(usize) -> bool,
    centre: Point2,
    (width, height): (f64, f64),
    frame: &str,
    stamp: Time,
) -> Costmap {
    let cells =
        |metres: f64| ((metres / info.resolution).round() as i64).clamp(1, MAX_WINDOW_CELLS);
    let (nx, ny) = (cells(width), cells(height));
    let g = info.world_to_grid(centre);
    // A non-finite centre casts to 0: a window at the map's corner, never a panic. A centre a
    // trillion cells off the map (a pose of 1e300 m is finite) is held there, where the window
    // is all off the map as it would be farther out, so `x0 + nx` cannot overflow.
    const FAR: i64 = 1 << 40;
    let x0 = ((g.x - nx as f64 / 2.0).floor() as i64).clamp(-FAR, FAR);
    let y0 = ((g.y - ny as f64 / 2.0).floor() as i64).clamp(-FAR, FAR);
    let (w, h) = (i64::from(info.width), i64::from(info.height));
    let mut data = Vec::with_capacity((nx * ny) as usize);
    for y in y0..y0 + ny {
        for x in x0..x0 + nx {
            data.push(if (0..w).contains(&x) && (0..h).contains(&y) {
                cost_of(grid, &unknown, (y * w + x) as usize)
            } else {
                NO_INFORMATION
            });
        }
    }
    let corner = info.grid_to_world(Point2::new(x0 as f64, y0 as f64));
    let window = MapInfo {
        width: nx as u32,
        height: ny as u32,
        resolution: info.resolution,
        origin: Pose2 {
            x: corner.x,
            y: corner.y,
            yaw: info.origin.yaw,
        },
    };
    costmap(&window, frame, stamp, data)
}

/// Cell `i`'s cost on costmap_2d's scale, NO_INFORMATION where nothing is known of it.
fn cost_of(grid: &PlanningGrid, unknown: impl Fn(usize) -> bool, i: usize) -> u8 {
    if unknown(i) {
        NO_INFORMATION
    } else {
        grid.costs()[i]
    }
}

/// A nav2_msgs/Costmap of `data` (row-major) over the cells `info` describes, layer `master`.
fn costmap(info: &MapInfo, frame: &str, stamp: Time, data: Vec<u8>) -> Costmap {
    let grid = grid_msg(info, frame, stamp, Vec::new());
    Costmap {
        header: grid.header,
        metadata: CostmapMetaData {
            map_load_time: stamp,
            update_time: stamp,
            layer: "master".into(),
            resolution: grid.info.resolution,
            size_x: grid.info.width,
            size_y: grid.info.height,
            origin: grid.info.origin,
        },
        data,
    }
}

/// costmap_2d's cost of a cell nothing is known of.
const NO_INFORMATION: u8 = 255;

/// An OccupancyGrid of `data` (row-major) over the cells `info` describes.
fn grid_msg(info: &MapInfo, frame: &str, stamp: Time, data: Vec<i8>) -> OccupancyGrid {
    OccupancyGrid {
        header: Header {
            stamp,
            frame_id: frame.into(),
        },
        info: MapMetaData {
            map_load_time: stamp,
            resolution: info.resolution as f32,
            width: info.width,
            height: info.height,
            origin: Pose {
                position: Point {
                    x: info.origin.x,
                    y: info.origin.y,
                    z: 0.0,
                },
                orientation: quaternion_from_yaw(info.origin.yaw),
            },
        },
        data,
    }
}

/// A plan as nav_msgs/Path: densified to one pose per `spacing` metres (Nav2's planners publish
/// dense paths and its controllers expect them), each pose facing along the path, the last one
/// with the goal's heading.
pub fn path_msg(waypoints: &[Point2], goal_yaw: f64, spacing: f64, header: Header) -> Path {
    // Densification is bounded whatever the spacing asked for: at most about MAX_PATH_POSES
    // poses (plus one per waypoint).
    let total: f64 = waypoints.windows(2).map(|w| (w[1] - w[0]).norm()).sum();
    let spacing = if spacing.is_finite() && spacing > 0.0 {
        spacing
    } else {
        total
    };
    let spacing = spacing.max(total / MAX_PATH_POSES as f64);
    let mut points: Vec<Point2> = Vec::new();
    for w in waypoints.windows(2) {
        let d = w[1] - w[0];
        let steps = ((d.norm() / spacing).ceil() as usize).max(1);
        points.extend((0..steps).map(|k| w[0] + d * (k as f64 / steps as f64)));
    }
    points.extend(waypoints.last());
    let poses = points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let yaw = match points.get(i + 1) {
                Some(n) if i + 1 < points.len() => (n.y - p.y).atan2(n.x - p.x),
                _ => goal_yaw,
            };
            pose_stamped(Pose2::new(p.x, p.y, yaw), header.clone())
        })
        .collect();
    Path { header, poses }
}

/// An operator's Twist as a differential drive's command: its forward speed and yaw rate (the
/// rest it cannot do); a command with a NaN or infinite part is a stop.
pub fn twist2(t: &Twist) -> chassis::Twist2 {
    let (linear, angular) = (t.linear.x, t.angular.z);
    if linear.is_finite() && angular.is_finite() {
        chassis::Twist2 { linear, angular }
    } else {
        chassis::Twist2::STOP
    }
}

/// A planar pose as the chassis crate's follower, progress checker and motions take it.
pub fn chassis_pose(p: Pose2) -> chassis::Pose {
    chassis::Pose {
        x: p.x,
        y: p.y,
        yaw: p.yaw,
    }
}

/// A planar pose as geometry_msgs/PoseStamped.
pub fn pose_stamped(p: Pose2, header: Header) -> PoseStamped {
    PoseStamped {
        header,
        pose: Pose {
            position: Point {
                x: p.x,
                y: p.y,
                z: 0.0,
            },
            orientation: quaternion_from_yaw(p.yaw),
        },
    }
}

/// A duration as builtin_interfaces/Duration.
pub fn duration_msg(d: std::time::Duration) -> Duration {
    Duration {
        sec: i32::try_from(d.as_secs()).unwrap_or(i32::MAX),
        nanosec: d.subsec_nanos(),
    }
}

/// The most poses (about) a published path holds: a 5 km patrol at 5 cm spacing. A longer or
/// finer plan is spaced more widely instead of exhausting memory.
pub const MAX_PATH_POSES: usize = 100_000;

/// One `/diagnostics` status per request: the result code, the reason and the figures.
pub fn diagnostics(
    header: Header,
    planner: PlannerName,
    seed: u64,
    outcome: Result<&Plan, &Failure>,
    elapsed_ms: f64,
) -> DiagnosticArray {
    let kv = |k: &str, v: String| KeyValue {
        key: k.into(),
        value: v,
    };
    let mut values = vec![
        kv("planner", planner.to_string()),
        kv("seed", seed.to_string()),
        kv("planning_time_ms", format!("{elapsed_ms:.3}")),
    ];
    let (level, code, message) = match outcome {
        Ok(plan) => {
            values.extend([
                kv("iterations", plan.stats.iterations.to_string()),
                kv("length_m", format!("{:.4}", plan.metrics.length_m)),
                kv("turning_rad", format!("{:.4}", plan.metrics.turning_rad)),
                kv(
                    "min_clearance_m",
                    format!("{:.4}", plan.metrics.min_clearance_m),
                ),
                kv(
                    "mean_clearance_m",
                    format!("{:.4}", plan.metrics.mean_clearance_m),
                ),
                kv("path_cost", format!("{:.4}", plan.metrics.path_cost)),
                kv(
                    "corridor_half_width_m",
                    format!("{:.4}", plan.metrics.corridor_half_width_m),
                ),
                kv("cut_short", plan.stats.cut_short.to_string()),
                // What the planner said about this plan (a moved start, a cut-short search,
                // a seed returned unchanged), one per line.
                kv("notes", plan.stats.notes.join("\n")),
                kv(
                    "termination",
                    plan.stats
                        .termination
                        .map_or_else(String::new, |t| t.to_string()),
                ),
            ]);
            (
                0u8,
                ResultCode::None,
                format!("planned {:.2} m", plan.metrics.length_m),
            )
        }
        Err(f) => (2u8, f.code, f.message.clone()),
    };
    values.insert(1, kv("result", code.name().into()));
    values.insert(2, kv("result_code", code.number().to_string()));
    DiagnosticArray {
        header,
        status: vec![DiagnosticStatus {
            level,
            name: "patrol_planner: plan".into(),
            message,
            hardware_id: String::new(),
            values,
        }],
    }
}

/// Every Pareto-front path as a line strip, the chosen one thicker, for RViz.
pub fn pareto_markers(plan: &Plan, header: Header) -> MarkerArray {
    let mut markers = vec![Marker {
        header: header.clone(),
        ns: "pareto".into(),
        action: Marker::DELETEALL,
        ..Marker::default()
    }];
    for (i, m) in plan.pareto.iter().enumerate() {
        let chosen = (m.f1_length_m - plan.metrics.length_m).abs() < 1e-9
            && (m.f2_turning_rad - plan.metrics.turning_rad).abs() < 1e-9;
        markers.push(Marker {
            header: header.clone(),
            ns: "pareto".into(),
            id: i as i32,
            type_: Marker::LINE_STRIP,
            action: Marker::ADD,
            pose: Pose::default(),
            scale: Vector3 {
                x: if chosen { 0.06 } else { 0.02 },
                y: 0.0,
                z: 0.0,
            },
            color: if chosen {
                ColorRGBA {
                    r: 0.9,
                    g: 0.1,
                    b: 0.1,
                    a: 1.0,
                }
            } else {
                ColorRGBA {
                    r: 0.2,
                    g: 0.4,
                    b: 0.9,
                    a: 0.6,
                }
            },
            points: m
                .waypoints
                .iter()
                .map(|p| Point {
                    x: p.x,
                    y: p.y,
                    z: 0.0,
                })
                .collect(),
            text: format!("{:.2} m, {:.2} rad", m.f1_length_m, m.f2_turning_rad),
            ..Marker::default()
        });
    }
    MarkerArray { markers }
}

/// The most points a point cloud may carry: a 640 x 480 depth camera has 307 200, a 128-beam
/// lidar about 260 000. A cloud beyond it is refused, so no message can make the obstacle
/// layer trace without end.
pub const MAX_CLOUD_POINTS: usize = 1_000_000;

/// A sensor_msgs/PointCloud2's points (x, y, z in its header's frame), read as
/// sensor_msgs' point_cloud2 iterator reads them: fields `x`, `y` and `z` of FLOAT32 (7) or
/// FLOAT64 (8), at their offsets in each point of `point_step` bytes, rows `row_step` apart,
/// in the cloud's byte order. Refused, with what is wrong: a missing or non-float coordinate
/// field, a field or point that does not fit its step, data shorter than the cloud, more points
/// than [`MAX_CLOUD_POINTS`]. Points that are not finite are kept (a dense cloud has none; the
/// obstacle layer drops them).
pub fn cloud_points(msg: &PointCloud2) -> Result<Vec<Point3<f64>>, String> {
    let count = msg.width as usize * msg.height as usize;
    if count > MAX_CLOUD_POINTS {
        return Err(format!(
            "{} x {} points, more than {MAX_CLOUD_POINTS}",
            msg.width, msg.height
        ));
    }
    let field = |name: &str| -> Result<(usize, usize), String> {
        let f = msg
            .fields
            .iter()
            .find(|f| f.name == name)
            .ok_or_else(|| format!("no field `{name}`"))?;
        let size = match f.datatype {
            7 => 4,
            8 => 8,
            other => {
                return Err(format!(
                    "field `{name}` is of datatype {other}, not a float (7 or 8)"
                ))
            }
        };
        let end = f.offset as usize + size;
        if end > msg.point_step as usize {
            return Err(format!(
                "field `{name}` ends at byte {end}, past point_step {}",
                msg.point_step
            ));
        }
        Ok((f.offset as usize, size))
    };
    let axes = [field("x")?, field("y")?, field("z")?];
    let (step, row) = (msg.point_step as usize, msg.row_step as usize);
    if msg.height > 0 && msg.width > 0 {
        let needed = (msg.height as usize - 1)
            .checked_mul(row)
            .and_then(|n| n.checked_add(msg.width as usize * step))
            .filter(|&n| n <= msg.data.len());
        if needed.is_none() || (msg.height > 1 && row < msg.width as usize * step) {
            return Err(format!(
                "{} bytes of data for {} rows of {} points ({} bytes a point, {} a row)",
                msg.data.len(),
                msg.height,
                msg.width,
                step,
                row
            ));
        }
    }
    let read = |at: usize, size: usize| -> f64 {
        let b = &msg.data[at..at + size];
        match (size, msg.is_bigendian) {
            (4, false) => f64::from(f32::from_le_bytes(b.try_into().expect("4 bytes"))),
            (4, true) => f64::from(f32::from_be_bytes(b.try_into().expect("4 bytes"))),
            (_, false) => f64::from_le_bytes(b.try_into().expect("8 bytes")),
            (_, true) => f64::from_be_bytes(b.try_into().expect("8 bytes")),
        }
    };
    let mut points = Vec::with_capacity(count);
    for r in 0..msg.height as usize {
        for c in 0..msg.width as usize {
            let base = r * row + c * step;
            let [x, y, z] = axes.map(|(offset, size)| read(base + offset, size));
            points.push(Point3::new(x, y, z));
        }
    }
    Ok(points)
}

#[cfg(test)]
mod tests {
    use super::*;
    use planner_core::grid::map::UNKNOWN;

    fn stamped(frame: &str, x: f64, y: f64, q: Quaternion) -> PoseStamped {
        PoseStamped {
            header: Header {
                stamp: Time::default(),
                frame_id: frame.into(),
            },
            pose: Pose {
                position: Point { x, y, z: 0.0 },
                orientation: q,
            },
        }
    }

    /// A cloud with x, y, z and an intensity in each 16-byte point, two rows of two with 4
    /// padding bytes a row, in either byte order and float width; and the clouds that are
    /// refused, each with what is wrong.
    #[test]
    fn point_clouds_are_read_at_their_offsets_and_refused_when_malformed() {
        use patrol_msgs::sensor_msgs::{PointCloud2, PointField};
        let field = |name: &str, offset, datatype| PointField {
            name: name.into(),
            offset,
            datatype,
            count: 1,
        };
        let points: [[f64; 3]; 4] = [
            [1.0, 2.0, 3.0],
            [-1.5, 0.25, 0.0],
            [4.0, 5.0, 6.0],
            [7.0, 8.0, 9.5],
        ];
        let cloud = |big: bool, wide: bool| {
            let size = if wide { 8 } else { 4 };
            let step = 4 * size;
            let mut data = Vec::new();
            for row in points.chunks(2) {
                for p in row {
                    for v in p.iter().chain([&42.0]) {
                        let bytes: Vec<u8> = match (wide, big) {
                            (false, false) => (*v as f32).to_le_bytes().to_vec(),
                            (false, true) => (*v as f32).to_be_bytes().to_vec(),
                            (true, false) => v.to_le_bytes().to_vec(),
                            (true, true) => v.to_be_bytes().to_vec(),
                        };
                        data.extend(bytes);
                    }
                }
                data.extend([0u8; 4]);
            }
            let datatype = if wide { 8 } else { 7 };
            PointCloud2 {
                height: 2,
                width: 2,
                // z before y, and the intensity first: offsets, not order, place them.
                fields: vec![
                    field("intensity", 3 * size as u32, datatype),
                    field("x", 0, datatype),
                    field("z", 2 * size as u32, datatype),
                    field("y", size as u32, datatype),
                ],
                is_bigendian: big,
                point_step: step as u32,
                row_step: (2 * step + 4) as u32,
                data,
                ..Default::default()
            }
        };
        for (big, wide) in [(false, false), (true, false), (false, true), (true, true)] {
            let read = cloud_points(&cloud(big, wide)).unwrap();
            let read: Vec<[f64; 3]> = read.iter().map(|p| [p.x, p.y, p.z]).collect();
            assert_eq!(read, points, "big-endian {big}, 64-bit {wide}");
        }
        let refused = |c: PointCloud2, says: &str| {
            let e = cloud_points(&c).unwrap_err();
            assert!(e.contains(says), "{e}");
        };
        let mut no_z = cloud(false, false);
        no_z.fields.retain(|f| f.name != "z");
        refused(no_z, "no field `z`");
        let mut bytes = cloud(false, false);
        bytes.fields[1].datatype = 2;
        refused(bytes, "datatype 2");
        let mut past = cloud(false, false);
        past.fields[2].offset = 14;
        refused(past, "past point_step");
        let mut short = cloud(false, false);
        short.data.truncate(40);
        refused(short, "bytes of data");
        let mut huge = cloud(false, false);
        huge.width = 1 << 20;
        refused(huge, "more than");
    }

    /// /diagnostics carries what the planner said about the plan (here a moved start and a
    /// cut-short search), one note per line, beside the metrics.
    #[test]
    fn diagnostics_carry_the_plans_notes() {
        use planner_core::grid::metrics::PathMetrics;
        use planner_core::planner::PlanStats;
        let notes = vec![
            "the start (1.050, 0.250) is not free: the plan uses the nearest free cell's centre"
                .to_string(),
            "the exact search was cut short (deadline)".to_string(),
        ];
        let plan = Plan {
            planner: PlannerName::AnyAngle,
            waypoints: vec![Point2::new(0.0, 0.0), Point2::new(1.0, 0.0)],
            metrics: PathMetrics {
                length_m: 1.0,
                turning_rad: 0.0,
                turns: 0,
                min_clearance_m: 0.5,
                mean_clearance_m: 0.5,
                path_cost: 0.0,
                corridor_half_width_m: 0.5,
                collision_free: true,
            },
            stats: PlanStats {
                notes: notes.clone(),
                cut_short: true,
                ..PlanStats::default()
            },
            pareto: Vec::new(),
            goal: Point2::new(1.0, 0.0),
            resolution: 0.05,
            via: Vec::new(),
        };
        let msg = diagnostics(Header::default(), plan.planner, 3, Ok(&plan), 1.0);
        let values = &msg.status[0].values;
        let value = |k: &str| values.iter().find(|v| v.key == k).map(|v| v.value.clone());
        assert_eq!(value("notes"), Some(notes.join("\n")));
        assert_eq!(value("cut_short").as_deref(), Some("true"));
    }

    #[test]
    fn quaternions_are_normalised_and_zero_is_refused() {
        let q = quaternion_from_yaw(1.0);
        assert!((yaw_from_quaternion(&q).unwrap() - 1.0).abs() < 1e-12);
        let scaled = Quaternion {
            x: 0.0,
            y: 0.0,
            z: q.z * 3.0,
            w: q.w * 3.0,
        };
        assert!((yaw_from_quaternion(&scaled).unwrap() - 1.0).abs() < 1e-12);
        let zero = Quaternion {
            x: 0.0,
            y: 0.0,
            z: 0.0,
            w: 0.0,
        };
        assert_eq!(
            yaw_from_quaternion(&zero).unwrap_err().code,
            ResultCode::InvalidInput
        );
        let nan = Quaternion {
            x: f64::NAN,
            ..Quaternion::default()
        };
        assert_eq!(
            yaw_from_quaternion(&nan).unwrap_err().code,
            ResultCode::InvalidInput
        );
    }

    #[test]
    fn transforms_give_their_planar_part_and_refuse_non_finite_numbers() {
        let t = Transform {
            translation: Vector3 {
                x: 2.0,
                y: -1.0,
                z: 0.3,
            },
            rotation: quaternion_from_yaw(0.5),
        };
        let p = transform2(&t).unwrap();
        assert!((p.x - 2.0).abs() < 1e-12 && (p.y + 1.0).abs() < 1e-12);
        assert!((p.yaw - 0.5).abs() < 1e-12);
        let mut bad = t;
        bad.translation.y = f64::INFINITY;
        assert_eq!(transform2(&bad).unwrap_err().code, ResultCode::InvalidInput);
        bad = t;
        bad.rotation = Quaternion {
            x: 0.0,
            y: 0.0,
            z: 0.0,
            w: 0.0,
        };
        assert_eq!(transform2(&bad).unwrap_err().code, ResultCode::InvalidInput);
        assert_eq!(frame_name("/map"), "map");
    }

    #[test]
    fn frames_and_non_finite_poses_are_refused() {
        let q = Quaternion::default();
        assert!(pose_in_frame(&stamped("map", 1.0, 2.0, q), "map").is_ok());
        assert!(pose_in_frame(&stamped("", 1.0, 2.0, q), "map").is_ok());
        assert!(pose_in_frame(&stamped("/map", 1.0, 2.0, q), "map").is_ok());
        // One slash is ROS 1's; more make no frame's name.
        let slashes = format!("{}map", "/".repeat(1000));
        assert!(pose_in_frame(&stamped(&slashes, 1.0, 2.0, q), "map").is_err());
        assert_eq!(
            pose_in_frame(&stamped("odom", 1.0, 2.0, q), "map")
                .unwrap_err()
                .code,
            ResultCode::TfError
        );
        assert_eq!(
            pose_in_frame(&stamped("map", f64::NAN, 2.0, q), "map")
                .unwrap_err()
                .code,
            ResultCode::InvalidInput
        );
        assert_eq!(
            pose_in_frame(&stamped("map", 1.0, f64::INFINITY, q), "map")
                .unwrap_err()
                .code,
            ResultCode::InvalidInput
        );
    }

    #[test]
    fn maps_round_trip_and_bad_ones_are_refused() {
        let info = MapInfo {
            width: 3,
            height: 2,
            resolution: 0.05,
            origin: Pose2::new(-1.0, 2.0, 0.5),
        };
        let map = GridMap::new(info, vec![0, -1, 100, 0, 0, 50]).unwrap();
        let msg = msg_from_grid(&map, "map", Time::default());
        let back = grid_from_msg(&msg).unwrap();
        assert_eq!(back.data(), map.data());
        let (i, j) = (back.info(), map.info());
        assert_eq!((i.width, i.height), (3, 2));
        assert!(
            (i.resolution - j.resolution).abs() < 1e-6,
            "{}",
            i.resolution
        );
        assert!((i.origin.x + 1.0).abs() < 1e-9 && (i.origin.y - 2.0).abs() < 1e-9);
        assert!((back.info().origin.yaw - 0.5).abs() < 1e-9);
        let mut bad = msg.clone();
        bad.data.pop();
        assert!(matches!(
            grid_from_msg(&bad),
            Err(MapError::DataLength { .. })
        ));
        let mut bad = msg.clone();
        bad.info.resolution = f32::NAN;
        assert!(matches!(
            grid_from_msg(&bad),
            Err(MapError::BadResolution(_))
        ));
        let mut bad = msg;
        bad.info.resolution = 0.0;
        assert!(matches!(
            grid_from_msg(&bad),
            Err(MapError::BadResolution(_))
        ));
    }

    /// The published costmap reads as costmap_2d's: the wall lethal, the inflated band inscribed,
    /// the graded costs falling away from it to free, unknown cells unknown; and planning on it
    /// as a costmap gives back the node's own free cells.
    #[test]
    fn the_planning_grid_is_published_as_costmap_2d_publishes_a_costmap() {
        use planner_core::grid::InflationConfig;
        // One row of 40 cells at 0.1 m: a wall at 0, unknown at 39.
        let info = MapInfo {
            width: 40,
            height: 1,
            resolution: 0.1,
            origin: Pose2::new(0.0, 0.0, 0.0),
        };
        let mut data = vec![0i8; 40];
        data[0] = 100;
        data[39] = -1;
        let map = GridMap::new(info, data).unwrap();
        let cfg = InflationConfig {
            allow_unknown: true,
            ..InflationConfig::default()
        };
        let grid = PlanningGrid::new(&map, &cfg).unwrap();
        let msg = costmap_msg(
            map.info(),
            &grid,
            |i| map.data()[i] == UNKNOWN,
            "map",
            Time::default(),
        );
        assert_eq!((msg.info.width, msg.info.height), (40, 1));
        let v = &msg.data;
        assert_eq!(v[0], 100);
        assert_eq!(v[39], -1);
        // 0.45 m inflated (robot 0.25 + margin 0.2): cells 1-4 inscribed, 5 on graded.
        assert!(v[1..=4].iter().all(|&c| c == 99), "{v:?}");
        assert!(v[5] > 0 && v[5] < 99, "{v:?}");
        assert!(v[5..39].windows(2).all(|w| w[0] >= w[1]), "{v:?}");
        // Beyond the 1.75 m inflation radius nothing costs.
        assert_eq!(v[20], 0);
        let back = PlanningGrid::from_costmap(&grid_from_msg(&msg).unwrap(), true);
        for x in 0..40 {
            let c = planner_core::geometry::Cell::new(x, 0);
            assert_eq!(back.is_free(c), grid.is_free(c), "cell {x}");
        }
    }

    /// The local costmap's window holds the grid's own costs round the robot, cell for cell,
    /// its origin on a grid corner in the map's frame (rotated maps too), NO_INFORMATION where
    /// it reaches past the map; its size is bounded however fine the map.
    #[test]
    fn the_local_window_is_the_grid_round_the_robot() {
        use planner_core::grid::InflationConfig;
        for yaw in [0.0, 0.7] {
            // 20 x 10 cells of 0.1 m, an obstacle at cell (12, 5), one unknown cell (3, 2).
            let info = MapInfo {
                width: 20,
                height: 10,
                resolution: 0.1,
                origin: Pose2::new(1.0, -2.0, yaw),
            };
            let mut data = vec![0i8; 200];
            data[5 * 20 + 12] = 100;
            data[2 * 20 + 3] = -1;
            let map = GridMap::new(info, data).unwrap();
            let cfg = InflationConfig {
                allow_unknown: true,
                ..InflationConfig::default()
            };
            let grid = PlanningGrid::new(&map, &cfg).unwrap();
            let unknown = |i: usize| map.data()[i] == UNKNOWN;
            let whole = costmap_costs(map.info(), &grid, unknown, "map", Time::default());
            // The window of `size` metres round the robot in the middle of grid cell `cell`.
            let window = |cell: (f64, f64), size| {
                let robot = info.grid_to_world(Point2::new(cell.0 + 0.5, cell.1 + 0.5));
                costmap_window(
                    map.info(),
                    &grid,
                    unknown,
                    robot,
                    size,
                    "map",
                    Time::default(),
                )
            };
            // The robot in cell (10, 5), a 0.6 x 0.4 m window: cells 7..13 x 3..7.
            let w = window((10.0, 5.0), (0.6, 0.4));
            assert_eq!((w.metadata.size_x, w.metadata.size_y), (6, 4));
            for j in 0..4 {
                for i in 0..6 {
                    let (x, y) = (7 + i, 3 + j);
                    assert_eq!(w.data[j * 6 + i], whole.data[y * 20 + x], "({x}, {y})");
                }
            }
            assert_eq!(w.data[2 * 6 + 5], 254, "the obstacle at (12, 5)");
            let corner = info.grid_to_world(Point2::new(7.0, 3.0));
            let o = &w.metadata.origin;
            assert!(
                (o.position.x - corner.x).abs() < 1e-9 && (o.position.y - corner.y).abs() < 1e-9
            );
            assert!((yaw_from_quaternion(&o.orientation).unwrap() - yaw).abs() < 1e-9);
            // At the map's corner: the cells off the map are unknown, the unknown cell too.
            let w = window((0.0, 0.0), (0.8, 0.6));
            assert_eq!((w.metadata.size_x, w.metadata.size_y), (8, 6));
            // Window cell (i, j) is map cell (i - 4, j - 3).
            assert!(w.data[..3 * 8].iter().all(|&c| c == NO_INFORMATION));
            assert!((0..6).all(|j| w.data[j * 8] == NO_INFORMATION));
            assert_eq!(w.data[5 * 8 + 7], NO_INFORMATION, "map cell (3, 2) unknown");
            assert_eq!(w.data[4 * 8 + 7], whole.data[20 + 3], "map cell (3, 1)");
            assert_ne!(w.data[4 * 8 + 7], NO_INFORMATION);
        }
        // A 100 m window on 1 cm cells is cut to MAX_WINDOW_CELLS a side; a NaN centre is the
        // corner, not a panic.
        let info = MapInfo {
            width: 4,
            height: 4,
            resolution: 0.01,
            origin: Pose2::new(0.0, 0.0, 0.0),
        };
        let map = GridMap::new(info, vec![0; 16]).unwrap();
        let grid =
            PlanningGrid::new(&map, &planner_core::grid::InflationConfig::default()).unwrap();
        let nan = Point2::new(f64::NAN, f64::NAN);
        let w = costmap_window(
            &info,
            &grid,
            |_| false,
            nan,
            (100.0, 0.0),
            "map",
            Time::default(),
        );
        assert_eq!(w.metadata.size_x as i64, MAX_WINDOW_CELLS);
        assert_eq!(w.metadata.size_y, 1);
        assert_eq!(w.data.len(), MAX_WINDOW_CELLS as usize);
        // A finite centre far past any map (odometry of 1e300 m) is a whole window off the
        // map: every cell there, none wrapped away.
        for far in [1e300, -1e300] {
            let w = costmap_window(
                &info,
                &grid,
                |_| false,
                Point2::new(far, far),
                (0.03, 0.02),
                "map",
                Time::default(),
            );
            assert_eq!((w.metadata.size_x, w.metadata.size_y), (3, 2));
            assert_eq!(w.data, vec![NO_INFORMATION; 6]);
        }
    }

    /// A 100 m path at a resolution of 1e-6 m (a map replaced mid-plan, a corrupted one) is
    /// spaced more widely, not densified into 10^8 poses; nonsense spacings still give a path.
    #[test]
    fn densification_is_bounded() {
        let wp = [Point2::new(0.0, 0.0), Point2::new(100.0, 0.0)];
        let path = path_msg(&wp, 0.0, 1e-6, Header::default());
        assert!(
            path.poses.len() <= MAX_PATH_POSES + 2,
            "{}",
            path.poses.len()
        );
        assert!(path.poses.len() > MAX_PATH_POSES / 2);
        for spacing in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let path = path_msg(&wp, 0.0, spacing, Header::default());
            assert!((2..=3).contains(&path.poses.len()), "{spacing}");
        }
        let one = path_msg(&[Point2::new(1.0, 1.0)], 0.5, 0.05, Header::default());
        assert_eq!(one.poses.len(), 1);
    }

    #[test]
    fn paths_are_dense_and_end_with_the_goal_heading() {
        let wp = [
            Point2::new(0.0, 0.0),
            Point2::new(1.0, 0.0),
            Point2::new(1.0, 0.5),
        ];
        let path = path_msg(&wp, 0.3, 0.1, Header::default());
        assert_eq!(path.poses.len(), 10 + 5 + 1);
        let first = &path.poses[0].pose;
        assert!(yaw_from_quaternion(&first.orientation).unwrap().abs() < 1e-12);
        let last = &path.poses.last().unwrap().pose;
        assert_eq!((last.position.x, last.position.y), (1.0, 0.5));
        assert!((yaw_from_quaternion(&last.orientation).unwrap() - 0.3).abs() < 1e-12);
        for w in path.poses.windows(2) {
            let d = ((w[1].pose.position.x - w[0].pose.position.x).powi(2)
                + (w[1].pose.position.y - w[0].pose.position.y).powi(2))
            .sqrt();
            assert!(d <= 0.1 + 1e-12);
        }
    }
    /// A costmap_2d update writes its window, row by row, and nothing else; a window outside
    /// the costmap or with the wrong number of cells is refused and changes nothing.
    #[test]
    fn costmap_updates_write_their_window() {
        let mut costmap = OccupancyGrid::default();
        costmap.info.width = 4;
        costmap.info.height = 3;
        costmap.data = vec![0; 12];
        let update = |x, y, width, height, data: Vec<i8>| OccupancyGridUpdate {
            x,
            y,
            width,
            height,
            data,
            ..OccupancyGridUpdate::default()
        };
        apply_update(&mut costmap, &update(1, 1, 2, 2, vec![1, 2, 3, 4])).unwrap();
        assert_eq!(costmap.data, vec![0, 0, 0, 0, 0, 1, 2, 0, 0, 3, 4, 0]);
        let before = costmap.data.clone();
        for bad in [
            update(3, 1, 2, 1, vec![9, 9]),
            update(-1, 0, 1, 1, vec![9]),
            update(0, 2, 1, 2, vec![9, 9]),
            update(0, 0, 2, 2, vec![9, 9, 9]),
        ] {
            assert!(apply_update(&mut costmap, &bad).is_err(), "{bad:?}");
        }
        assert_eq!(costmap.data, before);
        // An empty window is nothing to write.
        apply_update(&mut costmap, &update(0, 0, 0, 0, vec![])).unwrap();
        assert_eq!(costmap.data, before);
    }
}
