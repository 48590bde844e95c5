//! Graph search on the planning grid: the exact methods every table compares with.
//!
//! - [`astar`]: 8-connected A* with the octile heuristic and no corner cutting (the patrol car
//!   paper's baseline, the fallback seed of the field-guided planners, checked against the Moving
//!   AI optima);
//! - [`any_angle`]: the exact Euclidean shortest path through the free cells (visibility graph over
//!   obstacle corners), the reference every planner's length is reported against.

pub mod any_angle;
pub mod astar;
pub mod theta_star;

use crate::params::{check, ParamError, Range};
use serde::{Deserialize, Serialize};

/// Parameters of the graph searches.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SearchParams {
    /// `astar`'s and `theta_star`'s weight on the costmap cost (Nav2's Smac 2D
    /// `cost_travel_multiplier`): a step into a cell of cost `c` (for `theta_star` a segment
    /// over cells of mean cost `c`) costs its length times `1 + multiplier * c / 252`. 0
    /// (default): pure length, the papers' baseline; Nav2's default is 2.0.
    pub cost_travel_multiplier: f64,
}

impl Default for SearchParams {
    fn default() -> Self {
        Self {
            cost_travel_multiplier: 0.0,
        }
    }
}

impl SearchParams {
    pub fn validate(&self) -> Result<(), ParamError> {
        // Nav2's Smac planners document 0-10ish; past 1000 the cost swamps any length.
        check(
            Range::Within(0.0, 1_000.0),
            &[("search.cost_travel_multiplier", self.cost_travel_multiplier)],
        )
    }
}
