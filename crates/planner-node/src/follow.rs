//! The path follower's loop: the node drives the plan it published, from `/odom`, through
//! chassis-bridge's regulated pure pursuit, within the twist and acceleration limits.

use crate::outputs::Outputs;
use crate::state::Shared;
use chassis_bridge::follower::Status as FollowStatus;
use chassis_bridge::Twist2;
use log::{info, warn};
use std::sync::Arc;
use std::time::Duration;

/// The follower loop: at `control_rate_hz`, the next command for the plan being followed, from
/// the latest `/odom`, within the twist and acceleration limits. It stops when odometry is stale
/// and when the goal is reached (within position and heading tolerance).
pub async fn follow(s: Arc<Shared>, o: Outputs) {
    let dt = 1.0 / s.params.control_rate_hz;
    let mut ticker = tokio::time::interval(Duration::from_secs_f64(dt));
    let mut previous = Twist2::STOP;
    let mut stale_reported = false;
    loop {
        ticker.tick().await;
        let pose = s
            .odom
            .read()
            .expect("lock")
            .filter(|(_, t)| t.elapsed().as_secs_f64() <= s.params.pose_timeout)
            .map(|(p, _)| p);
        let cmd = {
            let mut guard = s.follower.lock().expect("lock");
            let Some(f) = guard.as_mut() else {
                previous = Twist2::STOP;
                continue;
            };
            match pose {
                None => {
                    if !stale_reported {
                        warn!("following paused: no /odom for {} s", s.params.pose_timeout);
                        stale_reported = true;
                    }
                    Twist2::STOP
                }
                Some(p) => {
                    stale_reported = false;
                    let (cmd, status) = f.command(
                        &chassis_bridge::sim::Pose {
                            x: p.x,
                            y: p.y,
                            yaw: p.yaw,
                        },
                        &s.params.twist_limits,
                    );
                    if status == FollowStatus::Arrived {
                        info!("goal reached");
                        *guard = None;
                    }
                    cmd
                }
            }
        };
        let applied = s.params.twist_limits.apply(cmd, previous, dt);
        previous = applied;
        o.drive(&s, applied).await;
    }
}
