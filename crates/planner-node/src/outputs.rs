//! What the node publishes in answer: `/plan`, the Pareto markers, `/diagnostics` (and the log
//! line that goes with every answer), and the follower's `/cmd_vel`; and the planning grid as a
//! costmap each time it is made.

use crate::convert;
use crate::result::Outcome;
use crate::state::{MapState, Shared};
use chassis::Twist2;
use log::{debug, info, warn};
use patrol_msgs::diagnostic_msgs::DiagnosticArray;
use patrol_msgs::geometry_msgs::{Twist, TwistStamped, Vector3};
use patrol_msgs::nav_msgs::{OccupancyGrid, Path};
use patrol_msgs::std_msgs::Header;
use patrol_msgs::visualization_msgs::MarkerArray;
use planner_core::planner::Plan;
use ros2_client::Publisher;
use std::sync::Arc;

/// The publishers every request answers on.
#[derive(Clone)]
pub struct Outputs {
    pub plan: Arc<Publisher<Path>>,
    pub diagnostics: Arc<Publisher<DiagnosticArray>>,
    pub pareto: Arc<Publisher<MarkerArray>>,
    pub cmd_vel: CmdVel,
}

/// `/cmd_vel` as Twist, or as TwistStamped (`enable_stamped_cmd_vel`).
#[derive(Clone)]
pub enum CmdVel {
    Plain(Arc<Publisher<Twist>>),
    Stamped(Arc<Publisher<TwistStamped>>),
}

impl Outputs {
    /// A velocity command on `/cmd_vel`.
    pub async fn drive(&self, s: &Shared, t: Twist2) {
        let twist = Twist {
            linear: Vector3 {
                x: t.linear,
                y: 0.0,
                z: 0.0,
            },
            angular: Vector3 {
                x: 0.0,
                y: 0.0,
                z: t.angular,
            },
        };
        let sent = match &self.cmd_vel {
            CmdVel::Plain(p) => p.async_publish(twist).await.map_err(|e| format!("{e:?}")),
            CmdVel::Stamped(p) => {
                let header = Header {
                    stamp: ros_edge::now(),
                    frame_id: s.params.robot_base_frame.clone(),
                };
                p.async_publish(TwistStamped { header, twist })
                    .await
                    .map_err(|e| format!("{e:?}"))
            }
        };
        if let Err(e) = sent {
            warn!("/cmd_vel: {e}");
        }
    }

    pub fn header(&self, s: &Shared) -> Header {
        Header {
            stamp: ros_edge::now(),
            frame_id: s.params.global_frame.clone(),
        }
    }

    /// `/diagnostics` for one answer, labelled with the planner that gave it.
    pub async fn diagnose(&self, s: &Shared, outcome: &Outcome) {
        let (planner, seed, elapsed_ms) = (outcome.planner, outcome.seed, outcome.elapsed_ms);
        let f = s.params.expected_planner_frequency;
        if f > 0.0 && elapsed_ms > 1e3 / f {
            warn!(
                "planner loop missed its desired rate of {f:.4} Hz: the plan took {elapsed_ms:.1} ms ({:.4} Hz)",
                1e3 / elapsed_ms
            );
        }
        let result = outcome.result.as_ref().map(|(p, _)| p);
        // The one place every answer is logged (terminal and /rosout) with its reason.
        match result {
            Ok(plan) => {
                info!(
                    "{planner}: {:.2} m, {:.2} rad of turning in {elapsed_ms:.1} ms (seed {seed})",
                    plan.metrics.length_m, plan.metrics.turning_rad
                );
                // Every plan has a few (the swarm's encoding and corridor...): on /diagnostics
                // always, in the log at debug level.
                for note in &plan.stats.notes {
                    debug!("{planner}: {note}");
                }
            }
            Err(f) => warn!("{planner}: {}: {} (seed {seed})", f.code, f.message),
        }
        let msg = convert::diagnostics(self.header(s), planner, seed, result, elapsed_ms);
        if let Err(e) = self.diagnostics.async_publish(msg).await {
            warn!("/diagnostics: {e:?}");
        }
    }

    /// A plan as nav_msgs/Path, densified at the resolution of the map it was planned on (not
    /// the current one: a map may have replaced it meanwhile).
    pub fn path(&self, s: &Shared, plan: &Plan, goal_yaw: f64) -> Path {
        let yaw = final_yaw(
            s.params.use_final_approach_orientation,
            &plan.waypoints,
            goal_yaw,
        );
        convert::path_msg(&plan.waypoints, yaw, plan.resolution, self.header(s))
    }

    /// A goal's answer: `/plan` (on success), the Pareto markers, and `/diagnostics`. Returns the
    /// published path.
    pub async fn publish(&self, s: &Shared, outcome: &Outcome) -> Option<Path> {
        let mut published = None;
        if let Ok((plan, goal_yaw)) = &outcome.result {
            let path = self.path(s, plan, *goal_yaw);
            published = Some(path.clone());
            self.publish_plan(s, path, plan).await;
        }
        self.diagnose(s, outcome).await;
        published
    }

    /// `/plan` and, for a multi-objective planner, its front on `~/pareto`.
    pub async fn publish_plan(&self, s: &Shared, path: Path, plan: &Plan) {
        if let Err(e) = self.plan.async_publish(path).await {
            warn!("/plan: {e:?}");
        }
        if s.params.publish_pareto && !plan.pareto.is_empty() {
            if let Err(e) = self
                .pareto
                .async_publish(convert::pareto_markers(plan, self.header(s)))
                .await
            {
                warn!("pareto: {e:?}");
            }
        }
    }
}

/// Publishes each installed planning grid on `publisher` as costmap_2d publishes a costmap
/// (`publish_costmap`), once per grid: a new map, or the same map made again for a changed
/// inflation. Grids installed faster than they are published are coalesced into the newest.
pub async fn publish_costmaps(s: Arc<Shared>, publisher: Publisher<OccupancyGrid>) {
    let mut last: Option<Arc<MapState>> = None;
    loop {
        s.grid_installed.notified().await;
        let Some(map) = s.map.read().expect("lock").clone() else {
            continue;
        };
        if last.as_ref().is_some_and(|l| Arc::ptr_eq(l, &map)) {
            continue;
        }
        let frame = s.params.global_frame.clone();
        let grid = map.clone();
        // One pass over the map: off the async threads on a map of millions of cells.
        let msg = tokio::task::spawn_blocking(move || {
            let unknown = |i| grid.is_unknown(i);
            convert::costmap_msg(
                grid.map().info(),
                &grid.grid,
                unknown,
                &frame,
                ros_edge::now(),
            )
        })
        .await;
        match msg {
            Ok(msg) => {
                if let Err(e) = publisher.async_publish(msg).await {
                    warn!("costmap: {e:?}");
                }
            }
            Err(e) => warn!("costmap task: {e}"),
        }
        last = Some(map);
    }
}

/// The heading of a path's last pose: the goal's, or with `use_final_approach_orientation` the
/// direction of the last segment (Nav2's option, for goals whose heading the robot should not
/// turn to at the end).
pub fn final_yaw(
    use_approach: bool,
    waypoints: &[planner_core::geometry::Point2],
    goal_yaw: f64,
) -> f64 {
    match waypoints {
        [.., a, b] if use_approach && a != b => (b.y - a.y).atan2(b.x - a.x),
        _ => goal_yaw,
    }
}

#[cfg(test)]
mod tests {
    use super::final_yaw;
    use planner_core::geometry::Point2;

    #[test]
    fn the_final_approach_orientation_faces_along_the_last_segment() {
        let wp = [
            Point2::new(0.0, 0.0),
            Point2::new(1.0, 0.0),
            Point2::new(1.0, 2.0),
        ];
        assert_eq!(final_yaw(false, &wp, 0.3), 0.3);
        assert!((final_yaw(true, &wp, 0.3) - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert_eq!(final_yaw(true, &wp[..1], 0.3), 0.3);
    }
}
