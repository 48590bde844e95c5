//! What a plan request ends in, as Nav2 names it: nav2_msgs/action/ComputePathToPose's error
//! codes with their numbers, and this project's own above them. The node puts them in action
//! results, on `/diagnostics` and in its log; the CLI prints them with its failures, so a script
//! around `patrol-plan` and a Nav2 client see the same names. Every planner-core error maps to
//! its code explicitly ([`From<&PlanError>`]), so a new error kind cannot silently become
//! NO_VALID_PATH.

use planner_core::planner::PlanError;
use std::fmt;

/// A request's result. The first ten are nav2_msgs/action/ComputePathToPose's error codes,
/// with its numbers; the rest are patrol-planner's own, numbered above Nav2's range so they can never
/// be mistaken for one of its codes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u16)]
pub enum ResultCode {
    None = 0,
    Unknown = 200,
    InvalidPlanner = 201,
    TfError = 202,
    StartOutsideMap = 203,
    GoalOutsideMap = 204,
    StartOccupied = 205,
    GoalOccupied = 206,
    Timeout = 207,
    NoValidPath = 208,
    /// A malformed request: a NaN pose, a zero quaternion, a malformed map.
    InvalidInput = 290,
    /// No map has arrived yet.
    NoMap = 291,
    /// The request has no start and no pose has arrived yet.
    NoStartPose = 292,
    /// A newer goal replaced this one while it was planned.
    Cancelled = 293,
    /// The node is not active (lifecycle): it plans only once activated.
    NotActive = 294,
    /// The plan would need more working memory on this map than `max_plan_memory_mb` allows.
    TooLarge = 295,
    /// A `/goal_pose` while `navigate_through_poses` drives: one navigation at a time, as
    /// bt_navigator, whose `navigate_to_pose` navigator the muxer refuses then.
    Busy = 296,
}

impl ResultCode {
    /// The number (Nav2's where it has one).
    pub fn number(self) -> u16 {
        self as u16
    }

    /// The name `/diagnostics` and the log carry (Nav2's constant names).
    pub fn name(self) -> &'static str {
        match self {
            ResultCode::None => "NONE",
            ResultCode::Unknown => "UNKNOWN",
            ResultCode::InvalidPlanner => "INVALID_PLANNER",
            ResultCode::TfError => "TF_ERROR",
            ResultCode::StartOutsideMap => "START_OUTSIDE_MAP",
            ResultCode::GoalOutsideMap => "GOAL_OUTSIDE_MAP",
            ResultCode::StartOccupied => "START_OCCUPIED",
            ResultCode::GoalOccupied => "GOAL_OCCUPIED",
            ResultCode::Timeout => "TIMEOUT",
            ResultCode::NoValidPath => "NO_VALID_PATH",
            ResultCode::InvalidInput => "INVALID_INPUT",
            ResultCode::NoMap => "NO_MAP",
            ResultCode::NoStartPose => "NO_START_POSE",
            ResultCode::Cancelled => "CANCELLED",
            ResultCode::NotActive => "NOT_ACTIVE",
            ResultCode::TooLarge => "TOO_LARGE",
            ResultCode::Busy => "BUSY",
        }
    }
}

impl fmt::Display for ResultCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl From<&PlanError> for ResultCode {
    fn from(e: &PlanError) -> Self {
        match e {
            PlanError::StartOutsideMap(_) => ResultCode::StartOutsideMap,
            PlanError::GoalOutsideMap(_) => ResultCode::GoalOutsideMap,
            PlanError::StartOccupied(_) => ResultCode::StartOccupied,
            PlanError::GoalOccupied(_) => ResultCode::GoalOccupied,
            PlanError::NoValidPath(_) => ResultCode::NoValidPath,
            PlanError::TimedOut => ResultCode::Timeout,
            PlanError::Cancelled => ResultCode::Cancelled,
            PlanError::InvalidInput(_) => ResultCode::InvalidInput,
            PlanError::TooLarge { .. } => ResultCode::TooLarge,
        }
    }
}
