//! What the node's tasks share: the parameters, the settings `ros2 param set` changes, the
//! current map with its planning grid, the latest poses, the goal counter and the plan being
//! followed. Locks are held only to copy a value in or out, never across an await or a plan.

use crate::localization::{KnownFrames, Localization};
use crate::result::{Failure, ResultCode};
use crate::tf_buffer::TfBuffer;
use chassis::behavior::{Motion, Status as MotionStatus};
use chassis::follower::Follower;
use chassis::Twist2;
use log::{info, warn};
use nalgebra::Isometry3;
use patrol_msgs::geometry_msgs::PoseStamped;
use patrol_msgs::nav_msgs::Path;
use planner_core::config::PlannerConfig;
use planner_core::geometry::{Point2, Pose2};
use planner_core::grid::inflation::{keepout_cost, planning_grid};
use planner_core::grid::map::UNKNOWN;
use planner_core::grid::obstacle_layer::ObstacleLayer;
use planner_core::grid::{GridMap, InflationConfig, MapInfo, PlanningGrid};
use planner_core::params::ParamError;
use planner_core::PlannerName;
use planner_io::parameters::NodeParams;
use std::borrow::Cow;
use std::sync::atomic::{AtomicBool, AtomicU64};
use std::sync::{Arc, Mutex, RwLock, Weak};
use std::time::Instant;

/// Settings that `ros2 param set` may change while the node runs.
#[derive(Clone, Debug)]
pub struct Live {
    pub planner: PlannerName,
    pub max_planning_time: f64,
    pub tolerance: f64,
    /// The planning configuration with the weights and the inflation as last set
    /// (`crate::params::SETTINGS`); the next plan is built from it.
    pub config: PlannerConfig,
    /// `obstacle_layer.enabled` as last set: while false, readings are passed over and the grid
    /// is made without what the sources saw (kept, and laid again when it is set true), as
    /// Nav2's ObstacleLayer takes its `enabled` at run time (a lift, a dock the lidar would see
    /// as a wall).
    pub obstacles_enabled: bool,
}

/// What a planning grid is made with beside its map: the costmap parameters as last set, the
/// keepout mask as last received (`keepout_mask_topic`; Nav2's keepout filter) and the obstacles
/// the scans have shown (`obstacle_layer`). A grid made with other settings is made again
/// ([`Shared::current_map`]).
#[derive(Clone, Debug)]
pub struct GridSettings {
    pub costmap: InflationConfig,
    pub keepout: Option<Arc<GridMap>>,
    pub obstacles: Option<Arc<ObstacleLayer>>,
}

#[cfg(test)]
impl GridSettings {
    /// `costmap` and no keepout mask.
    pub fn without_keepout(costmap: InflationConfig) -> Self {
        Self {
            costmap,
            keepout: None,
            obstacles: None,
        }
    }
}

/// A validated map and the planning grid made from it (inflated obstacles, clearance, costs, the
/// map's metadata). The map is kept beside its grid so that a changed inflation
/// (`ros2 param set /patrol_planner costmap.inflation_radius ...`) makes the grid again from it,
/// as costmap_2d re-inflates its master grid when its inflation parameters change.
pub struct MapState {
    pub grid: PlanningGrid,
    /// The map as it arrived.
    source: Arc<GridMap>,
    /// `source` cell for cell the grid's: `source` itself, or, with
    /// `costmap.downsampling_factor`, `source` downsampled alike (each block's worst value). The
    /// grid is not made from it (the map is inflated at full resolution first); it says which
    /// of the grid's cells are unknown when the grid is published as a costmap.
    map: Arc<GridMap>,
    /// The map is a costmap, taken as it is: only `allow_unknown` reads it.
    as_costmap: bool,
    /// The costmap parameters the grid was made with.
    made_with: InflationConfig,
    /// The keepout mask laid over it, if any (the one received, shared, not a copy).
    keepout: Option<Arc<GridMap>>,
    /// The obstacles seen by the scans it was made with, if any (laid on the map when they are
    /// on its grid: [`ObstacleLayer::overlay`]).
    obstacles: Option<Arc<ObstacleLayer>>,
}

impl MapState {
    /// Makes `map`'s planning grid: the node's inflation of it by `settings.costmap`, with the
    /// obstacles the scans have shown laid on it first (inflated as its walls are), or, with
    /// `as_costmap`, the map as a costmap (already inflated and graded); the keepout mask laid
    /// over it; then downsampled by `costmap.downsampling_factor` ([`planning_grid`]), so the
    /// inflation is exact.
    pub fn new(
        source: Arc<GridMap>,
        as_costmap: bool,
        settings: &GridSettings,
    ) -> Result<Self, ParamError> {
        let costmap = &settings.costmap;
        let mask = settings.keepout.as_deref();
        let seen = match &settings.obstacles {
            Some(layer) if !as_costmap && layer.marked_count() > 0 => layer.overlay(&source),
            _ => None,
        };
        let planned_on = seen.as_ref().unwrap_or(&source);
        let (coarse, grid) = match planning_grid(planned_on, costmap, as_costmap, mask)? {
            (Cow::Borrowed(_), grid) => (None, grid),
            (Cow::Owned(coarse), grid) => (Some(coarse), grid),
        };
        let map = match (coarse, seen) {
            (Some(coarse), _) => Arc::new(coarse),
            (None, Some(seen)) => Arc::new(seen),
            (None, None) => source.clone(),
        };
        Ok(Self {
            grid,
            source,
            map,
            as_costmap,
            made_with: costmap.clone(),
            keepout: settings.keepout.clone(),
            obstacles: settings.obstacles.clone(),
        })
    }

    /// Whether the grid is what `settings` would make of the map.
    pub fn is_made_with(&self, settings: &GridSettings) -> bool {
        self.sees_what(settings) && self.is_set_as(settings)
    }

    /// Whether the grid was made with the obstacles `settings` has seen.
    fn sees_what(&self, settings: &GridSettings) -> bool {
        same(&self.obstacles, &settings.obstacles)
    }

    /// Whether the grid was made with the costmap parameters and keepout mask of `settings`.
    fn is_set_as(&self, settings: &GridSettings) -> bool {
        let same_mask = same(&self.keepout, &settings.keepout);
        let costmap = &settings.costmap;
        same_mask
            && if self.as_costmap {
                self.made_with.allow_unknown == costmap.allow_unknown
                    && self.made_with.downsampling_factor == costmap.downsampling_factor
            } else {
                self.made_with == *costmap
            }
    }

    /// The grid the map arrived on (before any downsampling): the one the scans' obstacles are
    /// kept on.
    pub fn source_info(&self) -> &MapInfo {
        self.source.info()
    }

    /// Whether the map is a costmap taken as it is (`costmap_topic`).
    pub fn is_costmap(&self) -> bool {
        self.as_costmap
    }

    /// The map cell for cell the grid's (downsampled, if the grid was), with the obstacles seen
    /// laid on it: what a published costmap marks unknown.
    pub fn map(&self) -> &GridMap {
        &self.map
    }

    /// Whether the grid's cell `i` is one nothing is known of, as a published costmap marks it
    /// (-1, NO_INFORMATION): unknown on the map, and not in a keepout zone (a mask cell of a
    /// cost above 0 over it: Nav2's keepout filter writes its cost over an unknown cell, so a
    /// zone shows over unexplored space too; a free mask cell leaves it unknown here, where
    /// `allow_unknown` still decides whether it may be crossed).
    pub fn is_unknown(&self, i: usize) -> bool {
        self.map.data()[i] == UNKNOWN
            && !self.keepout.as_deref().is_some_and(|mask| {
                let info = self.map.info();
                let centre = info.cell_to_world(info.cell_at(i));
                mask.info()
                    .world_to_cell(centre)
                    .and_then(|c| keepout_cost(mask.value(c)))
                    .is_some_and(|cost| cost > 0)
            })
    }

    /// The same map's grid made with `settings`.
    pub fn remade(&self, settings: &GridSettings) -> Result<Self, ParamError> {
        Self::new(self.source.clone(), self.as_costmap, settings)
    }
}

/// Whether two optional shared values are the same one (not merely equal: comparing two masks
/// or layers of millions of cells would cost what making the grid again costs).
fn same<T>(a: &Option<Arc<T>>, b: &Option<Arc<T>>) -> bool {
    match (a, b) {
        (Some(a), Some(b)) => Arc::ptr_eq(a, b),
        (None, None) => true,
        _ => false,
    }
}

/// What the tasks share.
pub struct Shared {
    /// The node's own parameters (frames, map, follower).
    pub params: NodeParams,
    /// When the node started: a sensor that has sent nothing yet is overdue from then
    /// (`obstacle_layer::overdue_source`).
    pub started: Instant,
    /// The planning parameters from the file; `live` overrides the ones set at run time.
    pub planning: PlannerConfig,
    pub live: RwLock<Live>,
    /// The current map; read it with [`Shared::current_map`], which brings its grid up to the
    /// costmap parameters as last set and the keepout mask as last received.
    pub map: RwLock<Option<Arc<MapState>>>,
    /// The keepout mask as last received on `keepout_mask_topic` (Nav2's keepout filter mask,
    /// in the global frame), laid over every grid made from now on.
    pub keepout: RwLock<Option<Arc<GridMap>>>,
    /// The obstacle layer as the sources' readings and the clearing services leave it, each
    /// source's latest reading, and whether the layer changed since it was last laid on the
    /// grid (obstacle_layer.rs).
    pub obstacles: Mutex<crate::obstacle_layer::Seen>,
    /// When each obstacle layer source's latest reading was kept, by its index (costmap_2d's
    /// observation buffer's `last_updated_`): apart from `obstacles`, which an update holds
    /// while it traces, so a plan asking whether the costmap is current never waits on it.
    pub sources_read_at: Mutex<std::collections::HashMap<usize, Instant>>,
    /// The obstacles as last laid on the grid ([`Shared::lay_obstacles`]).
    pub seen_obstacles: RwLock<Option<Arc<ObstacleLayer>>>,
    /// Held while a grid is made again for changed costmap parameters, so that two requests
    /// arriving together do not both make it.
    pub remaking: Mutex<()>,
    /// Told each time a grid is installed (a new map, or one made again), so the grid can be
    /// published as a costmap (`publish_costmap`).
    pub grid_installed: tokio::sync::Notify,
    /// Told when a setting changes (`ros2 param set`, a keepout mask, the obstacles the scans
    /// have shown), and when a map was installed with settings that changed while it was made: the grid is then made again at once
    /// (`inputs::remake_grid_on_change`), not by the next plan.
    pub settings_changed: tokio::sync::Notify,
    /// The last grid and path checked against each other (`inputs::replan_if_blocked`), so
    /// that a path is checked once against each grid, whichever task installed it.
    /// Weak: it keeps no grid or path alive.
    #[allow(clippy::type_complexity)]
    pub checked_grid: Mutex<(Weak<MapState>, Weak<Vec<(f64, f64)>>)>,
    /// Told each time a path is handed to the follower: it may have been planned on a grid
    /// that a new map, inflation or keepout mask replaced while it was planned, so it is
    /// checked against the grid as it is now (`inputs::remake_grid_on_change`).
    pub path_installed: tokio::sync::Notify,
    /// The latest start pose (map frame) and when it arrived.
    pub start: RwLock<Option<(Pose2, Instant)>>,
    /// Counts the goals that take the robot (each `/goal_pose`, each `navigate_to_pose`, each
    /// `follow_waypoints` once for all its legs; drive.rs, patrol.rs): a plan or drive for an
    /// older one stops when it moves on. A replan around a new map keeps its goal's number.
    pub goals: AtomicU64,
    /// `map -> odom` and the recent odometry (see localization.rs).
    pub localization: Mutex<Localization>,
    /// Every transform on `/tf` and `/tf_static`: the frames goals may be stamped in beyond the
    /// node's own (tf_buffer.rs).
    pub tf: Mutex<TfBuffer>,
    /// The latest odometry pose (map frame) and when it arrived: the follower's feedback.
    pub odom: RwLock<Option<(Pose2, Instant)>>,
    /// Where odometry came from last, and when `odom_frame -> robot_base_frame` last arrived on
    /// `/tf` ([`Shared::odometry`]).
    odometry_source: Mutex<(Option<OdometrySource>, Option<Instant>)>,
    /// The same pose in the odometry frame, as it arrived (Nav2's `local_frame`): what a
    /// behaviour's motion measures its turning and driving by, so that a localisation update
    /// (AMCL's correction during a recovery spin) is not taken for motion.
    pub odom_local: RwLock<Option<Pose2>>,
    /// The plan being followed, if any.
    pub follower: Mutex<Option<Follower>>,
    /// A behaviour's motion (a spin, a back-up: behaviors.rs), its goal's number and whether it
    /// is done: driven by the follower loop while no plan is followed.
    pub motion: Mutex<Option<Moving>>,
    /// The goal and path (map metres) of the plan being followed: checked again when a new
    /// map arrives, and replanned only when the new map blocks it.
    pub followed: Mutex<Option<Followed>>,
    /// The goal (its number) whose path the follower last finished, and when: how a drive knows
    /// it arrived (drive.rs), whichever of its replans the robot was on.
    pub arrived: Mutex<Option<(u64, Instant)>>,
    /// Why the last replan of a goal (its number) failed, for its drive to report (drive.rs):
    /// the follower stops, and the drive's answer says why rather than only "not reached".
    pub failed_replan: Mutex<Option<(u64, Failure)>>,
    /// Whether the last `/cmd_vel` the follower sent was not a stop (shutdown then sends one).
    pub moving: AtomicBool,
    /// How many inputs (std_msgs/Empty on `input_at_waypoint.input_topic`) have arrived: a
    /// patrol waiting at a waypoint waits for this to pass its count at arrival.
    pub waypoint_inputs: AtomicU64,
    /// How many frames have come on `photo_at_waypoint.image_topic`, and the latest: a patrol
    /// at a waypoint waits for the count to pass its count at arrival (photo_at_waypoint.rs).
    pub camera: Mutex<(u64, Option<Arc<patrol_msgs::sensor_msgs::Image>>)>,
    /// The operator's latest command on `behavior_server.cmd_vel_teleop`, and when it came
    /// (assisted_teleop.rs).
    pub teleop: Mutex<Option<(Twist2, Instant)>>,
    /// How many std_msgs/Empty have arrived on `preempt_teleop`: an assisted teleop ends when
    /// this passes its count at the start.
    pub teleop_preempts: AtomicU64,
    /// The speed limit (m/s) last set on `speed_limit_topic` or by the speed zones, if one is
    /// in force.
    pub speed_limit: RwLock<Option<f64>>,
    /// The speed zones (`speed_filter_info_topic`; Nav2's speed filter): how the mask reads, and
    /// the mask as last received.
    pub speed_zones: RwLock<crate::costmap_filters::Zones>,
    /// The binary zones (`binary_filter`; Nav2's binary filter): how the mask reads, and the
    /// mask as last received.
    pub binary_zones: RwLock<crate::costmap_filters::Zones>,
    /// The lifecycle state: only an active node plans and drives.
    pub lifecycle: RwLock<crate::lifecycle::State>,
    /// The navigation going on, if any (see [`Shared::start_navigating`]).
    navigator: Mutex<Option<Navigation>>,
}

/// Where an odometry pose comes from ([`Shared::odometry`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OdometrySource {
    /// `odom_frame -> robot_base_frame` on `/tf`, as Nav2 reads the robot's pose.
    Tf,
    /// `/odom` (nav_msgs/Odometry), while that transform does not come.
    Topic,
}

/// A behaviour's motion being driven.
#[derive(Clone, Debug)]
pub struct Moving {
    /// The goal it is made for (a behaviour action's, or the drive it recovers).
    pub owner: u64,
    pub motion: Motion,
    /// What the motion said at the last command.
    pub status: MotionStatus,
    /// When its goal last set it: a teleop not set for a while is stopped by the follower
    /// loop, whatever became of the task that sets it.
    pub set_at: Instant,
}

/// A navigation: the navigate action it counts as, and its goal.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Navigation {
    name: &'static str,
    owner: u64,
    /// A `/goal_pose`'s, which no action's drive ends: the planning task, the follower and a
    /// lifecycle transition do ([`Shared::done_topic_goal`]), until it is handed to its
    /// recoveries' drive ([`Shared::hand_topic_goal_to_drive`]), which then ends it.
    from_topic: bool,
}

impl Shared {
    /// The state at start: the parameter file's settings, no map or pose yet, and the lifecycle
    /// state `autostart` gives (without a lifecycle manager the node configures and activates
    /// itself).
    pub fn new(params: NodeParams, planning: PlannerConfig) -> Self {
        let live = Live {
            planner: planning.planner,
            max_planning_time: planning.max_planning_time,
            tolerance: planning.tolerance,
            config: planning.clone(),
            obstacles_enabled: params.obstacle_layer.enabled,
        };
        let [x, y, yaw] = params.map_to_odom;
        Self {
            localization: Mutex::new(Localization::new(
                Pose2::new(x, y, yaw),
                params.track_map_to_odom,
            )),
            tf: Mutex::new(TfBuffer::default()),
            lifecycle: RwLock::new(if params.autostart {
                crate::lifecycle::State::Active
            } else {
                crate::lifecycle::State::Unconfigured
            }),
            params,
            started: Instant::now(),
            planning,
            live: RwLock::new(live),
            map: RwLock::new(None),
            keepout: RwLock::new(None),
            obstacles: Mutex::new(Default::default()),
            sources_read_at: Mutex::new(Default::default()),
            seen_obstacles: RwLock::new(None),
            remaking: Mutex::new(()),
            grid_installed: tokio::sync::Notify::new(),
            settings_changed: tokio::sync::Notify::new(),
            checked_grid: Mutex::new((Weak::new(), Weak::new())),
            path_installed: tokio::sync::Notify::new(),
            start: RwLock::new(None),
            goals: AtomicU64::new(0),
            odom: RwLock::new(None),
            odometry_source: Mutex::new((None, None)),
            odom_local: RwLock::new(None),
            follower: Mutex::new(None),
            motion: Mutex::new(None),
            followed: Mutex::new(None),
            failed_replan: Mutex::new(None),
            arrived: Mutex::new(None),
            moving: AtomicBool::new(false),
            waypoint_inputs: AtomicU64::new(0),
            camera: Mutex::new((0, None)),
            teleop: Mutex::new(None),
            teleop_preempts: AtomicU64::new(0),
            speed_limit: RwLock::new(None),
            speed_zones: RwLock::default(),
            binary_zones: RwLock::default(),
            navigator: Mutex::new(None),
        }
    }

    /// The current map, its grid made with the costmap parameters as they are now: a grid made
    /// under values `ros2 param set` has since changed is made again first (blocking: call it
    /// off the async threads; it takes as long as inflating the map). `None` before any map.
    pub fn current_map(&self) -> Option<Arc<MapState>> {
        let wanted = || self.grid_settings();
        let current = || self.map.read().expect("lock").clone();
        let map = current()?;
        if map.is_made_with(&wanted()) {
            return Some(map);
        }
        let _one_at_a_time = self.remaking.lock().expect("lock");
        // Made meanwhile by whoever held the lock, or replaced by a newer map.
        let map = current()?;
        let settings = wanted();
        if map.is_made_with(&settings) {
            return Some(map);
        }
        // The scans' obstacles change the grid at the layer's rate: not worth a line each time.
        let (level, what) = if map.is_set_as(&settings) {
            (log::Level::Debug, "the obstacles seen changed")
        } else {
            (
                log::Level::Info,
                "costmap parameters or keepout mask changed",
            )
        };
        let t0 = Instant::now();
        match map.remade(&settings) {
            Ok(fresh) => {
                let fresh = Arc::new(fresh);
                let installed = {
                    let mut slot = self.map.write().expect("lock");
                    // A map that arrived while this one was made stays: it is the newer, and
                    // the next call brings it up to date in turn.
                    let current = slot.as_ref().is_some_and(|m| Arc::ptr_eq(m, &map));
                    if current {
                        *slot = Some(fresh.clone());
                    }
                    current
                };
                if installed {
                    self.grid_installed.notify_one();
                }
                log::log!(
                    level,
                    "{what}: the {} x {} grid made again in {:.0} ms",
                    fresh.grid.width(),
                    fresh.grid.height(),
                    t0.elapsed().as_secs_f64() * 1e3
                );
                Some(fresh)
            }
            // The values were validated when set, so this is not expected; the old grid serves.
            Err(e) => {
                log::error!("the grid could not be made again: {e}");
                Some(map)
            }
        }
    }

    /// Applies every source's latest reading to the obstacle layer, on the current map's grid
    /// (not on a costmap taken as it is), then clears the robot's footprint with
    /// `footprint_clearing_enabled` ([`crate::obstacle_layer::Seen::update`]). Blocking: the
    /// readings are traced.
    pub fn update_obstacles(&self) {
        let Some(info) = self
            .map
            .read()
            .expect("lock")
            .as_ref()
            .filter(|m| !m.is_costmap())
            .map(|m| *m.source_info())
        else {
            return;
        };
        let footprint = self
            .params
            .obstacle_layer
            .footprint_clearing_enabled
            .then(|| {
                self.fresh_odom()
                    .or_else(|| self.start.read().expect("lock").map(|(p, _)| p))
            })
            .flatten()
            .map(|robot| {
                let radius = self.live.read().expect("lock").config.costmap.robot_radius;
                (robot.position(), radius)
            });
        self.obstacles.lock().expect("lock").update(info, footprint);
    }

    /// Lays the obstacle layer on the grid, if it changed since it last was: the grid is made
    /// again from it at once ([`Shared::settings_changed`]). Returns how many cells are marked.
    pub fn lay_obstacles(&self) -> Option<usize> {
        let marked = {
            let mut seen = self.obstacles.lock().expect("lock");
            if !std::mem::take(&mut seen.changed) {
                return None;
            }
            let laid = seen.layer.clone().map(Arc::new);
            let marked = laid.as_ref().map_or(0, |l| l.marked_count());
            // Written under the layer's lock: a copy taken before a clearing can never be
            // written after the clearing's own, which would bring back what was cleared.
            *self.seen_obstacles.write().expect("lock") = laid;
            marked
        };
        self.settings_changed.notify_one();
        Some(marked)
    }

    /// Clears the obstacle layer, everything or a `square` (centre in the global frame, side in
    /// m, inside it or all but it: costmap_2d's clearing regions), forgets the sources' latest
    /// readings ([`crate::obstacle_layer::Seen::clear`]), and lays it on the grid at once, not
    /// at the layer's next update: a recovery's clearing, as Nav2's trees clear both
    /// costmaps, and the clearing services'. Returns how many cells were marked before and are
    /// after; `None` before the layer's first update. Blocking: an update holds the layer
    /// while it traces.
    pub fn clear_obstacles(&self, square: Option<(Point2, f64, bool)>) -> Option<(usize, usize)> {
        let counts = self.obstacles.lock().expect("lock").clear(square)?;
        self.lay_obstacles();
        Some(counts)
    }

    /// The limits the follower drives a plan under: the chassis' (`twist_limits`), the top speed
    /// lowered to the speed limit in force (`speed_limit_topic`), never raised.
    pub fn drive_limits(&self) -> chassis::limits::TwistLimits {
        let mut limits = self.params.twist_limits;
        if let Some(cap) = *self.speed_limit.read().expect("lock") {
            limits.max_linear = limits.max_linear.min(cap);
        }
        limits
    }

    /// What a grid made now is made with: the costmap parameters as last set, the keepout mask
    /// as last received.
    pub fn grid_settings(&self) -> GridSettings {
        let (costmap, obstacles_enabled) = {
            let live = self.live.read().expect("lock");
            (live.config.costmap.clone(), live.obstacles_enabled)
        };
        GridSettings {
            costmap,
            keepout: self.keepout.read().expect("lock").clone(),
            obstacles: obstacles_enabled
                .then(|| self.seen_obstacles.read().expect("lock").clone())
                .flatten(),
        }
    }

    /// [`Shared::clear_obstacles`] from an async task, on a blocking thread: an update holds the
    /// layer while it traces the sources' readings. The error is a clearing that panicked.
    pub async fn clear_obstacles_off_thread(
        self: &Arc<Self>,
        square: Option<(Point2, f64, bool)>,
    ) -> Result<Option<(usize, usize)>, String> {
        let shared = self.clone();
        tokio::task::spawn_blocking(move || shared.clear_obstacles(square))
            .await
            .map_err(|e| e.to_string())
    }

    /// [`Shared::current_map`] from an async task: the grid is made again, if it must be, on a
    /// blocking thread, not on the runtime's.
    pub async fn current_map_off_thread(self: &Arc<Self>) -> Option<Arc<MapState>> {
        let shared = self.clone();
        tokio::task::spawn_blocking(move || shared.current_map())
            .await
            .unwrap_or_default()
    }

    /// A goal or start as a pose in the global frame, as planner_server transforms one: from a
    /// frame the node keeps itself (`localization::KnownFrames`: the global frame, `odom_frame`,
    /// `robot_base_frame`) with its latest transform, from any other frame of the TF tree
    /// through `/tf` and `/tf_static` at the pose's stamp (tf_buffer.rs). A frame not (yet)
    /// connected, or a stamp the transforms do not (yet) reach, is waited for up to
    /// `transform_tolerance`, then TF_ERROR with the reason; a pose that is not finite is
    /// INVALID_INPUT at once.
    pub async fn pose_in_global(&self, msg: &PoseStamped) -> Result<Pose2, Failure> {
        let pose = crate::convert::pose3(&msg.pose)?;
        let origin = self
            .frame_in_global(
                &msg.header.frame_id,
                crate::convert::seconds(&msg.header.stamp),
            )
            .await?;
        Ok(crate::convert::planar(&(origin * pose)))
    }

    /// Where the frame `frame_id` is in the global frame at `stamp` (s; 0: the latest), as
    /// [`Shared::pose_in_global`] finds it (once for many poses in one frame, a path's).
    pub async fn frame_in_global(
        &self,
        frame_id: &str,
        stamp: f64,
    ) -> Result<Isometry3<f64>, Failure> {
        let frame = crate::convert::frame_name(frame_id);
        let asked = Instant::now();
        loop {
            match self.frame_in_global_now(frame, stamp) {
                Ok(t) => return Ok(t),
                Err(why) if asked.elapsed().as_secs_f64() >= self.params.transform_tolerance => {
                    return Err(Failure::new(ResultCode::TfError, why))
                }
                Err(_) => tokio::time::sleep(std::time::Duration::from_millis(20)).await,
            }
        }
    }

    /// [`Shared::frame_in_global`] with what the node holds now.
    fn frame_in_global_now(&self, frame: &str, stamp: f64) -> Result<Isometry3<f64>, String> {
        let frames = KnownFrames {
            global: &self.params.global_frame,
            odom: &self.params.odom_frame,
            map_to_odom: self.localization.lock().expect("lock").map_to_odom(),
            base: &self.params.robot_base_frame,
            robot: self.start.read().expect("lock").map(|(p, _)| p),
        };
        let tf = self.tf.lock().expect("lock");
        let (known, to_known) = tf
            .to_known_frame(frame, stamp, |f| frames.knows(f), &frames.names())
            .map_err(|e| e.to_string())?;
        Ok(crate::convert::iso3(frames.in_global(known)?) * to_known)
    }

    /// An odometry pose (the robot in `odom_frame`, stamped `stamp` s): the robot's pose from
    /// now on, carried into the global frame with `map -> odom`. Nav2 reads the robot's pose
    /// from TF (costmap_2d's `getRobotPose`), where the odometry publishes `odom -> base_link`:
    /// a robot's driver, or robot_localization's filter fusing the wheels with an IMU while
    /// `/odom` stays the raw wheel odometry. So the transform is the pose while it keeps coming
    /// (each within `pose_timeout`), and `/odom` is used only without it (a simulation or a
    /// driver that publishes no TF).
    pub fn odometry(&self, source: OdometrySource, stamp: f64, in_odom: Pose2) {
        {
            let mut last = self.odometry_source.lock().expect("lock");
            let (used, tf_at) = &mut *last;
            if source == OdometrySource::Tf {
                *tf_at = Some(Instant::now());
            } else if tf_at.is_some_and(|t| t.elapsed().as_secs_f64() <= self.params.pose_timeout) {
                return;
            }
            if *used != Some(source) {
                let (base, odom) = (&self.params.robot_base_frame, &self.params.odom_frame);
                match source {
                    OdometrySource::Tf => info!(
                        "the robot's pose now comes from `{odom}` -> `{base}` on /tf, as Nav2 \
                         reads it; /odom is not used while it keeps coming"
                    ),
                    OdometrySource::Topic if used.is_some() => warn!(
                        "no `{odom}` -> `{base}` on /tf for {} s: the robot's pose comes from \
                         /odom again",
                        self.params.pose_timeout
                    ),
                    OdometrySource::Topic => info!("the robot's pose comes from /odom"),
                }
                *used = Some(source);
            }
        }
        let in_map = self
            .localization
            .lock()
            .expect("lock")
            .odometry(stamp, in_odom);
        *self.start.write().expect("lock") = Some((in_map, Instant::now()));
        *self.odom.write().expect("lock") = Some((in_map, Instant::now()));
        *self.odom_local.write().expect("lock") = Some(in_odom);
    }

    /// The robot's pose (global frame) from odometry no older than `pose_timeout`: what the
    /// follower and the behaviours' motions steer by (`None`: they hold the robot stopped).
    pub fn fresh_odom(&self) -> Option<Pose2> {
        self.odom
            .read()
            .expect("lock")
            .filter(|(_, t)| t.elapsed().as_secs_f64() <= self.params.pose_timeout)
            .map(|(p, _)| p)
    }

    /// The robot's pose (global frame), waiting up to 3 s for the first one: an action goal
    /// sent right after start-up may arrive before the first odometry, and Nav2 waits for its
    /// transform the same way (`transform_tolerance`).
    pub async fn robot_pose(&self) -> Option<Pose2> {
        let asked = Instant::now();
        loop {
            let pose = self.start.read().expect("lock").map(|(p, _)| p);
            if pose.is_some() || asked.elapsed() >= std::time::Duration::from_secs(3) {
                return pose;
            }
            tokio::time::sleep(std::time::Duration::from_millis(100)).await;
        }
    }

    /// Takes the robot for a new goal: its number, which every older goal's plan or drive sees
    /// as newer than its own and stops for ([`Shared::owns_robot`]).
    pub fn take_robot(&self) -> u64 {
        self.goals.fetch_add(1, std::sync::atomic::Ordering::SeqCst) + 1
    }

    /// Takes the robot for a goal of the navigate action `name`, unless the other navigate
    /// action is navigating: then `Err` names it. One navigator at a time, as bt_navigator's
    /// navigators share it (`NavigatorMuxer`): a goal of the other one is refused and the
    /// running one goes on; a newer goal of the same action preempts it (action_server.rs). A
    /// navigator whose goal has lost the robot (to a `/goal_pose` it allowed, or to
    /// `follow_waypoints`, not one of bt_navigator's navigators) no longer counts. End with
    /// [`Shared::done_navigating`].
    pub fn start_navigating(&self, name: &'static str) -> Result<u64, &'static str> {
        self.navigate(name, false)
    }

    fn navigate(&self, name: &'static str, from_topic: bool) -> Result<u64, &'static str> {
        let mut navigator = self.navigator.lock().expect("lock");
        let owner = self.take_robot_unless_other(&navigator, name)?;
        *navigator = Some(Navigation {
            name,
            owner,
            from_topic,
        });
        Ok(owner)
    }

    /// Takes the robot for a goal that bt_navigator hands to its navigator `name` (a
    /// `/goal_pose`, which bt_navigator sends to its `navigate_to_pose`): refused, `Err` naming
    /// the other, while the other navigate action is navigating; a running goal of `name` itself
    /// loses the robot to it, as a preempt. The goal then navigates as `name` until it is
    /// reached, fails or loses the robot: the planning task and the follower end it
    /// ([`Shared::done_topic_goal`]), as there is no action's drive to, or, once it made no
    /// progress and is recovered, its recoveries' drive (drive.rs).
    pub fn take_robot_as(&self, name: &'static str) -> Result<u64, &'static str> {
        self.navigate(name, true)
    }

    /// The robot for a goal of `name`, unless another navigator is navigating; the caller holds
    /// the navigator's lock, so no other navigation can start in between.
    fn take_robot_unless_other(
        &self,
        navigator: &Option<Navigation>,
        name: &'static str,
    ) -> Result<u64, &'static str> {
        match *navigator {
            Some(n) if n.name != name && self.owns_robot(n.owner) => Err(n.name),
            _ => Ok(self.take_robot()),
        }
    }

    /// Ends goal `owner`'s navigation, if it is still the one navigating (an action's drive,
    /// as it ends).
    pub fn done_navigating(&self, owner: u64) {
        self.end_navigation_if(|n| n.owner == owner);
    }

    /// Ends `/goal_pose` goal `owner`'s navigation, if it is still the one navigating; an
    /// action's goal of the same number (a replan of its path fails in the planning task) is
    /// left to its drive, which may still recover.
    pub fn done_topic_goal(&self, owner: u64) {
        self.end_navigation_if(|n| n.from_topic && n.owner == owner);
    }

    /// Hands `/goal_pose` goal `owner`'s navigation to a drive (its recoveries: drive.rs), if it
    /// is still the one navigating: from now on only that drive ends it
    /// ([`Shared::done_navigating`]), as an action's drive ends its own, and the follower no
    /// longer watches its progress. Returns whether it did.
    pub fn hand_topic_goal_to_drive(&self, owner: u64) -> bool {
        let mut navigator = self.navigator.lock().expect("lock");
        match navigator.as_mut() {
            Some(n) if n.from_topic && n.owner == owner && self.owns_robot(owner) => {
                n.from_topic = false;
                true
            }
            _ => false,
        }
    }

    /// Ends a `/goal_pose`'s navigation (the node left the active state, and the follower with
    /// it); an action's drive ends its own.
    pub fn end_topic_navigation(&self) {
        self.end_navigation_if(|n| n.from_topic);
    }

    /// The `/goal_pose` goal navigating, if one is.
    pub fn topic_goal(&self) -> Option<u64> {
        let navigator = self.navigator.lock().expect("lock");
        navigator.filter(|n| n.from_topic).map(|n| n.owner)
    }

    fn end_navigation_if(&self, ends: impl Fn(&Navigation) -> bool) {
        let mut navigator = self.navigator.lock().expect("lock");
        if navigator.as_ref().is_some_and(ends) {
            *navigator = None;
        }
    }

    /// Whether goal `owner` still has the robot (no newer goal has taken it).
    pub fn owns_robot(&self, owner: u64) -> bool {
        self.goals.load(std::sync::atomic::Ordering::SeqCst) == owner
    }

    /// Hands the robot a plan to follow (`handover`), if `owner` still has the robot and the
    /// node is active; returns whether it did.
    pub fn follow(&self, owner: u64, handover: Handover) -> bool {
        self.install_follower(owner, Some(handover), Install::NewGoal)
    }

    /// As [`Shared::follow`], for a replan of the path `replaces` around a new map: only while
    /// that very path is still being followed. A drive that ended meanwhile (arrived,
    /// cancelled, out of time), or a patrol gone on to its next leg (the same owner, another
    /// path), is not sent back by a replan finishing late.
    pub fn refollow(
        &self,
        owner: u64,
        replaces: &Arc<Vec<(f64, f64)>>,
        handover: Handover,
    ) -> bool {
        self.install_follower(owner, Some(handover), Install::Replan(replaces, None))
    }

    /// The goals still ahead on `path` (see [`Followed::goals_ahead`]), if it is still the path
    /// being followed.
    pub fn goals_ahead_on(&self, path: &Arc<Vec<(f64, f64)>>) -> Option<Vec<Pose2>> {
        let follower = self.follower.lock().expect("lock");
        let followed = self.followed.lock().expect("lock");
        let (f, now) = (follower.as_ref()?, followed.as_ref()?);
        Arc::ptr_eq(&now.path, path).then(|| now.goals_ahead(f.progress()))
    }

    /// The goals still ahead of goal `owner`'s robot, if its path is being followed.
    pub fn goals_ahead_of(&self, owner: u64) -> Option<Vec<Pose2>> {
        let follower = self.follower.lock().expect("lock");
        let followed = self.followed.lock().expect("lock");
        let (f, now) = (follower.as_ref()?, followed.as_ref()?);
        (now.owner == owner).then(|| now.goals_ahead(f.progress()))
    }

    /// Whether goal `owner`'s path was finished (the follower arrived) since `since`.
    pub fn arrived_since(&self, owner: u64, since: Instant) -> bool {
        matches!(*self.arrived.lock().expect("lock"), Some((o, at)) if o == owner && at >= since)
    }

    /// Whether goal `owner`'s path is being followed.
    pub fn is_following(&self, owner: u64) -> bool {
        (self.followed.lock().expect("lock").as_ref()).is_some_and(|f| f.owner == owner)
    }

    /// Stops the robot (the follower loop brakes it to a stop: no plan, no behaviour's motion)
    /// if `owner` still has it: a goal that ends does not stop a newer one's drive.
    pub fn stop_following(&self, owner: u64) -> bool {
        self.install_follower(owner, None, Install::NewGoal)
    }

    /// Hands the robot a behaviour's motion for goal `owner`, in place of any plan being
    /// followed, if `owner` still has the robot and the node is active; returns whether it did.
    pub fn start_motion(&self, owner: u64, motion: Motion) -> bool {
        let mut follower = self.follower.lock().expect("lock");
        let mut followed = self.followed.lock().expect("lock");
        if !self.owns_robot(owner) || self.refusal().is_some() {
            return false;
        }
        *follower = None;
        *followed = None;
        *self.motion.lock().expect("lock") = Some(Moving {
            owner,
            motion,
            status: MotionStatus::Running,
            set_at: Instant::now(),
        });
        true
    }

    /// Goal `owner`'s motion as it is now, if it is still being driven.
    pub fn motion_of(&self, owner: u64) -> Option<Moving> {
        let motion = self.motion.lock().expect("lock");
        motion.as_ref().filter(|m| m.owner == owner).cloned()
    }

    /// Sets the command of goal `owner`'s teleop motion (assisted_teleop.rs); false when the
    /// robot is no longer driven by it.
    pub fn set_teleop(&self, owner: u64, twist: Twist2) -> bool {
        let mut motion = self.motion.lock().expect("lock");
        match motion.as_mut() {
            Some(Moving {
                owner: o,
                motion: Motion::Teleop(teleop),
                set_at,
                ..
            }) if *o == owner => {
                teleop.twist = twist;
                *set_at = Instant::now();
                true
            }
            _ => false,
        }
    }

    /// Ends goal `owner`'s motion, if it is still being driven: the follower loop brakes the
    /// robot to a stop.
    pub fn stop_motion(&self, owner: u64) {
        let mut motion = self.motion.lock().expect("lock");
        if motion.as_ref().is_some_and(|m| m.owner == owner) {
            *motion = None;
        }
    }

    /// Stops a goal whose replan of the path `replaced` failed, if that path is still being
    /// followed, with the reason its drive reports.
    pub fn replan_failed(&self, owner: u64, replaced: &Arc<Vec<(f64, f64)>>, why: Failure) -> bool {
        self.install_follower(owner, None, Install::Replan(replaced, Some(why)))
    }

    /// Takes the reason goal `owner`'s replan failed, if it did.
    pub fn take_failed_replan(&self, owner: u64) -> Option<Failure> {
        let mut failed = self.failed_replan.lock().expect("lock");
        match failed.take() {
            Some((o, f)) if o == owner => Some(f),
            other => {
                *failed = other;
                None
            }
        }
    }

    /// Under the follower's lock, so a newer goal's plan, installed meanwhile, is never
    /// overwritten by an older one's (the lock order everywhere: follower, then followed, then
    /// motion or lifecycle, each taken last and let go at once; the lifecycle services take
    /// the follower's lock only after releasing theirs).
    /// Only an active node is handed a path: a plan that finishes after a deactivation does not
    /// start the robot. Stopping is always allowed.
    fn install_follower(&self, owner: u64, next: Option<Handover>, how: Install) -> bool {
        // Made before the locks are taken: they are held only to swap it in.
        let next = match next {
            Some(Handover {
                goals,
                via_at,
                path,
                goal_yaw,
            }) => {
                let path = Arc::new(path);
                match Follower::new(self.params.follower, path.to_vec(), goal_yaw) {
                    Some(f) => Some((
                        f,
                        Followed {
                            owner,
                            goals,
                            via_at,
                            path,
                        },
                    )),
                    None => return false,
                }
            }
            None => None,
        };
        let mut follower = self.follower.lock().expect("lock");
        let mut followed = self.followed.lock().expect("lock");
        if !self.owns_robot(owner) {
            return false;
        }
        if let Install::Replan(replaces, _) = &how {
            let same = |f: &Followed| f.owner == owner && Arc::ptr_eq(&f.path, replaces);
            if follower.is_none() || !followed.as_ref().is_some_and(same) {
                return false;
            }
        }
        let Some((f, plan)) = next else {
            *follower = None;
            *followed = None;
            *self.motion.lock().expect("lock") = None;
            // Told before the follower's lock is let go: the drive that sees no follower finds
            // the reason waiting.
            if let Install::Replan(_, Some(why)) = how {
                *self.failed_replan.lock().expect("lock") = Some((owner, why));
            }
            return true;
        };
        if self.refusal().is_some() {
            return false;
        }
        *follower = Some(f);
        *followed = Some(plan);
        *self.motion.lock().expect("lock") = None;
        self.path_installed.notify_one();
        true
    }

    /// Why the node cannot plan now, if it cannot: it is not active.
    pub fn refusal(&self) -> Option<crate::result::Failure> {
        let state = *self.lifecycle.read().expect("lock");
        (state != crate::lifecycle::State::Active).then(|| {
            crate::result::Failure::new(
                crate::result::ResultCode::NotActive,
                format!(
                    "the node is {} (lifecycle): it plans once activated",
                    state.label()
                ),
            )
        })
    }
}

/// The length of a path (map metres) along its points.
pub fn path_length(points: &[(f64, f64)]) -> f64 {
    points
        .windows(2)
        .map(|w| (w[1].0 - w[0].0).hypot(w[1].1 - w[0].1))
        .sum()
}

/// A plan handed to the follower.
#[derive(Clone, Debug)]
pub struct Handover {
    /// Where the plan goes: its via poses in order, then its goal (global frame).
    pub goals: Vec<Pose2>,
    /// Where the path passes each via pose: an index into `path`.
    pub via_at: Vec<usize>,
    /// The path (map metres), as published.
    pub path: Vec<(f64, f64)>,
    /// The heading to end with.
    pub goal_yaw: f64,
}

impl Handover {
    /// The plan published as `path` for `goals` (via poses, then the goal), whose planner
    /// passed the via poses at `via` (each the pose, or the free cell it was moved to: one of
    /// the plan's vertices, which the published path keeps exactly).
    pub fn new(goals: Vec<Pose2>, path: &Path, via: &[Point2], goal_yaw: f64) -> Self {
        let path: Vec<(f64, f64)> = path
            .poses
            .iter()
            .map(|q| (q.pose.position.x, q.pose.position.y))
            .collect();
        // Each via point, searched from the last one on: a path may pass a place twice.
        let mut from = 0;
        let via_at = via
            .iter()
            .map(|v| {
                let d = |p: &(f64, f64)| (p.0 - v.x).hypot(p.1 - v.y);
                let at = (from..path.len())
                    .find(|&i| d(&path[i]) < 1e-9)
                    .or_else(|| {
                        (from..path.len()).min_by(|&a, &b| d(&path[a]).total_cmp(&d(&path[b])))
                    })
                    .unwrap_or(from);
                from = at;
                at
            })
            .collect();
        Self {
            goals,
            via_at,
            path,
            goal_yaw,
        }
    }
}

/// How a path is handed to the follower.
#[derive(Debug)]
enum Install<'a> {
    /// A goal's first plan (or its stop): while the goal has the robot.
    NewGoal,
    /// A replan of the goal's path: while that very path is still being followed, too; with
    /// the reason, when the replan failed.
    Replan(&'a Arc<Vec<(f64, f64)>>, Option<Failure>),
}

/// The plan being followed: its owner (its number in [`Shared::goals`]), where it goes and its
/// path (map metres; shared, so a drive can tell a replanned path from the one it started on).
#[derive(Clone, Debug)]
pub struct Followed {
    pub owner: u64,
    /// The via poses in order, then the goal (global frame).
    pub goals: Vec<Pose2>,
    /// Where the path passes each via pose (an index into `path`).
    pub via_at: Vec<usize>,
    pub path: Arc<Vec<(f64, f64)>>,
}

impl Followed {
    /// The goals still ahead of a robot at `progress` along the path (the follower's
    /// [`Follower::progress`]): the via poses the path has not reached yet, then the goal. A via
    /// pose counts as passed once the robot's nearest path point is the one at it, as Nav2's
    /// RemovePassedGoals drops a goal the robot has come to.
    pub fn goals_ahead(&self, progress: usize) -> Vec<Pose2> {
        let Some((goal, via)) = self.goals.split_last() else {
            return Vec::new();
        };
        via.iter()
            .zip(&self.via_at)
            .filter(|&(_, &at)| at > progress)
            .map(|(&p, _)| p)
            .chain(std::iter::once(*goal))
            .collect()
    }

    /// How many of [`Followed::goals_ahead`] there are, without making the list (each tick's
    /// feedback counts them).
    pub fn poses_ahead(&self, progress: usize) -> usize {
        // `via_at` never decreases along the path.
        self.via_at.len() - self.via_at.partition_point(|&at| at <= progress) + 1
    }
}

/// A goal for the planning task (`plan_goals`): a `/goal_pose`, or the goal being followed again
/// after a new map blocked its path.
#[derive(Clone, Debug)]
pub struct GoalRequest {
    /// The goal's number (see [`Shared::goals`]); a replan keeps its goal's.
    pub owner: u64,
    /// The via poses still ahead in order (a replan of `navigate_through_poses`), then the goal.
    pub goals: Vec<Pose2>,
    /// For a replan, the blocked path it replaces: the new path replaces it only while it is
    /// still followed ([`Shared::refollow`]), and a failure is reported to the goal's drive.
    pub replaces: Option<Arc<Vec<(f64, f64)>>>,
}

/// The newest goal waiting to be planned: newer ones replace it before it is planned.
pub type GoalSlot = Option<GoalRequest>;

#[cfg(test)]
mod tests {
    use super::*;
    use planner_core::geometry::Cell;
    use planner_core::grid::MapInfo;

    /// A 40 x 10 map at 0.1 m with a wall across its left end (column 0).
    fn wall_map() -> GridMap {
        wall_map_at(0)
    }

    /// A 40 x 10 map at 0.1 m with a wall across it at `column`.
    fn wall_map_at(column: usize) -> GridMap {
        let (w, h) = (40, 10);
        let data = (0..w * h)
            .map(|i| if i % w == column { 100 } else { 0 })
            .collect();
        let info = MapInfo {
            width: w as u32,
            height: h as u32,
            resolution: 0.1,
            origin: Pose2::new(0.0, 0.0, 0.0),
        };
        GridMap::new(info, data).unwrap()
    }

    fn shared_with(map: GridMap, as_costmap: bool) -> Shared {
        let s = Shared::new(NodeParams::default(), PlannerConfig::default());
        let state = MapState::new(Arc::new(map), as_costmap, &s.grid_settings()).unwrap();
        *s.map.write().unwrap() = Some(Arc::new(state));
        s
    }

    #[test]
    fn a_downsampled_grid_is_made_again_from_the_map_as_it_arrived() {
        let costmap = GridSettings::without_keepout(InflationConfig {
            downsampling_factor: 2,
            safety_margin: 0.3,
            ..InflationConfig::default()
        });
        assert!((costmap.costmap.radius() - 0.55).abs() < 1e-12);
        let state = MapState::new(Arc::new(wall_map_at(1)), false, &costmap).unwrap();
        assert_eq!((state.map().width(), state.map().height()), (20, 5));
        assert_eq!((state.grid.width(), state.grid.height()), (20, 5));
        assert!((state.grid.resolution() - 0.2).abs() < 1e-12);
        // The wall (column 1) is inflated by 0.55 m at full resolution (columns up to 6, 0.5 m
        // off, blocked), then downsampled: coarse column 3 (columns 6-7) is blocked, 4 free.
        // Downsampled first, the wall would be coarse column 0 and column 3 (0.6 m from it)
        // free, with the robot's centre allowed 0.5 m from the wall.
        assert!(!state.grid.is_free(Cell::new(3, 2)) && state.grid.is_free(Cell::new(4, 2)));
        assert_eq!(state.map().value(Cell::new(0, 2)), 100);
        let wider = GridSettings::without_keepout(InflationConfig {
            safety_margin: 0.6,
            ..costmap.costmap.clone()
        });
        let remade = state.remade(&wider).unwrap();
        assert_eq!(
            remade.map().width(),
            20,
            "made from the map as it arrived, not downsampled twice"
        );
        assert!(state.is_made_with(&costmap) && !state.is_made_with(&wider));
        assert!(!state.is_made_with(&GridSettings::without_keepout(InflationConfig::default())));
        // A costmap is downsampled too, and its factor read like its allow_unknown.
        let as_costmap = MapState::new(Arc::new(wall_map()), true, &costmap).unwrap();
        assert_eq!(as_costmap.grid.width(), 20);
        assert!(
            !as_costmap.is_made_with(&GridSettings::without_keepout(InflationConfig::default()))
        );
        // A keepout mask is part of what the grid is made with: another mask (even an equal
        // copy: masks are told apart by identity, as received) makes it again.
        let mask = Arc::new(wall_map_at(10));
        let kept_out = GridSettings {
            keepout: Some(mask.clone()),
            ..costmap.clone()
        };
        let under = state.remade(&kept_out).unwrap();
        assert!(under.is_made_with(&kept_out) && !under.is_made_with(&costmap));
        assert!(!state.is_made_with(&kept_out));
        let copy = GridSettings {
            keepout: Some(Arc::new(wall_map_at(10))),
            ..costmap.clone()
        };
        assert!(!under.is_made_with(&copy));
        // The mask's wall (column 10) is lethal but not inflated: the robot's centre is kept out
        // of its coarse column 5 only, while the map's wall at column 1 is inflated.
        assert!(!under.grid.is_free(Cell::new(5, 2)));
        assert!(under.grid.is_free(Cell::new(4, 2)) && under.grid.is_free(Cell::new(6, 2)));
        assert!(state.grid.is_free(Cell::new(5, 2)));
    }

    /// The obstacles the scans have shown are laid on the map before it is inflated (a seen
    /// obstacle keeps the robot's radius and margin off, as a wall does), are part of what a
    /// grid is made with (a new layer makes it again), and are left off a map of another size.
    #[test]
    fn seen_obstacles_are_inflated_with_the_map() {
        use planner_core::grid::obstacle_layer::Ray;
        let settings = GridSettings::without_keepout(InflationConfig::default());
        let radius = settings.costmap.radius();
        assert!(radius > 0.2 && radius < 0.8, "{radius}");
        let map = Arc::new(wall_map_at(1));
        let mut layer = ObstacleLayer::new(*map.info());
        // A return in cell (20, 5), seen from half a metre before it.
        let at = Point2::new(2.05, 0.55);
        assert!(layer.observe(
            &[&[Ray {
                clear: Some((Point2::new(1.55, 0.55), at)),
                mark: Some(at),
            }]],
            None
        ));
        let seen = GridSettings {
            obstacles: Some(Arc::new(layer)),
            ..settings.clone()
        };
        let state = MapState::new(map.clone(), false, &seen).unwrap();
        assert_eq!(state.map().value(Cell::new(20, 5)), 100);
        // 0.2 m off is within the inflated radius, 0.8 m off is not.
        assert!(!state.grid.is_free(Cell::new(20, 5)) && !state.grid.is_free(Cell::new(22, 5)));
        assert!(state.grid.is_free(Cell::new(28, 5)));
        assert!(state.is_made_with(&seen) && !state.is_made_with(&settings));
        let plain = state.remade(&settings).unwrap();
        assert!(plain.grid.is_free(Cell::new(20, 5)) && plain.is_made_with(&settings));
        let narrower = GridMap::new(
            MapInfo {
                width: 30,
                ..*map.info()
            },
            vec![0; 300],
        )
        .unwrap();
        let other = MapState::new(Arc::new(narrower), false, &seen).unwrap();
        assert!(
            other.grid.is_free(Cell::new(20, 5)),
            "a layer of another grid is not laid"
        );
    }

    /// A published costmap marks a cell unknown only where the map is and no keepout zone lies
    /// over it: a zone laid over unexplored space shows there, as Nav2's keepout filter's does,
    /// and the free rest of the mask leaves unexplored space unknown.
    #[test]
    fn a_keepout_zone_over_unknown_space_is_no_longer_unknown() {
        let mut map = wall_map();
        let w = map.width() as usize;
        // Unknown: columns 30-39 of the 40 x 10 map.
        let data: Vec<i8> = (0..map.data().len())
            .map(|i| if i % w >= 30 { UNKNOWN } else { map.data()[i] })
            .collect();
        map = GridMap::new(*map.info(), data).unwrap();
        // A mask over x 3.0-3.5 m (columns 30-34): 100, free at column 33, unknown at 34.
        let mask = GridMap::new(
            MapInfo {
                width: 5,
                height: 10,
                resolution: 0.1,
                origin: Pose2::new(3.0, 0.0, 0.0),
            },
            (0..50)
                .map(|i| match i % 5 {
                    4 => UNKNOWN,
                    3 => 0,
                    _ => 100,
                })
                .collect(),
        )
        .unwrap();
        let allow = InflationConfig {
            allow_unknown: true,
            ..InflationConfig::default()
        };
        let settings = GridSettings {
            keepout: Some(Arc::new(mask)),
            ..GridSettings::without_keepout(allow.clone())
        };
        let state = MapState::new(Arc::new(map.clone()), false, &settings).unwrap();
        let unknown: Vec<usize> = (0..w).filter(|&x| state.is_unknown(2 * w + x)).collect();
        assert_eq!(unknown, vec![33, 34, 35, 36, 37, 38, 39]);
        let bare =
            MapState::new(Arc::new(map), false, &GridSettings::without_keepout(allow)).unwrap();
        assert!((30..40).all(|x| bare.is_unknown(2 * w + x)));
        assert!(!bare.is_unknown(2 * w + 29));
    }

    /// A speed limit lowers the top speed a plan is driven at, never raises it past the
    /// chassis' limit, and leaves the turn rate and accelerations as they are.
    #[test]
    fn a_speed_limit_lowers_the_top_speed_only() {
        let s = Shared::new(NodeParams::default(), PlannerConfig::default());
        let chassis = s.params.twist_limits;
        assert_eq!(s.drive_limits(), chassis);
        *s.speed_limit.write().unwrap() = Some(0.2);
        let slow = s.drive_limits();
        assert_eq!(slow.max_linear, 0.2);
        assert_eq!(
            (slow.max_angular, slow.max_linear_accel),
            (chassis.max_angular, chassis.max_linear_accel)
        );
        *s.speed_limit.write().unwrap() = Some(5.0);
        assert_eq!(s.drive_limits().max_linear, chassis.max_linear);
    }

    #[test]
    fn a_changed_inflation_makes_the_grid_again_once() {
        let s = shared_with(wall_map(), false);
        let first = s.current_map().unwrap();
        assert!(
            Arc::ptr_eq(&first, &s.current_map().unwrap()),
            "unchanged: the same grid"
        );
        // 0.45 m inflated by default: the cell 0.6 m off the wall is free, and 0.3 m is not.
        let (near, far) = (Cell::new(6, 5), Cell::new(12, 5));
        assert!(first.grid.is_free(far) && !first.grid.is_free(Cell::new(3, 5)));
        let cost_before = first.grid.cost(far);
        s.live.write().unwrap().config.costmap.safety_margin = 0.6;
        let wider = s.current_map().unwrap();
        assert!(!Arc::ptr_eq(&first, &wider));
        assert!(
            !wider.grid.is_free(near),
            "0.85 m inflated: 0.6 m off the wall is blocked"
        );
        assert!(wider.grid.is_free(Cell::new(10, 5)));
        assert!(
            Arc::ptr_eq(&wider, &s.current_map().unwrap()),
            "made once, then kept"
        );
        assert!(
            Arc::ptr_eq(&wider, s.map.read().unwrap().as_ref().unwrap()),
            "and installed"
        );
        // The graded costs follow the inflation's own parameters.
        s.live.write().unwrap().config.costmap.cost_scaling_factor = 10.0;
        let steeper = s.current_map().unwrap();
        assert!(
            steeper.grid.cost(far) < cost_before,
            "{} -> {}",
            cost_before,
            steeper.grid.cost(far)
        );
    }

    #[test]
    fn a_costmap_taken_as_it_is_ignores_the_inflation() {
        let s = shared_with(wall_map(), true);
        let first = s.current_map().unwrap();
        s.live.write().unwrap().config.costmap.inflation_radius = 3.0;
        assert!(Arc::ptr_eq(&first, &s.current_map().unwrap()));
        // Only its reading of unknown cells is the node's.
        s.live.write().unwrap().config.costmap.allow_unknown = true;
        assert!(!Arc::ptr_eq(&first, &s.current_map().unwrap()));
    }

    fn straight() -> Vec<(f64, f64)> {
        vec![(0.0, 0.0), (1.0, 0.0), (2.0, 0.0)]
    }

    /// `path` handed over as a plan to (2, 0), with no via poses.
    fn to_goal(path: Vec<(f64, f64)>) -> Handover {
        Handover {
            goals: vec![Pose2::new(2.0, 0.0, 0.0)],
            via_at: Vec::new(),
            path,
            goal_yaw: 0.0,
        }
    }

    /// Out along x to (2, 0) and back to (0, 0), then up to (0, 1): via poses at (2, 0) and at
    /// (0, 0), where the path also starts. Each is found in order, the second at its second
    /// passage; each counts as passed once the robot's progress reaches it.
    #[test]
    fn via_poses_are_found_in_order_along_the_path_and_passed_by_progress() {
        let pose = |x: f64, y: f64| {
            crate::convert::pose_stamped(Pose2::new(x, y, 0.0), Default::default())
        };
        let points = [
            (0.0, 0.0),
            (1.0, 0.0),
            (2.0, 0.0),
            (1.0, 0.0),
            (0.0, 0.0),
            (0.0, 1.0),
        ];
        let path = Path {
            header: Default::default(),
            poses: points.iter().map(|&(x, y)| pose(x, y)).collect(),
        };
        let goals = vec![
            Pose2::new(2.0, 0.0, 0.0),
            Pose2::new(0.0, 0.0, 0.0),
            Pose2::new(0.0, 1.0, 1.0),
        ];
        let via = [Point2::new(2.0, 0.0), Point2::new(0.0, 0.0)];
        let h = Handover::new(goals.clone(), &path, &via, 1.0);
        assert_eq!(h.via_at, vec![2, 4]);
        assert_eq!(h.path, points.to_vec());
        let followed = Followed {
            owner: 1,
            goals: h.goals,
            via_at: h.via_at,
            path: Arc::new(h.path),
        };
        assert_eq!(followed.goals_ahead(0), goals);
        assert_eq!(followed.goals_ahead(1), goals);
        assert_eq!(followed.goals_ahead(2), goals[1..]);
        assert_eq!(followed.goals_ahead(4), goals[2..]);
        assert_eq!(followed.goals_ahead(5), goals[2..]);
        for progress in 0..points.len() {
            assert_eq!(
                followed.poses_ahead(progress),
                followed.goals_ahead(progress).len()
            );
        }
        // No via poses: the goal alone, wherever the robot is.
        let plain = Handover::new(goals[2..].to_vec(), &path, &[], 1.0);
        assert!(plain.via_at.is_empty());
        let plain = Followed {
            owner: 1,
            goals: plain.goals,
            via_at: plain.via_at,
            path: Arc::new(plain.path),
        };
        for progress in 0..points.len() {
            assert_eq!(plain.goals_ahead(progress), goals[2..]);
            assert_eq!(plain.poses_ahead(progress), 1);
        }
    }

    #[test]
    fn a_newer_goal_takes_the_robot_and_an_older_one_cannot_take_it_back() {
        let s = Shared::new(NodeParams::default(), PlannerConfig::default());
        let old = s.take_robot();
        assert!(s.follow(old, to_goal(straight())));
        let new = s.take_robot();
        assert!(
            !s.follow(old, to_goal(straight())),
            "the older goal's plan came late"
        );
        assert!(
            !s.stop_following(old),
            "nor does its end stop the newer goal"
        );
        assert!(s.follower.lock().unwrap().is_some());
        assert!(s.stop_following(new));
        assert!(s.follower.lock().unwrap().is_none() && s.followed.lock().unwrap().is_none());
    }

    /// A behaviour's motion stands in for the plan of the goal that has the robot: it replaces
    /// that plan, a newer goal's plan replaces it, and an older goal can neither start nor end
    /// one; an inactive node starts none.
    #[test]
    fn a_motion_belongs_to_the_goal_that_has_the_robot() {
        let spin = || chassis::behavior::Motion::Spin(chassis::behavior::Spin::new(1.0).unwrap());
        let s = Shared::new(NodeParams::default(), PlannerConfig::default());
        let old = s.take_robot();
        assert!(s.follow(old, to_goal(straight())));
        assert!(s.start_motion(old, spin()));
        assert!(s.follower.lock().unwrap().is_none() && s.followed.lock().unwrap().is_none());
        assert!(s.motion_of(old).is_some());
        let new = s.take_robot();
        assert!(
            !s.start_motion(old, spin()),
            "the older goal's motion came late"
        );
        s.stop_motion(new);
        assert!(
            s.motion_of(old).is_some(),
            "another goal's stop leaves it be"
        );
        assert!(s.follow(new, to_goal(straight())));
        assert!(
            s.motion.lock().unwrap().is_none(),
            "the newer goal's plan replaced it"
        );
        assert!(s.start_motion(new, spin()));
        s.stop_motion(new);
        assert!(s.motion.lock().unwrap().is_none());
        // A goal that takes the robot stops whatever drove it, a motion too.
        assert!(s.start_motion(new, spin()));
        let newest = s.take_robot();
        assert!(s.stop_following(newest));
        assert!(s.motion.lock().unwrap().is_none());
        *s.lifecycle.write().unwrap() = crate::lifecycle::State::Inactive;
        assert!(!s.start_motion(newest, spin()));
    }

    #[test]
    fn one_navigator_at_a_time_as_bt_navigator() {
        let s = Shared::new(NodeParams::default(), PlannerConfig::default());
        let route = s.start_navigating("navigate_through_poses").unwrap();
        assert_eq!(
            s.start_navigating("navigate_to_pose"),
            Err("navigate_through_poses"),
            "the other navigator is refused"
        );
        assert!(s.owns_robot(route), "and the running one keeps the robot");
        // A newer goal of the same action takes over, and the older one's end leaves it be.
        let newer = s.start_navigating("navigate_through_poses").unwrap();
        assert!(newer > route && s.owns_robot(newer));
        s.done_navigating(route);
        assert!(s.start_navigating("navigate_to_pose").is_err());
        s.done_navigating(newer);
        let pose = s.start_navigating("navigate_to_pose").unwrap();
        // A /goal_pose preempts navigate_to_pose, as bt_navigator hands it to that navigator,
        // and navigates as it: the other is refused until the click's goal ends.
        let click = s.take_robot_as("navigate_to_pose").unwrap();
        assert!(s.owns_robot(click) && !s.owns_robot(pose));
        s.done_navigating(pose);
        assert_eq!(
            s.start_navigating("navigate_through_poses"),
            Err("navigate_to_pose")
        );
        assert_eq!(s.topic_goal(), Some(click));
        // Ending the click's navigation as a /goal_pose's leaves an action's of another number
        // be, and ends its own.
        s.done_topic_goal(click - 1);
        assert_eq!(s.topic_goal(), Some(click));
        s.done_topic_goal(click);
        assert_eq!(s.topic_goal(), None);
        // A click handed to its recoveries' drive is that drive's to end, as an action's is.
        let click = s.take_robot_as("navigate_to_pose").unwrap();
        assert!(s.hand_topic_goal_to_drive(click));
        assert!(!s.hand_topic_goal_to_drive(click), "once");
        assert_eq!(s.topic_goal(), None, "the follower no longer watches it");
        s.done_topic_goal(click);
        s.end_topic_navigation();
        assert_eq!(
            s.start_navigating("navigate_through_poses"),
            Err("navigate_to_pose")
        );
        s.done_navigating(click);
        let route = s.start_navigating("navigate_through_poses").unwrap();
        // While a route drives, a /goal_pose is refused and the route keeps the robot.
        assert_eq!(
            s.take_robot_as("navigate_to_pose"),
            Err("navigate_through_poses")
        );
        assert!(s.owns_robot(route));
        // A patrol taking the robot ends the route's navigation: a /goal_pose is taken again.
        s.take_robot();
        assert!(s.take_robot_as("navigate_to_pose").is_ok());
        // A node leaving the active state ends a /goal_pose's navigation, not an action's (its
        // drive ends it).
        s.end_topic_navigation();
        let route = s.start_navigating("navigate_through_poses").unwrap();
        s.end_topic_navigation();
        s.done_topic_goal(route);
        assert_eq!(
            s.start_navigating("navigate_to_pose"),
            Err("navigate_through_poses"),
            "an action's navigation ends only with its drive"
        );
        s.done_navigating(route);
        assert!(s.start_navigating("navigate_to_pose").is_ok());
    }

    #[test]
    fn a_replan_replaces_only_a_path_still_followed() {
        let s = Shared::new(NodeParams::default(), PlannerConfig::default());
        let id = s.take_robot();
        let none = Arc::new(straight());
        assert!(
            !s.refollow(id, &none, to_goal(straight())),
            "nothing followed yet"
        );
        assert!(s.follow(id, to_goal(straight())));
        let first = s.followed.lock().unwrap().clone().unwrap().path;
        assert!(
            !s.refollow(id, &none, to_goal(straight())),
            "another path, equal or not"
        );
        assert!(s.refollow(id, &first, to_goal(vec![(0.0, 0.0), (2.0, 0.0)])));
        let second = s.followed.lock().unwrap().clone().unwrap().path;
        assert!(!Arc::ptr_eq(&first, &second) && second.len() == 2);
        // A patrol's next leg (same owner, new path): the last leg's late replan is refused.
        assert!(s.follow(id, to_goal(straight())));
        let leg = s.followed.lock().unwrap().clone().unwrap().path;
        assert!(!s.refollow(id, &second, to_goal(straight())));
        let late = Failure::new(ResultCode::NoValidPath, "late");
        assert!(!s.replan_failed(id, &second, late.clone()));
        assert!(Arc::ptr_eq(
            &leg,
            &s.followed.lock().unwrap().clone().unwrap().path
        ));
        // The drive ends (cancelled): a replan finishing late does not start it again.
        assert!(s.stop_following(id));
        assert!(!s.refollow(id, &leg, to_goal(straight())));
        assert!(s.follower.lock().unwrap().is_none());
        assert!(!s.replan_failed(id, &leg, late));
        assert!(s.take_failed_replan(id).is_none());
    }

    /// A replan takes the goals still ahead on the path it replaces, and only while that path
    /// is followed; an arrival counts for its own goal, after the drive started.
    #[test]
    fn a_replan_goes_on_from_the_goals_still_ahead_and_arrival_is_per_goal() {
        let s = Shared::new(NodeParams::default(), PlannerConfig::default());
        let id = s.take_robot();
        let goals = vec![Pose2::new(1.0, 0.0, 0.0), Pose2::new(2.0, 0.0, 0.0)];
        let handover = Handover {
            goals: goals.clone(),
            via_at: vec![1],
            ..to_goal(straight())
        };
        assert!(s.follow(id, handover));
        let path = s.followed.lock().unwrap().clone().unwrap().path;
        assert_eq!(s.goals_ahead_on(&path), Some(goals.clone()));
        assert_eq!(
            s.goals_ahead_on(&Arc::new(straight())),
            None,
            "another path"
        );
        let started = Instant::now();
        assert!(!s.arrived_since(id, started));
        *s.arrived.lock().unwrap() = Some((id, Instant::now()));
        assert!(s.arrived_since(id, started));
        assert!(!s.arrived_since(id + 1, started), "another goal's drive");
        assert!(
            !s.arrived_since(id, Instant::now()),
            "an arrival before this drive started"
        );
    }

    #[test]
    fn a_failed_replan_stops_the_robot_and_tells_its_own_drive_why() {
        let s = Shared::new(NodeParams::default(), PlannerConfig::default());
        let id = s.take_robot();
        assert!(s.follow(id, to_goal(straight())));
        let path = s.followed.lock().unwrap().clone().unwrap().path;
        let why = Failure::new(ResultCode::NoValidPath, "walled in");
        assert!(s.replan_failed(id, &path, why));
        assert!(s.follower.lock().unwrap().is_none());
        assert!(
            s.take_failed_replan(id + 1).is_none(),
            "another goal's drive is not told"
        );
        assert_eq!(s.take_failed_replan(id).unwrap().message, "walled in");
        assert!(s.take_failed_replan(id).is_none(), "told once");
    }

    #[test]
    fn an_inactive_node_is_handed_no_path_but_may_always_stop() {
        let s = Shared::new(NodeParams::default(), PlannerConfig::default());
        *s.lifecycle.write().unwrap() = crate::lifecycle::State::Inactive;
        let id = s.take_robot();
        assert!(!s.follow(id, to_goal(straight())));
        assert!(s.follower.lock().unwrap().is_none());
        assert!(s.stop_following(id));
        *s.lifecycle.write().unwrap() = crate::lifecycle::State::Active;
        assert!(s.follow(id, to_goal(straight())));
    }

    #[test]
    fn no_map_no_grid() {
        let s = Shared::new(NodeParams::default(), PlannerConfig::default());
        assert!(s.current_map().is_none());
    }
}
