//! Judging a cell path by the answer it makes: the path after the delete operation that
//! [`crate::planner::solve`] applies, measured by length and turning.
//!
//! The colonies and the genetic algorithm search over 8-connected cell paths, and their papers
//! keep the best path by the cell path's own measure (its length, or the GA's fitness). At real
//! scale the field's seed is already within a fraction of a percent of the shortest staircase,
//! so no searched staircase beats it there, and the planner returned its seed (issue 12: eapf_iaco
//! 0 of 100, imga 15 of 100 better than the seed). A staircase a little longer than the seed's
//! can straighten into a shorter or smoother answer; judging by the straightened path finds it.

use crate::geometry::{wrap_angle, Cell, Point2};
#[cfg(doc)]
use crate::grid::metrics::{path_length, total_turning};
use crate::grid::smoothing::for_each_kept;
use crate::grid::PlanningGrid;
use crate::planner::{cannot_improve_on, improves_on};
use std::ops::ControlFlow;

/// The most an 8-connected shortest staircase is longer than the straight segment between its
/// ends: octile over Euclidean distance, largest at 22.5 degrees (cos + (sqrt 2 - 1) sin). A
/// staircase longer than this times the best answer is taken not to straighten into a shorter
/// one, and is not straightened at all (a heuristic: a wandering path may straighten more).
pub const STAIRCASE_STRETCH: f64 = 1.082_392_200_292_394;

/// Length (cells) and turning (rad) of a cell path after the delete operation, on cell centres.
/// `solve` first moves the ends to the exact start and goal points, which can change what the
/// delete operation keeps near them, so this is the answer's measure up to those two ends.
pub fn pulled(grid: &PlanningGrid, cells: &[Cell]) -> (f64, f64) {
    pulled_unless_no_better(grid, cells, None)
        .expect("with nothing to beat the walk runs to the end")
}

/// [`pulled`], or `None` as soon as the straightened prefix shows the path cannot improve on
/// `best` ([`cannot_improve_on`]): its length so far plus the straight distance left, or its
/// turning so far, is already too much. The sums run in [`path_length`]'s and
/// [`total_turning`]'s order, so a full walk gives their bits exactly.
fn pulled_unless_no_better(
    grid: &PlanningGrid,
    cells: &[Cell],
    best: Option<(f64, f64)>,
) -> Option<(f64, f64)> {
    let pts: Vec<Point2> = cells.iter().map(|c| c.center()).collect();
    let Some(&goal) = pts.last() else {
        return Some((-0.0, -0.0));
    };
    // From -0.0, as `Iterator::sum` starts: a path with no turn measures the same bits.
    let (mut length, mut turning) = (-0.0, -0.0);
    let mut previous: Option<Point2> = None;
    let mut heading: Option<f64> = None;
    let walk = for_each_kept(grid, &pts, |p| {
        if let Some(q) = previous {
            let d = p - q;
            length += d.norm();
            if d.norm_squared() > 0.0 {
                let h = d.y.atan2(d.x);
                if let Some(before) = heading.replace(h) {
                    turning += wrap_angle(h - before).abs();
                }
            }
        }
        previous = Some(p);
        match best {
            Some(best) if cannot_improve_on(best, length + (goal - p).norm(), turning) => {
                ControlFlow::Break(())
            }
            _ => ControlFlow::Continue(()),
        }
    });
    walk.is_continue().then_some((length, turning))
}

/// The best answer so far by [`improves_on`]: a candidate replaces it only when its straightened
/// path is shorter or smoother and worse on neither.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PulledBest {
    best: Option<(f64, f64)>,
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

    /// Makes `cells` the best answer whatever it is (the seed a planner starts from).
    pub fn set(&mut self, grid: &PlanningGrid, cells: &[Cell]) {
        self.best = Some(pulled(grid, cells));
    }

    /// Straightens `cells` and makes it the best answer when it improves on the current one (or
    /// there is none yet). Returns whether it did.
    pub fn offer(&mut self, grid: &PlanningGrid, cells: &[Cell]) -> bool {
        let Some(candidate) = pulled_unless_no_better(grid, cells, self.best) else {
            return false;
        };
        let better = self.best.is_none_or(|best| improves_on(best, candidate));
        if better {
            self.best = Some(candidate);
        }
        better
    }

    /// One step of the local search on an answer (the colonies' and IMGA's `local_search`): a
    /// reroute of `answer` ([`crate::genetic::operators::reroute`], at most `budget` median
    /// insertions) is offered, and replaces `answer` when it straightens into a better one.
    /// Returns whether it did.
    pub fn offer_reroute(
        &mut self,
        grid: &PlanningGrid,
        answer: &mut Vec<Cell>,
        budget: usize,
        rng: &mut impl rand::Rng,
    ) -> bool {
        let Some(moved) = crate::genetic::operators::reroute(grid, answer, budget, rng) else {
            return false;
        };
        let kept = self.offer(grid, &moved);
        if kept {
            *answer = moved;
        }
        kept
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::metrics::{path_length, total_turning};
    use crate::grid::smoothing::delete_redundant;
    use crate::planner::PlanContext;
    use crate::search::astar::astar_cells;
    use crate::test_support::{grid_from_rows, random_grid, rng};
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(128))]
        /// The pulled measure is the delete operation's path measured by `path_length` and
        /// `total_turning`, bit for bit; and stopping the walk early never changes an offer's
        /// outcome: against bests around the candidate's own measure (so that the early stop
        /// is taken on many of them), the stopped walk accepts exactly what the whole walk does.
        #[test]
        fn stopping_early_never_changes_a_verdict(
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
                if let Some(moved) = crate::genetic::operators::reroute(&grid, &cells, 400, &mut r) {
                    candidates.push(moved);
                }
            }
            for candidate in &candidates {
                let pts: Vec<Point2> = candidate.iter().map(|c| c.center()).collect();
                let straight = delete_redundant(&grid, &pts);
                let whole = pulled(&grid, candidate);
                prop_assert_eq!(whole.0.to_bits(), path_length(&straight).to_bits());
                prop_assert_eq!(whole.1.to_bits(), total_turning(&straight).to_bits());
                let mut bests: Vec<(f64, f64)> = candidates.iter().map(|c| pulled(&grid, c)).collect();
                bests.push((whole.0 * scale_len, whole.1 * scale_turn));
                bests.push((whole.0 * scale_len, whole.1));
                bests.push((whole.0, whole.1 * scale_turn));
                for best in bests {
                    let stopped = pulled_unless_no_better(&grid, candidate, Some(best));
                    prop_assert_eq!(stopped.is_some_and(|m| improves_on(best, m)), improves_on(best, whole));
                    if let Some(m) = stopped {
                        prop_assert_eq!(m, whole);
                    }
                }
            }
        }
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
