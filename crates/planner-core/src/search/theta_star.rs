//! `theta_star`: any-angle search that weighs the costmap, in the manner of Nav2's Theta*
//! planner (nav2_theta_star_planner: Daniel, Nash, Koenig and Felner's Theta* with a traversal
//! cost term). Where `any_angle` is the pure-length reference (the shortest path, hugging the
//! corners it bends around), this one trades length against the cost of the cells a segment
//! crosses, so it keeps off the walls where that is cheap.
//!
//! Theta* over the grid's 8-neighbour moves (no corner cutting): a cell reached from `s` takes
//! `s`'s parent as its own when the parent sees it and the straight segment from the parent is
//! no dearer than the step through `s`, so paths bend anywhere, not only in 45 degree steps. The cost of a segment `a -> b` is its length times
//! `1 + m * mean cost / 252` over the cells its supercover crosses (`m` =
//! `search.cost_travel_multiplier`, the same weight as `astar`'s cost-aware mode; 0 is plain
//! Theta* by length). The Euclidean distance to the goal is the heuristic: admissible, since no
//! segment costs less than its length. Theta* is not guaranteed optimal in any-angle length;
//! the bench's reference stays `any_angle`.
//!
//! By length alone (`m` = 0) the search is Lazy Theta* (Nash, Koenig and Tovey, "Lazy Theta*:
//! Any-Angle Path Planning and Path Length Analysis in 3D", AAAI 2010): a reached cell takes
//! its predecessor's parent on trust, and the line of sight is tested once, when the cell is
//! expanded; where it fails, the cell takes the best of its closed neighbours instead. Theta*
//! tests it for every neighbour of every expanded cell: on a 4000 x 4000 map that was 13 s,
//! most of it line of sight. Weighing the cost, every candidate segment is walked for its cost
//! anyway, and the walk says whether it is free: the eager form stays.

use crate::geometry::{Cell, Point2};
use crate::grid::inflation::PlanningGrid;
use crate::grid::raycast::{blocked_and_cost_length, line_of_sight};
use crate::planner::{PlanContext, PlanError, PlanStats, Planner, Problem, RawPlan};
use crate::planner_name::PlannerName;
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// The planner.
#[derive(Clone, Debug, Default)]
pub struct ThetaStar {
    /// The weight of the costmap cost (see the module doc).
    pub cost_travel_multiplier: f64,
}

#[derive(Clone, Copy, PartialEq)]
struct Open {
    f: f64,
    g: f64,
    index: usize,
}
impl Eq for Open {}
impl Ord for Open {
    fn cmp(&self, other: &Self) -> Ordering {
        other
            .f
            .total_cmp(&self.f)
            .then_with(|| self.g.total_cmp(&other.g))
            .then_with(|| other.index.cmp(&self.index))
    }
}
impl PartialOrd for Open {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl ThetaStar {
    /// The cost (grid units) of the straight segment between two cell centres.
    fn segment(&self, grid: &PlanningGrid, a: Cell, b: Cell) -> f64 {
        let (pa, pb) = (a.center(), b.center());
        if self.cost_travel_multiplier > 0.0 {
            let (_, cost_len) = blocked_and_cost_length(grid, &[pa, pb]);
            (pb - pa).norm() + self.cost_travel_multiplier * cost_len
        } else {
            (pb - pa).norm()
        }
    }
}

impl Planner for ThetaStar {
    fn name(&self) -> PlannerName {
        PlannerName::ThetaStar
    }

    fn plan(&self, problem: &Problem<'_>, ctx: &mut PlanContext<'_>) -> Result<RawPlan, PlanError> {
        let grid = problem.grid;
        let info = grid.info();
        let (start, goal) = (problem.start, problem.goal);
        let n = info.cell_count();
        // All-zero tables (zero pages until touched): `seen[i]` says g[i] and parent[i] are set.
        let mut g = vec![0.0f64; n];
        let mut parent = vec![0u32; n];
        let mut seen = vec![false; n];
        let mut closed = vec![false; n];
        let h = |c: Cell| (goal.center() - c.center()).norm();
        let si = info.index(start);
        g[si] = 0.0;
        parent[si] = si as u32;
        seen[si] = true;
        let mut open = BinaryHeap::from([Open {
            f: h(start),
            g: 0.0,
            index: si,
        }]);
        let mut stats = PlanStats::default();
        let lazy = self.cost_travel_multiplier <= 0.0;
        while let Some(Open {
            g: gc, index: i, ..
        }) = open.pop()
        {
            if closed[i] || gc > g[i] {
                continue;
            }
            closed[i] = true;
            stats.iterations += 1;
            if stats.iterations % 4096 == 0 {
                ctx.check()?;
            }
            let c = info.cell_at(i);
            if lazy {
                // Lazy Theta*'s SetVertex: the parent taken on trust must see this cell, else the
                // cheapest closed neighbour (the one that reached it is closed) becomes it.
                let p = parent[i] as usize;
                if p != i && !line_of_sight(grid, info.cell_at(p).center(), c.center()) {
                    let (from, g_via) = grid
                        .moves(c)
                        .map(|(_, nb)| info.index(nb))
                        .filter(|&j| closed[j])
                        .map(|j| (j, g[j] + self.segment(grid, info.cell_at(j), c)))
                        .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)))
                        .expect("the cell that reached this one is closed");
                    parent[i] = from as u32;
                    g[i] = g_via;
                }
            }
            let gc = g[i];
            if c == goal {
                let mut cells = vec![c];
                let mut k = i;
                while k != si {
                    k = parent[k] as usize;
                    cells.push(info.cell_at(k));
                }
                cells.reverse();
                // Cell centres: the segments were checked between centres, and `solve` pins the
                // exact start and goal only where they still see their neighbours.
                let waypoints: Vec<Point2> = cells.iter().map(|c| c.center()).collect();
                stats.evaluations = stats.iterations;
                return Ok(RawPlan {
                    waypoints,
                    stats,
                    ..RawPlan::default()
                });
            }
            let p = parent[i] as usize;
            let pc = info.cell_at(p);
            for (_, nb) in grid.moves(c) {
                let j = info.index(nb);
                if closed[j] {
                    continue;
                }
                // Path 1: through this cell. Path 2 of Theta*: straight from its parent, when the
                // parent sees the neighbour. With a cost term the triangle inequality no longer
                // holds (the straight segment may cross costlier cells), so the cheaper one wins
                // rather than path 2 always. Lazily (by length, where path 2 always wins) it is
                // taken on trust: its line of sight is tested when `nb` is expanded.
                let mut best = (i, gc + self.segment(grid, c, nb));
                if p != i && (lazy || line_of_sight(grid, pc.center(), nb.center())) {
                    let via_parent = g[p] + self.segment(grid, pc, nb);
                    if lazy || via_parent <= best.1 {
                        best = (p, via_parent);
                    }
                }
                let (from, ng) = best;
                if !seen[j] || ng < g[j] {
                    g[j] = ng;
                    parent[j] = from as u32;
                    seen[j] = true;
                    open.push(Open {
                        f: ng + h(nb),
                        g: ng,
                        index: j,
                    });
                }
            }
        }
        Err(PlanError::NoValidPath(format!(
            "the goal is not reachable from the start (Theta* closed {} cells)",
            stats.iterations
        )))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::metrics::measure;
    use crate::planner::Query;
    use crate::test_support::{grid_with, solve_seeded};

    /// A 1.6 m wide corridor, start and goal 0.5 m off its lower wall: by length, Theta* runs
    /// straight along the wall; weighing the cost, it moves towards the middle (more clearance,
    /// less cost) for a little more length. Both are collision-free and end where asked.
    #[test]
    fn weighing_the_cost_keeps_to_the_middle_of_a_corridor() {
        let grid = grid_with((120, 20), 0.1, 0.25, |_, y| y == 0 || y == 19);
        let q = Query {
            start: Point2::new(0.55, 0.55),
            goal: Point2::new(11.45, 0.55),
            tolerance: 0.0,
        };
        let run = |m: f64| {
            let planner = ThetaStar {
                cost_travel_multiplier: m,
            };
            let plan = solve_seeded(&planner, &grid, &q, 0).unwrap();
            assert!(plan.metrics.collision_free);
            assert_eq!(plan.waypoints[0], q.start);
            assert_eq!(*plan.waypoints.last().unwrap(), q.goal);
            measure(&grid, &grid_points(&grid, &plan.waypoints))
        };
        let plain = run(0.0);
        let aware = run(3.0);
        assert!(
            (plain.length_m - 10.9).abs() < 0.05,
            "by length: straight, {}",
            plain.length_m
        );
        assert!(
            aware.mean_clearance_m > plain.mean_clearance_m + 0.15,
            "clearance {} -> {}",
            plain.mean_clearance_m,
            aware.mean_clearance_m
        );
        assert!(aware.path_cost < 0.7 * plain.path_cost);
        assert!(aware.length_m < 1.15 * plain.length_m);
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]
        /// On random maps, lazily (by length) and eagerly (weighing the cost): a path wherever A*
        /// finds one, none where it does not, every segment free (the lazy search's trusted
        /// parents all checked), between the cell centres of start and goal, and by length not
        /// much longer than A*'s 8-neighbour path. Theta*, lazy or not, is not guaranteed to be
        /// shorter than the grid path (the committed seed is a lazy path 1 % longer); 10 % is
        /// allowed: the check is against gross detours, not against Theta*'s own slack.
        #[test]
        fn a_free_path_wherever_astar_finds_one(seed in proptest::prelude::any::<u64>(), density in 0.0f64..0.4) {
            use crate::grid::raycast::path_is_free;
            use crate::search::astar::{astar_cells, cell_path_length};
            use crate::test_support::{random_grid, rng};
            let (grid, start, goal) = random_grid(seed, 30, 22, density);
            let mut r = rng(0);
            let astar = astar_cells(&grid, start, goal, &PlanContext::never_interrupted(&mut r));
            for m in [0.0, 2.0] {
                let planner = ThetaStar { cost_travel_multiplier: m };
                let problem = Problem {
                    grid: &grid,
                    start,
                    goal,
                    start_point: start.center(),
                    goal_point: goal.center(),
                };
                let mut r = rng(0);
                let ours = planner.plan(&problem, &mut PlanContext::never_interrupted(&mut r));
                match (&astar, ours) {
                    (Err(PlanError::NoValidPath(_)), Err(PlanError::NoValidPath(_))) => {}
                    (Ok((cells, _)), Ok(plan)) => {
                        let w = &plan.waypoints;
                        proptest::prop_assert_eq!(w[0], start.center());
                        proptest::prop_assert_eq!(*w.last().unwrap(), goal.center());
                        proptest::prop_assert!(path_is_free(&grid, w), "m {}: a blocked segment", m);
                        if m == 0.0 {
                            let length: f64 = w.windows(2).map(|s| (s[1] - s[0]).norm()).sum();
                            proptest::prop_assert!(
                                length <= 1.1 * cell_path_length(cells),
                                "{} against A*'s {}", length, cell_path_length(cells)
                            );
                        }
                    }
                    (a, o) => proptest::prop_assert!(false, "A* {:?}, theta* {:?}", a.is_ok(), o.is_ok()),
                }
            }
        }
    }

    fn grid_points(grid: &PlanningGrid, world: &[Point2]) -> Vec<Point2> {
        world
            .iter()
            .map(|&p| grid.info().world_to_grid(p))
            .collect()
    }
}
