//! [`build`], the one place that maps a name of the one list of planners ([`PlannerName`]) to an
//! implementation with its parameters. A new planner is one variant of [`PlannerName`], one arm
//! here, and its module.

use crate::colony::{ColonyPlanner, ColonyVariant};
use crate::config::PlannerConfig;
use crate::genetic::{GaPlanner, GaVariant};
use crate::params::ParamError;
use crate::planner::Planner;
use crate::planner_name::PlannerName;
use crate::search::any_angle::AnyAngle;
use crate::search::astar::AStar;
use crate::search::theta_star::ThetaStar;
use crate::seed::ApfPlanner;
use crate::swarm::nsga2::Nsga2Planner;
use crate::swarm::{SwarmPlanner, Variant};

/// Builds `config.planner` with the parameters of `config` (validated first).
pub fn build(config: &PlannerConfig) -> Result<Box<dyn Planner>, ParamError> {
    config.validate()?;
    let apf = config.field();
    let swarm = |variant| -> Box<dyn Planner> {
        Box::new(SwarmPlanner {
            variant,
            params: config.swarm.clone(),
            apf: apf.clone(),
        })
    };
    let colony = |variant| -> Box<dyn Planner> {
        Box::new(ColonyPlanner {
            variant,
            params: config.colony.clone(),
            apf: apf.clone(),
        })
    };
    let genetic = |variant| -> Box<dyn Planner> {
        Box::new(GaPlanner {
            variant,
            params: config.genetic.clone(),
            apf: apf.clone(),
        })
    };
    Ok(match config.planner {
        PlannerName::Astar => Box::new(AStar {
            cost_travel_multiplier: config.search.cost_travel_multiplier,
        }),
        PlannerName::AnyAngle => Box::new(AnyAngle),
        PlannerName::ThetaStar => Box::new(ThetaStar {
            cost_travel_multiplier: config.search.cost_travel_multiplier,
        }),
        PlannerName::Apf => Box::new(ApfPlanner {
            params: apf.clone(),
            substation_field: false,
        }),
        PlannerName::Mocmcso => swarm(Variant::Mocmcso),
        PlannerName::Mocso => swarm(Variant::Mocso),
        PlannerName::Mopso => swarm(Variant::Mopso),
        PlannerName::Cmcso => swarm(Variant::Cmcso),
        PlannerName::Cso => swarm(Variant::Cso),
        PlannerName::Pso => swarm(Variant::Pso),
        PlannerName::Eapf => Box::new(ApfPlanner::eapf(&apf)),
        PlannerName::EapfIaco => colony(ColonyVariant::EapfIaco),
        PlannerName::Aco => colony(ColonyVariant::Aco),
        PlannerName::AcoApf => colony(ColonyVariant::AcoApf),
        PlannerName::Imga => genetic(GaVariant::Imga),
        PlannerName::Ga => genetic(GaVariant::Ga),
        PlannerName::Nsga2 => Box::new(Nsga2Planner {
            params: config.nsga2.clone(),
            swarm: config.swarm.clone(),
            apf: apf.clone(),
        }),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_name_builds_reports_itself_and_round_trips() {
        for name in PlannerName::ALL {
            let config = PlannerConfig {
                planner: name,
                ..PlannerConfig::default()
            };
            assert_eq!(build(&config).unwrap().name(), name);
            assert_eq!(name.as_str().parse::<PlannerName>().unwrap(), name);
            let yaml = serde_yaml::to_string(&name).unwrap();
            assert_eq!(yaml.trim(), name.as_str());
            assert_eq!(serde_yaml::from_str::<PlannerName>(&yaml).unwrap(), name);
        }
        let err = "dijkstra".parse::<PlannerName>().unwrap_err();
        assert!(err.to_string().contains("astar") && err.to_string().contains("dijkstra"));
    }

    /// A deadline that passes while a planner starts or runs stops it with its best path so far
    /// or TimedOut, never a panic, and it asks again at most 3 times; the swarms and NSGA-II stop
    /// their start at once (a start of 2 000 members evaluates the seed and no more), so a large
    /// population no longer holds the plan for a whole start or iteration.
    #[test]
    fn a_deadline_stops_every_planner_at_once() {
        use crate::planner::{Interrupt, PlanError};
        use crate::test_support::{hall, solve_interrupted};
        let (grid, q) = hall(true);
        let deadline_at = |config: &PlannerConfig, fire_at| {
            let planner = build(config).unwrap();
            solve_interrupted(planner.as_ref(), &grid, &q, 1, fire_at, Interrupt::Deadline)
        };
        for name in PlannerName::ALL {
            let config = PlannerConfig {
                planner: name,
                ..PlannerConfig::default()
            };
            for fire_at in [1u64, 5, 40] {
                let (plan, polls) = deadline_at(&config, fire_at);
                match plan {
                    Ok(plan) => assert!(plan.metrics.collision_free, "{name:?}"),
                    Err(PlanError::TimedOut) => {}
                    Err(e) => panic!("{name:?} at poll {fire_at}: {e}"),
                }
                let after = polls.saturating_sub(fire_at);
                assert!(
                    after <= 3,
                    "{name:?}: {after} polls after the deadline at {fire_at}"
                );
            }
        }
        for name in [PlannerName::Mocmcso, PlannerName::Pso, PlannerName::Nsga2] {
            let mut config = PlannerConfig {
                planner: name,
                ..PlannerConfig::default()
            };
            config.swarm.population = 2_000;
            config.nsga2.population = 2_000;
            let plan = deadline_at(&config, 1)
                .0
                .unwrap_or_else(|e| panic!("{name:?}: {e}"));
            assert!(
                plan.stats.cut_short && plan.metrics.collision_free,
                "{name:?}"
            );
            assert!(
                plan.stats.evaluations <= 2,
                "{name:?}: {}",
                plan.stats.evaluations
            );
        }
        // The genetic planners at their largest start (3 000 paths, 100 attempts each): after
        // the deadline each answers with its seed alone (without the polls in the start, all
        // 3 000 were made and evaluated first).
        for name in [PlannerName::Imga, PlannerName::Ga] {
            let mut config = PlannerConfig {
                planner: name,
                ..PlannerConfig::default()
            };
            config.genetic.population = 3_000;
            config.genetic.init_attempts = 100;
            let (plan, polls) = deadline_at(&config, 1);
            let plan = plan.unwrap_or_else(|e| panic!("{name:?}: {e}"));
            assert!(plan.stats.cut_short && plan.metrics.collision_free);
            assert_eq!(plan.stats.evaluations, 1, "{name:?}: the seed only");
            assert!(polls <= 4, "{name:?}: {polls} polls");
        }
    }

    /// A goal in the start's own cell (or equal to the start) is answered by every planner with
    /// the straight segment inside that cell, as Nav2's planners answer it, not a panic (the
    /// swarms' encodings used to panic on it).
    #[test]
    fn a_goal_in_the_start_cell_gets_the_trivial_path_from_every_planner() {
        use crate::geometry::Point2;
        use crate::planner::Query;
        use crate::planner::Termination;
        use crate::test_support::{grid_from_rows, solve_seeded};
        let grid = grid_from_rows(&["....", "....", "...."]);
        for (start, goal) in [
            (Point2::new(1.2, 1.3), Point2::new(1.7, 1.9)),
            (Point2::new(2.5, 0.5), Point2::new(2.5, 0.5)),
        ] {
            let q = Query {
                start,
                goal,
                tolerance: 0.0,
            };
            for name in PlannerName::ALL {
                let planner = build(&PlannerConfig {
                    planner: name,
                    ..PlannerConfig::default()
                })
                .unwrap();
                let plan = solve_seeded(planner.as_ref(), &grid, &q, 1)
                    .unwrap_or_else(|e| panic!("{name}: {e}"));
                assert_eq!(plan.waypoints.first(), Some(&start), "{name}");
                assert_eq!(plan.waypoints.last(), Some(&goal), "{name}");
                assert!(plan.waypoints.len() <= 2, "{name}");
                assert!(plan.metrics.collision_free, "{name}");
                assert_eq!(plan.stats.termination, Some(Termination::Completed));
            }
        }
    }

    /// A start inside the inflated band moves to the nearest free cell within the start
    /// tolerance (the plan starts there); beyond it, or with tolerance 0, START_OCCUPIED.
    #[test]
    fn a_start_in_the_inflated_band_moves_to_free_space_within_the_tolerance() {
        use crate::geometry::Point2;
        use crate::planner::{solve, PlanContext, PlanError, Query, SolveOptions};
        use crate::test_support::{grid_with, rng};
        // 40 x 20 cells of 0.1 m, a wall along row 0, inflated by 0.3 m.
        let grid = grid_with((40, 20), 0.1, 0.3, |_, y| y == 0);
        let q = Query {
            start: Point2::new(1.05, 0.25), // 0.2 m from the wall: in the band (free from 0.45 m)
            goal: Point2::new(3.05, 1.55),
            tolerance: 0.0,
        };
        let planner = build(&PlannerConfig {
            planner: PlannerName::Astar,
            ..PlannerConfig::default()
        })
        .unwrap();
        let run = |start_tolerance| {
            let mut r = rng(0);
            solve(
                planner.as_ref(),
                &grid,
                &q,
                SolveOptions {
                    start_tolerance,
                    ..SolveOptions::default()
                },
                &mut PlanContext::never_interrupted(&mut r),
            )
        };
        assert_eq!(run(0.0).unwrap_err(), PlanError::StartOccupied(q.start));
        assert_eq!(run(0.1).unwrap_err(), PlanError::StartOccupied(q.start));
        let plan = run(0.25).unwrap();
        let first = plan.waypoints[0];
        assert!(
            (first.x - 1.05).abs() < 1e-9 && (first.y - 0.45).abs() < 1e-9,
            "{first:?}"
        );
        assert!(plan.metrics.collision_free);
        // The plan says where its start moved, and only that (the goal was free).
        let moved: Vec<&String> = plan
            .stats
            .notes
            .iter()
            .filter(|n| n.contains("not free"))
            .collect();
        assert_eq!(moved.len(), 1, "{:?}", plan.stats.notes);
        assert!(
            moved[0].contains("start (1.050, 0.250)")
                && moved[0].contains("(1.050, 0.450), 0.200 m away"),
            "{}",
            moved[0]
        );
    }

    /// A plan whose planner's working tables would pass the memory cap is refused before it
    /// runs, naming the planner, the need and the cap; within the cap the same query plans.
    #[test]
    fn a_plan_over_the_memory_cap_is_refused_before_it_runs() {
        use crate::geometry::Point2;
        use crate::planner::{solve, PlanContext, PlanError, Query, SolveOptions};
        use crate::test_support::{grid_from_rows, rng};
        let grid = grid_from_rows(&["........", "........", "........"]);
        let padded = 10 * 5;
        let q = Query {
            start: Point2::new(0.5, 0.5),
            goal: Point2::new(7.5, 2.5),
            tolerance: 0.0,
        };
        for name in PlannerName::ALL {
            let planner = build(&PlannerConfig {
                planner: name,
                ..PlannerConfig::default()
            })
            .unwrap();
            let per_cell = planner.working_bytes_per_cell();
            assert!(per_cell >= crate::planner::ASTAR_BYTES_PER_CELL, "{name}");
            let run = |cap| {
                let mut r = rng(1);
                solve(
                    planner.as_ref(),
                    &grid,
                    &q,
                    SolveOptions {
                        max_plan_bytes: cap,
                        ..SolveOptions::default()
                    },
                    &mut PlanContext::never_interrupted(&mut r),
                )
            };
            let need = padded * per_cell + planner.working_bytes_beyond_cells(8, 3);
            match run(need - 1) {
                Err(PlanError::TooLarge {
                    planner,
                    needed,
                    cap,
                    ..
                }) => {
                    assert_eq!((planner, needed, cap), (name, need, need - 1));
                }
                other => panic!("{name}: {:?}", other.map(|p| p.waypoints)),
            }
            assert!(run(need).is_ok(), "{name}");
        }
    }
}
