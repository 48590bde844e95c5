//! Points, cells and poses shared by every module.
//!
//! Two coordinate systems meet in this crate:
//! - *world* coordinates, metres in the map frame (what ROS messages and scenario files carry);
//! - *grid* coordinates, continuous and in cells: the point `(x + 0.5, y + 0.5)` is the centre of
//!   cell `(x, y)`, cell `(0, 0)` is the one at the map origin (ROS's bottom-left).
//!
//! Planners work in grid coordinates only; [`crate::grid::MapInfo`] converts at the boundary.

use serde::{Deserialize, Serialize};

/// A continuous point (world metres or grid cells, depending on context).
pub type Point2 = nalgebra::Point2<f64>;
/// A continuous vector (same units as [`Point2`]).
pub type Vector2 = nalgebra::Vector2<f64>;

/// The integer index of a grid cell. Signed so that neighbour arithmetic can step off the map
/// and be checked afterwards.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub struct Cell {
    pub x: i32,
    pub y: i32,
}

impl Cell {
    pub const fn new(x: i32, y: i32) -> Self {
        Self { x, y }
    }

    /// The cell's centre in grid coordinates.
    pub fn center(self) -> Point2 {
        Point2::new(self.x as f64 + 0.5, self.y as f64 + 0.5)
    }

    /// The cell containing a grid-coordinate point (no bounds check).
    pub fn containing(p: Point2) -> Self {
        Self::new(floor_i32(p.x), floor_i32(p.y))
    }

    pub fn offset(self, dx: i32, dy: i32) -> Self {
        Self::new(self.x + dx, self.y + dy)
    }
}

/// `v.floor() as i32` without the libm call that `floor` becomes on baseline x86-64 (it showed
/// in the swarms' profile: every segment of every candidate path starts with two of them).
#[inline]
pub fn floor_i32(v: f64) -> i32 {
    let t = v as i32;
    if (t as f64) > v {
        t - 1
    } else {
        t
    }
}

/// The eight neighbour offsets, orthogonal ones first. The order is part of every planner's
/// determinism: do not reorder.
pub const NEIGHBOURS_8: [(i32, i32); 8] = [
    (1, 0),
    (0, 1),
    (-1, 0),
    (0, -1),
    (1, 1),
    (-1, 1),
    (-1, -1),
    (1, -1),
];

/// A planar pose: position and heading (rad, counter-clockwise from +x).
#[derive(Clone, Copy, Debug, PartialEq, Default, Serialize, Deserialize)]
pub struct Pose2 {
    pub x: f64,
    pub y: f64,
    pub yaw: f64,
}

impl Pose2 {
    pub const fn new(x: f64, y: f64, yaw: f64) -> Self {
        Self { x, y, yaw }
    }

    pub fn position(&self) -> Point2 {
        Point2::new(self.x, self.y)
    }

    pub fn is_finite(&self) -> bool {
        self.x.is_finite() && self.y.is_finite() && self.yaw.is_finite()
    }
}

/// Wraps an angle to (-pi, pi].
pub fn wrap_angle(a: f64) -> f64 {
    let two_pi = std::f64::consts::TAU;
    // `%` is exact and returns `a` itself when |a| < 2 pi, which a difference of two headings
    // from `atan2` always is but at +-2 pi: skipping the call gives the same bits, and the
    // swarms wrap every vertex of every feasible candidate.
    let mut r = if a.abs() < two_pi { a } else { a % two_pi };
    if r <= -std::f64::consts::PI {
        r += two_pi;
    } else if r > std::f64::consts::PI {
        r -= two_pi;
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn wrap_angle_lands_in_half_open_interval() {
        assert!((wrap_angle(3.0 * PI) - PI).abs() < 1e-12);
        assert!((wrap_angle(-PI) - PI).abs() < 1e-12);
        assert!((wrap_angle(0.5) - 0.5).abs() < 1e-12);
        assert!((wrap_angle(-0.5 - 2.0 * PI) + 0.5).abs() < 1e-12);
    }

    proptest::proptest! {
        /// Skipping `%` below 2 pi gives the same bits as always taking it: the swarms' turning,
        /// and so every recorded path, depends on them.
        #[test]
        fn wrap_angle_is_bit_for_bit_the_remainder_form(a in -20.0f64..20.0) {
            let reference = |a: f64| {
                let mut r = a % std::f64::consts::TAU;
                if r <= -PI {
                    r += std::f64::consts::TAU;
                } else if r > PI {
                    r -= std::f64::consts::TAU;
                }
                r
            };
            for x in [a, std::f64::consts::TAU, -std::f64::consts::TAU, 2.0 * PI - 1e-15] {
                proptest::prop_assert_eq!(wrap_angle(x).to_bits(), reference(x).to_bits());
            }
        }
    }

    #[test]
    fn floor_i32_is_floor() {
        for v in [-2.5, -2.0, -0.5, -0.0, 0.0, 0.3, 1.0, 1.999_999, 1e6 + 0.5] {
            assert_eq!(floor_i32(v), v.floor() as i32, "{v}");
        }
    }

    #[test]
    fn cell_center_and_containing_agree() {
        let c = Cell::new(3, -2);
        assert_eq!(Cell::containing(c.center()), c);
    }
}
