//! Grids for unit and property tests.

use crate::geometry::{Cell, Point2, Pose2};
use crate::grid::inflation::PlanningGrid;
use crate::grid::MapInfo;
use crate::planner::PlannerRng;
use rand::{Rng, SeedableRng};

pub fn rng(seed: u64) -> PlannerRng {
    PlannerRng::seed_from_u64(seed)
}

/// A `w` x `h` grid of `resolution` m cells at the origin, cell (x, y) blocked where `blocked`
/// says (y up, as the map's cells count), obstacles grown by `inflate` m.
pub fn grid_with(
    (w, h): (usize, usize),
    resolution: f64,
    inflate: f64,
    blocked: impl Fn(usize, usize) -> bool,
) -> PlanningGrid {
    let obstacle = (0..w * h).map(|i| blocked(i % w, i / w)).collect();
    let info = MapInfo {
        width: w as u32,
        height: h as u32,
        resolution,
        origin: Pose2::default(),
    };
    PlanningGrid::from_obstacles(info, obstacle, inflate)
}

/// A grid from text rows listed top to bottom (`#` blocked, anything else free), 1 m cells, no
/// inflation: the picture in the source reads like the map.
pub fn grid_from_rows(rows: &[&str]) -> PlanningGrid {
    let (w, h) = (rows[0].len(), rows.len());
    assert!(rows.iter().all(|r| r.len() == w), "ragged test map");
    grid_with((w, h), 1.0, 0.0, |x, y| {
        rows[h - 1 - y].as_bytes()[x] == b'#'
    })
}

/// A seeded random grid (1 m cells, no inflation) with two distinct free cells as start and goal.
pub fn random_grid(seed: u64, w: usize, h: usize, density: f64) -> (PlanningGrid, Cell, Cell) {
    let mut r = rng(seed);
    let mut obstacle: Vec<bool> = (0..w * h).map(|_| r.random_bool(density)).collect();
    let start = Cell::new(r.random_range(0..w as i32), r.random_range(0..h as i32));
    let mut goal = start;
    while goal == start {
        goal = Cell::new(r.random_range(0..w as i32), r.random_range(0..h as i32));
    }
    for c in [start, goal] {
        obstacle[c.y as usize * w + c.x as usize] = false;
    }
    let grid = grid_with((w, h), 1.0, 0.0, |x, y| obstacle[y * w + x]);
    (grid, start, goal)
}

/// `planner`'s plan for `query` on `grid` with the default options, its random choices from
/// `seed`, with the interrupt `what` answered from its `fire_at`-th poll on (1: at once,
/// `u64::MAX`: never); with how many times it was polled. What the deadline and cancel tests
/// ask.
pub fn solve_interrupted(
    planner: &dyn crate::planner::Planner,
    grid: &PlanningGrid,
    query: &crate::planner::Query,
    seed: u64,
    fire_at: u64,
    what: crate::planner::Interrupt,
) -> (Result<crate::planner::Plan, crate::planner::PlanError>, u64) {
    use crate::planner::{solve, PlanContext, SolveOptions};
    let polls = std::cell::Cell::new(0u64);
    let interrupt = || {
        polls.set(polls.get() + 1);
        (polls.get() >= fire_at).then_some(what)
    };
    let mut r = rng(seed);
    let mut ctx = PlanContext::new(&mut r, &interrupt);
    let plan = solve(planner, grid, query, SolveOptions::default(), &mut ctx);
    (plan, polls.get())
}

/// `planner`'s plan for `query` on `grid` with the default options, its random choices from
/// `seed`, never interrupted: what most planner tests ask.
pub fn solve_seeded(
    planner: &dyn crate::planner::Planner,
    grid: &PlanningGrid,
    query: &crate::planner::Query,
    seed: u64,
) -> Result<crate::planner::Plan, crate::planner::PlanError> {
    use crate::planner::{solve, PlanContext, SolveOptions};
    let mut r = rng(seed);
    solve(
        planner,
        grid,
        query,
        SolveOptions::default(),
        &mut PlanContext::never_interrupted(&mut r),
    )
}

/// Of the runs of `planner` with random seeds `seeds`, how many answer better than the seed
/// they started from (counter `improved_on_seed`); every answer must be collision-free.
pub fn runs_improved_on_seed(
    planner: &dyn crate::planner::Planner,
    grid: &PlanningGrid,
    query: &crate::planner::Query,
    seeds: std::ops::RangeInclusive<u64>,
) -> usize {
    seeds
        .filter(|&seed| {
            let plan = solve_seeded(planner, grid, query, seed).unwrap();
            assert!(plan.metrics.collision_free, "seed {seed}");
            plan.stats.counters["improved_on_seed"] == 1.0
        })
        .count()
}

/// A 160 x 40 hall split by a wall with a gap at its top, start and goal in the two far
/// bottom corners; or (`pillars`) a 100 x 60 hall with 2 x 2 pillars every 9 cells, start
/// and goal in opposite corners.
pub fn hall(pillars: bool) -> (PlanningGrid, crate::planner::Query) {
    let (w, h) = if pillars { (100, 60) } else { (160, 40) };
    let blocked = |x: usize, y: usize| {
        if pillars {
            x % 9 >= 4 && x % 9 < 6 && y % 9 >= 4 && y % 9 < 6
        } else {
            x == 80 && y < 32
        }
    };
    let goal = (w as f64 - 1.5, if pillars { h as f64 - 1.5 } else { 1.5 });
    let q = crate::planner::Query {
        start: Point2::new(1.5, 1.5),
        goal: Point2::new(goal.0, goal.1),
        tolerance: 0.0,
    };
    (grid_with((w, h), 1.0, 0.0, blocked), q)
}

/// A real map's resolution: a 20 x 10 m room of 0.05 m cells (400 x 200), split by a wall with
/// a gap at its top, a short bar on the way, obstacles inflated 0.3 m; start and goal in the
/// two bottom corners, 1 m from the walls.
pub fn split_room_fine() -> (PlanningGrid, crate::planner::Query) {
    let grid = grid_with((400, 200), 0.05, 0.3, |x, y| {
        (x == 200 && y < 150) || (y == 60 && x > 80 && x < 120)
    });
    let q = crate::planner::Query {
        start: Point2::new(1.0, 1.0),
        goal: Point2::new(19.0, 1.0),
        tolerance: 0.0,
    };
    (grid, q)
}
