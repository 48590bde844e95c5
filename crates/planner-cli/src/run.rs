//! Loading a map into a planning grid and running a planner on it, timed: what `plan`, `render`
//! and `bench` share.

use crate::render::{Drawing, Layer};
use anyhow::{bail, Context, Result};
use planner_core::config::PlannerConfig;
use planner_core::geometry::Point2;
use planner_core::grid::inflation::{planning_grid, PlanningGrid};
use planner_core::grid::GridMap;
use planner_core::planner::{
    Interrupt, Plan, PlanContext, PlanError, PlannerRng, Query, Termination,
};
use planner_core::{registry, PlannerName};
use planner_io::result_code::ResultCode;
use rand::SeedableRng;
use serde::Serialize;
use std::borrow::Cow;
use std::path::Path;
use std::time::{Duration, Instant};

/// The config file's planning parameters, or the defaults.
pub fn load_config(path: Option<&Path>) -> Result<PlannerConfig> {
    Ok(match path {
        Some(p) => {
            let file = planner_io::parameters::load_parameter_file(p)?;
            for w in &file.warnings {
                eprintln!("warning: {w}");
            }
            file.planning
        }
        None => PlannerConfig::default(),
    })
}

/// How long the any-angle reference may take (s), or the config's budget if that is longer (or
/// none if the config has none): on a maze of rooms 1 200 cells wide its graph search takes
/// seconds.
pub const REFERENCE_TIME: f64 = 60.0;

/// A loaded map and its planning grid.
pub struct Workspace {
    pub map: GridMap,
    pub grid: PlanningGrid,
    pub config: PlannerConfig,
}

impl Workspace {
    pub fn load(map_path: &Path, config: PlannerConfig) -> Result<Self> {
        Self::load_under(map_path, None, config)
    }

    /// [`Workspace::load`] with a keepout mask (a map_server YAML, in the map's frame) laid
    /// over the grid as the node lays `keepout_mask_topic`'s.
    pub fn load_under(
        map_path: &Path,
        keepout: Option<&Path>,
        config: PlannerConfig,
    ) -> Result<Self> {
        let map = planner_io::load_map(map_path)?;
        let mask = keepout.map(planner_io::load_map_server).transpose()?;
        Self::new_under(map, mask.as_ref(), config)
    }

    /// The planning grid of `map` with the `keepout` mask, if any, laid over it (Nav2's keepout
    /// filter: `PlanningGrid::with_keepout`), downsampled by `costmap.downsampling_factor` after
    /// it is inflated (then `map` is the downsampled map, cell for cell the grid's).
    pub fn new_under(
        map: GridMap,
        keepout: Option<&GridMap>,
        config: PlannerConfig,
    ) -> Result<Self> {
        let (coarse, grid) = match planning_grid(&map, &config.costmap, false, keepout)? {
            (Cow::Owned(coarse), grid) => (Some(coarse), grid),
            (Cow::Borrowed(_), grid) => (None, grid),
        };
        let map = coarse.unwrap_or(map);
        Ok(Self { map, grid, config })
    }

    pub fn query(&self, start: [f64; 2], goal: [f64; 2]) -> Query {
        Query {
            start: Point2::new(start[0], start[1]),
            goal: Point2::new(goal[0], goal[1]),
            tolerance: self.config.tolerance,
        }
    }

    /// Runs one planner once, honouring the config's time budget; returns the result and the
    /// wall time of the whole request (validation, planning, post-processing, metrics).
    pub fn run(
        &self,
        planner: PlannerName,
        query: &Query,
        seed: u64,
    ) -> Result<(Result<Plan, PlanError>, Duration)> {
        self.run_through(planner, query, &[], seed)
    }

    /// [`Workspace::run`] through the points `via`, in order, before the query's goal, as
    /// ComputePathThroughPoses plans (`solve_through`); with none, [`Workspace::run`].
    pub fn run_through(
        &self,
        planner: PlannerName,
        query: &Query,
        via: &[Point2],
        seed: u64,
    ) -> Result<(Result<Plan, PlanError>, Duration)> {
        self.run_within(planner, query, via, seed, self.config.max_planning_time)
    }

    /// The any-angle reference every length ratio divides by (through `via`, if any): exact or
    /// nothing. It gets [`REFERENCE_TIME`] (a measurement, not a robot waiting), and an answer
    /// the deadline cut short (the string-pulled A* path, not the optimum) is no reference.
    pub fn reference(&self, query: &Query, via: &[Point2]) -> Result<Option<Plan>> {
        let own = self.config.max_planning_time;
        let budget = if own == 0.0 {
            0.0
        } else {
            REFERENCE_TIME.max(own)
        };
        let (result, _) = self.run_within(PlannerName::AnyAngle, query, via, 0, budget)?;
        Ok(result.ok().filter(|p| !p.stats.cut_short))
    }

    /// [`Workspace::run_through`] with a time budget of `budget` s (0: none) for each leg, as
    /// the node gives each leg its `max_planning_time`.
    fn run_within(
        &self,
        planner: PlannerName,
        query: &Query,
        via: &[Point2],
        seed: u64,
        budget: f64,
    ) -> Result<(Result<Plan, PlanError>, Duration)> {
        let p = registry::build(&PlannerConfig {
            planner,
            ..self.config.clone()
        })?;
        let mut rng = PlannerRng::seed_from_u64(seed);
        let t0 = Instant::now();
        let leg_started = std::cell::Cell::new(t0);
        let interrupt = || {
            (budget > 0.0 && leg_started.get().elapsed() >= Duration::from_secs_f64(budget))
                .then_some(Interrupt::Deadline)
        };
        let on_leg = || leg_started.set(Instant::now());
        let mut ctx = PlanContext::new(&mut rng, &interrupt);
        ctx.on_leg = Some(&on_leg);
        let options = self.config.solve_options();
        let goals: Vec<Point2> = via.iter().copied().chain([query.goal]).collect();
        let result = planner_core::solve_through(
            p.as_ref(),
            &self.grid,
            query.start,
            &goals,
            query.tolerance,
            options,
            &mut ctx,
        );
        Ok((result, t0.elapsed()))
    }
}

#[derive(Serialize)]
struct PlanOutput<'a> {
    planner: PlannerName,
    seed: u64,
    length_m: f64,
    turning_rad: f64,
    turns: usize,
    min_clearance_m: f64,
    /// Clearance averaged over the path's length (m).
    mean_clearance_m: f64,
    /// The costmap cost integrated along the path (m).
    path_cost: f64,
    /// The half-width of the corridors the path runs through, averaged over its length (m).
    corridor_half_width_m: f64,
    collision_free: bool,
    time_ms: f64,
    reference_length_m: Option<f64>,
    goal: [f64; 2],
    /// Where the path passes each via point (the point, or the free cell it was moved to);
    /// absent without via points.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    via: Vec<[f64; 2]>,
    iterations: u64,
    evaluations: u64,
    cut_short: bool,
    /// Why the run stopped: completed, max_iterations, converged, deadline or cancelled.
    termination: Option<Termination>,
    best_iteration: Option<u64>,
    counters: &'a std::collections::BTreeMap<String, f64>,
    notes: &'a [String],
    /// Best objective value after each iteration.
    convergence: &'a [f64],
    /// The Pareto front (multi-objective planners): each member's length and turning.
    pareto: Vec<[f64; 2]>,
    waypoints: Vec<[f64; 2]>,
}

/// Points given as `[x, y]` (map metres).
fn points(given: &[[f64; 2]]) -> Vec<Point2> {
    given.iter().map(|&[x, y]| Point2::new(x, y)).collect()
}

/// What `plan` prints when the planner cannot answer: Nav2's ComputePathToPose result fields.
#[derive(Serialize)]
struct FailureOutput {
    planner: PlannerName,
    seed: u64,
    error_code: u16,
    error_name: &'static str,
    error_msg: String,
}

/// A failed plan as one line: its Nav2 code, number and reason, e.g.
/// `GOAL_OCCUPIED (206): goal (5.5, 5.5) is in an obstacle ...`.
pub fn failure_line(e: &PlanError) -> String {
    let code = ResultCode::from(e);
    format!("{} ({}): {e}", code.name(), code.number())
}

/// `patrol-plan plan`: one plan from `start` through each of `via` in order to `goal`.
#[allow(clippy::too_many_arguments)]
pub fn plan_command(
    map_path: &Path,
    keepout: Option<&Path>,
    start: [f64; 2],
    via: &[[f64; 2]],
    goal: [f64; 2],
    planner: Option<PlannerName>,
    seed: Option<u64>,
    svg: Option<&Path>,
    config: Option<&Path>,
) -> Result<()> {
    let config = load_config(config)?;
    let planner = planner.unwrap_or(config.planner);
    let seed = seed.or(config.seed).unwrap_or(0);
    let ws = Workspace::load_under(map_path, keepout, config)?;
    let query = ws.query(start, goal);
    let via = points(via);
    let (result, elapsed) = ws.run_through(planner, &query, &via, seed)?;
    let plan = match result {
        Ok(plan) => plan,
        Err(e) => {
            // As a Nav2 action result says it: the code and the reason, also on stdout as JSON,
            // so a script reading the plan's JSON reads the failure's too.
            let code = ResultCode::from(&e);
            let out = FailureOutput {
                planner,
                seed,
                error_code: code.number(),
                error_name: code.name(),
                error_msg: e.to_string(),
            };
            out!("{}", serde_json::to_string(&out)?);
            let through = match via.len() {
                0 => String::new(),
                1 => " through 1 via point".into(),
                n => format!(" through {n} via points"),
            };
            bail!(
                "{planner} could not plan from {start:?} to {goal:?}{through}: {}",
                failure_line(&e)
            );
        }
    };
    let reference = ws.reference(&query, &via)?;
    let out = PlanOutput {
        planner: plan.planner,
        seed,
        length_m: plan.metrics.length_m,
        turning_rad: plan.metrics.turning_rad,
        turns: plan.metrics.turns,
        min_clearance_m: plan.metrics.min_clearance_m,
        mean_clearance_m: plan.metrics.mean_clearance_m,
        path_cost: plan.metrics.path_cost,
        corridor_half_width_m: plan.metrics.corridor_half_width_m,
        collision_free: plan.metrics.collision_free,
        time_ms: elapsed.as_secs_f64() * 1e3,
        reference_length_m: reference.as_ref().map(|r| r.metrics.length_m),
        goal: [plan.goal.x, plan.goal.y],
        via: plan.via.iter().map(|p| [p.x, p.y]).collect(),
        iterations: plan.stats.iterations,
        evaluations: plan.stats.evaluations,
        cut_short: plan.stats.cut_short,
        termination: plan.stats.termination,
        best_iteration: plan.stats.best_iteration,
        counters: &plan.stats.counters,
        notes: &plan.stats.notes,
        convergence: &plan.stats.convergence,
        pareto: plan
            .pareto
            .iter()
            .map(|m| [m.f1_length_m, m.f2_turning_rad])
            .collect(),
        waypoints: plan.waypoints.iter().map(|p| [p.x, p.y]).collect(),
    };
    out!("{}", serde_json::to_string(&out)?);
    if let Some(svg) = svg {
        let mut drawing = Drawing::new(&ws.map, &ws.grid, &ws.config);
        if let Some(r) = &reference {
            drawing.add(Layer::path("any_angle (reference)", &r.waypoints));
        }
        drawing.add(Layer::path(plan.planner.as_str(), &plan.waypoints));
        drawing.add(Layer::endpoints(query.start, plan.goal));
        if !plan.via.is_empty() {
            drawing.add(Layer::via(&plan.via));
        }
        if !plan.pareto.is_empty() {
            let front: Vec<[f64; 3]> = plan
                .pareto
                .iter()
                .map(|m| [m.f1_length_m, m.f2_turning_rad, m.f3_safety])
                .collect();
            // The chosen member: the front's point nearest the plan's length and turning (its
            // safety value is the objective's, not the metric's).
            let (l, t) = (plan.metrics.length_m, plan.metrics.turning_rad);
            let chosen = front
                .iter()
                .copied()
                .min_by(|a, b| {
                    ((a[0] - l).abs() + (a[1] - t).abs())
                        .total_cmp(&((b[0] - l).abs() + (b[1] - t).abs()))
                })
                .unwrap_or([l, t, 0.0]);
            drawing.add(Layer::Pareto { front, chosen });
        }
        std::fs::write(svg, drawing.to_svg())
            .with_context(|| format!("writing {}", svg.display()))?;
    }
    Ok(())
}

/// `patrol-plan render`: each planner's plan from `start` through each of `via` to `goal`,
/// drawn on one map.
#[allow(clippy::too_many_arguments)]
pub fn render_command(
    map_path: &Path,
    keepout: Option<&Path>,
    start: [f64; 2],
    via: &[[f64; 2]],
    goal: [f64; 2],
    planners: &[PlannerName],
    seed: u64,
    out: &Path,
    config: Option<&Path>,
) -> Result<()> {
    let ws = Workspace::load_under(map_path, keepout, load_config(config)?)?;
    let query = ws.query(start, goal);
    let via = points(via);
    let mut drawing = Drawing::new(&ws.map, &ws.grid, &ws.config);
    let mut answered = 0;
    for name in planners {
        match ws.run_through(*name, &query, &via, seed)?.0 {
            Ok(plan) => {
                answered += 1;
                eprintln!(
                    "{name}: {:.3} m, {:.3} rad, {} turns, collision-free: {}",
                    plan.metrics.length_m,
                    plan.metrics.turning_rad,
                    plan.metrics.turns,
                    plan.metrics.collision_free
                );
                drawing.add(Layer::path(name.as_str(), &plan.waypoints));
            }
            Err(e) => eprintln!("{name}: {}", failure_line(&e)),
        }
    }
    drawing.add(Layer::endpoints(query.start, query.goal));
    if !via.is_empty() {
        drawing.add(Layer::via(&via));
    }
    std::fs::write(out, drawing.to_svg()).with_context(|| format!("writing {}", out.display()))?;
    eprintln!("wrote {}", out.display());
    // The drawing still shows the map and the query, which is often why; but the command failed.
    if answered == 0 {
        bail!("no planner answered (the reasons are above)");
    }
    Ok(())
}
