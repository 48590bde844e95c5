//! `patrol-plan movingai`: A* against the Moving AI benchmarks' published optimal lengths
//! (8-connected, diagonal sqrt 2, no corner cutting), as the pathfinding crate's own bench does,
//! so the benchmark is also a correctness check.

use anyhow::{bail, Result};
use planner_core::grid::inflation::{InflationConfig, PlanningGrid};
use planner_core::planner::{PlanContext, PlannerRng};
use planner_core::search::astar::{astar_cells, cell_path_length};
use rand::SeedableRng;
use std::path::Path;

/// Runs every scenario, or `sample` of them evenly spaced through the file; prints each failure
/// and a closing `N passed, M failed`. Returns M.
pub fn run(map_path: &Path, scen_path: &Path, sample: Option<usize>) -> Result<usize> {
    let map = planner_io::load_movingai_map(map_path)?;
    let scenarios = planner_io::load_movingai_scenarios(scen_path)?;
    let name = map_path
        .file_name()
        .map(|n| n.to_string_lossy().to_string())
        .unwrap_or_default();
    if let Some(other) = scenarios.iter().find(|s| s.map != name) {
        bail!(
            "{} names map `{}`, not `{name}`",
            scen_path.display(),
            other.map
        );
    }
    // The benchmarks' lengths are for the bare grid: no inflation.
    let grid = PlanningGrid::new(&map.grid, &InflationConfig::none())?;
    let mut rng = PlannerRng::seed_from_u64(0);
    let ctx = PlanContext::never_interrupted(&mut rng);
    let (mut passed, mut failed) = (0usize, 0usize);
    let chosen = sampled(scenarios.len(), sample);
    for i in chosen {
        let s = &scenarios[i];
        let start = map.cell(s.start.0, s.start.1);
        let goal = map.cell(s.goal.0, s.goal.1);
        let outcome = if !grid.is_free(start) || !grid.is_free(goal) {
            Err("start or goal is blocked".to_string())
        } else {
            match astar_cells(&grid, start, goal, &ctx) {
                Ok((cells, _)) => {
                    let len = cell_path_length(&cells);
                    if (len - s.optimal_length).abs() <= s.tolerance {
                        Ok(())
                    } else {
                        Err(format!(
                            "length {len:.8} vs optimal {} (tolerance {:e})",
                            s.optimal_length, s.tolerance
                        ))
                    }
                }
                Err(e) => Err(e.to_string()),
            }
        };
        match outcome {
            Ok(()) => passed += 1,
            Err(why) => {
                failed += 1;
                println!(
                    "FAIL {name} scenario {i} ({:?} -> {:?}): {why}",
                    s.start, s.goal
                );
            }
        }
    }
    if passed + failed < scenarios.len() {
        println!(
            "(a sample: {} of the file's {} scenarios, evenly spaced)",
            passed + failed,
            scenarios.len()
        );
    }
    println!("{passed} passed, {failed} failed");
    Ok(failed)
}

/// The indices checked: all of `0..total`, or `n` of them spread evenly from the first to the
/// last (the longest problems are the ones most likely to expose a wrong length).
fn sampled(total: usize, n: Option<usize>) -> Vec<usize> {
    match n {
        Some(n) if n < total && n > 1 => (0..n).map(|k| k * (total - 1) / (n - 1)).collect(),
        Some(1) if total > 0 => vec![total - 1],
        _ => (0..total).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::sampled;

    #[test]
    fn a_sample_is_evenly_spaced_and_keeps_both_ends() {
        assert_eq!(sampled(5, None), vec![0, 1, 2, 3, 4]);
        assert_eq!(sampled(5, Some(9)), vec![0, 1, 2, 3, 4]);
        assert_eq!(sampled(10, Some(4)), vec![0, 3, 6, 9]);
        assert_eq!(sampled(8010, Some(1000)).len(), 1000);
        let s = sampled(8010, Some(1000));
        assert_eq!((s[0], s[999]), (0, 8009));
        assert!(s.windows(2).all(|w| w[0] < w[1]));
        assert_eq!(sampled(7, Some(1)), vec![6]);
        assert!(sampled(0, Some(3)).is_empty());
    }
}
