//! The delete operation of the genetic algorithm paper (section 4.5), shared by every planner.
//!
//! "If a node can be barrier-free connected to its front and rear nodes (nonadjacent path
//! points), then the intermediate nodes between these two points are redundant." We walk the
//! path once: from the last kept node (the anchor), a node is dropped while the anchor still sees
//! the node after it. By the triangle inequality this never lengthens the path, and every new
//! segment is a line-of-sight segment, so it never adds a collision.

use crate::geometry::Point2;
use crate::grid::inflation::PlanningGrid;
use crate::grid::raycast::{line_of_sight, supercover};
use std::convert::Infallible;
use std::ops::ControlFlow;

/// Removes every node whose kept predecessor sees its successor. The first and last points stay.
pub fn delete_redundant(grid: &PlanningGrid, points: &[Point2]) -> Vec<Point2> {
    let mut out: Vec<Point2> = points.first().copied().into_iter().collect();
    let ControlFlow::Continue(()) = for_each_kept_after(grid, points, 0, |_, p| {
        out.push(p);
        ControlFlow::<Infallible>::Continue(())
    });
    out
}

/// The points [`delete_redundant`] keeps after `points[kept]` (a point it kept), each handed to
/// `keep` with its index in `points` as soon as it is known, in order; the walk stops as soon as
/// `keep` breaks. The pulled judge ([`crate::judge`]) straightens a candidate only to learn
/// whether it beats the best answer; most do not, and a prefix of the straightened path already
/// longer or more turning than the best says so before the rest of the path's line-of-sight
/// tests are run. What the walk keeps up to `points[kept]` depends only on `points[..kept + 2]`
/// (keeping a point is decided by a line-of-sight test to the point after it), so a path that
/// shares those points with one already straightened can resume where that one kept
/// `points[kept]`.
pub fn for_each_kept_after<B>(
    grid: &PlanningGrid,
    points: &[Point2],
    kept: usize,
    mut keep: impl FnMut(usize, Point2) -> ControlFlow<B>,
) -> ControlFlow<B> {
    let Some(last) = points.len().checked_sub(1).filter(|&last| kept < last) else {
        return ControlFlow::Continue(());
    };
    let mut anchor = points[kept];
    for k in kept + 1..last {
        if !line_of_sight(grid, anchor, points[k + 1]) {
            keep(k, points[k])?;
            anchor = points[k];
        }
    }
    keep(last, points[last])
}

/// The delete operation weighing the costmap as cost-aware A* does: from the anchor, a node is
/// dropped only when the shortcut to the node after it is free and costs no more, in Smac 2D's
/// step cost `length * (1 + multiplier * cost / 252)` (the cost averaged over the cells the
/// segment touches), than the path it replaces. A cost-aware path so straightened keeps the
/// clearance it was searched for, where [`delete_redundant`] would pull it back onto the walls.
/// Where every cost is 0, or with a multiplier that is not a positive finite number, it is
/// [`delete_redundant`]. Like it, it walks from the anchor to each next node: quadratic in the
/// length of the straight runs, once per path.
pub fn delete_redundant_weighted(
    grid: &PlanningGrid,
    points: &[Point2],
    multiplier: f64,
) -> Vec<Point2> {
    if points.len() <= 2 || !(multiplier.is_finite() && multiplier > 0.0) {
        return delete_redundant(grid, points);
    }
    let cells = grid.cell_reader();
    let weighted = |a: Point2, b: Point2| -> Option<f64> {
        let (mut total, mut cost) = (0u32, 0u64);
        let free = supercover(a, b, |c| {
            let (free, v) = cells.free_and_cost(c);
            total += 1;
            cost += u64::from(v);
            free
        });
        // `supercover` visits the first cell before it can stop: `total` is at least 1.
        free.then(|| (b - a).norm() * (1.0 + multiplier * cost as f64 / (252.0 * total as f64)))
    };
    let mut out = vec![points[0]];
    let mut anchor = points[0];
    // The weighted length of the output from the anchor to `points[k]` (k = 1 first).
    let mut along = weighted(points[0], points[1]).unwrap_or(f64::INFINITY);
    for k in 1..points.len() - 1 {
        let step = weighted(points[k], points[k + 1]).unwrap_or(f64::INFINITY);
        match weighted(anchor, points[k + 1]) {
            Some(direct) if direct <= along + step => along = direct,
            _ => {
                out.push(points[k]);
                anchor = points[k];
                along = step;
            }
        }
    }
    out.push(points[points.len() - 1]);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Pose2;
    use crate::grid::MapInfo;

    use crate::geometry::Cell;
    use crate::planner::PlanContext;
    use crate::search::astar::{astar_cells, astar_cells_cost_aware};
    use crate::test_support::{random_grid, rng};
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(96))]
        /// On random grids, for the A* staircase and for a random feasible detour through it, the
        /// delete operation keeps the ends, never lengthens the path and never makes it collide.
        #[test]
        fn never_lengthens_nor_collides(seed in any::<u64>(), density in 0.0f64..0.35) {
            let (grid, start, goal) = random_grid(seed, 20, 16, density);
            let mut r = rng(seed);
            let Ok((cells, _)) = astar_cells(&grid, start, goal, &PlanContext::never_interrupted(&mut r)) else {
                return Ok(());
            };
            let path: Vec<Point2> = cells.iter().map(|c| c.center()).collect();
            let out = delete_redundant(&grid, &path);
            prop_assert_eq!(out.first(), path.first());
            prop_assert_eq!(out.last(), path.last());
            prop_assert!(crate::grid::metrics::path_length(&out) <= crate::grid::metrics::path_length(&path) + 1e-9);
            prop_assert!(crate::grid::raycast::path_is_free(&grid, &out));
        }
    }

    /// The weighted length [`delete_redundant_weighted`] compares, summed over a polyline.
    fn weighted_length(grid: &PlanningGrid, path: &[Point2], multiplier: f64) -> f64 {
        path.windows(2)
            .map(|w| {
                let (mut total, mut cost) = (0u32, 0u64);
                supercover(w[0], w[1], |c| {
                    total += 1;
                    cost += u64::from(grid.cost(c));
                    true
                });
                (w[1] - w[0]).norm() * (1.0 + multiplier * cost as f64 / (252.0 * total as f64))
            })
            .sum()
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(96))]
        /// On random grids, for cost-aware A*'s path, the weighted delete operation keeps the
        /// ends, never makes the path cost more (in the weighted length it compares) and never
        /// makes it collide, and keeps nodes of the path, in order.
        #[test]
        fn weighted_never_costs_more_nor_collides(seed in any::<u64>(), density in 0.0f64..0.35) {
            let (grid, start, goal) = random_grid(seed, 20, 16, density);
            let mut r = rng(seed);
            let ctx = PlanContext::never_interrupted(&mut r);
            let Ok((cells, _)) = astar_cells_cost_aware(&grid, start, goal, &ctx, 3.0) else {
                return Ok(());
            };
            let path: Vec<Point2> = cells.iter().map(|c| c.center()).collect();
            let out = delete_redundant_weighted(&grid, &path, 3.0);
            prop_assert_eq!(out.first(), path.first());
            prop_assert_eq!(out.last(), path.last());
            prop_assert!(weighted_length(&grid, &out, 3.0) <= weighted_length(&grid, &path, 3.0) + 1e-9);
            prop_assert!(crate::grid::raycast::path_is_free(&grid, &out));
            // The output keeps nodes of the path, in order.
            let mut rest = path.iter();
            prop_assert!(out.iter().all(|p| rest.any(|q| q == p)));
        }
    }

    /// Where nothing costs anything the weighted operation is the plain one: across an empty
    /// room, both straighten a staircase that starts off a cell's centre into one segment.
    #[test]
    fn weighted_is_plain_where_nothing_costs() {
        use crate::test_support::grid_with;
        let room = grid_with((30, 20), 1.0, 0.0, |_, _| false);
        let mut path: Vec<Point2> = (0..15)
            .map(|k| Point2::new(2.5 + k as f64, 2.5 + (k / 2) as f64))
            .collect();
        path[0] = Point2::new(2.2, 2.9);
        let plain = delete_redundant(&room, &path);
        assert_eq!(plain.len(), 2);
        for m in [0.0, 3.0, f64::NAN, f64::INFINITY] {
            assert_eq!(
                delete_redundant_weighted(&room, &path, m),
                plain,
                "multiplier {m}"
            );
        }
    }

    /// A 4 m corridor (0.1 m cells) with a block rising from its floor to 1.5 m below the
    /// ceiling: cost-aware A* passes over the block through the middle of the gap. Straightened
    /// by the plain delete operation the path grazes the block's corners; by the weighted one it
    /// keeps most of the gap's clearance, and is still shorter and far smoother than the
    /// staircase.
    #[test]
    fn weighted_straightening_keeps_off_the_corners() {
        use crate::grid::metrics::{min_clearance, path_length};
        use crate::test_support::grid_with;
        let grid = grid_with((120, 42), 0.1, 0.0, |x, y| {
            y == 0 || y == 41 || ((50..70).contains(&x) && y <= 25)
        });
        let mut r = rng(1);
        let ctx = PlanContext::never_interrupted(&mut r);
        let (cells, _) =
            astar_cells_cost_aware(&grid, Cell::new(5, 20), Cell::new(115, 20), &ctx, 3.0).unwrap();
        let path: Vec<Point2> = cells.iter().map(|c| c.center()).collect();
        let plain = delete_redundant(&grid, &path);
        let weighted = delete_redundant_weighted(&grid, &path, 3.0);
        assert!(crate::grid::raycast::path_is_free(&grid, &weighted));
        let (c_path, c_plain, c_weighted) = (
            min_clearance(&grid, &path),
            min_clearance(&grid, &plain),
            min_clearance(&grid, &weighted),
        );
        assert!(c_plain < 0.2, "the plain one grazes a corner: {c_plain}");
        assert!(
            c_weighted > 0.7 * c_path,
            "{c_weighted} (A*'s {c_path}, plain {c_plain})"
        );
        // 0.1 m from the block's corner plain, 0.71 m weighted, 0.76 m along the staircase;
        // lengths 112.0, 115.2 and 120.8 cells; turning 0.4, 2.3 and 17.3 rad.
        let turning = crate::grid::metrics::total_turning;
        assert!(path_length(&weighted) < 0.98 * path_length(&path));
        assert!(turning(&weighted) < 0.2 * turning(&path));
    }

    #[test]
    fn staircase_around_a_block_keeps_only_the_needed_corner() {
        // 6x6 grid, one blocked cell at (2, 2).
        let info = MapInfo {
            width: 6,
            height: 6,
            resolution: 1.0,
            origin: Pose2::default(),
        };
        let mut obstacle = vec![false; 36];
        obstacle[2 * 6 + 2] = true;
        let grid = PlanningGrid::from_obstacles(info, obstacle, 0.0);
        let c = |x: f64, y: f64| Point2::new(x + 0.5, y + 0.5);
        let path = vec![
            c(0.0, 0.0),
            c(1.0, 0.0),
            c(2.0, 0.0),
            c(3.0, 0.0),
            c(3.0, 1.0),
            c(3.0, 2.0),
            c(3.0, 3.0),
            c(3.0, 4.0),
        ];
        let out = delete_redundant(&grid, &path);
        assert_eq!(out.first(), path.first());
        assert_eq!(out.last(), path.last());
        assert!(out.len() < path.len());
        assert!(crate::grid::raycast::path_is_free(&grid, &out));
        assert!(
            crate::grid::metrics::path_length(&out) <= crate::grid::metrics::path_length(&path)
        );
    }
}
