//! One drive to a pose, as Nav2's default navigation tree runs one without its recoveries: plan
//! from where the robot is, publish the plan, and follow it (follow.rs; a new map that blocks it
//! has it planned again, inputs.rs, and the drive goes on along the new path, with that path's
//! end and time limit) until the robot arrives, a stop is asked for (cancel, preemption), a newer
//! goal takes the robot (superseded: that goal's drive goes on), the node is deactivated
//! (lifecycle: the robot stops), or the time to drive it runs out. `navigate_to_pose` is one
//! drive; `navigate_through_poses` one through all its poses, as Nav2's through-poses tree
//! plans one path through them and drives it without stopping at each (a replan goes through
//! the poses not yet passed); `follow_waypoints` one per waypoint, stopping at each.

use crate::action_server::GoalStop;
use crate::outputs::Outputs;
use crate::planning;
use crate::result::{Failure, ResultCode};
use crate::state::{path_length, Handover, Shared};
use chassis::limits::TwistLimits;
use planner_core::geometry::Pose2;
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
    /// Planned and followed, but the robot was not there when the time to drive it ran out
    /// (stalled, blocked, no odometry). A replan that failed is [`DriveEnd::NoPlan`], with its
    /// reason.
    NotReached,
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
}

/// The time (s) a cusp of the path costs beside its half turn: the approach down to a crawl
/// (the follower regulates the speed down over its `approach_distance`) and some slack.
const CUSP_S: f64 = 15.0;

/// How often a drive checks on the follower and reports its progress.
const TICK: Duration = Duration::from_millis(100);

/// Drives through `goals` (global frame; via poses in order, then the goal, which the robot ends
/// facing) for goal `mine` (its claim on the robot, [`Shared::take_robot`]: a patrol takes it
/// once for all its legs), calling `progress` each tick while the plan is followed. Callers
/// check `follow_plan` first, before the goal takes the robot, and give at least one pose.
pub async fn drive_to<P, Fut>(
    s: &Arc<Shared>,
    o: &Outputs,
    goals: &[Pose2],
    mine: u64,
    stop: &GoalStop,
    mut progress: P,
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
    let superseded = {
        let s = s.clone();
        move || !s.owns_robot(mine)
    };
    let stop_plan = {
        let (stop, superseded) = (stop.clone(), superseded.clone());
        move || stop.requested() || superseded()
    };
    // Why the drive is no longer this goal's to go on with: the node was deactivated (its
    // reason), or a newer goal took the robot.
    let taken = || {
        s.refusal()
            .map(DriveEnd::NoPlan)
            .or_else(|| superseded().then_some(DriveEnd::Superseded))
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
        if let Some(end) = taken() {
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
        return taken().unwrap_or(DriveEnd::Superseded);
    }
    // The plan being driven: the first, then each replan around a new map (inputs.rs), which
    // brings its own end (the goal, or the free cell it was moved to) and its own time limit.
    let mut driven = Plan::default();
    if let Some(first) = s.followed.lock().expect("lock").as_ref() {
        driven.update(&first.path, &s.params.twist_limits);
    }
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
        if let Some(end) = taken() {
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
                driven.update(&now.path, &s.params.twist_limits);
            }
            let poses = followed
                .as_ref()
                .map_or(1, |now| now.poses_ahead(f.progress()));
            let remaining = robot.map(|p| {
                f.remaining(&chassis::Pose {
                    x: p.x,
                    y: p.y,
                    yaw: p.yaw,
                })
            });
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
            })
            .await;
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
    if let Some(end) = taken() {
        return end;
    }
    if let Some(f) = s.take_failed_replan(mine) {
        return DriveEnd::NoPlan(f);
    }
    DriveEnd::NotReached
}

/// The path a drive is following, as last seen on the follower.
#[derive(Default)]
struct Plan {
    /// The path, to tell a replan from it.
    path: Option<Arc<Vec<(f64, f64)>>>,
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
    fn update(&mut self, path: &Arc<Vec<(f64, f64)>>, limits: &TwistLimits) {
        if self.path.as_ref().is_some_and(|p| Arc::ptr_eq(p, path)) {
            return;
        }
        let cusps = chassis::follower::cusps(path).len() as f64;
        let per_cusp = CUSP_S + std::f64::consts::PI / limits.max_angular.max(0.05);
        let time = Duration::from_secs_f64(
            20.0 + 3.0 * path_length(path) / limits.max_linear.max(0.05) + cusps * per_cusp,
        );
        let now = Instant::now();
        let cap = *self.cap.get_or_insert(now + 3 * time);
        self.deadline = Some((now + time).min(cap));
        self.path = Some(path.clone());
    }
}
