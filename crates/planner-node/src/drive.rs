//! One drive to a pose, as Nav2's default navigation tree runs one without its recoveries: plan
//! from where the robot is, publish the plan, and follow it (follow.rs; a new map that blocks it
//! has it planned again, inputs.rs) until the robot arrives, a stop is asked for (cancel,
//! preemption) or the time to drive it runs out. `navigate_to_pose` is one drive;
//! `follow_waypoints` one per waypoint.

use crate::action_server::GoalStop;
use crate::outputs::Outputs;
use crate::planning;
use crate::result::{Failure, ResultCode};
use crate::state::Shared;
use chassis::follower::Follower;
use planner_core::geometry::Pose2;
use std::future::Future;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// How a drive ended.
#[derive(Debug)]
pub enum DriveEnd {
    /// At the end of the plan (the goal, or the free cell it was moved to), within twice the
    /// follower's goal tolerance.
    Reached,
    /// Stopped on request; the robot brakes to a stop.
    Stopped,
    /// Another goal took the robot: a `/goal_pose`, or another action's drive.
    Superseded,
    /// No plan, and the planner's reason (on `/diagnostics` too).
    NoPlan(Failure),
    /// Planned and followed, but the robot was not there when the time to drive it ran out
    /// (stalled, blocked, no odometry).
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
}

/// How often a drive checks on the follower and reports its progress.
const TICK: Duration = Duration::from_millis(100);

/// Drives to `to` (global frame), calling `progress` each tick while the plan is followed.
pub async fn drive_to<P, Fut>(
    s: &Arc<Shared>,
    o: &Outputs,
    to: Pose2,
    stop: &GoalStop,
    mut progress: P,
) -> DriveEnd
where
    P: FnMut(Progress) -> Fut,
    Fut: Future<Output = ()>,
{
    let Some(from) = s.start.read().expect("lock").map(|(p, _)| p) else {
        return DriveEnd::NoPlan(Failure::new(
            ResultCode::NoStartPose,
            "no robot pose yet: publish /initialpose, /amcl_pose or /odom",
        ));
    };
    let tolerance = s.live.read().expect("lock").tolerance;
    // The robot is this drive's now: a plan for an older goal, or another drive, sees the count
    // move on and stops; so does this one when a newer goal comes.
    let mine = s.goals.fetch_add(1, Ordering::SeqCst) + 1;
    let superseded = {
        let s = s.clone();
        move || s.goals.load(Ordering::SeqCst) != mine
    };
    let stop_plan = {
        let (stop, superseded) = (stop.clone(), superseded.clone());
        move || stop.requested() || superseded()
    };
    let outcome = planning::plan_off_thread(s, from, to, tolerance, None, stop_plan).await;
    let Some(path) = o.publish(s, &outcome).await else {
        // No plan: the robot does not go on along an older goal's path.
        release(s, mine);
        if stop.requested() {
            return DriveEnd::Stopped;
        }
        if superseded() {
            return DriveEnd::Superseded;
        }
        let why = outcome.result.err().unwrap_or_else(|| {
            Failure::new(ResultCode::Unknown, "the plan could not be published")
        });
        return DriveEnd::NoPlan(why);
    };
    let points: Vec<(f64, f64)> = path
        .poses
        .iter()
        .map(|q| (q.pose.position.x, q.pose.position.y))
        .collect();
    let length: f64 = points
        .windows(2)
        .map(|w| (w[1].0 - w[0].0).hypot(w[1].1 - w[0].1))
        .sum();
    // Reached where the plan ends: the goal, or the free cell it was moved to.
    let target = points.last().copied().unwrap_or((to.x, to.y));
    *s.followed.lock().expect("lock") = Some((to, points.clone()));
    *s.follower.lock().expect("lock") = Follower::new(s.params.follower, points, to.yaw);
    // Time to drive it at a third of the speed limit, plus turning on the spot.
    let limit =
        Duration::from_secs_f64(20.0 + 3.0 * length / s.params.twist_limits.max_linear.max(0.05));
    let started = Instant::now();
    let mut last: Option<(Pose2, Instant)> = None;
    loop {
        tokio::time::sleep(TICK).await;
        // A newer goal's drive owns the follower now (release leaves it be).
        if stop.requested() {
            release(s, mine);
            return DriveEnd::Stopped;
        }
        if superseded() {
            return DriveEnd::Superseded;
        }
        // Deactivated (lifecycle): the node has stopped the robot already.
        if let Some(f) = s.refusal() {
            release(s, mine);
            return DriveEnd::NoPlan(f);
        }
        let robot = s.odom.read().expect("lock").map(|(p, _)| p);
        // The follower's own remaining length (it may have been replaced by a replan).
        let remaining = {
            let follower = s.follower.lock().expect("lock");
            match (follower.as_ref(), robot) {
                (None, _) => break,
                (Some(f), Some(p)) => Some(f.remaining(&chassis::Pose {
                    x: p.x,
                    y: p.y,
                    yaw: p.yaw,
                })),
                (Some(_), None) => None,
            }
        };
        if let (Some(robot), Some(remaining_m)) = (robot, remaining) {
            let now = Instant::now();
            let speed = last.map_or(0.0, |(p, t)| {
                (robot.x - p.x).hypot(robot.y - p.y) / (now - t).as_secs_f64().max(1e-3)
            });
            last = Some((robot, now));
            progress(Progress {
                robot,
                remaining_m,
                speed,
            })
            .await;
        }
        if started.elapsed() > limit {
            release(s, mine);
            break;
        }
    }
    let at = s.odom.read().expect("lock").map(|(p, _)| p);
    let reached = at.is_some_and(|p| {
        (p.x - target.0).hypot(p.y - target.1) <= 2.0 * s.params.follower.goal_tolerance
    });
    if reached {
        DriveEnd::Reached
    } else {
        DriveEnd::NotReached
    }
}

/// Ends drive `mine`: the follower loop brakes within the acceleration limits to a stop. Not
/// when a newer goal has taken the robot: its plan, or the one about to come, is not ours to
/// end (a preempted drive noticing its stop after the newer one has started).
fn release(s: &Shared, mine: u64) {
    let mut follower = s.follower.lock().expect("lock");
    if s.goals.load(Ordering::SeqCst) == mine {
        *follower = None;
        *s.followed.lock().expect("lock") = None;
    }
}
