//! The seed of the field-guided planners: the potential field's own path where its descent (with
//! the virtual-traction escape) reaches the goal, else A*'s, and the record of which answered.
//! Planners `apf`/`eapf` return it, the swarms start from it (patrol car paper, section II.E step
//! 2: the APF path is the first global best), the improved colony takes it as its first good path
//! (substation paper, section 3.3).

use crate::field::{descend_on, ApfParams, Attraction, Wavefront};
use crate::geometry::Cell;
use crate::planner::{PlanContext, PlanError, PlanStats, Problem};
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
