//! The node's obstacle layer (`obstacle_layer`): laser scans and point clouds in, from each of
//! its observation sources, the obstacles they show laid on the planning grid, as Nav2's global
//! costmap runs its ObstacleLayer between the static map and the inflation.
//!
//! Each source's readings ([`receive`], a task per source) are placed in the global frame
//! through TF at their stamp (the sensor's frame up to the robot, then the robot's pose), clear
//! the cells their rays cross and mark those their returns fall in, as the source's `clearing`
//! and `marking` say (planner_core's `ObstacleLayer`; returns outside the source's heights
//! dropped first); the robot's own footprint is cleared. All sources write one layer, and at
//! the layer's `update_frequency` ([`lay`]) what changed is handed to the grid
//! ([`Shared::lay_obstacles`]), which is made again, and the path being followed is checked
//! against it as against a new map: an obstacle across it is planned round
//! (`inputs::remake_grid_on_change`). A source that goes quiet for longer than its
//! `expected_update_rate` is warned of, as costmap_2d warns of a stale observation buffer.
//! `obstacle_layer.enabled` may be set at run time: while false, readings are passed over and
//! grids are made without the layer (`Shared::grid_settings`).
//!
//! A bad reading (numbers that are not finite, more rays than [`MAX_RAYS`], a malformed cloud:
//! `convert::cloud_points`, a frame TF cannot place) is logged once per kind of fault and
//! skipped; the layer goes on.

use crate::state::Shared;
use log::{debug, info, warn};
use nalgebra::{Isometry3, Point3};
use patrol_msgs::sensor_msgs::{LaserScan, PointCloud2};
use patrol_msgs::std_msgs::Header;
use planner_core::grid::obstacle_layer::{cloud_rays, scan_rays, ObstacleLayer, Ray, SourceRules};
use planner_core::grid::MapInfo;
use planner_io::parameters::ObservationSource;
use ros2_client::Subscription;
use std::collections::HashSet;
use std::sync::Arc;
use std::time::Duration;
use tokio::time::Instant;

/// The most rays a scan may have: a 0.1-degree scanner has 3600. A scan beyond it is refused,
/// so no message can make the layer trace without end (a cloud's bound is
/// `convert::MAX_CLOUD_POINTS`).
pub const MAX_RAYS: usize = 20_000;

/// A source's topic, of the type its `data_type` names.
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

/// Takes one source's readings into the layer ([`Shared::obstacles`]), and warns once when
/// none has come for longer than the source's `expected_update_rate` (until one comes).
pub async fn receive(s: Arc<Shared>, source: ObservationSource, readings: Readings) {
    let rules = source.rules(&s.params.obstacle_layer);
    let name = format!("obstacle_layer.{} (`{}`)", source.name, source.topic);
    let expected = (source.expected_update_rate > 0.0)
        .then(|| Duration::from_secs_f64(source.expected_update_rate));
    let (mut last, mut quiet) = (Instant::now(), false);
    let mut faults = HashSet::new();
    loop {
        let overdue = async {
            match expected {
                Some(period) if !quiet => tokio::time::sleep_until(last + period).await,
                _ => std::future::pending().await,
            }
        };
        tokio::select! {
            taken = readings.next() => {
                last = Instant::now();
                if std::mem::take(&mut quiet) {
                    info!("{name}: readings come again");
                }
                let observed = match taken {
                    // Switched off at run time: passed over, as Nav2's layer does.
                    Ok(_) if !s.live.read().expect("lock").obstacles_enabled => Ok(()),
                    Ok(reading) => observe(&s, reading, &source.sensor_frame, rules).await,
                    Err(why) => Err(Fault { kind: "decode", why }),
                };
                if let Err(Fault { kind, why }) = observed {
                    // One line per kind of fault, not one per reading at the sensor's rate.
                    if faults.insert(kind) {
                        warn!("{name}: a reading skipped: {why}");
                    } else {
                        debug!("{name}: a reading skipped: {why}");
                    }
                }
            }
            () = overdue => {
                quiet = true;
                warn!(
                    "{name}: no reading for {:.2} s, where one should come every {:.2} s \
                     (expected_update_rate): what it saw last stays marked",
                    last.elapsed().as_secs_f64(),
                    source.expected_update_rate
                );
            }
        }
    }
}

/// Lays what the sources changed on the grid, at most at the layer's `update_frequency`
/// ([`Shared::lay_obstacles`]).
pub async fn lay(s: Arc<Shared>) {
    let period = Duration::from_secs_f64(1.0 / s.params.obstacle_layer.update_frequency);
    let mut tick = tokio::time::interval(period);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    loop {
        tick.tick().await;
        if let Some(marked) = s.lay_obstacles() {
            debug!("obstacle_layer: {marked} cells seen occupied");
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
/// The sensor is `sensor_frame` when set (the source's), else the reading's own frame.
/// The reading is checked and traced off the async threads: a cloud of a million points, or a
/// long raytrace range on a fine map, takes tens of milliseconds.
async fn observe(
    s: &Arc<Shared>,
    reading: Reading,
    sensor_frame: &str,
    rules: SourceRules,
) -> Result<(), Fault> {
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
    let frame = if sensor_frame.is_empty() {
        &header.frame_id
    } else {
        sensor_frame
    };
    let sensor = s
        .frame_in_global(frame, crate::convert::seconds(&header.stamp))
        .await
        .map_err(|f| Fault {
            kind: "frame",
            why: f.message,
        })?;
    let s = s.clone();
    tokio::task::spawn_blocking(move || {
        let rays = rays(&reading, &rules, &sensor)?;
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
    rules: &SourceRules,
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
                rules,
                |x, y| sensor * Point3::new(x, y, 0.0),
            ))
        }
        Reading::Cloud(cloud) => {
            let points =
                crate::convert::cloud_points(cloud).map_err(|why| Fault { kind: "cloud", why })?;
            Ok(cloud_rays(
                Point3::from(sensor.translation.vector),
                points.into_iter().map(|q| sensor * q),
                rules,
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
