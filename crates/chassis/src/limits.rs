//! Twist limits: every command the chassis receives is clamped to the tighter of the limits the
//! planner forwards and the chassis's own hard limits, and to its acceleration limits. A command
//! that is not a finite number becomes a stop: a NaN must never reach a motor.

use crate::Twist2;
use serde::{Deserialize, Serialize};

/// Speed and acceleration limits of a differential-drive chassis.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TwistLimits {
    /// |v| limit (m/s). Default 0.6: the patrol car paper's limit.
    pub max_linear: f64,
    /// |omega| limit (rad/s). Default 0.4: the patrol car paper's limit.
    pub max_angular: f64,
    /// |dv/dt| limit (m/s^2). Default 0.5.
    pub max_linear_accel: f64,
    /// |domega/dt| limit (rad/s^2). Default 1.0.
    pub max_angular_accel: f64,
}

impl Default for TwistLimits {
    fn default() -> Self {
        Self::RATED
    }
}

impl TwistLimits {
    /// The patrol car's rated limits: the paper's 0.6 m/s and 0.4 rad/s, and the accelerations
    /// its drive is rated for. A parameter file may tighten them, never loosen them
    /// ([`TwistLimits::is_within_rated`]), so no configuration can command the car past what it
    /// is built for.
    pub const RATED: TwistLimits = TwistLimits {
        max_linear: 0.6,
        max_angular: 0.4,
        max_linear_accel: 0.5,
        max_angular_accel: 1.0,
    };

    /// The tighter of two sets of limits, field by field. Non-finite or negative values in
    /// `other` are ignored (the forwarded limits cannot loosen or poison the hard ones).
    pub fn tighter(&self, other: &TwistLimits) -> TwistLimits {
        let pick = |mine: f64, theirs: f64| {
            if theirs.is_finite() && theirs >= 0.0 {
                mine.min(theirs)
            } else {
                mine
            }
        };
        TwistLimits {
            max_linear: pick(self.max_linear, other.max_linear),
            max_angular: pick(self.max_angular, other.max_angular),
            max_linear_accel: pick(self.max_linear_accel, other.max_linear_accel),
            max_angular_accel: pick(self.max_angular_accel, other.max_angular_accel),
        }
    }

    /// Whether every limit is a finite positive number (a limit of 0 would forbid every motion).
    pub fn is_valid(&self) -> bool {
        [
            self.max_linear,
            self.max_angular,
            self.max_linear_accel,
            self.max_angular_accel,
        ]
        .iter()
        .all(|v| v.is_finite() && *v > 0.0)
    }

    /// Whether every limit is a finite positive number no greater than the rated one
    /// ([`TwistLimits::RATED`]): what a parameter file's limits must be.
    pub fn is_within_rated(&self) -> bool {
        self.is_valid() && self.tighter(&Self::RATED) == *self
    }

    /// [`TwistLimits::is_within_rated`], or why not in words, for limits read as `key` (the
    /// node's `twist_limits`, the bridge's `limits`).
    pub fn check_rated(&self, key: &str) -> Result<(), String> {
        if self.is_within_rated() {
            return Ok(());
        }
        let r = Self::RATED;
        Err(format!(
            "{key} must be positive and within the car's rated limits: max_linear {} m/s, max_angular {} rad/s, max_linear_accel {} m/s^2, max_angular_accel {} rad/s^2",
            r.max_linear, r.max_angular, r.max_linear_accel, r.max_angular_accel
        ))
    }

    /// These limits with the top linear speed lowered to `max_linear` (a speed limit), no
    /// faster than the robot can brake: from `previous`, over `dt` seconds, the top speed falls
    /// by at most `max_linear_accel * dt`. A limit that drops below the speed being driven is
    /// then reached by braking within the acceleration limit, where [`TwistLimits::apply`]
    /// (which clamps `previous` to the top speed) would make the speed jump down. Never above
    /// these limits' own top speed; a `max_linear` that is not a finite positive number leaves
    /// them as they are.
    pub fn lowered_to(&self, max_linear: f64, previous: Twist2, dt: f64) -> TwistLimits {
        if !(max_linear.is_finite() && max_linear > 0.0) {
            return *self;
        }
        let dt = if dt.is_finite() && dt > 0.0 { dt } else { 0.0 };
        let braking = if previous.linear.is_finite() {
            previous.linear.abs() - self.max_linear_accel * dt
        } else {
            0.0
        };
        TwistLimits {
            max_linear: max_linear.max(braking).min(self.max_linear),
            ..*self
        }
    }

    /// `cmd` brought within the speed limits along the same curve: both speeds scaled by one
    /// factor, where [`TwistLimits::apply`] clamps each alone (and a turn at a capped speed
    /// would sweep a wider arc than the one asked for). What a check of the arc ahead checks.
    pub fn keeping_curve(&self, cmd: Twist2) -> Twist2 {
        let over = |v: f64, max: f64| if v.abs() > max { max / v.abs() } else { 1.0 };
        let scale = over(cmd.linear, self.max_linear).min(over(cmd.angular, self.max_angular));
        Twist2 {
            linear: cmd.linear * scale,
            angular: cmd.angular * scale,
        }
    }

    /// The command to apply: `cmd` clamped to the speed limits and, from `previous` over `dt`
    /// seconds, to the acceleration limits. A non-finite command (or `dt`) is a stop, still
    /// reached within the acceleration limits. The speed limits come first: a `previous` above
    /// them (the limits just lowered) gives way to them at once where braking could not reach
    /// them in `dt` ([`TwistLimits::lowered_to`] lowers a limit gently instead).
    pub fn apply(&self, cmd: Twist2, previous: Twist2, dt: f64) -> Twist2 {
        let finite = cmd.linear.is_finite() && cmd.angular.is_finite();
        let target = if finite { cmd } else { Twist2::STOP };
        let dt = if dt.is_finite() && dt > 0.0 { dt } else { 0.0 };
        let step = |target: f64, prev: f64, max: f64, accel: f64| {
            let prev = if prev.is_finite() { prev } else { 0.0 };
            let wanted = target.clamp(-max, max);
            let reach = accel * dt;
            wanted.clamp(prev - reach, prev + reach).clamp(-max, max)
        };
        Twist2 {
            linear: step(
                target.linear,
                previous.linear,
                self.max_linear,
                self.max_linear_accel,
            ),
            angular: step(
                target.angular,
                previous.angular,
                self.max_angular,
                self.max_angular_accel,
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A file may tighten any limit and loosen none; zero, negative and non-finite limits are
    /// refused as before.
    #[test]
    fn limits_from_a_file_may_tighten_the_rated_ones_only() {
        assert!(TwistLimits::RATED.is_within_rated());
        let tighter = TwistLimits {
            max_linear: 0.3,
            max_angular_accel: 0.2,
            ..TwistLimits::RATED
        };
        assert!(tighter.is_within_rated());
        for k in 0..4 {
            for bad in [0.0, -0.1, f64::NAN, f64::INFINITY, 5.0] {
                let mut v = [0.6, 0.4, 0.5, 1.0];
                v[k] = bad;
                let l = TwistLimits {
                    max_linear: v[0],
                    max_angular: v[1],
                    max_linear_accel: v[2],
                    max_angular_accel: v[3],
                };
                assert!(!l.is_within_rated(), "field {k}: {bad}");
            }
        }
    }

    /// A command past the limits is scaled along its curve: its turn radius stays.
    #[test]
    fn a_command_past_the_limits_keeps_its_curve() {
        let limits = TwistLimits::default();
        let fast_turn = Twist2 {
            linear: 0.5,
            angular: 1.0,
        };
        let kept = limits.keeping_curve(fast_turn);
        assert!(
            (kept.angular - limits.max_angular).abs() < 1e-12,
            "{kept:?}"
        );
        assert!(
            (kept.linear / kept.angular - 0.5).abs() < 1e-12,
            "the radius: {kept:?}"
        );
        let within = Twist2 {
            linear: -0.3,
            angular: 0.1,
        };
        assert_eq!(limits.keeping_curve(within), within);
    }
    use proptest::prelude::*;

    fn any_f64() -> impl Strategy<Value = f64> {
        prop_oneof![
            -100.0f64..100.0,
            Just(f64::NAN),
            Just(f64::INFINITY),
            Just(f64::NEG_INFINITY),
            Just(0.0),
        ]
    }

    proptest! {
        /// For any command, NaN and infinities included, the output never exceeds the limits,
        /// never changes faster than the acceleration limits, and NaN becomes a stop.
        #[test]
        fn output_respects_every_limit(v in any_f64(), w in any_f64(), pv in -0.6f64..0.6, pw in -0.4f64..0.4, dt in 0.0f64..0.5) {
            let l = TwistLimits::default();
            let out = l.apply(Twist2::new(v, w), Twist2::new(pv, pw), dt);
            prop_assert!(out.linear.is_finite() && out.angular.is_finite());
            prop_assert!(out.linear.abs() <= l.max_linear + 1e-12);
            prop_assert!(out.angular.abs() <= l.max_angular + 1e-12);
            prop_assert!((out.linear - pv).abs() <= l.max_linear_accel * dt + 1e-12);
            prop_assert!((out.angular - pw).abs() <= l.max_angular_accel * dt + 1e-12);
            if !(v.is_finite() && w.is_finite()) {
                // Heading for a stop: never further from zero than before.
                prop_assert!(out.linear.abs() <= pv.abs() + 1e-12 && out.angular.abs() <= pw.abs() + 1e-12);
            }
        }
    }

    proptest! {
        /// A lowered top speed is braked down to within the acceleration limit, and held to
        /// from then on; the chassis' own top speed is never exceeded.
        #[test]
        fn a_lowered_top_speed_is_reached_by_braking(pv in -0.6f64..0.6, cap in 0.01f64..1.0, v in any_f64(), dt in 0.0f64..0.5) {
            let limits = TwistLimits::default();
            let previous = Twist2 { linear: pv, angular: 0.0 };
            let out = limits.lowered_to(cap, previous, dt).apply(Twist2 { linear: v, angular: 0.0 }, previous, dt);
            prop_assert!((out.linear - pv).abs() <= limits.max_linear_accel * dt + 1e-12);
            prop_assert!(out.linear.abs() <= limits.max_linear + 1e-12);
            let braked = (pv.abs() - limits.max_linear_accel * dt).max(0.0);
            prop_assert!(out.linear.abs() <= cap.max(braked) + 1e-12);
        }
    }

    /// From the top speed under a new limit of half of it: 0.025 m/s less each 50 ms tick,
    /// down to the limit in 12 ticks, where it stays.
    #[test]
    fn a_speed_limit_below_the_speed_driven_brakes_down_to_it() {
        let limits = TwistLimits::default();
        let dt = 0.05;
        let mut previous = Twist2 {
            linear: 0.6,
            angular: 0.0,
        };
        let full_ahead = Twist2 {
            linear: 1.0,
            angular: 0.0,
        };
        let mut speeds = Vec::new();
        for _ in 0..14 {
            previous = limits
                .lowered_to(0.3, previous, dt)
                .apply(full_ahead, previous, dt);
            speeds.push(previous.linear);
        }
        assert!((speeds[0] - 0.575).abs() < 1e-9, "{speeds:?}");
        assert!((speeds[11] - 0.3).abs() < 1e-9, "{speeds:?}");
        assert!(
            speeds[12..].iter().all(|v| (v - 0.3).abs() < 1e-9),
            "{speeds:?}"
        );
        assert_eq!(limits.lowered_to(f64::NAN, previous, dt), limits);
    }

    #[test]
    fn forwarded_limits_can_only_tighten() {
        let hard = TwistLimits::default();
        let loose = TwistLimits {
            max_linear: 2.0,
            max_angular: f64::NAN,
            max_linear_accel: -1.0,
            max_angular_accel: 0.2,
        };
        let t = hard.tighter(&loose);
        assert_eq!(
            (
                t.max_linear,
                t.max_angular,
                t.max_linear_accel,
                t.max_angular_accel
            ),
            (0.6, 0.4, 0.5, 0.2)
        );
        // Enough time to reach any speed: clamped to the speed limits.
        let out = hard.apply(Twist2::new(5.0, -5.0), Twist2::STOP, 10.0);
        assert_eq!(out, Twist2::new(0.6, -0.4));
        // A NaN command from full speed ramps down.
        let out = hard.apply(Twist2::new(f64::NAN, 0.0), Twist2::new(0.6, 0.0), 0.1);
        assert!((out.linear - 0.55).abs() < 1e-12);
    }
}
