//! planner-core: the pure heart of patrol-planner.
//!
//! Grid maps with nav_msgs/OccupancyGrid semantics and their parsers, obstacle inflation, the one
//! collision rule (supercover line of sight), path metrics, the [`Planner`] trait with its
//! request/result/error types, and the planners themselves. No ROS, no I/O, no async, no clock:
//! everything here can be tested and benchmarked alone.
//!
//! ```
//! use planner_core::{grid::{GridMap, MapInfo}, geometry::{Point2, Pose2}, inflation::*, planner::*, registry};
//! let info = MapInfo { width: 20, height: 10, resolution: 0.1, origin: Pose2::default() };
//! let map = GridMap::new(info, vec![0; 200]).unwrap();
//! let grid = PlanningGrid::new(&map, &InflationConfig::default()).unwrap();
//! let planner = registry::build("astar", &Default::default()).unwrap();
//! let query = Query { start: Point2::new(0.15, 0.15), goal: Point2::new(1.85, 0.85), tolerance: 0.0 };
//! let mut rng = <PlannerRng as rand::SeedableRng>::seed_from_u64(7);
//! let plan = solve(planner.as_ref(), &grid, &query, SolveOptions::default(), &mut PlanContext::never_interrupted(&mut rng)).unwrap();
//! assert!(plan.metrics.collision_free);
//! ```

pub mod ant_colony;
pub mod any_angle;
pub mod astar;
pub mod config;
pub mod genetic;
pub mod geometry;
pub mod grid;
pub mod inflation;
pub mod maps;
pub mod metrics;
pub mod planner;
pub mod potential;
pub mod raycast;
pub mod registry;
pub mod smoothing;
pub mod swarm;
#[cfg(test)]
pub(crate) mod test_support;

pub use planner::{solve, Plan, PlanContext, PlanError, Planner, PlannerRng, Query, SolveOptions};
