//! A path follower: regulated pure pursuit (in the manner of Nav2's RPP controller), for the
//! dense `/plan` the planner publishes.
//!
//! Each tick: advance along the path to the point nearest the robot, pick the first point at
//! least `lookahead` ahead, and steer on the circle through it (curvature `2 y / L^2` in the
//! robot's frame). The speed is the limit, regulated down on tight curves (below
//! `min_turn_radius`) and near the goal (within `approach_distance`), and lowered further so that
//! the turn rate stays within its limit on the same curve. A lookahead point more than
//! `rotate_angle` off the heading is turned to in place first. Within `goal_tolerance` of the
//! last point the robot turns in place to the goal's heading, then reports `Arrived` and stops.
//!
//! A path that turns back on itself (a cusp: consecutive segments more than 90 degrees apart,
//! as a route out to a via point and back has) is followed up to the cusp first, as Nav2's RPP
//! cuts its lookahead at a cusp when it may reverse; a differential drive that does not reverse
//! turns on the spot there instead. Neither the progress nor the lookahead point looks past the
//! cusp, and the speed is regulated down towards it as towards the goal. Without that, the
//! progress would jump to the way back where it runs beside the way out, and the robot would
//! turn round short of the cusp. For the same reason the goal counts as reached only once the
//! robot has come along the path to it: a route that passes over its goal on the way, or loops
//! back to where it started, is driven to its end.

use crate::limits::TwistLimits;
use crate::{Pose, Twist2};
use serde::{Deserialize, Serialize};

/// Follower parameters (m, rad).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FollowerParams {
    /// Distance to the carrot point (m). Default 0.6.
    pub lookahead: f64,
    /// Position tolerance at the goal (m). Default 0.10.
    pub goal_tolerance: f64,
    /// Heading tolerance at the goal (rad). Default 0.10.
    pub yaw_tolerance: f64,
    /// Turn in place when the carrot is more than this off the heading (rad). Default 0.8.
    pub rotate_angle: f64,
    /// Below this turning radius the speed is scaled down (m). Default 0.5.
    pub min_turn_radius: f64,
    /// Within this distance of the goal the speed is scaled down (m). Default 1.0.
    pub approach_distance: f64,
    /// The slowest approach speed (m/s). Default 0.05.
    pub min_approach_speed: f64,
}

impl Default for FollowerParams {
    fn default() -> Self {
        Self {
            lookahead: 0.6,
            goal_tolerance: 0.10,
            yaw_tolerance: 0.10,
            rotate_angle: 0.8,
            min_turn_radius: 0.5,
            approach_distance: 1.0,
            min_approach_speed: 0.05,
        }
    }
}

impl FollowerParams {
    /// Checks what a parameter file can get wrong; the error names the first key out of its
    /// range. The bounds keep the follower able to arrive: a tolerance of NaN or 0 is never met
    /// (the robot would circle its goal for ever), and an approach distance of 0 would divide
    /// the approach speed by zero.
    pub fn validate(&self) -> Result<(), String> {
        let ranges = [
            ("lookahead", self.lookahead, 0.05, 10.0),
            ("goal_tolerance", self.goal_tolerance, 0.01, 10.0),
            (
                "yaw_tolerance",
                self.yaw_tolerance,
                0.01,
                std::f64::consts::PI,
            ),
            (
                "rotate_angle",
                self.rotate_angle,
                0.01,
                std::f64::consts::PI,
            ),
            ("min_turn_radius", self.min_turn_radius, 0.0, 10.0),
            ("approach_distance", self.approach_distance, 0.01, 100.0),
            ("min_approach_speed", self.min_approach_speed, 0.001, 1.0),
        ];
        match ranges.iter().find(|(_, v, lo, hi)| !(lo..=hi).contains(&v)) {
            Some((key, v, lo, hi)) => {
                Err(format!("follower.{key}: {v:?} is not within {lo}..={hi}"))
            }
            None => Ok(()),
        }
    }
}

/// What the follower is doing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Status {
    Following,
    /// Turning in place (towards the path, or to the goal's heading).
    Rotating,
    /// Within both tolerances: the command is a stop.
    Arrived,
}

/// Follows one path.
#[derive(Clone, Debug)]
pub struct Follower {
    params: FollowerParams,
    path: Vec<(f64, f64)>,
    goal_yaw: f64,
    nearest: usize,
    /// The indices of the path's cusps, in order (see the module's documentation).
    cusps: Vec<usize>,
    /// The length of the path up to each point (m), so the way between two points is a
    /// difference.
    along: Vec<f64>,
}

/// How far along the path (m) the progress search looks ahead each tick: far beyond what the
/// robot drives in a tick, and short of a loop that comes back past the same place.
const SEARCH_AHEAD_M: f64 = 5.0;

/// The indices of the points where `path` turns back: the next segment more than 90 degrees
/// from the last (points that repeat are skipped: they have no direction).
pub fn cusps(path: &[(f64, f64)]) -> Vec<usize> {
    let mut found = Vec::new();
    let mut last: Option<(f64, f64)> = None;
    for (i, w) in path.windows(2).enumerate() {
        let d = (w[1].0 - w[0].0, w[1].1 - w[0].1);
        if d == (0.0, 0.0) {
            continue;
        }
        if last.is_some_and(|l| l.0 * d.0 + l.1 * d.1 < 0.0) {
            found.push(i);
        }
        last = Some(d);
    }
    found
}

fn wrap(a: f64) -> f64 {
    (a + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI
}

impl Follower {
    /// A follower for `path` (at least one point), ending with heading `goal_yaw`.
    pub fn new(params: FollowerParams, path: Vec<(f64, f64)>, goal_yaw: f64) -> Option<Self> {
        if path.is_empty() {
            return None;
        }
        let mut along = Vec::with_capacity(path.len());
        let mut total = 0.0;
        along.push(total);
        for w in path.windows(2) {
            total += (w[1].0 - w[0].0).hypot(w[1].1 - w[0].1);
            along.push(total);
        }
        Some(Self {
            params,
            cusps: cusps(&path),
            along,
            path,
            goal_yaw,
            nearest: 0,
        })
    }

    /// The path point nearest `here` among those from the progress on, up to the next cusp
    /// and within [`SEARCH_AHEAD_M`] along the path, in the first stretch of the path that
    /// comes near: the search stops once the path has gone a lookahead farther away than the
    /// nearest point so far, so that a path crossing itself further on is not taken up at the
    /// crossing. Of equally near points, the later (a point repeated at a cusp is passed at its
    /// last copy).
    fn nearest_ahead(&self, here: (f64, f64)) -> usize {
        let dist = |i: usize| (self.path[i].0 - here.0).hypot(self.path[i].1 - here.1);
        let reach = self.along[self.nearest] + SEARCH_AHEAD_M;
        let mut best = (self.nearest, dist(self.nearest));
        for i in self.nearest..=self.horizon() {
            if self.along[i] > reach {
                break;
            }
            let d = dist(i);
            if d <= best.1 {
                best = (i, d);
            } else if d > best.1 + self.params.lookahead {
                break;
            }
        }
        best.0
    }

    /// The farthest path point the robot may advance or look to now: the next cusp ahead of
    /// its progress, else the path's end.
    fn horizon(&self) -> usize {
        self.cusps
            .iter()
            .copied()
            .find(|&c| c > self.nearest)
            .unwrap_or(self.path.len() - 1)
    }

    /// How far along the path the robot has come: the index of the path point it was last
    /// nearest to. It only grows (the search runs forward), so a path that passes a place
    /// twice is not taken for done at its first passage.
    pub fn progress(&self) -> usize {
        self.nearest
    }

    /// The length of the path still to drive from `pose`: to the path point nearest it (from
    /// the last progress on, up to the next cusp), then along the path to its end, as Nav2's
    /// navigators report `distance_remaining`.
    pub fn remaining(&self, pose: &Pose) -> f64 {
        let here = (pose.x, pose.y);
        let nearest = self.nearest_ahead(here);
        let to_path = (self.path[nearest].0 - here.0).hypot(self.path[nearest].1 - here.1);
        to_path + self.along[self.path.len() - 1] - self.along[nearest]
    }

    /// The command for the robot at `pose` under `limits` (speed limits only: the caller applies
    /// acceleration limits with [`TwistLimits::apply`]).
    pub fn command(&mut self, pose: &Pose, limits: &TwistLimits) -> (Twist2, Status) {
        let p = self.params;
        let dist = |q: (f64, f64)| ((q.0 - pose.x).powi(2) + (q.1 - pose.y).powi(2)).sqrt();
        // Progress: the nearest point, searching forward only (the path does not go backwards)
        // and not past the next cusp, which counts as reached within the goal tolerance once
        // the robot has come along the path to within a lookahead of it.
        self.nearest = self.nearest_ahead((pose.x, pose.y));
        let horizon = self.horizon();
        let last = self.path.len() - 1;
        let close = |f: &Self, i: usize| {
            dist(f.path[i]) <= p.goal_tolerance
                && f.along[i] - f.along[f.nearest] <= p.lookahead + p.goal_tolerance
        };
        if horizon < last && close(self, horizon) {
            self.nearest = horizon;
        }
        // At the goal: the last stretch of the path, within the tolerance of its end.
        if self.horizon() == last && close(self, last) {
            let err = wrap(self.goal_yaw - pose.yaw);
            if err.abs() <= p.yaw_tolerance {
                return (Twist2::STOP, Status::Arrived);
            }
            let w = (2.0 * err).clamp(-limits.max_angular, limits.max_angular);
            return (Twist2::new(0.0, w), Status::Rotating);
        }
        // Where the robot is to stop next: the next cusp (to turn on the spot there), or the goal.
        let horizon = self.horizon();
        let stop_at = self.path[horizon];
        let carrot = self.path[self.nearest..=horizon]
            .iter()
            .copied()
            .find(|&q| dist(q) >= p.lookahead)
            .unwrap_or(stop_at);
        // The carrot in the robot's frame.
        let (dx, dy) = (carrot.0 - pose.x, carrot.1 - pose.y);
        let (s, c) = pose.yaw.sin_cos();
        let (x, y) = (c * dx + s * dy, -s * dx + c * dy);
        let alpha = y.atan2(x);
        if alpha.abs() > p.rotate_angle {
            return (
                Twist2::new(0.0, limits.max_angular.copysign(alpha)),
                Status::Rotating,
            );
        }
        let l2 = (x * x + y * y).max(1e-9);
        let curvature = 2.0 * y / l2;
        let mut v = limits.max_linear;
        let radius = 1.0 / curvature.abs().max(1e-9);
        if radius < p.min_turn_radius {
            v *= radius / p.min_turn_radius;
        }
        let d_stop = dist(stop_at);
        if d_stop < p.approach_distance {
            v = v.min((limits.max_linear * d_stop / p.approach_distance).max(p.min_approach_speed));
        }
        // Keep the curve, slow down until the turn rate fits.
        if (v * curvature).abs() > limits.max_angular {
            v = limits.max_angular / curvature.abs();
        }
        let v = v.clamp(0.0, limits.max_linear);
        let w = (v * curvature).clamp(-limits.max_angular, limits.max_angular);
        (Twist2::new(v, w), Status::Following)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::Unicycle;
    use proptest::prelude::*;

    #[test]
    fn parameters_that_could_never_arrive_are_refused() {
        assert_eq!(FollowerParams::default().validate(), Ok(()));
        let with = |f: fn(&mut FollowerParams, f64), v: f64| {
            let mut p = FollowerParams::default();
            f(&mut p, v);
            p.validate()
        };
        let err = with(|p, v| p.goal_tolerance = v, f64::NAN).unwrap_err();
        assert!(err.starts_with("follower.goal_tolerance: NaN"), "{err}");
        assert!(with(|p, v| p.yaw_tolerance = v, -1.0).is_err());
        assert!(with(|p, v| p.approach_distance = v, 0.0).is_err());
        assert!(with(|p, v| p.lookahead = v, f64::INFINITY).is_err());
        assert!(with(|p, v| p.min_approach_speed = v, 0.0).is_err());
        assert!(with(|p, v| p.min_turn_radius = v, 0.0).is_ok());
    }

    #[test]
    fn remaining_is_the_way_left_along_the_path() {
        // An L: 4 m along x, then 3 m up y.
        let f = Follower::new(
            FollowerParams::default(),
            dense(&[(0.0, 0.0), (4.0, 0.0), (4.0, 3.0)]),
            0.0,
        )
        .unwrap();
        let at = |x, y| f.remaining(&Pose { x, y, yaw: 0.0 });
        assert!((at(0.0, 0.0) - 7.0).abs() < 1e-9);
        // Half a metre off the path at x = 1: back onto it, then 3 + 3 m.
        assert!((at(1.0, 0.5) - 6.5).abs() < 1e-9, "{}", at(1.0, 0.5));
        // Up the second leg, within the search's reach of the progress (still at the start).
        assert!((at(4.0, 0.5) - 2.5).abs() < 1e-9, "{}", at(4.0, 0.5));
    }

    /// A path that crosses itself 4 m on (out 1.6 m, round a 0.8 m loop, back across the way
    /// out): a robot on the way out at the crossing is on the first passage, though a point of
    /// the second is nearer it.
    #[test]
    fn progress_keeps_to_the_first_passage_of_a_crossing() {
        let path = [
            (0.0, 0.0),
            (1.6, 0.0),
            (1.6, 0.8),
            (0.83, 0.8),
            (0.83, -1.0),
        ];
        let mut f = Follower::new(FollowerParams::default(), dense(&path), 0.0).unwrap();
        assert!(f.cusps.is_empty());
        let _ = f.command(
            &Pose {
                x: 0.83,
                y: 0.0,
                yaw: 0.0,
            },
            &TwistLimits::default(),
        );
        assert_eq!(f.progress(), 17, "0.85 m on, at 0.05 m a point");
    }

    /// A route that loops back to where it starts, and one that passes over its goal on the
    /// way: neither counts as arrived until the robot has driven round to the end.
    #[test]
    fn a_goal_passed_on_the_way_is_not_taken_for_arrival() {
        let square = [(0.0, 0.0), (2.0, 0.0), (2.0, 2.0), (0.0, 2.0), (0.0, 0.0)];
        let mut f = Follower::new(FollowerParams::default(), dense(&square), 0.0).unwrap();
        let (_, status) = f.command(&Pose::default(), &TwistLimits::default());
        assert_ne!(status, Status::Arrived, "arrived before setting off");
        let (pose, steps, _, status) = drive(&square, 0.0, Pose::default());
        assert_eq!(status, Status::Arrived);
        assert!(pose.x.hypot(pose.y) <= 0.1 && steps as f64 * 0.05 > 8.0 / 0.6);
        // Out to (3, 0) and back to (1.5, 0.05): the goal lies on the way out.
        let out_and_back = [(0.0, 0.0), (3.0, 0.0), (1.5, 0.05)];
        let mut f = Follower::new(FollowerParams::default(), dense(&out_and_back), 0.0).unwrap();
        let mut car = Unicycle::new(Pose::default());
        let limits = TwistLimits::default();
        let mut farthest: f64 = 0.0;
        for _ in 0..4000 {
            let (cmd, status) = f.command(&car.pose, &limits);
            if status == Status::Arrived {
                break;
            }
            car.step(limits.apply(cmd, car.twist, 0.05), 0.05);
            farthest = farthest.max(car.pose.x);
        }
        assert!(
            farthest >= 2.9,
            "stopped on the way out at x = {farthest:.2}"
        );
        assert!((car.pose.x - 1.5).hypot(car.pose.y - 0.05) <= 0.1);
    }

    /// Densifies a polyline to 0.05 m, as the planner's /plan is.
    fn dense(pts: &[(f64, f64)]) -> Vec<(f64, f64)> {
        let mut out = Vec::new();
        for w in pts.windows(2) {
            let n = ((((w[1].0 - w[0].0).powi(2) + (w[1].1 - w[0].1).powi(2)).sqrt() / 0.05).ceil()
                as usize)
                .max(1);
            out.extend((0..n).map(|k| {
                let t = k as f64 / n as f64;
                (
                    w[0].0 + t * (w[1].0 - w[0].0),
                    w[0].1 + t * (w[1].1 - w[0].1),
                )
            }));
        }
        out.push(*pts.last().unwrap());
        out
    }

    /// Closes the loop with the simulated chassis: returns the final pose, the steps taken and the
    /// largest deviation from the path.
    fn drive(path: &[(f64, f64)], goal_yaw: f64, start: Pose) -> (Pose, usize, f64, Status) {
        let limits = TwistLimits::default();
        let mut f = Follower::new(FollowerParams::default(), dense(path), goal_yaw).unwrap();
        let mut car = Unicycle::new(start);
        let dt = 0.05;
        let mut worst: f64 = 0.0;
        for step in 0..4000 {
            let (cmd, status) = f.command(&car.pose, &limits);
            assert!(
                cmd.linear.abs() <= limits.max_linear + 1e-12
                    && cmd.angular.abs() <= limits.max_angular + 1e-12
            );
            if status == Status::Arrived {
                return (car.pose, step, worst, status);
            }
            let applied = limits.apply(cmd, car.twist, dt);
            car.step(applied, dt);
            let off = f
                .path
                .iter()
                .map(|q| ((q.0 - car.pose.x).powi(2) + (q.1 - car.pose.y).powi(2)).sqrt())
                .fold(f64::INFINITY, f64::min);
            worst = worst.max(off);
        }
        (car.pose, 4000, worst, Status::Following)
    }

    #[test]
    fn drives_an_l_shaped_path_to_the_goal_and_stops_within_tolerance() {
        let path = [(0.0, 0.0), (4.0, 0.0), (4.0, 3.0)];
        let (pose, steps, worst, status) =
            drive(&path, std::f64::consts::FRAC_PI_2, Pose::default());
        assert_eq!(status, Status::Arrived, "did not arrive in 200 s");
        assert!(((pose.x - 4.0).powi(2) + (pose.y - 3.0).powi(2)).sqrt() <= 0.10);
        assert!(wrap(pose.yaw - std::f64::consts::FRAC_PI_2).abs() <= 0.10);
        // Pure pursuit cuts the corner by less than the lookahead.
        assert!(worst < 0.6, "strayed {worst:.2} m from the path");
        // 7 m at up to 0.6 m/s plus a turn: well under a minute.
        assert!((steps as f64) * 0.05 < 60.0);
    }

    #[test]
    fn turns_in_place_when_the_path_starts_behind() {
        let path = [(0.0, 0.0), (-3.0, 0.0)];
        let mut f = Follower::new(
            FollowerParams::default(),
            dense(&path),
            std::f64::consts::PI,
        )
        .unwrap();
        let (cmd, status) = f.command(&Pose::default(), &TwistLimits::default());
        assert_eq!(status, Status::Rotating);
        assert_eq!(cmd.linear, 0.0);
        let (pose, _, _, status) = drive(&path, std::f64::consts::PI, Pose::default());
        assert_eq!(status, Status::Arrived);
        assert!((pose.x + 3.0).abs() <= 0.1);
    }

    /// Out to (3, 0) and back beside the way out: the robot drives to the cusp before turning
    /// round (pure pursuit alone turned back where the lookahead first reached the way back),
    /// and the way left counts the whole way back too.
    #[test]
    fn drives_out_to_a_cusp_before_turning_back() {
        let path = [(0.0, 0.0), (3.0, 0.0), (0.5, 0.3)];
        let dense_path = dense(&path);
        let f = Follower::new(FollowerParams::default(), dense_path.clone(), 0.0).unwrap();
        assert_eq!(
            f.cusps,
            vec![60],
            "the cusp at (3, 0), the 61st point at 0.05 m"
        );
        let whole = 3.0 + (2.5f64.powi(2) + 0.09).sqrt();
        // Nearer the way back (0.09 m) than the way out (0.15 m), but not there yet.
        let left = f.remaining(&Pose {
            x: 1.0,
            y: 0.15,
            yaw: 0.0,
        });
        assert!((left - (0.15 + whole - 1.0)).abs() < 1e-6, "{left}");
        let limits = TwistLimits::default();
        let mut f = Follower::new(FollowerParams::default(), dense_path, 0.0).unwrap();
        let mut car = Unicycle::new(Pose::default());
        let (mut farthest, mut progress) = (0.0f64, 0);
        for _ in 0..4000 {
            let (cmd, status) = f.command(&car.pose, &limits);
            assert!(f.progress() >= progress, "progress only grows");
            progress = f.progress();
            if status == Status::Arrived {
                break;
            }
            car.step(limits.apply(cmd, car.twist, 0.05), 0.05);
            farthest = farthest.max(car.pose.x);
        }
        assert!(
            farthest >= 3.0 - 0.1,
            "turned back at x = {farthest:.2}, short of the cusp"
        );
        assert!((car.pose.x - 0.5).hypot(car.pose.y - 0.3) <= 0.1);
    }

    proptest! {
        /// On random paths and poses, every command respects the speed limits and is finite.
        #[test]
        fn output_respects_the_limits_on_random_paths(
            pts in proptest::collection::vec((-10.0f64..10.0, -10.0f64..10.0), 2..8),
            x in -10.0f64..10.0, y in -10.0f64..10.0, yaw in -3.2f64..3.2, goal_yaw in -3.2f64..3.2,
        ) {
            let limits = TwistLimits::default();
            let mut f = Follower::new(FollowerParams::default(), dense(&pts), goal_yaw).unwrap();
            let (cmd, _) = f.command(&Pose { x, y, yaw }, &limits);
            prop_assert!(cmd.linear.is_finite() && cmd.angular.is_finite());
            prop_assert!(cmd.linear.abs() <= limits.max_linear + 1e-12);
            prop_assert!(cmd.angular.abs() <= limits.max_angular + 1e-12);
        }
    }
}
