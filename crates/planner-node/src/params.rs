//! The parameters `ros2 param set` may change while the node runs, and how each value is checked
//! before ros2-client stores it: the planner, its time and tolerance, the objective weights and
//! the costmap's inflation (as costmap_2d takes `inflation_radius` and the others at run time).
//! The parameter file itself (planning keys and the node's own) is read by
//! `planner_io::parameters`, the same way `patrol-plan --config` reads it.

use planner_core::config::PlannerConfig;
use planner_core::params::ParamError;
use planner_core::PlannerName;
use ros2_client::ParameterValue;

/// A planning value settable at run time: its name and where it lives in [`PlannerConfig`].
pub struct Setting {
    pub name: &'static str,
    pub get: fn(&PlannerConfig) -> f64,
    pub set: fn(&mut PlannerConfig, f64),
    /// The value only shapes the node's own inflation of a map: on a costmap taken as it is
    /// (`costmap_topic`), whose inflation is its own node's, it changes nothing.
    pub inflation_only: bool,
}

/// The numbers `ros2 param set` may change: the objective weights (issue 13) and the costmap's
/// inflation. The next plan uses them; a changed inflation makes the planning grid again from
/// the map it was made from (`Shared::current_map`), as costmap_2d re-inflates its costmap when
/// its inflation layer's parameters change, so a Nav2 user tunes them as Nav2's tuning guide
/// does, live. Each is checked by the planners' own parameter rules (`PlannerConfig::validate`)
/// before it is taken, so a value the parameter file would refuse is refused here too.
pub const SETTINGS: &[Setting] = &[
    Setting {
        name: "swarm.safety_weight",
        get: |c| c.swarm.safety_weight,
        set: |c, v| c.swarm.safety_weight = v,
        inflation_only: false,
    },
    Setting {
        name: "swarm.length_weight",
        get: |c| c.swarm.length_weight,
        set: |c, v| c.swarm.length_weight = v,
        inflation_only: false,
    },
    Setting {
        name: "genetic.weight_length",
        get: |c| c.genetic.weight_length,
        set: |c, v| c.genetic.weight_length = v,
        inflation_only: false,
    },
    Setting {
        name: "genetic.weight_safety",
        get: |c| c.genetic.weight_safety,
        set: |c, v| c.genetic.weight_safety = v,
        inflation_only: false,
    },
    Setting {
        name: "genetic.weight_energy",
        get: |c| c.genetic.weight_energy,
        set: |c, v| c.genetic.weight_energy = v,
        inflation_only: false,
    },
    Setting {
        name: "genetic.weight_cost",
        get: |c| c.genetic.weight_cost,
        set: |c, v| c.genetic.weight_cost = v,
        inflation_only: false,
    },
    Setting {
        name: "colony.cost_weight",
        get: |c| c.colony.cost_weight,
        set: |c, v| c.colony.cost_weight = v,
        inflation_only: false,
    },
    Setting {
        name: "search.cost_travel_multiplier",
        get: |c| c.search.cost_travel_multiplier,
        set: |c, v| c.search.cost_travel_multiplier = v,
        inflation_only: false,
    },
    // Not `occupied_threshold`, `allow_unknown` or `downsampling_factor`: which cells are
    // obstacles, and how many, is the map's reading, set with it, as Nav2's static layer reads
    // its thresholds once.
    // The robot's radius is the potential field's chassis radius too (eq. 9 of the EAPF paper,
    // unless `apf.chassis_radius` is set), so it counts on a costmap topic as well.
    Setting {
        name: "costmap.robot_radius",
        get: |c| c.costmap.robot_radius,
        set: |c, v| c.costmap.robot_radius = v,
        inflation_only: false,
    },
    Setting {
        name: "costmap.safety_margin",
        get: |c| c.costmap.safety_margin,
        set: |c, v| c.costmap.safety_margin = v,
        inflation_only: true,
    },
    Setting {
        name: "costmap.inflation_radius",
        get: |c| c.costmap.inflation_radius,
        set: |c, v| c.costmap.inflation_radius = v,
        inflation_only: true,
    },
    Setting {
        name: "costmap.cost_scaling_factor",
        get: |c| c.costmap.cost_scaling_factor,
        set: |c, v| c.costmap.cost_scaling_factor = v,
        inflation_only: true,
    },
];

/// `config` with the setting `name` set to `value`, if `name` is one and the result is valid.
pub fn with_setting(
    config: &PlannerConfig,
    name: &str,
    value: f64,
) -> Option<Result<PlannerConfig, String>> {
    let setting = SETTINGS.iter().find(|w| w.name == name)?;
    let mut changed = config.clone();
    (setting.set)(&mut changed, value);
    Some(changed.validate().map(|()| changed).map_err(|e| {
        // The planners' rules name a value by its key in its own block
        // (`inflation_radius`); a `ros2 param set` answer names it as it was set
        // (`costmap.inflation_radius`).
        if name.rsplit('.').next() == Some(e.name.as_str()) {
            ParamError {
                name: name.into(),
                ..e
            }
            .to_string()
        } else {
            e.to_string()
        }
    }))
}

/// Whether the setting `name` may take `value` by the planners' rules. Every setting's rule is a
/// range of its own (none depends on another value), so checking it on the defaults decides.
fn in_range(name: &str, value: f64) -> Result<(), String> {
    match with_setting(&PlannerConfig::default(), name, value) {
        Some(Err(e)) => Err(e),
        _ => Ok(()),
    }
}

/// Refuses a new value for a setting that only shapes the node's own inflation of a map
/// (`costmap.safety_margin`, `inflation_radius`, `cost_scaling_factor`) when the node plans on
/// the costmap of `costmap_topic` as it is: that costmap's inflation layer, on its own node, is
/// what counts there, and a set that is taken and changes nothing would mislead whoever tunes
/// it. Nav2's planner_server has no inflation parameters of its own for the same reason. The
/// value the node holds is accepted (ros2-client checks every declared value at start-up).
pub fn unused_on_costmap(
    name: &str,
    value: f64,
    current: &PlannerConfig,
    costmap_topic: &str,
) -> Result<(), String> {
    match SETTINGS.iter().find(|w| w.name == name) {
        Some(w) if w.inflation_only && !costmap_topic.is_empty() && value != (w.get)(current) => {
            Err(format!(
                "`{name}` shapes the node's own inflation of a map and is not used here: the node \
                 plans on the costmap of `{costmap_topic}` (costmap_topic) as it is; set the \
                 inflation layer of that costmap's node instead"
            ))
        }
        _ => Ok(()),
    }
}

fn is_setting(name: &str) -> bool {
    SETTINGS.iter().any(|w| w.name == name)
}

/// The obstacle layer's switch, settable at run time as Nav2's ObstacleLayer's `enabled` is
/// (`Live::obstacles_enabled`).
pub const OBSTACLES_ENABLED: &str = "obstacle_layer.enabled";

/// Whether `ros2 param set` may change `name` while the node runs: `planner`,
/// `max_planning_time`, `tolerance`, [`OBSTACLES_ENABLED`] and the [`SETTINGS`]. The node's
/// other parameters are declared read-only (node.rs).
pub fn is_live(name: &str) -> bool {
    matches!(
        name,
        "planner" | "max_planning_time" | "tolerance" | OBSTACLES_ENABLED
    ) || is_setting(name)
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
        (OBSTACLES_ENABLED, ParameterValue::Boolean(_)) => Ok(()),
        (OBSTACLES_ENABLED, v) => Err(format!("{OBSTACLES_ENABLED} must be a bool, not {v:?}")),
        // The range is the planners' own rule. It is checked here, before anything is stored,
        // as well as when the value is applied: ros2-client validates every value of a
        // SetParametersAtomically request before it applies the first, so a request with one
        // value out of range changes nothing.
        (n, ParameterValue::Double(v)) if is_setting(n) => {
            if v.is_finite() {
                in_range(n, *v)
            } else {
                Err(format!("{name} must be finite, not {v}"))
            }
        }
        // `ros2 param set ... swarm.safety_weight 0` sends an integer.
        (n, ParameterValue::Integer(v)) if is_setting(n) => in_range(n, *v as f64),
        (n, v) if is_setting(n) => Err(format!("{name} must be a number, not {v:?}")),
        _ => Err(format!("`{name}` cannot be set at run time")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The names ros2 param set may change are the three top-level ones and the settings; the
    /// rest of the parameter file, declared read-only, is not.
    #[test]
    fn live_names_are_the_settable_ones() {
        for live in [
            "planner",
            "max_planning_time",
            "tolerance",
            "swarm.safety_weight",
            "obstacle_layer.enabled",
        ] {
            assert!(is_live(live), "{live}");
        }
        for fixed in [
            "swarm.iterations",
            "planner_plugins",
            "map_yaml",
            "use_sim_time",
            "swarm",
        ] {
            assert!(!is_live(fixed), "{fixed}");
        }
    }

    #[test]
    fn every_setting_reads_and_writes_its_own_field_and_is_range_checked() {
        let base = PlannerConfig::default();
        for w in SETTINGS {
            // A value each setting does not have already (the robot's radius is 0.25 by
            // default), so that a setter writing nothing, or the wrong field, is caught.
            let v = if (w.get)(&base) == 0.25 { 0.3 } else { 0.25 };
            let changed = with_setting(&base, w.name, v).unwrap().unwrap();
            assert_eq!((w.get)(&changed), v, "{}", w.name);
            // Every other setting is left as it was.
            for other in SETTINGS.iter().filter(|o| o.name != w.name) {
                assert_eq!((other.get)(&changed), (other.get)(&base), "{}", other.name);
            }
            let refused = with_setting(&base, w.name, -1.0).unwrap();
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
        assert!(with_setting(&base, "swarm.safety_weight", 1.5)
            .unwrap()
            .is_err());
        // The costmap's own bounds: no robot is 100 m wide. The refusal names the parameter as
        // it was set.
        let wide = with_setting(&base, "costmap.robot_radius", 150.0).unwrap();
        let why = wide.unwrap_err();
        assert!(why.contains("`costmap.robot_radius`"), "{why}");
        assert!(with_setting(&base, "swarm.population", 1.0).is_none());
        // Which cells are obstacles is read with the map, not set at run time.
        assert!(
            validate_parameter("costmap.occupied_threshold", &ParameterValue::Integer(50)).is_err()
        );
    }

    #[test]
    fn on_a_costmap_topic_the_inflation_settings_are_refused_but_the_rest_are_taken() {
        let config = PlannerConfig::default();
        let topic = "/global_costmap/costmap";
        for w in SETTINGS {
            let held = (w.get)(&config);
            // The value held is taken (ros2-client checks it at start-up), as is any value when
            // the node inflates its map itself.
            assert!(
                unused_on_costmap(w.name, held, &config, topic).is_ok(),
                "{}",
                w.name
            );
            assert!(
                unused_on_costmap(w.name, held + 0.1, &config, "").is_ok(),
                "{}",
                w.name
            );
            let other = unused_on_costmap(w.name, held + 0.1, &config, topic);
            let is_inflation = matches!(
                w.name,
                "costmap.safety_margin"
                    | "costmap.inflation_radius"
                    | "costmap.cost_scaling_factor"
            );
            assert_eq!(other.is_err(), is_inflation, "{}", w.name);
            if let Err(why) = other {
                assert!(why.contains(w.name) && why.contains(topic), "{why}");
            }
        }
    }
}
