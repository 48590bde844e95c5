//! Judging a cell path by the answer it makes: the path after the delete operation that
//! [`crate::planner::solve`] applies, measured by length and turning.
//!
//! The colonies and the genetic algorithm search over 8-connected cell paths, and their papers
//! keep the best path by the cell path's own measure (its length, or the GA's fitness). At real
//! scale the field's seed is already within a fraction of a percent of the shortest staircase,
//! so no searched staircase beats it there, and the planner returned its seed (issue 12: eapf_iaco
//! 0 of 100, imga 15 of 100 better than the seed). A staircase a little longer than the seed's
//! can straighten into a shorter or smoother answer; judging by the straightened path finds it.

use crate::geometry::{Cell, Point2};
use crate::grid::metrics::{path_length, total_turning, RunningMeasure};
use crate::grid::smoothing::for_each_kept_after;
use crate::grid::PlanningGrid;
use crate::planner::{cannot_improve_on, improves_on};
use std::ops::ControlFlow;

/// The most an 8-connected shortest staircase is longer than the straight segment between its
/// ends: octile over Euclidean distance, largest at 22.5 degrees (cos + (sqrt 2 - 1) sin). A
/// staircase longer than this times the best answer is taken not to straighten into a shorter
/// one, and is not straightened at all (a heuristic: a wandering path may straighten more).
pub const STAIRCASE_STRETCH: f64 = 1.082_392_200_292_394;

/// Where the straightening walk stands when it keeps a point: that point's index and the kept
/// prefix's measure.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Prefix {
    /// Index of the point just kept.
    kept: usize,
    measure: RunningMeasure,
}

/// A straightened path: its measure, the length (cells) and turning (rad) of the cell path
/// after the delete operation on cell centres, and the walk at each point it kept but the last
/// (where a path sharing its beginning can resume: [`for_each_kept_after`]). `solve` first
/// moves the ends to the exact start and goal points, which can change what the delete
/// operation keeps near them, so this is the answer's measure up to those two ends.
struct Straightened {
    measure: (f64, f64),
    marks: Vec<Prefix>,
}

/// Straightens `cells` (resuming from the straightened path `seen`, walked with `marks`, where
/// the two share their beginning; both empty: from the start), or gives up with `None` as soon
/// as the straightened prefix shows the path cannot improve on `best` ([`cannot_improve_on`]):
/// its length so far plus the straight distance left, or its turning so far, is already too
/// much.
fn straighten(
    grid: &PlanningGrid,
    cells: &[Cell],
    best: Option<(f64, f64)>,
    seen: &[Cell],
    marks: &[Prefix],
) -> Option<Straightened> {
    let pts: Vec<Point2> = cells.iter().map(|c| c.center()).collect();
    let (Some(&first), Some(&goal)) = (pts.first(), pts.last()) else {
        return Some(Straightened {
            measure: (path_length(&[]), total_turning(&[])),
            marks: Vec::new(),
        });
    };
    // Where the walk kept `points[k]` it had looked at `points[..k + 2]` only.
    let shared = seen.iter().zip(cells).take_while(|(a, b)| a == b).count();
    let mut marks: Vec<Prefix> = marks
        .iter()
        .take_while(|m| m.kept + 2 <= shared)
        .copied()
        .collect();
    let mut walk = match marks.last() {
        Some(&resumed) => resumed,
        None => {
            marks.push(Prefix {
                kept: 0,
                measure: RunningMeasure::start(first),
            });
            marks[0]
        }
    };
    let last = pts.len() - 1;
    let flow = for_each_kept_after(grid, &pts, walk.kept, |k, p| {
        walk.measure.push(p);
        walk.kept = k;
        if k < last {
            marks.push(walk);
        }
        match best {
            Some(best)
                if cannot_improve_on(
                    best,
                    walk.measure.length + (goal - p).norm(),
                    walk.measure.turning,
                ) =>
            {
                ControlFlow::Break(())
            }
            _ => ControlFlow::Continue(()),
        }
    });
    flow.is_continue().then_some(Straightened {
        measure: (walk.measure.length, walk.measure.turning),
        marks,
    })
}

/// The best answer so far by [`improves_on`]: a candidate replaces it only when its straightened
/// path is shorter or smoother and worse on neither. Keeps the best's cells and its walk's
/// marks: most candidates are the best rerouted or bred from it, and share its beginning, whose
/// straightening is then not walked again.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PulledBest {
    best: Option<(f64, f64)>,
    cells: Vec<Cell>,
    marks: Vec<Prefix>,
}

impl PulledBest {
    /// The longest cell path (cells) that may still straighten into a shorter answer than the
    /// best: [`STAIRCASE_STRETCH`] times its length; infinite while there is none.
    pub fn length_limit(&self) -> f64 {
        self.best
            .map_or(f64::INFINITY, |(len, _)| STAIRCASE_STRETCH * len + 1e-9)
    }

    /// Whether a cell path of `cells_length` (cells) is within [`PulledBest::length_limit`].
    pub fn may_improve(&self, cells_length: f64) -> bool {
        cells_length <= self.length_limit()
    }

    /// The best answer's (length in cells, turning in rad), if any.
    pub fn get(&self) -> Option<(f64, f64)> {
        self.best
    }

    /// The best answer's cells (empty while there is none).
    pub fn cells(&self) -> &[Cell] {
        &self.cells
    }

    /// Makes `cells` the best answer whatever it is (the seed a planner starts from).
    pub fn set(&mut self, grid: &PlanningGrid, cells: &[Cell]) {
        let whole = straighten(grid, cells, None, &[], &[]).expect("nothing to beat");
        self.take(cells, whole);
    }

    fn take(&mut self, cells: &[Cell], straightened: Straightened) {
        self.best = Some(straightened.measure);
        self.cells.clear();
        self.cells.extend_from_slice(cells);
        self.marks = straightened.marks;
    }

    /// Straightens `cells` and makes it the best answer when it improves on the current one (or
    /// there is none yet). Returns whether it did.
    pub fn offer(&mut self, grid: &PlanningGrid, cells: &[Cell]) -> bool {
        // With no best yet, its cells and marks are empty: a walk from the start.
        let Some(candidate) = straighten(grid, cells, self.best, &self.cells, &self.marks) else {
            return false;
        };
        let better = self
            .best
            .is_none_or(|best| improves_on(best, candidate.measure));
        if better {
            self.take(cells, candidate);
        }
        better
    }

    /// One step of the local search on the answer (the colonies' and IMGA's `local_search`): a
    /// reroute of it ([`crate::genetic::operators::reroute`], at most `budget` median
    /// insertions) is offered, and replaces it when it straightens into a better one. Returns
    /// whether it did.
    pub fn offer_reroute(
        &mut self,
        grid: &PlanningGrid,
        budget: usize,
        rng: &mut impl rand::Rng,
    ) -> bool {
        match crate::genetic::operators::reroute(grid, &self.cells, budget, rng) {
            Some(moved) => self.offer(grid, &moved),
            None => false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::smoothing::delete_redundant;
    use crate::planner::PlanContext;
    use crate::search::astar::astar_cells;
    use crate::test_support::{grid_from_rows, random_grid, rng};
    use proptest::prelude::*;
    use rand::Rng;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(128))]
        /// The pulled measure is the delete operation's path measured by `path_length` and
        /// `total_turning`, bit for bit. Neither stopping the walk early nor resuming it from
        /// another path's marks changes a verdict: against bests around the candidate's own
        /// measure (so that the early stop is taken on many), resumed from each other candidate
        /// (reroutes share the A* path's beginning), the walk accepts exactly what the whole
        /// walk does, with the same measure; and a `PulledBest` offered the candidates in turn
        /// takes the same ones as `improves_on` on whole walks.
        #[test]
        fn stopping_early_or_resuming_never_changes_a_verdict(
            seed in any::<u64>(),
            density in 0.0f64..0.3,
            scale_len in 0.97f64..1.03,
            scale_turn in 0.5f64..1.5,
        ) {
            let (grid, start, goal) = random_grid(seed, 40, 30, density);
            let mut r = rng(seed);
            let Ok((cells, _)) = astar_cells(&grid, start, goal, &PlanContext::never_interrupted(&mut r)) else {
                return Ok(());
            };
            let mut candidates = vec![cells.clone()];
            for _ in 0..6 {
                let from = candidates[r.random_range(0..candidates.len())].clone();
                if let Some(moved) = crate::genetic::operators::reroute(&grid, &from, 400, &mut r) {
                    candidates.push(moved);
                }
            }
            let walks: Vec<Straightened> = candidates
                .iter()
                .map(|c| straighten(&grid, c, None, &[], &[]).unwrap())
                .collect();
            for (candidate, whole) in candidates.iter().zip(&walks) {
                let whole = whole.measure;
                let pts: Vec<Point2> = candidate.iter().map(|c| c.center()).collect();
                let straight = delete_redundant(&grid, &pts);
                prop_assert_eq!(whole.0.to_bits(), path_length(&straight).to_bits());
                prop_assert_eq!(whole.1.to_bits(), total_turning(&straight).to_bits());
                let mut bests: Vec<(f64, f64)> = walks.iter().map(|w| w.measure).collect();
                bests.push((whole.0 * scale_len, whole.1 * scale_turn));
                bests.push((whole.0 * scale_len, whole.1));
                bests.push((whole.0, whole.1 * scale_turn));
                let froms = std::iter::once((&[][..], &[][..])).chain(
                    candidates.iter().zip(&walks).map(|(c, w)| (&c[..], &w.marks[..])),
                );
                for (seen, marks) in froms {
                    let resumed = straighten(&grid, candidate, None, seen, marks).unwrap();
                    prop_assert_eq!(resumed.measure.0.to_bits(), whole.0.to_bits());
                    prop_assert_eq!(resumed.measure.1.to_bits(), whole.1.to_bits());
                    for &best in &bests {
                        let stopped = straighten(&grid, candidate, Some(best), seen, marks);
                        prop_assert_eq!(
                            stopped.as_ref().is_some_and(|m| improves_on(best, m.measure)),
                            improves_on(best, whole)
                        );
                        if let Some(m) = stopped {
                            prop_assert_eq!(m.measure, whole);
                        }
                    }
                }
            }
            let mut judge = PulledBest::default();
            let mut naive: Option<(f64, f64)> = None;
            for (candidate, whole) in candidates.iter().zip(&walks) {
                let takes = naive.is_none_or(|best| improves_on(best, whole.measure));
                if takes {
                    naive = Some(whole.measure);
                }
                prop_assert_eq!(judge.offer(&grid, candidate), takes);
                prop_assert_eq!(judge.get(), naive);
            }
        }
    }

    /// Length (cells) and turning (rad) of a cell path after the delete operation, on cell
    /// centres: the whole walk's measure.
    fn pulled(grid: &PlanningGrid, cells: &[Cell]) -> (f64, f64) {
        straighten(grid, cells, None, &[], &[]).unwrap().measure
    }

    /// The cells of a path through a picture, in the order given (x right, y up).
    fn cells(points: &[(i32, i32)]) -> Vec<Cell> {
        points.iter().map(|&(x, y)| Cell::new(x, y)).collect()
    }

    /// Two staircases between the same ends in a room with a pillar: straightened, the one that
    /// keeps the goal in sight becomes the straight segment and wins, the one bent round the
    /// pillar keeps its bend. An offer is taken only when it improves on the best.
    #[test]
    fn offers_are_judged_by_the_straightened_path() {
        let grid = grid_from_rows(&[
            "..........", // y 5
            "..##......", // y 4
            "..##......", // y 3
            "..........", // y 2
            "..........", // y 1
            "..........", // y 0
        ]);
        // From (0, 0) to (8, 5). Below the pillar: the segment sees past it.
        let below = cells(&[
            (0, 0),
            (1, 1),
            (2, 1),
            (3, 2),
            (4, 2),
            (5, 3),
            (6, 3),
            (7, 4),
            (8, 5),
        ]);
        // Round the pillar's left and over its top.
        let above = cells(&[
            (0, 0),
            (0, 1),
            (0, 2),
            (1, 3),
            (1, 4),
            (2, 5),
            (3, 5),
            (4, 5),
            (5, 5),
            (6, 5),
            (7, 5),
            (8, 5),
        ]);
        let (straight_len, straight_turn) = pulled(&grid, &below);
        assert!(
            (straight_len - 8f64.hypot(5.0)).abs() < 1e-9,
            "{straight_len}"
        );
        assert!(straight_turn.abs() < 1e-9);
        let (bent_len, bent_turn) = pulled(&grid, &above);
        assert!(bent_len > straight_len + 0.1 && bent_turn > 0.1);

        let mut best = PulledBest::default();
        best.set(&grid, &above);
        assert!(
            best.offer(&grid, &below),
            "the straight answer improves on the bent one"
        );
        assert_eq!(best.get(), Some((straight_len, straight_turn)));
        assert!(
            !best.offer(&grid, &above),
            "the bent one does not improve on it"
        );
        assert!(!best.offer(&grid, &below), "nor does an equal one");
        assert_eq!(best.get(), Some((straight_len, straight_turn)));
    }

    /// A staircase may still straighten into a shorter answer up to the octile stretch over the
    /// best answer's length, not beyond; anything may while there is no answer.
    #[test]
    fn may_improve_up_to_the_staircase_stretch() {
        let grid = grid_from_rows(&["....", "...."]);
        let mut best = PulledBest::default();
        assert!(best.may_improve(1e9));
        best.set(&grid, &cells(&[(0, 0), (1, 0), (2, 0), (3, 0)]));
        assert_eq!(best.get(), Some((3.0, 0.0)));
        assert!(best.may_improve(3.0 * STAIRCASE_STRETCH));
        assert!(!best.may_improve(3.0 * STAIRCASE_STRETCH + 1e-6));
    }
}
