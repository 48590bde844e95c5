//! Differential-drive kinematics: a twist to left and right wheel angular speeds and back, for a
//! chassis with wheel radius `r` and wheel separation `b` (the patrol car paper's section IV.B):
//! `v = r (wR + wL) / 2`, `omega = r (wR - wL) / b`.

use crate::Twist2;
use serde::{Deserialize, Serialize};

/// The geometry of a differential-drive chassis (m).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DiffDrive {
    /// Wheel radius (m). Default 0.08.
    pub wheel_radius: f64,
    /// Distance between the wheels' contact points (m). Default 0.40.
    pub wheel_separation: f64,
}

impl Default for DiffDrive {
    fn default() -> Self {
        Self {
            wheel_radius: 0.08,
            wheel_separation: 0.40,
        }
    }
}

impl DiffDrive {
    /// Left and right wheel angular speeds (rad/s) for a twist.
    pub fn wheel_speeds(&self, t: Twist2) -> (f64, f64) {
        let half = t.angular * self.wheel_separation / 2.0;
        (
            (t.linear - half) / self.wheel_radius,
            (t.linear + half) / self.wheel_radius,
        )
    }

    /// The twist that wheel speeds produce.
    pub fn twist(&self, left: f64, right: f64) -> Twist2 {
        Twist2 {
            linear: self.wheel_radius * (right + left) / 2.0,
            angular: self.wheel_radius * (right - left) / self.wheel_separation,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// The wheel speeds reproduce the commanded v and omega.
        #[test]
        fn wheels_reproduce_the_twist(v in -0.6f64..0.6, w in -0.4f64..0.4, r in 0.02f64..0.3, b in 0.1f64..1.0) {
            let d = DiffDrive { wheel_radius: r, wheel_separation: b };
            let (left, right) = d.wheel_speeds(Twist2::new(v, w));
            prop_assert!((r * (right + left) / 2.0 - v).abs() < 1e-12);
            prop_assert!((r * (right - left) / b - w).abs() < 1e-12);
            let back = d.twist(left, right);
            prop_assert!((back.linear - v).abs() < 1e-12 && (back.angular - w).abs() < 1e-12);
        }
    }

    #[test]
    fn turning_in_place_spins_the_wheels_opposite() {
        let (l, r) = DiffDrive::default().wheel_speeds(Twist2::new(0.0, 0.4));
        assert!((l + r).abs() < 1e-12 && r > 0.0);
    }
}
