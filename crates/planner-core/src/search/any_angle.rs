//! The any-angle reference: the Euclidean shortest path from the start to the goal through the
//! free cells of the inflated grid, bending anywhere (not only at cell centres). Every table
//! reports each planner's length as a ratio to it; no feasible polyline can be shorter.
//!
//! Free space is the closure of the free cells (a path may run along an obstacle's edge), minus
//! the diagonal squeeze between two blocked cells that touch at a corner. A shortest path in such
//! a polygonal domain bends only at convex obstacle corners: lattice points with exactly one
//! blocked cell among the four around them. Each such vertex is nudged [`NUDGE`] cells diagonally
//! into the free space, so the path also passes the project's strict collision rule (supercover,
//! which rejects touching a blocked cell) and its length exceeds the true optimum by at most
//! `NUDGE * sqrt 2` per bend. This is the length Polyanya reports on the Moving AI maps, and a test
//! checks it against their `arena` values.
//!
//! Method:
//! 1. An upper bound: the A* path with the delete operation applied (string pulling).
//! 2. Only corner vertices inside the ellipse `|s - v| + |v - g| <= bound` can lie on a shorter
//!    path.
//! 3. A* over the visibility graph of those vertices (Euclidean heuristic), testing line of sight
//!    lazily and only for edges that could still beat the bound.
//!
//! The answer is the shorter of the bound and the graph search, so it is never longer than A*.

/// How far (cells) a corner vertex is moved off the obstacle corner into free space.
pub const NUDGE: f64 = 1e-6;

use crate::geometry::{Cell, Point2};
use crate::grid::inflation::PlanningGrid;
use crate::grid::metrics::path_length;
use crate::grid::raycast::line_of_sight;
use crate::grid::smoothing::delete_redundant;
use crate::planner::{PlanContext, PlanError, PlanStats, Planner, Problem, RawPlan};
use crate::search::astar::astar_cells;
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// The `any_angle` planner.
#[derive(Clone, Debug, Default)]
pub struct AnyAngle;

impl Planner for AnyAngle {
    /// A* (the bound) plus, per candidate corner (at most one per cell): its point (16 B), g
    /// (8 B), parent (8 B) and closed flag.
    fn working_bytes_per_cell(&self) -> u64 {
        crate::planner::ASTAR_BYTES_PER_CELL + 40
    }

    fn name(&self) -> crate::planner_name::PlannerName {
        crate::planner_name::PlannerName::AnyAngle
    }

    fn plan(&self, problem: &Problem<'_>, ctx: &mut PlanContext<'_>) -> Result<RawPlan, PlanError> {
        let grid = problem.grid;
        let (cells, astar_stats) = astar_cells(grid, problem.start, problem.goal, ctx)?;
        let mut bound_path: Vec<Point2> = Vec::with_capacity(cells.len() + 2);
        bound_path.push(problem.start_point);
        bound_path.extend(cells.iter().map(|c| c.center()));
        bound_path.push(problem.goal_point);
        let bound_path = delete_redundant(grid, &bound_path);
        let bound = path_length(&bound_path);

        let mut stats = PlanStats {
            evaluations: astar_stats.evaluations,
            ..PlanStats::default()
        };
        let s = problem.start_point;
        let g = problem.goal_point;
        // Node 0 is the start, node 1 the goal, the rest are candidate bend points.
        let mut nodes = vec![s, g];
        nodes.extend(
            corner_vertices(grid).filter(|&v| (v - s).norm() + (v - g).norm() <= bound + 1e-9),
        );
        stats
            .counters
            .insert("candidates".into(), (nodes.len() - 2) as f64);
        let result = visibility_astar(grid, &nodes, bound, ctx, &mut stats)?;
        let waypoints = match result {
            Some(path) if path_length(&path) < bound => path,
            _ => bound_path,
        };
        Ok(RawPlan {
            waypoints,
            stats,
            ..RawPlan::default()
        })
    }
}

/// The convex corners of the blocked region (lattice points with exactly one blocked cell among
/// the four around them), each nudged [`NUDGE`] cells into the diagonally opposite free cell.
pub fn corner_vertices(grid: &PlanningGrid) -> impl Iterator<Item = Point2> + '_ {
    let (w, h) = (grid.width() as i32, grid.height() as i32);
    (1..h)
        .flat_map(move |y| (1..w).map(move |x| (x, y)))
        .filter_map(move |(x, y)| {
            // The four cells around lattice point (x, y), with the direction from the point into each.
            let around = [
                (x, y, 1.0, 1.0),
                (x - 1, y, -1.0, 1.0),
                (x - 1, y - 1, -1.0, -1.0),
                (x, y - 1, 1.0, -1.0),
            ];
            let mut blocked = around
                .iter()
                .filter(|&&(cx, cy, _, _)| !grid.is_free(Cell::new(cx, cy)));
            match (blocked.next(), blocked.next()) {
                (Some(&(_, _, sx, sy)), None) => {
                    Some(Point2::new(x as f64 - sx * NUDGE, y as f64 - sy * NUDGE))
                }
                _ => None,
            }
        })
}

#[derive(Clone, Copy, PartialEq)]
struct Open {
    f: f64,
    node: usize,
}
impl Eq for Open {}
impl Ord for Open {
    fn cmp(&self, other: &Self) -> Ordering {
        other
            .f
            .total_cmp(&self.f)
            .then_with(|| other.node.cmp(&self.node))
    }
}
impl PartialOrd for Open {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

/// A* from node 0 to node 1 over the complete graph of `nodes`, edges existing where there is
/// line of sight, pruning anything that cannot beat `bound`.
fn visibility_astar(
    grid: &PlanningGrid,
    nodes: &[Point2],
    bound: f64,
    ctx: &PlanContext<'_>,
    stats: &mut PlanStats,
) -> Result<Option<Vec<Point2>>, PlanError> {
    let n = nodes.len();
    let goal = nodes[1];
    let h: Vec<f64> = nodes.iter().map(|&p| (goal - p).norm()).collect();
    let mut g = vec![f64::INFINITY; n];
    let mut parent = vec![usize::MAX; n];
    let mut closed = vec![false; n];
    let mut open = BinaryHeap::new();
    g[0] = 0.0;
    open.push(Open { f: h[0], node: 0 });
    let mut los_checks = 0u64;
    while let Some(Open { node: u, .. }) = open.pop() {
        if closed[u] {
            continue;
        }
        closed[u] = true;
        stats.iterations += 1;
        ctx.check()?;
        if u == 1 {
            let mut path = vec![nodes[1]];
            let mut k = 1;
            while k != 0 {
                k = parent[k];
                path.push(nodes[k]);
            }
            path.reverse();
            stats
                .counters
                .insert("los_checks".into(), los_checks as f64);
            return Ok(Some(path));
        }
        for v in 0..n {
            if closed[v] {
                continue;
            }
            let nd = g[u] + (nodes[v] - nodes[u]).norm();
            if nd >= g[v] || nd + h[v] > bound + 1e-9 {
                continue;
            }
            los_checks += 1;
            if line_of_sight(grid, nodes[u], nodes[v]) {
                g[v] = nd;
                parent[v] = u;
                open.push(Open {
                    f: nd + h[v],
                    node: v,
                });
            }
        }
    }
    stats
        .counters
        .insert("los_checks".into(), los_checks as f64);
    Ok(None)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::planner::{solve, Query, SolveOptions};
    use crate::test_support::{random_grid, rng};
    use proptest::prelude::*;

    /// Dijkstra over the visibility graph of every lattice point nudged into each free cell
    /// around it (and every cell centre): slow, obviously a superset of the vertices a shortest
    /// path can bend at.
    fn brute_force(grid: &PlanningGrid, s: Point2, g: Point2) -> Option<f64> {
        let mut nodes = vec![s, g];
        let (w, h) = (grid.width() as i32, grid.height() as i32);
        for y in 0..h {
            for x in 0..w {
                let c = Cell::new(x, y);
                if grid.is_free(c) {
                    nodes.push(c.center());
                    for (px, py) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)] {
                        let (sx, sy) = (
                            if px == 0.0 { 1.0 } else { -1.0 },
                            if py == 0.0 { 1.0 } else { -1.0 },
                        );
                        nodes.push(Point2::new(
                            x as f64 + px + sx * NUDGE,
                            y as f64 + py + sy * NUDGE,
                        ));
                    }
                }
            }
        }
        let n = nodes.len();
        let mut dist = vec![f64::INFINITY; n];
        let mut done = vec![false; n];
        dist[0] = 0.0;
        loop {
            let u = (0..n)
                .filter(|&i| !done[i])
                .min_by(|&a, &b| dist[a].total_cmp(&dist[b]))?;
            if dist[u].is_infinite() {
                return None;
            }
            if u == 1 {
                return Some(dist[1]);
            }
            done[u] = true;
            for v in 0..n {
                if !done[v] && line_of_sight(grid, nodes[u], nodes[v]) {
                    dist[v] = dist[v].min(dist[u] + (nodes[v] - nodes[u]).norm());
                }
            }
        }
    }

    fn debug_picture(grid: &PlanningGrid, s: Cell, g: Cell) -> String {
        let mut out = String::new();
        for y in (0..grid.height() as i32).rev() {
            for x in 0..grid.width() as i32 {
                let c = Cell::new(x, y);
                out.push(if c == s {
                    'S'
                } else if c == g {
                    'G'
                } else if grid.is_free(c) {
                    '.'
                } else {
                    '#'
                });
            }
            out.push('\n');
        }
        out
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(128))]
        #[test]
        fn exact_against_brute_force_and_never_longer_than_astar(seed in any::<u64>(), density in 0.05f64..0.35) {
            let (grid, start, goal) = random_grid(seed, 9, 7, density);
            let q = Query { start: start.center(), goal: goal.center(), tolerance: 0.0 };
            let mut r = rng(seed);
            let any = solve(&AnyAngle, &grid, &q, SolveOptions::default(), &mut PlanContext::never_interrupted(&mut r));
            let astar = solve(&crate::search::astar::AStar::default(), &grid, &q, SolveOptions::default(), &mut PlanContext::never_interrupted(&mut r));
            match (brute_force(&grid, start.center(), goal.center()), any, astar) {
                (None, Err(PlanError::NoValidPath(_)), Err(PlanError::NoValidPath(_))) => {}
                (Some(best), Ok(any), Ok(astar)) => {
                    // The brute force may bend at a vertex nudged along an edge instead of diagonally:
                    // both are within a few NUDGE of the true optimum.
                    prop_assert!((any.metrics.length_m - best).abs() < 1e-4, "any-angle {} vs brute force {}\n{}{:?}", any.metrics.length_m, best, debug_picture(&grid, start, goal), any.waypoints);
                    prop_assert!(any.metrics.length_m <= astar.metrics.length_m + 1e-9);
                    prop_assert!(any.metrics.collision_free);
                    prop_assert_eq!(any.waypoints[0], start.center());
                    prop_assert_eq!(*any.waypoints.last().unwrap(), goal.center());
                }
                (b, a, s) => prop_assert!(false, "disagree: {:?} {:?} {:?}\n{}", b, a.map(|p| p.metrics.length_m), s.map(|p| p.metrics.length_m), debug_picture(&grid, start, goal)),
            }
        }
    }
}
