//! Nav2's behavior server's `assisted_teleop` (nav2_msgs/AssistedTeleop, Jazzy), as
//! nav2_simple_commander's `assistedTeleop()` sends it: an operator drives the robot by hand
//! (geometry_msgs/Twist on `behavior_server.cmd_vel_teleop`) and the node passes each command
//! on through the follower loop, within the chassis' limits, scaled down as Nav2's
//! AssistedTeleop scales it when the poses it leads to within `behavior_server.projection_time`
//! near an obstacle or a keepout zone (chassis' `assisted`): the robot slows as it closes in and
//! stops short. The goal ends when a std_msgs/Empty arrives on `preempt_teleop` (succeeded), its
//! time allowance passes (TIMEOUT 731), odometry stops for a second (TF_ERROR 732), a client
//! cancels, a newer goal of the action preempts it, or any other goal takes the robot.
//!
//! Unlike Nav2's, a command older than [`COMMAND_TIMEOUT`] counts as a stop: an operator's
//! teleop that goes quiet (a dropped link, a keyboard teleop between key presses) does not
//! leave the robot driving on its last command; and the follower loop stops a teleop its task
//! has not set for a few cycles. A command is checked as it will be driven: brought within the
//! speed limits along its own curve first. A robot already in a keepout zone may be driven
//! anywhere (to get it out), kept off obstacles only, as a spin or back-up started there.

use crate::action_server::{Feedback, GoalStop, Preemption};
use crate::behaviors::{
    allowance, clear_from, goal_end, interrupted, no_pose, BehaviorEnd, BehaviorFailure,
    STALE_LIMIT,
};
use crate::convert::{chassis_pose, duration_msg};
use crate::drive::taken;
use crate::outputs::Outputs;
use crate::state::Shared;
use chassis::behavior::{assisted, Motion, Teleop};
use chassis::Twist2;
use log::info;
use patrol_msgs::nav2_msgs::{AssistedTeleopFeedback, AssistedTeleopGoal, BehaviorResult};
use ros2_client::action::{AsyncActionServer, GoalEndStatus};
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::time::{Duration, Instant};

pub type Server = AsyncActionServer<AssistedTeleopGoal, BehaviorResult, AssistedTeleopFeedback>;

/// An operator's command older than this is a stop.
pub const COMMAND_TIMEOUT: Duration = Duration::from_millis(500);

/// AssistedTeleop's result code (Jazzy) for a failure: UNKNOWN 730, TIMEOUT 731, TF_ERROR 732.
fn code(f: BehaviorFailure) -> u16 {
    match f {
        BehaviorFailure::Timeout => 731,
        BehaviorFailure::TfError => 732,
        _ => 730,
    }
}

/// Serves `assisted_teleop` until the node stops (the door: action_server.rs).
pub async fn serve(s: Arc<Shared>, o: Outputs, server: Server) {
    crate::action_server::serve(s, o, "assisted_teleop", Preemption::Newest, server, teleop).await
}

/// One assisted teleop: it takes the robot and drives it by the operator's commands, each
/// scaled for what lies ahead, every control cycle until it ends.
async fn teleop(
    s: Arc<Shared>,
    _o: Outputs,
    goal: AssistedTeleopGoal,
    stop: GoalStop,
    feedback: Feedback<AssistedTeleopGoal, BehaviorResult, AssistedTeleopFeedback>,
) -> (GoalEndStatus, BehaviorResult) {
    let started = Instant::now();
    let limit = allowance(&goal.time_allowance);
    let preempts = s.teleop_preempts.load(Ordering::SeqCst);
    let mine = s.take_robot();
    s.stop_following(mine);
    let end = if s.start_motion(mine, Motion::Teleop(Teleop::default())) {
        info!("goal {mine}: assisted teleop");
        drive(&s, mine, &stop, limit, preempts, &feedback, started).await
    } else {
        taken(&s, mine).map_or(BehaviorEnd::Stopped, BehaviorEnd::Taken)
    };
    s.stop_motion(mine);
    if let BehaviorEnd::Succeeded = end {
        info!("assisted_teleop: ended on preempt_teleop");
    }
    goal_end("assisted_teleop", end, &stop, started, code)
}

/// The teleop's control cycles, at the follower's rate, until it ends.
async fn drive(
    s: &Shared,
    mine: u64,
    stop: &GoalStop,
    limit: Option<Duration>,
    preempts: u64,
    feedback: &Feedback<AssistedTeleopGoal, BehaviorResult, AssistedTeleopFeedback>,
    started: Instant,
) -> BehaviorEnd {
    let b = &s.params.behavior_server;
    let period = Duration::from_secs_f64(1.0 / s.params.control_rate_hz);
    let mut stale_since: Option<Instant> = None;
    loop {
        tokio::time::sleep(period).await;
        if let Some(end) = interrupted(s, mine, stop) {
            return end;
        }
        if limit.is_some_and(|l| started.elapsed() > l) {
            let secs = limit.unwrap_or_default().as_secs_f64();
            let why = format!("past its time allowance ({secs:.1} s)");
            return BehaviorEnd::Failed(BehaviorFailure::Timeout, why);
        }
        if s.teleop_preempts.load(Ordering::SeqCst) > preempts {
            return BehaviorEnd::Succeeded;
        }
        // Without fresh odometry nothing can be checked: the robot is held stopped, and the
        // goal fails once that has lasted STALE_LIMIT.
        let clear = s
            .fresh_odom()
            .and_then(|pose| Some((pose, clear_from(s, pose)?)));
        let twist = match clear {
            Some((pose, clear)) => {
                stale_since = None;
                // Checked as it will be driven: within the speed limits, on the same curve.
                let command = s
                    .params
                    .twist_limits
                    .keeping_curve(latest_command(s, started));
                let (horizon, step) = (b.projection_time, b.simulation_time_step);
                assisted(command, &chassis_pose(pose), horizon, step, |p| !clear(p))
            }
            None => {
                if stale_since.get_or_insert_with(Instant::now).elapsed() > STALE_LIMIT {
                    return BehaviorEnd::Failed(BehaviorFailure::TfError, no_pose());
                }
                Twist2::STOP
            }
        };
        if !s.set_teleop(mine, twist) {
            return taken(s, mine).map_or(BehaviorEnd::Stopped, BehaviorEnd::Taken);
        }
        feedback
            .send(AssistedTeleopFeedback {
                current_teleop_duration: duration_msg(started.elapsed()),
            })
            .await;
    }
}

/// The operator's latest command, if it came after `since` (the goal's start: one from before
/// it is not this goal's, as Nav2 clears its command when a teleop ends) and is no older than
/// [`COMMAND_TIMEOUT`]; else a stop.
fn latest_command(s: &Shared, since: Instant) -> Twist2 {
    s.teleop
        .lock()
        .expect("lock")
        .filter(|(_, at)| *at >= since && at.elapsed() <= COMMAND_TIMEOUT)
        .map_or(Twist2::STOP, |(twist, _)| twist)
}
