//! The node's obstacle layer (`obstacle_layer`): laser scans and point clouds in, from each of
//! its observation sources, the obstacles they show laid on the planning grid, as Nav2's global
//! costmap runs its ObstacleLayer between the static map and the inflation.
//!
//! Each source's readings ([`receive`], a task per source) are placed in the global frame
//! through TF at their stamp (the sensor's frame up to the robot, then the robot's pose) and
//! traced into rays (returns outside the source's heights dropped), the latest kept per source
//! ([`Seen`]). At the layer's `update_frequency` ([`lay`]) every source's latest reading clears
//! the cells its rays cross and then marks those its returns fall in, as its `clearing` and
//! `marking` say (planner_core's `ObstacleLayer`), the robot's own footprint is cleared, and
//! what changed is handed to the grid ([`Shared::lay_obstacles`]), which is made again; the
//! path being followed is checked against it as against a new map: an obstacle across it is
//! planned round (`inputs::remake_grid_on_change`). A source that goes quiet for longer than its
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
use planner_core::geometry::Point2;
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

/// Keeps source `index`'s latest reading, as rays in the global frame, for the layer's updates
/// ([`Seen::keep`]), and warns once when none has come for longer than the source's
/// `expected_update_rate` (until one comes).
pub async fn receive(s: Arc<Shared>, index: usize, source: ObservationSource, readings: Readings) {
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
                let kept = match taken {
                    // Switched off at run time: passed over, as Nav2's layer does.
                    Ok(_) if !s.live.read().expect("lock").obstacles_enabled => Ok(()),
                    Ok(reading) => keep(&s, index, reading, &source.sensor_frame, rules).await,
                    Err(why) => Err(Fault { kind: "decode", why }),
                };
                if let Err(Fault { kind, why }) = kept {
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

/// The layer's updates, at its `update_frequency` while it is enabled: every source's latest
/// reading applied ([`Shared::update_obstacles`]), and what that changed laid on the grid
/// ([`Shared::lay_obstacles`]).
pub async fn lay(s: Arc<Shared>) {
    let period = Duration::from_secs_f64(1.0 / s.params.obstacle_layer.update_frequency);
    let mut tick = tokio::time::interval(period);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    loop {
        tick.tick().await;
        // Switched off: grids are made without the layer, and nothing is kept meanwhile.
        if !s.live.read().expect("lock").obstacles_enabled {
            continue;
        }
        let shared = s.clone();
        // Tracing every source's reading takes up to tens of milliseconds: off the async threads.
        let laid = tokio::task::spawn_blocking(move || {
            shared.update_obstacles();
            shared.lay_obstacles()
        })
        .await;
        if let Ok(Some(marked)) = laid {
            debug!("obstacle_layer: {marked} cells seen occupied");
        }
    }
}

/// What the sources have seen ([`Shared::obstacles`]): the layer on the current map's grid,
/// each source's latest reading as rays in the global frame, and whether the layer changed
/// since it was last laid on the grid. As in costmap_2d's ObstacleLayer with
/// `observation_persistence` 0, each update applies every source's latest reading, its
/// clearing first and then its marks (one source's rays never clear another's returns), and
/// a reading is applied again at every update until its source's next one replaces it.
#[derive(Debug, Default)]
pub struct Seen {
    pub layer: Option<ObstacleLayer>,
    latest: Vec<Option<Vec<Ray>>>,
    pub changed: bool,
}

impl Seen {
    /// Source `index`'s latest reading, for the next update.
    pub fn keep(&mut self, index: usize, rays: Vec<Ray>) {
        if self.latest.len() <= index {
            self.latest.resize_with(index + 1, || None);
        }
        self.latest[index] = Some(rays);
    }

    /// One update on the map's grid `info`: the layer made afresh when the map's size or
    /// origin changed (a new floor: what was seen on the old one is no longer where it was), as
    /// costmap_2d's layers are reset when the map resizes (the same map republished keeps
    /// them); every source's latest reading applied, and the robot's footprint, a disc of
    /// radius `footprint.1` round `footprint.0`, cleared ([`ObstacleLayer::observe`]).
    pub fn update(&mut self, info: MapInfo, footprint: Option<(Point2, f64)>) {
        let Seen {
            layer,
            latest,
            changed,
        } = self;
        if let Some(old) = layer.as_ref().filter(|l| *l.info() != info) {
            info!(
                "a map of another size or origin: the obstacles seen on the last one are forgotten"
            );
            // A grid is never made with a layer of another map, so only marks laid before
            // call for laying the empty layer (were that map to come back, they would show).
            *changed |= old.marked_count() > 0;
        }
        let layer = match layer {
            Some(l) if *l.info() == info => l,
            _ => layer.insert(ObstacleLayer::new(info)),
        };
        let readings: Vec<&[Ray]> = latest.iter().flatten().map(Vec::as_slice).collect();
        *changed |= layer.observe(&readings, footprint);
    }

    /// Clears the layer, everything or a `square` (centre in the global frame, side in m,
    /// inside it or all but it: costmap_2d's clearing regions), and forgets the sources' latest
    /// readings, so the clearing holds until they see again (Nav2 applies its kept readings at
    /// its next update). Returns how many cells were marked before and are after; `None`
    /// before the first update made the layer.
    pub fn clear(&mut self, square: Option<(Point2, f64, bool)>) -> Option<(usize, usize)> {
        self.latest.iter_mut().for_each(|l| *l = None);
        let layer = self.layer.as_mut()?;
        let before = layer.marked_count();
        self.changed |= match square {
            None => layer.clear_all(),
            Some((center, side, inside)) => layer.clear_square(center, side, inside),
        };
        Some((before, layer.marked_count()))
    }
}

/// Why a reading was skipped: its kind (logged once) and the details.
struct Fault {
    kind: &'static str,
    why: String,
}

/// One reading of source `index`, placed through TF at its stamp (the sensor is
/// `sensor_frame` when set, the source's, else the reading's own frame), traced into rays in
/// the global frame and kept as the source's latest ([`Seen::keep`]); nothing before the first
/// map, or on a costmap taken as it is. Off the async threads: a cloud of a million points
/// takes tens of milliseconds to trace, and an update holds the layer while it applies the
/// readings.
async fn keep(
    s: &Arc<Shared>,
    index: usize,
    reading: Reading,
    sensor_frame: &str,
    rules: SourceRules,
) -> Result<(), Fault> {
    let on_map = s
        .map
        .read()
        .expect("lock")
        .as_ref()
        .is_some_and(|m| !m.is_costmap());
    if !on_map {
        return Ok(());
    }
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
        s.obstacles.lock().expect("lock").keep(index, rays);
        s.sources_read_at
            .lock()
            .expect("lock")
            .insert(index, std::time::Instant::now());
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

/// The first source the layer waits for, if any: one with an `expected_update_rate` whose
/// latest reading is older than it (none since the node started counts from then), as
/// costmap_2d's ObservationBuffer is not current; a name and why, for the plan's TIMEOUT. None
/// while the layer is off, or on a costmap taken as it is.
pub fn overdue_source(s: &Shared) -> Option<String> {
    let layer = &s.params.obstacle_layer;
    if !s.params.costmap_topic.is_empty() || !s.live.read().expect("lock").obstacles_enabled {
        return None;
    }
    let read_at = s.sources_read_at.lock().expect("lock");
    layer.sources.iter().enumerate().find_map(|(i, source)| {
        let since = read_at.get(&i).unwrap_or(&s.started).elapsed().as_secs_f64();
        (source.expected_update_rate > 0.0 && since > source.expected_update_rate).then(|| {
            format!(
                "obstacle_layer.{} (`{}`): no reading for {since:.2} s, where one should come every {:.2} s",
                source.name, source.topic, source.expected_update_rate
            )
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use planner_core::geometry::Pose2;

    /// Each update applies every source's latest reading, clearing before marking: the camera's
    /// box, under the lidar's ray, stays while the lidar reads on; a clearing forgets the
    /// readings, so the next update brings nothing back; the footprint is cleared last.
    #[test]
    fn each_update_applies_every_sources_latest_reading_marks_last() {
        let info = MapInfo {
            width: 40,
            height: 20,
            resolution: 0.1,
            origin: Pose2::new(0.0, 0.0, 0.0),
        };
        let at = |x: f64| Point2::new(x, 1.05);
        let cell = |x: f64| info.world_to_cell(at(x)).unwrap();
        let lidar = Ray {
            clear: Some((at(0.55), at(2.55))),
            mark: Some(at(2.55)),
        };
        let camera = Ray {
            clear: None,
            mark: Some(at(1.55)),
        };
        let mut seen = Seen::default();
        seen.keep(1, vec![camera]);
        seen.keep(0, vec![lidar]);
        seen.update(info, None);
        let layer = |seen: &Seen| seen.layer.clone().unwrap();
        assert!(
            seen.changed
                && layer(&seen).is_marked(cell(1.55))
                && layer(&seen).is_marked(cell(2.55))
        );
        seen.changed = false;
        seen.keep(0, vec![lidar]);
        seen.update(info, None);
        assert!(
            !seen.changed && layer(&seen).is_marked(cell(1.55)),
            "the camera's box stays"
        );
        assert_eq!(seen.clear(None), Some((2, 0)));
        seen.update(info, None);
        assert_eq!(
            layer(&seen).marked_count(),
            0,
            "the readings went with the clearing"
        );
        seen.keep(1, vec![camera]);
        seen.update(info, Some((at(1.6), 0.2)));
        assert_eq!(layer(&seen).marked_count(), 0, "under the robot");
        // Another map: the layer made afresh on its grid.
        let other = MapInfo { width: 30, ..info };
        seen.update(other, None);
        assert_eq!(*layer(&seen).info(), other);
    }
}
