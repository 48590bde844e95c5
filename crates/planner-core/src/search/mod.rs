//! Graph search on the planning grid: the exact methods every table compares with.
//!
//! - [`astar`]: 8-connected A* with the octile heuristic and no corner cutting (the patrol car
//!   paper's baseline, the fallback seed of the field-guided planners, checked against the Moving
//!   AI optima);
//! - [`any_angle`]: the exact Euclidean shortest path through the free cells (visibility graph over
//!   obstacle corners), the reference every planner's length is reported against.

pub mod any_angle;
pub mod astar;
