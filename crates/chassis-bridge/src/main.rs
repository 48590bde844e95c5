//! `chassis_bridge`: the ROS 2 edge of the chassis. Subscribes `/cmd_vel` (geometry_msgs/Twist,
//! or TwistStamped with `enable_stamped_cmd_vel`, as Jazzy's diff_drive_controller takes it) and
//! `/patrol_planner/twist_limits`; clamps every command (the chassis crate's limits.rs) and stops
//! when commands stop (its watchdog.rs); publishes the wheel speeds on `/wheel_cmd`
//! (std_msgs/Float64MultiArray, [left, right] in rad/s) and sends them to the chassis back end
//! (chassis.rs): `sim`, the simulated car, or `serial`, a motor controller on a serial line
//! (serial.rs). Either way the odometry comes back on `/odom` (nav_msgs/Odometry, odom ->
//! base_link) and, with `publish_tf`, as the odom -> base_link transform on `/tf`, as
//! diff_drive_controller publishes it. Those are the names in the root namespace: the node's
//! name, namespace and topics take `-r` rules as patrol_planner's do (`-r __ns:=/robot1` puts
//! every topic but `/tf` under `/robot1`).
//!
//! A serial controller that cannot be opened, goes away or stops reporting is logged and retried;
//! `/odom` pauses meanwhile (so the planner's follower stops on stale odometry) and the bridge
//! keeps serving.
//!
//! Usage: `chassis_bridge [--params-file FILE] [--ros-args [-r __node:=NAME] [--params-file FILE]
//! [-p [NODE:]NAME:=VALUE] ...]` (default `config/chassis.yaml` if present and no file is given).
//! Every file and `-p` applies, as rclcpp applies them (ros-parameters: `/**` values, then the
//! node's own over them): launch_ros' `parameters=[chassis.yaml, {...}]` is read whole. The
//! node's block (`chassis_bridge: ros__parameters:`, or its remapped name's) is read strictly: an
//! unknown key, at the top or in a section, is an error naming it and the sources; a `/**`
//! block's keys the bridge does not have are other nodes' (`use_sim_time`), passed over with a
//! warning.

use anyhow::{anyhow, bail, Result};
use chassis::kinematics::DiffDrive;
use chassis::limits::TwistLimits;
use chassis::watchdog::{Verdict, Watchdog};
use chassis::{Pose, Twist2};
use chassis_bridge::chassis::{Chassis, ChassisError, Odometry2, SimChassis};
use chassis_bridge::serial::{SerialChassis, SerialConfig};
use log::{error, info, warn};
use patrol_msgs::geometry_msgs::{
    Point, Pose as PoseMsg, PoseWithCovariance, Transform, TransformStamped, Twist, TwistStamped,
    TwistWithCovariance, Vector3,
};
use patrol_msgs::nav_msgs::Odometry;
use patrol_msgs::std_msgs::{Float64MultiArray, Header, MultiArrayDimension, MultiArrayLayout};
use patrol_msgs::tf2_msgs::TFMessage;
use ros2_client::{
    qos::{Durability, History},
    MessageTypeName, NodeName, NodeOptions, QosProfile, Subscription,
};
use ros_edge::command_line::CommandLine;
use ros_edge::naming::Naming;
use ros_edge::parameter_values::{flatten, read_only_answer};
use serde::{Deserialize, Serialize};
use std::path::Path;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
enum Backend {
    Sim,
    Serial,
}

/// The `chassis_bridge: ros__parameters:` block. Unknown keys are refused here and in every
/// section (limits, drive, serial, serial.encoders), so a typo is an error, not a default.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
struct Params {
    backend: Backend,
    enable_stamped_cmd_vel: bool,
    cmd_timeout: f64,
    rate_hz: f64,
    limits: TwistLimits,
    drive: DiffDrive,
    initial_pose: [f64; 3],
    odom_frame: String,
    base_frame: String,
    publish_tf: bool,
    serial: SerialConfig,
    feedback_timeout: f64,
    reconnect_interval: f64,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            backend: Backend::Sim,
            enable_stamped_cmd_vel: false,
            cmd_timeout: 0.5,
            rate_hz: 50.0,
            limits: TwistLimits::default(),
            drive: DiffDrive::default(),
            initial_pose: [0.1, 0.1, 0.0],
            odom_frame: "odom".into(),
            base_frame: "base_link".into(),
            publish_tf: true,
            serial: SerialConfig::default(),
            feedback_timeout: 0.5,
            reconnect_interval: 1.0,
        }
    }
}

/// The parameters and the names the command line gives.
fn load() -> Result<(Params, Naming)> {
    let line = CommandLine::from_env("chassis_bridge").map_err(|e| anyhow!("command line: {e}"))?;
    let (params, warnings) = parameters(&line, Path::new("config/chassis.yaml"))?;
    for warning in warnings {
        warn!("{warning}");
    }
    check(&params)?;
    Ok((params, line.naming))
}

/// The bridge's topics as written, resolved through the command line's names as the node's are
/// (ros_edge::naming): relative ones inside the namespace, so that `-r __ns:=/robot1` gives
/// `/robot1/cmd_vel` and each robot of a fleet has its own; `/tf` absolute, as tf2 has it
/// (remap `/tf:=tf` for a namespaced tree). The planner forwards its limits on its private
/// `~/twist_limits`: `patrol_planner/twist_limits` here (remap it when the planner is renamed).
const CMD_VEL: &str = "cmd_vel";
const TWIST_LIMITS: &str = "patrol_planner/twist_limits";
const WHEEL_CMD: &str = "wheel_cmd";
const ODOM: &str = "odom";
const TF: &str = "/tf";

/// The parameters `line` gives (`default` first when it names no file and exists), with what
/// was read past.
fn parameters(line: &CommandLine, default: &Path) -> Result<(Params, Vec<String>)> {
    let sources = line.parameter_sources(default);
    for source in &sources {
        info!("{source}");
    }
    let full = line.naming.node_path();
    // The node's fully qualified name, its plain name, rclcpp's wildcard, and the bundled
    // file's block under a remapped name.
    let names = [
        full.as_str(),
        line.naming.node.as_str(),
        ros_parameters::WILDCARD,
        "chassis_bridge",
    ];
    Ok(ros_parameters::read(&sources, &names)?)
}

/// The longest `cmd_timeout` and `feedback_timeout` (s): the car stops when commands (or the
/// board's feedback) stop, and at 0.6 m/s it drives 1.2 m in this time.
const MAX_TIMEOUT: f64 = 2.0;

/// A parameter file's values: the limits no looser than the car's rated ones, the timeouts
/// short enough that the car does stop when commands stop, the geometry positive.
fn check(params: &Params) -> Result<()> {
    let within = |v: f64, lo: f64, hi: f64| v > lo && v <= hi;
    params
        .limits
        .check_rated("limits")
        .map_err(anyhow::Error::msg)?;
    if !within(params.cmd_timeout, 0.0, MAX_TIMEOUT)
        || !within(params.feedback_timeout, 0.0, MAX_TIMEOUT)
        || !within(params.reconnect_interval, 0.0, 60.0)
        || !within(params.rate_hz, 0.0, 1000.0)
    {
        bail!("cmd_timeout and feedback_timeout must be within (0, {MAX_TIMEOUT}] s, reconnect_interval within (0, 60] s, rate_hz within (0, 1000]");
    }
    let positive = |v: f64| v.is_finite() && v > 0.0;
    if !positive(params.drive.wheel_radius) || !positive(params.drive.wheel_separation) {
        bail!("wheel_radius and wheel_separation must be positive");
    }
    let enc = &params.serial.encoders;
    if !positive(enc.ticks_per_rev) || !positive(enc.max_wheel_speed) {
        bail!("serial.encoders: ticks_per_rev and max_wheel_speed must be positive");
    }
    if params.initial_pose.iter().any(|v| !v.is_finite()) {
        bail!("initial_pose must be finite");
    }
    Ok(())
}

fn main() -> std::process::ExitCode {
    ros_edge::logging::init(&["chassis_bridge"]);
    let result = load().and_then(|(p, naming)| ros_edge::run_ros(run(p, naming)));
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            log::error!("{e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

/// The back end, and when to try opening it again after it failed.
struct Link {
    chassis: Option<Box<dyn Chassis + Send>>,
    retry_at: Instant,
    /// An outage is logged once when it starts and once when it ends, not every retry.
    outage_logged: bool,
    last_odometry: Instant,
    feedback_lost: bool,
}

impl Link {
    fn open(p: &Params, start: Pose) -> Result<Box<dyn Chassis + Send>, ChassisError> {
        Ok(match p.backend {
            Backend::Sim => Box::new(SimChassis::new(p.drive, start)),
            Backend::Serial => Box::new(SerialChassis::open(&p.serial, p.drive, start)?),
        })
    }

    /// Drives the wheels for one period; the odometry when there is news.
    fn drive(
        &mut self,
        p: &Params,
        left: f64,
        right: f64,
        dt: f64,
        pose: Pose,
    ) -> Option<Odometry2> {
        let now = Instant::now();
        if self.chassis.is_none() && now >= self.retry_at {
            match Self::open(p, pose) {
                Ok(c) => {
                    if self.outage_logged {
                        info!("{}: open again", p.serial.device);
                    }
                    self.outage_logged = false;
                    self.last_odometry = now;
                    self.chassis = Some(c);
                }
                Err(e) => {
                    if !self.outage_logged {
                        error!(
                            "{e}; retrying every {} s, /odom paused",
                            p.reconnect_interval
                        );
                        self.outage_logged = true;
                    }
                    self.retry_at = now + Duration::from_secs_f64(p.reconnect_interval);
                }
            }
        }
        let chassis = self.chassis.as_mut()?;
        let result = chassis.drive(left, right, dt);
        for w in chassis.take_warnings() {
            warn!("{w}");
        }
        match result {
            Ok(Some(odo)) => {
                if self.feedback_lost {
                    info!("odometry from the chassis again");
                    self.feedback_lost = false;
                }
                self.last_odometry = now;
                Some(odo)
            }
            Ok(None) => {
                let silent = now.duration_since(self.last_odometry).as_secs_f64();
                if silent > p.feedback_timeout && !self.feedback_lost {
                    warn!("no odometry from the chassis for {silent:.2} s: /odom paused");
                    self.feedback_lost = true;
                }
                None
            }
            Err(e) => {
                error!(
                    "{e}; reopening every {} s, /odom paused",
                    p.reconnect_interval
                );
                self.outage_logged = true;
                self.chassis = None;
                self.retry_at = now + Duration::from_secs_f64(p.reconnect_interval);
                None
            }
        }
    }
}

async fn run(p: Params, naming: Naming) -> Result<()> {
    let mut signals = ros_edge::ShutdownSignals::new()?;
    let (context, domain) = ros_edge::context()?;
    // Every parameter as ROS parameters, read-only: `ros2 param get` and `ros2 param dump`
    // show what the bridge runs with; a `ros2 param set` to another value is refused with the
    // way to change it (the limits and the watchdog are checked at start, not while the car
    // drives). The value it holds is accepted, as declaring it passes through here too.
    let values = flatten(&p);
    let held = values.clone();
    let mut options = NodeOptions::new()
        .enable_rosout(true)
        .parameter_validator(Box::new(move |name, value| {
            read_only_answer(&held, name, value, "the bridge").unwrap_or(Ok(()))
        }));
    for (name, value) in values {
        options = options.declare_parameter(&name, value);
    }
    let mut node = context.new_node(NodeName::new(&naming.namespace, &naming.node)?, options)?;
    let spinner = tokio::spawn(node.spinner()?.spin());
    ros_edge::logging::forward_to_rosout(node.logging_handle());
    // Every task holding a DDS reader or writer, so that shutdown can end them before the
    // node and its participant go (otherwise RustDDS logs an error for each endpoint).
    let mut tasks = tokio::task::JoinSet::new();
    let best_effort = QosProfile::subscription_default().history(History::KeepLast { depth: 1 });
    let volatile = ros_edge::reliable(10, Durability::Volatile);
    let latched = ros_edge::reliable(1, Durability::TransientLocal);

    // The latest command (and whether one arrived since the last tick), and the forwarded limits.
    let latest: Arc<Mutex<(Twist2, bool)>> = Arc::new(Mutex::new((Twist2::STOP, false)));
    // /cmd_vel as TwistStamped (Jazzy's diff_drive_controller) or Twist: same handling after.
    let (cmd_type, stamped) = if p.enable_stamped_cmd_vel {
        ("TwistStamped", true)
    } else {
        ("Twist", false)
    };
    let cmd_topic = node.create_topic(
        &naming.name(CMD_VEL)?,
        MessageTypeName::new("geometry_msgs", cmd_type),
        &volatile,
    )?;
    if stamped {
        let sub =
            node.create_subscription::<TwistStamped>(&cmd_topic, Some(best_effort.clone()))?;
        tasks.spawn(keep_latest(sub, latest.clone(), |t| t.twist));
    } else {
        let sub = node.create_subscription::<Twist>(&cmd_topic, Some(best_effort.clone()))?;
        tasks.spawn(keep_latest(sub, latest.clone(), |t| t));
    }
    let lim_topic = node.create_topic(
        &naming.name(TWIST_LIMITS)?,
        MessageTypeName::new("geometry_msgs", "Twist"),
        &latched,
    )?;
    let lim_sub = node.create_subscription::<Twist>(&lim_topic, Some(latched))?;
    let wheel_topic = node.create_topic(
        &naming.name(WHEEL_CMD)?,
        MessageTypeName::new("std_msgs", "Float64MultiArray"),
        &volatile,
    )?;
    let wheel_pub =
        node.create_publisher::<Float64MultiArray>(&wheel_topic, Some(volatile.clone()))?;
    let odom_topic = node.create_topic(
        &naming.name(ODOM)?,
        MessageTypeName::new("nav_msgs", "Odometry"),
        &volatile,
    )?;
    let odom_pub = node.create_publisher::<Odometry>(&odom_topic, Some(volatile.clone()))?;
    // tf2's own QoS for /tf: reliable, volatile, depth 100.
    let tf_qos = ros_edge::reliable(100, Durability::Volatile);
    let tf_pub = if p.publish_tf {
        let topic = node.create_topic(
            &naming.name(TF)?,
            MessageTypeName::new("tf2_msgs", "TFMessage"),
            &tf_qos,
        )?;
        Some(node.create_publisher::<TFMessage>(&topic, Some(tf_qos.clone()))?)
    } else {
        None
    };

    let forwarded: Arc<Mutex<Option<TwistLimits>>> = Arc::new(Mutex::new(None));
    let f = forwarded.clone();
    tasks.spawn(async move {
        loop {
            if let Ok((t, _)) = lim_sub.async_take().await {
                let lim = TwistLimits {
                    max_linear: t.linear.x,
                    max_angular: t.angular.z,
                    max_linear_accel: f64::NAN,
                    max_angular_accel: f64::NAN,
                };
                info!(
                    "forwarded limits: {} m/s, {} rad/s",
                    t.linear.x, t.angular.z
                );
                *f.lock().expect("lock") = Some(lim);
            }
        }
    });

    let dt = 1.0 / p.rate_hz;
    let mut watchdog = Watchdog::new(p.cmd_timeout);
    let [x, y, yaw] = p.initial_pose;
    let mut pose = Pose { x, y, yaw };
    let mut link = Link {
        chassis: None,
        retry_at: Instant::now(),
        outage_logged: false,
        last_odometry: Instant::now(),
        feedback_lost: false,
    };
    // The last command sent, for the acceleration limits.
    let mut sent = Twist2::STOP;
    let mut ticker = tokio::time::interval(Duration::from_secs_f64(dt));
    info!(
        "{} ({}) on ROS_DOMAIN_ID {domain}: {} Hz, timeout {} s, {} as {}",
        naming.node_path(),
        match p.backend {
            Backend::Sim => "sim".to_string(),
            Backend::Serial => format!("serial {}", p.serial.device),
        },
        p.rate_hz,
        p.cmd_timeout,
        naming.resolve(CMD_VEL),
        if p.enable_stamped_cmd_vel {
            "TwistStamped"
        } else {
            "Twist"
        }
    );
    loop {
        tokio::select! {
            _ = ticker.tick() => {}
            name = signals.recv() => {
                info!("{name}: shutting down");
                break;
            }
        }
        let (cmd, fresh) = {
            let mut g = latest.lock().expect("lock");
            let v = *g;
            g.1 = false;
            v
        };
        if fresh {
            watchdog.feed();
        }
        let limits = match *forwarded.lock().expect("lock") {
            Some(f) => p.limits.tighter(&f),
            None => p.limits,
        };
        // Fresh commands are clamped and ramped; a tripped watchdog stops the wheels at once.
        sent = match watchdog.tick(dt) {
            Verdict::Drive => limits.apply(cmd, sent, dt),
            Verdict::JustTripped => {
                warn!("no /cmd_vel for {} s: wheels to zero", p.cmd_timeout);
                Twist2::STOP
            }
            Verdict::Stopped => Twist2::STOP,
        };
        let (left, right) = p.drive.wheel_speeds(sent);
        if let Err(e) = wheel_pub.async_publish(wheel_msg(left, right)).await {
            warn!("/wheel_cmd: {e:?}");
        }
        if let Some(odo) = link.drive(&p, left, right, dt, pose) {
            pose = odo.pose;
            let odom = odom_msg(&p, odo);
            if let Some(tf_pub) = &tf_pub {
                if let Err(e) = tf_pub.async_publish(tf_msg(&odom)).await {
                    warn!("/tf: {e:?}");
                }
            }
            if let Err(e) = odom_pub.async_publish(odom).await {
                warn!("/odom: {e:?}");
            }
        }
    }
    info!("chassis_bridge stopping: wheels to zero");
    let _ = wheel_pub.async_publish(wheel_msg(0.0, 0.0)).await;
    if let Some(chassis) = link.chassis.as_mut() {
        if let Err(e) = chassis.stop() {
            error!("stopping the chassis: {e}");
        }
    }
    ros_edge::logging::stop_forwarding();
    tasks.shutdown().await;
    // Dropping the node stops its spinner, which holds the node's own endpoints (parameter
    // services, rosout); they must go before the participant does, when `context` drops.
    drop(node);
    let _ = spinner.await;
    Ok(())
}

/// Keeps the newest command from `sub` in `latest` (flagged fresh for the watchdog).
async fn keep_latest<M: 'static + serde::de::DeserializeOwned>(
    sub: Subscription<M>,
    latest: Arc<Mutex<(Twist2, bool)>>,
    twist: fn(M) -> Twist,
) {
    loop {
        if let Ok((m, _)) = sub.async_take().await {
            let t = twist(m);
            *latest.lock().expect("lock") = (Twist2::new(t.linear.x, t.angular.z), true);
        }
    }
}

fn wheel_msg(left: f64, right: f64) -> Float64MultiArray {
    Float64MultiArray {
        layout: MultiArrayLayout {
            dim: vec![MultiArrayDimension {
                label: "left_right_rad_s".into(),
                size: 2,
                stride: 2,
            }],
            data_offset: 0,
        },
        data: vec![left, right],
    }
}

fn odom_msg(p: &Params, odo: Odometry2) -> Odometry {
    let Odometry2 { pose, twist } = odo;
    Odometry {
        header: Header {
            stamp: ros_edge::now(),
            frame_id: p.odom_frame.clone(),
        },
        child_frame_id: p.base_frame.clone(),
        pose: PoseWithCovariance {
            pose: PoseMsg {
                position: Point {
                    x: pose.x,
                    y: pose.y,
                    z: 0.0,
                },
                orientation: ros_edge::quaternion_from_yaw(pose.yaw),
            },
            ..Default::default()
        },
        twist: TwistWithCovariance {
            twist: Twist {
                linear: Vector3 {
                    x: twist.linear,
                    y: 0.0,
                    z: 0.0,
                },
                angular: Vector3 {
                    x: 0.0,
                    y: 0.0,
                    z: twist.angular,
                },
            },
            ..Default::default()
        },
    }
}

/// The odom -> base_link transform of an odometry message (same stamp, same pose).
fn tf_msg(odom: &Odometry) -> TFMessage {
    let pose = odom.pose.pose;
    TFMessage {
        transforms: vec![TransformStamped {
            header: odom.header.clone(),
            child_frame_id: odom.child_frame_id.clone(),
            transform: Transform {
                translation: Vector3 {
                    x: pose.position.x,
                    y: pose.position.y,
                    z: pose.position.z,
                },
                rotation: pose.orientation,
            },
        }],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::{Path, PathBuf};

    /// Without rules, the names one robot has always had; under `-r __ns:=/robot1` every topic
    /// but /tf is that robot's own, and a remap renames the planner's limits topic.
    #[test]
    fn topics_follow_the_command_lines_names() {
        let resolve = |args: &str| {
            let line =
                CommandLine::from_args(args.split_whitespace().map(String::from), "chassis_bridge")
                    .unwrap();
            [CMD_VEL, TWIST_LIMITS, WHEEL_CMD, ODOM, TF].map(|t| line.naming.resolve(t))
        };
        assert_eq!(
            resolve(""),
            [
                "/cmd_vel",
                "/patrol_planner/twist_limits",
                "/wheel_cmd",
                "/odom",
                "/tf"
            ]
        );
        assert_eq!(
            resolve("--ros-args -r __ns:=/robot1 -r patrol_planner/twist_limits:=planner_server/twist_limits"),
            [
                "/robot1/cmd_vel",
                "/robot1/planner_server/twist_limits",
                "/robot1/wheel_cmd",
                "/robot1/odom",
                "/tf"
            ]
        );
    }

    /// A parameter file of `text` in the temporary folder (the caller removes it).
    fn temp_file(name: &str, text: &str) -> PathBuf {
        let path =
            std::env::temp_dir().join(format!("chassis-bridge-{name}-{}.yaml", std::process::id()));
        std::fs::write(&path, text).unwrap();
        path
    }

    fn bundled() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/chassis.yaml")
    }

    /// The parameters of a command line (`args` split at spaces), with the bundled file as the
    /// default.
    fn parameters_of(args: &str) -> Result<(Params, Vec<String>)> {
        let line =
            CommandLine::from_args(args.split_whitespace().map(String::from), "chassis_bridge")
                .map_err(anyhow::Error::msg)?;
        parameters(&line, &bundled())
    }

    #[test]
    fn the_bundled_config_is_the_built_in_default() {
        let (p, warnings) = parameters_of("").unwrap();
        assert_eq!(p, Params::default());
        assert!(warnings.is_empty(), "{warnings:?}");
    }

    /// As a launch starts the bridge: the bundled file, a dict's file of `/**` values and `-p`
    /// rules, each applied with rclcpp's precedence (the node's own values over `/**` ones);
    /// under a remapped name, that name's rules. Before, only the first file was read.
    #[test]
    fn every_file_and_rule_applies_as_rclcpp_applies_them() {
        let dict = temp_file(
            "dict",
            "/**:\n  ros__parameters:\n    use_sim_time: true\n    rate_hz: 99.0\n    limits: {max_angular: 0.3}\n",
        );
        let args = format!(
            "--params-file {} --ros-args --params-file {} -p chassis_bridge:cmd_timeout:=0.25 \
             -p publish_tf:=false -p other:backend:=serial",
            bundled().display(),
            dict.display()
        );
        let result = parameters_of(&args);
        let _ = std::fs::remove_file(&dict);
        let (p, warnings) = result.unwrap();
        assert_eq!(p.cmd_timeout, 0.25, "the node's own rule");
        assert_eq!(
            p.rate_hz, 50.0,
            "the bundled block's over the later `/**` file's"
        );
        assert_eq!(
            p.limits.max_angular, 0.4,
            "the block's limits over the `/**` section's"
        );
        assert!(p.publish_tf, "a plain rule under the block's value");
        assert_eq!(p.backend, Backend::Sim, "another node's rule");
        let said = warnings.join("\n");
        assert!(said.contains("ignored `/**` key `use_sim_time`"), "{said}");
        assert!(
            said.contains("`-p publish_tf:=false` does nothing"),
            "{said}"
        );
        assert!(
            said.contains("`-p other:backend:=serial` is for another node"),
            "{said}"
        );
        // Remapped: the bundled `chassis_bridge:` block still read, the new name's rules apply.
        let (p, _) = parameters_of(
            "--ros-args -r __node:=base -p base:rate_hz:=20.0 -p chassis_bridge_x:rate_hz:=1.0",
        )
        .unwrap();
        assert_eq!((p.rate_hz, p.cmd_timeout), (20.0, 0.5));
        // An unknown key from a rule is refused naming the rule.
        let e = parameters_of("--ros-args -p limits.max_linar:=0.3")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("unknown field `max_linar`")
                && e.contains("set by `-p limits.max_linar:=0.3`"),
            "{e}"
        );
    }

    #[test]
    fn a_typo_at_the_top_of_the_block_is_refused_naming_the_key_and_the_file() {
        let path = temp_file(
            "typo",
            "chassis_bridge:\n  ros__parameters:\n    backnd: serial\n",
        );
        let result = parameters_of(&format!("--params-file {}", path.display()));
        let _ = std::fs::remove_file(&path);
        let message = result.unwrap_err().to_string();
        assert!(
            message.starts_with(&path.display().to_string())
                && message.contains("unknown field `backnd`"),
            "{message}"
        );
    }

    #[test]
    fn the_transform_is_the_odometry_pose() {
        let p = Params::default();
        let odo = Odometry2 {
            pose: Pose {
                x: 1.5,
                y: -2.0,
                yaw: 0.7,
            },
            twist: Twist2::new(0.3, 0.1),
        };
        let odom = odom_msg(&p, odo);
        let tf = tf_msg(&odom);
        let t = &tf.transforms[0];
        assert_eq!(
            (t.header.frame_id.as_str(), t.child_frame_id.as_str()),
            ("odom", "base_link")
        );
        assert_eq!(t.header.stamp, odom.header.stamp);
        assert_eq!(
            (t.transform.translation.x, t.transform.translation.y),
            (1.5, -2.0)
        );
        let q = t.transform.rotation;
        assert!((2.0 * q.z.atan2(q.w) - 0.7).abs() < 1e-12);
    }
}
