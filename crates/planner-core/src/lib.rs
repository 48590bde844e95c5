//! planner-core: the pure heart of patrol-planner. No ROS, no I/O, no async, no clock: everything
//! here can be tested and benchmarked alone.
//!
//! How it is laid out, from the map up:
//! - [`geometry`]: points, cells, poses;
//! - [`grid`]: the map with OccupancyGrid semantics and its parsers, inflation into the planning
//!   grid, the one move rule, the one collision rule, path metrics, the delete operation;
//! - [`planner`]: the one [`Planner`] trait every planner implements, the request, result and
//!   error types, and [`solve`], which validates, runs, verifies and measures (and
//!   [`solve_through`], which does so leg by leg through via points);
//! - [`driver`]: the one loop of every population planner, which ends each run with a typed
//!   [`planner::Termination`];
//! - [`field`]: the potential fields, the wavefront and the virtual-traction escape;
//! - [`seed`]: the potential-field-else-A* path the field-guided planners start from, and the
//!   planners `apf`/`eapf` that return it;
//! - the other planner families: [`search`] (A*, any-angle, cost-aware Theta*), [`swarm`]
//!   (the patrol car paper's cat and particle swarms), [`colony`] (the substation paper's ant
//!   colonies), [`genetic`] (the genetic algorithm paper's IMGA and a plain GA);
//! - [`planner_name`]: the one list of planners, by the names users select them by;
//! - [`registry`]: the builder that maps a name to a planner with its parameters;
//! - [`route`]: patrol routes, the visiting order of many inspection points and the legs between;
//! - [`sampling`]: random start/goal pairs (Nav2's benchmark rules) and random routes on any map;
//! - [`config`]: every parameter section in one struct; [`params`]: how each is checked.
//!
//! ```
//! use planner_core::{grid::{GridMap, InflationConfig, MapInfo, PlanningGrid}, geometry::{Point2, Pose2}, planner::*, registry, PlannerName};
//! let info = MapInfo { width: 20, height: 10, resolution: 0.1, origin: Pose2::default() };
//! let map = GridMap::new(info, vec![0; 200]).unwrap();
//! let grid = PlanningGrid::new(&map, &InflationConfig::default()).unwrap();
//! let config = planner_core::config::PlannerConfig { planner: PlannerName::Astar, ..Default::default() };
//! let planner = registry::build(&config).unwrap();
//! let query = Query { start: Point2::new(0.15, 0.15), goal: Point2::new(1.85, 0.85), tolerance: 0.0 };
//! let mut rng = <PlannerRng as rand::SeedableRng>::seed_from_u64(7);
//! let plan = solve(planner.as_ref(), &grid, &query, SolveOptions::default(), &mut PlanContext::never_interrupted(&mut rng)).unwrap();
//! assert!(plan.metrics.collision_free);
//! ```

pub mod colony;
pub mod config;
pub mod driver;
pub mod field;
pub mod genetic;
pub mod geometry;
pub mod grid;
pub mod judge;
pub mod params;
pub mod planner;
pub mod planner_name;
pub mod registry;
pub mod route;
pub mod sampling;
pub mod search;
pub mod seed;
pub mod swarm;
#[cfg(test)]
pub(crate) mod test_support;

pub use planner::{
    solve, solve_through, Plan, PlanContext, PlanError, Planner, PlannerRng, Query, SolveOptions,
};
pub use planner_name::PlannerName;
