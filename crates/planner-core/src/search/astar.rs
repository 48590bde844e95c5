//! A* on the 8-connected grid: the comparison baseline of the patrol car paper's field test and
//! the fallback seed of the potential-field planners.
//!
//! Octile heuristic (admissible and consistent for unit straight moves and sqrt 2 diagonal moves);
//! a diagonal move only when both side cells are free, so no path cuts an obstacle corner. This is
//! exactly the Moving AI benchmarks' convention, and `patrol-plan movingai` checks it against their
//! published optimal lengths. Dense arrays instead of hash maps: a planning grid is small enough,
//! and the swarm planners call this tens of thousands of times over a run.

use crate::geometry::{Cell, NEIGHBOURS_8};
use crate::grid::inflation::PlanningGrid;
use crate::grid::moves::{allowed, step_length};
use crate::planner::{PlanContext, PlanError, PlanStats, Planner, Problem, RawPlan};
use crate::planner_name::PlannerName;
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// Poll the interrupt callback once per this many expansions.
const POLL_EVERY: u64 = 4096;

/// The `astar` planner: pure length (the papers' baseline, `cost_travel_multiplier` 0), or
/// Nav2's Smac 2D cost-aware mode, where a step into a cell of costmap cost `c` costs its length
/// times `1 + cost_travel_multiplier * c / 252`, so that among equally short paths the one
/// through the middle of an aisle wins.
#[derive(Clone, Debug, Default)]
pub struct AStar {
    pub cost_travel_multiplier: f64,
}

impl Planner for AStar {
    fn name(&self) -> PlannerName {
        PlannerName::Astar
    }

    fn plan(&self, problem: &Problem<'_>, ctx: &mut PlanContext<'_>) -> Result<RawPlan, PlanError> {
        let (cells, stats) = if self.cost_travel_multiplier > 0.0 {
            astar_cells_cost_aware(
                problem.grid,
                problem.start,
                problem.goal,
                ctx,
                self.cost_travel_multiplier,
            )?
        } else {
            astar_cells(problem.grid, problem.start, problem.goal, ctx)?
        };
        let waypoints = cells.into_iter().map(Cell::center).collect();
        Ok(RawPlan {
            waypoints,
            stats,
            ..RawPlan::default()
        })
    }
}

/// Octile distance between two cells (in cells).
#[inline]
pub fn octile(a: Cell, b: Cell) -> f64 {
    let dx = (a.x - b.x).abs() as f64;
    let dy = (a.y - b.y).abs() as f64;
    dx.max(dy) + (std::f64::consts::SQRT_2 - 1.0) * dx.min(dy)
}

/// An open-list entry. The order is smallest f first, then the deeper node (larger g), then the
/// smaller index, so the order of expansion is fully deterministic. f and g are non-negative, so
/// their IEEE bit patterns order like the numbers: the key is one integer comparison.
#[derive(Clone, Copy, PartialEq, Eq)]
struct Open {
    key: u128,
    /// Index into the padded arrays.
    index: u32,
}

impl Open {
    fn new(f: f64, g: f64, index: usize) -> Self {
        // BinaryHeap is a max-heap: invert f so the smallest f is the largest key.
        let key = ((!f.to_bits() as u128) << 64) | g.to_bits() as u128;
        Self {
            key,
            index: index as u32,
        }
    }
    fn g(&self) -> f64 {
        f64::from_bits(self.key as u64)
    }
}

impl Ord for Open {
    fn cmp(&self, other: &Self) -> Ordering {
        self.key
            .cmp(&other.key)
            .then_with(|| other.index.cmp(&self.index))
    }
}

impl PartialOrd for Open {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

/// The 8-connected successors of a cell with their step costs, by the one move rule of
/// [`crate::grid::moves`] (A* applies the same rule to its padded mask); the tests' oracle uses it.
pub fn successors(grid: &PlanningGrid, c: Cell) -> impl Iterator<Item = (Cell, f64)> + '_ {
    grid.moves(c)
        .map(move |(_, n)| (n, step_length(n.x - c.x, n.y - c.y)))
}

/// A* from `start` to `goal` (both free). Returns the cell path and its statistics.
///
/// Works on the grid's padded free mask, so no move needs a bounds check; a stale heap entry
/// (one whose g is no longer the best) is skipped instead of keeping a closed set.
pub fn astar_cells(
    grid: &PlanningGrid,
    start: Cell,
    goal: Cell,
    ctx: &PlanContext<'_>,
) -> Result<(Vec<Cell>, PlanStats), PlanError> {
    search(grid, start, goal, ctx, |_, dx, dy| step_length(dx, dy))
}

/// A* with Smac 2D's cost-aware step: the step into cell `c` costs its length times
/// `1 + multiplier * cost(c) / 252` (costs from [`PlanningGrid::cost`]). The octile heuristic
/// stays admissible, since no step costs less than its length.
pub fn astar_cells_cost_aware(
    grid: &PlanningGrid,
    start: Cell,
    goal: Cell,
    ctx: &PlanContext<'_>,
    multiplier: f64,
) -> Result<(Vec<Cell>, PlanStats), PlanError> {
    search(grid, start, goal, ctx, |c: Cell, dx, dy| {
        step_length(dx, dy) * (1.0 + multiplier * grid.cost(c) as f64 / 252.0)
    })
}

/// The search itself; `step(cell, dx, dy)` is the cost of the move into `cell`.
fn search(
    grid: &PlanningGrid,
    start: Cell,
    goal: Cell,
    ctx: &PlanContext<'_>,
    step: impl Fn(Cell, i32, i32) -> f64,
) -> Result<(Vec<Cell>, PlanStats), PlanError> {
    let stride = grid.width() + 2;
    let free = grid.padded_free();
    let padded = |c: Cell| (c.y as usize + 1) * stride + c.x as usize + 1;
    let unpadded = |i: usize| Cell::new((i % stride) as i32 - 1, (i / stride) as i32 - 1);
    let s = stride as isize;
    let offsets: [isize; 8] = NEIGHBOURS_8.map(|(dx, dy)| dx as isize + dy as isize * s);
    // All-zero tables, which the allocator hands out as untouched zero pages: a search pays for
    // the cells it reaches, not for the map (a short query on a 4 M-cell map used to spend
    // most of its time filling g with infinity). `seen[j]` says g[j] is set; unseen is infinite.
    let mut g = vec![0.0f64; free.len()];
    let mut seen = vec![false; free.len()];
    let mut parent = vec![0u32; free.len()];
    let mut open = BinaryHeap::new();
    let (si, gi) = (padded(start), padded(goal));
    g[si] = 0.0;
    seen[si] = true;
    open.push(Open::new(octile(start, goal), 0.0, si));
    let mut stats = PlanStats::default();
    while let Some(top) = open.pop() {
        let (gc, index) = (top.g(), top.index);
        let i = index as usize;
        if gc > g[i] {
            continue;
        }
        stats.iterations += 1;
        if stats.iterations % POLL_EVERY == 0 {
            ctx.check()?;
        }
        if i == gi {
            let mut cells = vec![goal];
            let mut k = gi;
            while k != si {
                k = parent[k] as usize;
                cells.push(unpadded(k));
            }
            cells.reverse();
            return Ok((cells, stats));
        }
        let c = unpadded(i);
        for (k, &(dx, dy)) in NEIGHBOURS_8.iter().enumerate() {
            let j = (i as isize + offsets[k]) as usize;
            if !allowed(dx, dy, |x, y| {
                free[(i as isize + x as isize + y as isize * s) as usize]
            }) {
                continue;
            }
            let ng = gc + step(c.offset(dx, dy), dx, dy);
            if !seen[j] || ng < g[j] {
                stats.evaluations += 1;
                g[j] = ng;
                seen[j] = true;
                parent[j] = index;
                open.push(Open::new(ng + octile(c.offset(dx, dy), goal), ng, j));
            }
        }
    }
    Err(PlanError::NoValidPath(format!(
        "the goal is not reachable from the start (A* closed {} cells)",
        stats.iterations
    )))
}

/// Length (in cells) of a cell path.
pub fn cell_path_length(cells: &[Cell]) -> f64 {
    cells
        .windows(2)
        .map(|w| (w[1].center() - w[0].center()).norm())
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::{random_grid, rng};
    use ordered_float::OrderedFloat;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// Against the `pathfinding` crate's A* as an oracle: same optimal length, and the path is
        /// a connected, collision-free 8-neighbour walk from start to goal.
        #[test]
        fn optimal_like_the_pathfinding_crate(seed in any::<u64>(), density in 0.0f64..0.4) {
            let (grid, start, goal) = random_grid(seed, 24, 18, density);
            let oracle = pathfinding::directed::astar::astar(
                &start,
                |&c| successors(&grid, c).map(|(n, w)| (n, OrderedFloat(w))).collect::<Vec<_>>(),
                |&c| OrderedFloat(octile(c, goal)),
                |&c| c == goal,
            );
            let mut r = rng(0);
            let ours = astar_cells(&grid, start, goal, &PlanContext::never_interrupted(&mut r));
            match (oracle, ours) {
                (None, Err(PlanError::NoValidPath(_))) => {}
                (Some((_, cost)), Ok((cells, _))) => {
                    prop_assert!((cell_path_length(&cells) - cost.0).abs() < 1e-9);
                    prop_assert_eq!(cells[0], start);
                    prop_assert_eq!(*cells.last().unwrap(), goal);
                    for w in cells.windows(2) {
                        prop_assert!(successors(&grid, w[0]).any(|(n, _)| n == w[1]));
                    }
                    let pts: Vec<_> = cells.iter().map(|c| c.center()).collect();
                    prop_assert!(crate::grid::raycast::path_is_free(&grid, &pts));
                }
                (o, u) => prop_assert!(false, "oracle {:?} vs ours {:?}", o.map(|x| x.1), u.map(|x| x.0.len())),
            }
        }
    }

    /// In a corridor, with start and goal beside one wall, plain A* runs along that wall; the
    /// cost-aware mode moves towards the middle, where the costmap is cheaper, at a small price
    /// in length.
    #[test]
    fn cost_aware_astar_keeps_to_the_middle_of_a_corridor() {
        use crate::grid::metrics::{measure, path_length};
        // 60 x 11 cells of 0.1 m: walls on rows 0 and 10, a corridor 0.9 m wide between.
        let grid = crate::test_support::grid_with((60, 11), 0.1, 0.15, |_, y| y == 0 || y == 10);
        let (start, goal) = (Cell::new(1, 2), Cell::new(58, 2));
        let mut r = rng(0);
        let ctx = PlanContext::never_interrupted(&mut r);
        let plain = astar_cells(&grid, start, goal, &ctx).unwrap().0;
        let aware = astar_cells_cost_aware(&grid, start, goal, &ctx, 2.0)
            .unwrap()
            .0;
        let pts = |cells: &[Cell]| cells.iter().map(|c| c.center()).collect::<Vec<_>>();
        let (mp, ma) = (measure(&grid, &pts(&plain)), measure(&grid, &pts(&aware)));
        assert!(
            plain.iter().all(|c| c.y == 2),
            "plain A* runs straight along the wall"
        );
        assert!(
            aware.iter().any(|c| c.y == 5),
            "the cost-aware path reaches the middle row"
        );
        assert!(
            ma.mean_clearance_m > mp.mean_clearance_m + 0.15,
            "{ma:?} vs {mp:?}"
        );
        assert!(ma.path_cost < mp.path_cost);
        assert!(path_length(&pts(&aware)) < 1.1 * path_length(&pts(&plain)));
        // Multiplier 0 is the plain search.
        assert_eq!(
            astar_cells_cost_aware(&grid, start, goal, &ctx, 0.0)
                .unwrap()
                .0,
            plain
        );
    }

    #[test]
    fn interrupt_stops_the_search() {
        // A wall splits the map, so the search must close the whole left half before giving up,
        // far more than POLL_EVERY cells.
        let mut rows = vec![format!("{}#{}", ".".repeat(100), ".".repeat(99)); 200];
        rows[0] = format!("{}#{}", ".".repeat(100), ".".repeat(99));
        let grid = crate::test_support::grid_from_rows(
            &rows.iter().map(String::as_str).collect::<Vec<_>>(),
        );
        let mut r = rng(0);
        let ctx = PlanContext::new(&mut r, &|| Some(crate::planner::Interrupt::Deadline));
        let result = astar_cells(&grid, Cell::new(0, 0), Cell::new(199, 199), &ctx);
        assert_eq!(result.map(|_| ()), Err(PlanError::TimedOut));
        let ctx = PlanContext::never_interrupted(&mut r);
        assert!(matches!(
            astar_cells(&grid, Cell::new(0, 0), Cell::new(199, 199), &ctx),
            Err(PlanError::NoValidPath(_))
        ));
    }
}
