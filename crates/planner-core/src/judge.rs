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
use crate::grid::metrics::{path_length, total_turning};
use crate::grid::smoothing::delete_redundant;
use crate::grid::PlanningGrid;
use crate::planner::improves_on;

/// The most an 8-connected shortest staircase is longer than the straight segment between its
/// ends: octile over Euclidean distance, largest at 22.5 degrees (cos + (sqrt 2 - 1) sin). A
/// staircase longer than this times the best answer is taken not to straighten into a shorter
/// one, and is not straightened at all (a heuristic: a wandering path may straighten more).
pub const STAIRCASE_STRETCH: f64 = 1.082_392_200_292_394;

/// Length (cells) and turning (rad) of a cell path after the delete operation, on cell centres.
/// `solve` first moves the ends to the exact start and goal points, which can change what the
/// delete operation keeps near them, so this is the answer's measure up to those two ends.
pub fn pulled(grid: &PlanningGrid, cells: &[Cell]) -> (f64, f64) {
    let pts: Vec<Point2> = cells.iter().map(|c| c.center()).collect();
    let pulled = delete_redundant(grid, &pts);
    (path_length(&pulled), total_turning(&pulled))
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
        let candidate = pulled(grid, cells);
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
    use crate::test_support::grid_from_rows;

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
