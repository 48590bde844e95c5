//! The one move rule of every walk on the planning grid: the eight neighbours (orthogonal ones
//! first, in [`NEIGHBOURS_8`]'s order, which every planner's determinism depends on), a move only
//! into a free cell, and a diagonal move only when both cells beside it are free, so no walk cuts
//! an obstacle's corner. This is the Moving AI benchmarks' convention, so A* can be checked
//! against their published optima, and every walk that keeps to it also passes the collision
//! rule of [`super::raycast`].

use super::inflation::PlanningGrid;
use crate::geometry::{Cell, NEIGHBOURS_8};
use std::f64::consts::SQRT_2;

/// Whether the move `(dx, dy)` (one of [`NEIGHBOURS_8`]) is allowed, given which cells are free,
/// named by their offset from the cell moved from. Stated once here and used by every walk,
/// whatever it stores its free cells in (A* reads a padded mask).
#[inline]
pub fn allowed(dx: i32, dy: i32, free: impl Fn(i32, i32) -> bool) -> bool {
    free(dx, dy) && (dx == 0 || dy == 0 || (free(dx, 0) && free(0, dy)))
}

/// The length of a move, in cells: 1 straight, sqrt 2 diagonal.
#[inline]
pub fn step_length(dx: i32, dy: i32) -> f64 {
    if dx != 0 && dy != 0 {
        SQRT_2
    } else {
        1.0
    }
}

impl PlanningGrid {
    /// Whether the move `(dx, dy)` from `c` is allowed.
    #[inline]
    pub fn can_move(&self, c: Cell, dx: i32, dy: i32) -> bool {
        allowed(dx, dy, |x, y| self.is_free(c.offset(x, y)))
    }

    /// The allowed moves from `c`: the index into [`NEIGHBOURS_8`] and the cell moved into, in
    /// that order.
    pub fn moves(&self, c: Cell) -> impl Iterator<Item = (usize, Cell)> + '_ {
        NEIGHBOURS_8
            .iter()
            .enumerate()
            .filter(move |(_, &(dx, dy))| self.can_move(c, dx, dy))
            .map(move |(k, &(dx, dy))| (k, c.offset(dx, dy)))
    }

    /// Whether `b` is one allowed move from `a`.
    pub fn adjacent(&self, a: Cell, b: Cell) -> bool {
        let (dx, dy) = (b.x - a.x, b.y - a.y);
        dx.abs() <= 1 && dy.abs() <= 1 && (dx, dy) != (0, 0) && self.can_move(a, dx, dy)
    }
}

#[cfg(test)]
mod tests {
    use crate::geometry::Cell;
    use crate::test_support::grid_from_rows;

    #[test]
    fn no_corner_is_cut() {
        // Row 0 is the bottom row: the blocked cell (1, 0) stands beside the diagonal (0,0)->(1,1).
        let grid = grid_from_rows(&["...", ".#."]);
        let from = Cell::new(0, 1);
        let moves: Vec<Cell> = grid.moves(from).map(|(_, c)| c).collect();
        assert_eq!(moves, vec![Cell::new(1, 1), Cell::new(0, 0)]);
        let c = Cell::new(0, 0);
        assert!(
            !grid.can_move(c, 1, 1),
            "the diagonal past the block cuts its corner"
        );
        assert!(grid.can_move(c, 0, 1));
        assert!(!grid.can_move(c, -1, 0), "off the map");
        assert!(grid.adjacent(Cell::new(2, 1), Cell::new(1, 1)));
        assert!(!grid.adjacent(Cell::new(0, 0), Cell::new(2, 0)));
        assert!(!grid.adjacent(c, c));
    }
}
