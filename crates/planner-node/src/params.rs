//! The node's parameters: the planning part every front end shares ([`PlannerConfig`]) plus what
//! only the node needs, read from the `patrol_planner: ros__parameters:` block of a ROS 2
//! parameter file (Nav2's layout), `config/planner.yaml` by default.

use anyhow::{Context, Result};
use chassis::follower::FollowerParams;
use chassis::limits::TwistLimits;
use planner_core::config::PlannerConfig;
use planner_core::registry;
use ros2_client::ParameterValue;
use serde::Deserialize;
use std::path::{Path, PathBuf};

#[derive(Clone, Debug, Deserialize)]
#[serde(default)]
pub struct NodeParams {
    #[serde(flatten)]
    pub planning: PlannerConfig,
    /// A map_server YAML the node loads itself and publishes on `/map` (transient local), so it
    /// works without a map server. Relative paths are relative to the parameter file. Empty: wait
    /// for `/map`.
    pub map_yaml: String,
    /// The frame plans are made in; goals must be in it (or have an empty frame).
    pub global_frame: String,
    /// The static map -> odom transform `[x, y, yaw]` applied to `/odom` poses (identity by
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
    /// Follow each goal's plan: publish `/cmd_vel` from `/odom` (regulated pure pursuit).
    pub follow_plan: bool,
    /// The chassis limits the follower keeps to, also forwarded on `/patrol_planner/twist_limits`.
    pub twist_limits: TwistLimits,
    /// The path follower.
    pub follower: FollowerParams,
    /// Publish `/cmd_vel` as geometry_msgs/TwistStamped (what Jazzy's diff_drive_controller
    /// expects; Nav2's parameter of the same name) instead of Twist.
    pub enable_stamped_cmd_vel: bool,
    /// The frame of stamped `/cmd_vel` commands (Nav2's name).
    pub robot_base_frame: String,
    /// Follower rate (Hz).
    pub control_rate_hz: f64,
    /// The follower stops when `/odom` is older than this (s).
    pub pose_timeout: f64,
}

impl Default for NodeParams {
    fn default() -> Self {
        Self {
            planning: PlannerConfig::default(),
            map_yaml: String::new(),
            global_frame: "map".into(),
            map_to_odom: [0.0; 3],
            track_map_to_odom: true,
            odom_frame: "odom".into(),
            publish_pareto: true,
            follow_plan: true,
            twist_limits: TwistLimits::default(),
            follower: FollowerParams::default(),
            enable_stamped_cmd_vel: false,
            robot_base_frame: "base_link".into(),
            control_rate_hz: 20.0,
            pose_timeout: 0.5,
        }
    }
}

impl NodeParams {
    /// Loads and validates a parameter file; resolves `map_yaml` against its folder.
    pub fn load(path: &Path) -> Result<Self> {
        let block = planner_io::load_ros_parameters(path, "patrol_planner")?;
        let mut params: NodeParams = serde_yaml::from_value(block)
            .with_context(|| format!("{}: patrol_planner parameters", path.display()))?;
        params
            .planning
            .validate()
            .with_context(|| format!("{}", path.display()))?;
        if !params.map_yaml.is_empty() {
            let p = PathBuf::from(&params.map_yaml);
            if p.is_relative() {
                params.map_yaml = path
                    .parent()
                    .unwrap_or(Path::new("."))
                    .join(p)
                    .to_string_lossy()
                    .into_owned();
            }
        }
        let positive = |v: f64| v.is_finite() && v > 0.0;
        if !params.twist_limits.is_valid()
            || !positive(params.control_rate_hz)
            || params.control_rate_hz > 200.0
            || !positive(params.pose_timeout)
        {
            anyhow::bail!(
                "{}: twist_limits, control_rate_hz and pose_timeout must be finite and positive",
                path.display()
            );
        }
        if !params.map_to_odom.iter().all(|v| v.is_finite()) {
            anyhow::bail!("{}: map_to_odom must be finite", path.display());
        }
        Ok(params)
    }
}

/// Checks a parameter value before ros2-client stores it; the reason goes back to `ros2 param set`.
pub fn validate_parameter(name: &str, value: &ParameterValue) -> Result<(), String> {
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
