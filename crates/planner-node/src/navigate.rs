//! Nav2's navigate actions (nav2_msgs, Jazzy), as bt_navigator serves them and
//! nav2_simple_commander sends them: `navigate_to_pose` (`goToPose`), one drive (drive.rs) from
//! where the robot is to the goal, and `navigate_through_poses` (`goThroughPoses`), one drive
//! through every pose in order, planned as one path (ComputePathThroughPoses) and driven without
//! stopping at the poses on the way, as Nav2's through-poses tree does. Feedback each tick, as
//! bt_navigator's: the robot's pose, the time since the goal arrived, the path length still to
//! drive, the time remaining at the current speed, the recoveries so far (drive.rs: a drive that
//! makes no progress or finds no path waits and plans again, as Nav2's trees retry), and, for
//! through-poses, the poses still ahead. A newer goal of the same action preempts the running
//! one (aborted), a client's cancel stops the robot (canceled); a goal of the other navigate
//! action while one navigates is refused (aborted, error code 0) and the running one goes on,
//! as bt_navigator's navigators share it. A `/goal_pose` counts as a `navigate_to_pose` goal,
//! as bt_navigator turns it into one: it preempts that action's goal, is refused (BUSY on
//! `/diagnostics`) while a route drives, and while it drives a route is refused.
//! `follow_waypoints` takes the robot from either. A failure carries the code of the step that
//! failed, as bt_navigator reports it: the planner's (ComputePathToPose's 2xx,
//! ComputePathThroughPoses' 3xx) or the controller's FAILED_TO_MAKE_PROGRESS (105) for a robot
//! that made no progress or a plan not driven within its time, once the recoveries are spent.
//! `behavior_tree` names one of bt_navigator's trees; this node has none, and says so in its
//! log.

use crate::action_server::{Feedback, GoalStop, Preemption};
use crate::actions::{nav2_code, NO_VIAPOINTS_GIVEN};
use crate::convert::{duration_msg, pose_stamped};
use crate::drive::{action_end, drive_to, Progress};
use crate::outputs::Outputs;
use crate::state::Shared;
use log::{info, warn};
use patrol_msgs::builtin_interfaces::Duration as DurationMsg;
use patrol_msgs::geometry_msgs::PoseStamped;
use patrol_msgs::nav2_msgs::{
    NavigateThroughPosesFeedback, NavigateThroughPosesGoal, NavigateThroughPosesResult,
    NavigateToPoseFeedback, NavigateToPoseGoal, NavigateToPoseResult,
};
use ros2_client::action::{AsyncActionServer, GoalEndStatus};
use ros2_client::Message;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// One tick of a navigation's feedback, whichever action it is for.
pub struct NavigationFeedback {
    pub current_pose: PoseStamped,
    pub navigation_time: DurationMsg,
    pub estimated_time_remaining: DurationMsg,
    pub distance_remaining: f32,
    /// The poses still ahead, the goal included.
    pub poses_remaining: usize,
    /// The recoveries so far.
    pub recoveries: i16,
}

/// What the two navigate actions' goals have in common (as actions.rs's `PlannerGoal` is for
/// the planner actions): their poses, their tree, and how their result and feedback are made.
pub trait NavigateGoal: Message + Clone + Send + Sync + 'static {
    type Result: Message + Clone + Default + Send + Sync + 'static;
    type Feedback: Message + Send + Sync + 'static;
    /// The action's name, for logs.
    const NAME: &'static str;
    /// The error-code base of the planner action its tree calls: 200 (ComputePathToPose) or
    /// 300 (ComputePathThroughPoses).
    const CODE_BASE: u16;
    /// The poses to drive through in order; the last is the goal.
    fn poses(&self) -> &[PoseStamped];
    fn behavior_tree(&self) -> &str;
    fn result(error_code: u16, error_msg: String) -> Self::Result;
    fn feedback(f: NavigationFeedback) -> Self::Feedback;
}

impl NavigateGoal for NavigateToPoseGoal {
    type Result = NavigateToPoseResult;
    type Feedback = NavigateToPoseFeedback;
    const NAME: &'static str = "navigate_to_pose";
    const CODE_BASE: u16 = 200;
    fn poses(&self) -> &[PoseStamped] {
        std::slice::from_ref(&self.pose)
    }
    fn behavior_tree(&self) -> &str {
        &self.behavior_tree
    }
    fn result(error_code: u16, error_msg: String) -> Self::Result {
        NavigateToPoseResult {
            error_code,
            error_msg,
        }
    }
    fn feedback(f: NavigationFeedback) -> Self::Feedback {
        NavigateToPoseFeedback {
            current_pose: f.current_pose,
            navigation_time: f.navigation_time,
            estimated_time_remaining: f.estimated_time_remaining,
            number_of_recoveries: f.recoveries,
            distance_remaining: f.distance_remaining,
        }
    }
}

impl NavigateGoal for NavigateThroughPosesGoal {
    type Result = NavigateThroughPosesResult;
    type Feedback = NavigateThroughPosesFeedback;
    const NAME: &'static str = "navigate_through_poses";
    const CODE_BASE: u16 = 300;
    fn poses(&self) -> &[PoseStamped] {
        &self.poses
    }
    fn behavior_tree(&self) -> &str {
        &self.behavior_tree
    }
    fn result(error_code: u16, error_msg: String) -> Self::Result {
        NavigateThroughPosesResult {
            error_code,
            error_msg,
        }
    }
    fn feedback(f: NavigationFeedback) -> Self::Feedback {
        NavigateThroughPosesFeedback {
            current_pose: f.current_pose,
            navigation_time: f.navigation_time,
            estimated_time_remaining: f.estimated_time_remaining,
            number_of_recoveries: f.recoveries,
            distance_remaining: f.distance_remaining,
            number_of_poses_remaining: i16::try_from(f.poses_remaining).unwrap_or(i16::MAX),
        }
    }
}

/// Serves one navigate action until the node stops (the door: action_server.rs).
pub async fn serve<G: NavigateGoal>(
    s: Arc<Shared>,
    o: Outputs,
    server: AsyncActionServer<G, G::Result, G::Feedback>,
) {
    crate::action_server::serve(s, o, G::NAME, Preemption::Newest, server, navigate::<G>).await
}

/// One goal: its poses carried into the global frame, planned through, driven to.
async fn navigate<G: NavigateGoal>(
    s: Arc<Shared>,
    o: Outputs,
    goal: G,
    stop: GoalStop,
    feedback: Feedback<G, G::Result, G::Feedback>,
) -> (GoalEndStatus, G::Result) {
    let (s, o, stop) = (&s, &o, &stop);
    let name = G::NAME;
    let failed = |error_code: u16, error_msg: String| {
        warn!("{name}: {error_code}: {error_msg}");
        (GoalEndStatus::Aborted, G::result(error_code, error_msg))
    };
    if !goal.behavior_tree().is_empty() {
        info!(
            "{name}: behavior_tree `{}` ignored: this node plans and follows without behavior \
             trees",
            goal.behavior_tree()
        );
    }
    if goal.poses().is_empty() {
        return failed(NO_VIAPOINTS_GIVEN, "no poses given".into());
    }
    if let Err(f) = crate::planning::check_pose_count(goal.poses().len()) {
        return failed(nav2_code(f.code, G::CODE_BASE), f.message);
    }
    // Every pose is carried into the global frame once, as the goal arrives: a pose in
    // `base_link` is relative to where the robot is now.
    let mut goals = Vec::with_capacity(goal.poses().len());
    for (i, pose) in goal.poses().iter().enumerate() {
        match s.pose_in_global(pose).await {
            Ok(p) => goals.push(p),
            Err(f) => {
                let which = if goal.poses().len() > 1 {
                    format!("pose {i}: ")
                } else {
                    String::new()
                };
                return failed(
                    nav2_code(f.code, G::CODE_BASE),
                    format!("{which}{}", f.message),
                );
            }
        }
    }
    let to = *goals.last().expect("checked non-empty");
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
        let message = G::feedback(NavigationFeedback {
            current_pose: pose_stamped(p.robot, header),
            navigation_time: duration_msg(started.elapsed()),
            estimated_time_remaining: duration_msg(eta),
            distance_remaining: p.remaining_m as f32,
            poses_remaining: p.poses_remaining,
            recoveries: i16::try_from(p.recoveries).unwrap_or(i16::MAX),
        });
        async move { feedback.send(message).await }
    };
    // One navigator at a time, as bt_navigator: while the other navigate action drives, this
    // goal ends at once, aborted with no error code, as bt_navigator terminates it. Unlike
    // bt_navigator (whose muxer is asked first), the goal is checked before: claiming the
    // navigator takes the robot, and a goal that cannot be driven must not stop the drive.
    let mine = match s.start_navigating(name) {
        Ok(mine) => Navigating { s, mine },
        Err(other) => {
            return failed(
                0,
                format!(
                    "{other} is navigating: one navigation at a time, as bt_navigator; cancel \
                     it first"
                ),
            )
        }
    };
    let end = drive_to(s, o, &goals, mine.mine, stop, progress).await;
    let (status, code, why) = action_end(name, end, stop, to, started, |f| {
        nav2_code(f.code, G::CODE_BASE)
    });
    (status, G::result(code, why))
}

/// A goal's claim to be the navigator navigating, given up when its run ends, however it ends.
struct Navigating<'a> {
    s: &'a Shared,
    mine: u64,
}

impl Drop for Navigating<'_> {
    fn drop(&mut self) {
        self.s.done_navigating(self.mine);
    }
}
