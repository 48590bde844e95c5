//! The parameters `ros2 param set` may change while the node runs, and how each value is checked
//! before ros2-client stores it. The parameter file itself (planning keys and the node's own) is
//! read by `planner_io::parameters`, the same way `patrol-plan --config` reads it.

use planner_core::PlannerName;
use ros2_client::ParameterValue;

/// Checks a parameter value before ros2-client stores it; the reason goes back to `ros2 param set`.
pub fn validate_parameter(name: &str, value: &ParameterValue) -> Result<(), String> {
    match (name, value) {
        ("planner", ParameterValue::String(s)) => s
            .parse::<PlannerName>()
            .map(|_| ())
            .map_err(|e| e.to_string()),
        ("max_planning_time" | "tolerance", ParameterValue::Double(v))
            if v.is_finite() && *v >= 0.0 =>
        {
            Ok(())
        }
        ("max_planning_time" | "tolerance", v) => Err(format!(
            "{name} must be a finite non-negative double, not {v:?}"
        )),
        ("planner", v) => Err(format!("planner must be a string, not {v:?}")),
        _ => Err(format!("`{name}` cannot be set at run time")),
    }
}
