//! Nav2's `navigate_to_pose` action (nav2_msgs/NavigateToPose, Jazzy), as bt_navigator serves it
//! and nav2_simple_commander's `goToPose` sends it: one drive (drive.rs) from where the robot is
//! to the goal, with bt_navigator's feedback each tick (the robot's pose, the time since the goal
//! arrived, the path length still to drive, the time remaining at the current speed, and no
//! recoveries: the node has none). A newer goal preempts the running one (aborted), a client's
//! cancel stops the robot (canceled). A failure carries the code of the step that failed, as
//! bt_navigator reports it: the planner's (ComputePathToPose's 2xx) or the controller's
//! FAILED_TO_MAKE_PROGRESS (105) for a plan not driven within its time. `behavior_tree` names
//! one of bt_navigator's trees; this node has none, and says so in its log.

use crate::action_server::{Feedback, GoalStop};
use crate::actions::nav2_code;
use crate::convert::{duration_msg, pose_stamped};
use crate::drive::{drive_to, DriveEnd, Progress};
use crate::outputs::Outputs;
use crate::state::Shared;
use log::{info, warn};
use patrol_msgs::nav2_msgs::{NavigateToPoseFeedback, NavigateToPoseGoal, NavigateToPoseResult};
use ros2_client::action::{AsyncActionServer, GoalEndStatus};
use std::sync::Arc;
use std::time::{Duration, Instant};

pub type Server =
    AsyncActionServer<NavigateToPoseGoal, NavigateToPoseResult, NavigateToPoseFeedback>;

/// FollowPath's FAILED_TO_MAKE_PROGRESS: the plan was followed but not to its end in time.
const FAILED_TO_MAKE_PROGRESS: u16 = 105;

/// Serves `navigate_to_pose` until the node stops (the door: action_server.rs).
pub async fn serve(s: Arc<Shared>, o: Outputs, server: Server) {
    crate::action_server::serve(s, o, "navigate_to_pose", server, navigate).await
}

/// One goal: carried into the global frame, planned to, driven to.
async fn navigate(
    s: Arc<Shared>,
    o: Outputs,
    goal: NavigateToPoseGoal,
    stop: GoalStop,
    feedback: Feedback<NavigateToPoseGoal, NavigateToPoseResult, NavigateToPoseFeedback>,
) -> (GoalEndStatus, NavigateToPoseResult) {
    let (s, o, stop) = (&s, &o, &stop);
    let failed = |error_code: u16, error_msg: String| {
        warn!("navigate_to_pose: {error_code}: {error_msg}");
        (
            GoalEndStatus::Aborted,
            NavigateToPoseResult {
                error_code,
                error_msg,
            },
        )
    };
    if !goal.behavior_tree.is_empty() {
        info!(
            "navigate_to_pose: behavior_tree `{}` ignored: this node plans and follows without \
             behavior trees",
            goal.behavior_tree
        );
    }
    // Checked before the goal takes the robot, so a plan for /goal_pose is not cancelled for it.
    if !s.params.follow_plan {
        return failed(
            200,
            "follow_plan is false: this node plans only, and leaves driving to another controller"
                .into(),
        );
    }
    let to = match s.pose_in_global(&goal.pose) {
        Ok(p) => p,
        Err(f) => return failed(nav2_code(f.code, 200), f.message),
    };
    let started = Instant::now();
    let header = o.header(s);
    let progress = |p: Progress| {
        let (feedback, mut header) = (feedback.clone(), header.clone());
        header.stamp = ros_edge::now();
        // As bt_navigator estimates it: the distance left at the current speed, once moving.
        let eta = if p.speed > 0.01 && p.remaining_m > 0.1 {
            Duration::from_secs_f64((p.remaining_m / p.speed).min(1e6))
        } else {
            Duration::ZERO
        };
        let message = NavigateToPoseFeedback {
            current_pose: pose_stamped(p.robot, header),
            navigation_time: duration_msg(started.elapsed()),
            estimated_time_remaining: duration_msg(eta),
            number_of_recoveries: 0,
            distance_remaining: p.remaining_m as f32,
        };
        async move { feedback.send(message).await }
    };
    match drive_to(s, o, to, s.take_robot(), stop, progress).await {
        DriveEnd::Reached => {
            info!(
                "navigate_to_pose: reached ({:.2}, {:.2}) in {:.1} s",
                to.x,
                to.y,
                started.elapsed().as_secs_f64()
            );
            (GoalEndStatus::Succeeded, NavigateToPoseResult::default())
        }
        DriveEnd::Stopped => {
            let why = stop.reason();
            info!("navigate_to_pose: {why}");
            (
                stop.end_status(),
                NavigateToPoseResult {
                    error_code: 0,
                    error_msg: why.into(),
                },
            )
        }
        DriveEnd::Superseded => failed(
            0,
            "preempted by a newer goal on /goal_pose or another action".into(),
        ),
        DriveEnd::NoPlan(f) => failed(nav2_code(f.code, 200), f.message),
        DriveEnd::NotReached => failed(
            FAILED_TO_MAKE_PROGRESS,
            "the robot did not reach the end of its plan within the time to drive it".into(),
        ),
    }
}
