//! The map side of planning: everything about the grid, nothing about any planner.
//!
//! - [`map`]: [`GridMap`] with nav_msgs/OccupancyGrid semantics, and the cell <-> world
//!   conversions of [`MapInfo`];
//! - [`parsers`]: map_server YAML + PGM/PNG, Moving AI maps and scenarios, bench scenario files
//!   (from bytes: reading files is planner-io's job);
//! - [`inflation`]: the [`PlanningGrid`] every planner works on (obstacles inflated by the robot's
//!   radius through an exact distance transform, clearance per cell);
//! - [`moves`]: the one 8-neighbour move rule (no corner cutting) of every grid walk;
//! - [`obstacle_layer`]: what a range sensor sees, marked and cleared as costmap_2d's obstacle
//!   layer does, laid on the map before it is inflated;
//! - [`raycast`]: the one collision rule for segments (supercover line of sight);
//! - [`metrics`]: length, turning, clearance of a path;
//! - [`smoothing`]: the genetic algorithm paper's delete operation (section 4.5).

pub mod inflation;
pub mod map;
pub mod metrics;
pub mod moves;
pub mod obstacle_layer;
pub mod parsers;
pub mod raycast;
pub mod smoothing;

pub use inflation::{InflationConfig, PlanningGrid};
pub use map::{GridMap, MapError, MapInfo};
