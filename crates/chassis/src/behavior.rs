//! The motions of Nav2's behavior server (nav2_behaviors) a recovery makes when following a path
//! got nowhere: `Spin` turns on the spot through a given angle, `DriveOnHeading` drives straight
//! forwards or back (a back-up) a given distance; `Teleop` passes on an operator's command as
//! [`assisted`] scales it (Nav2's AssistedTeleop). Each is a small state machine like the path
//! follower: fed the robot's pose each control cycle, it says what to command and whether it is
//! done, and it measures its own progress (the angle turned, the distance driven) as Nav2's
//! feedback reports it.
//!
//! As in nav2_behaviors, a motion only commands; whoever runs it watches its time allowance and
//! checks the poses it is about to pass ([`Motion::ahead`]) against a costmap: the chassis crate
//! has neither a clock nor a map.

use crate::limits::TwistLimits;
use crate::{Pose, Twist2};
use std::f64::consts::PI;

/// The slowest turn rate (rad/s) a spin commands near its end, so it always finishes: Nav2's
/// `min_rotational_vel` (0.4) is this chassis's top rate, so it would leave no slowing down.
pub const MIN_SPIN_RATE: f64 = 0.05;

/// The slowest speed (m/s) a drive on heading (a back-up) commands near its end, for the same
/// reason.
pub const MIN_DRIVE_SPEED: f64 = 0.02;

/// Whether a motion is still going.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Status {
    Running,
    /// It has turned (or driven) as far as it was asked; the command is a stop.
    Done,
}

/// A turn on the spot through `target` rad (counter-clockwise if positive), as nav2_behaviors'
/// Spin: the angle turned is summed from the change of heading each cycle (across +-pi), and
/// the turn rate is `sqrt(2 * max_angular_accel * remaining)` within the limits, so the robot
/// slows to a stop where the turn ends.
#[derive(Clone, Debug)]
pub struct Spin {
    target: f64,
    turned: f64,
    last_yaw: Option<f64>,
}

impl Spin {
    /// A spin through `target` rad; `None` unless it is finite.
    pub fn new(target: f64) -> Option<Self> {
        target.is_finite().then_some(Self {
            target,
            turned: 0.0,
            last_yaw: None,
        })
    }

    /// The angle turned so far (rad, signed), Spin's `angular_distance_traveled`.
    pub fn turned(&self) -> f64 {
        self.turned
    }

    /// Takes the pose and gives the command: a turn towards the target's side, or a stop once
    /// it has turned far enough.
    pub fn command(&mut self, pose: &Pose, limits: &TwistLimits) -> (Twist2, Status) {
        if let Some(last) = self.last_yaw {
            self.turned += wrap(pose.yaw - last);
        }
        self.last_yaw = Some(pose.yaw);
        // Turning the other way (a robot still braking from a turn) counts against it.
        let remaining = self.target.abs() - self.turned * self.target.signum();
        if remaining < 1e-6 {
            return (Twist2::STOP, Status::Done);
        }
        let rate = (2.0 * limits.max_angular_accel * remaining)
            .sqrt()
            .min(limits.max_angular)
            .max(MIN_SPIN_RATE.min(limits.max_angular));
        (
            Twist2::new(0.0, rate.copysign(self.target)),
            Status::Running,
        )
    }
}

/// A straight drive along the heading through `distance` m (backwards if negative) at up to
/// `speed` m/s, as nav2_behaviors' DriveOnHeading and BackUp (its backwards use): the distance
/// driven is measured along the heading it began with, in its direction (a robot still rolling
/// the other way has driven less than nothing), and the speed falls as
/// `sqrt(2 * max_linear_accel * remaining)` near the end.
#[derive(Clone, Debug)]
pub struct DriveOnHeading {
    /// How far, as a magnitude.
    distance: f64,
    /// 1 forwards, -1 backwards.
    direction: f64,
    /// How fast, as a magnitude.
    speed: f64,
    from: Option<Pose>,
    driven: f64,
}

impl DriveOnHeading {
    /// A drive through `distance` m (backwards if negative) at `speed` m/s (its magnitude; a
    /// distance of 0 is done at once, as Nav2's); `None` unless both are finite and the speed
    /// not zero (it would never get there).
    pub fn new(distance: f64, speed: f64) -> Option<Self> {
        (distance.is_finite() && speed.is_finite() && speed != 0.0).then_some(Self {
            distance: distance.abs(),
            direction: if distance < 0.0 { -1.0 } else { 1.0 },
            speed: speed.abs(),
            from: None,
            driven: 0.0,
        })
    }

    /// A back-up through `distance` m at `speed` m/s, both taken as magnitudes, as Nav2's
    /// BackUp takes them.
    pub fn back_up(distance: f64, speed: f64) -> Option<Self> {
        Self::new(-distance.abs(), speed)
    }

    /// The distance driven so far (m) in the drive's direction, the `distance_traveled` of
    /// Nav2's feedback.
    pub fn driven(&self) -> f64 {
        self.driven
    }

    /// Takes the pose and gives the command: along the heading, or a stop once it has driven
    /// far enough.
    pub fn command(&mut self, pose: &Pose, limits: &TwistLimits) -> (Twist2, Status) {
        let from = *self.from.get_or_insert(*pose);
        let along = (pose.x - from.x) * from.yaw.cos() + (pose.y - from.y) * from.yaw.sin();
        self.driven = self.direction * along;
        let remaining = self.distance - self.driven;
        if remaining <= 0.0 {
            return (Twist2::STOP, Status::Done);
        }
        let speed = (2.0 * limits.max_linear_accel * remaining)
            .sqrt()
            .min(self.speed)
            .min(limits.max_linear)
            .max(MIN_DRIVE_SPEED.min(self.speed).min(limits.max_linear));
        (Twist2::new(self.direction * speed, 0.0), Status::Running)
    }

    /// How far (m) it still has to go.
    pub fn remaining(&self) -> f64 {
        (self.distance - self.driven).max(0.0)
    }
}

/// Teleoperation as Nav2's AssistedTeleop assists it: the operator's command, each cycle the
/// one [`assisted`] leaves of it (set by whoever runs the motion, which has the costmap). It is
/// never done: the operator, or a time allowance, ends it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Teleop {
    pub twist: Twist2,
}

/// Nav2's AssistedTeleop (`onCycleUpdate`): the poses `twist` leads to from `pose`, every `step`
/// seconds up to `projection` seconds, are checked with `collides`; at the first that collides,
/// the command is stopped if it is the first step, else scaled by the time to it over
/// `projection`, so the robot slows as it nears an obstacle and stops short of it. A command
/// that leads into nothing passes as it is.
pub fn assisted(
    twist: Twist2,
    pose: &Pose,
    projection: f64,
    step: f64,
    collides: impl Fn(&Pose) -> bool,
) -> Twist2 {
    let mut projected = *pose;
    let mut k = 1;
    // As Nav2: time = step, 2 step, ... while below `projection`.
    while (k as f64) * step < projection {
        projected = Pose {
            x: projected.x + step * twist.linear * projected.yaw.cos(),
            y: projected.y + step * twist.linear * projected.yaw.sin(),
            yaw: projected.yaw + step * twist.angular,
        };
        if collides(&projected) {
            if k == 1 {
                return Twist2::STOP;
            }
            let scale = (k as f64) * step / projection;
            return Twist2 {
                linear: twist.linear * scale,
                angular: twist.angular * scale,
            };
        }
        k += 1;
    }
    twist
}

/// A behaviour's motion, as the node's control loop runs it.
#[derive(Clone, Debug)]
pub enum Motion {
    Spin(Spin),
    Drive(DriveOnHeading),
    Teleop(Teleop),
}

impl Motion {
    /// The command for this cycle and whether the motion is done.
    pub fn command(&mut self, pose: &Pose, limits: &TwistLimits) -> (Twist2, Status) {
        match self {
            Motion::Spin(s) => s.command(pose, limits),
            Motion::Drive(d) => d.command(pose, limits),
            Motion::Teleop(t) => (t.twist, Status::Running),
        }
    }

    /// How far it has come: the angle turned (rad) or the distance driven (m); a teleop
    /// measures nothing (0).
    pub fn progress(&self) -> f64 {
        match self {
            Motion::Spin(s) => s.turned(),
            Motion::Drive(d) => d.driven(),
            Motion::Teleop(_) => 0.0,
        }
    }

    /// The poses the robot will pass from `pose` over the next `horizon` seconds at `step`
    /// spacing (s), not beyond the motion's end, as nav2_behaviors simulates ahead before each
    /// command (`simulate_ahead_time`): the caller checks each against its costmap. A spin stays
    /// where it is and only turns, so for a round robot its one pose is the one to check; a
    /// drive runs along the heading (back, for a back-up), at most its remaining distance. A
    /// teleop's command is checked where it is made ([`assisted`]): here only its pose.
    pub fn ahead(&self, pose: &Pose, limits: &TwistLimits, horizon: f64, step: f64) -> Vec<Pose> {
        match self {
            Motion::Spin(_) | Motion::Teleop(_) => vec![*pose],
            Motion::Drive(drive) => {
                let speed = drive.speed.min(limits.max_linear);
                let reach = (speed * horizon.max(0.0)).min(drive.remaining());
                let ds = (speed * step).max(1e-3);
                let n = (reach / ds).ceil() as usize;
                (0..=n)
                    .map(|i| {
                        let d = drive.direction * (i as f64 * ds).min(reach);
                        Pose {
                            x: pose.x + d * pose.yaw.cos(),
                            y: pose.y + d * pose.yaw.sin(),
                            yaw: pose.yaw,
                        }
                    })
                    .collect()
            }
        }
    }
}

/// An angle change wrapped into (-pi, pi].
fn wrap(a: f64) -> f64 {
    let r = a.rem_euclid(2.0 * PI);
    if r > PI {
        r - 2.0 * PI
    } else {
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::Unicycle;

    /// Runs `motion` on the simulated chassis within `limits` until it is done (or `cycles` run
    /// out); returns the final pose and every command applied.
    fn run(mut motion: Motion, from: Pose, cycles: usize) -> (Pose, Vec<Twist2>, bool) {
        let limits = TwistLimits::default();
        let dt = 0.05;
        let mut sim = Unicycle::new(from);
        let (mut previous, mut sent) = (Twist2::STOP, vec![]);
        for _ in 0..cycles {
            let (cmd, status) = motion.command(&sim.pose, &limits);
            let applied = limits.apply(cmd, previous, dt);
            sent.push(applied);
            previous = applied;
            if status == Status::Done && applied == Twist2::STOP {
                return (sim.pose, sent, true);
            }
            sim.step(applied, dt);
        }
        (sim.pose, sent, false)
    }

    /// Nav2's AssistedTeleop scaling, a wall 1 m ahead and a 2 s projection in 0.1 s steps: at
    /// 0.5 m/s the robot would reach it after 2 s, past the projection, so the command passes;
    /// at 1 m/s after 1 s (the 10th step), so it is halved, turn and all; at the wall the first
    /// step collides: a stop; backing away, or turning on the spot, passes.
    #[test]
    fn an_assisted_command_slows_as_it_nears_an_obstacle_and_stops_at_it() {
        let pose = Pose::default();
        let wall = |p: &Pose| p.x >= 1.0 - 1e-9;
        let twist = |linear, angular| Twist2 { linear, angular };
        let slow = twist(0.5, 0.0);
        assert_eq!(assisted(slow, &pose, 2.0, 0.1, wall), slow);
        let scaled = assisted(twist(1.0, 0.0), &pose, 2.0, 0.1, wall);
        assert!((scaled.linear - 0.5).abs() < 1e-9, "{scaled:?}");
        let turning = assisted(twist(1.0, 0.2), &pose, 2.0, 0.1, wall);
        assert!(turning.linear < 1.0, "{turning:?}");
        assert!(
            (turning.angular / turning.linear - 0.2).abs() < 1e-9,
            "scaled alike: {turning:?}"
        );
        let at = Pose { x: 0.96, ..pose };
        assert_eq!(assisted(twist(1.0, 0.2), &at, 2.0, 0.1, wall), Twist2::STOP);
        let back = twist(-0.3, 0.0);
        assert_eq!(assisted(back, &at, 2.0, 0.1, wall), back);
        let turn = twist(0.0, 0.4);
        assert_eq!(assisted(turn, &at, 2.0, 0.1, wall), turn);
    }

    #[test]
    fn a_spin_turns_through_its_angle_across_pi_and_stops() {
        // From 3 rad, a quarter turn to the left crosses +pi.
        let from = Pose {
            x: 1.0,
            y: 2.0,
            yaw: 3.0,
        };
        let (end, sent, done) = run(Motion::Spin(Spin::new(1.57).unwrap()), from, 400);
        assert!(done);
        let turned = wrap(end.yaw - 3.0);
        assert!((turned - 1.57).abs() < 0.05, "turned {turned}");
        assert!((end.x - 1.0).abs() < 1e-9 && (end.y - 2.0).abs() < 1e-9);
        assert!(sent.iter().all(|c| c.linear == 0.0 && c.angular >= 0.0));
        assert!(
            sent.iter().any(|c| (c.angular - 0.4).abs() < 1e-9),
            "top rate"
        );
        // And to the right.
        let (end, sent, done) = run(Motion::Spin(Spin::new(-3.0).unwrap()), from, 400);
        assert!(done && sent.iter().all(|c| c.angular <= 0.0));
        assert!((wrap(end.yaw - 3.0) + 3.0).abs() < 0.05);
    }

    #[test]
    fn a_spin_of_more_than_a_turn_sums_its_turning() {
        let (end, sent, done) = run(
            Motion::Spin(Spin::new(2.0 * PI + 0.5).unwrap()),
            Pose::default(),
            1000,
        );
        assert!(done);
        assert!((wrap(end.yaw) - 0.5).abs() < 0.05, "{}", end.yaw);
        // The whole turn and a half radian, not the half radian alone (the same end yaw).
        let turned: f64 = sent.iter().map(|c| c.angular * 0.05).sum();
        assert!((turned - (2.0 * PI + 0.5)).abs() < 0.05, "{turned}");
    }

    #[test]
    fn a_back_up_drives_straight_back_its_distance_and_stops() {
        let from = Pose {
            x: 2.0,
            y: 1.0,
            yaw: PI / 2.0,
        };
        let mut b = Motion::Drive(DriveOnHeading::back_up(0.3, -0.15).unwrap());
        let (end, sent, done) = run(b.clone(), from, 400);
        assert!(done);
        assert!(
            (end.y - 0.7).abs() < 0.02 && (end.x - 2.0).abs() < 1e-9,
            "{end:?}"
        );
        assert!(sent
            .iter()
            .all(|c| c.linear <= 0.0 && c.linear >= -0.15 && c.angular == 0.0));
        // What it will pass: straight behind, at most its distance.
        let ahead = b.ahead(&from, &TwistLimits::default(), 2.0, 0.1);
        let last = ahead.last().unwrap();
        assert!(
            (last.y - 0.7).abs() < 1e-9 && (last.x - 2.0).abs() < 1e-9,
            "{last:?}"
        );
        assert!(ahead.windows(2).all(|w| w[1].y < w[0].y));
        // Once started, only the remaining distance is ahead.
        b.command(&from, &TwistLimits::default());
        let moved = Pose { y: 0.9, ..from };
        b.command(&moved, &TwistLimits::default());
        assert!((b.progress() - 0.1).abs() < 1e-9);
        let last = *b
            .ahead(&moved, &TwistLimits::default(), 2.0, 0.1)
            .last()
            .unwrap();
        assert!((last.y - 0.7).abs() < 1e-9, "{last:?}");
        // At 0.15 m/s over 1 s only 0.15 m is looked at.
        let short = b.ahead(&moved, &TwistLimits::default(), 1.0, 0.1);
        assert!((short.last().unwrap().y - 0.75).abs() < 1e-9);
    }

    #[test]
    fn a_drive_on_heading_goes_forwards_its_distance() {
        let from = Pose {
            x: 1.0,
            y: 1.0,
            yaw: PI / 4.0,
        };
        let drive = Motion::Drive(DriveOnHeading::new(0.5, 0.2).unwrap());
        let ahead = drive.ahead(&from, &TwistLimits::default(), 2.0, 0.1);
        let last = *ahead.last().unwrap();
        assert!(
            (last.x - 1.0 - 0.4 * (PI / 4.0).cos()).abs() < 1e-9,
            "0.2 m/s x 2 s: {last:?}"
        );
        let (end, sent, done) = run(drive, from, 400);
        assert!(done && sent.iter().all(|c| c.linear >= 0.0 && c.linear <= 0.2));
        let d = (end.x - 1.0).hypot(end.y - 1.0);
        assert!(
            (d - 0.5).abs() < 0.02 && end.x > 1.0 && end.y > 1.0,
            "{end:?}"
        );
    }

    #[test]
    fn motions_that_go_nowhere_are_refused() {
        assert!(Spin::new(f64::NAN).is_none() && Spin::new(f64::INFINITY).is_none());
        assert!(
            DriveOnHeading::new(0.3, 0.0).is_none() && DriveOnHeading::new(f64::NAN, 0.1).is_none()
        );
        // A zero spin or back-up is done at once.
        let limits = TwistLimits::default();
        let mut s = Spin::new(0.0).unwrap();
        assert_eq!(s.command(&Pose::default(), &limits).1, Status::Done);
        let mut b = DriveOnHeading::back_up(0.0, 0.1).unwrap();
        assert_eq!(b.command(&Pose::default(), &limits).1, Status::Done);
    }

    /// A robot still rolling forward (or turning the other way) as the motion starts has not
    /// backed up (or turned) by it: only motion in the asked direction counts.
    #[test]
    fn motion_the_wrong_way_counts_against_the_goal() {
        let limits = TwistLimits::default();
        let mut b = DriveOnHeading::back_up(0.3, 0.15).unwrap();
        let from = Pose::default();
        b.command(&from, &limits);
        let rolled = Pose { x: 0.4, ..from };
        let (cmd, status) = b.command(&rolled, &limits);
        assert_eq!(status, Status::Running);
        assert!(cmd.linear < 0.0 && (b.driven() + 0.4).abs() < 1e-9);
        assert!((b.remaining() - 0.7).abs() < 1e-9);
        let mut s = Spin::new(1.0).unwrap();
        s.command(&from, &limits);
        let (cmd, status) = s.command(&Pose { yaw: -0.2, ..from }, &limits);
        assert_eq!(status, Status::Running);
        assert!(cmd.angular > 0.0 && (s.turned() + 0.2).abs() < 1e-9);
        // 1.2 rad still to go: the top rate, not the slowing down of the last 0.08 rad.
        assert!((cmd.angular - limits.max_angular).abs() < 1e-9);
    }
}
