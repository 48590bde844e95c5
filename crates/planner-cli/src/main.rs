//! `patrol-plan`: run patrol-planner's planners from the command line — one plan, a benchmark
//! table, a picture, or a check of A* against the Moving AI benchmarks' optimal lengths.

/// `println!` for what the command prints: a failed write (a full disk) is an error that says
/// so, not a panic. A closed pipe still ends the process quietly (SIGPIPE, see `main`).
macro_rules! out {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        writeln!(std::io::stdout().lock(), $($arg)*)
            .map_err(|e| anyhow::anyhow!("writing standard output: {e}"))?
    }};
}

mod bench;
mod movingai;
mod render;
mod route;
mod run;

use anyhow::Result;
use clap::{Parser, Subcommand};
use std::path::PathBuf;

#[derive(Parser)]
#[command(name = "patrol-plan", version, about = "Plan, benchmark and draw patrol-planner's global planners", long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

/// A point `X,Y` in map metres.
fn parse_point(s: &str) -> Result<[f64; 2], String> {
    let (x, y) = s.split_once(',').ok_or("expected X,Y")?;
    let p = |v: &str| v.trim().parse::<f64>().map_err(|e| format!("`{v}`: {e}"));
    let pt = [p(x)?, p(y)?];
    if pt.iter().all(|v| v.is_finite()) {
        Ok(pt)
    } else {
        Err("coordinates must be finite".into())
    }
}

#[derive(clap::Args, Clone)]
struct Common {
    /// Parameter file in the node's layout (`patrol_planner: ros__parameters:`); its planning
    /// keys (costmap, tolerance, planner sections) apply. Default: built-in defaults.
    #[arg(long)]
    config: Option<PathBuf>,
}

/// One planning request on one map: what `plan` and `render` share.
#[derive(clap::Args, Clone)]
struct Request {
    /// Map: map_server YAML, or a Moving AI `.map` (read with 1 m cells).
    #[arg(long)]
    map: PathBuf,
    /// Start `X,Y` in map metres.
    #[arg(long, value_parser = parse_point, allow_hyphen_values = true)]
    start: [f64; 2],
    /// Goal `X,Y` in map metres.
    #[arg(long, value_parser = parse_point, allow_hyphen_values = true)]
    goal: [f64; 2],
    /// A via point `X,Y` in map metres, passed before the goal; repeat it for more, passed in
    /// the order given (one plan through them all, as Nav2's ComputePathThroughPoses).
    #[arg(long = "via", value_name = "X,Y", value_parser = parse_point, allow_hyphen_values = true)]
    via: Vec<[f64; 2]>,
    /// A keepout mask (map_server YAML, in the map's frame), laid over the planning grid as the
    /// node lays `keepout_mask_topic`'s (Nav2's keepout filter): black keeps the robot out,
    /// grey costs.
    #[arg(long)]
    keepout: Option<PathBuf>,
    #[command(flatten)]
    common: Common,
}

#[derive(Subcommand)]
enum Command {
    /// Plan one path and print it as one JSON object (planner, seed, length_m, turning_rad, turns,
    /// min_clearance_m, collision_free, time_ms, reference_length_m, termination, waypoints, ...).
    /// When the planner cannot answer: an object with error_code, error_name and error_msg (Nav2
    /// ComputePathToPose's codes, e.g. 206 GOAL_OCCUPIED, 208 NO_VALID_PATH) and exit status 1.
    Plan {
        #[command(flatten)]
        request: Request,
        /// Planner name (default: the config's `planner`, else mocmcso). `patrol-plan planners`
        /// lists them.
        #[arg(long)]
        planner: Option<planner_core::PlannerName>,
        /// RNG seed (default: the config's `seed`, else 0). The node logs the seed of every plan so
        /// it can be replayed here.
        #[arg(long)]
        seed: Option<u64>,
        /// Also draw the map, the inflated area, the path, the any-angle reference, start and goal.
        #[arg(long)]
        svg: Option<PathBuf>,
    },
    /// Run A* on every scenario of a Moving AI `.scen` and compare each length with the recorded
    /// optimum (to the file's printed precision). Ends with `N passed, M failed`; exits 1 on any
    /// failure.
    Movingai {
        #[arg(long)]
        map: PathBuf,
        #[arg(long)]
        scen: PathBuf,
        /// Check at most N scenarios, evenly spaced from the shortest optimal length to the
        /// longest (so every length bucket keeps its share, both ends included); all of them
        /// when unset.
        #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
        sample: Option<u32>,
    },
    /// Run each planner R times (seeds 0..R-1) on every scenario of the given bench scenario files
    /// and write a table: one row per map x scenario x planner, lengths also as ratios to the
    /// any-angle reference and times as ratios to A* measured in the same run.
    Bench(bench::BenchArgs),
    /// Draw a map with the paths of several planners as SVG, so a person can check them by eye.
    Render {
        #[command(flatten)]
        request: Request,
        /// Comma-separated planner names, each drawn in its own colour.
        #[arg(long, value_delimiter = ',', default_value = "astar,any_angle")]
        planners: Vec<planner_core::PlannerName>,
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Output SVG file.
        #[arg(long)]
        out: PathBuf,
    },
    /// Order a patrol route's inspection points for the least driving time (turning in place
    /// included) and plan every leg; print one JSON object (order, legs, total_length_m,
    /// total_time_s, given_order_length_m, given_order_time_s, skipped, notes, ...).
    Route(route::RouteArgs),
    /// List the planner names.
    Planners,
}

fn main() {
    // Output piped into a reader that stops early (`patrol-plan plan ... | head`): end quietly as
    // Unix tools do, instead of panicking on the broken pipe in println!.
    #[cfg(unix)]
    // SAFETY: restoring the default disposition of one signal before any thread starts.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    // Errors are for users: one line of causes, no backtrace (even with RUST_BACKTRACE set).
    if let Err(e) = run(Cli::parse()) {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Plan {
            request: r,
            planner,
            seed,
            svg,
        } => run::plan_command(
            &r.map,
            r.keepout.as_deref(),
            r.start,
            &r.via,
            r.goal,
            planner,
            seed,
            svg.as_deref(),
            r.common.config.as_deref(),
        ),
        Command::Movingai { map, scen, sample } => {
            let failed = movingai::run(&map, &scen, sample.map(|n| n as usize))?;
            std::process::exit(if failed > 0 { 1 } else { 0 })
        }
        Command::Bench(args) => bench::run(&args),
        Command::Render {
            request: r,
            planners,
            seed,
            out,
        } => run::render_command(
            &r.map,
            r.keepout.as_deref(),
            r.start,
            &r.via,
            r.goal,
            &planners,
            seed,
            &out,
            r.common.config.as_deref(),
        ),
        Command::Route(args) => route::run(&args),
        Command::Planners => {
            for name in planner_core::PlannerName::ALL {
                out!("{name}");
            }
            Ok(())
        }
    }
}
