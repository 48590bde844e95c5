//! Nav2's behavior server (nav2_behaviors): `spin` turns the robot on the spot, `backup` drives
//! it straight back, `drive_on_heading` straight on (or back), `wait` keeps it standing. Served
//! as Nav2's actions (nav2_msgs, Jazzy), as nav2_simple_commander's `spin()`, `backup()` and
//! `driveOnHeading()` and the behaviour trees' Spin, BackUp, DriveOnHeading and Wait nodes send
//! them, and made by a drive's recoveries (drive.rs) in turn, as Nav2's default
//! trees' round robin makes them.
//!
//! A motion is made by the node's control loop (follow.rs, from the chassis crate's
//! `behavior` state machines); the behaviour watches it each tick, as nav2_behaviors'
//! `onCycleUpdate` does: it ends when the motion is done, fails with TIMEOUT past its time
//! allowance, with TF_ERROR when odometry stops (for a second), and with COLLISION_AHEAD, stopping first, when a
//! pose the robot would pass within `behavior_server.simulate_ahead_time` is within the robot's
//! radius of an obstacle on the grid the node plans on. A spin, back-up or drive goal takes the
//! robot as any goal does (a newer goal of any kind takes it back); a wait goal only waits, as Nav2's. A
//! client's cancel stops a behaviour (canceled), a newer goal of the same action preempts it
//! (aborted), as Nav2's behaviours end.

use crate::action_server::{Feedback, GoalStop, Preemption};
use crate::convert::{chassis_pose, duration_msg};
use crate::drive::{taken, DriveEnd};
use crate::outputs::Outputs;
use crate::state::Shared;
use chassis::behavior::{DriveOnHeading, Motion, Spin, Status as MotionStatus};
use log::{info, warn};
use patrol_msgs::builtin_interfaces::Duration as DurationMsg;
use patrol_msgs::nav2_msgs::{
    BackUpFeedback, BackUpGoal, BehaviorResult, DriveOnHeadingGoal, SpinFeedback, SpinGoal,
    WaitFeedback, WaitGoal,
};
use planner_core::geometry::{Point2, Pose2};
use planner_core::grid::inflation::LETHAL;
use ros2_client::action::{AsyncActionServer, GoalEndStatus};
use std::future::Future;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// How often a behaviour checks on its motion and reports.
const TICK: Duration = Duration::from_millis(100);

/// How long a behaviour goes on without fresh odometry (`pose_timeout`) before it fails with
/// TF_ERROR, at its start and while its motion runs.
pub const STALE_LIMIT: Duration = Duration::from_secs(1);

/// How long a behaviour waits for the robot to come to rest before its motion starts: braking
/// from the top speeds takes 1.2 s at the default limits.
const SETTLE: Duration = Duration::from_secs(3);

/// The spacing (s of motion) of the poses checked ahead, as nav2_behaviors' `cycle_frequency`
/// (10 Hz) spaces them.
const AHEAD_STEP_S: f64 = 0.1;

/// One behaviour, as its action's goal or a recovery asks for it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Behavior {
    /// Turn on the spot through this angle (rad, counter-clockwise if positive).
    Spin(f64),
    /// Drive straight along the heading this far (m; backwards if negative: a back-up) at this
    /// speed (m/s).
    Drive { distance: f64, speed: f64 },
    /// Stand still this long.
    Wait(Duration),
}

impl std::fmt::Display for Behavior {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Behavior::Spin(a) => write!(f, "spin {a:.2} rad"),
            Behavior::Drive { distance, speed } if *distance < 0.0 => {
                write!(f, "back up {:.2} m at {speed:.2} m/s", -distance)
            }
            Behavior::Drive { distance, speed } => {
                write!(f, "drive {distance:.2} m on heading at {speed:.2} m/s")
            }
            Behavior::Wait(d) => write!(f, "wait {:.1} s", d.as_secs_f64()),
        }
    }
}

impl Behavior {
    /// The motion it makes (`None`: a wait), or why it cannot: a spin's angle must be finite,
    /// a back-up's distance and speed finite and its speed not zero.
    pub fn motion(&self) -> Result<Option<Motion>, String> {
        let motion = match *self {
            Behavior::Wait(_) => return Ok(None),
            Behavior::Spin(angle) => Spin::new(angle).map(Motion::Spin),
            Behavior::Drive { distance, speed } => {
                DriveOnHeading::new(distance, speed).map(Motion::Drive)
            }
        };
        motion.map(Some).ok_or_else(|| {
            format!("{self}: the angle, distance and speed must be finite, the speed not zero")
        })
    }
}

/// Why a behaviour failed, as nav2_behaviors' result codes name it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BehaviorFailure {
    Unknown,
    Timeout,
    /// No fresh robot pose (odometry stopped).
    TfError,
    InvalidInput,
    CollisionAhead,
}

/// How a behaviour ended.
#[derive(Debug)]
pub enum BehaviorEnd {
    Succeeded,
    Failed(BehaviorFailure, String),
    /// Stopped on request (cancel, preemption); the robot brakes to a stop.
    Stopped,
    /// The goal lost the robot: a newer goal took it, or the node was deactivated.
    Taken(DriveEnd),
}

/// Makes `behavior` for goal `mine` (which must have the robot), calling `progress` each tick
/// with the angle turned (rad), the distance driven (m) or the time left (s). A spin or back-up
/// fails past `allowance` (`None`: no limit).
pub async fn run<P, Fut>(
    s: &Arc<Shared>,
    behavior: Behavior,
    allowance: Option<Duration>,
    mine: u64,
    stop: &GoalStop,
    mut progress: P,
) -> BehaviorEnd
where
    P: FnMut(f64) -> Fut,
    Fut: Future<Output = ()>,
{
    let started = Instant::now();
    let motion = match behavior.motion() {
        Ok(Some(motion)) => motion,
        Ok(None) => return wait(behavior, || interrupted(s, mine, stop), progress).await,
        Err(why) => return BehaviorEnd::Failed(BehaviorFailure::InvalidInput, why),
    };
    // A pose as fresh as the follower needs, waited for a moment (as a TF lookup waits its
    // tolerance): a goal may overtake the odometry on a busy machine.
    let mut pose = s.fresh_odom();
    let asked = Instant::now();
    while pose.is_none() && asked.elapsed() < STALE_LIMIT {
        tokio::time::sleep(TICK).await;
        pose = s.fresh_odom();
    }
    let Some(pose) = pose else {
        return BehaviorEnd::Failed(BehaviorFailure::TfError, no_pose());
    };
    if let Some(why) = collision_ahead(s, &motion, pose) {
        return BehaviorEnd::Failed(BehaviorFailure::CollisionAhead, why);
    }
    // From rest, as a behaviour starts: a robot still braking from the drive before would carry
    // its motion into this one's.
    let settling = Instant::now();
    while s.moving.load(Ordering::SeqCst) && settling.elapsed() < SETTLE {
        if let Some(end) = interrupted(s, mine, stop) {
            return end;
        }
        tokio::time::sleep(TICK).await;
    }
    if !s.start_motion(mine, motion) {
        return taken(s, mine).map_or(BehaviorEnd::Stopped, BehaviorEnd::Taken);
    }
    info!("goal {mine}: {behavior}");
    let mut stale_since: Option<Instant> = None;
    let end = loop {
        tokio::time::sleep(TICK).await;
        if let Some(end) = interrupted(s, mine, stop) {
            break end;
        }
        let Some(moving) = s.motion_of(mine) else {
            // Ended by a newer goal's plan or a deactivation in between (or by one undone
            // within the tick: no stop was asked for, so it failed).
            break taken(s, mine).map_or_else(
                || BehaviorEnd::Failed(BehaviorFailure::Unknown, format!("{behavior}: ended")),
                BehaviorEnd::Taken,
            );
        };
        progress(moving.motion.progress()).await;
        if moving.status == MotionStatus::Done {
            break BehaviorEnd::Succeeded;
        }
        if allowance.is_some_and(|a| started.elapsed() > a) {
            break BehaviorEnd::Failed(
                BehaviorFailure::Timeout,
                format!(
                    "{behavior}: not done within its time allowance ({:.1} s)",
                    allowance.unwrap_or_default().as_secs_f64()
                ),
            );
        }
        // Without fresh odometry the follower loop holds the robot stopped; the behaviour fails
        // once that has lasted [`STALE_LIMIT`].
        let Some(pose) = s.fresh_odom() else {
            if stale_since.get_or_insert_with(Instant::now).elapsed() > STALE_LIMIT {
                break BehaviorEnd::Failed(BehaviorFailure::TfError, no_pose());
            }
            continue;
        };
        stale_since = None;
        if let Some(why) = collision_ahead(s, &moving.motion, pose) {
            break BehaviorEnd::Failed(BehaviorFailure::CollisionAhead, why);
        }
    };
    // Every way out stops the robot (a newer goal's own plan or motion is left be).
    s.stop_motion(mine);
    end
}

/// A wait of `behavior`'s duration (none for a motion), ended early by what `interrupted` says.
async fn wait<P, Fut>(
    behavior: Behavior,
    interrupted: impl Fn() -> Option<BehaviorEnd>,
    mut progress: P,
) -> BehaviorEnd
where
    P: FnMut(f64) -> Fut,
    Fut: Future<Output = ()>,
{
    let started = Instant::now();
    let d = match behavior {
        Behavior::Wait(d) => d,
        _ => Duration::ZERO,
    };
    while started.elapsed() < d {
        if let Some(end) = interrupted() {
            return end;
        }
        progress(d.saturating_sub(started.elapsed()).as_secs_f64()).await;
        tokio::time::sleep(TICK.min(d.saturating_sub(started.elapsed()))).await;
    }
    BehaviorEnd::Succeeded
}

/// A stop asked for, or the robot no longer this goal's.
pub fn interrupted(s: &Shared, mine: u64, stop: &GoalStop) -> Option<BehaviorEnd> {
    if stop.requested() {
        return Some(BehaviorEnd::Stopped);
    }
    taken(s, mine).map(BehaviorEnd::Taken)
}

pub fn no_pose() -> String {
    "the robot's pose is not available: no fresh /odom".into()
}

/// Why the motion may not go on from `pose`, if it may not: a pose it would pass within
/// `behavior_server.simulate_ahead_time` is not clear ([`clear_from`]), or there is no map to
/// check against.
fn collision_ahead(s: &Shared, motion: &Motion, pose: Pose2) -> Option<String> {
    let Some(clear) = clear_from(s, pose) else {
        return Some("no map to check the motion against".into());
    };
    let ahead = motion.ahead(
        &chassis_pose(pose),
        &s.params.twist_limits,
        s.params.behavior_server.simulate_ahead_time,
        AHEAD_STEP_S,
    );
    let radius = s.live.read().expect("lock").config.costmap.robot_radius;
    ahead.iter().find(|p| !clear(p)).map(|p| {
        format!(
            "collision ahead: the robot would be within its radius ({radius} m) of an \
             obstacle, or in a keepout zone, at ({:.2}, {:.2})",
            p.x, p.y
        )
    })
}

/// Where the robot may be, for a motion starting at `pose`: a pose is clear when it is on the
/// grid the node plans on, at least the robot's radius from its obstacles (the robot would
/// touch one nearer: the planner's wider inflated band is where a path may not run, not where
/// the robot may not be), and out of keepout zones (`keepout_mask_topic`: a lethal cell that
/// is no obstacle), unless the robot is in one already: then it may move, to get out. `None`
/// without a map.
pub fn clear_from(s: &Shared, pose: Pose2) -> Option<impl Fn(&chassis::Pose) -> bool> {
    let map = s.map.read().expect("lock").clone()?;
    let radius = s.live.read().expect("lock").config.costmap.robot_radius;
    let inside = map
        .grid
        .cell_at(Point2::new(pose.x, pose.y))
        .is_some_and(|c| map.grid.cost(c) >= LETHAL);
    Some(move |p: &chassis::Pose| {
        let grid = &map.grid;
        grid.cell_at(Point2::new(p.x, p.y))
            .is_some_and(|c| grid.clearance(c) >= radius && (inside || grid.cost(c) < LETHAL))
    })
}

/// What the behaviour actions' goals have in common.
trait BehaviorGoal: ros2_client::Message + Clone + Send + Sync + 'static {
    type Feedback: ros2_client::Message + Send + Sync + 'static;
    const NAME: &'static str;
    /// The action's result codes (nav2_msgs, Jazzy).
    const CODES: Codes;
    fn behavior(&self) -> Behavior;
    /// Why the goal asks for what the behaviour cannot do, if it does.
    fn refusal(&self) -> Option<String> {
        None
    }
    fn allowance(&self) -> Option<Duration>;
    fn feedback(progress: f64) -> Self::Feedback;
    /// The action's code for a failure.
    fn code(f: BehaviorFailure) -> u16 {
        let c = Self::CODES;
        match f {
            BehaviorFailure::Unknown => c.unknown,
            BehaviorFailure::Timeout => c.timeout,
            BehaviorFailure::TfError => c.tf_error,
            BehaviorFailure::InvalidInput => c.invalid_input,
            BehaviorFailure::CollisionAhead => c.collision_ahead,
        }
    }
}

/// One action's result codes, as its `.action` file numbers them.
struct Codes {
    unknown: u16,
    timeout: u16,
    tf_error: u16,
    invalid_input: u16,
    collision_ahead: u16,
}

/// The feedback of a drive (back-up, drive on heading): the distance driven.
fn drive_feedback(progress: f64) -> BackUpFeedback {
    BackUpFeedback {
        distance_traveled: progress as f32,
    }
}

/// A goal's `time_allowance`: zero (or negative) is no limit, as in nav2_behaviors.
pub fn allowance(d: &DurationMsg) -> Option<Duration> {
    let secs = f64::from(d.sec) + f64::from(d.nanosec) * 1e-9;
    (secs > 0.0).then(|| Duration::from_secs_f64(secs))
}

impl BehaviorGoal for SpinGoal {
    type Feedback = SpinFeedback;
    const NAME: &'static str = "spin";
    /// Spin has no INVALID_INPUT: UNKNOWN serves.
    const CODES: Codes = Codes {
        unknown: 700,
        timeout: 701,
        tf_error: 702,
        invalid_input: 700,
        collision_ahead: 703,
    };
    fn behavior(&self) -> Behavior {
        Behavior::Spin(f64::from(self.target_yaw))
    }
    fn allowance(&self) -> Option<Duration> {
        allowance(&self.time_allowance)
    }
    fn feedback(progress: f64) -> SpinFeedback {
        SpinFeedback {
            angular_distance_traveled: progress as f32,
        }
    }
}

impl BehaviorGoal for BackUpGoal {
    type Feedback = BackUpFeedback;
    const NAME: &'static str = "backup";
    const CODES: Codes = Codes {
        unknown: 710,
        timeout: 711,
        tf_error: 712,
        invalid_input: 713,
        collision_ahead: 714,
    };
    /// Backwards whatever the signs, as nav2_behaviors' BackUp takes both magnitudes.
    fn behavior(&self) -> Behavior {
        Behavior::Drive {
            distance: -self.target.x.abs(),
            speed: f64::from(self.speed).abs(),
        }
    }
    /// As nav2_behaviors' BackUp: only along the robot's heading.
    fn refusal(&self) -> Option<String> {
        (self.target.y != 0.0 || self.target.z != 0.0)
            .then(|| "backing up in y and z is not supported: only target.x is driven".into())
    }
    fn allowance(&self) -> Option<Duration> {
        allowance(&self.time_allowance)
    }
    fn feedback(progress: f64) -> BackUpFeedback {
        drive_feedback(progress)
    }
}

impl BehaviorGoal for DriveOnHeadingGoal {
    type Feedback = BackUpFeedback;
    const NAME: &'static str = "drive_on_heading";
    const CODES: Codes = Codes {
        unknown: 720,
        timeout: 721,
        tf_error: 722,
        invalid_input: 724,
        collision_ahead: 723,
    };
    fn behavior(&self) -> Behavior {
        Behavior::Drive {
            distance: self.target.x,
            speed: f64::from(self.speed).abs(),
        }
    }
    /// As nav2_behaviors' DriveOnHeading: only along the robot's heading, and `target.x > 0`
    /// exactly when `speed > 0` (so a zero distance passes with a speed not above 0, and is
    /// done at once). Unlike Nav2, a speed of 0, which would drive at 0 m/s until the time
    /// allowance, is refused too ([`Behavior::motion`]).
    fn refusal(&self) -> Option<String> {
        if self.target.y != 0.0 || self.target.z != 0.0 {
            return Some("driving in y and z is not supported: only target.x is driven".into());
        }
        ((self.target.x > 0.0) != (self.speed > 0.0))
            .then(|| "target.x and speed must have the same sign".into())
    }
    fn allowance(&self) -> Option<Duration> {
        allowance(&self.time_allowance)
    }
    fn feedback(progress: f64) -> BackUpFeedback {
        drive_feedback(progress)
    }
}

impl BehaviorGoal for WaitGoal {
    type Feedback = WaitFeedback;
    const NAME: &'static str = "wait";
    /// Jazzy's Wait result has no codes: a wait that cannot run says why with code 0.
    const CODES: Codes = Codes {
        unknown: 0,
        timeout: 0,
        tf_error: 0,
        invalid_input: 0,
        collision_ahead: 0,
    };
    fn behavior(&self) -> Behavior {
        Behavior::Wait(allowance(&self.time).unwrap_or_default())
    }
    fn allowance(&self) -> Option<Duration> {
        None
    }
    fn feedback(progress: f64) -> WaitFeedback {
        WaitFeedback {
            time_left: duration_msg(Duration::from_secs_f64(progress.max(0.0))),
        }
    }
}

/// Serves one behaviour action until the node stops (the door: action_server.rs).
async fn serve<G: BehaviorGoal>(
    s: Arc<Shared>,
    o: Outputs,
    server: AsyncActionServer<G, BehaviorResult, G::Feedback>,
) {
    crate::action_server::serve(s, o, G::NAME, Preemption::Newest, server, behave::<G>).await
}

/// The behaviour actions' servers.
pub struct BehaviorServers {
    pub spin: AsyncActionServer<SpinGoal, BehaviorResult, SpinFeedback>,
    pub backup: AsyncActionServer<BackUpGoal, BehaviorResult, BackUpFeedback>,
    pub drive_on_heading: AsyncActionServer<DriveOnHeadingGoal, BehaviorResult, BackUpFeedback>,
    pub wait: AsyncActionServer<WaitGoal, BehaviorResult, WaitFeedback>,
}

/// Serves `spin`, `backup`, `drive_on_heading` and `wait` side by side.
pub async fn serve_all(s: Arc<Shared>, o: Outputs, servers: BehaviorServers) {
    tokio::join!(
        serve(s.clone(), o.clone(), servers.spin),
        serve(s.clone(), o.clone(), servers.backup),
        serve(s.clone(), o.clone(), servers.drive_on_heading),
        serve(s, o, servers.wait),
    );
}

/// One behaviour goal: it takes the robot, and its result says how it ended.
async fn behave<G: BehaviorGoal>(
    s: Arc<Shared>,
    _o: Outputs,
    goal: G,
    stop: GoalStop,
    feedback: Feedback<G, BehaviorResult, G::Feedback>,
) -> (GoalEndStatus, BehaviorResult) {
    let started = Instant::now();
    let behavior = goal.behavior();
    let moves = !matches!(behavior, Behavior::Wait(_));
    // Refused before the goal takes the robot: a bad goal does not stop a good one.
    if let Some(why) = goal.refusal().or_else(|| behavior.motion().err()) {
        let invalid = BehaviorEnd::Failed(BehaviorFailure::InvalidInput, why);
        return goal_end(G::NAME, invalid, &stop, started, G::code);
    }
    let progress = |p: f64| {
        let feedback = feedback.clone();
        async move { feedback.send(G::feedback(p)).await }
    };
    let end = if moves {
        // The robot is this goal's: whatever drove it stops now, even if the motion cannot
        // start (no pose, a collision ahead).
        let mine = s.take_robot();
        s.stop_following(mine);
        run(&s, behavior, goal.allowance(), mine, &stop, progress).await
    } else {
        // A wait only waits, as nav2_behaviors' Wait: it does not take the robot from a drive.
        let refused = || s.refusal().map(|f| BehaviorEnd::Taken(DriveEnd::NoPlan(f)));
        let interrupted = || {
            stop.requested()
                .then_some(BehaviorEnd::Stopped)
                .or_else(refused)
        };
        wait(behavior, interrupted, progress).await
    };
    if let BehaviorEnd::Succeeded = end {
        info!("{}: {behavior}: done", G::NAME);
    }
    goal_end(G::NAME, end, &stop, started, G::code)
}

/// How a behaviour's goal ends, as its action's result: succeeded; canceled or aborted on
/// request (a cancel, a newer goal of the action); aborted with the action's `code` for a
/// failure, and why; aborted with its code for UNKNOWN when the robot was taken (or the node
/// deactivated). `total_elapsed_time` counts from `started`.
pub fn goal_end(
    name: &str,
    end: BehaviorEnd,
    stop: &GoalStop,
    started: Instant,
    code: impl Fn(BehaviorFailure) -> u16,
) -> (GoalEndStatus, BehaviorResult) {
    let result = |error_code: u16, error_msg: String| BehaviorResult {
        total_elapsed_time: duration_msg(started.elapsed()),
        error_code,
        error_msg,
    };
    match end {
        BehaviorEnd::Succeeded => (GoalEndStatus::Succeeded, result(0, String::new())),
        BehaviorEnd::Stopped => (stop.end_status(), result(0, stop.reason().into())),
        BehaviorEnd::Failed(f, why) => {
            warn!("{name}: {why}");
            (GoalEndStatus::Aborted, result(code(f), why))
        }
        BehaviorEnd::Taken(end) => {
            let why = match end {
                DriveEnd::NoPlan(f) => f.message,
                _ => "preempted by a newer goal on /goal_pose or another action".into(),
            };
            (
                GoalEndStatus::Aborted,
                result(code(BehaviorFailure::Unknown), why),
            )
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_actions_codes_are_jazzys() {
        use BehaviorFailure::*;
        let spin: Vec<u16> = [Unknown, Timeout, TfError, CollisionAhead, InvalidInput]
            .map(SpinGoal::code)
            .into();
        assert_eq!(spin, [700, 701, 702, 703, 700]);
        let back: Vec<u16> = [Unknown, Timeout, TfError, InvalidInput, CollisionAhead]
            .map(BackUpGoal::code)
            .into();
        assert_eq!(back, [710, 711, 712, 713, 714]);
        let drive: Vec<u16> = [Unknown, Timeout, TfError, CollisionAhead, InvalidInput]
            .map(DriveOnHeadingGoal::code)
            .into();
        assert_eq!(drive, [720, 721, 722, 723, 724]);
        assert_eq!(WaitGoal::code(Timeout), 0);
    }

    /// As nav2_behaviors' DriveOnHeading: forwards or back as target.x says, with a speed of
    /// the same sign, only along the heading.
    #[test]
    fn a_drive_on_heading_goal_keeps_its_signs() {
        let mut g = DriveOnHeadingGoal {
            speed: -0.2,
            ..Default::default()
        };
        g.target.x = -0.5;
        assert_eq!(g.refusal(), None);
        assert!(matches!(g.behavior(), Behavior::Drive { distance, .. } if distance == -0.5));
        g.speed = 0.2;
        assert!(g.refusal().unwrap().contains("same sign"));
        g.target.x = 0.5;
        assert_eq!(g.refusal(), None);
        g.target.x = 0.0;
        assert!(g.refusal().is_some(), "0 is not above 0, the speed is");
        g.speed = -0.2;
        assert_eq!(g.refusal(), None, "and done at once");
        g.speed = 0.2;
        g.target.x = 0.5;
        g.target.z = 1.0;
        assert!(g.refusal().is_some());
    }

    #[test]
    fn a_back_up_goal_backs_up_whatever_its_signs() {
        let mut g = BackUpGoal {
            speed: 0.2,
            ..Default::default()
        };
        g.target.x = 0.4;
        let b = g.behavior();
        g.target.x = -0.4;
        g.speed = -0.2;
        assert_eq!(g.behavior(), b);
        assert!(matches!(b, Behavior::Drive { distance, speed }
            if (distance + 0.4).abs() < 1e-9 && (speed - 0.2).abs() < 1e-6));
        assert_eq!(g.refusal(), None);
        g.target.y = 0.1;
        assert!(g.refusal().is_some());
        // No allowance given: none.
        assert_eq!(g.allowance(), None);
        g.time_allowance.sec = 3;
        assert_eq!(g.allowance(), Some(Duration::from_secs(3)));
    }
}
