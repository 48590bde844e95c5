//! The delete operation of the genetic algorithm paper (section 4.5), shared by every planner.
//!
//! "If a node can be barrier-free connected to its front and rear nodes (nonadjacent path
//! points), then the intermediate nodes between these two points are redundant." We walk the
//! path once: from the last kept node (the anchor), a node is dropped while the anchor still sees
//! the node after it. By the triangle inequality this never lengthens the path, and every new
//! segment is a line-of-sight segment, so it never adds a collision.

use crate::geometry::Point2;
use crate::grid::inflation::PlanningGrid;
use crate::grid::raycast::line_of_sight;

/// Removes every node whose kept predecessor sees its successor. The first and last points stay.
pub fn delete_redundant(grid: &PlanningGrid, points: &[Point2]) -> Vec<Point2> {
    if points.len() <= 2 {
        return points.to_vec();
    }
    let mut out = vec![points[0]];
    let mut anchor = points[0];
    for k in 1..points.len() - 1 {
        if !line_of_sight(grid, anchor, points[k + 1]) {
            out.push(points[k]);
            anchor = points[k];
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

    use crate::planner::PlanContext;
    use crate::search::astar::astar_cells;
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
