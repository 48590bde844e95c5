//! The path follower's loop: the node drives the plan it published, from `/odom`, through
//! the chassis library's regulated pure pursuit, within the twist and acceleration limits. A
//! `/goal_pose`'s drive, which no action watches, is checked for progress here, and handed to
//! the recoveries (drive.rs) when it makes none.

use crate::convert::chassis_pose;
use crate::drive::{hand_topic_goal_to_recoveries, DriveEnd, StallWatch};
use crate::outputs::Outputs;
use crate::state::Shared;
use chassis::behavior::Motion;
use chassis::follower::Status as FollowStatus;
use chassis::Twist2;
use log::{info, warn};
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// The follower loop: at `control_rate_hz`, the next command for the plan being followed (or,
/// with none, for a behaviour's motion: behaviors.rs), from the latest `/odom`, within the twist
/// and acceleration limits. It stops when odometry is stale and when the goal is reached (within
/// position and heading tolerance) or the motion done.
///
/// Every drive ends on an exact zero command, as Nav2's controller ends one: when the goal is
/// reached, or the plan fails, the loop keeps braking within the acceleration limits until it
/// has sent a stop, and only then goes quiet (leaving `/cmd_vel` to teleop or anyone else).
pub async fn follow(s: Arc<Shared>, o: Outputs) {
    let dt = 1.0 / s.params.control_rate_hz;
    let mut ticker = tokio::time::interval(Duration::from_secs_f64(dt));
    let mut previous = Twist2::STOP;
    let mut stale_reported = false;
    // The `/goal_pose` goal being driven, and its progress (an action's drive checks its own).
    let mut watched: Option<(u64, StallWatch)> = None;
    loop {
        ticker.tick().await;
        let pose = s.fresh_odom();
        let cmd = {
            let mut guard = s.follower.lock().expect("lock");
            match (guard.as_mut(), pose) {
                // No plan: a behaviour's motion (a spin, a back-up), if one is going.
                (None, _) => match motion_command(&s, pose) {
                    Some(cmd) => cmd,
                    // Nothing going, and the last command sent was a stop: nothing to say.
                    None if previous == Twist2::STOP => continue,
                    // The drive ended (goal reached, plan failed): brake down to a stop.
                    None => Twist2::STOP,
                },
                (Some(_), None) => {
                    if !stale_reported {
                        warn!("following paused: no /odom for {} s", s.params.pose_timeout);
                        stale_reported = true;
                    }
                    Twist2::STOP
                }
                (Some(f), Some(p)) => {
                    stale_reported = false;
                    let (cmd, status) = f.command(&chassis_pose(p), &s.drive_limits());
                    if status == FollowStatus::Arrived {
                        info!("goal reached");
                        *guard = None;
                        // Nothing followed any more: a new map has no path to check. The drive of
                        // the goal it was learns it arrived.
                        if let Some(done) = s.followed.lock().expect("lock").take() {
                            *s.arrived.lock().expect("lock") = Some((done.owner, Instant::now()));
                            // A /goal_pose's navigation ends here (an action's, with its drive).
                            s.done_topic_goal(done.owner);
                        }
                    }
                    cmd
                }
            }
        };
        // A /goal_pose's drive that makes no progress stops and is recovered, as
        // navigate_to_pose's would be.
        match s.topic_goal().filter(|&g| s.is_following(g)) {
            Some(goal) => {
                if watched.as_ref().is_none_or(|(g, _)| *g != goal) {
                    watched = Some((goal, StallWatch::new(&s)));
                }
                let (_, watch) = watched.as_mut().expect("set above");
                if let Some(why) = watch.stuck(pose) {
                    // Recovered as navigate_to_pose's drive would be (drive.rs), through the
                    // poses it has not passed; the robot stops meanwhile.
                    let ahead = s.goals_ahead_of(goal).unwrap_or_default();
                    s.stop_following(goal);
                    let end = DriveEnd::NotReached(why.clone());
                    if !hand_topic_goal_to_recoveries(&s, &o, ahead, goal, end) {
                        warn!("goal {goal} from /goal_pose given up: {why}");
                        s.done_topic_goal(goal);
                    }
                    watched = None;
                }
            }
            None => watched = None,
        }
        // A plan is driven under the speed limit in force, braked down to within the
        // acceleration limit when it drops; a behaviour's motion under the chassis' limits
        // (Nav2's behaviours do not take speed limits either).
        let limits = if s.follower.lock().expect("lock").is_some() {
            let cap = s.drive_limits().max_linear;
            s.params.twist_limits.lowered_to(cap, previous, dt)
        } else {
            s.params.twist_limits
        };
        let applied = limits.apply(cmd, previous, dt);
        previous = applied;
        s.moving.store(applied != Twist2::STOP, Ordering::SeqCst);
        o.drive(&s, applied).await;
    }
}

/// The command for the behaviour's motion going on, if one is: a stop while odometry is stale
/// (the behaviour then fails for want of a pose) or once the motion is done, which the motion
/// records for its behaviour to see. The motion is measured in the odometry frame (`pose` only
/// says whether odometry is fresh).
fn motion_command(s: &Shared, pose: Option<planner_core::geometry::Pose2>) -> Option<Twist2> {
    let mut motion = s.motion.lock().expect("lock");
    let moving = motion.as_mut()?;
    let Some(p) = pose.and(*s.odom_local.read().expect("lock")) else {
        return Some(Twist2::STOP);
    };
    // A teleop is set each control cycle by its goal's task (assisted_teleop.rs), each command
    // checked for what lies ahead; one not set for four cycles (a stalled task) is not driven on.
    let period = 1.0 / s.params.control_rate_hz;
    if matches!(moving.motion, Motion::Teleop(_))
        && moving.set_at.elapsed().as_secs_f64() > 4.0 * period
    {
        return Some(Twist2::STOP);
    }
    let (cmd, status) = moving
        .motion
        .command(&chassis_pose(p), &s.params.twist_limits);
    moving.status = status;
    Some(cmd)
}

#[cfg(test)]
mod tests {
    use super::*;
    use chassis::behavior::Teleop;
    use planner_core::config::PlannerConfig;
    use planner_core::geometry::Pose2;
    use planner_io::parameters::NodeParams;

    /// A teleop is driven on as its task last set it, and stopped once the task has not set it
    /// for four control cycles (a stalled task must not leave the robot driving unchecked).
    #[test]
    fn a_teleop_its_task_stopped_setting_is_stopped() {
        let s = Shared::new(NodeParams::default(), PlannerConfig::default());
        let pose = Pose2::new(1.0, 1.0, 0.0);
        *s.odom_local.write().unwrap() = Some(pose);
        let mine = s.take_robot();
        let ahead = Twist2 {
            linear: 0.3,
            angular: 0.1,
        };
        assert!(s.start_motion(mine, Motion::Teleop(Teleop::default())));
        assert!(s.set_teleop(mine, ahead));
        assert_eq!(motion_command(&s, Some(pose)), Some(ahead));
        let four_cycles = Duration::from_secs_f64(4.0 / s.params.control_rate_hz);
        std::thread::sleep(four_cycles + Duration::from_millis(20));
        assert_eq!(motion_command(&s, Some(pose)), Some(Twist2::STOP));
        assert!(s.set_teleop(mine, ahead), "set again, driven again");
        assert_eq!(motion_command(&s, Some(pose)), Some(ahead));
        // Another goal's set does not reach it.
        assert!(!s.set_teleop(mine + 1, Twist2::STOP));
        assert_eq!(motion_command(&s, Some(pose)), Some(ahead));
    }
}
