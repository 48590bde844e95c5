//! `patrol-plan bench`: every planner, R seeds, every scenario; one row per map x scenario x
//! planner. Lengths are also reported as ratios to the any-angle reference and times as ratios to
//! A*'s median on the same query in the same run, so figures from different machines compare.
//!
//! The queries come from scenario files, or (`--map M --random N --random-seed S`) are drawn on
//! any map the way Nav2's planner benchmark draws them (`planner_core::sampling`); a pair
//! with no path is kept and marked (`astar_found_path: false`), and a summary per map and
//! planner counts how each planner answered the solvable and the unsolvable ones.

use crate::run::{load_config, Workspace};
use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use planner_core::planner::PlannerRng;
use planner_core::sampling::{random_queries, QuerySampling};
use planner_core::swarm::pareto::hypervolume_2d;
use planner_core::PlannerName;
use planner_io::result_code::ResultCode;
use rand::SeedableRng;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::PathBuf;

/// `patrol-plan bench`'s arguments.
#[derive(clap::Args)]
pub struct BenchArgs {
    /// `*.scen.yaml` files (e.g. ../shared/maps/bench/datacenter_100.scen.yaml).
    #[arg(long, num_args = 1.., required_unless_present = "random")]
    pub scenarios: Vec<PathBuf>,
    /// Draw this many start/goal pairs on each `--map` instead of reading scenario files: free
    /// cells with a cost below 210, 5 % of the map away from its border, more than 3 m apart
    /// (Nav2's planner benchmark rules).
    #[arg(long, requires = "map", conflicts_with_all = ["scenarios", "only"],
          value_parser = clap::value_parser!(u32).range(1..=10_000))]
    pub random: Option<u32>,
    /// The seed of those draws.
    #[arg(long, default_value_t = 33, requires = "random")]
    pub random_seed: u64,
    /// Maps (map_server YAML or Moving AI `.map`) for `--random`.
    #[arg(long, num_args = 1.., requires = "random")]
    pub map: Vec<PathBuf>,
    /// Comma-separated planner names (`patrol-plan planners` lists them).
    #[arg(long, value_delimiter = ',', default_value = "astar,any_angle")]
    pub planners: Vec<PlannerName>,
    /// Runs per planner and scenario (seeds 0..runs-1).
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u64).range(1..=1_000))]
    pub runs: u64,
    /// Only these scenario names (comma-separated); default all.
    #[arg(long, value_delimiter = ',')]
    pub only: Vec<String>,
    /// Write the rows as a JSON array here (default: print JSON to stdout).
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write the same table as Markdown here.
    #[arg(long)]
    pub markdown: Option<PathBuf>,
    /// Parameter file in the node's layout (`patrol_planner: ros__parameters:`).
    #[arg(long)]
    pub config: Option<PathBuf>,
}

#[derive(Serialize, Debug, Clone)]
pub struct Row {
    pub map: String,
    pub scenario: String,
    /// The query's start and goal (map metres): `patrol-plan plan --start X,Y --goal X,Y`
    /// replays any row, a drawn (`--random`) one included.
    pub start: [f64; 2],
    pub goal: [f64; 2],
    pub planner: PlannerName,
    pub runs: u64,
    pub successes: u64,
    /// Successful runs whose path passed the collision check.
    pub collision_free: u64,
    pub length_m_best: Option<f64>,
    pub length_m_mean: Option<f64>,
    /// Mean length / any-angle reference length.
    pub length_ratio_mean: Option<f64>,
    pub turning_rad_best: Option<f64>,
    pub turning_rad_mean: Option<f64>,
    pub turns_mean: Option<f64>,
    pub min_clearance_m_mean: Option<f64>,
    /// Mean over runs of the clearance averaged along each path (m).
    pub mean_clearance_m_mean: Option<f64>,
    /// Mean over runs of the costmap cost integrated along each path (m).
    pub path_cost_mean: Option<f64>,
    /// Mean over runs of the half-width of the corridors each path runs through (m): the most
    /// mean clearance a path along them can have.
    pub corridor_half_width_m_mean: Option<f64>,
    pub time_ms_median: f64,
    /// This planner's median time / A*'s median time on the same query, in this run.
    pub time_vs_astar: Option<f64>,
    pub iterations_mean: Option<f64>,
    /// Mean iteration at which the best value last improved (population methods).
    pub best_iteration_mean: Option<f64>,
    pub reference_length_m: Option<f64>,
    /// False only where A* (seed 0) answered the query itself, with NO_VALID_PATH or a refusal
    /// of its start or goal (off the map, on an obstacle): there every planner should too.
    pub astar_found_path: bool,
    /// That answer of A*'s (`NO_VALID_PATH (208): ...`), when it gave one.
    pub astar_failure: Option<String>,
    /// With that answer: how many runs gave the same code.
    pub answered_as_astar: Option<u64>,
    /// Runs whose answer is better than the planner's seed path: shorter or smoother, worse on
    /// neither, both finished alike (counter `improved_on_seed`, from the planners that start
    /// from a seed).
    pub improved_on_seed: Option<u64>,
    /// Runs whose seed was already the straight segment from start to goal (counter
    /// `seed_straight`): nothing improves on those, so they are the misses no search can avoid.
    pub seed_straight: Option<u64>,
    /// Runs whose potential field (the path of `apf`/`eapf`, the seed of the others) could not
    /// reach the goal by its own descent, so that A* stood in (counter `apf_fallback`).
    pub apf_fallbacks: u64,
    /// How the successful runs ended, e.g. `max_iterations x3, converged x2`.
    pub terminations: String,
    /// Median over runs of the hypervolume of the planner's final front (planners that return
    /// one): see [`HV_REFERENCE`].
    pub hypervolume_median: Option<f64>,
    /// The first failure's Nav2 code and reason (`NO_VALID_PATH (208): ...`), when a run failed.
    pub failure: Option<String>,
}

/// "improved/runs", and how many of the runs had a seed that was already the straight segment
/// (which no answer improves on), when any had.
fn improved_cell(improved: u64, runs: u64, straight: u64) -> String {
    if straight > 0 {
        format!("{improved}/{runs} ({straight} seed straight)")
    } else {
        format!("{improved}/{runs}")
    }
}

/// The hypervolume's reference point, in units of A*'s path on the same query: each front
/// member's length and turning are divided by A*'s (seed 0; its turning at least 0.1 rad) and
/// the area it dominates below (1.2, 1.2) is counted, so a member counts only within 20 % of
/// A*'s length and turning, and a front of one point at A*'s own values scores 0.04.
pub const HV_REFERENCE: (f64, f64) = (1.2, 1.2);

fn mean(v: &[f64]) -> Option<f64> {
    (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
}

fn min(v: &[f64]) -> Option<f64> {
    v.iter().copied().reduce(f64::min)
}

pub fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        (v[n / 2 - 1] + v[n / 2]) / 2.0
    }
}

/// One query of the bench: its name, start and goal (map metres).
struct Job {
    name: String,
    start: [f64; 2],
    goal: [f64; 2],
}

/// A map's name in the tables: its file stem, or its folder's name when the stem is the
/// uninformative `map` (ROS packages ship `maps/<name>/map.yaml`).
fn stem(path: &std::path::Path) -> String {
    let name = |p: &std::path::Path| p.file_stem().map(|s| s.to_string_lossy().to_string());
    match name(path).as_deref() {
        Some("map") => path
            .parent()
            .and_then(|d| d.file_name())
            .map(|d| d.to_string_lossy().to_string())
            .unwrap_or_else(|| "map".into()),
        other => other.unwrap_or_default().to_string(),
    }
}

/// The maps and their queries: from scenario files, or drawn at random on `--map`s.
fn jobs(args: &BenchArgs) -> Result<Vec<(String, Workspace, Vec<Job>)>> {
    let config = load_config(args.config.as_deref())?;
    let mut jobs = Vec::new();
    if let Some(n) = args.random.map(|n| n as usize) {
        for map_path in &args.map {
            let ws = Workspace::load(map_path, config.clone())?;
            let mut rng = PlannerRng::seed_from_u64(args.random_seed);
            let pairs = random_queries(&ws.grid, n, &mut rng, &QuerySampling::default())
                .with_context(|| format!("drawing {n} queries on {}", map_path.display()))?;
            let queries = pairs
                .into_iter()
                .enumerate()
                .map(|(k, (a, b))| Job {
                    name: format!("random_{k}"),
                    start: [a.x, a.y],
                    goal: [b.x, b.y],
                })
                .collect();
            jobs.push((stem(map_path), ws, queries));
        }
        return Ok(jobs);
    }
    for path in &args.scenarios {
        let (file, map_path) = planner_io::load_scenario_file(path)?;
        let ws = Workspace::load(&map_path, config.clone())
            .with_context(|| format!("map of {}", path.display()))?;
        let scenarios: Vec<_> = file
            .scenarios
            .into_iter()
            .filter(|s| args.only.is_empty() || args.only.contains(&s.name))
            .map(|s| Job {
                name: s.name,
                start: s.start,
                goal: s.goal,
            })
            .collect();
        jobs.push((stem(&map_path), ws, scenarios));
    }
    // `--only` names scenarios: one that no file has is a typo, not an empty table.
    let unknown: Vec<&String> = args
        .only
        .iter()
        .filter(|name| {
            !jobs
                .iter()
                .any(|(_, _, js)| js.iter().any(|j| &j.name == *name))
        })
        .collect();
    if !unknown.is_empty() {
        anyhow::bail!(
            "--only: no scenario named {} in {}",
            unknown
                .iter()
                .map(|n| format!("`{n}`"))
                .collect::<Vec<_>>()
                .join(", "),
            args.scenarios
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    Ok(jobs)
}

pub fn run(args: &BenchArgs) -> Result<()> {
    let jobs = jobs(args)?;
    let total: u64 = jobs
        .iter()
        .map(|(_, _, s)| s.len() as u64 * (args.planners.len() as u64 + 1) * args.runs)
        .sum();
    let bar = ProgressBar::new(total).with_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} {msg}")
            .expect("valid template"),
    );
    let mut rows = Vec::new();
    for (map_name, ws, scenarios) in &jobs {
        for sc in scenarios {
            let query = ws.query(sc.start, sc.goal);
            bar.set_message(format!("{map_name}/{} reference", sc.name));
            let astar = ws.run(PlannerName::Astar, &query, 0)?.0;
            // Unsolvable where A* answers the query itself: no path, or an end off the map or
            // on an obstacle (not where it timed out or was refused for its size). Every
            // planner is to answer such a query as A* does.
            let astar_failure = astar.as_ref().err().filter(|e| answers_the_query(e));
            // Its code, which each run's failure is compared with.
            let astar_code = astar_failure.map(ResultCode::from);
            let astar_failure = astar_failure.map(crate::run::failure_line);
            let astar_found_path = astar_failure.is_none();
            let astar = astar.ok();
            // The hypervolume's units: A*'s length and turning on this query.
            let units = astar
                .as_ref()
                .map(|p| (p.metrics.length_m, p.metrics.turning_rad.max(0.1)));
            let reference = ws.reference(&query, &[])?.map(|p| p.metrics.length_m);
            // A*'s median time on this query, for the time ratios.
            let mut astar_times = Vec::new();
            for seed in 0..args.runs {
                astar_times.push(ws.run(PlannerName::Astar, &query, seed)?.1.as_secs_f64() * 1e3);
                bar.inc(1);
            }
            let astar_ms = median(astar_times);
            for planner in &args.planners {
                bar.set_message(format!("{map_name}/{} {planner}", sc.name));
                let mut times = Vec::new();
                let (mut len, mut turn, mut turns, mut clear, mut iters, mut best_it) =
                    (vec![], vec![], vec![], vec![], vec![], vec![]);
                let (mut mean_clear, mut cost, mut half) = (vec![], vec![], vec![]);
                let (mut ok, mut free, mut failure) = (0, 0, None);
                let mut as_astar = 0u64;
                let mut improved: Option<u64> = None;
                let mut straight: Option<u64> = None;
                let mut volumes = Vec::new();
                let mut fallbacks = 0u64;
                let mut ends: std::collections::BTreeMap<String, u64> = Default::default();
                for seed in 0..args.runs {
                    let (result, t) = ws.run(*planner, &query, seed)?;
                    times.push(t.as_secs_f64() * 1e3);
                    match result {
                        Ok(plan) => {
                            ok += 1;
                            free += u64::from(plan.metrics.collision_free);
                            len.push(plan.metrics.length_m);
                            turn.push(plan.metrics.turning_rad);
                            turns.push(plan.metrics.turns as f64);
                            clear.push(plan.metrics.min_clearance_m);
                            mean_clear.push(plan.metrics.mean_clearance_m);
                            half.push(plan.metrics.corridor_half_width_m);
                            cost.push(plan.metrics.path_cost);
                            iters.push(plan.stats.iterations as f64);
                            if let Some(b) = plan.stats.best_iteration {
                                best_it.push(b as f64);
                            }
                            if let (false, Some((l, t))) = (plan.pareto.is_empty(), units) {
                                let front: Vec<(f64, f64)> = plan
                                    .pareto
                                    .iter()
                                    .map(|m| (m.f1_length_m / l, m.f2_turning_rad / t))
                                    .collect();
                                volumes.push(hypervolume_2d(&front, HV_REFERENCE));
                            }
                            fallbacks +=
                                u64::from(plan.stats.counters.contains_key("apf_fallback"));
                            if let Some(v) = plan.stats.counters.get("improved_on_seed") {
                                *improved.get_or_insert(0) += u64::from(*v > 0.0);
                            }
                            if let Some(v) = plan.stats.counters.get("seed_straight") {
                                *straight.get_or_insert(0) += u64::from(*v > 0.0);
                            }
                            let end = plan
                                .stats
                                .termination
                                .map_or("completed".to_string(), |t| t.as_str().to_string());
                            *ends.entry(end).or_default() += 1;
                        }
                        Err(e) => {
                            as_astar += u64::from(astar_code == Some(ResultCode::from(&e)));
                            failure.get_or_insert_with(|| crate::run::failure_line(&e));
                        }
                    }
                    bar.inc(1);
                }
                let time_ms_median = median(times);
                rows.push(Row {
                    map: map_name.clone(),
                    scenario: sc.name.clone(),
                    start: sc.start,
                    goal: sc.goal,
                    planner: *planner,
                    runs: args.runs,
                    successes: ok,
                    collision_free: free,
                    length_m_best: min(&len),
                    length_m_mean: mean(&len),
                    length_ratio_mean: mean(&len).zip(reference).map(|(l, r)| l / r),
                    turning_rad_best: min(&turn),
                    turning_rad_mean: mean(&turn),
                    turns_mean: mean(&turns),
                    min_clearance_m_mean: mean(&clear),
                    mean_clearance_m_mean: mean(&mean_clear),
                    path_cost_mean: mean(&cost),
                    corridor_half_width_m_mean: mean(&half),
                    time_ms_median,
                    time_vs_astar: (astar_ms > 0.0).then(|| time_ms_median / astar_ms),
                    iterations_mean: mean(&iters),
                    best_iteration_mean: mean(&best_it),
                    reference_length_m: reference,
                    astar_found_path,
                    astar_failure: astar_failure.clone(),
                    answered_as_astar: astar_failure.is_some().then_some(as_astar),
                    apf_fallbacks: fallbacks,
                    hypervolume_median: (!volumes.is_empty()).then(|| median(volumes)),
                    improved_on_seed: improved,
                    seed_straight: straight,
                    terminations: ends
                        .iter()
                        .map(|(k, n)| format!("{k} x{n}"))
                        .collect::<Vec<_>>()
                        .join(", "),
                    failure,
                });
            }
        }
    }
    bar.finish_and_clear();
    // Written as it is serialised: a large run's JSON is never held whole in memory.
    let write = |w: &mut dyn std::io::Write| -> std::io::Result<()> {
        let mut w = std::io::BufWriter::new(w);
        serde_json::to_writer_pretty(&mut w, &rows)?;
        std::io::Write::write_all(&mut w, b"\n")?;
        std::io::Write::flush(&mut w)
    };
    match &args.json {
        Some(p) => std::fs::File::create(p)
            .and_then(|mut f| write(&mut f))
            .with_context(|| format!("writing {}", p.display()))?,
        None => write(&mut std::io::stdout().lock()).context("writing standard output")?,
    }
    if let Some(p) = &args.markdown {
        std::fs::write(p, markdown(&rows, args))
            .with_context(|| format!("writing {}", p.display()))?;
    }
    Ok(())
}

/// Whether a failure is an answer to the query itself (no path, an end off the map or on an
/// obstacle, a malformed query) rather than to the run (a deadline, the memory cap).
fn answers_the_query(e: &planner_core::planner::PlanError) -> bool {
    use ResultCode as R;
    matches!(
        R::from(e),
        R::NoValidPath
            | R::StartOutsideMap
            | R::GoalOutsideMap
            | R::StartOccupied
            | R::GoalOccupied
            | R::InvalidInput
    )
}

/// One line per map and planner: how it answered the queries A* solved and those it did not,
/// with the means over the solved ones.
fn summary(s: &mut String, rows: &[Row]) {
    let mut keys: Vec<(&str, PlannerName)> = Vec::new();
    for r in rows {
        if !keys.contains(&(r.map.as_str(), r.planner)) {
            keys.push((r.map.as_str(), r.planner));
        }
    }
    let _ = writeln!(
        s,
        "Summary per map and planner (queries where A* found a path: runs that succeeded, with a collision-free path; where it found none, or refused the query: runs that answered as A* did, NO_VALID_PATH or the refusal's code; means over the solvable queries' rows):\n"
    );
    let _ = writeln!(
        s,
        "| map | planner | solvable: ok | collision-free | unsolvable: A*'s answer | length vs any-angle | turning (rad) | mean clearance (m) | median time vs A* | improved on seed | hypervolume (median of rows) |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|---|");
    for (map, planner) in keys {
        let mine: Vec<&Row> = rows
            .iter()
            .filter(|r| r.map == map && r.planner == planner)
            .collect();
        let (solvable, unsolvable): (Vec<&Row>, Vec<&Row>) =
            mine.iter().partition(|r| r.astar_found_path);
        let runs = |v: &[&Row]| v.iter().map(|r| r.runs).sum::<u64>();
        let ok: u64 = solvable.iter().map(|r| r.successes).sum();
        let free: u64 = solvable.iter().map(|r| r.collision_free).sum();
        let refused: u64 = unsolvable
            .iter()
            .map(|r| r.answered_as_astar.unwrap_or(0))
            .sum();
        let avg = |get: &dyn Fn(&Row) -> Option<f64>| {
            mean(&solvable.iter().filter_map(|r| get(r)).collect::<Vec<_>>())
        };
        let ratios: Vec<f64> = solvable.iter().filter_map(|r| r.time_vs_astar).collect();
        let improved: Option<(u64, u64, u64)> = solvable
            .iter()
            .filter_map(|r| {
                r.improved_on_seed
                    .map(|n| (n, r.successes, r.seed_straight.unwrap_or(0)))
            })
            .reduce(|a, b| (a.0 + b.0, a.1 + b.1, a.2 + b.2));
        let _ =
            writeln!(
            s,
            "| {map} | {planner} | {ok}/{} | {free} | {refused}/{} | {} | {} | {} | {} | {} | {} |",
            runs(&solvable),
            runs(&unsolvable),
            f(avg(&|r| r.length_ratio_mean), 3),
            f(avg(&|r| r.turning_rad_mean), 2),
            f(avg(&|r| r.mean_clearance_m_mean), 2),
            f((!ratios.is_empty()).then(|| median(ratios.clone())), 2),
            improved.map_or("–".into(), |(n, d, straight)| improved_cell(n, d, straight)),
            f(
                Some(
                    solvable
                        .iter()
                        .filter_map(|r| r.hypervolume_median)
                        .collect::<Vec<_>>(),
                )
                .filter(|v| !v.is_empty())
                .map(median),
                4
            ),
        );
    }
    let _ = writeln!(s);
}

fn f(v: Option<f64>, digits: usize) -> String {
    v.map_or("–".into(), |x| format!("{x:.digits$}"))
}

/// The same table for people.
pub fn markdown(rows: &[Row], args: &BenchArgs) -> String {
    let mut s = String::new();
    let show = |paths: &[PathBuf]| {
        paths
            .iter()
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>()
            .join(" ")
    };
    let source = match args.random {
        Some(n) => format!(
            "--map {} --random {n} --random-seed {}",
            show(&args.map),
            args.random_seed
        ),
        None => format!("--scenarios {}", show(&args.scenarios)),
    };
    let _ = writeln!(
        s,
        "Produced by `patrol-plan bench {source} --planners {} --runs {}{}{}`.\n",
        args.planners
            .iter()
            .map(|p| p.as_str())
            .collect::<Vec<_>>()
            .join(","),
        args.runs,
        if args.only.is_empty() {
            String::new()
        } else {
            format!(" --only {}", args.only.join(","))
        },
        args.config
            .as_ref()
            .map_or(String::new(), |c| format!(" --config {}", c.display()))
    );
    summary(&mut s, rows);
    let _ = writeln!(
        s,
        "Lengths in m (ratio: mean length / any-angle reference), turning in rad, times in ms \
         (ratio: median / A*'s median on the same query in the same run). Hypervolume: of the \
         final front's (length, turning), each divided by A*'s on the query (turning at least \
         0.1 rad), below the reference point ({}, {}); the median over the runs. Improved on \
         seed: runs whose answer is shorter or smoother than the planner's seed and worse on \
         neither; \"seed straight\": runs whose seed was already the straight segment to the \
         goal, which no answer improves on.\n",
        HV_REFERENCE.0, HV_REFERENCE.1
    );
    let _ = writeln!(
        s,
        "| map | scenario | planner | A* path | ok | collision-free | length best | length mean | vs any-angle | turning best | turning mean | turns | min clearance | mean clearance | corridor half-width | path cost | time median | vs A* | iterations | best at | improved on seed | hypervolume | termination |"
    );
    let _ = writeln!(
        s,
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
    );
    for r in rows {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {}/{} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {:.3} | {} | {} | {} | {} | {} | {} |",
            r.map,
            r.scenario,
            r.planner,
            if r.astar_found_path { "yes" } else { "no" },
            r.successes,
            r.runs,
            r.collision_free,
            f(r.length_m_best, 2),
            f(r.length_m_mean, 2),
            f(r.length_ratio_mean, 3),
            f(r.turning_rad_best, 2),
            f(r.turning_rad_mean, 2),
            f(r.turns_mean, 1),
            f(r.min_clearance_m_mean, 2),
            f(r.mean_clearance_m_mean, 2),
            f(r.corridor_half_width_m_mean, 2),
            f(r.path_cost_mean, 2),
            r.time_ms_median,
            f(r.time_vs_astar, 2),
            f(r.iterations_mean, 0),
            f(r.best_iteration_mean, 1),
            r.improved_on_seed.map_or("–".into(), |n| {
                improved_cell(n, r.successes, r.seed_straight.unwrap_or(0))
            }),
            f(r.hypervolume_median, 4),
            r.terminations,
        );
    }
    let failures: Vec<_> = rows
        .iter()
        .filter_map(|r| r.failure.as_ref().map(|f| (r, f)))
        .collect();
    if !failures.is_empty() {
        let _ = writeln!(s, "\nFailures (first reason per row):\n");
        for (r, why) in failures {
            let _ = writeln!(s, "- {}/{} {}: {why}", r.map, r.scenario, r.planner);
        }
    }
    s
}
