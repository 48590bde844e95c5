//! The seed of the field-guided planners: the potential field's own path where its descent (with
//! the virtual-traction escape) reaches the goal, else A*'s, and the record of which answered.
//! The planners `apf`/`eapf` ([`ApfPlanner`], here) return it, the swarms start from it (patrol
//! car paper, section II.E step 2: the APF path is the first global best), the improved colony
//! takes it as its first good path (substation paper, section 3.3).

use crate::field::{descend_on, ApfParams, Attraction, Wavefront};
use crate::geometry::Cell;
use crate::planner::{PlanContext, PlanError, PlanStats, Planner, Problem, RawPlan};
use crate::planner_name::PlannerName;
use crate::search::astar::astar_cells;

/// The field's path from the problem's start cell to its goal cell, or A*'s when the field
/// cannot get there. Records the outcome in `stats` under one set of names: counter
/// `apf_escapes` (local minima escaped) when the field answered, counter `apf_fallback` and a
/// note with the field's reason when A* did. `role` names the path in the note ("seed", "first
/// good path", "path").
pub fn field_or_astar(
    problem: &Problem<'_>,
    field: &ApfParams,
    ctx: &PlanContext<'_>,
    stats: &mut PlanStats,
    role: &str,
) -> Result<Vec<Cell>, PlanError> {
    field_or_astar_on(problem, field, ctx, stats, role, None)
}

/// [`field_or_astar`] on the navigation function the caller already searched for this query.
pub fn field_or_astar_on(
    problem: &Problem<'_>,
    field: &ApfParams,
    ctx: &PlanContext<'_>,
    stats: &mut PlanStats,
    role: &str,
    known: Option<&Wavefront>,
) -> Result<Vec<Cell>, PlanError> {
    let check = || ctx.check();
    match descend_on(
        problem.grid,
        field,
        problem.start,
        problem.goal,
        &check,
        known,
    )? {
        Ok(path) => {
            match field.attraction {
                Attraction::Paper => {
                    stats
                        .counters
                        .insert("apf_escapes".into(), path.escapes as f64);
                    stats.notes.push(format!(
                        "{role}: potential field ({} local minima escaped)",
                        path.escapes
                    ));
                }
                Attraction::Navigation => {
                    stats
                        .counters
                        .insert("apf_wavefront_steps".into(), path.wavefront_steps as f64);
                    stats.notes.push(format!(
                        "{role}: potential field, navigation-function attraction ({} wavefront steps)",
                        path.wavefront_steps
                    ));
                }
            }
            Ok(path.cells)
        }
        Err(failure) => {
            stats.notes.push(format!(
                "{role}: A*, because the potential field failed ({} after {} steps and {} escapes)",
                failure.reason, failure.steps, failure.escapes
            ));
            stats.counters.insert("apf_fallback".into(), 1.0);
            Ok(astar_cells(problem.grid, problem.start, problem.goal, ctx)?.0)
        }
    }
}

/// Planners `apf` (the patrol car paper's field, eq. 1-9) and `eapf` (the substation paper's
/// enhanced field: eq. 1-2 without eq. 9's factor, with the same virtual-traction escape): the
/// potential-field path alone. When even the escape cannot reach the goal within its step budget
/// it reports that (`notes`, counter `apf_fallback`) and returns A*'s path instead.
#[derive(Clone, Debug, Default)]
pub struct ApfPlanner {
    pub params: ApfParams,
    /// `eapf` rather than `apf`: the substation paper's field.
    pub substation_field: bool,
}

impl ApfPlanner {
    /// The substation paper's EAPF with these parameters (eq. 9's factor off).
    pub fn eapf(params: &ApfParams) -> Self {
        Self {
            params: ApfParams {
                goal_distance_factor: false,
                ..params.clone()
            },
            substation_field: true,
        }
    }
}

impl Planner for ApfPlanner {
    fn name(&self) -> PlannerName {
        if self.substation_field {
            PlannerName::Eapf
        } else {
            PlannerName::Apf
        }
    }

    fn plan(&self, problem: &Problem<'_>, ctx: &mut PlanContext<'_>) -> Result<RawPlan, PlanError> {
        let mut stats = PlanStats::default();
        let cells = field_or_astar(problem, &self.params, ctx, &mut stats, "path")?;
        stats.iterations = cells.len() as u64;
        Ok(RawPlan {
            waypoints: cells.iter().map(|c| c.center()).collect(),
            stats,
            ..RawPlan::default()
        })
    }
}
