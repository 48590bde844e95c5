//! What the node's tasks share: the parameters, the settings `ros2 param set` changes, the
//! current map with its planning grid, the latest poses, the goal counter and the plan being
//! followed. Locks are held only to copy a value in or out, never across an await or a plan.

use crate::localization::Localization;
use chassis::follower::Follower;
use planner_core::config::PlannerConfig;
use planner_core::geometry::Pose2;
use planner_core::grid::PlanningGrid;
use planner_core::PlannerName;
use planner_io::parameters::NodeParams;
use std::sync::atomic::{AtomicBool, AtomicU64};
use std::sync::{Arc, Mutex, RwLock};
use std::time::Instant;

/// Settings that `ros2 param set` may change while the node runs.
#[derive(Clone, Debug)]
pub struct Live {
    pub planner: PlannerName,
    pub max_planning_time: f64,
    pub tolerance: f64,
    /// The planning configuration with the objective weights as last set
    /// (`crate::params::WEIGHTS`); the next plan is built from it.
    pub config: PlannerConfig,
}

/// A validated map's planning grid (inflated obstacles, clearance, the map's metadata).
pub struct MapState {
    pub grid: PlanningGrid,
}

/// What the tasks share.
pub struct Shared {
    /// The node's own parameters (frames, map, follower).
    pub params: NodeParams,
    /// The planning parameters from the file; `live` overrides the ones set at run time.
    pub planning: PlannerConfig,
    pub live: RwLock<Live>,
    pub map: RwLock<Option<Arc<MapState>>>,
    /// The latest start pose (map frame) and when it arrived.
    pub start: RwLock<Option<(Pose2, Instant)>>,
    /// Counts goals: a running goal plan stops when it moves on.
    pub goals: AtomicU64,
    /// `map -> odom` and the recent odometry (see localization.rs).
    pub localization: Mutex<Localization>,
    /// The latest `/odom` pose (map frame) and when it arrived: the follower's feedback.
    pub odom: RwLock<Option<(Pose2, Instant)>>,
    /// The plan being followed, if any.
    pub follower: Mutex<Option<Follower>>,
    /// The goal and path (map metres) of the plan being followed: checked again when a new
    /// map arrives, and replanned only when the new map blocks it.
    pub followed: Mutex<Option<Followed>>,
    /// Whether the last `/cmd_vel` the follower sent was not a stop (shutdown then sends one).
    pub moving: AtomicBool,
    /// The lifecycle state: only an active node plans and drives.
    pub lifecycle: RwLock<crate::lifecycle::State>,
}

impl Shared {
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

/// A followed plan's goal and its path (map metres).
pub type Followed = (Pose2, Vec<(f64, f64)>);

/// The newest goal waiting to be planned, numbered (see [`Shared::goals`]).
pub type GoalSlot = Option<(u64, Pose2)>;
