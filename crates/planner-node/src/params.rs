//! The parameters `ros2 param set` may change while the node runs, and how each value is checked
//! before ros2-client stores it. The parameter file itself (planning keys and the node's own) is
//! read by `planner_io::parameters`, the same way `patrol-plan --config` reads it.

use planner_core::config::PlannerConfig;
use planner_core::PlannerName;
use ros2_client::ParameterValue;

/// A planning value settable at run time: its name and where it lives in [`PlannerConfig`].
pub struct Weight {
    pub name: &'static str,
    pub get: fn(&PlannerConfig) -> f64,
    pub set: fn(&mut PlannerConfig, f64),
}

/// The objective weights `ros2 param set` may change (issue 13): the next plan uses them. Each
/// is checked by the planners' own parameter rules (`PlannerConfig::validate`) before it is
/// taken, so a value the parameter file would refuse is refused here too.
pub const WEIGHTS: &[Weight] = &[
    Weight {
        name: "swarm.safety_weight",
        get: |c| c.swarm.safety_weight,
        set: |c, v| c.swarm.safety_weight = v,
    },
    Weight {
        name: "swarm.length_weight",
        get: |c| c.swarm.length_weight,
        set: |c, v| c.swarm.length_weight = v,
    },
    Weight {
        name: "genetic.weight_length",
        get: |c| c.genetic.weight_length,
        set: |c, v| c.genetic.weight_length = v,
    },
    Weight {
        name: "genetic.weight_safety",
        get: |c| c.genetic.weight_safety,
        set: |c, v| c.genetic.weight_safety = v,
    },
    Weight {
        name: "genetic.weight_energy",
        get: |c| c.genetic.weight_energy,
        set: |c, v| c.genetic.weight_energy = v,
    },
    Weight {
        name: "genetic.weight_cost",
        get: |c| c.genetic.weight_cost,
        set: |c, v| c.genetic.weight_cost = v,
    },
    Weight {
        name: "colony.cost_weight",
        get: |c| c.colony.cost_weight,
        set: |c, v| c.colony.cost_weight = v,
    },
    Weight {
        name: "search.cost_travel_multiplier",
        get: |c| c.search.cost_travel_multiplier,
        set: |c, v| c.search.cost_travel_multiplier = v,
    },
];

/// `config` with the weight `name` set to `value`, if `name` is one and the result is valid.
pub fn with_weight(
    config: &PlannerConfig,
    name: &str,
    value: f64,
) -> Option<Result<PlannerConfig, String>> {
    let weight = WEIGHTS.iter().find(|w| w.name == name)?;
    let mut changed = config.clone();
    (weight.set)(&mut changed, value);
    Some(
        changed
            .validate()
            .map(|()| changed)
            .map_err(|e| e.to_string()),
    )
}

/// Whether the weight `name` may take `value` by the planners' rules. Every weight's rule is a
/// range of its own (none depends on another value), so checking it on the defaults decides.
fn in_range(name: &str, value: f64) -> Result<(), String> {
    match with_weight(&PlannerConfig::default(), name, value) {
        Some(Err(e)) => Err(e),
        _ => Ok(()),
    }
}

/// Checks a parameter value before ros2-client stores it; the reason goes back to `ros2 param set`.
pub fn validate_parameter(name: &str, value: &ParameterValue) -> Result<(), String> {
    match (name, value) {
        ("planner", ParameterValue::String(s)) => s
            .parse::<PlannerName>()
            .map(|_| ())
            .map_err(|e| e.to_string()),
        ("max_planning_time", ParameterValue::Double(v))
            if (0.0..=planner_core::config::MAX_PLANNING_TIME).contains(v) =>
        {
            Ok(())
        }
        ("max_planning_time", v) => Err(format!(
            "max_planning_time must be a double within 0..={} s, not {v:?}",
            planner_core::config::MAX_PLANNING_TIME
        )),
        ("tolerance", ParameterValue::Double(v)) if v.is_finite() && *v >= 0.0 => Ok(()),
        ("tolerance", v) => Err(format!(
            "tolerance must be a finite non-negative double, not {v:?}"
        )),
        ("planner", v) => Err(format!("planner must be a string, not {v:?}")),
        // The range is the planners' own rule. It is checked here, before anything is stored,
        // as well as when the value is applied: ros2-client validates every value of a
        // SetParametersAtomically request before it applies the first, so a request with one
        // value out of range changes nothing.
        (n, ParameterValue::Double(v)) if WEIGHTS.iter().any(|w| w.name == n) => {
            if v.is_finite() {
                in_range(n, *v)
            } else {
                Err(format!("{name} must be finite, not {v}"))
            }
        }
        // `ros2 param set ... swarm.safety_weight 0` sends an integer.
        (n, ParameterValue::Integer(v)) if WEIGHTS.iter().any(|w| w.name == n) => {
            in_range(n, *v as f64)
        }
        (n, v) if WEIGHTS.iter().any(|w| w.name == n) => {
            Err(format!("{name} must be a number, not {v:?}"))
        }
        _ => Err(format!("`{name}` cannot be set at run time")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_weight_reads_and_writes_its_own_field_and_is_range_checked() {
        let base = PlannerConfig::default();
        for w in WEIGHTS {
            let changed = with_weight(&base, w.name, 0.25).unwrap().unwrap();
            assert_eq!((w.get)(&changed), 0.25, "{}", w.name);
            // Every other weight is left as it was.
            for other in WEIGHTS.iter().filter(|o| o.name != w.name) {
                assert_eq!((other.get)(&changed), (other.get)(&base), "{}", other.name);
            }
            let refused = with_weight(&base, w.name, -1.0).unwrap();
            assert!(refused.is_err(), "{} took -1", w.name);
            assert!(validate_parameter(w.name, &ParameterValue::Double(f64::NAN)).is_err());
            assert!(validate_parameter(w.name, &ParameterValue::Integer(1)).is_ok());
            assert!(validate_parameter(w.name, &ParameterValue::Boolean(true)).is_err());
            assert!(validate_parameter(w.name, &ParameterValue::Double(0.5)).is_ok());
            // Out of range is refused before anything is stored (so an atomic set of several
            // values with one of them out of range changes none).
            assert!(validate_parameter(w.name, &ParameterValue::Double(-1.0)).is_err());
            assert!(validate_parameter(w.name, &ParameterValue::Integer(-1)).is_err());
        }
        assert!(with_weight(&base, "swarm.safety_weight", 1.5)
            .unwrap()
            .is_err());
        assert!(with_weight(&base, "swarm.population", 1.0).is_none());
    }
}
