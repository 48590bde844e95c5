//! The name table: the one place that maps planner names to implementations. The node and the
//! CLI select planners through it, so a new planner needs one line here and nothing else.

use crate::ant_colony::{ColonyPlanner, ColonyVariant};
use crate::any_angle::AnyAngle;
use crate::astar::AStar;
use crate::config::{ParamError, PlannerConfig};
use crate::genetic::{GaPlanner, GaVariant};
use crate::planner::Planner;
use crate::potential::ApfPlanner;
use crate::swarm::{SwarmPlanner, Variant};

/// Every selectable planner, in the order tables list them.
pub const PLANNER_NAMES: &[&str] = &[
    "astar",
    "any_angle",
    "apf",
    "mocmcso",
    "mocso",
    "mopso",
    "cmcso",
    "cso",
    "pso",
    "eapf",
    "eapf_iaco",
    "aco",
    "aco_apf",
    "imga",
    "ga",
];

/// Checks a planner name, with the list of valid ones in the error.
pub fn check_name(name: &str) -> Result<(), ParamError> {
    if PLANNER_NAMES.contains(&name) {
        Ok(())
    } else {
        Err(ParamError::new(
            "planner",
            format!(
                "unknown planner `{name}`; choose one of {}",
                PLANNER_NAMES.join(", ")
            ),
        ))
    }
}

/// Builds the named planner with the parameters of `config`.
pub fn build(name: &str, config: &PlannerConfig) -> Result<Box<dyn Planner>, ParamError> {
    config.costmap.validate()?;
    config.apf.validate()?;
    config.swarm.validate()?;
    config.colony.validate()?;
    config.genetic.validate()?;
    if let Some(&variant) = GaVariant::ALL.iter().find(|v| v.name() == name) {
        return Ok(Box::new(GaPlanner {
            variant,
            params: config.genetic.clone(),
        }));
    }
    if let Some(&variant) = ColonyVariant::ALL.iter().find(|v| v.name() == name) {
        return Ok(Box::new(ColonyPlanner {
            variant,
            params: config.colony.clone(),
            apf: config.apf.clone(),
        }));
    }
    if name == "eapf" {
        return Ok(Box::new(ApfPlanner::eapf(&config.apf)));
    }
    if let Some(&variant) = Variant::ALL.iter().find(|v| v.name() == name) {
        return Ok(Box::new(SwarmPlanner {
            variant,
            params: config.swarm.clone(),
            apf: config.apf.clone(),
        }));
    }
    match name {
        "astar" => Ok(Box::new(AStar)),
        "any_angle" => Ok(Box::new(AnyAngle)),
        "apf" => Ok(Box::new(ApfPlanner {
            params: config.apf.clone(),
            substation_field: false,
        })),
        other => check_name(other).map(|_| unreachable!("check_name accepted an unlisted name")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_listed_name_builds_and_reports_its_name() {
        for &name in PLANNER_NAMES {
            assert_eq!(build(name, &PlannerConfig::default()).unwrap().name(), name);
        }
        let err = build("dijkstra", &PlannerConfig::default()).err().unwrap();
        assert!(err.to_string().contains("astar"));
    }
}
