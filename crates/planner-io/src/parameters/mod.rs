//! The node's parameter file (`config/planner.yaml`, Nav2's `patrol_planner: ros__parameters:`
//! layout), read the same way by the node and by `patrol-plan --config`: the planning keys go to
//! planner-core's [`PlannerConfig`], the node's own keys (map, frames, follower, limits) to
//! [`NodeParams`], and a key that is neither is an error naming it and the file, so a typo such as
//! `planer: astar` can never silently run the default planner.

use crate::LoadError;
use chassis::follower::FollowerParams;
use chassis::limits::TwistLimits;
use chassis::progress::ProgressParams;
pub use obstacle_layer::{
    ObservationSource, ObservationType, ObstacleLayerParams, MAX_OBSERVATION_SOURCES,
};
use planner_core::config::PlannerConfig;
use planner_core::PlannerName;
use ros_parameters::{field_names as keys, Layers, WILDCARD};
pub use ros_parameters::{ParameterOverride, ParameterSource};
use serde::{Deserialize, Serialize};
use serde_yaml::{Mapping, Value};
use std::collections::BTreeMap;
use std::path::Path;

mod obstacle_layer;

/// The node name whose block the file holds.
pub const NODE_NAME: &str = "patrol_planner";

/// What only the node needs, beside the planning parameters.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NodeParams {
    /// A map_server YAML the node loads itself and publishes on `/map` (transient local), so it
    /// works without a map server. Relative paths are relative to the parameter file. Empty: wait
    /// for `/map`.
    pub map_yaml: String,
    /// The frame plans are made in. Goals may be in it (or have an empty frame), in `odom_frame`
    /// or `robot_base_frame`, or in any frame of the TF tree: the node carries those into it
    /// (`Shared::pose_in_global`).
    pub global_frame: String,
    /// The static map -> odom transform `[x, y, yaw]` applied to odometry poses (identity by
    /// default: odometry is the map frame, as for the simulated chassis).
    pub map_to_odom: [f64; 3],
    /// Re-estimate `map -> odom` instead of keeping `map_to_odom` fixed: from each
    /// `global_frame -> odom_frame` transform on `/tf` or `/tf_static` (AMCL, slam_toolbox,
    /// cartographer, a static publisher) and by anchoring each `/initialpose` and `/amcl_pose`.
    pub track_map_to_odom: bool,
    /// The odometry frame, the child of `global_frame` on `/tf` (AMCL's `odom_frame_id`).
    pub odom_frame: String,
    /// Publish every Pareto-front path on `/patrol_planner/pareto` for RViz.
    pub publish_pareto: bool,
    /// Publish the planning grid on `/patrol_planner/costmap` (latched), as costmap_2d publishes
    /// a costmap, each time it is made (a new map, a changed inflation): the obstacles, inflation
    /// and graded costs the planners weigh, for RViz's "costmap" colour scheme. Not with
    /// `costmap_topic`, whose costmap is already published. Holding it latched costs about 2 B per
    /// cell (8 MB on Nav2's 2000 x 2000 benchmark map).
    pub publish_costmap: bool,
    /// Follow each goal's plan: publish `/cmd_vel` from `/odom` (regulated pure pursuit).
    pub follow_plan: bool,
    /// The chassis limits the follower keeps to, also forwarded on `/patrol_planner/twist_limits`.
    pub twist_limits: TwistLimits,
    /// The path follower.
    pub follower: FollowerParams,
    /// Nav2's progress checker (controller_server's `PoseProgressChecker`): a drive (an
    /// action's goal, a patrol leg, a `/goal_pose`) that has neither moved nor turned far enough
    /// within its allowance fails to make progress.
    pub progress_checker: ProgressParams,
    /// What a drive does when it fails in a way a recovery may help, as bt_navigator's recovery
    /// tree does.
    pub recovery: RecoveryParams,
    /// The spin, back-up, drive-on-heading and wait behaviours (as Nav2's behavior server).
    pub behavior_server: BehaviorServerParams,
    /// The local costmap's window (`local_costmap/get_costmap`).
    pub local_costmap: LocalCostmapParams,
    /// What the robot's range sensors see, laid on the node's own grid (Nav2's ObstacleLayer:
    /// laser scans and point clouds, one or more sources). Not with `costmap_topic`, whose
    /// costmap has its own.
    pub obstacle_layer: ObstacleLayerParams,
    /// Publish `/cmd_vel` as geometry_msgs/TwistStamped (what Jazzy's diff_drive_controller
    /// expects; Nav2's parameter of the same name) instead of Twist.
    pub enable_stamped_cmd_vel: bool,
    /// The robot's frame (Nav2's name): of stamped `/cmd_vel` commands, and of goals given
    /// relative to the robot.
    pub robot_base_frame: String,
    /// Follower rate (Hz).
    pub control_rate_hz: f64,
    /// The follower stops when the odometry is older than this (s); `/odom` is the odometry
    /// only while `odom_frame -> robot_base_frame` has not come on `/tf` for this long.
    pub pose_timeout: f64,
    /// costmap_2d's `transform_tolerance` (s), which planner_server transforms goals with: how
    /// long a goal, start or path stamped in a frame of the TF tree waits for the transforms at
    /// its stamp (or for its frame to appear on `/tf`) before it fails with TF_ERROR. At most
    /// 10 s.
    pub transform_tolerance: f64,
    /// Nav2's planner_server `costmap_update_timeout` (s): a plan asked for while an obstacle
    /// layer source with an `expected_update_rate` has been quiet for longer than it (the
    /// costmap is not current, in costmap_2d's words) waits up to this long for the source,
    /// then fails with TIMEOUT (207), as planner_server's `waitForCostmap` does. Nav2's 1; at
    /// most 60.
    pub costmap_update_timeout: f64,
    /// Configure and activate itself at start (lifecycle), as without a lifecycle manager. Set
    /// false when Nav2's lifecycle_manager manages the node: it then starts unconfigured and
    /// plans only once activated.
    pub autostart: bool,
    /// Nav2's `use_final_approach_orientation`: the last pose of a path faces along its last
    /// segment (the direction the robot arrives from) instead of the goal's own heading.
    pub use_final_approach_orientation: bool,
    /// Nav2's `expected_planner_frequency` (Hz): a plan that takes longer than its period is
    /// logged as a warning, as planner_server logs a missed rate. 0: no warning.
    pub expected_planner_frequency: f64,
    /// Nav2's `bond_heartbeat_period` (s): while active, the node sends a bond heartbeat on
    /// `bond` this often, so Nav2's lifecycle manager can bond with it as with its own servers.
    /// 0: no bond.
    pub bond_heartbeat_period: f64,
    /// A costmap to plan on, as Nav2's costmap_2d publishes it (nav_msgs/OccupancyGrid, e.g.
    /// `/global_costmap/costmap`): with it the node plans on that costmap, its obstacles,
    /// inflation and graded costs as they are, instead of its own inflation of `map`, which it
    /// then leaves alone; costmap_2d's partial updates on `<topic>_updates` are written into it.
    /// Empty (default): plan on `map`.
    pub costmap_topic: String,
    /// A keepout mask to lay over the node's own costmap, as Nav2's keepout filter lays its
    /// mask over costmap_2d's (nav_msgs/OccupancyGrid, latched, in the global frame or one TF places in it, e.g. the
    /// `/keepout_filter_mask` a filter mask server publishes): occupancy 100 keeps the robot's
    /// centre out, lesser values are costs (0..100 scaled to 0..254). Each new mask is laid over
    /// the current grid at once. Not with `costmap_topic`, whose costmap has its own filters.
    /// Empty (default): none.
    pub keepout_mask_topic: String,
    /// Where Nav2's keepout filter finds its mask (its `filter_info_topic`, e.g.
    /// `/costmap_filter_info`): a nav2_msgs/CostmapFilterInfo, latched by Nav2's
    /// costmap_filter_info_server, names the mask topic, and the node takes its masks from
    /// there as from `keepout_mask_topic`, following the info to a new topic when it changes.
    /// Either this or `keepout_mask_topic`, not both; not with `costmap_topic`. Empty
    /// (default): none.
    pub keepout_filter_info_topic: String,
    /// controller_server's `speed_limit_topic`: the speed limits (nav2_msgs/SpeedLimit) the
    /// follower drives under, as Nav2's speed filter publishes them for its zones (in percent of
    /// `twist_limits.max_linear` or in m/s; 0 lifts the limit). Only with `follow_plan`. Empty:
    /// none.
    pub speed_limit_topic: String,
    /// Speed zones, as Nav2's SpeedFilter makes them (its `filter_info_topic`, e.g.
    /// `/speed_filter_info`): the nav2_msgs/CostmapFilterInfo a costmap_filter_info_server
    /// latches (type 1, percent of the top speed, or 2, m/s) names the speed mask's topic; the
    /// mask's cell under the robot, as `base + value * multiplier`, is the limit the follower
    /// drives under (0 no limit), as if sent on `speed_limit_topic`. Only with `follow_plan`.
    /// Empty (default): none.
    pub speed_filter_info_topic: String,
    /// Nav2's BinaryFilter: zones where the robot's presence switches something (a camera off
    /// in a sensitive room, lights on indoors), published as a std_msgs/Bool. Off by default.
    pub binary_filter: BinaryFilterParams,
    /// Stamp with the simulation's time, the latest rosgraph_msgs/Clock on `/clock`, as every
    /// node of a simulated Nav2 stack does (its launch files set it on them all); zero until
    /// the first arrives. Durations (timeouts, allowances) are still measured on the system
    /// clock, which a simulation running at real time keeps pace with. Default false.
    pub use_sim_time: bool,
    /// follow_waypoints: put the waypoints in the fastest order before driving them (the route
    /// planner's), instead of the order given.
    pub order_waypoints: bool,
    /// follow_waypoints: how long (s) to stay at each waypoint (Nav2's WaitAtWaypoint).
    pub waypoint_pause_duration: f64,
    /// follow_waypoints: end the patrol, aborted, at the first waypoint it misses (Nav2's
    /// waypoint_follower parameter, whose default is true); false (a patrol's default): report
    /// it missed and go on to the next.
    pub stop_on_failure: bool,
    /// follow_waypoints: at each waypoint reached (after the pause), wait for a word from
    /// outside, as Nav2's InputAtWaypoint task executor does: the inspection a patrol stops for
    /// (a gauge read, a photo taken) says it is done.
    pub input_at_waypoint: InputAtWaypointParams,
    /// Nav2's PhotoAtWaypoint: a photo at each waypoint of a patrol (off by default).
    pub photo_at_waypoint: PhotoAtWaypointParams,
    /// Nav2's `planner_plugins`: the planner ids a ComputePathToPose `planner_id` may name, as
    /// planner_server's behaviour trees send them (`GridBased` by default). Each id may have a
    /// block of its own, `<id>: {plugin: <planner>}`, naming one of this node's planners; an id
    /// without one, or whose `plugin` is a Nav2 C++ plugin (`nav2_navfn_planner/NavfnPlanner`),
    /// answers with the `planner` parameter.
    pub planner_plugins: Vec<String>,
    /// What each id of `planner_plugins` with a block of its own answers with (`None`: the
    /// `planner` parameter); filled from those blocks, not a key of its own.
    #[serde(skip)]
    pub plugin_planners: BTreeMap<String, Option<PlannerName>>,
}

/// Recoveries of a navigate action's (or a patrol leg's) drive, as Nav2's default trees retry
/// a navigation (`RecoveryNode number_of_retries="6"`) after a recovery behaviour taken in turn
/// (`RoundRobin`: clearing the costmaps, a spin, a wait, a back-up): here the robot stops, makes
/// the next of `behaviors` (one that fails, as a spin or back-up into an obstacle does, hands
/// over to the one after it, as in the round robin), and plans again from where it is, through
/// the poses not yet passed. Only failures a recovery may help are tried again, as Nav2's
/// `WouldAPlannerRecoveryHelp` and `WouldAControllerRecoveryHelp` decide: no valid path, a
/// planner timeout, an unknown error, no progress.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RecoveryParams {
    /// How many times a failed drive is tried again (Nav2's default trees: 6). 0: never.
    pub number_of_retries: u32,
    /// The behaviours, taken in turn, one per recovery (Nav2's tree: clear, spin, wait,
    /// back-up).
    pub behaviors: Vec<RecoveryBehavior>,
    /// The spin's angle (rad; Nav2's tree: `spin_dist` 1.57).
    pub spin_dist: f64,
    /// The back-up's distance (m) and speed (m/s; Nav2's tree: 0.30 and 0.15).
    pub backup_dist: f64,
    pub backup_speed: f64,
    /// How long (s) the robot waits, stopped (Nav2's tree: `wait_duration` 5).
    pub wait_duration: f64,
    /// How long (s) a spin or back-up may take before it fails (the tree's `time_allowance`:
    /// 10).
    pub time_allowance: f64,
}

/// One of the recovery behaviours of Nav2's behavior server.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RecoveryBehavior {
    /// Forget the obstacles the scans marked (the tree's ClearingActions: ClearEntireCostmap
    /// on both costmaps): a person who stood in the way and has walked out of the scanner's
    /// view no longer blocks the next plan. The map and its inflation stay. With nothing
    /// marked (no scanner, or `costmap_topic`) it is passed over for the next behaviour.
    Clear,
    /// Turn on the spot through `spin_dist`: lets a robot that lost its way see (and, with
    /// AMCL, localise) around it, and faces it another way for the next plan.
    Spin,
    /// Stand still for `wait_duration`: lets a passer-by move on.
    Wait,
    /// Drive straight back `backup_dist` at `backup_speed`: out of a corner the follower could
    /// not turn out of.
    Backup,
}

impl Default for RecoveryParams {
    fn default() -> Self {
        Self {
            number_of_retries: 6,
            behaviors: vec![
                RecoveryBehavior::Clear,
                RecoveryBehavior::Spin,
                RecoveryBehavior::Wait,
                RecoveryBehavior::Backup,
            ],
            spin_dist: 1.57,
            backup_dist: 0.30,
            backup_speed: 0.15,
            wait_duration: 5.0,
            time_allowance: 10.0,
        }
    }
}

/// Nav2's InputAtWaypoint task executor (its parameter names and defaults, but off by
/// default: a patrol without an inspection node would miss every waypoint).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct InputAtWaypointParams {
    /// Wait for the input at each waypoint. Default false.
    pub enabled: bool,
    /// Where the input comes from: any std_msgs/Empty on it after the robot reached the
    /// waypoint. Nav2's default `input_at_waypoint/input`.
    pub input_topic: String,
    /// How long (s) to wait; with no input by then the waypoint is missed
    /// (TASK_EXECUTOR_FAILED, 601), and with `stop_on_failure` the patrol ends. Nav2's 10.
    pub timeout: f64,
}

impl Default for InputAtWaypointParams {
    fn default() -> Self {
        Self {
            enabled: false,
            input_topic: "input_at_waypoint/input".into(),
            timeout: 10.0,
        }
    }
}

/// Nav2's PhotoAtWaypoint task executor (its parameter names and defaults, but off by
/// default): at each waypoint reached, after the pause, the latest camera frame, once one has
/// come since the arrival (Nav2 takes the latest, whenever it came), is saved as
/// `<save_dir>/<waypoint index>_<seconds>.<image_format>`, the seconds the node's clock's when
/// it is saved (Nav2 names it by the waypoint's own stamp, so a second pass overwrites the
/// first's photos).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PhotoAtWaypointParams {
    /// Take the photos. Default false.
    pub enabled: bool,
    /// The camera's sensor_msgs/Image topic, subscribed best effort, so that a camera
    /// publishing with the sensor-data QoS matches as well as a reliable one (Nav2 subscribes
    /// reliable, which a best-effort camera never matches). Nav2's `/camera/color/image_raw`.
    pub image_topic: String,
    /// The folder the photos go to, made when missing. Nav2's `/tmp/waypoint_images`.
    pub save_dir: String,
    /// `png`, Nav2's default (lossless; this build writes no other format).
    pub image_format: String,
}

impl Default for PhotoAtWaypointParams {
    fn default() -> Self {
        Self {
            enabled: false,
            image_topic: "/camera/color/image_raw".into(),
            save_dir: "/tmp/waypoint_images".into(),
            image_format: "png".into(),
        }
    }
}

/// Nav2's BinaryFilter (a costmap filter plugin; these are its parameter names and defaults,
/// the block Nav2 writes under the filter's name): the nav2_msgs/CostmapFilterInfo of type 3
/// that costmap_filter_info_server latches on `filter_info_topic` names a mask; where the robot
/// stands on it, a filter value `base + value * multiplier` above `flip_threshold` switches the
/// state to the opposite of `default_state`, and each change is published on
/// `binary_state_topic`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BinaryFilterParams {
    /// Run the filter when `filter_info_topic` is set. Default true, as every Nav2 layer.
    pub enabled: bool,
    /// Where the filter info arrives (e.g. `/binary_filter_info`). Empty (default): no filter.
    pub filter_info_topic: String,
    /// Where the state goes out, std_msgs/Bool, latched (reliable, transient local), so that a
    /// node started later reads the state in force. Nav2's default `binary_state`; relative
    /// names are in the node's namespace.
    pub binary_state_topic: String,
    /// The state outside every zone, off the mask and at start. Default false.
    pub default_state: bool,
    /// The filter value above which the state flips. Default 50.
    pub flip_threshold: f64,
}

impl Default for BinaryFilterParams {
    fn default() -> Self {
        Self {
            enabled: true,
            filter_info_topic: String::new(),
            binary_state_topic: "binary_state".into(),
            default_state: false,
            flip_threshold: 50.0,
        }
    }
}

impl BinaryFilterParams {
    /// Whether the node runs the filter: enabled and given a filter info topic.
    pub fn runs(&self) -> bool {
        self.enabled && !self.filter_info_topic.is_empty()
    }
}

/// Nav2's behavior server (nav2_behaviors), which serves the `spin`, `backup`,
/// `drive_on_heading` and `wait` actions and makes the recoveries' motions.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BehaviorServerParams {
    /// How far ahead (s) a spin's or back-up's motion is checked against the costmap before
    /// each command; a motion that would hit an obstacle within it stops and fails
    /// (COLLISION_AHEAD). Nav2's default 2.
    pub simulate_ahead_time: f64,
    /// assisted_teleop: how far ahead (s) an operator's command is projected; one that would
    /// reach an obstacle within it is scaled down by the time to it over this. Nav2's 1.
    pub projection_time: f64,
    /// assisted_teleop: the spacing (s) of the projected poses. Nav2's 0.1.
    pub simulation_time_step: f64,
    /// assisted_teleop: the operator's commands (geometry_msgs/Twist, or TwistStamped with
    /// `enable_stamped_cmd_vel`, as Nav2 reads them). Nav2's `cmd_vel_teleop`.
    pub cmd_vel_teleop: String,
}

impl Default for BehaviorServerParams {
    fn default() -> Self {
        Self {
            simulate_ahead_time: 2.0,
            projection_time: 1.0,
            simulation_time_step: 0.1,
            cmd_vel_teleop: "cmd_vel_teleop".into(),
        }
    }
}

/// The local costmap a node standing alone (`follow_plan`) serves on
/// `local_costmap/get_costmap`, as controller_server's local costmap: a rolling window of the
/// node's own grid round the robot, the costs its follower and behaviours check against.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LocalCostmapParams {
    /// The window's width (m, along the map's x). Nav2's nav2_params.yaml: 3.
    pub width: f64,
    /// The window's height (m, along the map's y). Nav2's nav2_params.yaml: 3.
    pub height: f64,
}

impl Default for LocalCostmapParams {
    fn default() -> Self {
        Self {
            width: 3.0,
            height: 3.0,
        }
    }
}

impl Default for NodeParams {
    fn default() -> Self {
        Self {
            map_yaml: String::new(),
            global_frame: "map".into(),
            map_to_odom: [0.0; 3],
            track_map_to_odom: true,
            odom_frame: "odom".into(),
            publish_pareto: true,
            publish_costmap: true,
            follow_plan: true,
            twist_limits: TwistLimits::default(),
            follower: FollowerParams::default(),
            progress_checker: ProgressParams::default(),
            recovery: RecoveryParams::default(),
            behavior_server: BehaviorServerParams::default(),
            local_costmap: LocalCostmapParams::default(),
            obstacle_layer: ObstacleLayerParams::default(),
            enable_stamped_cmd_vel: false,
            robot_base_frame: "base_link".into(),
            control_rate_hz: 20.0,
            pose_timeout: 0.5,
            transform_tolerance: 0.3,
            costmap_update_timeout: 1.0,
            autostart: true,
            use_final_approach_orientation: false,
            expected_planner_frequency: 1.0,
            bond_heartbeat_period: 0.1,
            costmap_topic: String::new(),
            keepout_mask_topic: String::new(),
            keepout_filter_info_topic: String::new(),
            speed_limit_topic: "speed_limit".into(),
            speed_filter_info_topic: String::new(),
            binary_filter: BinaryFilterParams::default(),
            use_sim_time: false,
            order_waypoints: true,
            waypoint_pause_duration: 0.0,
            stop_on_failure: false,
            input_at_waypoint: InputAtWaypointParams::default(),
            photo_at_waypoint: PhotoAtWaypointParams::default(),
            planner_plugins: vec!["GridBased".into()],
            plugin_planners: BTreeMap::new(),
        }
    }
}

impl NodeParams {
    /// Checks the values serde cannot: limits, rates and the transform.
    pub fn validate(&self) -> Result<(), String> {
        let positive = |v: f64| v.is_finite() && v > 0.0;
        self.twist_limits.check_rated("twist_limits")?;
        if !positive(self.control_rate_hz)
            || self.control_rate_hz > 200.0
            || !positive(self.pose_timeout)
        {
            return Err(
                "control_rate_hz (at most 200) and pose_timeout must be finite and positive".into(),
            );
        }
        if !(0.0..=60.0).contains(&self.costmap_update_timeout) {
            return Err(format!(
                "costmap_update_timeout must be from 0 to 60 s, not {}",
                self.costmap_update_timeout
            ));
        }
        if !(0.0..=10.0).contains(&self.transform_tolerance) {
            return Err(format!(
                "transform_tolerance must be from 0 to 10 s, not {}",
                self.transform_tolerance
            ));
        }
        self.follower.validate()?;
        let non_negative = |v: f64| v.is_finite() && v >= 0.0;
        if !non_negative(self.expected_planner_frequency)
            || !non_negative(self.bond_heartbeat_period)
            || !non_negative(self.waypoint_pause_duration)
        {
            return Err(
                "expected_planner_frequency, bond_heartbeat_period and waypoint_pause_duration must be finite and not negative"
                    .into(),
            );
        }
        // Periods become timers: one too short is a busy loop (or a zero period, which the
        // timer refuses), one too long overflows the clock.
        if self.control_rate_hz < 0.1
            || !(self.bond_heartbeat_period == 0.0
                || (0.01..=60.0).contains(&self.bond_heartbeat_period))
            || self.waypoint_pause_duration > 3_600.0
        {
            return Err(
                "control_rate_hz must be at least 0.1, bond_heartbeat_period 0 (off) or within 0.01..=60 s, waypoint_pause_duration at most 3600 s"
                    .into(),
            );
        }
        if !self.progress_checker.is_valid() {
            return Err(
                "progress_checker: required_movement_radius, required_movement_angle and movement_time_allowance (at most a day) must be finite and positive"
                    .into(),
            );
        }
        let r = &self.recovery;
        let within = |v: f64, lo: f64, hi: f64| (lo..=hi).contains(&v);
        if r.number_of_retries > 100
            || !within(r.wait_duration, 0.0, 600.0)
            || !within(r.time_allowance, 0.1, 600.0)
            || !within(r.spin_dist.abs(), 0.0, 4.0 * std::f64::consts::PI)
            || !within(r.backup_dist, 0.01, 5.0)
            || !within(r.backup_speed, 0.01, 1.0)
            || (r.number_of_retries > 0 && r.behaviors.is_empty())
            || r.behaviors.len() > 16
        {
            return Err(
                "recovery: number_of_retries at most 100, wait_duration within 0..=600 s, time_allowance within 0.1..=600 s, spin_dist within +-4 pi rad, backup_dist within 0.01..=5 m, backup_speed within 0.01..=1 m/s, behaviors 1 to 16 of clear, spin, wait, backup"
                    .into(),
            );
        }
        let binary = &self.binary_filter;
        if !binary.flip_threshold.is_finite()
            || (binary.runs() && binary.binary_state_topic.is_empty())
        {
            return Err(
                "binary_filter: flip_threshold must be finite, and a filter_info_topic needs a binary_state_topic"
                    .into(),
            );
        }
        let photo = &self.photo_at_waypoint;
        if photo.image_format != "png"
            || (photo.enabled && (photo.image_topic.is_empty() || photo.save_dir.is_empty()))
        {
            return Err(format!(
                "photo_at_waypoint: image_format `png` only (not `{}`: this build writes no other format), and an image_topic and save_dir when enabled",
                photo.image_format
            ));
        }
        let input = &self.input_at_waypoint;
        if !within(input.timeout, 0.1, 3_600.0) || (input.enabled && input.input_topic.is_empty()) {
            return Err(
                "input_at_waypoint: timeout within 0.1..=3600 s, and an input_topic when enabled"
                    .into(),
            );
        }
        let b = &self.behavior_server;
        if !within(b.simulate_ahead_time, 0.0, 10.0)
            || !within(b.projection_time, 0.1, 10.0)
            || !within(b.simulation_time_step, 0.01, b.projection_time)
            || b.simulation_time_step >= b.projection_time
            || b.cmd_vel_teleop.is_empty()
        {
            return Err("behavior_server: simulate_ahead_time within 0..=10 s, projection_time within 0.1..=10 s, simulation_time_step at least 0.01 s and below projection_time, cmd_vel_teleop a topic".into());
        }
        self.obstacle_layer.validate()?;
        let local = &self.local_costmap;
        if !within(local.width, 0.1, 100.0) || !within(local.height, 0.1, 100.0) {
            return Err("local_costmap: width and height within 0.1..=100 m".into());
        }
        for (key, topic) in [
            ("keepout_mask_topic", &self.keepout_mask_topic),
            ("keepout_filter_info_topic", &self.keepout_filter_info_topic),
        ] {
            if !topic.is_empty() && !self.costmap_topic.is_empty() {
                return Err(format!(
                    "{key} (`{topic}`) lays a mask over the node's own costmap, and with costmap_topic (`{}`) the node plans on another's: add Nav2's KeepoutFilter to that costmap instead, or leave costmap_topic empty",
                    self.costmap_topic
                ));
            }
        }
        if !self.keepout_mask_topic.is_empty() && !self.keepout_filter_info_topic.is_empty() {
            return Err(format!(
                "keepout_mask_topic (`{}`) and keepout_filter_info_topic (`{}`) both name the keepout mask: set one (the filter info names its mask topic itself)",
                self.keepout_mask_topic, self.keepout_filter_info_topic
            ));
        }
        if !self.map_to_odom.iter().all(|v| v.is_finite()) {
            return Err("map_to_odom must be finite".into());
        }
        for (k, id) in self.planner_plugins.iter().enumerate() {
            if id.is_empty() || self.planner_plugins[..k].contains(id) {
                return Err(format!(
                    "planner_plugins must name each id once, none empty: {:?}",
                    self.planner_plugins
                ));
            }
        }
        Ok(())
    }

    /// The planner a ComputePathToPose `planner_id` asks for. An id of `planner_plugins` with a
    /// planner of its own is that planner, as planner_server looks its plugin ids up; beyond
    /// Nav2, an id of `planner_plugins` without one (Nav2's `GridBased` by default) is `None`,
    /// the `planner` parameter, and so is an empty id, whatever the number of ids (Nav2 takes
    /// an empty id only with one plugin: here `planner` is always the default); and any of this
    /// node's planner names may be asked for by name. Anything else is refused with what it
    /// could have been.
    pub fn planner_for_id(&self, id: &str) -> Result<Option<PlannerName>, String> {
        if id.is_empty() {
            return Ok(None);
        }
        if self.planner_plugins.iter().any(|p| p == id) {
            return Ok(self.plugin_planners.get(id).copied().flatten());
        }
        id.parse::<PlannerName>().map(Some).map_err(|_| {
            format!(
                "planner_id `{id}` is neither an id of planner_plugins ({}) nor a planner ({})",
                self.planner_plugins.join(", "),
                PlannerName::list()
            )
        })
    }
}

/// Keys of Nav2's planner_server block that this node reads past, each with why. Each is
/// accepted with a warning, so that Nav2's own params file loads unedited.
const NAV2_KEYS_IGNORED: [(&str, &str); 1] = [(
    "action_server_result_timeout",
    "this node keeps an action's result 900 s for its client, as rcl_action does by default",
)];

/// Keys of a Nav2 planner plugin's block (NavFn's, Smac's and Theta*'s alike) that mean what
/// this node's top-level keys of the same meaning do: the first plugin id's (the one an
/// empty `planner_id` asks for) set those when the file does not set them itself, so that
/// Nav2's params file plans as Nav2 would (its GridBased block has `tolerance: 0.5` and
/// `allow_unknown: true`, where this node's defaults are 0.25 and false).
const PLUGIN_KEYS_ADOPTED: [&str; 2] = ["tolerance", "allow_unknown"];

/// What an id's block (`GridBased: {plugin: ..., tolerance: ...}`) makes the id answer with:
/// `Some(planner)` for one of ours, `None` (the `planner` parameter) for a Nav2 C++ plugin
/// (pluginlib's `package/Class` or `package::Class`), with a warning for that and for every other
/// key of the block, which belongs to the C++ plugin.
fn plugin_block(
    id: &str,
    block: &Value,
    adopts: bool,
    warnings: &mut Vec<String>,
) -> Result<Option<PlannerName>, String> {
    let Value::Mapping(m) = block else {
        return Err(format!(
            "`{id}` (in planner_plugins) must be a block such as `{id}: {{plugin: mocmcso}}`"
        ));
    };
    let plugin = match m.get("plugin") {
        Some(Value::String(s)) => s.as_str(),
        _ => {
            return Err(format!(
                "`{id}.plugin` must name a planner ({})",
                PlannerName::list()
            ))
        }
    };
    let others: Vec<&str> = m
        .keys()
        .filter_map(Value::as_str)
        .filter(|k| *k != "plugin" && !(adopts && PLUGIN_KEYS_ADOPTED.contains(k)))
        .collect();
    if !others.is_empty() {
        warnings.push(format!(
            "ignored in `{id}`: {} (keys of a Nav2 C++ plugin; this node's own are top-level: tolerance, allow_unknown, ...)",
            others.join(", ")
        ));
    }
    match plugin.parse::<PlannerName>() {
        Ok(p) => Ok(Some(p)),
        Err(_) if plugin.contains('/') || plugin.contains("::") => {
            warnings.push(format!(
                "`{id}.plugin` is the Nav2 plugin `{plugin}`, which this node does not load: `{id}` answers with the `planner` parameter"
            ));
            Ok(None)
        }
        Err(e) => Err(format!("`{id}.plugin`: {}", e.reason)),
    }
}

/// [`PLUGIN_KEYS_ADOPTED`] from the first plugin id's block into the planning keys, where the
/// file leaves them unset (a top-level `tolerance` or `costmap.allow_unknown` wins, with a
/// warning when the block says otherwise). Their types are checked with the rest.
fn adopt_plugin_keys(id: &str, block: &Value, planning: &mut Mapping, warnings: &mut Vec<String>) {
    for key in PLUGIN_KEYS_ADOPTED {
        let Some(value) = block.get(key) else {
            continue;
        };
        // `allow_unknown` is the costmap section's here.
        let section = if key == "allow_unknown" {
            let costmap = planning
                .entry(Value::from("costmap"))
                .or_insert_with(|| Value::Mapping(Mapping::new()));
            match costmap {
                Value::Mapping(m) => m,
                // Not a mapping: the typed read below names it.
                _ => continue,
            }
        } else {
            &mut *planning
        };
        match section.get(key) {
            None => {
                section.insert(Value::from(key), value.clone());
                warnings.push(format!(
                    "`{key}` from `{id}`: {} (the block of the first planner_plugins id)",
                    yaml_text(value)
                ));
            }
            // Equal as numbers too: `1` and `1.0` are one tolerance.
            Some(own)
                if own != value && own.as_f64().zip(value.as_f64()).is_none_or(|(a, b)| a != b) =>
            {
                warnings.push(format!(
                    "`{id}.{key}` ignored: the top-level value is set and wins"
                ))
            }
            Some(_) => {}
        }
    }
}

/// A YAML value as one line of a message (`astar`, `0.5`, `[GridBased, Smooth]`).
fn yaml_text(value: &Value) -> String {
    serde_yaml::to_string(value)
        .unwrap_or_default()
        .trim_end()
        .to_owned()
}

/// A relative `map_yaml` in a file's block, taken from that file's folder.
fn resolve_map_yaml(file: &Path, block: &mut Mapping) {
    if let Some(Value::String(map)) = block.get("map_yaml") {
        if !map.is_empty() && Path::new(map).is_relative() {
            let resolved = file.parent().unwrap_or(Path::new(".")).join(map);
            let resolved = Value::from(resolved.to_string_lossy().into_owned());
            block.insert(Value::from("map_yaml"), resolved);
        }
    }
}

/// A whole parameter file: the planning part and the node's own.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ParameterFile {
    pub planning: PlannerConfig,
    pub node: NodeParams,
    /// What was read past (Nav2's keys for its C++ plugins and its costmap), one line each, for
    /// the reader to log.
    pub warnings: Vec<String>,
}

/// Reads and validates the `patrol_planner` block of a parameter file (keyed `patrol_planner`,
/// `/patrol_planner` or rclcpp's wildcard `/**`, as ROS 2 files are). `map_yaml` comes back
/// resolved against the file's folder.
pub fn load_parameter_file(path: &Path) -> Result<ParameterFile, LoadError> {
    load_parameter_file_for(path, &[NODE_NAME, "/patrol_planner", WILDCARD])
}

/// The same for a node that may run under another name (`-r __node:=planner_server -r
/// __ns:=/robot1`): see [`load_parameters_for`], with this one file and no overrides.
pub fn load_parameter_file_for(
    path: &Path,
    node_names: &[&str],
) -> Result<ParameterFile, LoadError> {
    load_parameters_for(&[ParameterSource::File(path.to_owned())], node_names)
}

/// A node's parameters from every `--params-file` and `-p [node:]name:=value` of its command
/// line, with rclcpp's precedence (rclcpp#1094, launch_ros' Node documentation): every value
/// for the wildcard `/**` (a file's `/**` block, or a `-p` without a node prefix, which rcl
/// files under `/**`) in command-line order, then every value for the node's own name (its block
/// in a file, a `-p` prefixed with its name) over them, in command-line order. So launch_ros'
/// `parameters=[nav2_params.yaml, {'use_sim_time': True}]`, two files, is read whole (the
/// dict's `/**` value under the first file's own block, should that set it too); and a plain
/// `-p planner:=astar` is overridden by a file's `patrol_planner:` block that sets `planner`
/// (warned: write `-p patrol_planner:planner:=astar`, as a C++ node would need too). Sections
/// merge key by key; a dotted name is a nested key.
///
/// A file's own block is the first it has among `node_names` (say the fully qualified name,
/// the plain name, then `patrol_planner`). The merged values are read and validated as one
/// file's block would be. When some file has a block of the node's own, the `/**` blocks' keys
/// this node does not know are meant for other nodes: ignored with a warning, as rclcpp nodes
/// ignore undeclared ones; without one, a `/**` block is read as the node's own (unknown keys
/// refused). A `-p` is this node's, always: its unknown key is refused naming it, and a `-p` for
/// another node's name is passed over with a warning. A relative `map_yaml` is taken from the
/// folder of the file that names it (launch_ros writes a dict's file in the temporary folder:
/// give a launch's map_yaml as an absolute path). With several files, one without a block for
/// the node is passed over with a warning; with one, or when no file has a block, it is an
/// error. An error of the merged values names every source, a warning its own. The layering is
/// ros-parameters' [`Layers`], which chassis_bridge reads its parameters with too; what is the
/// planner's own here is which keys it knows and Nav2's plugin blocks.
pub fn load_parameters_for(
    sources: &[ParameterSource],
    node_names: &[&str],
) -> Result<ParameterFile, LoadError> {
    let mut layers = Layers::gather(sources, node_names, resolve_map_yaml)?;
    let planning_keys = keys(&PlannerConfig::default());
    let node_keys = keys(&NodeParams::default());
    // With a block of the node's own somewhere, the wildcard's unknown keys from files are
    // other nodes' (a `-p`'s stay: this node's, refused below when unknown).
    layers.drop_other_nodes_wildcard_keys(|k| {
        planning_keys.iter().chain(&node_keys).any(|n| n == k)
            || NAV2_KEYS_IGNORED.iter().any(|(n, _)| *n == k)
    });
    let block = layers.merge();
    let mut warnings = std::mem::take(&mut layers.warnings);
    let node_name = layers.own_block.as_deref().unwrap_or(WILDCARD);
    let config_err = |message: String| LoadError::from(layers.error(message));
    let block_warnings_from = warnings.len();
    // Nav2's plugin ids, whose blocks are keys of their own names.
    let plugin_ids: Vec<String> = match block.get("planner_plugins") {
        None => NodeParams::default().planner_plugins,
        Some(v) => serde_yaml::from_value(v.clone())
            .map_err(|e| config_err(format!("planner_plugins: {e}")))?,
    };
    let (mut planning, mut node) = (Mapping::new(), Mapping::new());
    let mut plugin_planners = BTreeMap::new();
    let mut first_block = None;
    for (key, value) in block {
        let name = key.as_str().unwrap_or_default();
        if plugin_ids.iter().any(|id| id == name) {
            if planning_keys.iter().chain(&node_keys).any(|k| k == name) {
                return Err(config_err(format!(
                    "planner_plugins id `{name}` is also a parameter's name"
                )));
            }
            let first = plugin_ids.first().is_some_and(|id| id == name);
            let planner = plugin_block(name, &value, first, &mut warnings).map_err(config_err)?;
            plugin_planners.insert(name.to_owned(), planner);
            if first {
                first_block = Some(value);
            }
        } else if planning_keys.iter().any(|k| k == name) {
            planning.insert(key, value);
        } else if node_keys.iter().any(|k| k == name) {
            node.insert(key, value);
        } else if let Some((_, why)) = NAV2_KEYS_IGNORED.iter().find(|(k, _)| *k == name) {
            warnings.push(format!("ignored Nav2's `{name}`: {why}"));
        } else {
            let mut valid = planning_keys.clone();
            valid.extend(node_keys.iter().cloned());
            let place = match layers.set_by(name) {
                Some(given) => format!("set by `{given}`"),
                None => format!("in `{node_name}: ros__parameters:`"),
            };
            return Err(config_err(format!(
                "unknown parameter `{}` {place}; valid: {}",
                yaml_text(&key),
                valid.join(", ")
            )));
        }
    }
    if let Some(block) = &first_block {
        adopt_plugin_keys(&plugin_ids[0], block, &mut planning, &mut warnings);
    }
    // A value of the wrong type is named by its key path (`swarm.population: invalid value:
    // integer -5, expected usize`), not by serde's type alone.
    let typed = |e: serde_path_to_error::Error<serde_yaml::Error>| {
        config_err(format!("parameter `{}`: {}", e.path(), e.inner()))
    };
    for id in &plugin_ids {
        let answers = plugin_planners.get(id).copied().flatten();
        // An id named like one of our planners must run it (bare, or with another planner's
        // block, it would answer otherwise): `planner_id: astar` would mean two things.
        if let Ok(named) = id.parse::<PlannerName>() {
            if answers != Some(named) {
                return Err(config_err(format!(
                    "planner_plugins id `{id}` is a planner's name: give it the block `{id}: {{plugin: {named}}}` or another id"
                )));
            }
        }
        if !plugin_planners.contains_key(id) && id != "GridBased" {
            warnings.push(format!(
                "planner_plugins id `{id}` has no block `{id}: {{plugin: ...}}`: it answers with the `planner` parameter"
            ));
        }
    }
    let planning: PlannerConfig =
        serde_path_to_error::deserialize(Value::Mapping(planning)).map_err(typed)?;
    planning.validate().map_err(|e| config_err(e.to_string()))?;
    let mut node: NodeParams =
        serde_path_to_error::deserialize(Value::Mapping(node)).map_err(typed)?;
    node.plugin_planners = plugin_planners;
    node.validate().map_err(config_err)?;
    // The merged block's warnings name its sources; each file's own already name the file.
    let label = layers.label();
    for w in &mut warnings[block_warnings_from..] {
        *w = format!("{label}: {w}");
    }
    Ok(ParameterFile {
        planning,
        node,
        warnings,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    /// A file of this text in the tests' folder (one per process; each test its own names).
    fn write_file(name: &str, text: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("planner-io-params-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    /// A `-p` rule as the command line gives it.
    fn rule(node: Option<&str>, name: &str, value: &Value, given: &str) -> ParameterSource {
        ParameterSource::Override(ParameterOverride {
            node: node.map(String::from),
            name: name.to_owned(),
            value: value.clone(),
            given: given.to_owned(),
        })
    }

    /// rclcpp's precedence over files and `-p` rules: `/**` values (a file's wildcard block, a
    /// `-p` without a node name) in command-line order, then the node's own (its block in a
    /// file, a `-p` with its name) over them in order; sections merged key by key; each file's
    /// relative map_yaml from its own folder; a rule for another node not applied; warnings
    /// name their source. (launch_ros passes `parameters=[nav2_params.yaml, {...}]` as two
    /// files.)
    #[test]
    fn files_and_rules_apply_with_rclcpps_precedence() {
        let base = write(
            "multi_base.yaml",
            "    planner: astar\n    tolerance: 0.3\n    map_yaml: maps/a.yaml\n    \
             swarm: {population: 30, patience: 5, iterations: 50}\n",
        );
        let dir = base.parent().unwrap().join("launch");
        std::fs::create_dir_all(&dir).unwrap();
        let dict = dir.join("multi_dict.yaml");
        std::fs::write(
            &dict,
            "/**:\n  ros__parameters:\n    use_sim_time: true\n    controller_frequency: 20.0\n\
             patrol_planner:\n  ros__parameters:\n    planner: any_angle\n    \
             map_yaml: b.yaml\n    swarm: {patience: 7}\n",
        )
        .unwrap();
        let other = write_file(
            "multi_other.yaml",
            "controller_server:\n  ros__parameters: {}\n",
        );
        let late = write_file(
            "multi_late.yaml",
            "/**:\n  ros__parameters:\n    max_planning_time: 7.0\n    swarm: {iterations: 99}\n    \
             late_only_key: 1\n",
        );
        let yaml = |t: &str| serde_yaml::from_str::<Value>(t).unwrap();
        let (v40, v05, off, imga, ga) = (
            yaml("40"),
            yaml("0.5"),
            yaml("false"),
            yaml("imga"),
            yaml("ga"),
        );
        let (v3, waypoints) = (yaml("3.0"), yaml("{waypoints: 9}"));
        let sources = [
            ParameterSource::File(base.clone()),
            ParameterSource::File(dict.clone()),
            rule(None, "swarm.population", &v40, "-p swarm.population:=40"),
            rule(None, "use_sim_time", &off, "-p use_sim_time:=false"),
            rule(None, "max_planning_time", &v3, "-p max_planning_time:=3.0"),
            rule(None, "swarm", &waypoints, "-p swarm:={waypoints: 9}"),
            ParameterSource::File(other.clone()),
            ParameterSource::File(late.clone()),
            rule(
                Some("patrol_planner"),
                "tolerance",
                &v05,
                "-p patrol_planner:tolerance:=0.5",
            ),
            rule(
                Some("patrol_planner"),
                "planner",
                &imga,
                "-p patrol_planner:planner:=imga",
            ),
            rule(
                Some("planner_server"),
                "planner",
                &ga,
                "-p planner_server:planner:=ga",
            ),
        ];
        let file = load_parameters_for(&sources, &[NODE_NAME, WILDCARD]).unwrap();
        let swarm = &file.planning.swarm;
        assert_eq!(
            file.planning.planner.to_string(),
            "imga",
            "the node's rule, not the other's"
        );
        assert_eq!(
            file.planning.tolerance, 0.5,
            "the node's rule after its blocks"
        );
        assert_eq!(swarm.population, 30, "the node's block over a plain -p");
        assert_eq!(
            swarm.patience, 7,
            "the second file's block over the first's, key by key"
        );
        assert_eq!(
            swarm.iterations, 50,
            "the node's block over a later /** block"
        );
        assert_eq!(
            file.planning.max_planning_time, 7.0,
            "a later /** block over a plain -p"
        );
        assert_eq!(
            swarm.waypoints, 9,
            "a plain -p's mapping merged under the node's block"
        );
        assert!(
            !file.node.use_sim_time,
            "a plain -p after the /** block that set it"
        );
        assert_eq!(file.node.map_yaml, dir.join("b.yaml").to_string_lossy());
        let warned = file.warnings.join("\n");
        for expected in [
            format!(
                "{}: ignored `/**` key `controller_frequency`",
                dict.display()
            ),
            format!("{}: no `<node>: ros__parameters:` block", other.display()),
            format!("{}: ignored `/**` key `late_only_key`", late.display()),
            "`-p swarm.population:=40` does nothing".to_owned(),
            "write `-p patrol_planner:swarm.population:=...`".to_owned(),
            "`-p planner_server:planner:=ga` is for another node".to_owned(),
        ] {
            assert!(warned.contains(&expected), "{expected}\nin\n{warned}");
        }
        assert!(
            !warned.contains("-p swarm:="),
            "a mapping merges, not overridden: {warned}"
        );
        // One file: its map from its own folder, its block as it is.
        let alone = load_parameters_for(
            &[ParameterSource::File(base.clone())],
            &[NODE_NAME, WILDCARD],
        )
        .unwrap();
        assert_eq!(
            alone.node.map_yaml,
            base.parent().unwrap().join("maps/a.yaml").to_string_lossy()
        );
        assert_eq!(alone.planning.swarm.patience, 5);
        assert!(alone.warnings.is_empty(), "{:?}", alone.warnings);
        // Rules alone (no file) set keys over the defaults.
        let bare = load_parameters_for(&sources[2..3], &[NODE_NAME, WILDCARD]).unwrap();
        assert_eq!(bare.planning.swarm.population, 40);
    }

    /// What the merged values get wrong is refused naming every source; an unknown key set by
    /// `-p` names that `-p` (a `-p` is this node's even without its name); no block in any file
    /// is an error.
    #[test]
    fn a_bad_rule_or_no_block_is_refused_naming_the_sources() {
        let base = write("multi_refused.yaml", "    planner: astar\n");
        let yaml = |t: &str| serde_yaml::from_str::<Value>(t).unwrap();
        let names = [NODE_NAME, WILDCARD];
        let refusal = |sources: &[ParameterSource]| {
            load_parameters_for(sources, &names)
                .unwrap_err()
                .to_string()
        };
        let refused = |name: &str, value: &str| {
            let value = yaml(value);
            let given = format!("-p {name}:=...");
            refusal(&[
                ParameterSource::File(base.clone()),
                rule(None, name, &value, &given),
            ])
        };
        let prefix = format!("{} + -p: ", base.display());
        let unknown = refused("planer", "astar");
        assert!(unknown.starts_with(&prefix), "{unknown}");
        assert!(
            unknown.contains("unknown parameter `planer` set by `-p planer:=...`"),
            "{unknown}"
        );
        let typed = refused("swarm.population", "-5");
        assert!(
            typed.starts_with(&prefix) && typed.contains("parameter `swarm.population`"),
            "{typed}"
        );
        let invalid = refused("tolerance", "-1.0");
        assert!(
            invalid.starts_with(&prefix) && invalid.contains("tolerance"),
            "{invalid}"
        );
        // A later file's `/**` block with the same unknown key does not make it another node's.
        let shared = write_file(
            "multi_shared.yaml",
            "/**:\n  ros__parameters:\n    planer: x\n",
        );
        let typo = yaml("astar");
        let sources = [
            ParameterSource::File(base.clone()),
            rule(None, "planer", &typo, "-p planer:=astar"),
            ParameterSource::File(shared.clone()),
        ];
        let err = refusal(&sources);
        assert!(
            err.contains("unknown parameter `planer` set by `-p planer:=astar`"),
            "{err}"
        );
        let other = write_file(
            "multi_none.yaml",
            "controller_server:\n  ros__parameters: {}\n",
        );
        let sources = [
            ParameterSource::File(other.clone()),
            ParameterSource::File(other.clone()),
        ];
        let none = refusal(&sources);
        assert!(
            none.contains("no `<node>: ros__parameters:` block for any of"),
            "{none}"
        );
    }

    /// The file `name` with `block` is refused, its error naming `word`.
    fn assert_refused(name: &str, block: &str, word: &str) {
        let err = load_parameter_file(&write(name, block))
            .unwrap_err()
            .to_string();
        assert!(err.contains(word), "{name}: {err}");
    }

    /// A parameter file whose `patrol_planner` block holds `block`.
    fn write(name: &str, block: &str) -> PathBuf {
        write_file(
            name,
            &format!("patrol_planner:\n  ros__parameters:\n{block}"),
        )
    }

    #[test]
    fn a_top_level_typo_is_an_error_naming_the_key_and_the_file() {
        for (file, typo) in [
            ("planer.yaml", "    planer: astar\n"),
            ("time.yaml", "    max_planing_time: 1.0\n"),
            ("node.yaml", "    folow_plan: false\n"),
        ] {
            let p = write(file, typo);
            let err = load_parameter_file(&p).unwrap_err().to_string();
            let key = typo.trim().split(':').next().unwrap();
            assert!(err.contains(&format!("`{key}`")), "{err}");
            assert!(err.contains(file), "{err}");
        }
    }

    /// Nav2's own planner_server block (Jazzy's nav2_params.yaml) loads as it stands: its plugin
    /// id answers with the `planner` parameter, what belongs to its C++ plugin and costmap is
    /// named in the warnings, and an id that is neither a plugin id nor a planner is refused.
    #[test]
    fn nav2s_planner_server_block_loads_unedited() {
        let p = write_file(
            "nav2_params.yaml",
            "planner_server:\n  ros__parameters:\n    expected_planner_frequency: 20.0\n    \
             use_sim_time: True\n    costmap_update_timeout: 1.0\n    \
             action_server_result_timeout: 10.0\n    \
             planner_plugins: [\"GridBased\"]\n    GridBased:\n      \
             plugin: \"nav2_navfn_planner/NavfnPlanner\"\n      tolerance: 0.5\n      \
             use_astar: false\n      allow_unknown: true\n",
        );
        let file = load_parameter_file_for(&p, &["planner_server"]).unwrap();
        let warned = file.warnings.join("\n");
        for word in [
            "action_server_result_timeout",
            "nav2_navfn_planner/NavfnPlanner",
            "ignored in `GridBased`: use_astar",
        ] {
            assert!(warned.contains(word), "{word} not in {warned}");
        }
        // The plugin's tolerance and allow_unknown mean what this node's keys do: adopted.
        assert_eq!(file.planning.tolerance, 0.5);
        assert!(file.planning.costmap.allow_unknown);
        let node = &file.node;
        assert_eq!(node.expected_planner_frequency, 20.0);
        assert_eq!(node.costmap_update_timeout, 1.0);
        assert!(
            node.use_sim_time,
            "Nav2's simulation stamps with /clock here too"
        );
        assert_eq!(node.planner_for_id(""), Ok(None));
        assert_eq!(node.planner_for_id("GridBased"), Ok(None));
        assert_eq!(node.planner_for_id("astar"), Ok(Some(PlannerName::Astar)));
        let err = node.planner_for_id("Dijkstra").unwrap_err();
        assert!(
            err.contains("GridBased") && err.contains("mocmcso"),
            "{err}"
        );
        // Under a namespace Nav2's launch nests the block: `robot1: planner_server:`.
        let nested = write_file(
            "nested.yaml",
            "robot1:\n  planner_server:\n    ros__parameters:\n      planner: astar\n",
        );
        let file = load_parameter_file_for(&nested, &["/robot1/planner_server"]).unwrap();
        assert_eq!(file.planning.planner, PlannerName::Astar);
    }

    /// The first plugin's block sets what the file leaves unset; a top-level value wins; a
    /// second plugin's block sets nothing; a value of the wrong type is refused by name.
    #[test]
    fn the_first_plugins_tolerance_and_allow_unknown_fill_unset_keys() {
        let both = write(
            "adopt.yaml",
            "    planner_plugins: [A, B]\n    A: {plugin: astar, tolerance: 0.6}\n    \
             B: {plugin: mocmcso, tolerance: 0.9, allow_unknown: true}\n    \
             costmap: {allow_unknown: false}\n",
        );
        let file = load_parameter_file(&both).unwrap();
        assert_eq!(file.planning.tolerance, 0.6);
        assert!(!file.planning.costmap.allow_unknown);
        let warned = file.warnings.join("\n");
        assert!(
            warned.contains("ignored in `B`: tolerance, allow_unknown"),
            "{warned}"
        );
        let own = write(
            "own.yaml",
            "    tolerance: 0.1\n    planner_plugins: [A]\n    A: {plugin: astar, tolerance: 0.6, allow_unknown: true}\n",
        );
        let file = load_parameter_file(&own).unwrap();
        assert_eq!(file.planning.tolerance, 0.1);
        assert!(file.planning.costmap.allow_unknown);
        assert!(file.warnings.join("\n").contains("`A.tolerance` ignored"));
        let bad = write(
            "badtol.yaml",
            "    planner_plugins: [A]\n    A: {plugin: astar, tolerance: far}\n",
        );
        let err = load_parameter_file(&bad).unwrap_err().to_string();
        assert!(err.contains("tolerance"), "{err}");
    }

    #[test]
    fn plugin_ids_name_our_planners_and_typos_are_refused() {
        let p = write(
            "ids.yaml",
            "    planner_plugins: [GridBased, Safe, Plain]\n    GridBased: {plugin: astar}\n    \
             Safe: {plugin: mocmcso}\n",
        );
        let file = load_parameter_file(&p).unwrap();
        assert_eq!(file.warnings.len(), 1, "{:?}", file.warnings);
        assert!(
            file.warnings[0].contains("`Plain` has no block"),
            "{:?}",
            file.warnings
        );
        let node = &file.node;
        assert_eq!(
            node.planner_for_id("GridBased"),
            Ok(Some(PlannerName::Astar))
        );
        assert_eq!(node.planner_for_id("Safe"), Ok(Some(PlannerName::Mocmcso)));
        // Listed without a block: the `planner` parameter.
        assert_eq!(node.planner_for_id("Plain"), Ok(None));
        // Without `planner_plugins`, Nav2's default id.
        let file = load_parameter_file(&write("none.yaml", "    planner: astar\n")).unwrap();
        assert_eq!(file.node.planner_for_id("GridBased"), Ok(None));
        for (name, block, word) in [
            (
                "typo.yaml",
                "    GridBased: {plugin: mocmsco}\n",
                "GridBased.plugin",
            ),
            (
                "noplugin.yaml",
                "    GridBased: {tolerance: 0.5}\n",
                "GridBased.plugin",
            ),
            ("scalar.yaml", "    GridBased: astar\n", "GridBased"),
            // A block whose id is not listed is a typo like any other key.
            (
                "unlisted.yaml",
                "    Safe: {plugin: astar}\n",
                "unknown parameter `Safe`",
            ),
            (
                "clash.yaml",
                "    planner_plugins: [swarm]\n    swarm: {plugin: astar}\n",
                "also a parameter",
            ),
            (
                "twice.yaml",
                "    planner_plugins: [A, A]\n",
                "each id once",
            ),
            ("empty.yaml", "    planner_plugins: ['']\n", "none empty"),
            // An id that is a planner's name runs that planner or is refused.
            (
                "shadow.yaml",
                "    planner_plugins: [astar]\n",
                "is a planner's name",
            ),
            (
                "other.yaml",
                "    planner_plugins: [astar]\n    astar: {plugin: mocmcso}\n",
                "is a planner's name",
            ),
            (
                "type.yaml",
                "    planner_plugins: GridBased\n",
                "planner_plugins",
            ),
        ] {
            assert_refused(name, block, word);
        }
    }

    #[test]
    fn the_block_may_be_keyed_as_ros2_files_key_it() {
        for key in ["/patrol_planner", "/**"] {
            let p = write_file(
                &format!("keyed{}.yaml", key.len()),
                &format!("{key}:\n  ros__parameters:\n    planner: astar\n"),
            );
            let file = load_parameter_file(&p).unwrap();
            assert_eq!(file.planning.planner, PlannerName::Astar, "{key}");
        }
    }

    /// rclcpp applies `/**` and the node's own block together, the node's own winning key by
    /// key; the wildcard's keys for other nodes are passed over with a warning.
    #[test]
    fn the_wildcard_block_applies_under_the_nodes_own() {
        let p = write_file(
            "wildcard.yaml",
            "/**:\n  ros__parameters:\n    use_sim_time: true\n    planner: astar\n    \
             swarm: {population: 30, patience: 9}\n    scan_topic: /scan\n\
             patrol_planner:\n  ros__parameters:\n    planner: any_angle\n    swarm: {patience: 5}\n",
        );
        let file = load_parameter_file(&p).unwrap();
        assert!(file.node.use_sim_time);
        assert_eq!(file.planning.planner, PlannerName::AnyAngle);
        assert_eq!(
            (file.planning.swarm.population, file.planning.swarm.patience),
            (30, 5)
        );
        let warned = file.warnings.join("\n");
        assert!(warned.contains("`scan_topic`"), "{warned}");
        // In the node's own block the same unknown key is refused.
        let own = write("own_unknown.yaml", "    scan_topic: /scan\n");
        assert!(load_parameter_file(&own)
            .unwrap_err()
            .to_string()
            .contains("scan_topic"));
    }

    #[test]
    fn keys_go_to_their_part() {
        let p = write(
            "both.yaml",
            "    planner: astar\n    follow_plan: false\n    map_yaml: maps/x.yaml\n    swarm: {population: 7}\n",
        );
        let file = load_parameter_file(&p).unwrap();
        assert_eq!(file.planning.planner, planner_core::PlannerName::Astar);
        assert_eq!(file.planning.swarm.population, 7);
        assert!(!file.node.follow_plan);
        assert!(file.node.map_yaml.ends_with("maps/x.yaml") && file.node.map_yaml.len() > 11);
        // A value of the wrong type names its parameter.
        for (name, block, key) in [
            (
                "neg.yaml",
                "    swarm: {population: -5}\n",
                "`swarm.population`",
            ),
            (
                "enum.yaml",
                "    swarm: {mutation: gaussian}\n",
                "`swarm.mutation`",
            ),
            (
                "int.yaml",
                "    costmap: {occupied_threshold: 500}\n",
                "`costmap.occupied_threshold`",
            ),
            (
                "lookahead.yaml",
                "    follower: {lookahead: fast}\n",
                "`follower.lookahead",
            ),
            (
                "input_timeout.yaml",
                "    input_at_waypoint: {enabled: true, timeout: 0.0}\n",
                "input_at_waypoint",
            ),
            (
                "input_topic.yaml",
                "    input_at_waypoint: {enabled: true, input_topic: ''}\n",
                "input_at_waypoint",
            ),
            (
                "photo_jpg.yaml",
                "    photo_at_waypoint: {enabled: true, image_format: jpg}\n",
                "not `jpg`",
            ),
            (
                "photo_dir.yaml",
                "    photo_at_waypoint: {enabled: true, save_dir: ''}\n",
                "save_dir",
            ),
        ] {
            assert_refused(name, block, key);
        }
        // A keepout mask is laid over the node's own costmap only.
        let mask = write(
            "mask.yaml",
            "    keepout_mask_topic: /keepout_filter_mask\n",
        );
        assert_eq!(
            load_parameter_file(&mask).unwrap().node.keepout_mask_topic,
            "/keepout_filter_mask"
        );
        let both = write(
            "mask_and_costmap.yaml",
            "    keepout_mask_topic: /mask\n    costmap_topic: /global_costmap/costmap\n",
        );
        let err = load_parameter_file(&both).unwrap_err().to_string();
        assert!(
            err.contains("keepout_mask_topic") && err.contains("KeepoutFilter"),
            "{err}"
        );
        // Nav2's InputAtWaypoint, its defaults where not given.
        let input = write(
            "input.yaml",
            "    input_at_waypoint: {enabled: true, timeout: 3.0}\n",
        );
        let read = load_parameter_file(&input).unwrap().node.input_at_waypoint;
        assert!(read.enabled && read.timeout == 3.0);
        assert_eq!(read.input_topic, "input_at_waypoint/input");
        // The mask's topic from Nav2's filter info instead: not beside a mask topic too.
        let info = write(
            "info.yaml",
            "    keepout_filter_info_topic: /costmap_filter_info\n",
        );
        assert_eq!(
            load_parameter_file(&info)
                .unwrap()
                .node
                .keepout_filter_info_topic,
            "/costmap_filter_info"
        );
        for (name, block, key) in [
            (
                "info_and_mask.yaml",
                "    keepout_filter_info_topic: /info\n    keepout_mask_topic: /mask\n",
                "both name the keepout mask",
            ),
            (
                "info_and_costmap.yaml",
                "    keepout_filter_info_topic: /info\n    costmap_topic: /global_costmap/costmap\n",
                "keepout_filter_info_topic (`/info`)",
            ),
        ] {
            assert_refused(name, block, key);
        }
        // Nav2's obstacle layer block as nav2_params.yaml writes it, with a depth camera
        // beside the scanner: the keys left out at their defaults, the camera's topic its name.
        let sources = write(
            "sources.yaml",
            concat!(
                "    obstacle_layer:\n",
                "      plugin: nav2_costmap_2d::ObstacleLayer\n",
                "      enabled: True\n",
                "      observation_sources: scan camera\n",
                "      max_obstacle_height: 1.8\n",
                "      scan: {topic: /scan, max_obstacle_height: 2.0, clearing: True, marking: True, data_type: LaserScan, raytrace_max_range: 3.0}\n",
                "      camera: {data_type: PointCloud2, clearing: false, sensor_frame: camera_depth, expected_update_rate: 0.5}\n",
            ),
        );
        let o = load_parameter_file(&sources).unwrap().node.obstacle_layer;
        let (scan, camera) = (&o.sources[0], &o.sources[1]);
        assert_eq!(o.sources.len(), 2);
        assert_eq!((scan.name.as_str(), scan.topic.as_str()), ("scan", "/scan"));
        assert_eq!(
            (
                camera.name.as_str(),
                camera.topic.as_str(),
                camera.data_type
            ),
            ("camera", "camera", ObservationType::PointCloud2)
        );
        assert!(scan.clearing && camera.marking && !camera.clearing);
        assert_eq!(
            (camera.sensor_frame.as_str(), camera.expected_update_rate),
            ("camera_depth", 0.5)
        );
        let rules = camera.rules(&o);
        assert_eq!(
            (rules.max_obstacle_height, rules.layer_max_obstacle_height),
            (2.0, 1.8)
        );
        // Written back as Nav2 names them, so `ros2 param get` finds each source's keys.
        let back = serde_yaml::to_value(&o).unwrap();
        assert_eq!(back["observation_sources"], Value::from("scan camera"));
        assert_eq!(back["camera"]["topic"], Value::from("camera"));
        let again: ObstacleLayerParams = serde_yaml::from_value(back).unwrap();
        assert_eq!(again, o);
        // No sources: the layer reads nothing, as Nav2's with an empty list.
        let none = write(
            "no_sources.yaml",
            "    obstacle_layer: {observation_sources: ''}\n",
        );
        assert!(load_parameter_file(&none)
            .unwrap()
            .node
            .obstacle_layer
            .sources
            .is_empty());
        // Nav2's BinaryFilter block, as Nav2 writes it under the filter's name; its defaults
        // where not given.
        let binary = write(
            "binary.yaml",
            "    binary_filter: {filter_info_topic: /binary_filter_info, flip_threshold: 30.0}\n",
        );
        let read = load_parameter_file(&binary).unwrap().node.binary_filter;
        assert!(read.runs() && read.flip_threshold == 30.0 && !read.default_state);
        assert_eq!(read.binary_state_topic, "binary_state");
        for (name, block, key) in [
            (
                "binary_nan.yaml",
                "    binary_filter: {filter_info_topic: /i, flip_threshold: .nan}\n",
                "binary_filter: flip_threshold",
            ),
            (
                "binary_topic.yaml",
                "    binary_filter: {filter_info_topic: /i, binary_state_topic: ''}\n",
                "binary_state_topic",
            ),
            (
                "binary_typo.yaml",
                "    binary_filter: {filter_info_topc: /i}\n",
                "filter_info_topc",
            ),
            (
                "tolerance_nan.yaml",
                "    transform_tolerance: .nan\n",
                "transform_tolerance must be from 0 to 10 s",
            ),
            (
                "tolerance_long.yaml",
                "    transform_tolerance: 60.0\n",
                "transform_tolerance must be from 0 to 10 s, not 60",
            ),
        ] {
            assert_refused(name, block, key);
        }
        let bad = write("rate.yaml", "    control_rate_hz: -1.0\n");
        assert!(load_parameter_file(&bad)
            .unwrap_err()
            .to_string()
            .contains("control_rate_hz"));
        // A speed limit of 0 forbids every motion: refused as a negative one is.
        let still = write("still.yaml", "    twist_limits: {max_linear: 0.0}\n");
        assert!(load_parameter_file(&still)
            .unwrap_err()
            .to_string()
            .contains("twist_limits"));
        // Past the car's rated limits, or a follower that could never arrive: refused by name.
        for (name, block, key) in [
            (
                "fast.yaml",
                "    twist_limits: {max_linear: 25.0}\n",
                "twist_limits",
            ),
            (
                "spin.yaml",
                "    twist_limits: {max_angular: 0.41}\n",
                "twist_limits",
            ),
            (
                "never.yaml",
                "    follower: {goal_tolerance: .nan}\n",
                "follower.goal_tolerance",
            ),
            (
                "yaw.yaml",
                "    follower: {yaw_tolerance: -1.0}\n",
                "follower.yaw_tolerance",
            ),
        ] {
            assert_refused(name, block, key);
        }
        // The progress checker and the recoveries: read, and bad values refused by name.
        let ok = write(
            "recovery.yaml",
            "    progress_checker: {movement_time_allowance: 4.0}\n    recovery: {number_of_retries: 2}\n",
        );
        let node = load_parameter_file(&ok).unwrap().node;
        assert_eq!(node.progress_checker.movement_time_allowance, 4.0);
        assert_eq!(node.progress_checker.required_movement_radius, 0.5);
        assert_eq!(node.recovery.number_of_retries, 2);
        assert_eq!(node.recovery.behaviors.len(), 4);
        let only = write(
            "only_wait.yaml",
            "    recovery: {behaviors: [wait, backup], backup_dist: 0.5}\n",
        );
        let r = load_parameter_file(&only).unwrap().node.recovery;
        assert_eq!(
            r.behaviors,
            [RecoveryBehavior::Wait, RecoveryBehavior::Backup]
        );
        assert_eq!((r.backup_dist, r.backup_speed), (0.5, 0.15));
        for (name, block, key) in [
            (
                "allow.yaml",
                "    progress_checker: {movement_time_allowance: 0.0}\n",
                "progress_checker",
            ),
            (
                "radius.yaml",
                "    progress_checker: {required_movement_radius: .nan}\n",
                "progress_checker",
            ),
            (
                "retries.yaml",
                "    recovery: {number_of_retries: 1000}\n",
                "recovery",
            ),
            (
                "wait.yaml",
                "    recovery: {wait_duration: -1.0}\n",
                "recovery",
            ),
            (
                "no_behaviors.yaml",
                "    recovery: {behaviors: []}\n",
                "recovery",
            ),
            (
                "dance.yaml",
                "    recovery: {behaviors: [spin, dance]}\n",
                "dance",
            ),
            (
                "far.yaml",
                "    recovery: {backup_dist: 50.0}\n",
                "recovery",
            ),
            ("spin.yaml", "    recovery: {spin_dist: .inf}\n", "recovery"),
            (
                "ahead.yaml",
                "    behavior_server: {simulate_ahead_time: -1.0}\n",
                "behavior_server",
            ),
            (
                "local.yaml",
                "    local_costmap: {width: 0.0}\n",
                "local_costmap",
            ),
            (
                "local_wide.yaml",
                "    local_costmap: {height: 1.0e9}\n",
                "local_costmap",
            ),
            (
                "obstacle_ranges.yaml",
                "    obstacle_layer: {scan: {obstacle_min_range: 3.0, obstacle_max_range: 2.0}}\n",
                "obstacle_layer.scan: ranges",
            ),
            (
                "raytrace_far.yaml",
                "    obstacle_layer: {scan: {raytrace_max_range: 1.0e6}}\n",
                "obstacle_layer.scan",
            ),
            (
                "obstacle_heights.yaml",
                "    obstacle_layer: {min_obstacle_height: 1.0, max_obstacle_height: 0.5}\n",
                "obstacle_layer: heights",
            ),
            (
                "source_heights.yaml",
                "    obstacle_layer: {scan: {min_obstacle_height: 1.0, max_obstacle_height: 0.5}}\n",
                "obstacle_layer.scan",
            ),
            (
                "obstacle_type.yaml",
                "    obstacle_layer: {scan: {data_type: Sonar}}\n",
                "obstacle_layer.scan: unknown variant `Sonar`",
            ),
            (
                "obstacle_rate.yaml",
                "    obstacle_layer: {update_frequency: .nan}\n",
                "update_frequency",
            ),
            (
                "obstacle_unlisted.yaml",
                "    obstacle_layer: {observation_sources: scan, camera: {topic: /points}}\n",
                "`obstacle_layer.camera`: neither",
            ),
            (
                "obstacle_typo.yaml",
                "    obstacle_layer: {enabeld: true}\n",
                "`obstacle_layer.enabeld`",
            ),
            (
                "source_typo.yaml",
                "    obstacle_layer: {scan: {topci: /scan}}\n",
                "obstacle_layer.scan: unknown field `topci`",
            ),
            (
                "source_named_as_a_key.yaml",
                "    obstacle_layer: {observation_sources: scan enabled}\n",
                "`enabled`, a key of the layer's own",
            ),
            (
                "source_twice.yaml",
                "    obstacle_layer: {observation_sources: scan scan}\n",
                "names `scan` twice",
            ),
            (
                "persistence.yaml",
                "    obstacle_layer: {scan: {observation_persistence: 2.0}}\n",
                "observation_persistence: only 0",
            ),
            (
                "voxel.yaml",
                "    obstacle_layer: {plugin: nav2_costmap_2d::VoxelLayer}\n",
                "runs `nav2_costmap_2d::ObstacleLayer` only",
            ),
            (
                "teleop_step.yaml",
                "    behavior_server: {projection_time: 1.0, simulation_time_step: 1.0}\n",
                "simulation_time_step",
            ),
        ] {
            assert_refused(name, block, key);
        }
    }
}
