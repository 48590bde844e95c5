//! Planning requests: a goal or a GetPlan call becomes a planner-core query on the current map
//! with the current settings, run on tokio's blocking pool so the node keeps receiving meanwhile.
//! A newer goal or `max_planning_time` interrupts a running plan.

use crate::drive::{hand_topic_goal_to_recoveries, DriveEnd};
use crate::outputs::Outputs;
use crate::result::{Failure, Outcome, ResultCode};
use crate::state::{GoalRequest, GoalSlot, Handover, MapState, Shared};
use log::{error, info, warn};
use patrol_msgs::nav_msgs::{GetPlanRequest, GetPlanResponse, Path};
use planner_core::config::PlannerConfig;
use planner_core::geometry::{Point2, Pose2};
use planner_core::grid::GridMap;
use planner_core::planner::{Interrupt, PlanContext, PlannerRng};
use planner_core::{registry, PlannerName};
use rand::SeedableRng;
use ros_edge::service::ServiceServer;
use std::cell::Cell;
use std::sync::Arc;
use std::time::{Duration, Instant};
use tokio::sync::watch;

/// The most poses one request may pass through (`compute_path_through_poses`,
/// `navigate_through_poses`), as a route file holds at most this many points: each is a plan of
/// its own, so a request's work and memory grow with their number.
pub const MAX_POSES: usize = planner_core::route::file::MAX_POINTS;

/// Refuses a request through more than [`MAX_POSES`] poses (before it takes the robot or
/// starts a plan).
pub fn check_pose_count(n: usize) -> Result<(), Failure> {
    if n > MAX_POSES {
        return Err(Failure::new(
            ResultCode::InvalidInput,
            format!("{n} poses: at most {MAX_POSES} in one request"),
        ));
    }
    Ok(())
}

/// One planning request, whatever it came from (a goal, GetPlan, an action).
pub struct Request<'a> {
    pub start: Pose2,
    /// The poses to pass through in order, the last being the goal (one for most requests;
    /// `compute_path_through_poses` and `navigate_through_poses` send more).
    pub goals: &'a [Pose2],
    /// How far (m) an occupied goal (or via pose) may move to a free cell.
    pub tolerance: f64,
    /// The planner to use (an action's `planner_id`); `None`: the `planner` parameter.
    pub planner: Option<PlannerName>,
    /// Whether the caller has given the request up (a newer goal, an action's cancel).
    pub cancelled: &'a (dyn Fn() -> bool + Sync),
}

/// Plans on the current map with the current settings (blocking).
pub fn plan(s: &Shared, request: Request<'_>) -> Outcome {
    let Request {
        start,
        goals,
        tolerance,
        planner,
        cancelled,
    } = request;
    let live = s.live.read().expect("lock").clone();
    let chosen = planner.unwrap_or(live.planner);
    let seed = s.planning.seed.unwrap_or_else(rand::random);
    let failed = |f: Failure| Outcome::failed(chosen, seed, f);
    if let Some(refusal) = s.refusal() {
        return failed(refusal);
    }
    let Some(goal) = goals.last().copied() else {
        return failed(Failure::new(ResultCode::InvalidInput, "no goal given"));
    };
    if let Err(f) = check_pose_count(goals.len()) {
        return failed(f);
    }
    let Some(map) = s.current_map() else {
        return failed(Failure::new(
            ResultCode::NoMap,
            "no map yet: publish /map or set map_yaml",
        ));
    };
    let config = PlannerConfig {
        planner: chosen,
        ..live.config
    };
    let planner = match registry::build(&config) {
        Ok(p) => p,
        Err(e) => return failed(Failure::new(ResultCode::InvalidPlanner, e.to_string())),
    };
    let t0 = Instant::now();
    // The budget is each leg's, as planner_server gives each leg of ComputePathThroughPoses its
    // planner's own time: the deadline moves on as each leg starts.
    let budget =
        (live.max_planning_time > 0.0).then(|| Duration::from_secs_f64(live.max_planning_time));
    let leg_started = Cell::new(t0);
    // Deactivating the node (lifecycle) ends a plan under way, as planner_server's deactivated
    // action server ends its goal: stopped as a cancel is, answered below as NOT_ACTIVE.
    // Remembered: a node deactivated and activated again within the plan still ends it so.
    let deactivated = Cell::new(false);
    let interrupt = || {
        if s.refusal().is_some() {
            deactivated.set(true);
        }
        if cancelled() || deactivated.get() {
            Some(Interrupt::Cancelled)
        } else if budget.is_some_and(|b| leg_started.get().elapsed() >= b) {
            Some(Interrupt::Deadline)
        } else {
            None
        }
    };
    let next_leg = || leg_started.set(Instant::now());
    let mut rng = PlannerRng::seed_from_u64(seed);
    let mut ctx = PlanContext::new(&mut rng, &interrupt);
    ctx.on_leg = Some(&next_leg);
    let points: Vec<Point2> = goals.iter().map(|g| Point2::new(g.x, g.y)).collect();
    let result = planner_core::solve_through(
        planner.as_ref(),
        &map.grid,
        start.position(),
        &points,
        tolerance,
        config.solve_options(),
        &mut ctx,
    );
    let elapsed_ms = t0.elapsed().as_secs_f64() * 1e3;
    // An anytime planner interrupted by a cancel returns its best path so far; the caller has
    // given the request up, so that path is not the answer.
    let result = match result {
        Ok(plan) if cancelled() => {
            drop(plan);
            Err(planner_core::PlanError::Cancelled)
        }
        other => other,
    };
    // No plan of a node deactivated meanwhile is answered or published (nor an anytime
    // planner's best so far, which an interrupt leaves it).
    if deactivated.get() || s.refusal().is_some() {
        let refusal = s.refusal().unwrap_or_else(|| {
            Failure::new(
                ResultCode::NotActive,
                "the node was deactivated while it planned",
            )
        });
        return Outcome {
            elapsed_ms,
            ..failed(refusal)
        };
    }
    match result {
        // Logged where the answer is published (Outputs::diagnose), with every other outcome.
        Ok(plan) => Outcome {
            planner: chosen,
            result: Ok((plan, goal.yaw)),
            seed,
            elapsed_ms,
        },
        Err(e) => Outcome {
            planner: chosen,
            result: Err(Failure::from(e)),
            seed,
            elapsed_ms,
        },
    }
}

/// Validates a map into a planning grid (off the async threads) and makes it the current one;
/// returns it, or `None` when the map is refused (the current one stays).
pub async fn install_map(
    s: &Shared,
    map: GridMap,
    source: &str,
    level: log::Level,
) -> Option<Arc<MapState>> {
    // The costmap parameters and keepout mask as they are now; if either changes while this
    // grid is made, the grid is made again once installed (below).
    let settings = s.grid_settings();
    let (w, h) = (map.width(), map.height());
    // With a costmap topic the costmap is the planning grid, taken as it is (already inflated,
    // graded); otherwise the node inflates the map itself.
    let as_costmap = !s.params.costmap_topic.is_empty();
    match tokio::task::spawn_blocking(move || MapState::new(Arc::new(map), as_costmap, &settings))
        .await
    {
        Ok(Ok(state)) => {
            let state = Arc::new(state);
            *s.map.write().expect("lock") = Some(state.clone());
            // Judged once installed: settings that change after this are the remake's to see.
            let stale = !state.is_made_with(&s.grid_settings());
            s.grid_installed.notify_one();
            if stale {
                s.settings_changed.notify_one();
            }
            let grid = state.grid.info();
            if (grid.width, grid.height) == (w, h) {
                log::log!(level, "map from {source}: {w} x {h} cells");
            } else {
                log::log!(
                    level,
                    "map from {source}: {w} x {h} cells, planned on as {} x {} of {:.3} m \
                     (costmap.downsampling_factor)",
                    grid.width,
                    grid.height,
                    grid.resolution
                );
            }
            Some(state)
        }
        Ok(Err(e)) => {
            error!("map from {source} refused: {e}");
            None
        }
        Err(e) => {
            error!("map task: {e}");
            None
        }
    }
}

/// A GetPlan request: its own start when it names a frame, else the current pose; its own
/// tolerance when positive, else the node's.
pub async fn answer_get_plan(s: &Arc<Shared>, req: GetPlanRequest) -> Outcome {
    let planner = s.live.read().expect("lock").planner;
    let failed = |f: Failure| Outcome::failed(planner, 0, f);
    let goal = match s.pose_in_global(&req.goal).await {
        Ok(g) => g,
        Err(f) => return failed(f),
    };
    let start = if req.start.header.frame_id.is_empty() {
        match s.start.read().expect("lock").map(|(p, _)| p) {
            Some(p) => p,
            None => {
                return failed(Failure::new(
                    ResultCode::NoStartPose,
                    "the request has no start (empty frame) and no pose arrived yet",
                ))
            }
        }
    } else {
        match s.pose_in_global(&req.start).await {
            Ok(p) => p,
            Err(f) => return failed(f),
        }
    };
    let tolerance = if req.tolerance.is_finite() && req.tolerance > 0.0 {
        req.tolerance as f64
    } else {
        s.live.read().expect("lock").tolerance
    };
    plan_off_thread(s, start, vec![goal], tolerance, None, || false).await
}

/// [`plan`] from `start` through `goals` (the last is the goal) on tokio's blocking pool, so
/// the node keeps receiving meanwhile; a panic in the planner becomes an UNKNOWN answer (see
/// [`task_failure`]).
pub async fn plan_off_thread(
    s: &Arc<Shared>,
    start: Pose2,
    goals: Vec<Pose2>,
    tolerance: f64,
    planner: Option<PlannerName>,
    cancelled: impl Fn() -> bool + Send + Sync + 'static,
) -> Outcome {
    let s2 = s.clone();
    let answering = planner.unwrap_or(s.live.read().expect("lock").planner);
    if let Err(why) = wait_for_current_costmap(s).await {
        warn!("no plan: the costmap is not current: {why}");
        return Outcome::failed(
            answering,
            0,
            Failure::new(
                ResultCode::Timeout,
                format!("the costmap is not current: {why}"),
            ),
        );
    }
    tokio::task::spawn_blocking(move || {
        plan(
            &s2,
            Request {
                start,
                goals: &goals,
                tolerance,
                planner,
                cancelled: &cancelled,
            },
        )
    })
    .await
    .unwrap_or_else(|e| Outcome::failed(answering, 0, task_failure(e)))
}

/// Waits, as planner_server's `waitForCostmap`, up to `costmap_update_timeout` for every
/// obstacle layer source with an `expected_update_rate` to have read within it; the overdue
/// source if one stays so.
async fn wait_for_current_costmap(s: &Shared) -> Result<(), String> {
    let deadline = Instant::now() + Duration::from_secs_f64(s.params.costmap_update_timeout);
    loop {
        match crate::obstacle_layer::overdue_source(s) {
            None => return Ok(()),
            Some(why) if Instant::now() >= deadline => return Err(why),
            // planner_server polls at 100 Hz.
            Some(_) => tokio::time::sleep(Duration::from_millis(10)).await,
        }
    }
}

/// A planning task that did not return: a panic in a planner is a bug, never silent. It is
/// logged as an error and answered as UNKNOWN with the panic's message, and the node goes on.
pub fn task_failure(e: tokio::task::JoinError) -> Failure {
    let reason = match e.try_into_panic() {
        Ok(panic) => panic
            .downcast_ref::<&str>()
            .map(|m| m.to_string())
            .or_else(|| panic.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "a panic without a message".into()),
        Err(e) => e.to_string(),
    };
    error!("planning task panicked (a bug, please report it with the seed): {reason}");
    Failure::new(
        ResultCode::Unknown,
        format!("the planner panicked: {reason}"),
    )
}

/// Plans the newest goal in the slot, publishes the answer, and hands a successful plan to the
/// follower (a failed one stops the robot, and is recovered where a recovery may help: drive.rs). Goals that arrive faster than plans finish are
/// coalesced: only the newest is planned. A replan (a new map blocked the followed path)
/// replaces the path only while it is still followed, and a failed one tells the goal's drive
/// why ([`Shared::replan_failed`]).
pub async fn plan_goals(s: Arc<Shared>, o: Outputs, mut slot: watch::Receiver<GoalSlot>) {
    while slot.changed().await.is_ok() {
        let Some(GoalRequest {
            owner: id,
            goals,
            replaces,
        }) = slot.borrow_and_update().clone()
        else {
            continue;
        };
        if !s.owns_robot(id) {
            continue; // a newer goal is already waiting
        }
        // A replan goes through the via poses still ahead now (the robot drove on since the
        // block was seen), and only while its path is still followed (not arrived, ended).
        let goals = match &replaces {
            Some(path) => match s.goals_ahead_on(path) {
                Some(ahead) => ahead,
                None => continue,
            },
            None => goals,
        };
        let start = s.start.read().expect("lock").map(|(p, _)| p);
        let Some(start) = start else {
            let planner = s.live.read().expect("lock").planner;
            let f = Failure::new(
                ResultCode::NoStartPose,
                "no start pose yet: publish /initialpose, /amcl_pose or /odom",
            );
            o.diagnose(&s, &Outcome::failed(planner, 0, f)).await;
            s.done_topic_goal(id);
            continue;
        };
        let tolerance = s.live.read().expect("lock").tolerance;
        let s2 = s.clone();
        let newer_goal = move || !s2.owns_robot(id);
        let outcome = plan_off_thread(&s, start, goals.clone(), tolerance, None, newer_goal).await;
        if matches!(&outcome.result, Err(f) if f.code == ResultCode::Cancelled) {
            info!("plan for goal {id} cancelled by a newer goal");
            continue;
        }
        let path = o.publish(&s, &outcome).await;
        // A new plan replaces the one being followed; a failed goal stops the robot (the
        // follower loop brakes it within the acceleration limits). Either only while this goal
        // still has the robot: a newer goal, or an action's drive, may have taken it meanwhile.
        if s.params.follow_plan {
            match (path, &outcome.result) {
                (Some(p), Ok((plan, goal_yaw))) => {
                    let handover = Handover::new(goals, &p, &plan.via, *goal_yaw);
                    if let Some(replaced) = &replaces {
                        s.refollow(id, replaced, handover);
                    } else {
                        s.follow(id, handover);
                    }
                }
                (_, result) if replaces.is_some() => {
                    let why = match result {
                        Err(f) => f.clone(),
                        Ok(_) => {
                            Failure::new(ResultCode::Unknown, "the plan could not be published")
                        }
                    };
                    let stopped = s.replan_failed(
                        id,
                        replaces.as_ref().expect("a replan"),
                        Failure::new(
                            why.code,
                            format!(
                                "a new map blocked the path, and replanning failed: {}",
                                why.message
                            ),
                        ),
                    );
                    // An action's drive reads the reason and recovers; a /goal_pose has no
                    // drive yet, so it is handed to its recoveries here, as after a failed
                    // first plan (bt_navigator's tree recovers a failed replan the same way).
                    if stopped && s.topic_goal() == Some(id) {
                        if let Some(f) = s.take_failed_replan(id) {
                            hand_topic_goal_to_recoveries(&s, &o, goals, id, DriveEnd::NoPlan(f));
                        }
                    }
                }
                (_, result) => {
                    s.stop_following(id);
                    // bt_navigator's tree recovers a failed first plan as it recovers a stalled
                    // drive (a spin, a wait, a back-up, then plan again), where one may help.
                    if let Err(f) = result {
                        let end = DriveEnd::NoPlan(f.clone());
                        hand_topic_goal_to_recoveries(&s, &o, goals, id, end);
                    }
                }
            }
        }
        // A goal not driven now (failed, or only planned) is no longer navigating: a
        // `/goal_pose`'s navigation ends here, or on arrival (follow.rs), or with the drive
        // that recovers it when its plan fails or it makes no progress (drive.rs).
        if !s.is_following(id) {
            s.done_topic_goal(id);
        }
    }
}

/// `/patrol_planner/make_plan` (nav_msgs/GetPlan): every request answered, an empty plan on
/// failure with the reason on `/diagnostics`.
pub async fn serve_get_plan(
    s: Arc<Shared>,
    o: Outputs,
    server: ServiceServer<GetPlanRequest, GetPlanResponse>,
) {
    loop {
        let (id, req) = server.next_request().await;
        let outcome = answer_get_plan(&s, req).await;
        o.diagnose(&s, &outcome).await;
        let plan = match &outcome.result {
            Ok((plan, goal_yaw)) => o.path(&s, plan, *goal_yaw),
            Err(_) => Path {
                header: o.header(&s),
                poses: Vec::new(),
            },
        };
        server.respond(id, GetPlanResponse { plan }).await;
    }
}
