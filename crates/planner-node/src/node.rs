//! The ROS 2 wiring of `patrol_planner`: the node, its parameters, every topic and the GetPlan
//! service, each served by one task: inputs in [`crate::inputs`], planning in
//! [`crate::planning`] (on tokio's blocking pool, so the node keeps receiving while it plans),
//! answers in [`crate::outputs`], the path follower in [`crate::follow`], the shared state in
//! [`crate::state`]. All message conversions live in [`crate::convert`].
//!
//! | direction | name | type | QoS |
//! |---|---|---|---|
//! | in | `/map` | nav_msgs/OccupancyGrid | reliable, transient local, depth 1 (like map_server) |
//! | in | `/goal_pose` | geometry_msgs/PoseStamped | reliable, volatile, depth 10 (RViz's 2D Goal Pose) |
//! | in | `/initialpose`, `/amcl_pose` | geometry_msgs/PoseWithCovarianceStamped | reliable, volatile |
//! | in | `input_at_waypoint.input_topic` (`input_at_waypoint/input`) | std_msgs/Empty | reliable, volatile, depth 10 (only with `follow_plan` and `input_at_waypoint.enabled`) |
//! | in | `photo_at_waypoint.image_topic` (`/camera/color/image_raw`) | sensor_msgs/Image | best effort, depth 5 (only with `follow_plan` and `photo_at_waypoint.enabled`: photo_at_waypoint.rs) |
//! | in | `/clock` | rosgraph_msgs/Clock | best effort, depth 1 (only with `use_sim_time`: every stamp is its time) |
//! | in | `behavior_server.cmd_vel_teleop` (`cmd_vel_teleop`), `preempt_teleop` | geometry_msgs/Twist (TwistStamped with `enable_stamped_cmd_vel`), std_msgs/Empty | reliable, volatile, depth 10 (only with `follow_plan`: assisted_teleop.rs) |
//! | in | `/odom` | nav_msgs/Odometry | best effort (matches reliable and best-effort publishers) |
//! | in | each `obstacle_layer.<source>.topic` (`scan`) | sensor_msgs/LaserScan or PointCloud2 (`<source>.data_type`) | best effort, depth 5 (not with `costmap_topic`; passed over while `obstacle_layer.enabled` is false: obstacle_layer.rs) |
//! | in | `/tf`, `/tf_static` | tf2_msgs/TFMessage | reliable, depth 100; `/tf_static` transient local (tf2's listener): the TF tree, `map -> odom`, and the odometry `odom -> base_link`, which wins over `/odom` |
//! | in | `speed_limit_topic` (`speed_limit`) | nav2_msgs/SpeedLimit | reliable, volatile, depth 10 (only with `follow_plan`) |
//! | in | `keepout_mask_topic` | nav_msgs/OccupancyGrid | reliable, transient local (only when set) |
//! | in | `keepout_filter_info_topic` | nav2_msgs/CostmapFilterInfo | reliable, transient local (only when set; then the mask topic it names, as above) |
//! | in | `speed_filter_info_topic` | nav2_msgs/CostmapFilterInfo | reliable, transient local (only when set, with `follow_plan`; then the mask topic it names) |
//! | in | `binary_filter.filter_info_topic` | nav2_msgs/CostmapFilterInfo | reliable, transient local (only when set; then the mask topic it names) |
//! | out | `binary_filter.binary_state_topic` (`binary_state`) | std_msgs/Bool | reliable, transient local, depth 1 (only with `binary_filter.filter_info_topic`) |
//! | out | `/map` | nav_msgs/OccupancyGrid | reliable, transient local (only with `map_yaml`) |
//! | out | `/plan` | nav_msgs/Path | reliable, transient local, depth 1 |
//! | out | `/diagnostics` | diagnostic_msgs/DiagnosticArray | reliable, volatile, depth 10 |
//! | out | `/patrol_planner/pareto` | visualization_msgs/MarkerArray | reliable, volatile, depth 1 |
//! | service | `/patrol_planner/make_plan` | nav_msgs/srv/GetPlan | reliable |
//! | service | `/map_server/load_map` | nav2_msgs/srv/LoadMap | reliable (only with `map_yaml`: map_server.rs) |
//! | out | `/rosout` | rcl_interfaces/Log | ros2-client's (reliable, transient local, depth 1) |
//!
//! A new goal cancels a plan still running for an older one (its interrupt callback sees the
//! goal counter move); goals that arrive faster than plans finish are coalesced to the newest.
//! Failed goals publish nothing on `/plan` (Nav2's planner server does the same) but always a
//! `/diagnostics` status with the reason.

use crate::actions;
use crate::costmap_filters::{self, Filter};
use crate::follow;
use crate::inputs;
use crate::lifecycle_services;
use crate::map_server;
use crate::obstacle_layer;
use crate::outputs::{CmdVel, Outputs};
use crate::params::{
    is_live, unused_on_costmap, validate_parameter, with_setting, OBSTACLES_ENABLED, SETTINGS,
};
use crate::planning;
use crate::state::{GoalSlot, Shared};
use anyhow::Result;
use chassis::Twist2;
use log::{error, info, warn};
use patrol_msgs::diagnostic_msgs::DiagnosticArray;
use patrol_msgs::geometry_msgs::{
    PoseStamped, PoseWithCovarianceStamped, Twist, TwistStamped, Vector3,
};
use patrol_msgs::lifecycle_msgs::TransitionEvent;
use patrol_msgs::map_msgs::OccupancyGridUpdate;
use patrol_msgs::nav2_msgs::{
    AssistedTeleopFeedback, AssistedTeleopGoal, BackUpFeedback, BackUpGoal, BehaviorResult,
    ComputePathResult, ComputePathThroughPosesGoal, ComputePathToPoseGoal, CostmapFilterInfo,
    DriveOnHeadingGoal, EmptyFeedback, FollowPathFeedback, FollowPathGoal, FollowPathResult,
    FollowWaypointsFeedback, FollowWaypointsGoal, FollowWaypointsResult, IsPathValidRequest,
    IsPathValidResponse, NavigateThroughPosesFeedback, NavigateThroughPosesGoal,
    NavigateThroughPosesResult, NavigateToPoseFeedback, NavigateToPoseGoal, NavigateToPoseResult,
    SpeedLimit, SpinFeedback, SpinGoal, WaitFeedback, WaitGoal,
};
use patrol_msgs::nav_msgs::{GetPlanRequest, GetPlanResponse, OccupancyGrid, Odometry, Path};
use patrol_msgs::rosgraph_msgs::Clock;
use patrol_msgs::sensor_msgs::{Image, LaserScan, PointCloud2};
use patrol_msgs::std_msgs::{Bool, Empty};
use patrol_msgs::tf2_msgs::TFMessage;
use patrol_msgs::visualization_msgs::MarkerArray;
use planner_core::params::ParamError;
use planner_io::parameters::{ObservationType, ParameterFile};
use ros2_client::action::{ActionServerQosPolicies, AsyncActionServer};
use ros2_client::{
    qos::{Durability, History},
    ActionTypeName, MessageTypeName, NodeName, NodeOptions, ParameterValue, QosProfile,
    ServiceMapping,
};
use ros_edge::naming::Naming;
use ros_edge::parameter_values::{flatten, read_only_answer};
use ros_edge::service::ServiceServer;
use std::sync::atomic::Ordering;
use std::sync::Arc;

/// `config` with the setting `name` set (`params::SETTINGS`), or why not.
fn setting(
    config: &planner_core::config::PlannerConfig,
    name: &str,
    value: f64,
) -> Result<planner_core::config::PlannerConfig, String> {
    with_setting(config, name, value)
        .unwrap_or_else(|| Err(format!("`{name}` cannot be set at run time")))
}

/// Nav2's action QoS, as rcl_action's defaults.
fn action_qos() -> ActionServerQosPolicies {
    ActionServerQosPolicies {
        goal_service: ros_edge::reliable(10, Durability::Volatile),
        result_service: ros_edge::reliable(10, Durability::Volatile),
        cancel_service: ros_edge::reliable(10, Durability::Volatile),
        feedback_publisher: ros_edge::reliable(10, Durability::Volatile),
        // As rcl_action's status QoS: the latest status array, latched.
        status_publisher: ros_edge::reliable(1, Durability::TransientLocal),
    }
}

/// A server of the nav2_msgs action `type_name` on `name` (the node's namespace and remappings
/// applied), with rcl_action's QoS: every action this node serves is one of Nav2's.
fn nav2_action_server<G, R, F>(
    node: &mut ros2_client::Node,
    naming: &Naming,
    name: &str,
    type_name: &str,
) -> Result<AsyncActionServer<G, R, F>>
where
    G: ros2_client::Message + Clone + 'static,
    R: ros2_client::Message + Clone + 'static,
    F: ros2_client::Message + 'static,
{
    Ok(AsyncActionServer::new(
        node.create_action_server::<G, R, F>(
            ServiceMapping::Enhanced,
            &naming.name(name)?,
            &ActionTypeName::new("nav2_msgs", type_name),
            action_qos(),
        )?,
    ))
}

/// Serves what the rest of a Nav2 stack serves, for a node standing alone (`follow_plan`): the
/// actions that drive the robot, bt_navigator's `navigate_to_pose` and `navigate_through_poses`
/// (navigate.rs), waypoint_follower's `follow_waypoints` (patrol.rs) and behavior_server's
/// `spin`, `backup`, `drive_on_heading` and `wait` (behaviors.rs) and `assisted_teleop`
/// (assisted_teleop.rs), controller_server's `follow_path` (follow_path.rs), and the global
/// and local costmaps' services (costmaps.rs). A node standing in for planner_server in a whole
/// Nav2 stack (`follow_plan: false`, as the README sets it up) serves none of them, so none of
/// that stack's requests (a behaviour tree's Spin, a user's goToPose) can reach this node
/// instead of its own servers.
fn serve_standalone(
    node: &mut ros2_client::Node,
    naming: &Naming,
    tasks: &mut tokio::task::JoinSet<()>,
    shared: &Arc<Shared>,
    out: &Outputs,
) -> Result<()> {
    let navigate_to_pose = nav2_action_server::<
        NavigateToPoseGoal,
        NavigateToPoseResult,
        NavigateToPoseFeedback,
    >(node, naming, "navigate_to_pose", "NavigateToPose")?;
    let navigate_through_poses = nav2_action_server::<
        NavigateThroughPosesGoal,
        NavigateThroughPosesResult,
        NavigateThroughPosesFeedback,
    >(
        node,
        naming,
        "navigate_through_poses",
        "NavigateThroughPoses",
    )?;
    let follow_waypoints = nav2_action_server::<
        FollowWaypointsGoal,
        FollowWaypointsResult,
        FollowWaypointsFeedback,
    >(node, naming, "follow_waypoints", "FollowWaypoints")?;
    // Nav2's behavior server's actions (see behaviors.rs), under its names.
    let spin =
        nav2_action_server::<SpinGoal, BehaviorResult, SpinFeedback>(node, naming, "spin", "Spin")?;
    let backup = nav2_action_server::<BackUpGoal, BehaviorResult, BackUpFeedback>(
        node, naming, "backup", "BackUp",
    )?;
    let drive_on_heading = nav2_action_server::<DriveOnHeadingGoal, BehaviorResult, BackUpFeedback>(
        node,
        naming,
        "drive_on_heading",
        "DriveOnHeading",
    )?;
    let wait =
        nav2_action_server::<WaitGoal, BehaviorResult, WaitFeedback>(node, naming, "wait", "Wait")?;
    // Nav2's AssistedTeleop: the action, the operator's commands (Twist, or TwistStamped as
    // Nav2 reads them with enable_stamped_cmd_vel) and preempt_teleop, with Nav2's QoS
    // (system defaults: reliable, volatile, depth 10).
    let assisted_teleop = nav2_action_server::<
        AssistedTeleopGoal,
        BehaviorResult,
        AssistedTeleopFeedback,
    >(node, naming, "assisted_teleop", "AssistedTeleop")?;
    // controller_server's FollowPath, which nav2_simple_commander's followPath() sends.
    let follow_path = nav2_action_server::<FollowPathGoal, FollowPathResult, FollowPathFeedback>(
        node,
        naming,
        "follow_path",
        "FollowPath",
    )?;
    tasks.spawn(crate::follow_path::serve(
        shared.clone(),
        out.clone(),
        follow_path,
    ));
    let volatile = ros_edge::reliable(10, Durability::Volatile);
    let teleop_name = naming.name(&shared.params.behavior_server.cmd_vel_teleop)?;
    if shared.params.enable_stamped_cmd_vel {
        let t = node.create_topic(
            &teleop_name,
            MessageTypeName::new("geometry_msgs", "TwistStamped"),
            &volatile,
        )?;
        let sub = node.create_subscription::<TwistStamped>(&t, Some(volatile.clone()))?;
        tasks.spawn(inputs::receive_teleop(shared.clone(), sub, |m| {
            crate::convert::twist2(&m.twist)
        }));
    } else {
        let t = node.create_topic(
            &teleop_name,
            MessageTypeName::new("geometry_msgs", "Twist"),
            &volatile,
        )?;
        let sub = node.create_subscription::<Twist>(&t, Some(volatile.clone()))?;
        tasks.spawn(inputs::receive_teleop(
            shared.clone(),
            sub,
            crate::convert::twist2,
        ));
    }
    let t = node.create_topic(
        &naming.name("preempt_teleop")?,
        MessageTypeName::new("std_msgs", "Empty"),
        &volatile,
    )?;
    let preempt = node.create_subscription::<Empty>(&t, Some(volatile))?;
    tasks.spawn(inputs::count_signals(
        shared.clone(),
        "preempt_teleop".into(),
        preempt,
        |s| &s.teleop_preempts,
    ));
    tasks.spawn(crate::assisted_teleop::serve(
        shared.clone(),
        out.clone(),
        assisted_teleop,
    ));
    tasks.spawn(crate::patrol::serve(
        shared.clone(),
        out.clone(),
        follow_waypoints,
    ));
    tasks.spawn(crate::navigate::serve(
        shared.clone(),
        out.clone(),
        navigate_to_pose,
    ));
    tasks.spawn(crate::navigate::serve(
        shared.clone(),
        out.clone(),
        navigate_through_poses,
    ));
    crate::costmaps::serve(node, naming, tasks, shared, out)?;
    tasks.spawn(crate::behaviors::serve_all(
        shared.clone(),
        out.clone(),
        crate::behaviors::BehaviorServers {
            spin,
            backup,
            drive_on_heading,
            wait,
        },
    ));
    Ok(())
}

/// Runs the node until Ctrl-C or SIGTERM.
pub async fn run(file: ParameterFile, naming: Naming) -> Result<()> {
    let mut signals = ros_edge::ShutdownSignals::new()?;
    let ParameterFile {
        planning,
        node: params,
        ..
    } = file;
    // Every other value the node runs with, read-only, so that `ros2 param get` and `ros2 param
    // dump` show what the parameter files and -p rules came to (they are read at start: a set
    // to another value is refused, saying so).
    let read_only: Vec<(String, ParameterValue)> = flatten(&params)
        .into_iter()
        .chain(flatten(&planning))
        // use_sim_time is ros2-client's own parameter (it switches ros2-client's clock; the node
        // stamps with ros_edge's): left as it was.
        .filter(|(name, _)| !is_live(name) && name != "use_sim_time")
        .collect();
    let held = read_only.clone();
    let shared = Arc::new(Shared::new(params.clone(), planning));
    let live = shared.live.read().expect("lock").clone();
    let on_set = shared.clone();
    let on_check = shared.clone();
    let mut options = NodeOptions::new()
        .enable_rosout(true)
        .start_parameter_services(true)
        .declare_parameter("planner", ParameterValue::String(live.planner.to_string()))
        .declare_parameter(
            "max_planning_time",
            ParameterValue::Double(live.max_planning_time),
        )
        .declare_parameter("tolerance", ParameterValue::Double(live.tolerance))
        .declare_parameter(
            OBSTACLES_ENABLED,
            ParameterValue::Boolean(live.obstacles_enabled),
        )
        .parameter_validator(Box::new(move |name, value| {
            if let Some(answer) = read_only_answer(&held, name, value, "the node") {
                return answer;
            }
            validate_parameter(name, value)?;
            // On a costmap taken as it is the layer does not run: a change is refused (the value
            // held passes, as it must when the parameter is declared at start).
            if let ParameterValue::Boolean(on) = value {
                let held = on_check
                    .live
                    .read()
                    .map_err(|_| "state lock poisoned".to_string())?
                    .obstacles_enabled;
                if name == OBSTACLES_ENABLED
                    && *on != held
                    && !on_check.params.costmap_topic.is_empty()
                {
                    return Err(format!(
                        "{name}: the node plans on `{}`, whose costmap node has its own obstacle layer",
                        on_check.params.costmap_topic
                    ));
                }
            }
            let number = match value {
                ParameterValue::Double(v) => *v,
                ParameterValue::Integer(v) => *v as f64,
                _ => return Ok(()),
            };
            let live = on_check
                .live
                .read()
                .map_err(|_| "state lock poisoned".to_string())?;
            unused_on_costmap(name, number, &live.config, &on_check.params.costmap_topic)
        }))
        .parameter_set_action(Box::new(move |name, value| {
            if !is_live(name) {
                // A read-only value, declared (the validator let through only the value held).
                return Ok(());
            }
            let mut l = on_set
                .live
                .write()
                .map_err(|_| "state lock poisoned".to_string())?;
            match (name, value) {
                ("planner", ParameterValue::String(s)) => {
                    l.planner = s.parse().map_err(|e: ParamError| e.to_string())?
                }
                ("max_planning_time", ParameterValue::Double(v)) => l.max_planning_time = *v,
                ("tolerance", ParameterValue::Double(v)) => l.tolerance = *v,
                (OBSTACLES_ENABLED, ParameterValue::Boolean(on)) => l.obstacles_enabled = *on,
                (_, ParameterValue::Double(v)) => l.config = setting(&l.config, name, *v)?,
                // `ros2 param set ... swarm.safety_weight 0` sends an integer.
                (_, ParameterValue::Integer(v)) => l.config = setting(&l.config, name, *v as f64)?,
                _ => return Err(format!("`{name}` cannot be set at run time")),
            }
            info!("parameter {name} set to {value:?}");
            // A changed inflation, or the obstacles switched, is made into the grid now, not by
            // the next plan.
            on_set.settings_changed.notify_one();
            Ok(())
        }));
    for w in SETTINGS {
        options = options.declare_parameter(w.name, ParameterValue::Double((w.get)(&live.config)));
    }
    for (name, value) in read_only {
        options = options.declare_parameter(&name, value);
    }
    let (context, domain) = ros_edge::context()?;
    let mut node = context.new_node(NodeName::new(&naming.namespace, &naming.node)?, options)?;
    let spinner = tokio::spawn(node.spinner()?.spin());
    // Every task holding a DDS reader or writer, so that shutdown can end them before the
    // node and its participant go (otherwise RustDDS logs an error for each endpoint).
    let mut tasks = tokio::task::JoinSet::new();
    ros_edge::logging::forward_to_rosout(node.logging_handle());

    // Every name goes through the command line's namespace and remaps (ros_edge::naming):
    // relative names resolve in the namespace, `~/` ones in the node.
    let topic = |node: &mut ros2_client::Node,
                 name: &str,
                 pkg: &str,
                 ty: &str,
                 qos: &QosProfile|
     -> Result<_> {
        Ok(node.create_topic(&naming.name(name)?, MessageTypeName::new(pkg, ty), qos)?)
    };
    let latched = ros_edge::reliable(1, Durability::TransientLocal);
    let volatile = ros_edge::reliable(10, Durability::Volatile);
    // A simulated stack's time (use_sim_time): every stamp from here on is the latest /clock.
    // The node reads /clock itself, typed rosgraph_msgs/Clock with rclcpp's clock QoS (best
    // effort, the last one): ros2-client's own reader takes it as builtin_interfaces/Time,
    // a type Gazebo's bridge or `ros2 bag play --clock` do not match.
    if params.use_sim_time {
        ros_edge::use_sim_time();
        info!(
            "use_sim_time: stamps from /clock (rosgraph_msgs/Clock); RustDDS may report /clock as an inconsistent topic, for ros2-client's own reader of it (builtin_interfaces/Time): expected"
        );
        if let Err(e) = node.set_parameter("use_sim_time", ParameterValue::Boolean(true)) {
            warn!("use_sim_time: {e}");
        }
        let clock_qos = QosProfile::subscription_default().history(History::KeepLast { depth: 1 });
        let t = topic(&mut node, "/clock", "rosgraph_msgs", "Clock", &clock_qos)?;
        let clock_sub = node.create_subscription::<Clock>(&t, Some(clock_qos))?;
        tasks.spawn(inputs::receive_clock(clock_sub));
    }
    let map_topic = topic(&mut node, "map", "nav_msgs", "OccupancyGrid", &latched)?;
    let map_pub =
        Arc::new(node.create_publisher::<OccupancyGrid>(&map_topic, Some(latched.clone()))?);
    let map_sub = node.create_subscription::<OccupancyGrid>(&map_topic, Some(latched.clone()))?;
    let costmap_sub = if params.costmap_topic.is_empty() {
        None
    } else {
        // costmap_2d publishes its costmap latched and reliable.
        let t = topic(
            &mut node,
            &params.costmap_topic,
            "nav_msgs",
            "OccupancyGrid",
            &latched,
        )?;
        let costmap = node.create_subscription::<OccupancyGrid>(&t, Some(latched.clone()))?;
        // Between full costmaps costmap_2d sends the changed window on `<topic>_updates`
        // (map_msgs/OccupancyGridUpdate, transient local and reliable as the costmap). Each is a
        // window of its own, so the reader keeps the last 10, not 1: with costmap_2d's rate of
        // about one a second a backlog that deep means the node is far behind anyway.
        let updates_qos = ros_edge::reliable(10, Durability::TransientLocal);
        let u = topic(
            &mut node,
            &format!("{}_updates", params.costmap_topic),
            "map_msgs",
            "OccupancyGridUpdate",
            &updates_qos,
        )?;
        let updates =
            node.create_subscription::<OccupancyGridUpdate>(&u, Some(updates_qos.clone()))?;
        Some((costmap, updates))
    };
    // A filter mask server (map_server) latches its mask, reliable, as map_server its map.
    let keepout_sub = if params.keepout_mask_topic.is_empty() {
        None
    } else {
        let t = topic(
            &mut node,
            &params.keepout_mask_topic,
            "nav_msgs",
            "OccupancyGrid",
            &latched,
        )?;
        Some(node.create_subscription::<OccupancyGrid>(&t, Some(latched.clone()))?)
    };
    // Or Nav2's costmap_filter_info_server names the mask topic, latched (costmap_filters.rs);
    // so it does for the speed zones the follower drives under and for the binary zones.
    let mut filter_info_subs = Vec::new();
    let binary = &params.binary_filter;
    if !binary.enabled && !binary.filter_info_topic.is_empty() {
        info!(
            "binary_filter.filter_info_topic `{}` not read: binary_filter.enabled is false",
            binary.filter_info_topic
        );
    }
    let binary_info_topic = if binary.runs() {
        binary.filter_info_topic.as_str()
    } else {
        ""
    };
    for (filter, info_topic) in [
        (Filter::Keepout, params.keepout_filter_info_topic.as_str()),
        (Filter::Speed, params.speed_filter_info_topic.as_str()),
        (Filter::Binary, binary_info_topic),
    ] {
        if info_topic.is_empty() {
            continue;
        }
        if filter == Filter::Speed && !params.follow_plan {
            warn!("speed_filter_info_topic `{info_topic}` not read: speed zones limit the node's own drive, and follow_plan is false");
            continue;
        }
        let t = topic(
            &mut node,
            info_topic,
            "nav2_msgs",
            "CostmapFilterInfo",
            &latched,
        )?;
        let sub = node.create_subscription::<CostmapFilterInfo>(&t, Some(latched.clone()))?;
        filter_info_subs.push((filter, info_topic.to_owned(), sub));
    }
    let plan_topic = topic(&mut node, "plan", "nav_msgs", "Path", &latched)?;
    let plan_pub = Arc::new(node.create_publisher::<Path>(&plan_topic, Some(latched.clone()))?);
    let diag_topic = topic(
        &mut node,
        "/diagnostics",
        "diagnostic_msgs",
        "DiagnosticArray",
        &volatile,
    )?;
    let diag_pub =
        Arc::new(node.create_publisher::<DiagnosticArray>(&diag_topic, Some(volatile.clone()))?);
    // The planning grid as a costmap, latched as costmap_2d publishes its own; not when the node
    // plans on a costmap topic, which is published already.
    let costmap_pub = if params.publish_costmap && params.costmap_topic.is_empty() {
        let t = topic(
            &mut node,
            "~/costmap",
            "nav_msgs",
            "OccupancyGrid",
            &latched,
        )?;
        Some(node.create_publisher::<OccupancyGrid>(&t, Some(latched.clone()))?)
    } else {
        None
    };
    // Nav2's BinaryFilter's state, latched: a node started later reads the state in force.
    let mut binary_state_pub = if binary.runs() {
        let name = &binary.binary_state_topic;
        let t = topic(&mut node, name, "std_msgs", "Bool", &latched)?;
        let publisher = node.create_publisher::<Bool>(&t, Some(latched.clone()))?;
        Some((publisher, naming.name(name)?.to_string()))
    } else {
        None
    };
    let pareto_qos = ros_edge::reliable(1, Durability::Volatile);
    let pareto_topic = topic(
        &mut node,
        "~/pareto",
        "visualization_msgs",
        "MarkerArray",
        &pareto_qos,
    )?;
    let pareto_pub =
        Arc::new(node.create_publisher::<MarkerArray>(&pareto_topic, Some(pareto_qos))?);
    let goal_topic = topic(
        &mut node,
        "goal_pose",
        "geometry_msgs",
        "PoseStamped",
        &volatile,
    )?;
    let goal_sub = node.create_subscription::<PoseStamped>(&goal_topic, Some(volatile.clone()))?;
    let initial_topic = topic(
        &mut node,
        "initialpose",
        "geometry_msgs",
        "PoseWithCovarianceStamped",
        &volatile,
    )?;
    let initial_sub = node
        .create_subscription::<PoseWithCovarianceStamped>(&initial_topic, Some(volatile.clone()))?;
    let amcl_topic = topic(
        &mut node,
        "amcl_pose",
        "geometry_msgs",
        "PoseWithCovarianceStamped",
        &volatile,
    )?;
    let amcl_sub =
        node.create_subscription::<PoseWithCovarianceStamped>(&amcl_topic, Some(volatile.clone()))?;
    let best_effort = QosProfile::subscription_default().history(History::KeepLast { depth: 5 });
    let odom_topic = topic(&mut node, "odom", "nav_msgs", "Odometry", &best_effort)?;
    let odom_sub = node.create_subscription::<Odometry>(&odom_topic, Some(best_effort.clone()))?;
    // The obstacle layer's sources, best effort as sensor drivers publish them (sensor data
    // QoS), also while the layer is not enabled (it may be at run time, as in Nav2); not on a
    // costmap taken as it is, which has its own obstacle layer.
    let layer = &params.obstacle_layer;
    let mut sources = Vec::new();
    if params.costmap_topic.is_empty() {
        for source in &layer.sources {
            let kind = match source.data_type {
                ObservationType::LaserScan => "LaserScan",
                ObservationType::PointCloud2 => "PointCloud2",
            };
            let t = topic(&mut node, &source.topic, "sensor_msgs", kind, &best_effort)?;
            let qos = Some(best_effort.clone());
            let readings = match source.data_type {
                ObservationType::LaserScan => {
                    obstacle_layer::Readings::Scans(node.create_subscription::<LaserScan>(&t, qos)?)
                }
                ObservationType::PointCloud2 => obstacle_layer::Readings::Clouds(
                    node.create_subscription::<PointCloud2>(&t, qos)?,
                ),
            };
            sources.push((source.clone(), readings));
        }
    }
    // controller_server's speed limits (reliable, volatile, depth 10: its QoS(10)).
    let speed_limit_sub = if params.follow_plan && !params.speed_limit_topic.is_empty() {
        let t = topic(
            &mut node,
            &params.speed_limit_topic,
            "nav2_msgs",
            "SpeedLimit",
            &volatile,
        )?;
        Some(node.create_subscription::<SpeedLimit>(&t, Some(volatile.clone()))?)
    } else {
        None
    };
    // Nav2's InputAtWaypoint reads its input with the default QoS (reliable, volatile).
    let waypoint_input_sub = if params.follow_plan && params.input_at_waypoint.enabled {
        let t = topic(
            &mut node,
            &params.input_at_waypoint.input_topic,
            "std_msgs",
            "Empty",
            &volatile,
        )?;
        Some(node.create_subscription::<Empty>(&t, Some(volatile.clone()))?)
    } else {
        None
    };
    // Nav2's PhotoAtWaypoint's camera, best effort: a camera's sensor-data QoS matches as well
    // as a reliable one (Nav2 subscribes reliable, which a best-effort camera never matches).
    let camera_sub = if params.follow_plan && params.photo_at_waypoint.enabled {
        let t = topic(
            &mut node,
            &params.photo_at_waypoint.image_topic,
            "sensor_msgs",
            "Image",
            &best_effort,
        )?;
        Some(node.create_subscription::<Image>(&t, Some(best_effort.clone()))?)
    } else {
        None
    };
    // The TF tree (map -> odom as AMCL or a SLAM node broadcasts it, odom -> base_link as the
    // odometry does), with tf2's listener
    // QoS: /tf reliable and volatile, /tf_static reliable and transient local, both depth 100.
    // The depth matters for /tf_static: every static broadcaster (robot_state_publisher, a
    // static map -> odom) latches its own message, all delivered on matching, and a reader of
    // depth 1 keeps only the last of them.
    let mut tf_subs = Vec::new();
    let tf_qos = ros_edge::reliable(100, Durability::Volatile);
    let tf_static_qos = ros_edge::reliable(100, Durability::TransientLocal);
    for (name, qos) in [("/tf", &tf_qos), ("/tf_static", &tf_static_qos)] {
        let t = topic(&mut node, name, "tf2_msgs", "TFMessage", qos)?;
        let sub = node.create_subscription::<TFMessage>(&t, Some(qos.clone()))?;
        tf_subs.push((name, sub));
    }
    // Requests are answered one after another; the reader keeps up to REQUEST_QUEUE waiting
    // ones (a burst of 200 concurrent calls used to lose all but the last 10 of them, which then
    // never got an answer). Replies (a plan each, kilobytes) are kept until acknowledged.
    const REQUEST_QUEUE: usize = 1024;
    const REPLY_QUEUE: usize = 64;
    let server = ServiceServer::<GetPlanRequest, GetPlanResponse>::with_queues(
        &mut node,
        &naming,
        "~/make_plan",
        "nav_msgs",
        "GetPlan",
        REQUEST_QUEUE,
        REPLY_QUEUE,
    )?;
    // Nav2's planner-server interface (see actions.rs): two actions and is_path_valid.
    let to_pose = nav2_action_server::<ComputePathToPoseGoal, ComputePathResult, EmptyFeedback>(
        &mut node,
        &naming,
        "compute_path_to_pose",
        "ComputePathToPose",
    )?;
    let through_poses =
        nav2_action_server::<ComputePathThroughPosesGoal, ComputePathResult, EmptyFeedback>(
            &mut node,
            &naming,
            "compute_path_through_poses",
            "ComputePathThroughPoses",
        )?;
    let is_path_valid = ServiceServer::<IsPathValidRequest, IsPathValidResponse>::new(
        &mut node,
        &naming,
        "is_path_valid",
        "nav2_msgs",
        "IsPathValid",
    )?;
    // The managed-node interface Nav2's lifecycle_manager drives (see lifecycle.rs).
    let lifecycle_qos = ros_edge::reliable(10, Durability::Volatile);
    const LIFECYCLE: &str = "lifecycle_msgs";
    let change_state = ServiceServer::new(
        &mut node,
        &naming,
        "~/change_state",
        LIFECYCLE,
        "ChangeState",
    )?;
    let get_state = ServiceServer::new(&mut node, &naming, "~/get_state", LIFECYCLE, "GetState")?;
    let get_states = ServiceServer::new(
        &mut node,
        &naming,
        "~/get_available_states",
        LIFECYCLE,
        "GetAvailableStates",
    )?;
    let transition_servers = [
        (
            ServiceServer::new(
                &mut node,
                &naming,
                "~/get_available_transitions",
                LIFECYCLE,
                "GetAvailableTransitions",
            )?,
            false,
        ),
        (
            ServiceServer::new(
                &mut node,
                &naming,
                "~/get_transition_graph",
                LIFECYCLE,
                "GetTransitionGraph",
            )?,
            true,
        ),
    ];
    let event_topic = topic(
        &mut node,
        "~/transition_event",
        "lifecycle_msgs",
        "TransitionEvent",
        &lifecycle_qos,
    )?;
    let events =
        node.create_publisher::<TransitionEvent>(&event_topic, Some(lifecycle_qos.clone()))?;
    let bond_topic = topic(&mut node, "bond", "bond", "Status", &lifecycle_qos)?;
    let bond_pub = node
        .create_publisher::<patrol_msgs::bond::Status>(&bond_topic, Some(lifecycle_qos.clone()))?;
    let cmd_pub = if params.enable_stamped_cmd_vel {
        let t = topic(
            &mut node,
            "cmd_vel",
            "geometry_msgs",
            "TwistStamped",
            &volatile,
        )?;
        CmdVel::Stamped(Arc::new(node.create_publisher(&t, Some(volatile.clone()))?))
    } else {
        let t = topic(&mut node, "cmd_vel", "geometry_msgs", "Twist", &volatile)?;
        CmdVel::Plain(Arc::new(node.create_publisher(&t, Some(volatile.clone()))?))
    };
    let limits_topic = topic(
        &mut node,
        "~/twist_limits",
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
        tasks.spawn(follow::follow(shared.clone(), out.clone()));
    }

    let (goal_tx, goal_rx) = tokio::sync::watch::channel::<GoalSlot>(None);
    // The bundled map, loaded by the node itself and latched on /map; with it, the node is the
    // map server, and map_server's load_map switches maps (map_server.rs).
    if !params.map_yaml.is_empty() {
        let map_server = Arc::new(map_server::MapServer::new(map_pub.clone()));
        if let Err(refused) = map_server::load(
            &shared,
            &map_server,
            &params.map_yaml,
            map_server::Asked::Startup,
        )
        .await
        {
            error!("map_yaml: {}; waiting for /map instead", refused.reason);
        }
        let load_map = ServiceServer::new(
            &mut node,
            &naming,
            "map_server/load_map",
            "nav2_msgs",
            "LoadMap",
        )?;
        tasks.spawn(map_server::serve_load_map(
            shared.clone(),
            map_server.clone(),
            load_map,
            goal_tx.clone(),
        ));
        let get_map =
            ServiceServer::new(&mut node, &naming, "map_server/map", "nav_msgs", "GetMap")?;
        tasks.spawn(map_server::serve_get_map(
            shared.clone(),
            map_server,
            get_map,
        ));
    }

    // The planning grid comes from the costmap topic when one is set, else from /map.
    // Our own latched map_yaml sample comes back on /map; it is skipped there (already installed).
    let own_map = (!params.map_yaml.is_empty()).then(|| map_pub.gid());
    let (grid_sub, updates, grid_source, own) = match costmap_sub {
        Some((sub, updates)) => (sub, Some(updates), "the costmap topic", None),
        None => (map_sub, None, "/map", own_map),
    };
    tasks.spawn(inputs::receive_maps(
        shared.clone(),
        out.clone(),
        grid_sub,
        updates,
        goal_tx.clone(),
        grid_source,
        own,
    ));
    if let Some(publisher) = costmap_pub {
        tasks.spawn(crate::outputs::publish_costmaps(shared.clone(), publisher));
    }
    if let Some(sub) = speed_limit_sub {
        tasks.spawn(inputs::receive_speed_limits(shared.clone(), sub));
    }
    if let Some(sub) = waypoint_input_sub {
        tasks.spawn(inputs::count_signals(
            shared.clone(),
            params.input_at_waypoint.input_topic.clone(),
            sub,
            |s| &s.waypoint_inputs,
        ));
    }
    if let Some(sub) = camera_sub {
        tasks.spawn(crate::photo_at_waypoint::receive(
            shared.clone(),
            params.photo_at_waypoint.image_topic.clone(),
            sub,
        ));
    }
    if let Some(sub) = keepout_sub {
        tasks.spawn(costmap_filters::receive_masks(
            shared.clone(),
            out.clone(),
            Filter::Keepout,
            params.keepout_mask_topic.clone(),
            sub,
        ));
    }
    tasks.spawn(inputs::remake_grid_on_change(
        shared.clone(),
        goal_tx.clone(),
    ));
    tasks.spawn(inputs::receive_start_poses(
        shared.clone(),
        "/initialpose",
        initial_sub,
    ));
    tasks.spawn(inputs::receive_start_poses(
        shared.clone(),
        "/amcl_pose",
        amcl_sub,
    ));
    tasks.spawn(inputs::receive_odometry(shared.clone(), odom_sub));
    if !sources.is_empty() {
        tasks.spawn(obstacle_layer::lay(shared.clone()));
    }
    for (index, (source, readings)) in sources.into_iter().enumerate() {
        tasks.spawn(obstacle_layer::receive(
            shared.clone(),
            index,
            source,
            readings,
        ));
    }
    for (name, sub) in tf_subs {
        tasks.spawn(inputs::receive_transforms(shared.clone(), name, sub));
    }
    tasks.spawn(inputs::receive_goals(
        shared.clone(),
        out.clone(),
        goal_sub,
        goal_tx,
    ));
    tasks.spawn(planning::plan_goals(shared.clone(), out.clone(), goal_rx));
    tasks.spawn(lifecycle_services::change_state(
        shared.clone(),
        change_state,
        events,
    ));
    tasks.spawn(lifecycle_services::get_state(shared.clone(), get_state));
    if params.bond_heartbeat_period > 0.0 {
        tasks.spawn(lifecycle_services::bond(
            shared.clone(),
            bond_pub,
            naming.node.clone(),
            params.bond_heartbeat_period,
        ));
    }
    tasks.spawn(lifecycle_services::get_available_states(get_states));
    for (server, whole_graph) in transition_servers {
        tasks.spawn(lifecycle_services::get_transitions(
            shared.clone(),
            server,
            whole_graph,
        ));
    }
    tasks.spawn(actions::serve(shared.clone(), out.clone(), to_pose));
    tasks.spawn(actions::serve(shared.clone(), out.clone(), through_poses));
    tasks.spawn(actions::serve_is_path_valid(shared.clone(), is_path_valid));
    if params.follow_plan {
        serve_standalone(&mut node, &naming, &mut tasks, &shared, &out)?;
    }
    tasks.spawn(planning::serve_get_plan(
        shared.clone(),
        out.clone(),
        server,
    ));
    // From here on the node is shared: a filter info subscribes to the mask topics it names
    // as they come.
    let node = Arc::new(std::sync::Mutex::new(node));
    for (filter, info_topic, sub) in filter_info_subs {
        match filter {
            Filter::Speed => {
                tasks.spawn(costmap_filters::limit_speed_in_zones(shared.clone()));
            }
            Filter::Binary => {
                if let Some((publisher, name)) = binary_state_pub.take() {
                    tasks.spawn(costmap_filters::switch_in_zones(
                        shared.clone(),
                        publisher,
                        name,
                    ));
                }
            }
            Filter::Keepout => {}
        }
        tasks.spawn(costmap_filters::receive_filter_info(
            shared.clone(),
            out.clone(),
            node.clone(),
            naming.clone(),
            filter,
            info_topic,
            sub,
        ));
    }

    info!(
        "patrol_planner ready on ROS_DOMAIN_ID {domain}: planner {}, frame {}",
        live.planner, params.global_frame
    );
    let name = signals.recv().await;
    info!("{name}: shutting down");
    tasks.shutdown().await;
    // As Nav2's controller does when it goes down: a robot still moving gets a last stop, rather
    // than driving on its last command until the chassis' own timeout.
    if shared.moving.load(Ordering::SeqCst) {
        out.drive(&shared, Twist2::STOP).await;
        info!("/cmd_vel: stopped the robot");
    }
    ros_edge::logging::stop_forwarding();
    // Dropping the node stops its spinner, which holds the node's own endpoints (parameter
    // services, rosout); they must go before the participant does, when `context` drops. The
    // tasks that shared it have ended, so this is the last of it.
    drop(node);
    let _ = spinner.await;
    Ok(())
}
