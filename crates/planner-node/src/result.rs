//! What a request ends in: a typed result code with Nav2's numbers, the failure with its reason,
//! and the outcome that `/diagnostics`, `/plan` and GetPlan are built from. Every planner-core
//! error maps to its code explicitly, so a new error kind cannot silently become NO_VALID_PATH.

use planner_core::planner::{Plan, PlanError};
use planner_core::PlannerName;
use std::fmt;

/// A request's result. The first eleven are nav2_msgs/action/ComputePathToPose's error codes,
/// with its numbers; the rest are this node's own, numbered above Nav2's range so they can never
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
        }
    }
}

impl fmt::Display for ResultCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Why a request could not be planned.
#[derive(Clone, Debug, PartialEq)]
pub struct Failure {
    pub code: ResultCode,
    pub message: String,
}

impl Failure {
    pub fn new(code: ResultCode, message: impl Into<String>) -> Self {
        Self {
            code,
            message: message.into(),
        }
    }
}

impl From<PlanError> for Failure {
    fn from(e: PlanError) -> Self {
        let code = match &e {
            PlanError::StartOutsideMap(_) => ResultCode::StartOutsideMap,
            PlanError::GoalOutsideMap(_) => ResultCode::GoalOutsideMap,
            PlanError::StartOccupied(_) => ResultCode::StartOccupied,
            PlanError::GoalOccupied(_) => ResultCode::GoalOccupied,
            PlanError::NoValidPath(_) => ResultCode::NoValidPath,
            PlanError::TimedOut => ResultCode::Timeout,
            PlanError::Cancelled => ResultCode::Cancelled,
            PlanError::InvalidInput(_) => ResultCode::InvalidInput,
            PlanError::TooLarge { .. } => ResultCode::TooLarge,
        };
        Failure::new(code, e.to_string())
    }
}

/// What one request produced.
pub struct Outcome {
    /// The planner that answered (the one selected when the request arrived, so a
    /// `ros2 param set` meanwhile cannot mislabel the answer).
    pub planner: PlannerName,
    /// The plan and the goal's heading, or why not.
    pub result: Result<(Plan, f64), Failure>,
    pub seed: u64,
    pub elapsed_ms: f64,
}

impl Outcome {
    /// A request that failed before planning started.
    pub fn failed(planner: PlannerName, seed: u64, failure: Failure) -> Self {
        Self {
            planner,
            result: Err(failure),
            seed,
            elapsed_ms: 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use planner_core::geometry::Point2;

    #[test]
    fn nav2_numbers_and_every_plan_error_mapped() {
        assert_eq!(ResultCode::None.number(), 0);
        assert_eq!(ResultCode::NoValidPath.number(), 208);
        assert_eq!(ResultCode::GoalOccupied.number(), 206);
        assert_eq!(ResultCode::TfError.number(), 202);
        let p = Point2::new(1.0, 2.0);
        let cases = [
            (PlanError::StartOutsideMap(p), ResultCode::StartOutsideMap),
            (PlanError::GoalOutsideMap(p), ResultCode::GoalOutsideMap),
            (PlanError::StartOccupied(p), ResultCode::StartOccupied),
            (PlanError::GoalOccupied(p), ResultCode::GoalOccupied),
            (PlanError::NoValidPath("x".into()), ResultCode::NoValidPath),
            (PlanError::TimedOut, ResultCode::Timeout),
            (PlanError::Cancelled, ResultCode::Cancelled),
            (
                PlanError::InvalidInput("x".into()),
                ResultCode::InvalidInput,
            ),
            (
                PlanError::TooLarge {
                    planner: PlannerName::Aco,
                    cells: 1 << 30,
                    per_cell: 56,
                    needed: 56 << 30,
                    cap: 2 << 30,
                },
                ResultCode::TooLarge,
            ),
        ];
        for (error, code) in cases {
            let message = error.to_string();
            let f = Failure::from(error);
            assert_eq!(f.code, code);
            assert_eq!(f.message, message);
        }
    }
}
