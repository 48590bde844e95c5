//! The one planner boundary.
//!
//! Every planner implements [`Planner`]: a pure function of (its parameters, the planning grid,
//! the start and goal cells, the seed) that may be interrupted through a callback. It works in
//! grid coordinates only. [`solve`] wraps it the way Nav2's planner plugins wrap their cores:
//! it checks the request (finite numbers, inside the map, start and goal free, goal tolerance),
//! calls the planner, applies the optional delete operation, verifies the result with the one
//! collision rule of [`crate::grid::raycast`], measures it and converts it to world metres. So no
//! planner repeats validation, and no planner can hand back a colliding path.

use crate::geometry::{Cell, Point2};
use crate::grid::inflation::PlanningGrid;
use crate::grid::metrics::{drop_collinear, measure, path_length, total_turning, PathMetrics};
use crate::grid::raycast::{line_of_sight, path_is_free};
use crate::grid::smoothing::delete_redundant;
use crate::planner_name::PlannerName;
use serde::Serialize;
use std::collections::BTreeMap;
use std::fmt;

/// The random number generator every planner draws from: portable and seedable, so the same seed
/// gives the same path on every machine.
pub type PlannerRng = rand_chacha::ChaCha8Rng;

/// Why a running plan was asked to stop.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interrupt {
    /// The time budget ran out.
    Deadline,
    /// The caller no longer wants the plan (a new goal, shutdown).
    Cancelled,
}

/// Why a run stopped. Every plan carries one (`PlanStats::termination`), the CLI prints it and
/// `/diagnostics` reports it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Termination {
    /// A method that runs to its end by itself (graph search, field descent) found its path.
    Completed,
    /// The iteration budget was used up.
    MaxIterations,
    /// No better value for `patience` iterations in a row.
    Converged { patience: usize },
    /// The time budget ran out or the caller cancelled; the best path so far came back.
    Interrupted(Interrupt),
}

impl Termination {
    /// The short name the CLI's JSON and `/diagnostics` carry.
    pub fn as_str(self) -> &'static str {
        match self {
            Termination::Completed => "completed",
            Termination::MaxIterations => "max_iterations",
            Termination::Converged { .. } => "converged",
            Termination::Interrupted(Interrupt::Deadline) => "deadline",
            Termination::Interrupted(Interrupt::Cancelled) => "cancelled",
        }
    }
}

impl fmt::Display for Termination {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Termination::Converged { patience } => {
                write!(f, "converged (no better value for {patience} iterations)")
            }
            other => f.write_str(other.as_str()),
        }
    }
}

impl Serialize for Termination {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.as_str())
    }
}

/// What the observer hook sees after every iteration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Iteration {
    /// 1 for the first iteration.
    pub number: u64,
    /// The best value so far (the family's objective; never increases).
    pub best: f64,
}

/// What a planner may use besides the problem: randomness, a way to learn it should stop, and
/// an optional observer of the population loop.
pub struct PlanContext<'a> {
    pub rng: &'a mut PlannerRng,
    /// Polled by planners (every iteration, or every few thousand expansions); `Some` means stop.
    /// Anytime planners then return their best path so far with `stats.cut_short` set.
    pub interrupt: &'a dyn Fn() -> Option<Interrupt>,
    /// Called after every iteration of a population planner (convergence plots, progress bars).
    pub observer: Option<&'a mut dyn FnMut(&Iteration)>,
    /// Called by [`solve_through`] as each leg starts, so that a caller can give every leg a
    /// time budget of its own, as Nav2's planner_server gives each leg of
    /// ComputePathThroughPoses its planner's own time.
    pub on_leg: Option<&'a dyn Fn()>,
}

impl<'a> PlanContext<'a> {
    /// A context with no observer.
    pub fn new(rng: &'a mut PlannerRng, interrupt: &'a dyn Fn() -> Option<Interrupt>) -> Self {
        Self {
            rng,
            interrupt,
            observer: None,
            on_leg: None,
        }
    }

    /// The context of a run with no deadline.
    pub fn never_interrupted(rng: &'a mut PlannerRng) -> Self {
        Self::new(rng, &|| None)
    }

    pub fn check(&self) -> Result<(), PlanError> {
        match (self.interrupt)() {
            None => Ok(()),
            Some(Interrupt::Deadline) => Err(PlanError::TimedOut),
            Some(Interrupt::Cancelled) => Err(PlanError::Cancelled),
        }
    }
}

/// A validated problem in grid coordinates, handed to [`Planner::plan`].
#[derive(Clone, Copy, Debug)]
pub struct Problem<'a> {
    pub grid: &'a PlanningGrid,
    pub start: Cell,
    pub goal: Cell,
    /// The exact start (inside `start`'s cell).
    pub start_point: Point2,
    /// The exact goal (inside `goal`'s cell; the cell centre when the goal was snapped).
    pub goal_point: Point2,
}

/// One member of a Pareto front.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ParetoMember {
    /// Path length (m).
    pub f1_length_m: f64,
    /// Total turning angle (rad).
    pub f2_turning_rad: f64,
    /// Safety cost: the costmap cost integrated along the path (m at cost 252); 0 when the
    /// planner's safety weight is 0.
    pub f3_safety: f64,
    pub waypoints: Vec<Point2>,
}

/// Statistics of a run: what the bench tables and `/diagnostics` report.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct PlanStats {
    /// Iterations (population methods) or node expansions (graph search).
    pub iterations: u64,
    /// Objective evaluations (population methods) or edges relaxed (graph search).
    pub evaluations: u64,
    /// The iteration at which the best value last improved.
    pub best_iteration: Option<u64>,
    /// Best objective value per iteration.
    pub convergence: Vec<f64>,
    /// The interrupt callback stopped the run and the best path so far came back.
    pub cut_short: bool,
    /// Why the run stopped ([`Termination::Completed`] for the methods that run to their end).
    pub termination: Option<Termination>,
    /// Planner-specific counters (e.g. `dropped_ants`), by name.
    pub counters: BTreeMap<String, f64>,
    /// Planner-specific remarks (e.g. which encoding was used, a fallback that happened).
    pub notes: Vec<String>,
}

/// What a planner returns: a polyline in grid coordinates from the problem's start point to its
/// goal point (cell centres in between are fine; `solve` adds the exact end points).
#[derive(Clone, Debug, Default)]
pub struct RawPlan {
    pub waypoints: Vec<Point2>,
    pub stats: PlanStats,
    /// The Pareto front (grid coordinates), for multi-objective planners.
    pub pareto: Vec<ParetoMember>,
    /// The path the planner started from, for planners that improve on a seed (the swarms,
    /// NSGA-II, the improved colony, the seeded GA): [`solve`] finishes it as it finishes the
    /// answer and records whether the answer is better (counter `improved_on_seed`) and whether
    /// the seed was already the straight segment, which nothing improves on (`seed_straight`).
    pub seed: Option<Vec<Point2>>,
}

/// The answer to a request: a verified, measured path in world metres.
#[derive(Clone, Debug, Serialize)]
pub struct Plan {
    pub planner: PlannerName,
    pub waypoints: Vec<Point2>,
    pub metrics: PathMetrics,
    pub stats: PlanStats,
    /// Pareto front in world metres (empty for single-objective planners).
    pub pareto: Vec<ParetoMember>,
    /// Where the plan actually ends: the requested goal, or the free cell it was snapped to.
    pub goal: Point2,
    /// The resolution (m per cell) of the grid the plan was made on: its densified form (a
    /// nav_msgs/Path) is spaced by it, whatever map has arrived since.
    pub resolution: f64,
    /// Where a plan through via points ([`solve_through`]) passes each of them, in order: the
    /// point asked for, or the free cell it was moved to. Each is one of `waypoints`. Empty for
    /// a plan to one goal.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub via: Vec<Point2>,
}

/// A planning request in world metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Query {
    pub start: Point2,
    pub goal: Point2,
    /// How far (m) the goal may be moved to reach a free cell; 0 means exactly there.
    pub tolerance: f64,
}

/// How a request can fail: Nav2's planner failure set. Exhaustive on purpose: the node maps
/// every variant to a result code, and a new one must be mapped there, not fall into a default.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PlanError {
    #[error("start ({}, {}) is outside the map", .0.x, .0.y)]
    StartOutsideMap(Point2),
    #[error("goal ({}, {}) is outside the map", .0.x, .0.y)]
    GoalOutsideMap(Point2),
    #[error("start ({}, {}) is in an obstacle, in unknown space or within the inflation radius of an obstacle", .0.x, .0.y)]
    StartOccupied(Point2),
    #[error("goal ({}, {}) is in an obstacle, in unknown space or within the inflation radius of an obstacle, and no free cell lies within the tolerance", .0.x, .0.y)]
    GoalOccupied(Point2),
    #[error("no valid path: {0}")]
    NoValidPath(String),
    #[error("planning timed out before any path was found")]
    TimedOut,
    #[error("planning was cancelled")]
    Cancelled,
    #[error("invalid request: {0}")]
    InvalidInput(String),
    /// The planner's working tables on this map would exceed the plan's memory cap.
    #[error("{planner} needs about {} MiB of working tables on this {cells}-cell map ({per_cell} B per cell, and the paths it keeps), over the cap of {} MiB (max_plan_memory_mb)", .needed >> 20, .cap >> 20)]
    TooLarge {
        planner: PlannerName,
        cells: u64,
        per_cell: u64,
        needed: u64,
        cap: u64,
    },
}

/// What one plan may allocate for its per-cell working tables unless configured otherwise
/// (`max_plan_memory_mb`): 2 GiB, which every planner stays within on a 4000 x 4000 map (16 M
/// cells; the largest, any_angle, needs 96 B per cell there, 1.5 GB). The map itself (the
/// grid, its clearance transform, the planning grid) is the node's and is not counted.
pub const DEFAULT_MAX_PLAN_BYTES: u64 = 2 << 30;

/// A*'s tables per cell (`search::astar`): g (8 B), parent (4 B) and a seen flag (1 B) of every
/// cell of the padded grid and, at most about one open-list entry (16 B) per cell, rounded up
/// to 32 B (the tables are zero pages until a cell is reached, so this bounds, not predicts).
/// Every planner but the bare potential field may run A* (as its seed or its fallback).
pub const ASTAR_BYTES_PER_CELL: u64 = 32;

/// The one trait every planner implements. Object safe: planners are chosen by name at run time.
pub trait Planner: Send + Sync {
    /// The name users select it by (`astar`, `mocmcso`, ...).
    fn name(&self) -> PlannerName;

    /// Whether [`solve`] applies the delete operation to this planner's path unless told
    /// otherwise. Colony and genetic planners, whose paths are cell staircases, say yes.
    fn smooth_by_default(&self) -> bool {
        false
    }

    /// The bytes per map cell this planner's working tables take in one plan, at most (an
    /// estimate of the tables it allocates per cell, never of the path): [`solve`] refuses a
    /// plan over [`SolveOptions::max_plan_bytes`] before the planner allocates anything.
    fn working_bytes_per_cell(&self) -> u64 {
        ASTAR_BYTES_PER_CELL
    }

    /// The bytes, at most, this planner holds in one plan on a `width x height` map beyond its
    /// per-cell tables (paths kept across an iteration that may each be as long as the step
    /// budget allows); counted against the same cap.
    fn working_bytes_beyond_cells(&self, _width: usize, _height: usize) -> u64 {
        0
    }

    /// Plans on a validated problem. Pure: the result depends only on `self`, `problem` and the
    /// RNG's state (and on when `ctx.interrupt` fires).
    fn plan(&self, problem: &Problem<'_>, ctx: &mut PlanContext<'_>) -> Result<RawPlan, PlanError>;
}

/// Options of [`solve`] that are not the planner's own.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolveOptions {
    /// Apply the delete operation (genetic algorithm paper section 4.5): `None` follows
    /// [`Planner::smooth_by_default`].
    pub smoothing: Option<bool>,
    /// How far (m) a start inside the inflated band may move to the nearest free cell instead
    /// of failing with START_OCCUPIED (a robot pushed against a wall, or a map update that
    /// grew an obstacle under it: navigation2 issues 5685, 6120). 0: never.
    pub start_tolerance: f64,
    /// The cap on one plan's per-cell working tables (bytes); see [`DEFAULT_MAX_PLAN_BYTES`].
    pub max_plan_bytes: u64,
}

impl Default for SolveOptions {
    fn default() -> Self {
        Self {
            smoothing: None,
            start_tolerance: 0.0,
            max_plan_bytes: DEFAULT_MAX_PLAN_BYTES,
        }
    }
}

/// Refuses a plan whose working tables on `grid` would pass `cap` bytes.
fn check_memory(planner: &dyn Planner, grid: &PlanningGrid, cap: u64) -> Result<(), PlanError> {
    // The padded grid A* indexes: (w + 2) x (h + 2).
    let cells = (grid.width() as u64 + 2) * (grid.height() as u64 + 2);
    let per_cell = planner.working_bytes_per_cell();
    let needed = cells
        .saturating_mul(per_cell)
        .saturating_add(planner.working_bytes_beyond_cells(grid.width(), grid.height()));
    if needed > cap {
        return Err(PlanError::TooLarge {
            planner: planner.name(),
            cells,
            per_cell,
            needed,
            cap,
        });
    }
    Ok(())
}

/// Validates a request, runs the planner, post-processes, verifies and measures its path.
pub fn solve(
    planner: &dyn Planner,
    grid: &PlanningGrid,
    query: &Query,
    options: SolveOptions,
    ctx: &mut PlanContext<'_>,
) -> Result<Plan, PlanError> {
    let problem = validate_with(grid, query, options.start_tolerance)?;
    let mut raw = if problem.start == problem.goal {
        // The goal lies in the start's own cell: the straight segment inside one free cell is
        // the path (Nav2's planners answer such a request with a one- or two-pose path). No
        // planner is asked: their encodings need at least one cell between the two.
        RawPlan {
            waypoints: vec![problem.start_point, problem.goal_point],
            ..RawPlan::default()
        }
    } else {
        // Only a plan that runs a planner allocates its working tables.
        check_memory(planner, grid, options.max_plan_bytes)?;
        planner.plan(&problem, ctx)?
    };
    raw.stats.termination.get_or_insert(Termination::Completed);
    note_moved_ends(
        grid,
        query,
        &problem,
        options.start_tolerance,
        &mut raw.stats,
    );
    let smoothing = options
        .smoothing
        .unwrap_or_else(|| planner.smooth_by_default());
    let waypoints = finish_path(grid, &problem, raw.waypoints, smoothing)?;
    let metrics = measure(grid, &waypoints);
    if let Some(seed) = raw.seed.take() {
        // The seed gets the same post-processing as the answer, so that the delete operation of
        // the colonies and the GA is not counted as the search's improvement.
        if let Ok(seed) = finish_path(grid, &problem, seed, smoothing) {
            // A seed that is one segment is the shortest path there is and has no turn: no
            // answer can be better, and the count of such runs says how many misses were these.
            let straight = seed.len() == 2;
            let seed = (path_length(&seed) * grid.resolution(), total_turning(&seed));
            let better = improves_on(seed, (metrics.length_m, metrics.turning_rad));
            let counters = &mut raw.stats.counters;
            counters.insert("improved_on_seed".into(), if better { 1.0 } else { 0.0 });
            counters.insert("seed_straight".into(), if straight { 1.0 } else { 0.0 });
            if straight {
                raw.stats.notes.push(
                    "the seed is already the straight segment to the goal: no path improves on it"
                        .into(),
                );
            } else if !better {
                raw.stats
                    .notes
                    .push("the answer is not better than the seed it started from".into());
            }
        }
    }
    let info = grid.info();
    let to_world = |pts: &[Point2]| {
        pts.iter()
            .map(|&p| info.grid_to_world(p))
            .collect::<Vec<_>>()
    };
    let pareto = raw
        .pareto
        .iter()
        .map(|m| ParetoMember {
            waypoints: to_world(&m.waypoints),
            ..m.clone()
        })
        .collect();
    Ok(Plan {
        planner: planner.name(),
        metrics,
        waypoints: to_world(&waypoints),
        stats: raw.stats,
        pareto,
        goal: info.grid_to_world(problem.goal_point),
        resolution: info.resolution,
        via: Vec::new(),
    })
}

/// Plans from `start` through each of `goals` in order, the last being the goal, as Nav2's
/// ComputePathThroughPoses does: one [`solve`] per leg on the same grid, with the same planner,
/// random stream and interrupt, each leg starting where the one before ended (its goal, or the
/// free cell within `tolerance` it was moved to). `ctx.on_leg` is told as each leg starts (a
/// caller's per-leg time budget starts there), and the interrupt is checked between legs too:
/// a request cancelled or out of time starts no further leg. The legs are joined into one
/// plan, measured as a whole ([`join_legs`]). With one goal this is [`solve`], bit for bit.
pub fn solve_through(
    planner: &dyn Planner,
    grid: &PlanningGrid,
    start: Point2,
    goals: &[Point2],
    tolerance: f64,
    options: SolveOptions,
    ctx: &mut PlanContext<'_>,
) -> Result<Plan, PlanError> {
    let mut legs = Vec::with_capacity(goals.len());
    let mut from = start;
    for (i, &goal) in goals.iter().enumerate() {
        if let Some(on_leg) = ctx.on_leg {
            on_leg();
        }
        // A request given up or out of time between legs starts no more of them.
        if i > 0 {
            ctx.check()?;
        }
        let query = Query {
            start: from,
            goal,
            tolerance,
        };
        let leg = solve(planner, grid, &query, options, ctx).map_err(|e| match e {
            // The other failures name the point they are about.
            PlanError::NoValidPath(why) if goals.len() > 1 => PlanError::NoValidPath(format!(
                "leg {} of {} (to ({}, {})): {why}",
                i + 1,
                goals.len(),
                goal.x,
                goal.y
            )),
            e => e,
        })?;
        from = leg.goal;
        legs.push(leg);
    }
    join_legs(legs).ok_or_else(|| PlanError::InvalidInput("no goal given".into()))
}

/// One plan from consecutive legs (each starting where the one before ends): the waypoints in
/// order, each leg's end but the last kept as a via point; the metrics of the whole path (the
/// lengths and costs summed, clearances and corridor widths averaged over length as
/// [`measure`] averages them, the turning measured across the joins too); the statistics summed
/// (each leg's notes prefixed with its number; a counter such as `improved_on_seed` then counts
/// legs). A joined path has no Pareto front of its own: each leg's front was over that leg.
/// `None` for no legs; one leg is returned as it is.
pub fn join_legs(legs: Vec<Plan>) -> Option<Plan> {
    if legs.len() <= 1 {
        return legs.into_iter().next();
    }
    let n = legs.len();
    let mut waypoints: Vec<Point2> = Vec::new();
    let mut via = Vec::with_capacity(n - 1);
    let mut stats = PlanStats::default();
    let (mut length, mut cost) = (0.0, 0.0);
    let (mut clearance_sum, mut corridor_sum) = (0.0, 0.0);
    let (mut min_clearance, mut free, mut resolution) = (f64::INFINITY, true, f64::INFINITY);
    for (i, leg) in legs.iter().enumerate() {
        // The leg starts where the last one ended: that point is already in.
        let skip = usize::from(!waypoints.is_empty());
        waypoints.extend(leg.waypoints.iter().skip(skip).copied());
        if i + 1 < n {
            via.push(*waypoints.last().expect("a leg has points"));
        }
        let m = &leg.metrics;
        length += m.length_m;
        cost += m.path_cost;
        min_clearance = min_clearance.min(m.min_clearance_m);
        free &= m.collision_free;
        resolution = resolution.min(leg.resolution);
        // A leg of no length weighs nothing (and its infinite clearance, on a map without
        // obstacles, would make the sum NaN).
        if m.length_m > 0.0 {
            clearance_sum += m.mean_clearance_m * m.length_m;
            corridor_sum += m.corridor_half_width_m * m.length_m;
        }
        let s = &leg.stats;
        stats.iterations += s.iterations;
        stats.evaluations += s.evaluations;
        stats.cut_short |= s.cut_short;
        // An interrupted leg says why the request stopped early (it agrees with `cut_short`);
        // else the first leg that did not run to its end says how the search ended.
        let interrupted = |t: Option<Termination>| matches!(t, Some(Termination::Interrupted(_)));
        if !interrupted(stats.termination)
            && (interrupted(s.termination)
                || matches!(stats.termination, None | Some(Termination::Completed)))
        {
            stats.termination = s.termination;
        }
        for (name, value) in &s.counters {
            *stats.counters.entry(name.clone()).or_insert(0.0) += value;
        }
        let leg_number = i + 1;
        stats.notes.extend(
            s.notes
                .iter()
                .map(|note| format!("leg {leg_number}: {note}")),
        );
    }
    // A path of no length at all (every goal in the start's cell) has its first point's value.
    let first = &legs[0].metrics;
    let averaged = |sum: f64, at_first: f64| {
        if length > 0.0 {
            sum / length
        } else {
            at_first
        }
    };
    let metrics = PathMetrics {
        length_m: length,
        turning_rad: total_turning(&waypoints),
        turns: crate::grid::metrics::turn_count(&waypoints),
        min_clearance_m: min_clearance,
        mean_clearance_m: averaged(clearance_sum, first.mean_clearance_m),
        path_cost: cost,
        corridor_half_width_m: averaged(corridor_sum, first.corridor_half_width_m),
        collision_free: free,
    };
    let last = legs.last().expect("more than one leg");
    Some(Plan {
        planner: last.planner,
        waypoints,
        metrics,
        stats,
        pareto: Vec::new(),
        goal: last.goal,
        resolution,
        via,
    })
}

/// Notes where the plan's start or goal is not the one asked for: an end in an obstacle, unknown
/// space or the inflated band moved to the nearest free cell's centre within its tolerance
/// (`start_tolerance`, the goal `tolerance`), as Nav2's planners move them; the note says where
/// to and how far, so a user sees why the path does not begin or end at the pose sent.
fn note_moved_ends(
    grid: &PlanningGrid,
    query: &Query,
    problem: &Problem<'_>,
    start_tolerance: f64,
    stats: &mut PlanStats,
) {
    let info = grid.info();
    let ends = [
        (
            "start",
            query.start,
            problem.start_point,
            "start_tolerance",
            start_tolerance,
        ),
        (
            "goal",
            query.goal,
            problem.goal_point,
            "tolerance",
            query.tolerance,
        ),
    ];
    for (what, asked, used, knob, tolerance) in ends {
        let used = info.grid_to_world(used);
        let moved = (used - asked).norm();
        if moved > 1e-6 {
            stats.notes.push(format!(
                "the {what} ({:.3}, {:.3}) is not free: the plan uses the nearest free cell's \
                 centre ({:.3}, {:.3}), {moved:.3} m away ({knob} {tolerance} m)",
                asked.x, asked.y, used.x, used.y
            ));
        }
    }
}

/// Whether `answer` is better than `seed`, each as (length, turning) in one unit of length, the
/// way issue 12 counts it: shorter or smoother, and worse on neither (a relative tolerance of
/// 1e-9 absorbs rounding). The answer against its seed (`solve`), and a straightened ant's walk
/// or GA individual against the best so far (the pulled judge, [`crate::judge`]).
pub fn improves_on((seed_len, seed_turn): (f64, f64), (len, turn): (f64, f64)) -> bool {
    let no_worse = len <= seed_len + improvement_tolerance(seed_len)
        && turn <= seed_turn + improvement_tolerance(seed_turn);
    let better = len < seed_len - improvement_tolerance(seed_len)
        || turn < seed_turn - improvement_tolerance(seed_turn);
    no_worse && better
}

/// The rounding [`improves_on`] forgives around a measure `v`.
fn improvement_tolerance(v: f64) -> f64 {
    1e-9 * v.abs().max(1.0)
}

/// Whether no answer whose length is at least `len_at_least` (up to rounding in summing it: the
/// bound is given another tolerance) or whose turning is at least `turn_at_least` (a prefix of
/// the same sum, so a true bound) can improve on `best` by [`improves_on`]. Lets the pulled
/// judge stop straightening a candidate part way.
pub fn cannot_improve_on(
    (best_len, best_turn): (f64, f64),
    len_at_least: f64,
    turn_at_least: f64,
) -> bool {
    len_at_least > best_len + 2.0 * improvement_tolerance(best_len)
        || turn_at_least > best_turn + improvement_tolerance(best_turn)
}

/// Checks a world-frame request against the grid and turns it into a [`Problem`].
pub fn validate<'a>(grid: &'a PlanningGrid, query: &Query) -> Result<Problem<'a>, PlanError> {
    validate_with(grid, query, 0.0)
}

/// [`validate`], letting an occupied start move up to `start_tolerance` (m) to the nearest free
/// cell (the plan then starts at that cell's centre).
pub fn validate_with<'a>(
    grid: &'a PlanningGrid,
    query: &Query,
    start_tolerance: f64,
) -> Result<Problem<'a>, PlanError> {
    let finite = |p: Point2| p.x.is_finite() && p.y.is_finite();
    if !finite(query.start) {
        return Err(PlanError::InvalidInput(format!(
            "start ({}, {}) is not finite",
            query.start.x, query.start.y
        )));
    }
    if !finite(query.goal) {
        return Err(PlanError::InvalidInput(format!(
            "goal ({}, {}) is not finite",
            query.goal.x, query.goal.y
        )));
    }
    if !(query.tolerance.is_finite() && query.tolerance >= 0.0) {
        return Err(PlanError::InvalidInput(format!(
            "tolerance {} is not a finite non-negative distance",
            query.tolerance
        )));
    }
    let info = grid.info();
    let mut start_point = info.world_to_grid(query.start);
    let mut goal_point = info.world_to_grid(query.goal);
    let mut start = grid
        .cell_at(query.start)
        .ok_or(PlanError::StartOutsideMap(query.start))?;
    let mut goal = grid
        .cell_at(query.goal)
        .ok_or(PlanError::GoalOutsideMap(query.goal))?;
    if !grid.is_free(start) {
        let moved = (start_tolerance.is_finite() && start_tolerance > 0.0)
            .then(|| grid.nearest_free(start, start_tolerance / info.resolution))
            .flatten();
        start = moved.ok_or(PlanError::StartOccupied(query.start))?;
        start_point = start.center();
    }
    if !grid.is_free(goal) {
        let snapped = (query.tolerance > 0.0)
            .then(|| grid.nearest_free(goal, query.tolerance / info.resolution))
            .flatten();
        goal = snapped.ok_or(PlanError::GoalOccupied(query.goal))?;
        goal_point = goal.center();
    }
    Ok(Problem {
        grid,
        start,
        goal,
        start_point,
        goal_point,
    })
}

/// Pins a planner's polyline to the exact start and goal, optionally applies the delete operation,
/// drops collinear vertices and verifies it.
fn finish_path(
    grid: &PlanningGrid,
    problem: &Problem<'_>,
    mut points: Vec<Point2>,
    smoothing: bool,
) -> Result<Vec<Point2>, PlanError> {
    if points.is_empty() {
        return Err(PlanError::NoValidPath(
            "the planner returned an empty path".into(),
        ));
    }
    // Segments inside one cell are always free, so pinning the ends never adds a collision.
    let (first, last) = (points[0], points[points.len() - 1]);
    if Cell::containing(first) != problem.start || Cell::containing(last) != problem.goal {
        return Err(PlanError::NoValidPath(format!(
            "the planner's path runs from cell {:?} to {:?}, not from the start to the goal",
            Cell::containing(first),
            Cell::containing(last)
        )));
    }
    // Replace an end by the exact point where it still sees its neighbour, else add a short
    // in-cell segment.
    if first != problem.start_point {
        if points.len() >= 2 && line_of_sight(grid, problem.start_point, points[1]) {
            points[0] = problem.start_point;
        } else {
            points.insert(0, problem.start_point);
        }
    }
    if last != problem.goal_point {
        let n = points.len();
        if n >= 2 && line_of_sight(grid, points[n - 2], problem.goal_point) {
            points[n - 1] = problem.goal_point;
        } else {
            points.push(problem.goal_point);
        }
    }
    if smoothing {
        points = delete_redundant(grid, &points);
    }
    let points = drop_collinear(&points);
    if !path_is_free(grid, &points) {
        return Err(PlanError::NoValidPath(
            "the planner's path crosses an obstacle".into(),
        ));
    }
    Ok(points)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn metrics(length_m: f64, turning_rad: f64) -> (f64, f64) {
        (length_m, turning_rad)
    }

    /// Issue 12's rule: shorter or smoother, worse on neither; equal is not an improvement.
    #[test]
    fn improvement_on_the_seed_is_better_on_one_and_worse_on_neither() {
        let seed = metrics(10.0, 2.0);
        assert!(improves_on(seed, metrics(9.5, 2.0)));
        assert!(improves_on(seed, metrics(10.0, 1.0)));
        assert!(improves_on(seed, metrics(9.0, 1.0)));
        assert!(!improves_on(seed, metrics(10.0, 2.0)));
        assert!(
            !improves_on(seed, metrics(9.0, 2.5)),
            "shorter but turns more"
        );
        assert!(
            !improves_on(seed, metrics(10.5, 0.5)),
            "smoother but longer"
        );
        // Rounding noise is neither better nor worse.
        assert!(!improves_on(seed, metrics(10.0 + 1e-12, 2.0 - 1e-12)));
    }

    /// A downsampled grid's edge cells reach past the map (9 cells at factor 2 make 5): a goal
    /// there is outside the map, as it is at full resolution, not occupied or moved onto it.
    #[test]
    fn a_goal_past_a_downsampled_maps_edge_is_outside_the_map() {
        use crate::config::PlannerConfig;
        let fine = crate::test_support::grid_from_rows(&[".........", ".........", "........."]);
        let coarse = fine.downsampled(2).unwrap();
        assert_eq!(coarse.width(), 5);
        let astar = crate::registry::build(&PlannerConfig {
            planner: PlannerName::Astar,
            ..PlannerConfig::default()
        })
        .unwrap();
        for grid in [&fine, &coarse] {
            let mut rng = crate::test_support::rng(3);
            let mut ctx = PlanContext::never_interrupted(&mut rng);
            let query = Query {
                start: Point2::new(0.5, 0.5),
                goal: Point2::new(9.5, 0.5),
                tolerance: 3.0,
            };
            let answer = solve(
                astar.as_ref(),
                grid,
                &query,
                SolveOptions::default(),
                &mut ctx,
            );
            assert!(
                matches!(answer, Err(PlanError::GoalOutsideMap(_))),
                "{answer:?}"
            );
        }
    }

    /// A wall between start and goal: the plan through a via point above it goes there first,
    /// then on; the joined plan is the two legs end to end, measured as one path; one goal is
    /// `solve` itself; an occupied via point is refused as an occupied goal.
    #[test]
    fn a_plan_through_via_points_passes_each_in_order_and_is_measured_whole() {
        use crate::config::PlannerConfig;
        use crate::grid::metrics::measure;
        let grid = crate::test_support::grid_from_rows(&[
            "..........",
            "....#.....",
            "....#.....",
            "....#.....",
            "....#.....",
            "..........",
        ]);
        let config = PlannerConfig {
            planner: PlannerName::Astar,
            ..PlannerConfig::default()
        };
        let astar = crate::registry::build(&config).unwrap();
        let (start, via, goal) = (
            Point2::new(0.5, 2.5),
            Point2::new(4.5, 5.5),
            Point2::new(9.5, 2.5),
        );
        let through = |goals: &[Point2]| {
            let mut rng = crate::test_support::rng(3);
            let mut ctx = PlanContext::never_interrupted(&mut rng);
            solve_through(
                astar.as_ref(),
                &grid,
                start,
                goals,
                0.0,
                SolveOptions::default(),
                &mut ctx,
            )
        };
        let leg = |from: Point2, to: Point2| {
            let mut rng = crate::test_support::rng(3);
            let mut ctx = PlanContext::never_interrupted(&mut rng);
            let query = Query {
                start: from,
                goal: to,
                tolerance: 0.0,
            };
            solve(
                astar.as_ref(),
                &grid,
                &query,
                SolveOptions::default(),
                &mut ctx,
            )
            .unwrap()
        };
        let plan = through(&[via, goal]).unwrap();
        assert_eq!(plan.via, vec![via]);
        let at = plan
            .waypoints
            .iter()
            .position(|&p| p == via)
            .expect("passes the via point");
        assert_eq!(plan.waypoints[0], start);
        assert_eq!(*plan.waypoints.last().unwrap(), goal);
        assert_eq!(plan.goal, goal);
        // The legs end to end, the via point once.
        let (first, second) = (leg(start, via), leg(via, goal));
        assert_eq!(plan.waypoints[..=at], first.waypoints[..]);
        assert_eq!(plan.waypoints[at..], second.waypoints[..]);
        // Measured as one path (1 m cells at the origin: world is grid), the turn at the via
        // point included.
        let whole = measure(&grid, &plan.waypoints);
        let m = &plan.metrics;
        let close = |a: f64, b: f64| (a - b).abs() < 1e-9 * (1.0 + b.abs());
        assert!(close(m.length_m, whole.length_m), "{m:?} {whole:?}");
        assert!(close(m.turning_rad, whole.turning_rad), "{m:?} {whole:?}");
        assert_eq!(m.turns, whole.turns);
        assert!(close(m.min_clearance_m, whole.min_clearance_m));
        assert!(
            close(m.mean_clearance_m, whole.mean_clearance_m),
            "{m:?} {whole:?}"
        );
        assert!(close(m.path_cost, whole.path_cost));
        assert!(m.collision_free);
        assert!(
            m.length_m > leg(start, goal).metrics.length_m,
            "the detour to the via point"
        );
        // One goal: `solve` itself.
        let direct = through(&[goal]).unwrap();
        assert_eq!(direct.waypoints, leg(start, goal).waypoints);
        assert!(direct.via.is_empty());
        // An occupied via point, as an occupied goal; no goal at all, as invalid input.
        let wall = Point2::new(4.5, 2.5);
        assert_eq!(
            through(&[wall, goal]).unwrap_err(),
            PlanError::GoalOccupied(wall)
        );
        assert!(matches!(through(&[]), Err(PlanError::InvalidInput(_))));
    }
}
