//! `patrol-plan bench`: every planner, R seeds, every scenario; one row per map x scenario x
//! planner. Lengths are also reported as ratios to the any-angle reference and times as ratios to
//! A*'s median on the same query in the same run, so figures from different machines compare.

use crate::run::{load_config, Workspace};
use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use planner_core::PlannerName;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::PathBuf;

/// `patrol-plan bench`'s arguments.
#[derive(clap::Args)]
pub struct BenchArgs {
    /// `*.scen.yaml` files (e.g. ../shared/maps/bench/datacenter_100.scen.yaml).
    #[arg(long, num_args = 1.., required = true)]
    pub scenarios: Vec<PathBuf>,
    /// Comma-separated planner names (`patrol-plan planners` lists them).
    #[arg(long, value_delimiter = ',', default_value = "astar,any_angle")]
    pub planners: Vec<PlannerName>,
    /// Runs per planner and scenario (seeds 0..runs-1).
    #[arg(long, default_value_t = 5)]
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
    pub time_ms_median: f64,
    /// This planner's median time / A*'s median time on the same query, in this run.
    pub time_vs_astar: Option<f64>,
    pub iterations_mean: Option<f64>,
    /// Mean iteration at which the best value last improved (population methods).
    pub best_iteration_mean: Option<f64>,
    pub reference_length_m: Option<f64>,
    /// The first failure's reason, when a run failed.
    pub failure: Option<String>,
}

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

pub fn run(args: &BenchArgs) -> Result<()> {
    let config = load_config(args.config.as_deref())?;
    let mut jobs = Vec::new();
    for path in &args.scenarios {
        let (file, map_path) = planner_io::load_scenario_file(path)?;
        let ws = Workspace::load(&map_path, config.clone())
            .with_context(|| format!("map of {}", path.display()))?;
        let map_name = map_path
            .file_stem()
            .map(|s| s.to_string_lossy().to_string())
            .unwrap_or_default();
        let scenarios: Vec<_> = file
            .scenarios
            .into_iter()
            .filter(|s| args.only.is_empty() || args.only.contains(&s.name))
            .collect();
        jobs.push((map_name, ws, scenarios));
    }
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
            let reference = ws
                .run(PlannerName::AnyAngle, &query, 0)?
                .0
                .ok()
                .map(|p| p.metrics.length_m);
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
                let (mut mean_clear, mut cost) = (vec![], vec![]);
                let (mut ok, mut free, mut failure) = (0, 0, None);
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
                            cost.push(plan.metrics.path_cost);
                            iters.push(plan.stats.iterations as f64);
                            if let Some(b) = plan.stats.best_iteration {
                                best_it.push(b as f64);
                            }
                        }
                        Err(e) => {
                            failure.get_or_insert_with(|| e.to_string());
                        }
                    }
                    bar.inc(1);
                }
                let time_ms_median = median(times);
                rows.push(Row {
                    map: map_name.clone(),
                    scenario: sc.name.clone(),
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
                    time_ms_median,
                    time_vs_astar: (astar_ms > 0.0).then(|| time_ms_median / astar_ms),
                    iterations_mean: mean(&iters),
                    best_iteration_mean: mean(&best_it),
                    reference_length_m: reference,
                    failure,
                });
            }
        }
    }
    bar.finish_and_clear();
    let json = serde_json::to_string_pretty(&rows)?;
    match &args.json {
        Some(p) => std::fs::write(p, json).with_context(|| format!("writing {}", p.display()))?,
        None => println!("{json}"),
    }
    if let Some(p) = &args.markdown {
        std::fs::write(p, markdown(&rows, args))
            .with_context(|| format!("writing {}", p.display()))?;
    }
    Ok(())
}

fn f(v: Option<f64>, digits: usize) -> String {
    v.map_or("–".into(), |x| format!("{x:.digits$}"))
}

/// The same table for people.
pub fn markdown(rows: &[Row], args: &BenchArgs) -> String {
    let mut s = String::new();
    let files: Vec<String> = args
        .scenarios
        .iter()
        .map(|p| p.display().to_string())
        .collect();
    let _ = writeln!(
        s,
        "Produced by `patrol-plan bench --scenarios {} --planners {} --runs {}`{}.\n",
        files.join(" "),
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
        }
    );
    let _ = writeln!(
        s,
        "Lengths in m (ratio: mean length / any-angle reference), turning in rad, times in ms \
         (ratio: median / A*'s median on the same query in the same run).\n"
    );
    let _ = writeln!(
        s,
        "| map | scenario | planner | ok | collision-free | length best | length mean | vs any-angle | turning best | turning mean | turns | min clearance | mean clearance | path cost | time median | vs A* | iterations | best at |"
    );
    let _ = writeln!(
        s,
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
    );
    for r in rows {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {}/{} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {:.3} | {} | {} | {} |",
            r.map,
            r.scenario,
            r.planner,
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
            f(r.path_cost_mean, 2),
            r.time_ms_median,
            f(r.time_vs_astar, 2),
            f(r.iterations_mean, 0),
            f(r.best_iteration_mean, 1),
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
