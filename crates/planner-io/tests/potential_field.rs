//! The potential field on the substation paper's complex 20 x 20 map: its U trap is a local
//! minimum of the plain field, and the virtual-traction escape leaves it (paper mode); the
//! navigation-function attraction (the default) never enters it.

use planner_core::field::{descend, descend_plain, ApfParams, Attraction};
use planner_core::geometry::Point2;
use planner_core::grid::inflation::{InflationConfig, PlanningGrid};
use planner_core::grid::raycast::path_is_free;
use planner_core::search::astar::{astar_cells, cell_path_length};
use std::path::PathBuf;

fn complex_map() -> PlanningGrid {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/maps/bench/substation_20_complex.yaml");
    let map = planner_io::load_map_server(&p).unwrap();
    PlanningGrid::new(&map, &InflationConfig::default()).unwrap()
}

#[test]
fn plain_apf_stalls_in_the_u_trap_and_the_escape_leaves_it() {
    let grid = complex_map();
    let info = *grid.info();
    // The map's `diagonal` scenario: from the lower left towards the upper right, straight into
    // the U (closed at x = 9 and y = 7, open to the upper right).
    let start = info.world_to_cell(Point2::new(0.5, 0.5)).unwrap();
    let goal = info.world_to_cell(Point2::new(19.5, 19.5)).unwrap();
    let params = ApfParams {
        attraction: Attraction::Paper,
        ..ApfParams::default()
    };
    let stalled = descend_plain(&grid, &params, start, goal).unwrap_err();
    assert!(stalled.reason.contains("local minimum"), "{stalled:?}");
    // It stalls against the U's closed side: the goal is 19 cells up and right of the start, and
    // the plain field gets nowhere near it.
    assert!(stalled.steps < 20, "{stalled:?}");
    let escaped = descend(&grid, &params, start, goal).unwrap();
    assert!(escaped.escapes >= 1);
    assert_eq!(*escaped.cells.last().unwrap(), goal);
    let pts: Vec<_> = escaped.cells.iter().map(|c| c.center()).collect();
    assert!(path_is_free(&grid, &pts));
    eprintln!(
        "stalled after {} steps; escaped with {} escapes in {} steps",
        stalled.steps,
        escaped.escapes,
        escaped.cells.len()
    );
}

#[test]
fn the_navigation_function_reaches_the_goal_past_the_u_trap_without_escapes() {
    let grid = complex_map();
    let info = *grid.info();
    let start = info.world_to_cell(Point2::new(0.5, 0.5)).unwrap();
    let goal = info.world_to_cell(Point2::new(19.5, 19.5)).unwrap();
    let params = ApfParams::default();
    assert_eq!(params.attraction, Attraction::Navigation);
    let path = descend(&grid, &params, start, goal).unwrap();
    assert_eq!(path.escapes, 0);
    assert_eq!(*path.cells.first().unwrap(), start);
    assert_eq!(*path.cells.last().unwrap(), goal);
    let pts: Vec<_> = path.cells.iter().map(|c| c.center()).collect();
    assert!(path_is_free(&grid, &pts));
    // No cell twice, each step to a neighbour.
    let mut seen = std::collections::HashSet::new();
    assert!(path.cells.iter().all(|c| seen.insert(*c)));
    assert!(path.cells.windows(2).all(|w| grid.adjacent(w[0], w[1])));
    // Not a detour, and not into the U's pocket and out again: within 1.2 x the length of the
    // shortest walk (A*'s) on the same grid.
    use rand::SeedableRng;
    let mut rng = planner_core::planner::PlannerRng::seed_from_u64(0);
    let ctx = planner_core::planner::PlanContext::never_interrupted(&mut rng);
    let (best, _) = astar_cells(&grid, start, goal, &ctx).unwrap();
    let (walked, shortest) = (cell_path_length(&path.cells), cell_path_length(&best));
    assert!(
        walked <= 1.2 * shortest,
        "{walked} cells against A*'s {shortest}"
    );
}
