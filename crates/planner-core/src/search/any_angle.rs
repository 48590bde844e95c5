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
//!    lazily and only for edges that could still beat the bound and that are tangent to the
//!    obstacle at each corner they join (the reduced visibility graph, which holds every
//!    shortest path: a path that bends at a corner wraps round its blocked cell, so each of its
//!    two segments leaves the corner without entering that cell's quadrant on either side).
//!
//! The answer is the shorter of the bound and the graph search, so it is never longer than A*.
//! When the deadline (or a cancel) comes during the graph search, the bound is the answer, with
//! the plan marked cut short: a feasible path, not the exact optimum, as the population planners
//! answer with their best so far.

/// How far (cells) a corner vertex is moved off the obstacle corner into free space.
pub const NUDGE: f64 = 1e-6;

use crate::geometry::{Cell, Point2};
use crate::grid::inflation::PlanningGrid;
use crate::grid::metrics::path_length;
use crate::grid::raycast::line_of_sight;
use crate::grid::smoothing::delete_redundant;
use crate::planner::{
    Interrupt, PlanContext, PlanError, PlanStats, Planner, Problem, RawPlan, Termination,
};
use crate::search::astar::astar_cells;
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// The `any_angle` planner.
#[derive(Clone, Debug, Default)]
pub struct AnyAngle;

impl Planner for AnyAngle {
    /// A* (the bound) plus, per candidate corner (at most one per cell): its vertex (32 B), h,
    /// g and parent (8 B each) and closed flag, rounded up to 64 B. The open list's entries
    /// (16 B, about one per vertex reached) are not counted: this bound already assumes a
    /// corner in every cell, where real maps have corners in a small share of them.
    fn working_bytes_per_cell(&self) -> u64 {
        crate::planner::ASTAR_BYTES_PER_CELL + 64
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
        let mut nodes = vec![
            Vertex {
                at: s,
                corner: None,
            },
            Vertex {
                at: g,
                corner: None,
            },
        ];
        nodes.extend(
            corners(grid).filter(|v| (v.at - s).norm() + (v.at - g).norm() <= bound + 1e-9),
        );
        // No growth slack beside the tables that follow (the memory estimate counts 32 B each).
        nodes.shrink_to_fit();
        stats
            .counters
            .insert("candidates".into(), (nodes.len() - 2) as f64);
        let result = match visibility_astar(grid, &nodes, bound, ctx, &mut stats) {
            Ok(result) => result,
            Err(why) => return Ok(cut_short(bound_path, stats, why)),
        };
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

/// The bound as the answer of a graph search that the interrupt ended: a feasible path, maybe
/// longer than the exact optimum, and the plan says so.
fn cut_short(bound_path: Vec<Point2>, mut stats: PlanStats, why: Interrupt) -> RawPlan {
    stats.cut_short = true;
    stats.termination = Some(Termination::Interrupted(why));
    stats.notes.push(format!(
        "the exact search was cut short ({}) after {} expansions: the string-pulled A* path is \
         returned, which may be longer than the any-angle optimum",
        Termination::Interrupted(why),
        stats.iterations
    ));
    RawPlan {
        waypoints: bound_path,
        stats,
        ..RawPlan::default()
    }
}

/// A node of the visibility graph: the start, the goal, or a corner with the quadrant of its
/// blocked cell (32 B: the memory estimate counts it).
#[derive(Clone, Copy, Debug)]
struct Vertex {
    /// Where the path may bend (a corner: nudged into free space).
    at: Point2,
    corner: Option<Corner>,
}

/// A convex corner: its lattice point and the signs (x, y) of the direction from it into its
/// blocked cell.
#[derive(Clone, Copy, Debug)]
struct Corner {
    x: i32,
    y: i32,
    sx: i8,
    sy: i8,
}

impl Corner {
    fn lattice(self) -> Point2 {
        Point2::new(f64::from(self.x), f64::from(self.y))
    }
}

impl Vertex {
    /// Whether the line through this vertex and `other` stays out of this vertex's blocked cell
    /// on both sides (always, for the start and the goal): a segment of a shortest path that
    /// ends at a corner does. Measured between lattice points, so a segment along a cell's edge
    /// counts as tangent whatever the nudges.
    fn tangent(&self, other: &Vertex) -> bool {
        let Some(corner) = self.corner else {
            return true;
        };
        let d = other.corner.map_or(other.at, Corner::lattice) - corner.lattice();
        let (sx, sy) = (f64::from(corner.sx), f64::from(corner.sy));
        sx * d.x * sy * d.y <= 1e-9 * d.norm_squared()
    }
}

/// The convex corners of the blocked region (lattice points with exactly one blocked cell among
/// the four around them), each nudged [`NUDGE`] cells into the diagonally opposite free cell,
/// with the quadrant of its blocked cell.
fn corners(grid: &PlanningGrid) -> impl Iterator<Item = Vertex> + '_ {
    let (w, h) = (grid.width() as i32, grid.height() as i32);
    (1..h)
        .flat_map(move |y| (1..w).map(move |x| (x, y)))
        .filter_map(move |(x, y)| {
            // The four cells around lattice point (x, y), with the direction from the point into each.
            let around = [
                (x, y, 1i8, 1i8),
                (x - 1, y, -1, 1),
                (x - 1, y - 1, -1, -1),
                (x, y - 1, 1, -1),
            ];
            let mut blocked = around
                .iter()
                .filter(|&&(cx, cy, _, _)| !grid.is_free(Cell::new(cx, cy)));
            match (blocked.next(), blocked.next()) {
                (Some(&(_, _, sx, sy)), None) => Some(Vertex {
                    at: Point2::new(
                        x as f64 - f64::from(sx) * NUDGE,
                        y as f64 - f64::from(sy) * NUDGE,
                    ),
                    corner: Some(Corner { x, y, sx, sy }),
                }),
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

/// A* from vertex 0 to vertex 1 over the complete graph of `vertices`, edges existing where there
/// is line of sight, pruning anything that cannot beat `bound` or is not tangent at a corner
/// ([`Vertex::tangent`]). `None` when no path beats the bound; the interrupt, if one came.
fn visibility_astar(
    grid: &PlanningGrid,
    vertices: &[Vertex],
    bound: f64,
    ctx: &PlanContext<'_>,
    stats: &mut PlanStats,
) -> Result<Option<Vec<Point2>>, Interrupt> {
    let at = |i: usize| vertices[i].at;
    let n = vertices.len();
    let goal = at(1);
    let h: Vec<f64> = vertices.iter().map(|v| (goal - v.at).norm()).collect();
    let mut g = vec![f64::INFINITY; n];
    let mut parent = vec![usize::MAX; n];
    let mut closed = vec![false; n];
    let mut open = BinaryHeap::new();
    g[0] = 0.0;
    open.push(Open { f: h[0], node: 0 });
    let mut los_checks = 0u64;
    let found = loop {
        let Some(Open { node: u, .. }) = open.pop() else {
            break Ok(None);
        };
        if closed[u] {
            continue;
        }
        closed[u] = true;
        stats.iterations += 1;
        if let Some(why) = (ctx.interrupt)() {
            break Err(why);
        }
        if u == 1 {
            let mut path = vec![at(1)];
            let mut k = 1;
            while k != 0 {
                k = parent[k];
                path.push(at(k));
            }
            path.reverse();
            break Ok(Some(path));
        }
        for v in 0..n {
            if closed[v] {
                continue;
            }
            let nd = g[u] + (at(v) - at(u)).norm();
            if nd >= g[v] || nd + h[v] > bound + 1e-9 {
                continue;
            }
            if !vertices[u].tangent(&vertices[v]) || !vertices[v].tangent(&vertices[u]) {
                continue;
            }
            los_checks += 1;
            if line_of_sight(grid, at(u), at(v)) {
                g[v] = nd;
                parent[v] = u;
                open.push(Open {
                    f: nd + h[v],
                    node: v,
                });
            }
        }
    };
    stats
        .counters
        .insert("los_checks".into(), los_checks as f64);
    found
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

    /// A deadline or a cancel during the graph search answers with the bound (the
    /// string-pulled A* path): feasible, marked cut short with the interrupt as its termination,
    /// and a note that says the optimum was not reached; never shorter than the exact answer.
    #[test]
    fn an_interrupt_in_the_graph_search_returns_the_bound() {
        use crate::planner::Interrupt;
        use crate::test_support::{hall, solve_interrupted};
        let (grid, q) = hall(false);
        let (whole, polls) =
            solve_interrupted(&AnyAngle, &grid, &q, 1, u64::MAX, Interrupt::Deadline);
        let whole = whole.unwrap();
        assert!(!whole.stats.cut_short);
        assert_eq!(whole.stats.termination, Some(Termination::Completed));
        // Each expansion of the graph search polls once; the last polls are its.
        assert!(whole.stats.iterations >= 2, "{}", whole.stats.iterations);
        for what in [Interrupt::Deadline, Interrupt::Cancelled] {
            let (part, _) = solve_interrupted(&AnyAngle, &grid, &q, 1, polls - 1, what);
            let part = part.unwrap_or_else(|e| panic!("{what:?}: {e}"));
            assert!(part.stats.cut_short);
            assert_eq!(part.stats.termination, Some(Termination::Interrupted(what)));
            assert!(part.metrics.collision_free);
            assert!(part.metrics.length_m >= whole.metrics.length_m - 1e-9);
            assert!(part.stats.notes.iter().any(|n| n.contains("cut short")));
        }
    }

    /// Pruning the edges that are not tangent at their corners changes no answer (the brute
    /// force below checks the length on random grids) and saves most line-of-sight tests: on a
    /// hall of pillars, under a third of those without it.
    #[test]
    fn tangent_pruning_saves_line_of_sight_tests() {
        use crate::test_support::{hall, solve_seeded};
        let (grid, q) = hall(true);
        let plan = solve_seeded(&AnyAngle, &grid, &q, 1).unwrap();
        let checks = plan.stats.counters["los_checks"];
        let candidates = plan.stats.counters["candidates"];
        let expansions = plan.stats.iterations as f64;
        assert!(
            checks < expansions * candidates / 3.0,
            "{checks} of {expansions} x {candidates}"
        );
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(128))]
        #[test]
        fn exact_against_brute_force_and_never_longer_than_astar(
            seed in any::<u64>(),
            density in 0.05f64..0.35,
            // Where in their cells the start and goal lie (the centre, or anywhere): edges from
            // them to corners at any angle, axis-aligned ones included.
            off in prop_oneof![Just([0.5; 4]), [0.01f64..0.99, 0.01f64..0.99, 0.01f64..0.99, 0.01f64..0.99]],
        ) {
            let (grid, start, goal) = random_grid(seed, 9, 7, density);
            let at = |c: Cell, dx: f64, dy: f64| Point2::new(c.x as f64 + dx, c.y as f64 + dy);
            let (s, g) = (at(start, off[0], off[1]), at(goal, off[2], off[3]));
            let q = Query { start: s, goal: g, tolerance: 0.0 };
            let mut r = rng(seed);
            let any = solve(&AnyAngle, &grid, &q, SolveOptions::default(), &mut PlanContext::never_interrupted(&mut r));
            let astar = solve(&crate::search::astar::AStar::default(), &grid, &q, SolveOptions::default(), &mut PlanContext::never_interrupted(&mut r));
            match (brute_force(&grid, s, g), any, astar) {
                (None, Err(PlanError::NoValidPath(_)), Err(PlanError::NoValidPath(_))) => {}
                (Some(best), Ok(any), Ok(astar)) => {
                    // The brute force may bend at a vertex nudged along an edge instead of diagonally:
                    // both are within a few NUDGE of the true optimum.
                    prop_assert!((any.metrics.length_m - best).abs() < 1e-4, "any-angle {} vs brute force {}\n{}{:?}", any.metrics.length_m, best, debug_picture(&grid, start, goal), any.waypoints);
                    prop_assert!(any.metrics.length_m <= astar.metrics.length_m + 1e-9);
                    prop_assert!(any.metrics.collision_free);
                    prop_assert_eq!(any.waypoints[0], s);
                    prop_assert_eq!(*any.waypoints.last().unwrap(), g);
                }
                (b, a, s) => prop_assert!(false, "disagree: {:?} {:?} {:?}\n{}", b, a.map(|p| p.metrics.length_m), s.map(|p| p.metrics.length_m), debug_picture(&grid, start, goal)),
            }
        }
    }
}
