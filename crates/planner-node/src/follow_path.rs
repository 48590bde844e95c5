//! controller_server's `follow_path` action (nav2_msgs/FollowPath, Jazzy), as
//! nav2_simple_commander's `followPath()` sends it, typically with a path that `getPath()` or
//! `getPathThroughPoses()` returned: the node's follower drives the given path to its end
//! (regulated pure pursuit within the twist limits, ending on the last pose's heading), with
//! controller_server's feedback, `distance_to_goal` along the path and `speed`.
//!
//! Checked before the robot moves, each with FollowPath's error code: an empty path, a pose that
//! is not finite, more than [`MAX_POSES`] poses, a path through an obstacle or the inflated band
//! on the node's map (`is_path_valid`'s rule), or one whose first pose is more than
//! [`MAX_START_DISTANCE_M`] from the robot, is INVALID_PATH (103): Nav2's controller would try
//! to steer round an obstacle or reach a far path with its local costmap's critics, and this
//! node has no local planner, so it does not drive into what it cannot steer round. A frame
//! the node cannot carry into `global_frame` (or no robot pose) is TF_ERROR (102); a
//! `controller_id` other than empty or `FollowPath` (Nav2's default id) INVALID_CONTROLLER
//! (101). The goal and progress checker ids name plugins this node does not have (it has one of
//! each: the follower's tolerances and `progress_checker`), so they are logged and ignored.
//!
//! Then the path is driven as the node's own plans are (drive.rs): a newer goal takes the robot
//! (this one aborted), cancel stops it (canceled), a new map that blocks it has it planned again
//! to its end (the node's rule for every path it drives), and no progress, or the time to drive
//! it run out, is FAILED_TO_MAKE_PROGRESS (105). No recoveries: controller_server makes none
//! (bt_navigator's tree does).

use crate::action_server::{Feedback, GoalStop, Preemption};
use crate::actions::{invalid_poses, MAX_GIVEN_PATH_POSES as MAX_POSES};
use crate::drive::{action_end, watch_followed, Progress};
use crate::outputs::Outputs;
use crate::state::{Handover, Shared};
use log::{info, warn};
use patrol_msgs::nav2_msgs::{FollowPathFeedback, FollowPathGoal, FollowPathResult};
use planner_core::geometry::{Point2, Pose2};
use ros2_client::action::{AsyncActionServer, GoalEndStatus};
use std::sync::Arc;
use std::time::Instant;

const NAME: &str = "follow_path";

/// FollowPath's error codes (nav2_msgs/action/FollowPath, Jazzy).
const UNKNOWN: u16 = 100;
const INVALID_CONTROLLER: u16 = 101;
const TF_ERROR: u16 = 102;
const INVALID_PATH: u16 = 103;

/// How far (m) the path's first pose may be from the robot: the follower drives along a path,
/// it does not plan its way onto one.
pub const MAX_START_DISTANCE_M: f64 = 1.0;

/// Serves `follow_path` until the node stops (the door: action_server.rs).
pub async fn serve(
    s: Arc<Shared>,
    o: Outputs,
    server: AsyncActionServer<FollowPathGoal, FollowPathResult, FollowPathFeedback>,
) {
    crate::action_server::serve(s, o, NAME, Preemption::Newest, server, follow_path).await
}

fn result(error_code: u16, error_msg: String) -> FollowPathResult {
    FollowPathResult {
        error_code,
        error_msg,
        ..FollowPathResult::default()
    }
}

/// A given path's poses in the global frame, or why they cannot be driven (a FollowPath code
/// and the reason).
async fn poses_in_global(s: &Shared, goal: &FollowPathGoal) -> Result<Vec<Pose2>, (u16, String)> {
    let poses = &goal.path.poses;
    if poses.is_empty() {
        return Err((INVALID_PATH, "the path is empty".into()));
    }
    if poses.len() > MAX_POSES {
        return Err((
            INVALID_PATH,
            format!("{} poses, at most {MAX_POSES}", poses.len()),
        ));
    }
    // The path's frame and stamp are the header's, as controller_server reads them: placed
    // once.
    let header = &goal.path.header;
    let origin = s
        .frame_in_global(&header.frame_id, crate::convert::seconds(&header.stamp))
        .await
        .map_err(|f| (TF_ERROR, format!("the path's frame: {}", f.message)))?;
    poses
        .iter()
        .enumerate()
        .map(|(i, p)| {
            crate::convert::pose3(&p.pose)
                .map(|pose| crate::convert::planar(&(origin * pose)))
                .map_err(|f| (INVALID_PATH, format!("pose {i}: {}", f.message)))
        })
        .collect()
}

/// One goal: the path checked, handed to the follower, watched to its end.
async fn follow_path(
    s: Arc<Shared>,
    _o: Outputs,
    goal: FollowPathGoal,
    stop: GoalStop,
    feedback: Feedback<FollowPathGoal, FollowPathResult, FollowPathFeedback>,
) -> (GoalEndStatus, FollowPathResult) {
    let failed = |error_code: u16, error_msg: String| {
        warn!("{NAME}: {error_code}: {error_msg}");
        (GoalEndStatus::Aborted, result(error_code, error_msg))
    };
    if !matches!(goal.controller_id.as_str(), "" | "FollowPath") {
        return failed(
            INVALID_CONTROLLER,
            format!(
                "no controller `{}`: this node's one follower answers to `FollowPath` or an \
                 empty id",
                goal.controller_id
            ),
        );
    }
    for (what, id) in [
        ("goal_checker_id", &goal.goal_checker_id),
        ("progress_checker_id", &goal.progress_checker_id),
    ] {
        if !id.is_empty() {
            info!("{NAME}: {what} `{id}` ignored: this node has one goal and one progress checker");
        }
    }
    if let Some(f) = s.refusal() {
        return failed(UNKNOWN, f.message);
    }
    let poses = match poses_in_global(&s, &goal).await {
        Ok(poses) => poses,
        Err((code, why)) => return failed(code, why),
    };
    let Some(map) = s.current_map_off_thread().await else {
        return failed(UNKNOWN, "no map yet: the path cannot be checked".into());
    };
    let points: Vec<(f64, f64)> = poses.iter().map(|p| (p.x, p.y)).collect();
    let checked = {
        let map = map.clone();
        tokio::task::spawn_blocking(move || invalid_poses(&map.grid, &points)).await
    };
    match checked.as_deref() {
        Ok([]) => {}
        Ok([first, ..]) => {
            let p = poses[*first as usize];
            return failed(
                INVALID_PATH,
                format!(
                    "pose {first} at ({:.2}, {:.2}) is in an obstacle or its inflated band, or \
                     reached only through one, on the node's map: this node has no local \
                     planner to steer round it",
                    p.x, p.y
                ),
            );
        }
        Err(e) => return failed(UNKNOWN, format!("the path check failed: {e}")),
    }
    let Some(robot) = s.robot_pose().await else {
        return failed(TF_ERROR, "no robot pose yet: publish /odom".into());
    };
    let first = poses[0];
    let off = (first.x - robot.x).hypot(first.y - robot.y);
    if off > MAX_START_DISTANCE_M {
        return failed(
            INVALID_PATH,
            format!(
                "the path starts {off:.2} m from the robot (at most {MAX_START_DISTANCE_M} m): \
                 the follower drives along a path, it does not plan its way onto one"
            ),
        );
    }
    // Densified as a plan is published, so that the follower's lookahead and progress work on
    // a sparse path (two poses metres apart) as on a planner's.
    let end_pose = *poses.last().expect("checked non-empty");
    let waypoints: Vec<Point2> = poses.iter().map(|p| Point2::new(p.x, p.y)).collect();
    let path = crate::convert::path_msg(
        &waypoints,
        end_pose.yaw,
        map.grid.resolution(),
        goal.path.header.clone(),
    );
    let mine = s.take_robot();
    let started = Instant::now();
    if !s.follow(
        mine,
        Handover::new(vec![end_pose], &path, &[], end_pose.yaw),
    ) {
        return failed(
            UNKNOWN,
            "the robot was taken, or the node deactivated, as the path was handed over".into(),
        );
    }
    info!(
        "{NAME}: following {} poses to ({:.2}, {:.2})",
        poses.len(),
        end_pose.x,
        end_pose.y
    );
    let progress = |p: Progress| {
        let feedback = feedback.clone();
        let message = FollowPathFeedback {
            distance_to_goal: p.remaining_m as f32,
            speed: p.speed as f32,
        };
        async move { feedback.send(message).await }
    };
    let end = watch_followed(&s, mine, &stop, started, progress).await;
    let (status, code, why) = action_end(NAME, end, &stop, end_pose, started, |_| UNKNOWN);
    (status, result(code, why))
}
