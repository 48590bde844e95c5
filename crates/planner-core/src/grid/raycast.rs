//! Supercover segment traversal and line of sight.
//!
//! A path is feasible when every segment crosses only free cells, where "crosses" means every
//! cell the segment touches (the supercover), not just Bresenham's one cell per column: a
//! segment that passes exactly through a cell corner touches both side cells, and both must be
//! free. This is the single collision rule of the project; every planner, metric and test uses it.

use crate::geometry::{Cell, Point2};
use crate::grid::inflation::PlanningGrid;

/// Two `t` values closer than this are treated as one crossing of a cell corner.
const CORNER_EPS: f64 = 1e-9;

/// Calls `visit` for every cell the segment `a -> b` (grid coordinates) touches, in order from
/// `a`'s cell to `b`'s, stopping early when `visit` returns false. Returns false iff stopped.
pub fn supercover(a: Point2, b: Point2, mut visit: impl FnMut(Cell) -> bool) -> bool {
    let mut cell = Cell::containing(a);
    let end = Cell::containing(b);
    if !visit(cell) {
        return false;
    }
    let (dx, dy) = (b.x - a.x, b.y - a.y);
    let step_x = if dx > 0.0 { 1 } else { -1 };
    let step_y = if dy > 0.0 { 1 } else { -1 };
    // Parameter t in [0, 1] at which the segment crosses the next vertical / horizontal line.
    let (mut t_max_x, t_delta_x) = if dx != 0.0 {
        let next = if dx > 0.0 {
            cell.x as f64 + 1.0
        } else {
            cell.x as f64
        };
        ((next - a.x) / dx, 1.0 / dx.abs())
    } else {
        (f64::INFINITY, f64::INFINITY)
    };
    let (mut t_max_y, t_delta_y) = if dy != 0.0 {
        let next = if dy > 0.0 {
            cell.y as f64 + 1.0
        } else {
            cell.y as f64
        };
        ((next - a.y) / dy, 1.0 / dy.abs())
    } else {
        (f64::INFINITY, f64::INFINITY)
    };
    let mut remaining = (end.x - cell.x).abs() + (end.y - cell.y).abs();
    while remaining > 1 {
        if (t_max_x - t_max_y).abs() < CORNER_EPS {
            // Through a corner: the two side cells are touched too.
            if !visit(cell.offset(step_x, 0)) || !visit(cell.offset(0, step_y)) {
                return false;
            }
            cell = cell.offset(step_x, step_y);
            t_max_x += t_delta_x;
            t_max_y += t_delta_y;
            remaining -= 2;
        } else if t_max_x < t_max_y {
            cell.x += step_x;
            t_max_x += t_delta_x;
            remaining -= 1;
        } else {
            cell.y += step_y;
            t_max_y += t_delta_y;
            remaining -= 1;
        }
        if !visit(cell) {
            return false;
        }
    }
    // The last step is into the end cell. Where the segment ends exactly on a cell corner its
    // two last crossings tie at t = 1, and rounding used to pick the other axis: a step past the
    // end's row or column, into a cell the segment never touches, and the end cell unvisited.
    if remaining == 1 && !visit(end) {
        return false;
    }
    true
}

/// Whether the straight segment `a -> b` (grid coordinates) crosses only free cells.
#[inline]
pub fn line_of_sight(grid: &PlanningGrid, a: Point2, b: Point2) -> bool {
    boxes_free(grid, a, b) || supercover(a, b, |c| grid.is_free(c))
}

/// Cells (along the segment's longer axis) per box of [`boxes_free`].
const BOX_CELLS: f64 = 8.0;

/// Cells per first, coarse box of [`boxes_free`]: one read of a long free stretch instead of
/// eight; only a coarse box that holds a blocked cell is tested again in [`BOX_CELLS`] pieces.
const COARSE_BOX_CELLS: f64 = 64.0;

/// A sufficient test for [`line_of_sight`] in a few reads per [`COARSE_BOX_CELLS`] cells of open
/// space: the segment is cut into pieces, and each piece's cells lie in the rectangle spanned by
/// its ends' cells, grown by one cell on every side (for corner touches and rounding); when
/// every such rectangle is free ([`PlanningGrid::box_is_free`]), so is every cell the segment
/// touches. A coarse piece whose rectangle is not free is cut again into pieces of
/// [`BOX_CELLS`]. False says nothing: near a wall a rectangle may hold a blocked cell the
/// segment misses, and [`supercover`] then decides. The delete operation tests long segments
/// across open space over and over; cell by cell, that was a quarter of `imga`'s time on a
/// large map, and with fine pieces alone still a quarter on a 4000 x 4000 hall.
fn boxes_free(grid: &PlanningGrid, a: Point2, b: Point2) -> bool {
    // Only segments with both ends in the map (so every piece's cell coordinates are small and
    // finite: no overflow, a bounded number of pieces), and long ones: short segments are no
    // faster with boxes.
    let inside = |p: Point2| grid.info().contains(Cell::containing(p)) && p.x >= 0.0 && p.y >= 0.0;
    let span = (b.x - a.x).abs().max((b.y - a.y).abs());
    if !(inside(a) && inside(b)) || span < 2.0 * BOX_CELLS {
        return false;
    }
    let cell_at = |t: f64| {
        if t >= 1.0 {
            Cell::containing(b)
        } else {
            Cell::containing(a + (b - a) * t)
        }
    };
    let free = |from: Cell, to: Cell| {
        grid.box_is_free(
            from.x.min(to.x) - 1,
            from.y.min(to.y) - 1,
            from.x.max(to.x) + 1,
            from.y.max(to.y) + 1,
        )
    };
    // Coarse pieces; one that is not free, again in fine pieces.
    pieces(
        span,
        (0.0, 1.0),
        Cell::containing(a),
        COARSE_BOX_CELLS,
        &cell_at,
        |t, from, to| {
            free(from, to)
                || pieces(span, t, from, BOX_CELLS, &cell_at, |_, from, to| {
                    free(from, to)
                })
        },
    )
}

/// Whether every piece of the stretch `t` (segment parameters; the segment `span` cells long)
/// passes `ok(its stretch, its first cell, its last cell)`: pieces of about `cells` cells, the
/// first starting in `from`, each ending where the next starts, the last in `cell_at(t.1)`.
fn pieces(
    span: f64,
    (t0, t1): (f64, f64),
    from: Cell,
    cells: f64,
    cell_at: &impl Fn(f64) -> Cell,
    mut ok: impl FnMut((f64, f64), Cell, Cell) -> bool,
) -> bool {
    let n = (span * (t1 - t0) / cells).ceil().max(1.0) as usize;
    let at = |k: usize| {
        if k == n {
            t1
        } else {
            t0 + (t1 - t0) * k as f64 / n as f64
        }
    };
    let mut from = from;
    (1..=n).all(|k| {
        let to = cell_at(at(k));
        let pass = ok((at(k - 1), at(k)), from, to);
        from = to;
        pass
    })
}

/// Whether every segment of a polyline (grid coordinates) crosses only free cells. A single point
/// is feasible when its cell is free.
pub fn path_is_free(grid: &PlanningGrid, points: &[Point2]) -> bool {
    match points {
        [] => false,
        [p] => grid.is_free(Cell::containing(*p)),
        _ => points.windows(2).all(|w| line_of_sight(grid, w[0], w[1])),
    }
}

/// The length (grid units) of the parts of a polyline that lie in blocked cells, approximated by
/// the blocked share of each segment's supercover. Exactly 0 iff every segment is free (the same
/// test as [`path_is_free`] for two or more points). Orders infeasible swarm candidates: the less
/// of a path is in obstacles, the closer it is to feasible.
pub fn blocked_length(grid: &PlanningGrid, points: &[Point2]) -> f64 {
    points
        .windows(2)
        .map(|w| {
            let (mut total, mut blocked) = (0u32, 0u32);
            supercover(w[0], w[1], |c| {
                total += 1;
                blocked += u32::from(!grid.is_free(c));
                true
            });
            if blocked == 0 {
                0.0
            } else {
                (w[1] - w[0]).norm() * blocked as f64 / total as f64
            }
        })
        .sum()
}

/// [`blocked_length`] and, in the same traversal, the costmap cost along the polyline: each
/// segment's length times the mean cost (as a share of 252, [`PlanningGrid::cost`]) of the cells
/// its supercover touches, in grid units. The swarms' safety objective: one pass for both.
pub fn blocked_and_cost_length(grid: &PlanningGrid, points: &[Point2]) -> (f64, f64) {
    let (mut blocked_len, mut cost_len) = (0.0, 0.0);
    let cells = grid.cell_reader();
    for w in points.windows(2) {
        let (mut total, mut blocked, mut cost) = (0u32, 0u32, 0u32);
        supercover(w[0], w[1], |c| {
            let (free, c) = cells.free_and_cost(c);
            total += 1;
            blocked += u32::from(!free);
            cost += u32::from(c);
            true
        });
        let len = (w[1] - w[0]).norm();
        if blocked > 0 {
            blocked_len += len * blocked as f64 / total as f64;
        }
        cost_len += len * cost as f64 / (252.0 * total as f64);
    }
    (blocked_len, cost_len)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn cells(a: (f64, f64), b: (f64, f64)) -> Vec<(i32, i32)> {
        let mut v = Vec::new();
        supercover(Point2::new(a.0, a.1), Point2::new(b.0, b.1), |c| {
            v.push((c.x, c.y));
            true
        });
        v
    }

    #[test]
    fn diagonal_through_corners_touches_side_cells() {
        assert_eq!(
            cells((0.5, 0.5), (2.5, 2.5)),
            vec![(0, 0), (1, 0), (0, 1), (1, 1), (2, 1), (1, 2), (2, 2)]
        );
    }

    /// A segment ending exactly on a cell corner ends in the cell that holds its end, whatever
    /// the rounding of its crossings: the walk used to step past the end's row on the last
    /// step (here into (225, -1), outside the map) and never reach (226, 0).
    #[test]
    fn a_segment_ending_on_a_corner_ends_in_its_end_cell() {
        for (a, b) in [
            ((124.0, 16.0), (226.0, 0.0)),
            (
                (218.214_285_714_285_72, 1.221_288_515_406_161_7),
                (226.0, 0.0),
            ),
            ((0.3, 0.1), (7.0, 3.0)),
            ((7.0, 3.0), (0.3, 0.1)),
        ] {
            let c = cells(a, b);
            let end = Cell::containing(Point2::new(b.0, b.1));
            assert_eq!(*c.last().unwrap(), (end.x, end.y), "{a:?} -> {b:?}: {c:?}");
            let (lo, hi) = (
                (a.0.min(b.0).floor() as i32, a.1.min(b.1).floor() as i32),
                (a.0.max(b.0).floor() as i32, a.1.max(b.1).floor() as i32),
            );
            assert!(
                c.iter()
                    .all(|&(x, y)| (lo.0..=hi.0).contains(&x) && (lo.1..=hi.1).contains(&y)),
                "{a:?} -> {b:?} leaves the segment's box: {c:?}"
            );
        }
    }

    /// Line of sight (summed-area boxes first) where rounding a point onto the grid and the
    /// walk's own crossings could disagree: a segment a rounding step off a grid line, and one a
    /// hair off a run of cell corners.
    #[test]
    fn line_of_sight_follows_the_whole_walk_at_a_hair() {
        let walls = |blocked: &dyn Fn(i32, i32) -> bool| {
            crate::test_support::grid_with((300, 40), 1.0, 0.0, |x, y| blocked(x as i32, y as i32))
        };
        let below = f64::from_bits(5.0f64.to_bits() - 1);
        let above = f64::from_bits(5.0f64.to_bits() + 1);
        for (grid, a, b) in [
            (
                walls(&|x, y| (70..120).contains(&x) && y == 4),
                Point2::new(3.5, below),
                Point2::new(120.0, 5.0),
            ),
            (
                walls(&|x, y| x == 60 && y == 5),
                Point2::new(0.5, below),
                Point2::new(200.5, above),
            ),
            (
                walls(&|x, y| x == 100 && y == 9),
                Point2::new(0.5, 0.05 + 1e-8),
                Point2::new(290.5, 29.05 + 1e-8),
            ),
        ] {
            assert_eq!(
                line_of_sight(&grid, a, b),
                supercover(a, b, |c| grid.is_free(c)),
                "{a:?} {b:?}"
            );
        }
    }

    #[test]
    fn shallow_segment_visits_every_touched_cell() {
        assert_eq!(
            cells((0.5, 0.5), (3.5, 1.2)),
            vec![(0, 0), (1, 0), (2, 0), (2, 1), (3, 1)]
        );
        assert_eq!(
            cells((3.5, 1.2), (0.5, 0.5)),
            vec![(3, 1), (2, 1), (2, 0), (1, 0), (0, 0)]
        );
        assert_eq!(cells((1.2, 1.7), (1.8, 1.1)), vec![(1, 1)]);
        // y = 0.5 + (x - 0.5) / 3 passes exactly through the corner (2, 1).
        assert_eq!(
            cells((0.5, 0.5), (3.5, 1.5)),
            vec![(0, 0), (1, 0), (2, 0), (1, 1), (2, 1), (3, 1)]
        );
        assert_eq!(
            cells((3.5, 1.5), (0.5, 0.5)),
            vec![(3, 1), (2, 1), (1, 1), (2, 0), (1, 0), (0, 0)]
        );
    }

    /// A segment end's coordinate on a 60-cell map: anywhere, on a cell border, or a little
    /// outside the map.
    fn coordinate() -> impl Strategy<Value = f64> {
        prop_oneof![0.0f64..60.0, (0i32..=60).prop_map(f64::from), -3.0f64..63.0,]
    }

    /// A 60 x 60 grid of scattered one-cell obstacles (no inflation).
    fn scattered(seed: u64, density: f64) -> PlanningGrid {
        crate::test_support::random_grid(seed, 60, 60, density).0
    }

    #[test]
    fn box_counts_match_the_cells() {
        let grid = scattered(3, 0.05);
        let mut r = crate::test_support::rng(4);
        use rand::Rng;
        for _ in 0..2000 {
            let (x0, y0) = (r.random_range(-2..62), r.random_range(-2..62));
            let (x1, y1) = (x0 + r.random_range(0..12), y0 + r.random_range(0..12));
            let brute = (x0..=x1).all(|x| (y0..=y1).all(|y| grid.is_free(Cell::new(x, y))));
            assert_eq!(
                grid.box_is_free(x0, y0, x1, y1),
                brute,
                "{x0},{y0} {x1},{y1}"
            );
        }
    }

    #[test]
    fn the_box_test_clears_open_space_and_defers_near_walls() {
        let open = scattered(1, 0.0);
        let (a, b) = (Point2::new(1.5, 1.5), Point2::new(58.5, 41.3));
        assert!(
            boxes_free(&open, a, b),
            "an empty map is all free boxes (away from its border)"
        );
        // One blocked cell beside the segment (y = 10.5), inside a grown box, not on the line.
        let beside = crate::test_support::grid_with((60, 20), 1.0, 0.0, |x, y| x == 30 && y == 11);
        let (a, b) = (Point2::new(1.5, 10.5), Point2::new(58.5, 10.5));
        assert!(!boxes_free(&beside, a, b));
        assert!(
            line_of_sight(&beside, a, b),
            "the cell-by-cell test decides"
        );
        let across = crate::test_support::grid_with((60, 20), 1.0, 0.0, |x, y| x == 30 && y == 10);
        assert!(!line_of_sight(&across, a, b));
        // Ends outside the map, far outside (past i32) or not numbers: never cleared by boxes.
        for (a, b) in [
            (Point2::new(3e9, 5.5), Point2::new(3e9, 30.5)),
            (Point2::new(5.5, 5.5), Point2::new(1e20, 5.5)),
            (Point2::new(-20.5, 5.5), Point2::new(20.5, 5.5)),
            (Point2::new(5.5, f64::NAN), Point2::new(40.5, 5.5)),
            (Point2::new(5.5, 5.5), Point2::new(f64::INFINITY, 5.5)),
        ] {
            assert!(!boxes_free(&open, a, b), "{a:?} {b:?}");
            assert!(!line_of_sight(&open, a, b), "{a:?} {b:?}");
        }
        // A coarse box holding a blocked cell the segment passes far from: the fine boxes of
        // that stretch clear it, so line of sight needs no cell-by-cell walk.
        // (Five coarse pieces; the second spans cells (61, 9) to (120, 16).)
        let (a, b) = (Point2::new(2.5, 2.5), Point2::new(297.5, 37.5));
        let long = crate::test_support::grid_with((300, 40), 1.0, 0.0, |x, y| x == 118 && y == 9);
        assert!(
            !long.box_is_free(60, 8, 121, 17),
            "the coarse box holds the cell"
        );
        assert!(boxes_free(&long, a, b));
        assert!(supercover(a, b, |c| long.is_free(c)));
        // On a sparse map it clears many long segments (else it would buy nothing).
        let sparse = scattered(5, 0.002);
        let mut r = crate::test_support::rng(6);
        use rand::Rng;
        let mut cleared = 0;
        for _ in 0..500 {
            let mut p = || Point2::new(r.random_range(0.0..60.0), r.random_range(0.0..60.0));
            let (a, b) = (p(), p());
            if boxes_free(&sparse, a, b) {
                cleared += 1;
                assert!(supercover(a, b, |c| sparse.is_free(c)));
            }
        }
        assert!(cleared > 100, "{cleared} of 500");
    }

    proptest! {
        /// Wherever the box test says a segment is free, every cell the supercover touches is
        /// free.
        #[test]
        fn the_box_test_never_clears_a_blocked_segment(
            seed in any::<u64>(), density in 0.0f64..0.02,
            ax in coordinate(), ay in coordinate(), bx in coordinate(), by in coordinate(),
        ) {
            let grid = scattered(seed, density);
            let (a, b) = (Point2::new(ax, ay), Point2::new(bx, by));
            if boxes_free(&grid, a, b) {
                prop_assert!(supercover(a, b, |c| grid.is_free(c)));
            }
        }

        /// The same on a long map, where segments span several coarse boxes (64 cells) and a
        /// coarse box with a blocked cell is cut into fine ones from the middle of the segment.
        #[test]
        fn the_box_test_never_clears_a_blocked_segment_across_coarse_boxes(
            seed in any::<u64>(), density in 0.0f64..0.002,
            ax in 0.0f64..300.0, ay in 0.0f64..40.0, bx in 0.0f64..300.0, by in 0.0f64..40.0,
        ) {
            let grid = crate::test_support::random_grid(seed, 300, 40, density).0;
            let (a, b) = (Point2::new(ax, ay), Point2::new(bx, by));
            if boxes_free(&grid, a, b) {
                prop_assert!(supercover(a, b, |c| grid.is_free(c)));
            }
        }

        /// Line of sight, summed-area boxes first, answers as the whole segment walked cell by
        /// cell: between cell centres and grid corners (whose segments cross cell corners
        /// exactly), near grid lines and corners, and anywhere, on maps with walls enough to
        /// fail some boxes and leave others free.
        #[test]
        fn line_of_sight_is_the_whole_walk(
            seed in any::<u64>(), density in 0.0f64..0.03, snap in 0u8..6,
            ax in 0.0f64..300.0, ay in 0.0f64..40.0, bx in 0.0f64..300.0, by in 0.0f64..40.0,
        ) {
            let grid = crate::test_support::random_grid(seed, 300, 40, density).0;
            // Cell centres, grid corners, a rounding step either side of a grid line (as map
            // metres divided by the resolution give: 0.6 / 0.2 = 2.9999999999999996), a hair
            // off a corner, a hair off a cell centre, and anywhere.
            let ulp = |v: f64, up: bool| f64::from_bits(if up { v.to_bits() + 1 } else { v.to_bits() - 1 });
            let at = |v: f64| match snap {
                0 => v.floor() + 0.5,
                1 => v.floor(),
                2 => ulp(v.floor().max(1.0), v.fract() < 0.5),
                3 => v.floor() + 1e-8,
                4 => v.floor() + 0.5 + (v.fract() - 0.5) * 1e-6,
                _ => v,
            };
            let (a, b) = (Point2::new(at(ax), at(ay)), Point2::new(at(bx), at(by)));
            prop_assert_eq!(
                line_of_sight(&grid, a, b),
                supercover(a, b, |c| grid.is_free(c)),
                "{:?} {:?}", a, b
            );
        }

        /// Every cell that a dense sampling of the segment hits must be in the supercover, and a
        /// random segment (which never passes exactly through a corner) moves by 4-neighbour steps.
        #[test]
        fn supercover_contains_every_sampled_cell(ax in 0.0f64..20.0, ay in 0.0f64..20.0, bx in 0.0f64..20.0, by in 0.0f64..20.0) {
            let v = cells((ax, ay), (bx, by));
            for k in 0..=2000 {
                let t = k as f64 / 2000.0;
                let p = Point2::new(ax + t * (bx - ax), ay + t * (by - ay));
                let c = Cell::containing(p);
                prop_assert!(v.contains(&(c.x, c.y)), "{:?} missing", c);
            }
            for w in v.windows(2) {
                prop_assert!((w[0].0 - w[1].0).abs() + (w[0].1 - w[1].1).abs() == 1);
            }
            prop_assert_eq!(*v.last().unwrap(), (bx.floor() as i32, by.floor() as i32));
        }
    }
}
