//! The any-angle reference against independent published values: Polyanya's expected Euclidean
//! shortest lengths for every scenario of the Moving AI `arena` map
//! (`../shared/maps/movingai/arena.map.anyangle.csv`, see `shared/maps/SOURCES.md`).
//!
//! Their convention: a scenario's `(x, y)` is the top-left corner point of cell `(x, y)` (rows from
//! the top), and paths may run along obstacle edges. Ours nudges every bend NUDGE cells into free
//! space, so each point is nudged the same way into its own cell and lengths agree to their
//! tolerance (1e-3) plus a few NUDGE.

use planner_core::geometry::Point2;
use planner_core::grid::inflation::{InflationConfig, PlanningGrid};
use planner_core::planner::{validate, PlanContext, Planner, PlannerRng, Query};
use planner_core::search::any_angle::AnyAngle;
use rand::SeedableRng;
use std::path::PathBuf;

#[test]
fn arena_lengths_match_polyanya() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/maps/movingai");
    let map = planner_io::load_movingai_map(&dir.join("arena.map")).unwrap();
    let grid = PlanningGrid::new(&map.grid, &InflationConfig::none()).unwrap();
    let h = map.grid.height() as f64;
    let csv = std::fs::read_to_string(dir.join("arena.map.anyangle.csv")).unwrap();
    let eps = 1e-7;
    let (mut checked, mut bad) = (0, Vec::new());
    for line in csv.lines().skip(1) {
        let v: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
        let (sx, sy, gx, gy, expected) = (v[1], v[2], v[3], v[4], v[6]);
        // Top-left corner of the cell, nudged into it.
        let corner = |x: f64, y: f64| Point2::new(x + eps, h - y - eps);
        let q = Query {
            start: corner(sx, sy),
            goal: corner(gx, gy),
            tolerance: 0.0,
        };
        let problem = validate(&grid, &q).unwrap();
        let mut rng = PlannerRng::seed_from_u64(0);
        let plan = AnyAngle
            .plan(&problem, &mut PlanContext::never_interrupted(&mut rng))
            .unwrap();
        let len = planner_core::grid::metrics::path_length(&plan.waypoints);
        checked += 1;
        if (len - expected).abs() > 1.1e-3 {
            bad.push(format!("{line}: ours {len:.6}"));
        }
    }
    assert_eq!(checked, 160);
    assert!(
        bad.is_empty(),
        "{} of 160 differ:\n{}",
        bad.len(),
        bad.join("\n")
    );
}
