//! The one list of planners: [`PlannerName`], which the CLI, the node, `patrol-plan planners`,
//! the parameter files and every planner's [`crate::planner::Planner::name`] use. A new planner
//! is one variant here, one arm in [`crate::registry::build`], and its module.

use crate::params::ParamError;
use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// Every selectable planner. Serialised (parameter files, JSON, `/diagnostics`) by the name users
/// select it by; an unknown name is refused with the list of valid ones.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(try_from = "String", into = "&'static str")]
pub enum PlannerName {
    /// 8-connected A*: the patrol car paper's baseline.
    Astar,
    /// The exact any-angle shortest path: every table's reference.
    AnyAngle,
    /// The patrol car paper's potential field alone (eq. 1-9).
    Apf,
    /// The patrol car paper's planner: multi-objective Cauchy-mutation cat swarm.
    Mocmcso,
    Mocso,
    Mopso,
    Cmcso,
    Cso,
    Pso,
    /// The substation paper's enhanced potential field alone.
    Eapf,
    /// The substation paper's planner: EAPF-guided improved ant colony.
    EapfIaco,
    Aco,
    AcoApf,
    /// The genetic algorithm paper's improved multi-objective GA.
    Imga,
    Ga,
    Nsga2,
    ThetaStar,
}

impl PlannerName {
    /// Every planner, in the order tables list them.
    pub const ALL: [PlannerName; 17] = [
        PlannerName::Astar,
        PlannerName::AnyAngle,
        PlannerName::Apf,
        PlannerName::Mocmcso,
        PlannerName::Mocso,
        PlannerName::Mopso,
        PlannerName::Cmcso,
        PlannerName::Cso,
        PlannerName::Pso,
        PlannerName::Eapf,
        PlannerName::EapfIaco,
        PlannerName::Aco,
        PlannerName::AcoApf,
        PlannerName::Imga,
        PlannerName::Ga,
        PlannerName::Nsga2,
        PlannerName::ThetaStar,
    ];

    pub fn as_str(self) -> &'static str {
        match self {
            PlannerName::Astar => "astar",
            PlannerName::AnyAngle => "any_angle",
            PlannerName::Apf => "apf",
            PlannerName::Mocmcso => "mocmcso",
            PlannerName::Mocso => "mocso",
            PlannerName::Mopso => "mopso",
            PlannerName::Cmcso => "cmcso",
            PlannerName::Cso => "cso",
            PlannerName::Pso => "pso",
            PlannerName::Eapf => "eapf",
            PlannerName::EapfIaco => "eapf_iaco",
            PlannerName::Aco => "aco",
            PlannerName::AcoApf => "aco_apf",
            PlannerName::Imga => "imga",
            PlannerName::Ga => "ga",
            PlannerName::Nsga2 => "nsga2",
            PlannerName::ThetaStar => "theta_star",
        }
    }

    /// The valid names, comma-separated, for error messages and help texts.
    pub fn list() -> String {
        Self::ALL.map(Self::as_str).join(", ")
    }
}

impl fmt::Display for PlannerName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl From<PlannerName> for &'static str {
    fn from(name: PlannerName) -> Self {
        name.as_str()
    }
}

impl TryFrom<String> for PlannerName {
    type Error = ParamError;

    fn try_from(name: String) -> Result<Self, ParamError> {
        name.parse()
    }
}

impl FromStr for PlannerName {
    type Err = ParamError;

    /// A planner by name; the error lists the valid ones.
    fn from_str(name: &str) -> Result<Self, ParamError> {
        Self::ALL
            .into_iter()
            .find(|p| p.as_str() == name)
            .ok_or_else(|| {
                ParamError::new(
                    "planner",
                    format!("unknown planner `{name}`; choose one of {}", Self::list()),
                )
            })
    }
}
