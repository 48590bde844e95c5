//! Planner configuration: serde structs, every default a named function that `Default` uses too,
//! so the YAML file, the CLI and the node agree on one set of values.
//!
//! This is the planning part of the node's `patrol_planner: ros__parameters:` block (see
//! `config/planner.yaml`); each planner family adds its own section here. How a value is checked
//! lives in the leaf module [`crate::params`], which the families use without importing this
//! aggregate back.

use crate::colony::ColonyParams;
use crate::field::ApfParams;
use crate::genetic::GaParams;
use crate::grid::inflation::InflationConfig;
use crate::params::{check, ParamError, Range};
use crate::planner_name::PlannerName;
use crate::search::SearchParams;
use crate::swarm::nsga2::Nsga2Params;
use crate::swarm::SwarmParams;
use serde::{Deserialize, Serialize};

/// Everything needed to build and run a planner.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PlannerConfig {
    /// The planner that answers requests. Default mocmcso.
    pub planner: PlannerName,
    /// RNG seed; `None` lets the caller draw one (and report it, so the plan can be replayed).
    pub seed: Option<u64>,
    /// How far (m) an occupied goal may be moved to the nearest free cell. Default 0.25.
    pub tolerance: f64,
    /// How far (m) a start inside the inflated band may be moved to the nearest free cell
    /// instead of failing with START_OCCUPIED. Default 0.25.
    pub start_tolerance: f64,
    /// Force the delete operation on (`true`) or off (`false`) for every planner; unset follows
    /// each planner's default.
    pub smoothing: Option<bool>,
    /// What one plan may allocate for its per-cell working tables (MiB): a plan whose planner
    /// would need more on this map is refused before allocating anything
    /// ([`crate::planner::PlanError::TooLarge`]). Default 2048.
    pub max_plan_memory_mb: f64,
    /// Time budget of one plan (s); anytime planners return their best path so far when it runs
    /// out, the others fail with a timeout. 0 means no limit. Default 5.
    pub max_planning_time: f64,
    /// How the raw map becomes the planning grid.
    pub costmap: InflationConfig,
    /// The graph searches (`astar`'s cost-aware mode).
    pub search: SearchParams,
    /// The potential field: planner `apf`, and the seed of the swarms.
    pub apf: ApfParams,
    /// The swarm planners (mocmcso, mocso, mopso, cmcso, cso, pso): table 3 of the patrol car paper.
    pub swarm: SwarmParams,
    /// The ant colonies (eapf_iaco, aco, aco_apf): the substation paper's parameters.
    pub colony: ColonyParams,
    /// The genetic planners (imga, ga): the genetic algorithm paper's parameters.
    pub genetic: GaParams,
    /// The NSGA-II baseline (nsga2): its operators and evaluation budget; its search space and
    /// weights are the swarms'.
    pub nsga2: Nsga2Params,
}

pub fn default_planner() -> PlannerName {
    PlannerName::Mocmcso
}
pub fn default_tolerance() -> f64 {
    0.25
}
/// The longest `max_planning_time` (s), a day: a deadline far beyond it overflows the clock.
pub const MAX_PLANNING_TIME: f64 = 86_400.0;

pub fn default_max_planning_time() -> f64 {
    5.0
}
pub fn default_max_plan_memory_mb() -> f64 {
    (crate::planner::DEFAULT_MAX_PLAN_BYTES >> 20) as f64
}

impl Default for PlannerConfig {
    fn default() -> Self {
        Self {
            planner: default_planner(),
            seed: None,
            tolerance: default_tolerance(),
            start_tolerance: default_tolerance(),
            smoothing: None,
            max_plan_memory_mb: default_max_plan_memory_mb(),
            max_planning_time: default_max_planning_time(),
            costmap: InflationConfig::default(),
            search: SearchParams::default(),
            apf: ApfParams::default(),
            swarm: SwarmParams::default(),
            colony: ColonyParams::default(),
            genetic: GaParams::default(),
            nsga2: Nsga2Params::default(),
        }
    }
}

impl PlannerConfig {
    pub fn validate(&self) -> Result<(), ParamError> {
        // Metres a goal or start may move to a free cell: a kilometre is past any map's use.
        check(
            Range::Within(0.0, 1_000.0),
            &[
                ("tolerance", self.tolerance),
                ("start_tolerance", self.start_tolerance),
            ],
        )?;
        // A day: beyond it the deadline would overflow the clock.
        check(
            Range::Within(0.0, MAX_PLANNING_TIME),
            &[("max_planning_time", self.max_planning_time)],
        )?;
        // At least 1 MiB, at most 1 TiB: the bytes must fit a u64 and mean something.
        check(
            Range::Within(1.0, (1u64 << 20) as f64),
            &[("max_plan_memory_mb", self.max_plan_memory_mb)],
        )?;
        self.costmap.validate()?;
        self.search.validate()?;
        self.apf.validate()?;
        self.swarm.validate()?;
        self.colony.validate()?;
        self.genetic.validate()?;
        self.nsga2.validate()
    }

    /// The potential field's parameters with R of eq. 9 (the chassis radius) resolved: the
    /// costmap's robot radius unless `apf.chassis_radius` is set, so the robot has one radius.
    pub fn field(&self) -> ApfParams {
        ApfParams {
            chassis_radius: Some(self.apf.chassis_radius.unwrap_or(self.costmap.robot_radius)),
            ..self.apf.clone()
        }
    }

    /// The options of [`crate::solve`] this configuration sets.
    pub fn solve_options(&self) -> crate::planner::SolveOptions {
        crate::planner::SolveOptions {
            smoothing: self.smoothing,
            start_tolerance: self.start_tolerance,
            max_plan_bytes: (self.max_plan_memory_mb * (1u64 << 20) as f64) as u64,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_field_takes_the_robot_radius_unless_its_own_is_set() {
        let mut config = PlannerConfig::default();
        config.costmap.robot_radius = 0.4;
        assert_eq!(config.field().chassis_radius, Some(0.4));
        config.apf.chassis_radius = Some(0.3);
        assert_eq!(config.field().chassis_radius, Some(0.3));
    }

    #[test]
    fn a_misspelt_key_is_an_error_naming_it() {
        let err = serde_yaml::from_str::<PlannerConfig>("planer: astar\n").unwrap_err();
        assert!(err.to_string().contains("planer"), "{err}");
        let ok: PlannerConfig = serde_yaml::from_str("planner: astar\n").unwrap();
        assert_eq!(ok.planner, PlannerName::Astar);
    }

    /// A value that would exhaust memory or hold a plan past its deadline is refused, naming the
    /// parameter (such values crashed `patrol-plan plan` by a failed allocation, or held it for
    /// hours, before counts had an upper bound); the defaults pass.
    #[test]
    fn huge_counts_and_factors_are_refused_by_name() {
        for (section, key, value) in [
            ("swarm", "population", "1000000000000"),
            ("swarm", "archive_size", "1000000000000"),
            ("swarm", "waypoints", "100000"),
            ("swarm", "smp", "1000000"),
            ("nsga2", "population", "100000"),
            ("colony", "ants", "1000000000"),
            ("colony", "local_search", "1000000"),
            ("colony", "step_budget_factor", "1.0e12"),
            ("genetic", "population", "1000000000000"),
            ("genetic", "init_attempts", "1000000"),
            ("genetic", "corridor", "1.0e8"),
            ("apf", "sweep_step_deg", "1.0e-300"),
            ("apf", "stall_window", "18446744073709551615"),
            ("apf", "step_budget_factor", "1.0e12"),
            // Exponents and weights that overflowed into no answer (a colony whose every
            // heuristic was infinite), radii and factors past any map's use.
            ("colony", "beta", "1.0e308"),
            ("colony", "alpha", "1.0e308"),
            ("colony", "delta", "1.0e308"),
            ("colony", "band", "1.0e308"),
            ("search", "cost_travel_multiplier", "1.0e308"),
            // A schedule that climbs instead of falling.
            ("swarm", "mr_max", "0.1\n  mr_min: 0.5"),
            ("swarm", "inertia_max", "0.1\n  inertia_min: 0.5"),
        ] {
            let yaml = format!("{section}:\n  {key}: {value}\n");
            let config: PlannerConfig = serde_yaml::from_str(&yaml).unwrap();
            let err = config.validate().unwrap_err();
            assert_eq!(err.name, format!("{section}.{key}"), "{yaml}");
        }
        for (key, value) in [
            ("robot_radius", "1.0e308"),
            ("inflation_radius", "1.0e9"),
            ("cost_scaling_factor", "1.0e308"),
            ("occupied_threshold", "0"),
            ("downsampling_factor", "0"),
            ("downsampling_factor", "17"),
        ] {
            let yaml = format!("costmap:\n  {key}: {value}\n");
            let config: PlannerConfig = serde_yaml::from_str(&yaml).unwrap();
            assert_eq!(config.validate().unwrap_err().name, key, "{yaml}");
        }
        for key in ["tolerance", "start_tolerance"] {
            let config: PlannerConfig = serde_yaml::from_str(&format!("{key}: 1.0e308\n")).unwrap();
            assert_eq!(config.validate().unwrap_err().name, key);
        }
        let day: PlannerConfig = serde_yaml::from_str("max_planning_time: 1.0e19\n").unwrap();
        assert_eq!(day.validate().unwrap_err().name, "max_planning_time");
        assert!(PlannerConfig::default().validate().is_ok());
    }
}
