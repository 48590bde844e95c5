//! What a request ends in: a typed result code with Nav2's numbers ([`ResultCode`], shared with
//! the CLI through planner-io), the failure with its reason, and the outcome that
//! `/diagnostics`, `/plan` and GetPlan are built from.

use planner_core::planner::{Plan, PlanError};
use planner_core::PlannerName;
pub use planner_io::result_code::ResultCode;

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
        Failure::new(ResultCode::from(&e), e.to_string())
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
