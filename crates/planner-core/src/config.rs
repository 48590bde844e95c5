//! Planner configuration: serde structs, every default a named function that `Default` uses too,
//! so the YAML file, the CLI and the node agree on one set of values.
//!
//! This is the planning part of the node's `patrol_planner: ros__parameters:` block (see
//! `config/planner.yaml`); each planner family adds its own section here.

use crate::ant_colony::ColonyParams;
use crate::genetic::GaParams;
use crate::inflation::InflationConfig;
use crate::potential::ApfParams;
use crate::swarm::SwarmParams;
use serde::{Deserialize, Serialize};

/// A parameter with a value it cannot take.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("parameter `{name}`: {reason}")]
pub struct ParamError {
    pub name: String,
    pub reason: String,
}

impl ParamError {
    pub fn new(name: impl Into<String>, reason: impl Into<String>) -> Self {
        Self {
            name: name.into(),
            reason: reason.into(),
        }
    }
}

/// Everything needed to build and run a planner.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct PlannerConfig {
    /// Planner name, one of [`crate::registry::PLANNER_NAMES`].
    pub planner: String,
    /// RNG seed; `None` lets the caller draw one (and report it, so the plan can be replayed).
    pub seed: Option<u64>,
    /// How far (m) an occupied goal may be moved to the nearest free cell. Default 0.25.
    pub tolerance: f64,
    /// Force the delete operation on (`true`) or off (`false`) for every planner; unset follows
    /// each planner's default.
    pub smoothing: Option<bool>,
    /// Time budget of one plan (s); anytime planners return their best path so far when it runs
    /// out, the others fail with a timeout. 0 means no limit. Default 5.
    pub max_planning_time: f64,
    /// How the raw map becomes the planning grid.
    pub costmap: InflationConfig,
    /// The potential field: planner `apf`, and the seed of the swarms.
    pub apf: ApfParams,
    /// The swarm planners (mocmcso, mocso, mopso, cmcso, cso, pso): table 3 of the patrol car paper.
    pub swarm: SwarmParams,
    /// The ant colonies (eapf_iaco, aco, aco_apf): the substation paper's parameters.
    pub colony: ColonyParams,
    /// The genetic planners (imga, ga): the genetic algorithm paper's parameters.
    pub genetic: GaParams,
}

pub fn default_planner() -> String {
    "mocmcso".into()
}
pub fn default_tolerance() -> f64 {
    0.25
}
pub fn default_max_planning_time() -> f64 {
    5.0
}

impl Default for PlannerConfig {
    fn default() -> Self {
        Self {
            planner: default_planner(),
            seed: None,
            tolerance: default_tolerance(),
            smoothing: None,
            max_planning_time: default_max_planning_time(),
            costmap: InflationConfig::default(),
            apf: ApfParams::default(),
            swarm: SwarmParams::default(),
            colony: ColonyParams::default(),
            genetic: GaParams::default(),
        }
    }
}

impl PlannerConfig {
    pub fn validate(&self) -> Result<(), ParamError> {
        crate::registry::check_name(&self.planner)?;
        if !(self.tolerance.is_finite() && self.tolerance >= 0.0) {
            return Err(ParamError::new(
                "tolerance",
                format!("{} is not a finite non-negative distance", self.tolerance),
            ));
        }
        if !(self.max_planning_time.is_finite() && self.max_planning_time >= 0.0) {
            return Err(ParamError::new(
                "max_planning_time",
                format!(
                    "{} is not a finite non-negative time",
                    self.max_planning_time
                ),
            ));
        }
        self.costmap.validate()?;
        self.apf.validate()?;
        self.swarm.validate()?;
        self.colony.validate()?;
        self.genetic.validate()
    }
}
