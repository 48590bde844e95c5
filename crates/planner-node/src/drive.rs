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
use planner_core::geometry::Pose2;
use std::future::Future;
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

/// Drives to `to` (global frame) for goal `mine` (its claim on the robot,
/// [`Shared::take_robot`]: a patrol takes it once for all its legs), calling `progress` each
/// tick while the plan is followed.
pub async fn drive_to<P, Fut>(
    s: &Arc<Shared>,
    o: &Outputs,
    to: Pose2,
    mine: u64,
    stop: &GoalStop,
    mut progress: P,
) -> DriveEnd
where
    P: FnMut(Progress) -> Fut,
    Fut: Future<Output = ()>,
{
    if !s.params.follow_plan {
        return DriveEnd::NoPlan(Failure::new(
            ResultCode::Unknown,
            "follow_plan is false: this node plans only, and leaves driving to another controller",
        ));
    }
    let Some(from) = s.robot_pose().await else {
        return DriveEnd::NoPlan(Failure::new(
            ResultCode::NoStartPose,
            "no robot pose yet: publish /initialpose, /amcl_pose or /odom",
        ));
    };
    let tolerance = s.live.read().expect("lock").tolerance;
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
    let outcome = planning::plan_off_thread(s, from, to, tolerance, None, stop_plan).await;
    let Some(path) = o.publish(s, &outcome).await else {
        // No plan: the robot does not go on along an older goal's path.
        s.stop_following(mine);
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
    if !s.follow(mine, to, points, to.yaw) {
        return DriveEnd::Superseded;
    }
    // Time to drive it at a third of the speed limit, plus turning on the spot.
    let limit =
        Duration::from_secs_f64(20.0 + 3.0 * length / s.params.twist_limits.max_linear.max(0.05));
    let started = Instant::now();
    let mut last: Option<(Pose2, Instant)> = None;
    loop {
        tokio::time::sleep(TICK).await;
        // Stopping leaves a newer goal's drive be (`stop_following` checks the owner).
        if stop.requested() {
            s.stop_following(mine);
            return DriveEnd::Stopped;
        }
        if superseded() {
            return DriveEnd::Superseded;
        }
        // Deactivated (lifecycle): the node has stopped the robot already.
        if let Some(f) = s.refusal() {
            s.stop_following(mine);
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
            s.stop_following(mine);
            break;
        }
    }
    // The follower went: arrived, a failed replan, or a newer goal's plan that failed.
    if superseded() {
        return DriveEnd::Superseded;
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
