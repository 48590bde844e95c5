//! The driving-time model of a leg (see the module doc of [`crate::route`]): straight segments at
//! `max_linear`, every heading change turned in place at `max_angular`, and the car facing the
//! pose's yaw at both ends of the leg.

use crate::geometry::{wrap_angle, Point2};
use crate::grid::metrics::total_turning;
use crate::params::{check, ParamError, Range};
use serde::{Deserialize, Serialize};

/// Default top speed (m/s): the chassis' hard limit (`crates/chassis`, the patrol car paper's).
pub const DEFAULT_MAX_LINEAR: f64 = 0.6;
/// Default top turn rate (rad/s): the chassis' hard limit.
pub const DEFAULT_MAX_ANGULAR: f64 = 0.4;

/// How fast the car drives and turns in place.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DrivingModel {
    /// Speed on straight segments (m/s). Default 0.6.
    pub max_linear: f64,
    /// Turn rate in place (rad/s). Default 0.4.
    pub max_angular: f64,
}

impl Default for DrivingModel {
    fn default() -> Self {
        Self {
            max_linear: DEFAULT_MAX_LINEAR,
            max_angular: DEFAULT_MAX_ANGULAR,
        }
    }
}

/// What the time of a leg depends on, besides the yaws at its ends: its length, the turning at
/// its bends, and the headings it leaves and arrives with. A leg driven the other way is the same
/// shape [`reversed`](PathShape::reversed), so each leg is measured once.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathShape {
    /// Length (the waypoints' unit, metres here).
    pub length: f64,
    /// Sum of the absolute heading changes at the bends (rad).
    pub bends: f64,
    /// Heading of the first and of the last non-degenerate segment; `None` for a leg that does
    /// not move (both ends in one place).
    pub headings: Option<(f64, f64)>,
}

impl PathShape {
    /// The shape of a polyline.
    pub fn of(points: &[Point2]) -> Self {
        let mut headings = points.windows(2).filter_map(|w| {
            let d = w[1] - w[0];
            (d.norm_squared() > 0.0).then(|| d.y.atan2(d.x))
        });
        let first = headings.next();
        let last = headings.next_back().or(first);
        Self {
            length: crate::grid::metrics::path_length(points),
            bends: total_turning(points),
            headings: first.zip(last),
        }
    }

    /// The same path driven from its end to its start.
    pub fn reversed(&self) -> Self {
        let back = |h: f64| wrap_angle(h + std::f64::consts::PI);
        Self {
            headings: self.headings.map(|(first, last)| (back(last), back(first))),
            ..*self
        }
    }

    /// Total turning (rad) when the car faces `from_yaw` at the start and must face `to_yaw` at the
    /// end: from the yaw to the first heading, the bends, from the last heading to the yaw.
    pub fn turning(&self, from_yaw: f64, to_yaw: f64) -> f64 {
        match self.headings {
            Some((first, last)) => {
                wrap_angle(first - from_yaw).abs() + self.bends + wrap_angle(to_yaw - last).abs()
            }
            None => wrap_angle(to_yaw - from_yaw).abs(),
        }
    }
}

/// The measured cost of one leg.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct LegCost {
    pub length_m: f64,
    /// Turning in place, the ends' turns included (rad).
    pub turning_rad: f64,
    /// `length_m / max_linear + turning_rad / max_angular` (s).
    pub time_s: f64,
}

impl DrivingModel {
    /// Both speeds finite and positive.
    pub fn validate(&self) -> Result<(), ParamError> {
        check(
            Range::Positive,
            &[
                ("max_linear", self.max_linear),
                ("max_angular", self.max_angular),
            ],
        )
    }

    /// The cost of a leg of this shape between a pose facing `from_yaw` and one facing `to_yaw`.
    pub fn cost(&self, shape: &PathShape, from_yaw: f64, to_yaw: f64) -> LegCost {
        let turning_rad = shape.turning(from_yaw, to_yaw);
        LegCost {
            length_m: shape.length,
            turning_rad,
            time_s: shape.length / self.max_linear + turning_rad / self.max_angular,
        }
    }

    /// The cost of driving `waypoints` (metres) from a pose facing `from_yaw` to one facing
    /// `to_yaw`.
    pub fn leg(&self, waypoints: &[Point2], from_yaw: f64, to_yaw: f64) -> LegCost {
        self.cost(&PathShape::of(waypoints), from_yaw, to_yaw)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, PI};

    fn p(x: f64, y: f64) -> Point2 {
        Point2::new(x, y)
    }

    #[test]
    fn a_straight_leg_facing_its_way_is_length_over_speed() {
        let m = DrivingModel::default();
        let c = m.leg(&[p(0.0, 0.0), p(3.0, 0.0)], 0.0, 0.0);
        assert_eq!(c.length_m, 3.0);
        assert_eq!(c.turning_rad, 0.0);
        assert!((c.time_s - 5.0).abs() < 1e-12, "3 m at 0.6 m/s");
    }

    #[test]
    fn hand_computed_l_shaped_leg() {
        // Facing west (pi) at (0, 0); east 3 m, then north 4 m; the goal must be faced east (0).
        // Turns: west -> east pi, the bend pi/2, north -> east pi/2: 2 pi in all.
        let m = DrivingModel::default();
        let c = m.leg(&[p(0.0, 0.0), p(3.0, 0.0), p(3.0, 4.0)], PI, 0.0);
        assert!((c.length_m - 7.0).abs() < 1e-12);
        assert!(
            (c.turning_rad - 2.0 * PI).abs() < 1e-12,
            "{}",
            c.turning_rad
        );
        let expected = 7.0 / 0.6 + 2.0 * PI / 0.4;
        assert!(
            (c.time_s - expected).abs() < 1e-9,
            "{} vs {expected}",
            c.time_s
        );
        // The other way: facing east at (3, 4), leave south (pi/2), bend pi/2 to west, arrive
        // heading west and turn to face west (pi): no turn. pi/2 + pi/2 + 0 = pi.
        let back = m.leg(&[p(3.0, 4.0), p(3.0, 0.0), p(0.0, 0.0)], 0.0, PI);
        assert!(
            (back.turning_rad - PI).abs() < 1e-12,
            "{}",
            back.turning_rad
        );
        // Each turn takes the short way round: -3 pi / 4 is 3 pi / 4 of turning, not 5 pi / 4.
        let short = m.leg(&[p(0.0, 0.0), p(1.0, 0.0)], 0.75 * PI, 0.0);
        assert!((short.turning_rad - 0.75 * PI).abs() < 1e-12);
    }

    #[test]
    fn a_leg_that_does_not_move_only_turns() {
        let m = DrivingModel {
            max_linear: 1.0,
            max_angular: 0.5,
        };
        let c = m.leg(&[p(1.0, 1.0), p(1.0, 1.0)], 0.0, -FRAC_PI_2);
        assert_eq!(c.length_m, 0.0);
        assert!((c.time_s - PI).abs() < 1e-12, "a quarter turn at 0.5 rad/s");
    }

    #[test]
    fn the_reversed_shape_is_the_shape_of_the_reversed_path() {
        let path = [p(0.0, 0.0), p(2.0, 1.0), p(2.5, 3.0), p(-1.0, 4.0)];
        let mut rev = path;
        rev.reverse();
        let (a, b) = (PathShape::of(&path).reversed(), PathShape::of(&rev));
        assert!((a.length - b.length).abs() < 1e-12 && (a.bends - b.bends).abs() < 1e-12);
        for yaws in [(0.3, -2.0), (3.0, 1.0), (-PI, PI)] {
            assert!((a.turning(yaws.0, yaws.1) - b.turning(yaws.0, yaws.1)).abs() < 1e-12);
        }
    }

    #[test]
    fn speeds_must_be_positive() {
        assert!(DrivingModel::default().validate().is_ok());
        let bad = DrivingModel {
            max_angular: 0.0,
            ..Default::default()
        };
        assert_eq!(bad.validate().unwrap_err().name, "max_angular");
    }
}
