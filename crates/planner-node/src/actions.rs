//! Nav2's planner-server actions, so bt_navigator and nav2_simple_commander (`getPath`,
//! `getPathThroughPoses`) can use this node in place of planner_server:
//! `compute_path_to_pose` and `compute_path_through_poses` (nav2_msgs, Jazzy), with Nav2's error
//! codes and messages, cancel, and a newer goal as planner_server takes it (it waits for the
//! running one, and an older goal still waiting ends aborted: `Preemption::Queue`). Each answer
//! also goes out on `/plan` and `/diagnostics`, as a goal on `/goal_pose` does; the actions plan
//! only, they do not drive.

use crate::action_server::GoalStop;
use crate::action_server::Preemption;
use crate::outputs::Outputs;
use crate::planning;
use crate::result::{Failure, ResultCode};
use crate::state::Shared;
use log::{info, warn};
use patrol_msgs::geometry_msgs::PoseStamped;
use patrol_msgs::nav2_msgs::{
    ComputePathResult, ComputePathThroughPosesGoal, ComputePathToPoseGoal, EmptyFeedback,
};
use ros2_client::action::{AsyncActionServer, GoalEndStatus};
use ros2_client::Message;
use std::sync::Arc;

/// What the two planner actions' goals have in common.
pub trait PlannerGoal: Message + Clone + Send + Sync + 'static {
    /// The poses to pass through, in order (the last is the goal).
    fn poses(&self) -> &[PoseStamped];
    fn start(&self) -> &PoseStamped;
    fn planner_id(&self) -> &str;
    fn use_start(&self) -> bool;
    /// The action's error-code base: 200 for ComputePathToPose, 300 for ComputePathThroughPoses.
    const CODE_BASE: u16;
    /// The action's name, for logs.
    const NAME: &'static str;
}

impl PlannerGoal for ComputePathToPoseGoal {
    fn poses(&self) -> &[PoseStamped] {
        std::slice::from_ref(&self.goal)
    }
    fn start(&self) -> &PoseStamped {
        &self.start
    }
    fn planner_id(&self) -> &str {
        &self.planner_id
    }
    fn use_start(&self) -> bool {
        self.use_start
    }
    const CODE_BASE: u16 = 200;
    const NAME: &'static str = "compute_path_to_pose";
}

impl PlannerGoal for ComputePathThroughPosesGoal {
    fn poses(&self) -> &[PoseStamped] {
        &self.goals
    }
    fn start(&self) -> &PoseStamped {
        &self.start
    }
    fn planner_id(&self) -> &str {
        &self.planner_id
    }
    fn use_start(&self) -> bool {
        self.use_start
    }
    const CODE_BASE: u16 = 300;
    const NAME: &'static str = "compute_path_through_poses";
}

/// ComputePathThroughPoses' NO_VIAPOINTS_GIVEN (navigate_through_poses answers an empty goal
/// with it too, as bt_navigator's planner call would).
pub const NO_VIAPOINTS_GIVEN: u16 = 309;

/// Nav2's code for a failure, in the action's range: UNKNOWN (base + 0) .. NO_VALID_PATH
/// (base + 8). This node's own codes have no Nav2 number and map onto the nearest: a missing
/// start pose is planner_server's TF_ERROR (it could not look the robot up), a malformed
/// request, a missing map or a panic UNKNOWN (the message says which).
pub fn nav2_code(code: ResultCode, base: u16) -> u16 {
    let offset = match code {
        ResultCode::None => return 0,
        ResultCode::Unknown
        | ResultCode::InvalidInput
        | ResultCode::NoMap
        | ResultCode::NotActive
        | ResultCode::TooLarge
        | ResultCode::Busy
        | ResultCode::Cancelled => 0,
        ResultCode::InvalidPlanner => 1,
        ResultCode::TfError | ResultCode::NoStartPose => 2,
        ResultCode::StartOutsideMap => 3,
        ResultCode::GoalOutsideMap => 4,
        ResultCode::StartOccupied => 5,
        ResultCode::GoalOccupied => 6,
        ResultCode::Timeout => 7,
        ResultCode::NoValidPath => 8,
    };
    base + offset
}

/// Serves one planner action until the node stops (the door: action_server.rs).
pub async fn serve<G: PlannerGoal>(
    s: Arc<Shared>,
    o: Outputs,
    server: AsyncActionServer<G, ComputePathResult, EmptyFeedback>,
) {
    crate::action_server::serve(
        s,
        o,
        G::NAME,
        Preemption::Queue,
        server,
        |s, o, goal: G, stop, _feedback| async move { run_goal(&s, &o, &goal, &stop).await },
    )
    .await
}

/// Plans one goal, through each of its poses in order (planning.rs, planner-core's
/// `solve_through`: one time budget for the whole request, as planner_server's), and builds its
/// result.
async fn run_goal<G: PlannerGoal>(
    s: &Arc<Shared>,
    o: &Outputs,
    goal: &G,
    stop: &GoalStop,
) -> (GoalEndStatus, ComputePathResult) {
    let t0 = std::time::Instant::now();
    let failed = |code: u16, message: String| {
        warn!("{}: {code}: {message}", G::NAME);
        (
            GoalEndStatus::Aborted,
            ComputePathResult {
                error_code: code,
                error_msg: message,
                planning_time: crate::convert::duration_msg(t0.elapsed()),
                ..ComputePathResult::default()
            },
        )
    };
    if goal.poses().is_empty() {
        return failed(NO_VIAPOINTS_GIVEN, "no goals given".into());
    }
    if let Err(f) = planning::check_pose_count(goal.poses().len()) {
        return failed(nav2_code(f.code, G::CODE_BASE), f.message);
    }
    let planner = match s.params.planner_for_id(goal.planner_id()) {
        Ok(p) => p,
        Err(reason) => return failed(G::CODE_BASE + 1, reason),
    };
    // Every pose is carried into the global frame once, as the goal arrives: a pose in
    // `base_link` is relative to where the robot is now, not where it will be after a leg.
    let mut targets = Vec::with_capacity(goal.poses().len());
    for pose in goal.poses() {
        match s.pose_in_global(pose).await {
            Ok(p) => targets.push(p),
            Err(f) => return failed(nav2_code(f.code, G::CODE_BASE), f.message),
        }
    }
    let from = if goal.use_start() {
        match s.pose_in_global(goal.start()).await {
            Ok(p) => p,
            Err(f) => return failed(nav2_code(f.code, G::CODE_BASE), f.message),
        }
    } else {
        match s.start.read().expect("lock").map(|(p, _)| p) {
            Some(p) => p,
            None => return failed(
                nav2_code(ResultCode::NoStartPose, G::CODE_BASE),
                "no robot pose yet (use_start is false): publish /initialpose, /amcl_pose or /odom"
                    .into(),
            ),
        }
    };
    let tolerance = s.live.read().expect("lock").tolerance;
    let stop_plan = stop.clone();
    let outcome = planning::plan_off_thread(s, from, targets, tolerance, planner, move || {
        stop_plan.requested()
    })
    .await;
    match &outcome.result {
        Err(f) if f.code == ResultCode::Cancelled => {
            o.diagnose(s, &outcome).await;
            // A cancel (planner goals wait for each other: none is preempted).
            let why = stop.reason();
            info!("{}: {why}", G::NAME);
            (
                stop.end_status(),
                ComputePathResult {
                    error_code: if stop.preempted() { G::CODE_BASE } else { 0 },
                    error_msg: why.into(),
                    planning_time: crate::convert::duration_msg(t0.elapsed()),
                    ..ComputePathResult::default()
                },
            )
        }
        Err(Failure { code, message }) => {
            o.diagnose(s, &outcome).await;
            failed(nav2_code(*code, G::CODE_BASE), message.clone())
        }
        // The path also goes out on /plan, as planner_server publishes every plan.
        Ok(_) => match o.publish(s, &outcome).await {
            Some(path) => (
                GoalEndStatus::Succeeded,
                ComputePathResult {
                    path,
                    planning_time: crate::convert::duration_msg(t0.elapsed()),
                    error_code: 0,
                    error_msg: String::new(),
                },
            ),
            None => failed(G::CODE_BASE, "the plan could not be published".into()),
        },
    }
}

/// The most poses a path handed to the node (`follow_path`, `is_path_valid`) may have: a
/// million-pose path would be 100 km at Nav2's 0.1 m spacing; the bound keeps a malformed one
/// from costing the node its memory.
pub const MAX_GIVEN_PATH_POSES: usize = 1_000_000;

/// The indices of the poses of `path` (map frame, metres) the robot cannot be at or reach from
/// the pose before: a pose outside the map or in an obstacle or the inflated band, or one the
/// segment from its predecessor reaches only through an obstacle. Nav2's `is_path_valid` asks the
/// same of the costmap (lethal or inscribed cost). With `costmap.downsampling_factor` the grid is
/// the coarse one the plans are made on, not the full costmap Nav2 asks: a coarse cell is blocked
/// when any of its cells is, so a path may be called invalid that only the full grid lets pass,
/// but a colliding path is never called valid.
pub fn invalid_poses(grid: &planner_core::grid::PlanningGrid, path: &[(f64, f64)]) -> Vec<i32> {
    use planner_core::geometry::Point2;
    use planner_core::grid::raycast::line_of_sight;
    let info = grid.info();
    let mut previous: Option<Point2> = None;
    let mut invalid = Vec::new();
    for (i, &(x, y)) in path.iter().enumerate() {
        let world = Point2::new(x, y);
        let free =
            x.is_finite() && y.is_finite() && grid.cell_at(world).is_some_and(|c| grid.is_free(c));
        let here = info.world_to_grid(world);
        let reachable = previous.is_none_or(|p| line_of_sight(grid, p, here));
        if !(free && reachable) {
            invalid.push(i as i32);
        }
        previous = free.then_some(here);
    }
    invalid
}

/// `is_path_valid` (nav2_msgs/srv/IsPathValid), as planner_server answers it: the path against
/// the current map and the robot's inflation, from the pose nearest the robot on (the part
/// already driven may have been blocked since, and does not matter), the indices those of the
/// whole path. An empty path is invalid, as in Nav2. Invalid too, with no indices and the
/// reason logged: a path in another frame, a path of more than [`MAX_GIVEN_PATH_POSES`] poses
/// (refused unchecked, as `follow_path` refuses it), or a node that is not active or has no
/// map. The check runs off the async threads: a long path on a fine map is many line-of-sight
/// walks.
pub async fn serve_is_path_valid(
    s: Arc<Shared>,
    server: ros_edge::service::ServiceServer<
        patrol_msgs::nav2_msgs::IsPathValidRequest,
        patrol_msgs::nav2_msgs::IsPathValidResponse,
    >,
) {
    use patrol_msgs::nav2_msgs::IsPathValidResponse;
    loop {
        let (id, req) = server.next_request().await;
        let poses = &req.path.poses;
        let frame = crate::convert::frame_name(&req.path.header.frame_id);
        let refusal = if let Some(f) = s.refusal() {
            Some(f.message)
        } else if poses.is_empty() {
            Some("the path is empty".into())
        } else if poses.len() > MAX_GIVEN_PATH_POSES {
            Some(format!(
                "{} poses, more than the {MAX_GIVEN_PATH_POSES} checked",
                poses.len()
            ))
        } else if !frame.is_empty() && frame != s.params.global_frame {
            Some(format!(
                "the path is in `{frame}`, this node checks paths in `{}`",
                s.params.global_frame
            ))
        } else {
            None
        };
        // A refused path is answered without the map (a burst of them fetches nothing).
        let map = match refusal {
            None => s.current_map_off_thread().await,
            Some(_) => None,
        };
        let response = match (refusal, map) {
            (Some(why), _) => {
                warn!("is_path_valid: invalid: {why}");
                IsPathValidResponse::default()
            }
            (None, None) => {
                warn!("is_path_valid: invalid: no map yet");
                IsPathValidResponse::default()
            }
            (None, Some(map)) => {
                let points: Vec<(f64, f64)> = poses
                    .iter()
                    .map(|p| (p.pose.position.x, p.pose.position.y))
                    .collect();
                let robot = s.start.read().expect("lock").map(|(p, _)| (p.x, p.y));
                let check = move || {
                    let from = robot.map_or(0, |r| nearest_pose(&points, r));
                    let invalid = invalid_poses(&map.grid, &points[from..]);
                    invalid
                        .into_iter()
                        .map(|i| i + from as i32)
                        .collect::<Vec<_>>()
                };
                match tokio::task::spawn_blocking(check).await {
                    Ok(invalid) => IsPathValidResponse {
                        is_valid: invalid.is_empty(),
                        invalid_pose_indices: invalid,
                    },
                    Err(_) => {
                        warn!("is_path_valid: invalid: the check did not finish");
                        IsPathValidResponse::default()
                    }
                }
            }
        };
        server.respond(id, response).await;
    }
}

/// The index of the pose of `path` nearest `robot` (the first of equals), where planner_server's
/// is_path_valid starts its check. `path` is not empty.
fn nearest_pose(path: &[(f64, f64)], robot: (f64, f64)) -> usize {
    let d = |p: &(f64, f64)| (p.0 - robot.0).hypot(p.1 - robot.1);
    path.iter()
        .enumerate()
        .fold((0, f64::INFINITY), |best, (i, p)| {
            let di = d(p);
            if di < best.1 {
                (i, di)
            } else {
                best
            }
        })
        .0
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Nav2 starts at the pose nearest the robot, the first of equals; a NaN pose is never
    /// the nearest.
    #[test]
    fn the_check_starts_at_the_pose_nearest_the_robot() {
        let path = [
            (0.0, 0.0),
            (1.0, 0.0),
            (f64::NAN, 0.0),
            (2.0, 0.0),
            (1.0, 0.0),
        ];
        assert_eq!(nearest_pose(&path, (1.1, 0.2)), 1);
        assert_eq!(nearest_pose(&path, (5.0, 0.0)), 3);
        assert_eq!(nearest_pose(&path, (-1.0, 0.0)), 0);
    }

    #[test]
    fn invalid_poses_are_those_in_or_behind_an_obstacle() {
        use planner_core::geometry::Pose2;
        use planner_core::grid::{MapInfo, PlanningGrid};
        // 10 x 3 cells of 1 m, a wall at x = 5 in the middle row only... and all rows: blocked.
        let info = MapInfo {
            width: 10,
            height: 3,
            resolution: 1.0,
            origin: Pose2::default(),
        };
        let obstacle: Vec<bool> = (0..30).map(|i| i % 10 == 5).collect();
        let grid = PlanningGrid::from_obstacles(info, obstacle, 0.0);
        let free = [(0.5, 1.5), (2.5, 1.5), (4.5, 1.5)];
        assert!(invalid_poses(&grid, &free).is_empty());
        // Into the wall (index 1), then beyond it: index 2 is free but reached only through the
        // wall from a blocked predecessor, so it counts as reachable (its predecessor is invalid
        // already); outside the map (3), NaN (4).
        let crossing = [
            (4.5, 1.5),
            (5.5, 1.5),
            (6.5, 1.5),
            (20.0, 1.5),
            (f64::NAN, 0.0),
        ];
        assert_eq!(invalid_poses(&grid, &crossing), vec![1, 3, 4]);
        // Jumping the wall in one segment: the pose after it is invalid.
        assert_eq!(invalid_poses(&grid, &[(4.5, 1.5), (6.5, 1.5)]), vec![1]);
    }

    #[test]
    fn nav2_codes_in_each_actions_range() {
        assert_eq!(nav2_code(ResultCode::GoalOccupied, 200), 206);
        assert_eq!(nav2_code(ResultCode::GoalOutsideMap, 200), 204);
        assert_eq!(nav2_code(ResultCode::NoValidPath, 300), 308);
        assert_eq!(nav2_code(ResultCode::NoStartPose, 200), 202);
        assert_eq!(nav2_code(ResultCode::NoMap, 300), 300);
        assert_eq!(nav2_code(ResultCode::None, 200), 0);
    }
}
