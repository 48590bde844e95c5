//! Every registered planner on a subset of the bench scenarios (debug-time friendly): a
//! collision-free path from the exact start to the exact goal, the same path for the same seed,
//! and for the Pareto planners a front that really is non-dominated. The full 20-seed sweep over
//! all bench maps is `patrol-plan bench` (see docs/results/).

use planner_core::config::PlannerConfig;
use planner_core::grid::inflation::PlanningGrid;
use planner_core::planner::Interrupt;
use planner_core::planner::Termination;
use planner_core::planner::{solve, PlanContext, PlanError, PlannerRng, Query, SolveOptions};
use planner_core::registry::build;
use planner_core::PlannerName;
use rand::SeedableRng;
use std::path::PathBuf;

fn bench(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/maps/bench")
        .join(name)
}

/// The colony baselines, which may fail honestly where every ant dead-ends.
const BASELINE_COLONIES: [PlannerName; 2] = [PlannerName::Aco, PlannerName::AcoApf];

#[test]
fn every_planner_is_collision_free_and_deterministic_on_the_bench_maps() {
    let config = PlannerConfig::default();
    for scen in [
        "substation_20_simple.scen.yaml",
        "substation_20_complex.scen.yaml",
        "datacenter_100.scen.yaml",
    ] {
        let (file, map_path) = planner_io::load_scenario_file(&bench(scen)).unwrap();
        let map = planner_io::load_map_server(&map_path).unwrap();
        let grid = PlanningGrid::new(&map, &config.costmap).unwrap();
        for sc in file.scenarios.iter().take(2) {
            let q = Query {
                start: sc.start(),
                goal: sc.goal(),
                tolerance: 0.0,
            };
            for name in PlannerName::ALL {
                let planner = build(&PlannerConfig {
                    planner: name,
                    ..config.clone()
                })
                .unwrap();
                let run = |seed: u64| {
                    let mut rng = PlannerRng::seed_from_u64(seed);
                    solve(
                        planner.as_ref(),
                        &grid,
                        &q,
                        SolveOptions::default(),
                        &mut PlanContext::never_interrupted(&mut rng),
                    )
                };
                for seed in 0..2 {
                    let plan = match run(seed) {
                        Ok(plan) => plan,
                        // The baseline colonies have no seed path: on the larger maps every ant
                        // can dead-end, and the honest answer is NO_VALID_PATH (the issue allows it).
                        Err(PlanError::NoValidPath(why))
                            if BASELINE_COLONIES.contains(&name) && why.contains("dropped") =>
                        {
                            continue
                        }
                        Err(e) => panic!("{scen}/{} {name} seed {seed}: {e}", sc.name),
                    };
                    let at = format!("{scen}/{} {name} seed {seed}", sc.name);
                    assert!(plan.metrics.collision_free, "{at}");
                    assert_eq!(plan.waypoints[0], q.start, "{at}");
                    assert_eq!(*plan.waypoints.last().unwrap(), q.goal, "{at}");
                    assert_eq!(
                        run(seed).unwrap().waypoints,
                        plan.waypoints,
                        "{at}: same seed, different path"
                    );
                    for a in &plan.pareto {
                        for b in &plan.pareto {
                            // Three objectives: length, turning and safety (0 when off).
                            let dominates = a.f1_length_m <= b.f1_length_m
                                && a.f2_turning_rad <= b.f2_turning_rad
                                && a.f3_safety <= b.f3_safety
                                && (a.f1_length_m < b.f1_length_m
                                    || a.f2_turning_rad < b.f2_turning_rad
                                    || a.f3_safety < b.f3_safety);
                            assert!(!dominates, "{at}: the front holds a dominated member");
                        }
                    }
                    assert!(plan.stats.termination.is_some(), "{at}: no termination");
                    if name.as_str().starts_with("mo") || name == PlannerName::Nsga2 {
                        assert!(
                            !plan.pareto.is_empty(),
                            "{at}: a Pareto planner without a front"
                        );
                    }
                }
            }
        }
    }
}

/// Anytime: a swarm interrupted part-way still returns a feasible path (its best so far) and says
/// it was cut short. (Interrupted before its seed exists, it fails with the interrupt's reason.)
#[test]
fn an_interrupted_swarm_returns_its_best_so_far() {
    let config = PlannerConfig::default();
    let map = planner_io::load_map_server(&bench("datacenter_100.yaml")).unwrap();
    let grid = PlanningGrid::new(&map, &config.costmap).unwrap();
    let q = Query {
        start: planner_core::geometry::Point2::new(0.1, 0.1),
        goal: planner_core::geometry::Point2::new(19.9, 19.9),
        tolerance: 0.0,
    };
    let planner = build(&PlannerConfig {
        planner: PlannerName::Mocmcso,
        ..config.clone()
    })
    .unwrap();
    let mut rng = PlannerRng::seed_from_u64(0);
    // The deadline passes at the 200th poll: the swarm asks before each of its 50 cats, in its
    // start and in every iteration, and the driver once per iteration, so this is after the seed
    // and the start, a few iterations in.
    let polls = std::cell::Cell::new(0);
    let interrupt = || {
        polls.set(polls.get() + 1);
        (polls.get() >= 200).then_some(planner_core::planner::Interrupt::Deadline)
    };
    let ctx = &mut PlanContext::new(&mut rng, &interrupt);
    let plan = solve(planner.as_ref(), &grid, &q, SolveOptions::default(), ctx).unwrap();
    assert!(plan.stats.cut_short);
    assert_eq!(
        plan.stats.termination,
        Some(Termination::Interrupted(Interrupt::Deadline))
    );
    assert!(plan.metrics.collision_free);
    assert!(
        plan.stats.iterations > 0 && plan.stats.iterations < 100,
        "{}",
        plan.stats.iterations
    );
    let mut rng = PlannerRng::seed_from_u64(0);
    let ctx = &mut PlanContext::new(&mut rng, &|| Some(Interrupt::Deadline));
    assert_eq!(
        solve(planner.as_ref(), &grid, &q, SolveOptions::default(), ctx).unwrap_err(),
        planner_core::planner::PlanError::TimedOut
    );
}

/// The same world at half the cell size: every parameter is in metres (steps, radii, corridors,
/// margins), so every planner still answers, collision-free, with a path of about the same
/// length (within 5 %; at 0.2 / 0.1 m they are within 1.1 % of each other on this query). A
/// parameter that slipped into cells (a step of k cells, a ring of k cells) would
/// halve or double its reach on the finer grid and show here as a failure or a path far off
/// the coarse one's. docs/results/unseen_maps.md measures the same on a real map, 100 queries.
#[test]
fn every_planner_answers_alike_at_half_the_cell_size() {
    use planner_core::grid::{GridMap, MapInfo};
    let config = PlannerConfig::default();
    let coarse = planner_io::load_map_server(&bench("datacenter_100.yaml")).unwrap();
    let info = *coarse.info();
    let (w, h) = (info.width as usize, info.height as usize);
    let fine_data: Vec<i8> = (0..2 * h)
        .flat_map(|y| (0..2 * w).map(move |x| (x / 2, y / 2)))
        .map(|(x, y)| coarse.data()[y * w + x])
        .collect();
    let fine = GridMap::new(
        MapInfo {
            width: info.width * 2,
            height: info.height * 2,
            resolution: info.resolution / 2.0,
            ..info
        },
        fine_data,
    )
    .unwrap();
    let q = Query {
        start: planner_core::geometry::Point2::new(0.5, 6.1),
        goal: planner_core::geometry::Point2::new(19.5, 14.9),
        tolerance: 0.0,
    };
    let grids = [&coarse, &fine].map(|m| PlanningGrid::new(m, &config.costmap).unwrap());
    for name in PlannerName::ALL {
        let planner = build(&PlannerConfig {
            planner: name,
            ..config.clone()
        })
        .unwrap();
        let lengths = grids.each_ref().map(|grid| {
            let mut rng = PlannerRng::seed_from_u64(0);
            match solve(
                planner.as_ref(),
                grid,
                &q,
                SolveOptions::default(),
                &mut PlanContext::never_interrupted(&mut rng),
            ) {
                Ok(plan) => {
                    assert!(
                        plan.metrics.collision_free,
                        "{name} at {} m",
                        grid.resolution()
                    );
                    Some(plan.metrics.length_m)
                }
                Err(PlanError::NoValidPath(_)) if BASELINE_COLONIES.contains(&name) => None,
                Err(e) => panic!("{name} at {} m: {e}", grid.resolution()),
            }
        });
        if let [Some(coarse), Some(fine)] = lengths {
            assert!(
                (fine / coarse - 1.0).abs() < 0.05,
                "{name}: {coarse:.2} m at 0.2 m cells, {fine:.2} m at 0.1 m"
            );
        }
    }
}
