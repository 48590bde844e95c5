//! The ROS 2 plumbing of `patrol_planner`: topics, the GetPlan service and parameters around
//! planner-core, on ros2-client and tokio. All conversions live in [`crate::convert`]; planning
//! runs on tokio's blocking pool so the node keeps receiving while it plans.
//!
//! | direction | name | type | QoS |
//! |---|---|---|---|
//! | in | `/map` | nav_msgs/OccupancyGrid | reliable, transient local, depth 1 (like map_server) |
//! | in | `/goal_pose` | geometry_msgs/PoseStamped | reliable, volatile, depth 10 (RViz's 2D Goal Pose) |
//! | in | `/initialpose`, `/amcl_pose` | geometry_msgs/PoseWithCovarianceStamped | reliable, volatile |
//! | in | `/odom` | nav_msgs/Odometry | best effort (matches reliable and best-effort publishers) |
//! | out | `/map` | nav_msgs/OccupancyGrid | reliable, transient local (only with `map_yaml`) |
//! | out | `/plan` | nav_msgs/Path | reliable, transient local, depth 1 |
//! | out | `/diagnostics` | diagnostic_msgs/DiagnosticArray | reliable, volatile, depth 10 |
//! | out | `/patrol_planner/pareto` | visualization_msgs/MarkerArray | reliable, volatile, depth 1 |
//! | service | `/patrol_planner/make_plan` | nav_msgs/srv/GetPlan | reliable |
//! | out | `/rosout` | rcl_interfaces/Log | ros2-client's (reliable, transient local, depth 1) |
//!
//! A new goal cancels a plan still running for an older one (its interrupt callback sees the
//! goal counter move); goals that arrive faster than plans finish are coalesced to the newest.
//! Failed goals publish nothing on `/plan` (Nav2's planner server does the same) but always a
//! `/diagnostics` status with the reason.

use crate::convert::{self, Failure};
use crate::params::NodeParams;
use anyhow::Result;
use chassis_bridge::follower::{Follower, Status as FollowStatus};
use chassis_bridge::Twist2;
use log::{error, info, warn};
use patrol_msgs::diagnostic_msgs::DiagnosticArray;
use patrol_msgs::geometry_msgs::{
    PoseStamped, PoseWithCovarianceStamped, Twist, TwistStamped, Vector3,
};
use patrol_msgs::nav_msgs::{GetPlanRequest, GetPlanResponse, OccupancyGrid, Odometry, Path};
use patrol_msgs::std_msgs::Header;
use patrol_msgs::visualization_msgs::MarkerArray;
use planner_core::geometry::{Point2, Pose2};
use planner_core::grid::GridMap;
use planner_core::inflation::PlanningGrid;
use planner_core::planner::{Interrupt, Plan, PlanContext, PlannerRng, Query, SolveOptions};
use planner_core::registry;
use rand::SeedableRng;
use ros2_client::{
    qos::{Durability, History},
    MessageTypeName, Name, NodeName, NodeOptions, ParameterValue, Publisher, QosProfile,
    ServiceMapping, ServiceTypeName,
};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, RwLock};
use std::time::{Duration, Instant};

/// Settings that `ros2 param set` may change while the node runs.
#[derive(Clone, Debug)]
struct Live {
    planner: String,
    max_planning_time: f64,
    tolerance: f64,
}

/// A validated map with its planning grid.
struct MapState {
    map: GridMap,
    grid: PlanningGrid,
}

/// What the tasks share.
struct Shared {
    params: NodeParams,
    live: RwLock<Live>,
    map: RwLock<Option<Arc<MapState>>>,
    /// The latest start pose (map frame) and when it arrived.
    start: RwLock<Option<(Pose2, Instant)>>,
    /// Counts goals: a running goal plan stops when it moves on.
    goals: AtomicU64,
    /// The latest `/odom` pose (map frame) and when it arrived: the follower's feedback.
    odom: RwLock<Option<(Pose2, Instant)>>,
    /// The plan being followed, if any.
    follower: std::sync::Mutex<Option<Follower>>,
}

/// Checks a parameter value before ros2-client stores it; the reason goes back to `ros2 param set`.
fn validate_parameter(name: &str, value: &ParameterValue) -> Result<(), String> {
    match (name, value) {
        ("planner", ParameterValue::String(s)) => {
            registry::check_name(s).map_err(|e| e.to_string())
        }
        ("max_planning_time" | "tolerance", ParameterValue::Double(v))
            if v.is_finite() && *v >= 0.0 =>
        {
            Ok(())
        }
        ("max_planning_time" | "tolerance", v) => Err(format!(
            "{name} must be a finite non-negative double, not {v:?}"
        )),
        ("planner", v) => Err(format!("planner must be a string, not {v:?}")),
        _ => Err(format!("`{name}` cannot be set at run time")),
    }
}

/// Runs the node until Ctrl-C or SIGTERM.
pub async fn run(params: NodeParams) -> Result<()> {
    let live = Live {
        planner: params.planning.planner.clone(),
        max_planning_time: params.planning.max_planning_time,
        tolerance: params.planning.tolerance,
    };
    let shared = Arc::new(Shared {
        params: params.clone(),
        live: RwLock::new(live.clone()),
        map: RwLock::new(None),
        start: RwLock::new(None),
        goals: AtomicU64::new(0),
        odom: RwLock::new(None),
        follower: std::sync::Mutex::new(None),
    });
    let on_set = shared.clone();
    let options = NodeOptions::new()
        .enable_rosout(true)
        .start_parameter_services(true)
        .declare_parameter("planner", ParameterValue::String(live.planner.clone()))
        .declare_parameter(
            "max_planning_time",
            ParameterValue::Double(live.max_planning_time),
        )
        .declare_parameter("tolerance", ParameterValue::Double(live.tolerance))
        .parameter_validator(Box::new(validate_parameter))
        .parameter_set_action(Box::new(move |name, value| {
            let mut l = on_set
                .live
                .write()
                .map_err(|_| "state lock poisoned".to_string())?;
            match (name, value) {
                ("planner", ParameterValue::String(s)) => l.planner = s.clone(),
                ("max_planning_time", ParameterValue::Double(v)) => l.max_planning_time = *v,
                ("tolerance", ParameterValue::Double(v)) => l.tolerance = *v,
                _ => return Err(format!("`{name}` cannot be set at run time")),
            }
            info!("parameter {name} set to {value:?}");
            Ok(())
        }));
    let (context, domain) = ros_edge::context()?;
    let mut node = context.new_node(NodeName::new("/", "patrol_planner")?, options)?;
    let spinner = tokio::spawn(node.spinner()?.spin());
    // Every task holding a DDS reader or writer, so that shutdown can end them before the
    // node and its participant go (otherwise RustDDS logs an error for each endpoint).
    let mut tasks = tokio::task::JoinSet::new();
    ros_edge::logging::forward_to_rosout(node.logging_handle());

    let topic = |node: &mut ros2_client::Node,
                 ns: &str,
                 name: &str,
                 pkg: &str,
                 ty: &str,
                 qos: &QosProfile|
     -> Result<_> {
        Ok(node.create_topic(&Name::new(ns, name)?, MessageTypeName::new(pkg, ty), qos)?)
    };
    let latched = ros_edge::reliable(1, Durability::TransientLocal);
    let volatile = ros_edge::reliable(10, Durability::Volatile);
    let map_topic = topic(&mut node, "/", "map", "nav_msgs", "OccupancyGrid", &latched)?;
    let map_pub =
        Arc::new(node.create_publisher::<OccupancyGrid>(&map_topic, Some(latched.clone()))?);
    let map_sub = node.create_subscription::<OccupancyGrid>(&map_topic, Some(latched.clone()))?;
    let plan_topic = topic(&mut node, "/", "plan", "nav_msgs", "Path", &latched)?;
    let plan_pub = Arc::new(node.create_publisher::<Path>(&plan_topic, Some(latched.clone()))?);
    let diag_topic = topic(
        &mut node,
        "/",
        "diagnostics",
        "diagnostic_msgs",
        "DiagnosticArray",
        &volatile,
    )?;
    let diag_pub =
        Arc::new(node.create_publisher::<DiagnosticArray>(&diag_topic, Some(volatile.clone()))?);
    let pareto_qos = ros_edge::reliable(1, Durability::Volatile);
    let pareto_topic = topic(
        &mut node,
        "/patrol_planner",
        "pareto",
        "visualization_msgs",
        "MarkerArray",
        &pareto_qos,
    )?;
    let pareto_pub =
        Arc::new(node.create_publisher::<MarkerArray>(&pareto_topic, Some(pareto_qos))?);
    let goal_topic = topic(
        &mut node,
        "/",
        "goal_pose",
        "geometry_msgs",
        "PoseStamped",
        &volatile,
    )?;
    let goal_sub = node.create_subscription::<PoseStamped>(&goal_topic, Some(volatile.clone()))?;
    let initial_topic = topic(
        &mut node,
        "/",
        "initialpose",
        "geometry_msgs",
        "PoseWithCovarianceStamped",
        &volatile,
    )?;
    let initial_sub = node
        .create_subscription::<PoseWithCovarianceStamped>(&initial_topic, Some(volatile.clone()))?;
    let amcl_topic = topic(
        &mut node,
        "/",
        "amcl_pose",
        "geometry_msgs",
        "PoseWithCovarianceStamped",
        &volatile,
    )?;
    let amcl_sub =
        node.create_subscription::<PoseWithCovarianceStamped>(&amcl_topic, Some(volatile.clone()))?;
    let best_effort = QosProfile::subscription_default().history(History::KeepLast { depth: 5 });
    let odom_topic = topic(&mut node, "/", "odom", "nav_msgs", "Odometry", &best_effort)?;
    let odom_sub = node.create_subscription::<Odometry>(&odom_topic, Some(best_effort))?;
    let service_qos = ros_edge::reliable(10, Durability::Volatile);
    let server = node.create_server::<GetPlanRequest, GetPlanResponse>(
        ServiceMapping::Enhanced,
        &Name::new("/patrol_planner", "make_plan")?,
        &ServiceTypeName::new("nav_msgs", "GetPlan"),
        service_qos.clone(),
        service_qos,
    )?;
    let cmd_pub = if params.enable_stamped_cmd_vel {
        let t = topic(
            &mut node,
            "/",
            "cmd_vel",
            "geometry_msgs",
            "TwistStamped",
            &volatile,
        )?;
        CmdVel::Stamped(Arc::new(node.create_publisher(&t, Some(volatile.clone()))?))
    } else {
        let t = topic(
            &mut node,
            "/",
            "cmd_vel",
            "geometry_msgs",
            "Twist",
            &volatile,
        )?;
        CmdVel::Plain(Arc::new(node.create_publisher(&t, Some(volatile.clone()))?))
    };
    let limits_topic = topic(
        &mut node,
        "/patrol_planner",
        "twist_limits",
        "geometry_msgs",
        "Twist",
        &latched,
    )?;
    let limits_pub = node.create_publisher::<Twist>(&limits_topic, Some(latched.clone()))?;
    let out = Outputs {
        plan: plan_pub,
        diagnostics: diag_pub,
        pareto: pareto_pub,
        cmd_vel: cmd_pub,
    };
    // The limits, latched, so the chassis bridge always knows them (a cmd_vel-style Twist).
    let l = params.twist_limits;
    let limits_msg = Twist {
        linear: Vector3 {
            x: l.max_linear,
            y: 0.0,
            z: 0.0,
        },
        angular: Vector3 {
            x: 0.0,
            y: 0.0,
            z: l.max_angular,
        },
    };
    if let Err(e) = limits_pub.async_publish(limits_msg).await {
        warn!("/patrol_planner/twist_limits: {e:?}");
    }
    if params.follow_plan {
        tasks.spawn(follow(shared.clone(), out.clone()));
    }

    // The bundled map, loaded by the node itself and latched on /map.
    if !params.map_yaml.is_empty() {
        let path = params.map_yaml.clone();
        match tokio::task::spawn_blocking(move || {
            planner_io::load_map_server(std::path::Path::new(&path))
        })
        .await?
        {
            Ok(map) => {
                let msg = convert::msg_from_grid(&map, &params.global_frame, ros_edge::now());
                install_map(&shared, map, "map_yaml").await;
                if let Err(e) = map_pub.async_publish(msg).await {
                    error!("publishing the map on /map: {e:?}");
                }
            }
            Err(e) => error!("map_yaml: {e}; waiting for /map instead"),
        }
    }

    // /map
    let (s, o) = (shared.clone(), out.clone());
    tasks.spawn(async move {
        loop {
            match map_sub.async_take().await {
                Ok((msg, _)) => {
                    match tokio::task::spawn_blocking(move || convert::grid_from_msg(&msg)).await {
                        Ok(Ok(map)) => install_map(&s, map, "/map").await,
                        Ok(Err(e)) => {
                            let f = Failure::new(
                                "INVALID_INPUT",
                                format!("map on /map refused, keeping the last good one: {e}"),
                            );
                            o.diagnose(&s, 0, Err(&f), 0.0).await;
                        }
                        Err(e) => error!("map task: {e}"),
                    }
                }
                Err(e) => warn!("/map: {e:?}"),
            }
        }
    });

    // Start poses: the latest of /initialpose, /amcl_pose and /odom wins.
    for (name, sub) in [("/initialpose", initial_sub), ("/amcl_pose", amcl_sub)] {
        let s = shared.clone();
        tasks.spawn(async move {
            loop {
                let Ok((msg, _)) = sub.async_take().await else {
                    continue;
                };
                let stamped = PoseStamped {
                    header: msg.header,
                    pose: msg.pose.pose,
                };
                match convert::pose_in_frame(&stamped, &s.params.global_frame) {
                    Ok(p) => *s.start.write().expect("lock") = Some((p, Instant::now())),
                    Err(f) => warn!("{name} ignored: {}", f.message),
                }
            }
        });
    }
    let s = shared.clone();
    tasks.spawn(async move {
        loop {
            let Ok((msg, _)) = odom_sub.async_take().await else {
                continue;
            };
            match convert::pose2(&msg.pose.pose) {
                Ok(p) => {
                    let [ox, oy, oyaw] = s.params.map_to_odom;
                    let (sn, cs) = oyaw.sin_cos();
                    let in_map = Pose2::new(
                        ox + cs * p.x - sn * p.y,
                        oy + sn * p.x + cs * p.y,
                        p.yaw + oyaw,
                    );
                    *s.start.write().expect("lock") = Some((in_map, Instant::now()));
                    *s.odom.write().expect("lock") = Some((in_map, Instant::now()));
                }
                Err(f) => warn!("/odom ignored: {}", f.message),
            }
        }
    });

    // Goals: checked on arrival, then coalesced so that only the newest is planned.
    let (goal_tx, mut goal_rx) = tokio::sync::watch::channel::<Option<(u64, Pose2)>>(None);
    let (s, o) = (shared.clone(), out.clone());
    tasks.spawn(async move {
        loop {
            let Ok((msg, _)) = goal_sub.async_take().await else {
                continue;
            };
            match convert::pose_in_frame(&msg, &s.params.global_frame) {
                Ok(goal) => {
                    let id = s.goals.fetch_add(1, Ordering::SeqCst) + 1;
                    // Fails only when the planning task has ended, i.e. during shutdown.
                    let _ = goal_tx.send(Some((id, goal)));
                }
                Err(f) => o.diagnose(&s, 0, Err(&f), 0.0).await,
            }
        }
    });
    let (s, o) = (shared.clone(), out.clone());
    tasks.spawn(async move {
        while goal_rx.changed().await.is_ok() {
            let Some((id, goal)) = *goal_rx.borrow_and_update() else {
                continue;
            };
            if s.goals.load(Ordering::SeqCst) != id {
                continue; // a newer goal is already waiting
            }
            let start = s.start.read().expect("lock").map(|(p, _)| p);
            let Some(start) = start else {
                o.diagnose(
                    &s,
                    0,
                    Err(&Failure::new(
                        "NO_START_POSE",
                        "no start pose yet: publish /initialpose, /amcl_pose or /odom",
                    )),
                    0.0,
                )
                .await;
                continue;
            };
            let tolerance = s.live.read().expect("lock").tolerance;
            let s2 = s.clone();
            let Ok(outcome) =
                tokio::task::spawn_blocking(move || plan(&s2, start, goal, tolerance, Some(id)))
                    .await
            else {
                continue;
            };
            if matches!(&outcome.result, Err(f) if f.code == "CANCELLED") {
                info!("plan for goal {id} cancelled by a newer goal");
                continue;
            }
            let path = o.publish(&s, &outcome).await;
            if s.params.follow_plan {
                // A new plan replaces the one being followed; a failed goal stops the robot.
                let next = path.and_then(|p| {
                    let pts = p
                        .poses
                        .iter()
                        .map(|q| (q.pose.position.x, q.pose.position.y))
                        .collect();
                    Follower::new(
                        s.params.follower,
                        pts,
                        outcome.result.as_ref().map_or(0.0, |r| r.1),
                    )
                });
                let stop = next.is_none();
                *s.follower.lock().expect("lock") = next;
                if stop {
                    o.drive(&s, Twist2::STOP).await;
                }
            }
        }
    });

    // GetPlan: its own start when the request names a frame, else the current pose.
    let (s, o) = (shared.clone(), out.clone());
    tasks.spawn(async move {
        loop {
            let (id, req) = match server.async_receive_request().await {
                Ok(r) => r,
                Err(e) => {
                    warn!("make_plan: {e:?}");
                    continue;
                }
            };
            let outcome = answer_get_plan(&s, req).await;
            o.diagnose(
                &s,
                outcome.seed,
                outcome.result.as_ref().map(|(p, _)| p),
                outcome.elapsed_ms,
            )
            .await;
            let plan = match &outcome.result {
                Ok((plan, goal_yaw)) => o.path(&s, plan, *goal_yaw),
                Err(_) => Path {
                    header: o.header(&s),
                    poses: Vec::new(),
                },
            };
            if let Err(e) = server
                .async_send_response(id, GetPlanResponse { plan })
                .await
            {
                warn!("make_plan response: {e:?}");
            }
        }
    });

    info!(
        "patrol_planner ready on ROS_DOMAIN_ID {domain}: planner {}, frame {}",
        live.planner, params.global_frame
    );
    let mut term = tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate())?;
    tokio::select! {
        _ = tokio::signal::ctrl_c() => info!("Ctrl-C: shutting down"),
        _ = term.recv() => info!("SIGTERM: shutting down"),
    }
    ros_edge::logging::stop_forwarding();
    tasks.shutdown().await;
    // Dropping the node stops its spinner, which holds the node's own endpoints (parameter
    // services, rosout); they must go before the participant does, when `context` drops.
    drop(node);
    let _ = spinner.await;
    Ok(())
}

/// The follower loop: at `control_rate_hz`, the next command for the plan being followed, from
/// the latest `/odom`, within the twist and acceleration limits. It stops when odometry is stale
/// and when the goal is reached (within position and heading tolerance).
async fn follow(s: Arc<Shared>, o: Outputs) {
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

async fn answer_get_plan(s: &Arc<Shared>, req: GetPlanRequest) -> Outcome {
    let failed = |f: Failure| Outcome {
        result: Err(f),
        seed: 0,
        elapsed_ms: 0.0,
    };
    let goal = match convert::pose_in_frame(&req.goal, &s.params.global_frame) {
        Ok(g) => g,
        Err(f) => return failed(f),
    };
    let start = if req.start.header.frame_id.is_empty() {
        match s.start.read().expect("lock").map(|(p, _)| p) {
            Some(p) => p,
            None => {
                return failed(Failure::new(
                    "NO_START_POSE",
                    "the request has no start (empty frame) and no pose arrived yet",
                ))
            }
        }
    } else {
        match convert::pose_in_frame(&req.start, &s.params.global_frame) {
            Ok(p) => p,
            Err(f) => return failed(f),
        }
    };
    let tolerance = if req.tolerance.is_finite() && req.tolerance > 0.0 {
        req.tolerance as f64
    } else {
        s.live.read().expect("lock").tolerance
    };
    let s2 = s.clone();
    tokio::task::spawn_blocking(move || plan(&s2, start, goal, tolerance, None))
        .await
        .unwrap_or_else(|e| {
            failed(Failure::new(
                "NO_VALID_PATH",
                format!("planning task failed: {e}"),
            ))
        })
}

/// What one request produced.
struct Outcome {
    /// The plan and the goal's heading, or why not.
    result: Result<(Plan, f64), Failure>,
    seed: u64,
    elapsed_ms: f64,
}

/// Plans on the current map with the current settings (blocking). `goal_id` makes the plan
/// stop when a newer goal arrives.
fn plan(s: &Shared, start: Pose2, goal: Pose2, tolerance: f64, goal_id: Option<u64>) -> Outcome {
    let live = s.live.read().expect("lock").clone();
    let seed = s.params.planning.seed.unwrap_or_else(rand::random);
    let failed = |f: Failure| Outcome {
        result: Err(f),
        seed,
        elapsed_ms: 0.0,
    };
    let Some(map) = s.map.read().expect("lock").clone() else {
        return failed(Failure::new(
            "NO_MAP",
            "no map yet: publish /map or set map_yaml",
        ));
    };
    let mut config = s.params.planning.clone();
    config.planner = live.planner.clone();
    let planner = match registry::build(&live.planner, &config) {
        Ok(p) => p,
        Err(e) => return failed(Failure::new("INVALID_PLANNER", e.to_string())),
    };
    let t0 = Instant::now();
    let deadline = (live.max_planning_time > 0.0)
        .then(|| t0 + Duration::from_secs_f64(live.max_planning_time));
    let interrupt = || {
        if goal_id.is_some_and(|id| s.goals.load(Ordering::SeqCst) != id) {
            Some(Interrupt::Cancelled)
        } else if deadline.is_some_and(|d| Instant::now() >= d) {
            Some(Interrupt::Deadline)
        } else {
            None
        }
    };
    let mut rng = PlannerRng::seed_from_u64(seed);
    let mut ctx = PlanContext {
        rng: &mut rng,
        interrupt: &interrupt,
    };
    let query = Query {
        start: start.position(),
        goal: Point2::new(goal.x, goal.y),
        tolerance,
    };
    let result = planner_core::solve(
        planner.as_ref(),
        &map.grid,
        &query,
        SolveOptions {
            smoothing: config.smoothing,
        },
        &mut ctx,
    );
    let elapsed_ms = t0.elapsed().as_secs_f64() * 1e3;
    match result {
        // Logged where the answer is published (Outputs::diagnose), with every other outcome.
        Ok(plan) => Outcome {
            result: Ok((plan, goal.yaw)),
            seed,
            elapsed_ms,
        },
        Err(e) => Outcome {
            result: Err(Failure::from(e)),
            seed,
            elapsed_ms,
        },
    }
}

async fn install_map(s: &Shared, map: GridMap, source: &str) {
    let costmap = s.params.planning.costmap.clone();
    let (w, h) = (map.width(), map.height());
    match tokio::task::spawn_blocking(move || {
        PlanningGrid::new(&map, &costmap).map(|grid| MapState { map, grid })
    })
    .await
    {
        Ok(Ok(state)) => {
            *s.map.write().expect("lock") = Some(Arc::new(state));
            info!("map from {source}: {w} x {h} cells");
        }
        Ok(Err(e)) => error!("map from {source} refused: {e}"),
        Err(e) => error!("map task: {e}"),
    }
}

/// The publishers every request answers on.
#[derive(Clone)]
struct Outputs {
    plan: Arc<Publisher<Path>>,
    diagnostics: Arc<Publisher<DiagnosticArray>>,
    pareto: Arc<Publisher<MarkerArray>>,
    cmd_vel: CmdVel,
}

/// `/cmd_vel` as Twist, or as TwistStamped (`enable_stamped_cmd_vel`).
#[derive(Clone)]
enum CmdVel {
    Plain(Arc<Publisher<Twist>>),
    Stamped(Arc<Publisher<TwistStamped>>),
}

impl Outputs {
    /// A velocity command on `/cmd_vel`.
    async fn drive(&self, s: &Shared, t: Twist2) {
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

    fn header(&self, s: &Shared) -> Header {
        Header {
            stamp: ros_edge::now(),
            frame_id: s.params.global_frame.clone(),
        }
    }

    async fn diagnose(
        &self,
        s: &Shared,
        seed: u64,
        result: Result<&Plan, &Failure>,
        elapsed_ms: f64,
    ) {
        let planner = s.live.read().expect("lock").planner.clone();
        // The one place every answer is logged (terminal and /rosout) with its reason.
        match result {
            Ok(plan) => info!(
                "{planner}: {:.2} m, {:.2} rad of turning in {elapsed_ms:.1} ms (seed {seed})",
                plan.metrics.length_m, plan.metrics.turning_rad
            ),
            Err(f) => warn!("{planner}: {}: {} (seed {seed})", f.code, f.message),
        }
        let msg = convert::diagnostics(self.header(s), &planner, seed, result, elapsed_ms);
        if let Err(e) = self.diagnostics.async_publish(msg).await {
            warn!("/diagnostics: {e:?}");
        }
    }

    /// A plan as nav_msgs/Path, densified at the current map's resolution.
    fn path(&self, s: &Shared, plan: &Plan, goal_yaw: f64) -> Path {
        let spacing = s
            .map
            .read()
            .expect("lock")
            .as_ref()
            .map_or(0.05, |m| m.map.info().resolution);
        convert::path_msg(&plan.waypoints, goal_yaw, spacing, self.header(s))
    }

    /// A goal's answer: `/plan` (on success), the Pareto markers, and `/diagnostics`. Returns the
    /// published path.
    async fn publish(&self, s: &Shared, outcome: &Outcome) -> Option<Path> {
        let mut published = None;
        if let Ok((plan, goal_yaw)) = &outcome.result {
            let path = self.path(s, plan, *goal_yaw);
            published = Some(path.clone());
            if let Err(e) = self.plan.async_publish(path).await {
                warn!("/plan: {e:?}");
            }
            if s.params.publish_pareto && !plan.pareto.is_empty() {
                if let Err(e) = self
                    .pareto
                    .async_publish(convert::pareto_markers(plan, self.header(s)))
                    .await
                {
                    warn!("/patrol_planner/pareto: {e:?}");
                }
            }
        }
        self.diagnose(
            s,
            outcome.seed,
            outcome.result.as_ref().map(|(p, _)| p),
            outcome.elapsed_ms,
        )
        .await;
        published
    }
}
