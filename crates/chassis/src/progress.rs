//! Whether a robot following a path is getting anywhere, as Nav2's controller_server asks its
//! progress checker (nav2_controller's `PoseProgressChecker`): the robot must move
//! `required_movement_radius` from where it last made progress, or turn
//! `required_movement_angle` there, within `movement_time_allowance`; otherwise the controller
//! fails with FAILED_TO_MAKE_PROGRESS and the navigator's recovery takes over. Turning counts so
//! that a robot turning on the spot (to a path behind it, at a cusp, to the goal's heading) is
//! not taken for a stuck one, as with Nav2's plain `SimpleProgressChecker` it is.

use crate::Pose;
use serde::{Deserialize, Serialize};

/// The progress checker's parameters, Nav2's names and defaults.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ProgressParams {
    /// How far the robot must move (m). Default 0.5.
    pub required_movement_radius: f64,
    /// How far it must turn instead (rad). Default 0.5.
    pub required_movement_angle: f64,
    /// Within how long (s). Default 10.
    pub movement_time_allowance: f64,
}

impl Default for ProgressParams {
    fn default() -> Self {
        Self {
            required_movement_radius: 0.5,
            required_movement_angle: 0.5,
            movement_time_allowance: 10.0,
        }
    }
}

impl ProgressParams {
    /// Whether every value is finite and positive, the allowance at most a day.
    pub fn is_valid(&self) -> bool {
        let positive = |v: f64| v.is_finite() && v > 0.0;
        positive(self.required_movement_radius)
            && positive(self.required_movement_angle)
            && positive(self.movement_time_allowance)
            && self.movement_time_allowance <= 86_400.0
    }
}

/// Tracks one drive's progress. Time is the caller's (seconds from any fixed origin): the chassis
/// crate has no clock.
#[derive(Clone, Debug)]
pub struct ProgressChecker {
    params: ProgressParams,
    /// When the robot last made progress (or the check began), and its pose then, if it had
    /// one (a drive may start before the first odometry).
    baseline: Option<(f64, Option<Pose>)>,
}

impl ProgressChecker {
    pub fn new(params: ProgressParams) -> Self {
        Self {
            params,
            baseline: None,
        }
    }

    pub fn params(&self) -> &ProgressParams {
        &self.params
    }

    /// Takes the robot's pose at time `t` (`None`: no pose now, as when odometry stopped) and
    /// says whether it is still making progress: false once it has been longer than the
    /// allowance since it last moved or turned far enough. The first call starts the clock.
    pub fn check(&mut self, pose: Option<&Pose>, t: f64) -> bool {
        let (since, from) = *self.baseline.get_or_insert((t, pose.copied()));
        match (from, pose) {
            (Some(from), Some(now)) if self.moved(&from, now) => {
                self.baseline = Some((t, Some(*now)));
                true
            }
            // The first pose of a drive that began without one: the clock runs on from then.
            (None, Some(now)) => {
                self.baseline = Some((since, Some(*now)));
                t - since <= self.params.movement_time_allowance
            }
            _ => t - since <= self.params.movement_time_allowance,
        }
    }

    fn moved(&self, from: &Pose, to: &Pose) -> bool {
        let turned = (to.yaw - from.yaw)
            .sin()
            .atan2((to.yaw - from.yaw).cos())
            .abs();
        (to.x - from.x).hypot(to.y - from.y) >= self.params.required_movement_radius
            || turned >= self.params.required_movement_angle
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(x: f64, yaw: f64) -> Pose {
        Pose { x, y: 0.0, yaw }
    }

    #[test]
    fn a_robot_that_neither_moves_nor_turns_fails_after_the_allowance() {
        let mut c = ProgressChecker::new(ProgressParams::default());
        // Creeping 0.04 m a second: 0.4 m in 10 s is not progress.
        for s in 0..=10 {
            assert!(c.check(Some(&at(0.04 * s as f64, 0.0)), s as f64), "{s} s");
        }
        assert!(!c.check(Some(&at(0.44, 0.0)), 11.0));
    }

    #[test]
    fn moving_or_turning_far_enough_restarts_the_clock() {
        let mut c = ProgressChecker::new(ProgressParams::default());
        assert!(c.check(Some(&at(0.0, 0.0)), 0.0));
        assert!(c.check(Some(&at(0.5, 0.0)), 9.0), "moved 0.5 m");
        assert!(c.check(Some(&at(0.6, 0.0)), 18.0), "9 s since");
        // Turning on the spot, across the +-pi seam: 0.6 rad is progress.
        let mut c = ProgressChecker::new(ProgressParams::default());
        assert!(c.check(Some(&at(0.0, 3.0)), 0.0));
        assert!(c.check(Some(&at(0.0, -2.68)), 9.0));
        assert!(c.check(Some(&at(0.0, -2.68)), 18.0));
        assert!(!c.check(Some(&at(0.0, -2.5)), 19.5), "0.18 rad in 10.5 s");
        // A small turn across the seam is small: 3.1 -> -3.1 rad is 0.08 rad, not 6.2.
        let mut c = ProgressChecker::new(ProgressParams::default());
        assert!(c.check(Some(&at(0.0, 3.1)), 0.0));
        assert!(
            !c.check(Some(&at(0.0, -3.1)), 10.5),
            "0.08 rad across the seam"
        );
    }

    #[test]
    fn no_pose_is_no_progress() {
        let mut c = ProgressChecker::new(ProgressParams::default());
        assert!(c.check(None, 0.0));
        assert!(c.check(None, 6.0));
        // The first pose does not restart the clock: the robot was never seen to move.
        assert!(c.check(Some(&at(3.0, 0.0)), 8.0));
        assert!(!c.check(Some(&at(3.1, 0.0)), 10.5));
        // Odometry gone mid-drive: the clock runs from the last progress.
        let mut c = ProgressChecker::new(ProgressParams::default());
        assert!(c.check(Some(&at(0.0, 0.0)), 0.0));
        assert!(c.check(Some(&at(1.0, 0.0)), 2.0));
        assert!(c.check(None, 11.0) && !c.check(None, 12.5));
    }

    #[test]
    fn parameters_must_be_positive_and_finite() {
        assert!(ProgressParams::default().is_valid());
        let fields: [fn(&mut ProgressParams) -> &mut f64; 3] = [
            |p| &mut p.required_movement_radius,
            |p| &mut p.required_movement_angle,
            |p| &mut p.movement_time_allowance,
        ];
        for (k, field) in fields.iter().enumerate() {
            for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
                let mut p = ProgressParams::default();
                *field(&mut p) = bad;
                assert!(!p.is_valid(), "field {k}: {bad}");
            }
        }
        // A day at most: a drive is judged within it.
        let day = |t| ProgressParams {
            movement_time_allowance: t,
            ..ProgressParams::default()
        };
        assert!(day(86_400.0).is_valid() && !day(86_400.1).is_valid());
    }
}
