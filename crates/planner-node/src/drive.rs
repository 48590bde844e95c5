//! One drive to a pose, as Nav2's default navigation tree runs one: plan from where the robot
//! is, publish the plan, and follow it (follow.rs; a new map that blocks it has it planned
//! again, inputs.rs, and the drive goes on along the new path, with that path's end and time
//! limit) until the robot arrives, a stop is asked for (cancel, preemption), a newer goal takes
//! the robot (superseded: that goal's drive goes on), the node is deactivated (lifecycle: the
//! robot stops), the robot makes no progress (`progress_checker`, as controller_server's), or
//! the time to drive it runs out. A failure a recovery may help (no progress or out of time,
//! no valid path, a planner timeout or unknown error) is tried again after a recovery, as
//! Nav2's trees retry (`recovery`): the robot stops, forgets what the scans marked, spins,
//! waits or backs up (behaviors.rs; one in turn), and the drive plans again from where it is. `navigate_to_pose` is one drive; `navigate_through_poses` one through all its poses,
//! as Nav2's through-poses tree plans one path through them and drives it without stopping at
//! each (a replan or a retry goes through the poses not yet passed); `follow_waypoints` one per
//! waypoint, stopping at each.

use crate::action_server::GoalStop;
use crate::behaviors::{self, Behavior, BehaviorEnd};
use crate::convert::chassis_pose;
use crate::outputs::Outputs;
use crate::planning;
use crate::result::{Failure, ResultCode};
use crate::state::{path_length, Handover, Shared};
use chassis::limits::TwistLimits;
use chassis::progress::ProgressChecker;
use log::{info, warn};
use planner_core::geometry::Pose2;
use planner_io::parameters::RecoveryBehavior;
use ros2_client::action::GoalEndStatus;
use std::future::Future;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// How a drive ended.
#[derive(Debug)]
pub enum DriveEnd {
    /// At the end of the plan (the goal, or the free cell it was moved to): the follower
    /// finished it, within its position and heading tolerances.
    Reached,
    /// Stopped on request; the robot brakes to a stop.
    Stopped,
    /// Another goal took the robot: a `/goal_pose`, or another action's drive.
    Superseded,
    /// No plan, and the planner's reason (on `/diagnostics` too).
    NoPlan(Failure),
    /// Planned and followed, but the robot did not get there: it made no progress (stalled,
    /// blocked, no odometry), or the time to drive the plan ran out; the reason says which. A
    /// replan that failed is [`DriveEnd::NoPlan`], with its reason.
    NotReached(String),
}

impl DriveEnd {
    /// Whether a recovery may help, as Nav2's `WouldAControllerRecoveryHelp` (no progress) and
    /// `WouldAPlannerRecoveryHelp` (no valid path, a timeout, an unknown error) judge: a goal
    /// outside the map or occupied, a bad frame, a stop or a newer goal is not tried again.
    pub fn recovery_may_help(&self) -> bool {
        match self {
            DriveEnd::NotReached(_) => true,
            DriveEnd::NoPlan(f) => matches!(
                f.code,
                ResultCode::NoValidPath | ResultCode::Timeout | ResultCode::Unknown
            ),
            DriveEnd::Reached | DriveEnd::Stopped | DriveEnd::Superseded => false,
        }
    }

    /// What went wrong, for the log: the drive's reason or the planner's.
    fn reason(&self) -> String {
        match self {
            DriveEnd::NotReached(why) => why.clone(),
            DriveEnd::NoPlan(f) => f.message.clone(),
            DriveEnd::Reached => "reached".into(),
            DriveEnd::Stopped => "stopped".into(),
            DriveEnd::Superseded => "superseded".into(),
        }
    }
}

/// FollowPath's FAILED_TO_MAKE_PROGRESS (controller_server's code, which bt_navigator passes
/// on): the plan was followed but not to its end in time, or the robot made no progress.
pub const FAILED_TO_MAKE_PROGRESS: u16 = 105;

/// How the drive of an action's goal ended, as that goal's end: its status, error code and
/// message (navigate_to_pose, navigate_through_poses: navigate.rs; follow_path:
/// follow_path.rs). Succeeded at `to`; canceled or aborted on request (a cancel, a newer goal
/// of the same action), code 0; aborted with code 0 when another goal took the robot; with
/// `no_plan`'s code for a failed plan; with FAILED_TO_MAKE_PROGRESS when it did not get there.
/// Each end is logged.
pub(crate) fn action_end(
    name: &str,
    end: DriveEnd,
    stop: &GoalStop,
    to: Pose2,
    started: Instant,
    no_plan: impl FnOnce(&Failure) -> u16,
) -> (GoalEndStatus, u16, String) {
    let failed = |error_code: u16, error_msg: String| {
        warn!("{name}: {error_code}: {error_msg}");
        (GoalEndStatus::Aborted, error_code, error_msg)
    };
    match end {
        DriveEnd::Reached => {
            info!(
                "{name}: reached ({:.2}, {:.2}) in {:.1} s",
                to.x,
                to.y,
                started.elapsed().as_secs_f64()
            );
            (GoalEndStatus::Succeeded, 0, String::new())
        }
        DriveEnd::Stopped => {
            let why = stop.reason();
            info!("{name}: {why}");
            (stop.end_status(), 0, why.into())
        }
        DriveEnd::Superseded => failed(
            0,
            "preempted by a newer goal on /goal_pose or another action".into(),
        ),
        DriveEnd::NoPlan(f) => failed(no_plan(&f), f.message),
        DriveEnd::NotReached(why) => failed(FAILED_TO_MAKE_PROGRESS, why),
    }
}

/// Where a drive stands, each tick, for an action's feedback.
#[derive(Clone, Copy, Debug)]
pub struct Progress {
    /// The robot's pose in the global frame.
    pub robot: Pose2,
    /// The path still to drive (m), as Nav2's `distance_remaining`.
    pub remaining_m: f64,
    /// The robot's speed over the last tick (m/s).
    pub speed: f64,
    /// The poses still ahead, the goal included, as Nav2's `number_of_poses_remaining`.
    pub poses_remaining: usize,
    /// The recoveries so far, as Nav2's `number_of_recoveries`.
    pub recoveries: u16,
}

/// The time (s) a cusp of the path costs beside its half turn: the approach down to a crawl
/// (the follower regulates the speed down over its `approach_distance`) and some slack.
const CUSP_S: f64 = 15.0;

/// How often a drive checks on the follower and reports its progress.
const TICK: Duration = Duration::from_millis(100);

/// Drives through `goals` (global frame; via poses in order, then the goal, which the robot ends
/// facing) for goal `mine` (its claim on the robot, [`Shared::take_robot`]: a patrol takes it
/// once for all its legs), calling `progress` each tick while the plan is followed or a
/// recovery's behaviour runs, and at once when a recovery starts. A failure a recovery may help is tried again up to
/// `recovery.number_of_retries` times, each after a recovery behaviour (behaviors.rs), taken in
/// turn from `recovery.behaviors` as Nav2's trees' round robin takes them: the robot stops and
/// spins, waits or backs up, and the drive plans again from where it is, through the poses it
/// has not passed yet. A behaviour that fails (a spin or back-up that would hit something, or
/// runs out of time) hands over to the next; when every one has failed, so has the drive, with
/// its own failure. Served only with `follow_plan` (the follower loop drives); callers give at
/// least one pose.
pub async fn drive_to<P, Fut>(
    s: &Arc<Shared>,
    o: &Outputs,
    goals: &[Pose2],
    mine: u64,
    stop: &GoalStop,
    progress: P,
) -> DriveEnd
where
    P: FnMut(Progress) -> Fut,
    Fut: Future<Output = ()>,
{
    let turn = RoundRobin::new(s);
    drive_with_recoveries(s, o, goals, mine, stop, progress, turn, 0).await
}

/// [`drive_to`] after `recoveries` recoveries already made, the next behaviour `turn`'s.
#[allow(clippy::too_many_arguments)]
async fn drive_with_recoveries<P, Fut>(
    s: &Arc<Shared>,
    o: &Outputs,
    goals: &[Pose2],
    mine: u64,
    stop: &GoalStop,
    mut progress: P,
    mut turn: RoundRobin,
    mut recoveries: u16,
) -> DriveEnd
where
    P: FnMut(Progress) -> Fut,
    Fut: Future<Output = ()>,
{
    let retries = s.params.recovery.number_of_retries;
    let mut ahead = goals;
    loop {
        let mut last: Option<Progress> = None;
        let end = drive_once(s, o, ahead, mine, stop, |p: Progress| {
            let p = Progress { recoveries, ..p };
            last = Some(p);
            progress(p)
        })
        .await;
        if u32::from(recoveries) >= retries || !end.recovery_may_help() {
            return end;
        }
        recoveries += 1;
        let why = end.reason();
        warn!("drive for goal {mine}: {why}; recovery {recoveries} of {retries}");
        // The recovery is reported at once, even when no plan was followed (no path found):
        // from the last tick, or from where the robot is, the goal's straight distance away.
        let goal = ahead[ahead.len() - 1];
        let robot_now = || s.odom.read().expect("lock").map(|(p, _)| p);
        // Standing (or in a recovery's motion), following no plan.
        let standing = |robot: Pose2, poses_remaining| Progress {
            robot,
            remaining_m: (goal.x - robot.x).hypot(goal.y - robot.y),
            speed: 0.0,
            poses_remaining,
            recoveries,
        };
        let report = last
            .map(|p| Progress { recoveries, ..p })
            .or_else(|| Some(standing(robot_now()?, ahead.len())));
        if let Some(p) = report {
            progress(p).await;
        }
        // The robot (stopped by drive_once) makes the next behaviour that works; the feedback
        // follows it (its pose, the goal's straight distance: no plan is followed meanwhile).
        let during = |_| {
            let tick = report
                .zip(robot_now())
                .map(|(p, robot)| standing(robot, p.poses_remaining));
            let sent = tick.map(&mut progress);
            async move {
                if let Some(sent) = sent {
                    sent.await;
                }
            }
        };
        match turn.recover(s, mine, stop, during).await {
            Recovered::Yes => {}
            Recovered::Stopped => return DriveEnd::Stopped,
            Recovered::Taken(end) => return end,
            Recovered::AllFailed(how) => {
                warn!("drive for goal {mine}: every recovery failed ({how})");
                return end;
            }
        }
        // Through the poses not passed yet (the goal always).
        if let Some(p) = last {
            ahead = &ahead[ahead.len() - p.poses_remaining.clamp(1, ahead.len())..];
        }
    }
}

/// Hands `/goal_pose` goal `mine`, whose plan failed or whose drive made no progress (`end`),
/// to its recoveries ([`recover_topic_goal`]) when a recovery may help, as bt_navigator's tree
/// recovers the navigate_to_pose goal it makes of a click: a failed ComputePathToPose and a
/// stalled FollowPath alike. `goals` are the poses it has not passed (the goal last). Returns
/// whether it did; if not, the goal's navigation is the caller's to end.
pub fn hand_topic_goal_to_recoveries(
    s: &Arc<Shared>,
    o: &Outputs,
    goals: Vec<Pose2>,
    mine: u64,
    end: DriveEnd,
) -> bool {
    let retries = s.params.recovery.number_of_retries;
    let helps = retries > 0 && !goals.is_empty() && end.recovery_may_help();
    // Handed over here, before anything else can end its navigation.
    if !(helps && s.hand_topic_goal_to_drive(mine)) {
        return false;
    }
    let why = end.reason();
    tokio::spawn(recover_topic_goal(s.clone(), o.clone(), goals, mine, why));
    true
}

/// A `/goal_pose` goal (`mine`) whose plan failed or whose drive made no progress (`why`),
/// recovered as bt_navigator recovers the navigate_to_pose goal it makes of one: the robot
/// (stopped) makes the first recovery behaviour, and the goal is planned again and driven
/// through `goals` (the poses it had not passed) as [`drive_to`] drives, with the recoveries
/// left. Its navigation, handed to this drive first ([`Shared::hand_topic_goal_to_drive`]),
/// ends with it. No action reports on it: the end is logged, and the robot stopped unless it
/// arrived.
async fn recover_topic_goal(s: Arc<Shared>, o: Outputs, goals: Vec<Pose2>, mine: u64, why: String) {
    let retries = s.params.recovery.number_of_retries;
    let stop = GoalStop::never();
    let mut turn = RoundRobin::new(&s);
    warn!("goal {mine} from /goal_pose: {why}; recovery 1 of {retries}");
    let end = match turn.recover(&s, mine, &stop, |_| async {}).await {
        Recovered::Yes => {
            let no_feedback = |_| async {};
            drive_with_recoveries(&s, &o, &goals, mine, &stop, no_feedback, turn, 1).await
        }
        Recovered::Stopped => DriveEnd::Stopped,
        Recovered::Taken(end) => end,
        Recovered::AllFailed(how) => {
            DriveEnd::NotReached(format!("{why}; every recovery failed ({how})"))
        }
    };
    match &end {
        DriveEnd::Reached => info!("goal {mine} from /goal_pose reached after recoveries"),
        DriveEnd::Superseded => info!("goal {mine} from /goal_pose superseded by a newer goal"),
        DriveEnd::Stopped => {}
        DriveEnd::NoPlan(f) => warn!("goal {mine} from /goal_pose given up: {}", f.message),
        DriveEnd::NotReached(why) => warn!("goal {mine} from /goal_pose given up: {why}"),
    }
    s.stop_following(mine);
    s.done_navigating(mine);
}

/// The recovery behaviours of one drive, taken in turn (Nav2's `RoundRobin`): each recovery
/// starts with the one after the last that ran.
struct RoundRobin {
    behaviors: Vec<Step>,
    allowance: Duration,
    next: usize,
}

/// One recovery behaviour of the round robin.
#[derive(Clone, Copy, Debug)]
enum Step {
    /// Forget what the scans marked (the tree's ClearingActions); with nothing marked it
    /// cannot help, and the round robin goes on to the next behaviour at once.
    Clear,
    /// A motion of the behavior server's.
    Move(Behavior),
}

/// How one recovery went.
enum Recovered {
    Yes,
    Stopped,
    Taken(DriveEnd),
    /// Every behaviour failed; how each did.
    AllFailed(String),
}

impl RoundRobin {
    fn new(s: &Shared) -> Self {
        let r = &s.params.recovery;
        let behaviors = r
            .behaviors
            .iter()
            .map(|b| match b {
                RecoveryBehavior::Clear => Step::Clear,
                RecoveryBehavior::Spin => Step::Move(Behavior::Spin(r.spin_dist)),
                RecoveryBehavior::Wait => {
                    Step::Move(Behavior::Wait(Duration::from_secs_f64(r.wait_duration)))
                }
                RecoveryBehavior::Backup => Step::Move(Behavior::Drive {
                    distance: -r.backup_dist,
                    speed: r.backup_speed,
                }),
            })
            .collect();
        Self {
            behaviors,
            allowance: Duration::from_secs_f64(r.time_allowance),
            next: 0,
        }
    }

    /// Makes behaviours in turn until one succeeds (or all have failed).
    async fn recover<P, Fut>(
        &mut self,
        s: &Arc<Shared>,
        mine: u64,
        stop: &GoalStop,
        mut progress: P,
    ) -> Recovered
    where
        P: FnMut(f64) -> Fut,
        Fut: Future<Output = ()>,
    {
        let mut failures = Vec::new();
        for _ in 0..self.behaviors.len() {
            let step = self.behaviors[self.next];
            self.next = (self.next + 1) % self.behaviors.len();
            let Step::Move(behavior) = step else {
                let had = s
                    .clear_obstacles_off_thread(None)
                    .await
                    .ok()
                    .flatten()
                    .map_or(0, |(before, _)| before);
                if had == 0 {
                    // Nothing seen to clear cannot help: the next behaviour, in this recovery.
                    failures.push("nothing seen to clear".to_string());
                    continue;
                }
                info!("drive for goal {mine}: recovery: the obstacles seen cleared ({had} cells were marked)");
                return Recovered::Yes;
            };
            info!("drive for goal {mine}: recovery: {behavior}");
            let allowance = Some(self.allowance);
            match behaviors::run(s, behavior, allowance, mine, stop, &mut progress).await {
                BehaviorEnd::Succeeded => return Recovered::Yes,
                BehaviorEnd::Stopped => return Recovered::Stopped,
                BehaviorEnd::Taken(end) => return Recovered::Taken(end),
                BehaviorEnd::Failed(_, why) => {
                    warn!("drive for goal {mine}: recovery failed: {why}");
                    failures.push(why);
                }
            }
        }
        Recovered::AllFailed(failures.join("; "))
    }
}

/// Why a drive is no longer goal `mine`'s to go on with: the node was deactivated (its reason),
/// or a newer goal took the robot.
pub(crate) fn taken(s: &Shared, mine: u64) -> Option<DriveEnd> {
    s.refusal()
        .map(DriveEnd::NoPlan)
        .or_else(|| (!s.owns_robot(mine)).then_some(DriveEnd::Superseded))
}

/// One try of [`drive_to`]: plan once, follow until it ends.
async fn drive_once<P, Fut>(
    s: &Arc<Shared>,
    o: &Outputs,
    goals: &[Pose2],
    mine: u64,
    stop: &GoalStop,
    progress: P,
) -> DriveEnd
where
    P: FnMut(Progress) -> Fut,
    Fut: Future<Output = ()>,
{
    let Some(from) = s.robot_pose().await else {
        return DriveEnd::NoPlan(Failure::new(
            ResultCode::NoStartPose,
            "no robot pose yet: publish /initialpose, /amcl_pose or /odom",
        ));
    };
    let tolerance = s.live.read().expect("lock").tolerance;
    let started = Instant::now();
    // A newer goal (`/goal_pose`, another action's) takes the robot from this drive; a replan
    // of this drive's own path (a new map blocks it, inputs.rs) keeps it.
    let stop_plan = {
        let (s, stop) = (s.clone(), stop.clone());
        move || stop.requested() || !s.owns_robot(mine)
    };
    let outcome =
        planning::plan_off_thread(s, from, goals.to_vec(), tolerance, None, stop_plan).await;
    let published = o.publish(s, &outcome).await;
    let (Some(path), Ok((plan, goal_yaw))) = (published, &outcome.result) else {
        // No plan: the robot does not go on along an older goal's path.
        s.stop_following(mine);
        if stop.requested() {
            return DriveEnd::Stopped;
        }
        if let Some(end) = taken(s, mine) {
            return end;
        }
        let why = outcome.result.as_ref().err().cloned().unwrap_or_else(|| {
            Failure::new(ResultCode::Unknown, "the plan could not be published")
        });
        return DriveEnd::NoPlan(why);
    };
    if !s.follow(
        mine,
        Handover::new(goals.to_vec(), &path, &plan.via, *goal_yaw),
    ) {
        return taken(s, mine).unwrap_or(DriveEnd::Superseded);
    }
    watch_followed(s, mine, stop, started, progress).await
}

/// Watches goal `mine`'s path, handed to the follower since `started`, until it ends: arrived,
/// stopped on request, taken by a newer goal or a deactivation, no progress, or out of time
/// (calling `progress` each tick). Shared by a drive's own plans and `follow_path`'s given
/// path (follow_path.rs).
pub(crate) async fn watch_followed<P, Fut>(
    s: &Arc<Shared>,
    mine: u64,
    stop: &GoalStop,
    started: Instant,
    mut progress: P,
) -> DriveEnd
where
    P: FnMut(Progress) -> Fut,
    Fut: Future<Output = ()>,
{
    // The plan being driven: the first, then each replan around a new map (inputs.rs), which
    // brings its own end (the goal, or the free cell it was moved to) and its own time limit.
    let mut driven = Plan::default();
    if let Some(first) = s.followed.lock().expect("lock").as_ref() {
        driven.update(&first.path, &s.drive_limits(), Instant::now());
    }
    let mut watch = StallWatch::new(s);
    let mut stuck = None;
    loop {
        tokio::time::sleep(TICK).await;
        // Arrived within the last tick: reached, whatever came after (a cancel, a newer goal).
        if s.arrived_since(mine, started) {
            return DriveEnd::Reached;
        }
        // Stopping leaves a newer goal's drive be (`stop_following` checks the owner).
        if stop.requested() {
            s.stop_following(mine);
            return DriveEnd::Stopped;
        }
        // Deactivated (lifecycle): the node stops the robot; so does the drive, in case it
        // looked first (a newer goal's drive is left be: `stop_following` checks the owner).
        if let Some(end) = taken(s, mine) {
            s.stop_following(mine);
            return end;
        }
        let robot = s.odom.read().expect("lock").map(|(p, _)| p);
        // The follower's own remaining length and poses (it may have been replaced by a
        // replan).
        let (remaining, poses_remaining) = {
            let follower = s.follower.lock().expect("lock");
            let Some(f) = follower.as_ref() else { break };
            let followed = s.followed.lock().expect("lock");
            if let Some(now) = followed.as_ref() {
                driven.update(&now.path, &s.drive_limits(), Instant::now());
            }
            let poses = followed
                .as_ref()
                .map_or(1, |now| now.poses_ahead(f.progress()));
            let remaining = robot.map(|p| f.remaining(&chassis_pose(p)));
            (remaining, poses)
        };
        if let (Some(robot), Some(remaining_m)) = (robot, remaining) {
            let now = Instant::now();
            let speed = driven.last.map_or(0.0, |(p, t)| {
                (robot.x - p.x).hypot(robot.y - p.y) / (now - t).as_secs_f64().max(1e-3)
            });
            driven.last = Some((robot, now));
            progress(Progress {
                robot,
                remaining_m,
                speed,
                poses_remaining,
                recoveries: 0,
            })
            .await;
        }
        if let Some(why) = watch.stuck(robot) {
            stuck = Some(why);
            s.stop_following(mine);
            break;
        }
        if driven.deadline.is_some_and(|d| Instant::now() > d) {
            s.stop_following(mine);
            break;
        }
    }
    // The follower went (arrived, a failed replan, a deactivation, a newer goal), or the time
    // to drive it ran out. Arrived is the follower's word (it finished this goal's path,
    // whichever replan it was on), not where the robot is: a route may end where it started.
    if s.arrived_since(mine, started) {
        return DriveEnd::Reached;
    }
    if let Some(end) = taken(s, mine) {
        return end;
    }
    if let Some(f) = s.take_failed_replan(mine) {
        return DriveEnd::NoPlan(f);
    }
    DriveEnd::NotReached(stuck.unwrap_or_else(|| {
        "the robot did not reach the end of its plan within the time to drive it".into()
    }))
}

/// A drive's progress checker, on the drive's own clock.
pub struct StallWatch {
    checker: ProgressChecker,
    started: Instant,
}

impl StallWatch {
    /// Starts watching now, with the node's `progress_checker` parameters.
    pub fn new(s: &Shared) -> Self {
        Self {
            checker: ProgressChecker::new(s.params.progress_checker),
            started: Instant::now(),
        }
    }

    /// Takes the robot's pose now (`None`: no fresh odometry); says why the robot is stuck once
    /// it has made no progress for longer than the allowance.
    pub fn stuck(&mut self, robot: Option<Pose2>) -> Option<String> {
        let pose = robot.map(chassis_pose);
        let t = self.started.elapsed().as_secs_f64();
        (!self.checker.check(pose.as_ref(), t)).then(|| {
            let p = self.checker.params();
            format!(
                "the robot made no progress: it neither moved {} m nor turned {} rad in {} s",
                p.required_movement_radius, p.required_movement_angle, p.movement_time_allowance
            )
        })
    }
}

/// The path a drive is following, as last seen on the follower.
#[derive(Default)]
struct Plan {
    /// The path, to tell a replan from it.
    path: Option<Arc<Vec<(f64, f64)>>>,
    /// The top speed its time was reckoned at, to tell a new speed limit from it.
    speed: f64,
    /// When the time to drive it runs out.
    deadline: Option<Instant>,
    /// When the whole drive's time runs out, replans and all: three times the first plan's, so a
    /// map that keeps blocking the path does not keep the drive going for ever.
    cap: Option<Instant>,
    /// The robot's pose at the last tick and when, for its speed.
    last: Option<(Pose2, Instant)>,
}

impl Plan {
    /// Takes `path` as the plan if it is a new one (the first, or a replan), with the time to
    /// drive it from now: its length at a third of the top speed, 20 s for turning on the spot,
    /// and for each cusp (chassis::follower::cusps), where the robot slows to a stop and turns
    /// round, [`CUSP_S`] and a half turn at the top turn rate (not beyond the drive's cap).
    ///
    /// A new speed limit (`limits.max_linear` changed) stretches what is left of the plan's
    /// time and of the cap by the ratio of the old top speed to the new: a slow zone may take
    /// far longer than the plan was given, and a limit that keeps changing gives the drive no
    /// more time than driving at each speed in turn would (resetting the cap instead would let
    /// a flapping limit keep a hopeless drive going for ever).
    fn update(&mut self, path: &Arc<Vec<(f64, f64)>>, limits: &TwistLimits, now: Instant) {
        let speed = limits.max_linear.max(0.05);
        if self.path.is_some() && self.speed != speed {
            let stretch = self.speed / speed;
            self.deadline = self.deadline.map(|t| stretched(now, t, stretch));
            self.cap = self.cap.map(|t| stretched(now, t, stretch));
        }
        self.speed = speed;
        if self.path.as_ref().is_some_and(|p| Arc::ptr_eq(p, path)) {
            return;
        }
        let cusps = chassis::follower::cusps(path).len() as f64;
        let per_cusp = CUSP_S + std::f64::consts::PI / limits.max_angular.max(0.05);
        let time =
            Duration::from_secs_f64(20.0 + 3.0 * path_length(path) / speed + cusps * per_cusp);
        let cap = *self.cap.get_or_insert(now + 3 * time);
        self.deadline = Some((now + time).min(cap));
        self.path = Some(path.clone());
    }
}

/// `then` as seen from `now`, with the time left until it multiplied by `stretch` (a day at
/// most: the time of a drive, not a number to overflow).
fn stretched(now: Instant, then: Instant, stretch: f64) -> Instant {
    let left = then.saturating_duration_since(now).as_secs_f64() * stretch;
    now + Duration::from_secs_f64(left.clamp(0.0, 86_400.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A slow zone stretches the time left by the ratio of the speeds; a limit that comes and
    /// goes gives the drive the time its slow spells cost and no more, however often it flaps
    /// (a second at a tenth of the speed is worth a tenth of a second's driving).
    #[test]
    fn a_speed_limit_stretches_the_time_left_and_a_flapping_one_gives_no_more() {
        let path = Arc::new(vec![(0.0, 0.0), (30.0, 0.0)]);
        let fast = TwistLimits::default();
        let slow = TwistLimits {
            max_linear: fast.max_linear / 10.0,
            ..fast
        };
        let t0 = Instant::now();
        let at = |s: f64| t0 + Duration::from_secs_f64(s);
        let mut plan = Plan::default();
        plan.update(&path, &fast, t0);
        // 20 s + 3 x 30 m / 0.6 m/s; the cap three times that.
        let (deadline, cap) = (plan.deadline.unwrap(), plan.cap.unwrap());
        assert!((deadline - t0).as_secs_f64() > 169.0 && (deadline - t0).as_secs_f64() < 171.0);
        assert_eq!(cap - t0, 3 * (deadline - t0));

        plan.update(&path, &slow, at(100.0));
        let left = plan.deadline.unwrap() - at(100.0);
        assert!(
            (left.as_secs_f64() - 700.0).abs() < 0.01,
            "70 s left, ten times slower: {left:?}"
        );

        for i in 0..100 {
            let s = 101.0 + 2.0 * f64::from(i);
            plan.update(&path, &fast, at(s));
            plan.update(&path, &slow, at(s + 1.0));
        }
        plan.update(&path, &fast, at(301.0));
        // 101 s spent at a tenth of the speed: the cap moves 0.9 s for each.
        let drift = (plan.cap.unwrap() - cap).as_secs_f64();
        assert!(
            (drift - 90.9).abs() < 0.1,
            "the flapping limit moved the cap by {drift} s"
        );
    }

    /// As Nav2's `WouldAControllerRecoveryHelp` and `WouldAPlannerRecoveryHelp`: no progress, no
    /// valid path, a timeout and an unknown error are tried again; a bad goal, a stop or a newer
    /// goal are not.
    #[test]
    fn only_failures_a_recovery_may_help_are_tried_again() {
        let no_plan = |code| DriveEnd::NoPlan(Failure::new(code, "why"));
        assert!(DriveEnd::NotReached("stuck".into()).recovery_may_help());
        for code in [
            ResultCode::NoValidPath,
            ResultCode::Timeout,
            ResultCode::Unknown,
        ] {
            assert!(no_plan(code).recovery_may_help(), "{code:?}");
        }
        for code in [
            ResultCode::GoalOccupied,
            ResultCode::StartOccupied,
            ResultCode::GoalOutsideMap,
            ResultCode::TfError,
            ResultCode::NotActive,
            ResultCode::NoMap,
        ] {
            assert!(!no_plan(code).recovery_may_help(), "{code:?}");
        }
        for end in [DriveEnd::Reached, DriveEnd::Stopped, DriveEnd::Superseded] {
            assert!(!end.recovery_may_help(), "{end:?}");
        }
    }
}
