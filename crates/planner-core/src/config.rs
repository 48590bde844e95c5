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

/// The range a numeric parameter must lie in.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Range {
    /// Finite and >= 0.
    NonNegative,
    /// Finite and > 0.
    Positive,
    /// In 0..=1.
    Share,
    /// In the open interval (0, 1).
    OpenUnit,
    /// Finite and greater than the bound.
    Above(f64),
}

impl Range {
    fn holds(self, v: f64) -> bool {
        match self {
            Range::NonNegative => v.is_finite() && v >= 0.0,
            Range::Positive => v.is_finite() && v > 0.0,
            Range::Share => (0.0..=1.0).contains(&v),
            Range::OpenUnit => v > 0.0 && v < 1.0,
            Range::Above(b) => v.is_finite() && v > b,
        }
    }

    fn describe(self) -> String {
        match self {
            Range::NonNegative => "a finite non-negative number".into(),
            Range::Positive => "a finite positive number".into(),
            Range::Share => "within 0..=1".into(),
            Range::OpenUnit => "strictly between 0 and 1".into(),
            Range::Above(b) => format!("a finite number above {b}"),
        }
    }
}

/// Checks every `(name, value)` against `range`; the error names the first one out of it. The
/// one place that says what a valid number is, for every parameter section.
pub(crate) fn check(range: Range, params: &[(&str, f64)]) -> Result<(), ParamError> {
    match params.iter().find(|(_, v)| !range.holds(*v)) {
        Some((name, v)) => Err(ParamError::new(
            *name,
            format!("{v} is not {}", range.describe()),
        )),
        None => Ok(()),
    }
}

/// Checks that every `(name, count)` is at least `min`.
pub(crate) fn check_counts(min: usize, params: &[(&str, usize)]) -> Result<(), ParamError> {
    match params.iter().find(|(_, v)| *v < min) {
        Some((name, v)) => Err(ParamError::new(*name, format!("{v} is less than {min}"))),
        None => Ok(()),
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
        check(
            Range::NonNegative,
            &[
                ("tolerance", self.tolerance),
                ("max_planning_time", self.max_planning_time),
            ],
        )?;
        self.costmap.validate()?;
        self.apf.validate()?;
        self.swarm.validate()?;
        self.colony.validate()?;
        self.genetic.validate()
    }
}
