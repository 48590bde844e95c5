//! The building blocks every swarm plan runs tens of thousands of times, measured on the shared
//! maps (`../shared/maps`), release build, one thread:
//! - A* and the any-angle reference on `substation_1000` and the ROS maps, each beside the same
//!   query solved by the `pathfinding` crate's A* (ours should not be slower);
//! - inflation (exact distance transform) of the 1000 x 1000 `substation_1000`;
//! - one obstacle-layer update on Nav2's 2000 x 2000 benchmark map: a 1080-ray scan observed,
//!   laid on the map, the map inflated again (what the node does at `update_frequency`);
//! - the collision check of one 32-waypoint path on `datacenter_100`.
//!
//! Every benchmark first asserts that what it measures is valid (same length as the oracle, a
//! collision-free path), so a fast wrong answer cannot pass. Run: `cargo bench -p planner-core`.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use nalgebra::Point3;
use ordered_float::OrderedFloat;
use planner_core::geometry::{Cell, Point2};
use planner_core::grid::inflation::{InflationConfig, PlanningGrid};
use planner_core::grid::obstacle_layer::{scan_rays, ObstacleLayer, SourceRules};
use planner_core::grid::raycast::path_is_free;
use planner_core::grid::GridMap;
use planner_core::planner::{validate, PlanContext, Planner, PlannerRng, Query};
use planner_core::search::any_angle::AnyAngle;
use planner_core::search::astar::{astar_cells, cell_path_length, octile, successors};
use rand::SeedableRng;
use std::hint::black_box;
use std::path::PathBuf;

fn shared(p: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/maps")
        .join(p)
}

fn load(p: &str) -> (GridMap, PlanningGrid) {
    let map = planner_io::load_map_server(&shared(p)).expect("shared map");
    let grid = PlanningGrid::new(&map, &InflationConfig::default()).unwrap();
    (map, grid)
}

/// Free cells nearest to two opposite corners (deterministic long query on any map), in the
/// largest connected region reachable from the first.
fn far_query(grid: &PlanningGrid) -> (Cell, Cell) {
    let (w, h) = (grid.width() as i32, grid.height() as i32);
    let nearest = |tx: i32, ty: i32| {
        (0..h)
            .flat_map(|y| (0..w).map(move |x| Cell::new(x, y)))
            .filter(|&c| grid.is_free(c))
            .min_by_key(|c| (c.x - tx).pow(2) + (c.y - ty).pow(2))
            .unwrap()
    };
    (nearest(w / 5, h / 5), nearest(4 * w / 5, 4 * h / 5))
}

fn oracle(grid: &PlanningGrid, s: Cell, g: Cell) -> f64 {
    pathfinding::directed::astar::astar(
        &s,
        |&c| {
            successors(grid, c)
                .map(|(n, w)| (n, OrderedFloat(w)))
                .collect::<Vec<_>>()
        },
        |&c| OrderedFloat(octile(c, g)),
        |&c| c == g,
    )
    .expect("reachable")
    .1
     .0
}

fn graph_search(c: &mut Criterion) {
    let maps = [
        (
            "substation_1000",
            "bench/substation_1000.yaml",
            Some(([1.25, 250.25], [498.75, 160.25])),
        ),
        ("turtlebot3_world", "ros/turtlebot3_world/map.yaml", None),
        ("nav2_depot", "ros/nav2_depot/depot.yaml", None),
        ("nav2_warehouse", "ros/nav2_warehouse/warehouse.yaml", None),
        (
            "aws_small_warehouse",
            "ros/aws_small_warehouse_005/map.yaml",
            None,
        ),
        ("aws_bookstore", "ros/aws_bookstore/map.yaml", None),
    ];
    let mut group = c.benchmark_group("graph_search");
    group.sample_size(10);
    for (name, path, query) in maps {
        let (map, grid) = load(path);
        let (s, g) = match query {
            Some((a, b)) => (
                map.info().world_to_cell(Point2::new(a[0], a[1])).unwrap(),
                map.info().world_to_cell(Point2::new(b[0], b[1])).unwrap(),
            ),
            None => far_query(&grid),
        };
        let mut rng = PlannerRng::seed_from_u64(0);
        let ctx = PlanContext::never_interrupted(&mut rng);
        let Ok((cells, _)) = astar_cells(&grid, s, g, &ctx) else {
            eprintln!("{name}: no path between {s:?} and {g:?}, skipped");
            continue;
        };
        let expected = oracle(&grid, s, g);
        assert!(
            (cell_path_length(&cells) - expected).abs() < 1e-6,
            "{name}: A* disagrees with the oracle"
        );
        group.bench_function(BenchmarkId::new("astar", name), |b| {
            b.iter(|| astar_cells(black_box(&grid), s, g, &ctx).unwrap())
        });
        group.bench_function(BenchmarkId::new("pathfinding_crate_astar", name), |b| {
            b.iter(|| oracle(black_box(&grid), s, g))
        });
        let info = *grid.info();
        let q = Query {
            start: info.cell_to_world(s),
            goal: info.cell_to_world(g),
            tolerance: 0.0,
        };
        let problem = validate(&grid, &q).unwrap();
        group.bench_function(BenchmarkId::new("any_angle", name), |b| {
            b.iter(|| {
                let mut rng = PlannerRng::seed_from_u64(0);
                AnyAngle
                    .plan(
                        black_box(&problem),
                        &mut PlanContext::never_interrupted(&mut rng),
                    )
                    .unwrap()
            })
        });
    }
    group.finish();
}

fn inflation(c: &mut Criterion) {
    let map = planner_io::load_map_server(&shared("bench/substation_1000.yaml")).unwrap();
    assert_eq!((map.width(), map.height()), (1000, 1000));
    c.bench_function("inflation/substation_1000", |b| {
        b.iter(|| PlanningGrid::new(black_box(&map), &InflationConfig::default()).unwrap())
    });
}

fn obstacle_layer_update(c: &mut Criterion) {
    let map = planner_io::load_map_server(&shared("nav2bench/100by100_20.yaml")).unwrap();
    assert_eq!((map.width(), map.height()), (2000, 2000));
    let info = *map.info();
    // A 270-degree scanner (1080 rays, a quarter degree apart) in the middle of the map, every
    // return 2 m away: a ring of marks within obstacle_max_range.
    let centre = info.grid_to_world(Point2::new(1000.0, 1000.0));
    let rules = SourceRules::default();
    let ranges = vec![2.0f32; 1080];
    let increment = 1.5 * std::f64::consts::PI / 1080.0;
    let rays = scan_rays(
        &ranges,
        -0.75 * std::f64::consts::PI,
        increment,
        0.05,
        10.0,
        &rules,
        |x, y| Point3::new(centre.x + x, centre.y + y, 0.2),
    );
    let mut layer = ObstacleLayer::new(info);
    assert!(layer.observe(&[&rays], None) && layer.marked_count() > 100);
    c.bench_function("obstacle_layer/scan_1080_rays", |b| {
        b.iter(|| black_box(&mut layer).observe(&[black_box(&rays)], None))
    });
    c.bench_function("obstacle_layer/lay_and_inflate_nav2bench_2000", |b| {
        b.iter(|| {
            let seen = layer.overlay(black_box(&map)).unwrap();
            PlanningGrid::new(&seen, &InflationConfig::default()).unwrap()
        })
    });
}

fn collision_check(c: &mut Criterion) {
    let (_, grid) = load("bench/datacenter_100.yaml");
    let q = Query {
        start: Point2::new(0.1, 0.1),
        goal: Point2::new(19.9, 19.9),
        tolerance: 0.0,
    };
    let problem = validate(&grid, &q).unwrap();
    let mut rng = PlannerRng::seed_from_u64(0);
    let any = AnyAngle
        .plan(&problem, &mut PlanContext::never_interrupted(&mut rng))
        .unwrap()
        .waypoints;
    // Split the corner_to_corner any-angle path's longest segments until it has 32 waypoints: a
    // feasible path of the size a cat carries (i = 32), so the check must walk every segment.
    let mut path = any.clone();
    while path.len() < 32 {
        let k = (0..path.len() - 1)
            .max_by(|&a, &b| {
                (path[a + 1] - path[a])
                    .norm()
                    .total_cmp(&(path[b + 1] - path[b]).norm())
            })
            .unwrap();
        let mid = path[k] + (path[k + 1] - path[k]) * 0.5;
        path.insert(k + 1, mid);
    }
    assert!(
        path_is_free(&grid, &path),
        "the benchmark path must be feasible"
    );
    c.bench_function("collision_check/datacenter_100_32_waypoints", |b| {
        b.iter(|| path_is_free(black_box(&grid), black_box(&path)))
    });
}

criterion_group!(
    benches,
    graph_search,
    inflation,
    obstacle_layer_update,
    collision_check
);
criterion_main!(benches);
