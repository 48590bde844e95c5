//! Patrols: Nav2's `follow_waypoints` action (nav2_msgs/FollowWaypoints, Jazzy), driven by this
//! node itself. The waypoints are put in the fastest order first (planner-core's route ordering:
//! Held-Karp up to 12 points, 2-opt/Or-opt above, with the driving-time model at the chassis'
//! limits; `order_waypoints`), then each leg is planned from where the robot is, followed, finished
//! facing the waypoint's heading, and paused at for `waypoint_pause_duration` (Nav2's
//! WaitAtWaypoint) and, with `input_at_waypoint`, waited at for a word from the inspection done
//! there (Nav2's InputAtWaypoint); `number_of_loops` more passes follow, the first starting at
//! `goal_index` as Nav2's does. A waypoint that cannot be planned to or reached in time is reported
//! missed (its index in the request and the planner's Nav2 code; at most [`MAX_MISSED`] listed)
//! and the patrol goes on, or ends aborted with `stop_on_failure`; a pass that reaches none of
//! its waypoints ends it (TASK_EXECUTOR_FAILED). Cancel stops the planning of the leg and the
//! robot, within the acceleration limits.

use crate::action_server::{Feedback, GoalStop, Preemption};
use crate::actions::nav2_code;
use crate::drive::{drive_to, DriveEnd};
use crate::outputs::Outputs;
use crate::photo_at_waypoint::{self, FRAME_WAIT};
use crate::state::Shared;
use log::{info, warn};
use patrol_msgs::nav2_msgs::{
    FollowWaypointsFeedback, FollowWaypointsGoal, FollowWaypointsResult, MissedWaypoint,
};
use planner_core::geometry::Pose2;
use planner_core::route::file::{RouteFile, RoutePoint, RoutePose};
use planner_core::route::{plan_route, RouteOptions};
use ros2_client::action::{AsyncActionServer, GoalEndStatus};
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// FollowWaypoints' TASK_EXECUTOR_FAILED: the code of a waypoint not reached in time, or
/// whose input did not come (`input_at_waypoint`).
const TASK_EXECUTOR_FAILED: u16 = 601;

/// The most missed waypoints a result lists. A patrol of many passes (`number_of_loops` is a
/// u32) may miss a waypoint on every one; later misses are logged, not kept.
const MAX_MISSED: usize = 1_000;

pub type Server =
    AsyncActionServer<FollowWaypointsGoal, FollowWaypointsResult, FollowWaypointsFeedback>;

/// Serves `follow_waypoints` until the node stops; a newer patrol preempts the running one
/// (the door: action_server.rs).
pub async fn serve(s: Arc<Shared>, o: Outputs, server: Server) {
    crate::action_server::serve(s, o, "follow_waypoints", Preemption::Newest, server, patrol).await
}

/// The order to visit `poses` in from `robot`: the route planner's over the current map, or the
/// given order when ordering is off or impossible (the reason is logged).
fn visiting_order(s: &Shared, robot: Pose2, poses: &[Pose2]) -> Vec<usize> {
    let given: Vec<usize> = (0..poses.len()).collect();
    if !s.params.order_waypoints || poses.len() < 3 {
        return given;
    }
    let Some(map) = s.current_map() else {
        return given;
    };
    let file = RouteFile {
        start: Some(RoutePose {
            x: robot.x,
            y: robot.y,
            yaw: robot.yaw,
        }),
        home: None,
        points: poses
            .iter()
            .enumerate()
            .map(|(i, p)| RoutePoint {
                name: format!("w{i}"),
                x: p.x,
                y: p.y,
                yaw: p.yaw,
                dwell: s.params.waypoint_pause_duration,
            })
            .collect(),
    };
    match plan_route(&map.grid, &file, &RouteOptions::default(), None) {
        Ok(plan) => {
            let mut order: Vec<usize> = plan
                .order
                .iter()
                .filter_map(|n| n.strip_prefix('w').and_then(|i| i.parse().ok()))
                .collect();
            // Skipped (unreachable) points still get their turn, to be reported missed.
            let rest: Vec<usize> = given
                .iter()
                .copied()
                .filter(|i| !order.contains(i))
                .collect();
            order.extend(rest);
            info!(
                "follow_waypoints: order {order:?} ({:.0} s predicted, {:.0} s in the given order)",
                plan.total_time_s, plan.given_order_time_s
            );
            order
        }
        Err(e) => {
            warn!("follow_waypoints: keeping the given order: {e}");
            given
        }
    }
}

/// The waypoints of pass `pass` (0 the first) in visiting order, as Nav2's waypoint follower
/// runs them: the first pass leaves out the waypoints whose index in the request is below
/// `goal_index` (in the given order, those before it; reordered, wherever the order puts them),
/// the `number_of_loops` passes after it visit all. One pass at a time: a client's
/// `number_of_loops` (a u32) never sizes an allocation.
fn pass_order(order: &[usize], goal_index: usize, pass: u32) -> Vec<usize> {
    let first = pass == 0;
    order
        .iter()
        .copied()
        .filter(|&i| !first || i >= goal_index)
        .collect()
}

/// One patrol: every pass, every waypoint in order.
async fn patrol(
    s: Arc<Shared>,
    o: Outputs,
    goal: FollowWaypointsGoal,
    stop: GoalStop,
    feedback: Feedback<FollowWaypointsGoal, FollowWaypointsResult, FollowWaypointsFeedback>,
) -> (GoalEndStatus, FollowWaypointsResult) {
    let (s, o, stop) = (&s, &o, &stop);
    let mut result = FollowWaypointsResult::default();
    let mut poses = Vec::with_capacity(goal.poses.len());
    for (i, p) in goal.poses.iter().enumerate() {
        match s.pose_in_global(p).await {
            Ok(pose) => poses.push(pose),
            Err(f) => {
                result.error_code = 600;
                result.error_msg = format!("waypoint {i}: {}", f.message);
                return (GoalEndStatus::Aborted, result);
            }
        }
    }
    // Nav2's waypoint follower aborts an empty patrol; a goal_index past the end, which it
    // would index with, is refused here the same way.
    if poses.is_empty() {
        result.error_code = 600;
        result.error_msg = "no waypoints given".into();
        return (GoalEndStatus::Aborted, result);
    }
    if goal.goal_index as usize >= poses.len() {
        result.error_code = 600;
        result.error_msg = format!(
            "goal_index {} is past the last of {} waypoints",
            goal.goal_index,
            poses.len()
        );
        return (GoalEndStatus::Aborted, result);
    }
    // The patrol has the robot from now on, between its legs too, until a newer goal takes it.
    let mine = s.take_robot();
    // An older goal's path is not driven on while the patrol orders its waypoints (nor after it,
    // if the patrol stops before its first leg).
    s.stop_following(mine);
    let superseded = |result: FollowWaypointsResult, i: usize| {
        let mut result = result;
        result.error_code = 600;
        result.error_msg =
            format!("preempted at waypoint {i} by a newer goal on /goal_pose or another action");
        (GoalEndStatus::Aborted, result)
    };
    let Some(robot) = s.robot_pose().await else {
        result.error_code = 600;
        result.error_msg = "no robot pose yet: publish /initialpose, /amcl_pose or /odom".into();
        return (GoalEndStatus::Aborted, result);
    };
    // Off the async threads: ordering solves a route over the map (and may make its grid again
    // after a changed inflation).
    let order = {
        let (shared, given) = (s.clone(), poses.clone());
        tokio::task::spawn_blocking(move || visiting_order(&shared, robot, &given))
            .await
            .unwrap_or_else(|_| (0..poses.len()).collect())
    };
    let stop_on_failure = s.params.stop_on_failure;
    for pass in 0..=goal.number_of_loops {
        let this_pass = pass_order(&order, goal.goal_index as usize, pass);
        // A pass that reaches none of its waypoints ends the patrol: the passes after it would
        // miss the same ones (most fail at once: off the map, in a wall), up to four billion
        // times over, each miss a warning and a /diagnostics message.
        let mut reached = 0usize;
        for &i in &this_pass {
            if stop.requested() {
                return (stop.end_status(), result);
            }
            if !s.owns_robot(mine) {
                return superseded(result, i);
            }
            feedback
                .send(FollowWaypointsFeedback {
                    current_waypoint: i as u32,
                })
                .await;
            let mut missed = |code: u16| {
                if result.missed_waypoints.len() < MAX_MISSED {
                    result.missed_waypoints.push(MissedWaypoint {
                        index: i as u32,
                        goal: goal.poses[i].clone(),
                        error_code: code,
                    });
                    if result.missed_waypoints.len() == MAX_MISSED {
                        warn!("follow_waypoints: {MAX_MISSED} missed waypoints listed; later misses are only logged");
                    }
                }
            };
            match drive_to(
                s,
                o,
                std::slice::from_ref(&poses[i]),
                mine,
                stop,
                |_| async {},
            )
            .await
            {
                DriveEnd::Reached => {}
                DriveEnd::Stopped => return (stop.end_status(), result),
                DriveEnd::Superseded => return superseded(result, i),
                DriveEnd::NoPlan(f) => {
                    warn!("follow_waypoints: pass {pass}, waypoint {i} missed: cannot plan to it");
                    missed(nav2_code(f.code, 200));
                    if stop_on_failure {
                        return failed(result, i);
                    }
                    continue;
                }
                DriveEnd::NotReached(why) => {
                    warn!("follow_waypoints: pass {pass}, waypoint {i} not reached: {why}");
                    missed(TASK_EXECUTOR_FAILED);
                    if stop_on_failure {
                        return failed(result, i);
                    }
                    continue;
                }
            }
            reached += 1;
            info!("follow_waypoints: pass {pass}, waypoint {i} reached");
            // An input or a camera frame counts from the arrival on, during the pause too.
            let inputs_before = s.waypoint_inputs.load(Ordering::SeqCst);
            let frames_before = s.camera.lock().expect("lock").0;
            let pause = Duration::from_secs_f64(s.params.waypoint_pause_duration);
            match wait_at_waypoint(s, mine, stop, pause, Until::Elapsed).await {
                Waited::Done | Waited::TimedOut => {}
                Waited::Stopped => return (stop.end_status(), result),
                Waited::Superseded => return superseded(result, i),
            }
            // Nav2's task executors, the photo before the word that the inspection is done.
            let photo = &s.params.photo_at_waypoint;
            let mut task_failed = None;
            if photo.enabled {
                let until = Until::FrameAfter(frames_before);
                match wait_at_waypoint(s, mine, stop, FRAME_WAIT, until).await {
                    Waited::Done => {
                        if let Err(why) = photo_at_waypoint::save(s, photo, i).await {
                            task_failed = Some(format!("no photo: {why}"));
                        }
                    }
                    Waited::Stopped => return (stop.end_status(), result),
                    Waited::Superseded => return superseded(result, i),
                    Waited::TimedOut => {
                        task_failed = Some(format!(
                            "no photo: no frame on {} since the arrival within {} s of the pause",
                            photo.image_topic,
                            FRAME_WAIT.as_secs_f64()
                        ))
                    }
                }
            }
            let input = &s.params.input_at_waypoint;
            if input.enabled && task_failed.is_none() {
                let timeout = Duration::from_secs_f64(input.timeout);
                let until = Until::InputAfter(inputs_before);
                match wait_at_waypoint(s, mine, stop, timeout, until).await {
                    Waited::Done => info!("follow_waypoints: waypoint {i}: input received"),
                    Waited::Stopped => return (stop.end_status(), result),
                    Waited::Superseded => return superseded(result, i),
                    Waited::TimedOut => {
                        task_failed = Some(format!(
                            "no input on {} within {} s",
                            input.input_topic, input.timeout
                        ))
                    }
                }
            }
            if let Some(why) = task_failed {
                warn!("follow_waypoints: pass {pass}, waypoint {i}: {why}");
                missed(TASK_EXECUTOR_FAILED);
                if stop_on_failure {
                    result.error_code = TASK_EXECUTOR_FAILED;
                    result.error_msg = format!("waypoint {i}: {why}, and stop_on_failure is set");
                    return (GoalEndStatus::Aborted, result);
                }
            }
        }
        if reached == 0 && !this_pass.is_empty() && pass < goal.number_of_loops {
            result.error_code = TASK_EXECUTOR_FAILED;
            result.error_msg = format!(
                "pass {pass} reached none of its {} waypoints; the {} passes left would miss them again",
                this_pass.len(),
                goal.number_of_loops - pass
            );
            warn!("follow_waypoints: {}", result.error_msg);
            return (GoalEndStatus::Aborted, result);
        }
    }
    (GoalEndStatus::Succeeded, result)
}

/// How a wait at a waypoint ended.
enum Waited {
    /// The pause is over, or the input came.
    Done,
    /// No input within the timeout.
    TimedOut,
    /// Cancelled or preempted ([`GoalStop`]).
    Stopped,
    /// The robot was taken by another goal.
    Superseded,
}

/// What a wait at a waypoint waits for.
#[derive(Clone, Copy)]
enum Until {
    /// Its time to pass (Nav2's WaitAtWaypoint).
    Elapsed,
    /// An input counted after the given count, the count at the arrival (Nav2's
    /// InputAtWaypoint), for at most the time given: [`Waited::TimedOut`].
    InputAfter(u64),
    /// A camera frame counted after the given count, the count at the arrival (a photo's,
    /// Nav2's PhotoAtWaypoint), for at most the time given: [`Waited::TimedOut`].
    FrameAfter(u64),
}

/// Stays at the reached waypoint for `duration`, or until what `until` names comes; polled at
/// 50 Hz, as Nav2's InputAtWaypoint polls.
async fn wait_at_waypoint(
    s: &Shared,
    mine: u64,
    stop: &GoalStop,
    duration: Duration,
    until: Until,
) -> Waited {
    let started = Instant::now();
    loop {
        let came = match until {
            Until::Elapsed => false,
            Until::InputAfter(n) => s.waypoint_inputs.load(Ordering::SeqCst) > n,
            Until::FrameAfter(n) => s.camera.lock().expect("lock").0 > n,
        };
        if came {
            return Waited::Done;
        }
        if stop.requested() {
            return Waited::Stopped;
        }
        if !s.owns_robot(mine) {
            return Waited::Superseded;
        }
        let left = duration.saturating_sub(started.elapsed());
        if left.is_zero() {
            return match until {
                Until::Elapsed => Waited::Done,
                Until::InputAfter(_) | Until::FrameAfter(_) => Waited::TimedOut,
            };
        }
        tokio::time::sleep(Duration::from_millis(20).min(left)).await;
    }
}

/// A patrol ended at its first missed waypoint (`stop_on_failure`), as Nav2's ends: aborted,
/// with the missed waypoints so far (each with its own code) and FollowWaypoints' UNKNOWN (600)
/// as the result's code, the only failure code Jazzy's action has beside the task executor's.
fn failed(mut result: FollowWaypointsResult, i: usize) -> (GoalEndStatus, FollowWaypointsResult) {
    result.error_code = 600;
    result.error_msg = format!("waypoint {i} missed and stop_on_failure is set");
    (GoalEndStatus::Aborted, result)
}

#[cfg(test)]
mod tests {
    use super::{pass_order, wait_at_waypoint, Until, Waited};
    use crate::action_server::GoalStop;
    use crate::state::Shared;
    use planner_core::config::PlannerConfig;
    use planner_io::parameters::NodeParams;
    use std::sync::atomic::Ordering;
    use std::sync::Arc;
    use std::time::{Duration, Instant};

    /// Nav2's InputAtWaypoint: an input after the arrival ends the wait at once, one counted
    /// before it does not, none by the timeout is a timeout; a newer goal taking the robot ends
    /// it as superseded; a plain pause lasts its time.
    #[tokio::test]
    async fn a_waypoint_waits_for_an_input_that_comes_after_the_arrival() {
        let s = Arc::new(Shared::new(NodeParams::default(), PlannerConfig::default()));
        let mine = s.take_robot();
        let stop = GoalStop::never();
        let (long, short) = (Duration::from_secs(5), Duration::from_millis(100));
        // An input before the arrival, then one after it, 50 ms into the wait.
        s.waypoint_inputs.fetch_add(1, Ordering::SeqCst);
        let at_arrival = s.waypoint_inputs.load(Ordering::SeqCst);
        let sender = s.clone();
        tokio::spawn(async move {
            tokio::time::sleep(Duration::from_millis(50)).await;
            sender.waypoint_inputs.fetch_add(1, Ordering::SeqCst);
        });
        let t0 = Instant::now();
        let until = Until::InputAfter(at_arrival);
        let waited = wait_at_waypoint(&s, mine, &stop, long, until).await;
        assert!(matches!(waited, Waited::Done));
        let took = t0.elapsed();
        assert!(
            took >= Duration::from_millis(50),
            "not the input before the arrival: {took:?}"
        );
        assert!(took < Duration::from_secs(1), "{took:?}");
        // No input after this arrival: the timeout.
        let until = Until::InputAfter(s.waypoint_inputs.load(Ordering::SeqCst));
        let waited = wait_at_waypoint(&s, mine, &stop, short, until).await;
        assert!(matches!(waited, Waited::TimedOut));
        let t0 = Instant::now();
        let waited = wait_at_waypoint(&s, mine, &stop, short, Until::Elapsed).await;
        assert!(matches!(waited, Waited::Done) && t0.elapsed() >= short);
        let _newer = s.take_robot();
        let waited = wait_at_waypoint(&s, mine, &stop, long, until).await;
        assert!(matches!(waited, Waited::Superseded));
    }

    #[test]
    fn the_first_pass_starts_at_goal_index_and_later_passes_visit_all() {
        // The given order: the first pass runs from goal_index to the end, as Nav2's does.
        assert_eq!(pass_order(&[0, 1, 2, 3], 2, 0), vec![2, 3]);
        assert_eq!(pass_order(&[0, 1, 2, 3], 2, 1), vec![0, 1, 2, 3]);
        assert_eq!(pass_order(&[0, 1, 2], 0, 0), vec![0, 1, 2]);
        // Reordered: the waypoints before goal_index in the request are left out of the first
        // pass, wherever the order puts them.
        assert_eq!(pass_order(&[3, 0, 2, 1], 2, 0), vec![3, 2]);
        assert_eq!(
            pass_order(&[3, 0, 2, 1], 2, 4_000_000_000),
            vec![3, 0, 2, 1]
        );
    }
}
