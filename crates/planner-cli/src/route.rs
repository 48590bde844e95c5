//! `patrol-plan route`: the visiting order of a patrol route's inspection points and the legs
//! between them (planner-core's `route` module), as one JSON object and optionally a picture.

use crate::render::{Drawing, Layer, Stop};
use crate::run::{load_config, Workspace};
use crate::Common;
use anyhow::{Context, Result};
use planner_core::geometry::Point2;
use planner_core::planner::{PlanError, Query};
use planner_core::route::{plan_route, RouteFile, RouteOptions, RoutePlan, START_NAME};
use planner_core::PlannerName;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(clap::Args)]
pub struct RouteArgs {
    /// Map: map_server YAML, or a Moving AI `.map` (read with 1 m cells).
    #[arg(long)]
    map: PathBuf,
    /// Route file (YAML): `points: [{name, x, y, yaw, dwell}, ...]` in map metres, radians and
    /// seconds; optional `start: {x, y, yaw}` (default: the first point) and `home: NAME`.
    #[arg(long, required_unless_present = "random_routes")]
    points: Option<PathBuf>,
    /// Instead of a route file: draw this many random routes on the map (`--route-points` points
    /// each, connected to a random start, no dwell) and report how much time the optimised order
    /// saves against the order drawn, per route and on average.
    #[arg(long, conflicts_with = "points", value_parser = clap::value_parser!(u32).range(1..=100_000))]
    random_routes: Option<u32>,
    /// Points per random route.
    #[arg(long, default_value_t = 10, requires = "random_routes")]
    route_points: usize,
    /// The seed of the random routes.
    #[arg(long, default_value_t = 33, requires = "random_routes")]
    random_seed: u64,
    /// The planner of the chosen legs (`patrol-plan planners` lists them); the order itself comes
    /// from string-pulled grid paths. Each leg is planned with the config's `seed` (else 0).
    #[arg(long, default_value = "any_angle")]
    planner: PlannerName,
    /// A closed loop: end back at the start.
    #[arg(long = "loop")]
    closed: bool,
    /// End at this point (an open route); replaces the file's `home`.
    #[arg(long, conflicts_with = "closed")]
    home: Option<String>,
    /// Also draw the map, every leg and the numbered points.
    #[arg(long)]
    svg: Option<PathBuf>,
    #[command(flatten)]
    common: Common,
}

#[derive(Serialize)]
struct RouteOutput<'a> {
    planner: PlannerName,
    /// Wall time of the whole command's planning: leg matrix, order and legs (ms).
    time_ms: f64,
    #[serde(flatten)]
    plan: &'a RoutePlan,
}

fn read_route(path: &Path) -> Result<RouteFile> {
    let bytes = planner_io::read(path)?;
    RouteFile::parse(&bytes).with_context(|| path.display().to_string())
}

/// One random route's figures.
#[derive(Serialize)]
struct RandomRoute {
    method: planner_core::route::OrderMethod,
    total_time_s: f64,
    given_order_time_s: f64,
    total_length_m: f64,
    given_order_length_m: f64,
    skipped: usize,
}

/// `--random-routes`: the optimised order against the drawn one on random routes (legs from the
/// leg matrix's string-pulled grid paths, as the order itself is chosen).
fn random_routes(args: &RouteArgs, n: usize) -> Result<()> {
    use planner_core::planner::PlannerRng;
    use planner_core::sampling::random_route;
    use rand::SeedableRng;
    let config = load_config(args.common.config.as_deref())?;
    let ws = Workspace::load(&args.map, config)?;
    let options = RouteOptions {
        closed: args.closed,
        ..RouteOptions::default()
    };
    let mut rng = PlannerRng::seed_from_u64(args.random_seed);
    let t0 = Instant::now();
    let mut routes = Vec::with_capacity(n);
    for k in 0..n {
        let route = random_route(&ws.grid, args.route_points, &mut rng)
            .with_context(|| format!("drawing random route {k} on {}", args.map.display()))?;
        let plan = plan_route(&ws.grid, &route, &options, None)
            .with_context(|| format!("planning random route {k}"))?;
        routes.push(RandomRoute {
            method: plan.method,
            total_time_s: plan.total_time_s,
            given_order_time_s: plan.given_order_time_s,
            total_length_m: plan.total_length_m,
            given_order_length_m: plan.given_order_length_m,
            skipped: plan.skipped.len(),
        });
    }
    let mean =
        |f: &dyn Fn(&RandomRoute) -> f64| routes.iter().map(f).sum::<f64>() / n.max(1) as f64;
    let out = serde_json::json!({
        "map": args.map.display().to_string(),
        "routes": n,
        "points_per_route": args.route_points,
        "random_seed": args.random_seed,
        "closed": args.closed,
        "time_ms": t0.elapsed().as_secs_f64() * 1e3,
        "mean_total_time_s": mean(&|r| r.total_time_s),
        "mean_given_order_time_s": mean(&|r| r.given_order_time_s),
        "mean_saving_s": mean(&|r| r.given_order_time_s - r.total_time_s),
        "mean_saving_share": mean(&|r| 1.0 - r.total_time_s / r.given_order_time_s),
        "worst_saving_share": routes
            .iter()
            .map(|r| 1.0 - r.total_time_s / r.given_order_time_s)
            .fold(f64::INFINITY, f64::min),
        "per_route": routes,
    });
    out!("{}", serde_json::to_string(&out)?);
    Ok(())
}

pub fn run(args: &RouteArgs) -> Result<()> {
    if let Some(n) = args.random_routes {
        return random_routes(args, n as usize);
    }
    let config = load_config(args.common.config.as_deref())?;
    let seed = config.seed.unwrap_or(0);
    let points = args.points.as_ref().expect("clap requires --points here");
    let mut route = read_route(points)?;
    if args.home.is_some() {
        route.home.clone_from(&args.home);
    }
    let ws = Workspace::load(&args.map, config)?;
    let options = RouteOptions {
        closed: args.closed,
        ..RouteOptions::default()
    };
    // Each leg through the same path as `plan` (the config's time budget, smoothing and seed),
    // exactly from point to point. A leg the time budget cut short keeps its planner's best
    // path so far (any_angle's: the string-pulled A* path), and the route's notes say which.
    let mut cut_short = Vec::new();
    let mut legs = |from: Point2, to: Point2| -> Result<Vec<Point2>, PlanError> {
        let query = Query {
            start: from,
            goal: to,
            tolerance: 0.0,
        };
        let (result, _) = ws
            .run(args.planner, &query, seed)
            .map_err(|e| PlanError::InvalidInput(format!("{e:#}")))?;
        let plan = result?;
        if plan.stats.cut_short {
            cut_short.push(format!(
                "leg ({:.2}, {:.2}) - ({:.2}, {:.2}): {} was cut short by the time budget; its \
                 best path so far is used",
                from.x, from.y, to.x, to.y, args.planner
            ));
        }
        Ok(plan.waypoints)
    };
    let t0 = Instant::now();
    let mut plan = plan_route(&ws.grid, &route, &options, Some(&mut legs))
        .with_context(|| format!("planning the route of {}", points.display()))?;
    plan.notes.extend(cut_short);
    let out = RouteOutput {
        planner: args.planner,
        time_ms: t0.elapsed().as_secs_f64() * 1e3,
        plan: &plan,
    };
    out!("{}", serde_json::to_string(&out)?);
    for note in &plan.notes {
        eprintln!("note: {note}");
    }
    if let Some(svg) = &args.svg {
        std::fs::write(svg, draw(&ws, &route, &plan).to_svg())
            .with_context(|| format!("writing {}", svg.display()))?;
    }
    Ok(())
}

/// The map, every leg in visiting order, the points numbered in that order (the start pose as
/// `S`), and the skipped ones crossed out.
fn draw<'a>(ws: &'a Workspace, route: &RouteFile, plan: &RoutePlan) -> Drawing<'a> {
    let mut drawing = Drawing::new(&ws.map, &ws.grid, &ws.config);
    for (k, leg) in plan.legs.iter().enumerate() {
        let label = format!(
            "{}. {} -> {} ({:.1} s)",
            k + 1,
            leg.from,
            leg.to,
            leg.time_s
        );
        drawing.add(Layer::path(&label, &leg.waypoints));
    }
    let mut stops = Vec::new();
    if let Some(s) = route.start {
        stops.push(Stop {
            position: Point2::new(s.x, s.y),
            yaw: s.yaw,
            label: "S".into(),
            title: START_NAME.into(),
            skipped: false,
        });
    }
    for p in &route.points {
        let position = Point2::new(p.x, p.y);
        if let Some(k) = plan.order.iter().position(|name| *name == p.name) {
            stops.push(Stop {
                position,
                yaw: p.yaw,
                label: (k + 1).to_string(),
                title: format!("{}. {} (dwell {} s)", k + 1, p.name, p.dwell),
                skipped: false,
            });
        } else if let Some(s) = plan.skipped.iter().find(|s| s.name == p.name) {
            stops.push(Stop {
                position,
                yaw: p.yaw,
                label: String::new(),
                title: format!("{} {}", s.name, s.reason),
                skipped: true,
            });
        }
    }
    drawing.add(Layer::Stops(stops));
    drawing
}
