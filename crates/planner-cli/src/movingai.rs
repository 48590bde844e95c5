//! `patrol-plan movingai`: A* against the Moving AI benchmarks' published optimal lengths
//! (8-connected, diagonal sqrt 2, no corner cutting), as the pathfinding crate's own bench does,
//! so the benchmark is also a correctness check.

use anyhow::{bail, Result};
use planner_core::grid::inflation::{InflationConfig, PlanningGrid};
use planner_core::grid::parsers::movingai::MovingAiScenario;
use planner_core::planner::{PlanContext, PlannerRng};
use planner_core::search::astar::{astar_cells, cell_path_length};
use rand::SeedableRng;
use std::path::Path;

/// Runs every scenario, or `sample` of them evenly spaced by optimal length; prints each failure
/// and a closing `N passed, M failed`. Returns M. A file without a problem is an error, so that a
/// check cannot pass by checking nothing.
pub fn run(map_path: &Path, scen_path: &Path, sample: Option<usize>) -> Result<usize> {
    let map = planner_io::load_movingai_map(map_path)?;
    let scenarios = planner_io::load_movingai_scenarios(scen_path)?;
    let name = map_path
        .file_name()
        .map(|n| n.to_string_lossy().to_string())
        .unwrap_or_default();
    if scenarios.is_empty() {
        bail!("{} holds no problem", scen_path.display());
    }
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
    let chosen = chosen_problems(&scenarios, sample);
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
                out!(
                    "FAIL {name} scenario {i} ({:?} -> {:?}): {why}",
                    s.start,
                    s.goal
                );
            }
        }
    }
    if passed + failed < scenarios.len() {
        out!(
            "(a sample: {} of the file's {} scenarios, evenly spaced by length)",
            passed + failed,
            scenarios.len()
        );
    }
    out!("{passed} passed, {failed} failed");
    Ok(failed)
}

/// The problems checked, as indices into the file in its order: all of them, or `sample` spread
/// evenly by length. By length first: most files list their problems bucket by bucket from the
/// shortest, but some (the `-random-` ones, AR0011SR) shuffle the buckets, and a sample should
/// still span every length.
fn chosen_problems(scenarios: &[MovingAiScenario], sample: Option<usize>) -> Vec<usize> {
    let mut by_length: Vec<usize> = (0..scenarios.len()).collect();
    by_length.sort_by(|&a, &b| {
        let (sa, sb) = (&scenarios[a], &scenarios[b]);
        sa.bucket
            .cmp(&sb.bucket)
            .then(sa.optimal_length.total_cmp(&sb.optimal_length))
            .then(a.cmp(&b))
    });
    let mut chosen: Vec<usize> = sampled(scenarios.len(), sample)
        .into_iter()
        .map(|k| by_length[k])
        .collect();
    // Failures are reported in the file's order.
    chosen.sort_unstable();
    chosen
}

/// The ranks checked (in the problems sorted by length): all of `0..total`, or `n` of them spread
/// evenly from the shortest to the longest (the longest problems are the ones most likely to
/// expose a wrong length).
fn sampled(total: usize, n: Option<usize>) -> Vec<usize> {
    match n {
        Some(n) if n < total && n > 1 => (0..n).map(|k| k * (total - 1) / (n - 1)).collect(),
        Some(1) if total > 0 => vec![total - 1],
        _ => (0..total).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::{chosen_problems, sampled};
    use planner_core::grid::parsers::movingai::MovingAiScenario;

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

    #[test]
    fn a_sample_of_a_shuffled_file_still_spans_every_length() {
        // Buckets 0..=4 listed out of order (as in the `-random-` files).
        let problem = |bucket: u32, optimal_length: f64| MovingAiScenario {
            bucket,
            map: "m.map".into(),
            start: (0, 0),
            goal: (1, 1),
            optimal_length,
            tolerance: 1e-6,
        };
        let file = vec![
            problem(3, 13.0),
            problem(0, 1.0),
            problem(4, 17.0),
            problem(1, 5.0),
            problem(2, 9.0),
            problem(0, 2.0),
        ];
        // The shortest (index 1) and the longest (index 2), in the file's order.
        assert_eq!(chosen_problems(&file, Some(2)), vec![1, 2]);
        // Ranks 0, 2, 5 by length: 1.0 (index 1), 5.0 (index 3), 17.0 (index 2).
        assert_eq!(chosen_problems(&file, Some(3)), vec![1, 2, 3]);
        assert_eq!(chosen_problems(&file, None), vec![0, 1, 2, 3, 4, 5]);
    }
}
