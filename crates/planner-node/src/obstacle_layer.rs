//! The node's obstacle layer (`obstacle_layer`): laser scans or point clouds in, the obstacles
//! they show laid on the planning grid, as Nav2's global costmap runs its ObstacleLayer between
//! the static map and the inflation.
//!
//! Each reading is placed in the global frame through TF at its stamp (the sensor's frame up to
//! the robot, then the robot's pose), clears the cells its rays cross and marks those its
//! returns fall in (planner_core's `ObstacleLayer`; a cloud's points outside the obstacle
//! heights dropped first); the robot's own footprint is cleared. At the
//! layer's `update_frequency` what changed is handed to the grid ([`Shared::seen_obstacles`]),
//! which is made again, and the path being followed is checked against it as against a new
//! map: an obstacle across it is planned round (`inputs::remake_grid_on_change`).
//!
//! A bad reading (numbers that are not finite, more rays than [`MAX_RAYS`], a malformed cloud:
//! `convert::cloud_points`, a frame TF cannot place) is logged once per kind of fault and
//! skipped; the layer goes on.

use crate::state::Shared;
use log::{debug, info, warn};
use nalgebra::{Isometry3, Point3};
use patrol_msgs::sensor_msgs::{LaserScan, PointCloud2};
use patrol_msgs::std_msgs::Header;
use planner_core::grid::obstacle_layer::{cloud_rays, scan_rays, ObstacleLayer, RangeLimits, Ray};
use planner_core::grid::MapInfo;
use ros2_client::Subscription;
use std::collections::HashSet;
use std::sync::Arc;
use std::time::Duration;

/// The most rays a scan may have: a 0.1-degree scanner has 3600. A scan beyond it is refused,
/// so no message can make the layer trace without end (a cloud's bound is
/// `convert::MAX_CLOUD_POINTS`).
pub const MAX_RAYS: usize = 20_000;

/// The layer's topic, of the type `obstacle_layer.data_type` names.
pub enum Readings {
    Scans(Subscription<LaserScan>),
    Clouds(Subscription<PointCloud2>),
}

/// One message of [`Readings`].
enum Reading {
    Scan(LaserScan),
    Cloud(PointCloud2),
}

impl Readings {
    /// The next reading, or why none could be taken (a sample that does not decode).
    async fn next(&self) -> Result<Reading, String> {
        match self {
            Readings::Scans(sub) => sub
                .async_take()
                .await
                .map(|(m, _)| Reading::Scan(m))
                .map_err(|e| format!("{e:?}")),
            Readings::Clouds(sub) => sub
                .async_take()
                .await
                .map(|(m, _)| Reading::Cloud(m))
                .map_err(|e| format!("{e:?}")),
        }
    }
}

impl Reading {
    fn header(&self) -> &Header {
        match self {
            Reading::Scan(m) => &m.header,
            Reading::Cloud(m) => &m.header,
        }
    }
}

/// Takes the readings into the layer ([`Shared::obstacles`]), and lays the layer on the grid
/// when it changed, at most at `update_frequency` ([`Shared::lay_obstacles`]).
pub async fn receive(s: Arc<Shared>, readings: Readings) {
    let params = s.params.obstacle_layer.clone();
    let limits = params.range_limits();
    let mut tick = tokio::time::interval(Duration::from_secs_f64(1.0 / params.update_frequency));
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut faults = HashSet::new();
    loop {
        tokio::select! {
            taken = readings.next() => {
                let observed = match taken {
                    Ok(reading) => observe(&s, reading, limits).await,
                    Err(why) => Err(Fault { kind: "decode", why }),
                };
                if let Err(Fault { kind, why }) = observed {
                    // One line per kind of fault, not one per reading at the sensor's rate.
                    if faults.insert(kind) {
                        warn!("{}: a reading skipped: {why}", params.topic);
                    } else {
                        debug!("{}: a reading skipped: {why}", params.topic);
                    }
                }
            }
            _ = tick.tick() => {
                if let Some(marked) = s.lay_obstacles() {
                    debug!("{}: {marked} cells seen occupied", params.topic);
                }
            }
        }
    }
}

/// Why a reading was skipped: its kind (logged once) and the details.
struct Fault {
    kind: &'static str,
    why: String,
}

/// One reading into the layer. The layer is made afresh on the current map's grid when the
/// map's size or origin changed (a new floor: what was seen on the old one is no longer where
/// it was), as costmap_2d's layers are reset when the map resizes; the same map republished
/// keeps what was seen. Nothing happens before the first map, or on a costmap taken as it is.
/// The reading is checked and traced off the async threads: a cloud of a million points, or a
/// long raytrace range on a fine map, takes tens of milliseconds.
async fn observe(s: &Arc<Shared>, reading: Reading, limits: RangeLimits) -> Result<(), Fault> {
    let Some(info) = s
        .map
        .read()
        .expect("lock")
        .as_ref()
        .filter(|m| !m.is_costmap())
        .map(|m| *m.source_info())
    else {
        return Ok(());
    };
    let header = reading.header();
    let sensor = s
        .frame_in_global(&header.frame_id, crate::convert::seconds(&header.stamp))
        .await
        .map_err(|f| Fault {
            kind: "frame",
            why: f.message,
        })?;
    let s = s.clone();
    tokio::task::spawn_blocking(move || {
        let rays = rays(&reading, &limits, &sensor)?;
        trace(&s, &rays, info);
        Ok(())
    })
    .await
    .unwrap_or_else(|e| {
        Err(Fault {
            kind: "task",
            why: e.to_string(),
        })
    })
}

/// A reading's rays in the global frame, its sensor at `sensor` there; a malformed reading is
/// a fault.
fn rays(
    reading: &Reading,
    limits: &RangeLimits,
    sensor: &Isometry3<f64>,
) -> Result<Vec<Ray>, Fault> {
    match reading {
        Reading::Scan(scan) => {
            let numbers = [
                scan.angle_min,
                scan.angle_increment,
                scan.range_min,
                scan.range_max,
            ];
            if numbers.iter().any(|v| !v.is_finite()) || scan.range_min < 0.0 {
                return Err(Fault {
                    kind: "numbers",
                    why: format!(
                        "angle_min {}, angle_increment {}, range_min {}, range_max {}: each must \
                         be finite, the ranges not negative",
                        scan.angle_min, scan.angle_increment, scan.range_min, scan.range_max
                    ),
                });
            }
            if scan.ranges.len() > MAX_RAYS {
                return Err(Fault {
                    kind: "rays",
                    why: format!("{} rays, more than {MAX_RAYS}", scan.ranges.len()),
                });
            }
            Ok(scan_rays(
                &scan.ranges,
                f64::from(scan.angle_min),
                f64::from(scan.angle_increment),
                f64::from(scan.range_min),
                f64::from(scan.range_max),
                limits,
                |x, y| sensor * Point3::new(x, y, 0.0),
            ))
        }
        Reading::Cloud(cloud) => {
            let points =
                crate::convert::cloud_points(cloud).map_err(|why| Fault { kind: "cloud", why })?;
            Ok(cloud_rays(
                Point3::from(sensor.translation.vector),
                points.into_iter().map(|q| sensor * q),
                limits,
            ))
        }
    }
}

/// `rays` into the layer on the map's grid `info`, then the robot's footprint cleared.
fn trace(s: &Shared, rays: &[Ray], info: MapInfo) {
    let robot = s
        .params
        .obstacle_layer
        .footprint_clearing_enabled
        .then(|| {
            s.fresh_odom()
                .or_else(|| s.start.read().expect("lock").map(|(p, _)| p))
        })
        .flatten();
    let radius = s.live.read().expect("lock").config.costmap.robot_radius;
    let mut obstacles = s.obstacles.lock().expect("lock");
    let (layer, changed) = &mut *obstacles;
    if layer.as_ref().is_none_or(|l| *l.info() != info) {
        if layer.is_some() {
            info!(
                "a map of another size or origin: the obstacles seen on the last one are forgotten"
            );
        }
        *layer = Some(ObstacleLayer::new(info));
        *changed = true;
    }
    let Some(layer) = layer.as_mut() else {
        return;
    };
    *changed |= layer.observe(rays);
    if let Some(robot) = robot {
        *changed |= layer.clear_disc(robot.position(), radius);
    }
}
