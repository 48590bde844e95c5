//! How long the patrol-route building blocks take, and what the bundled route gains:
//!
//! ```sh
//! cargo build --release -p planner-core --example route_timings
//! taskset -c 0 target/release/examples/route_timings
//! ```
//!
//! Each time is the median of several runs (the count is printed), after one warm-up run.

use planner_core::geometry::Point2;
use planner_core::grid::inflation::PlanningGrid;
use planner_core::planner::{PlannerRng, SolveOptions};
use planner_core::route::{
    held_karp, heuristic, plan_route, CostMatrix, DrivingModel, HeuristicParams, LegMatrix,
    PathShape, RouteFile, RouteOptions, SolveLegs, TourEnd,
};
use planner_core::search::any_angle::AnyAngle;
use rand::{Rng, SeedableRng};
use std::path::PathBuf;
use std::time::Instant;

/// Median wall time (ms) of `runs` calls, after one warm-up call.
fn median_ms<T>(runs: usize, mut f: impl FnMut() -> T) -> f64 {
    std::hint::black_box(f());
    let mut times: Vec<f64> = (0..runs)
        .map(|_| {
            let t0 = Instant::now();
            std::hint::black_box(f());
            t0.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    times.sort_by(f64::total_cmp);
    times[runs / 2]
}

/// Driving times between random poses in a 20 m x 20 m room, straight legs.
fn random_costs(seed: u64, n: usize) -> CostMatrix {
    let mut r = PlannerRng::seed_from_u64(seed);
    let poses: Vec<(Point2, f64)> = (0..n)
        .map(|_| {
            (
                Point2::new(r.random_range(0.0..20.0), r.random_range(0.0..20.0)),
                r.random_range(-std::f64::consts::PI..std::f64::consts::PI),
            )
        })
        .collect();
    let model = DrivingModel::default();
    CostMatrix::new(n, |a, b| {
        let shape = PathShape::of(&[poses[a].0, poses[b].0]);
        model.cost(&shape, poses[a].1, poses[b].1).time_s
    })
}

fn main() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
    let map = planner_io::load_map(&root.join("config/maps/datacenter_100.yaml")).expect("map");
    let grid = PlanningGrid::new(&map, &Default::default()).expect("grid");

    let exact = random_costs(1, 13);
    let ms = median_ms(21, || held_karp(&exact, TourEnd::Start));
    println!("held_karp, start + 12 points, closed loop: {ms:.3} ms (median of 21)");
    let ms = median_ms(21, || held_karp(&exact, TourEnd::Anywhere));
    println!("held_karp, start + 12 points, open route:  {ms:.3} ms (median of 21)");

    let big = random_costs(2, 101);
    let params = HeuristicParams::default();
    let ms = median_ms(5, || heuristic(&big, TourEnd::Start, &params));
    println!(
        "heuristic, start + 100 points, closed loop, {} kicks: {ms:.1} ms (median of 5)",
        params.kicks
    );
    let ms = median_ms(5, || heuristic(&big, TourEnd::Anywhere, &params));
    println!(
        "heuristic, start + 100 points, open route,  {} kicks: {ms:.1} ms (median of 5)",
        params.kicks
    );

    let cap = random_costs(4, 501);
    let ms = median_ms(3, || heuristic(&cap, TourEnd::Start, &params));
    println!("heuristic, start + 500 points (the cap), closed loop: {ms:.0} ms (median of 3)");

    // 20 random free points on the bundled map.
    let mut r = PlannerRng::seed_from_u64(3);
    let info = *grid.info();
    let mut points = Vec::new();
    while points.len() < 20 {
        let p = Point2::new(r.random_range(0.0..20.0), r.random_range(0.0..20.0));
        if info.world_to_cell(p).is_some_and(|c| grid.is_free(c)) {
            points.push(p);
        }
    }
    let m = LegMatrix::build(&grid, &points).expect("free start");
    assert_eq!(m.len(), 20, "every point reachable");
    let ms = median_ms(11, || LegMatrix::build(&grid, &points));
    println!("leg matrix, 20 points on datacenter_100: {ms:.2} ms (median of 11)");

    let text = std::fs::read(root.join("config/routes/datacenter_patrol.yaml")).expect("route");
    let route = RouteFile::parse(&text).expect("valid route");
    for closed in [false, true] {
        let options = RouteOptions {
            closed,
            ..Default::default()
        };
        let mut legs = SolveLegs {
            planner: &AnyAngle,
            grid: &grid,
            options: SolveOptions::default(),
            seed: 0,
        };
        let t0 = Instant::now();
        let plan = plan_route(&grid, &route, &options, Some(&mut legs)).expect("plans");
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        println!(
            "bundled route ({}), any-angle legs: optimised {:.1} s ({:.2} m) against the file's order {:.1} s ({:.2} m), {:.1} % less time; planned in {ms:.1} ms",
            if closed { "closed loop" } else { "open" },
            plan.total_time_s,
            plan.total_length_m,
            plan.given_order_time_s,
            plan.given_order_length_m,
            100.0 * (1.0 - plan.total_time_s / plan.given_order_time_s)
        );
    }
}
