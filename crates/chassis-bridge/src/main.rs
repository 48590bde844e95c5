//! `chassis_bridge`: the ROS 2 edge of the chassis. Subscribes `/cmd_vel` (geometry_msgs/Twist)
//! and `/patrol_planner/twist_limits`; clamps every command (limits.rs) and stops when commands
//! stop (watchdog.rs); publishes the wheel speeds on `/wheel_cmd` (std_msgs/Float64MultiArray,
//! [left, right] in rad/s); with the `sim` back end it drives the simulated chassis (sim.rs) and
//! publishes `/odom` (nav_msgs/Odometry, odom -> base_link).
//!
//! Usage: `chassis_bridge [--params-file FILE]` (default `config/chassis.yaml` if present).

use anyhow::{bail, Context as _, Result};
use chassis_bridge::kinematics::DiffDrive;
use chassis_bridge::limits::TwistLimits;
use chassis_bridge::sim::{Pose, Unicycle};
use chassis_bridge::watchdog::{Verdict, Watchdog};
use chassis_bridge::Twist2;
use log::{info, warn};
use patrol_msgs::geometry_msgs::{
    Point, Pose as PoseMsg, PoseWithCovariance, Quaternion, Twist, TwistWithCovariance, Vector3,
};
use patrol_msgs::nav_msgs::Odometry;
use patrol_msgs::std_msgs::{Float64MultiArray, Header, MultiArrayDimension, MultiArrayLayout};
use ros2_client::{
    qos::{Durability, History},
    MessageTypeName, Name, NodeName, NodeOptions, QosProfile,
};
use serde::Deserialize;
use std::sync::{Arc, Mutex};
use std::time::Duration;

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
struct Params {
    backend: String,
    cmd_timeout: f64,
    rate_hz: f64,
    limits: TwistLimits,
    drive: DiffDrive,
    initial_pose: [f64; 3],
    odom_frame: String,
    base_frame: String,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            backend: "sim".into(),
            cmd_timeout: 0.5,
            rate_hz: 50.0,
            limits: TwistLimits::default(),
            drive: DiffDrive::default(),
            initial_pose: [0.1, 0.1, 0.0],
            odom_frame: "odom".into(),
            base_frame: "base_link".into(),
        }
    }
}

fn load() -> Result<Params> {
    let (path, explicit) = ros_edge::params_file("config/chassis.yaml");
    let params: Params = if explicit || path.exists() {
        let block = planner_io::load_ros_parameters(&path, "chassis_bridge")?;
        serde_yaml::from_value(block)
            .with_context(|| format!("{}: chassis_bridge parameters", path.display()))?
    } else {
        Params::default()
    };
    if params.backend != "sim" {
        bail!(
            "backend `{}` is not available: only `sim` is implemented",
            params.backend
        );
    }
    let positive = |v: f64| v.is_finite() && v > 0.0;
    if !params.limits.is_valid()
        || !positive(params.cmd_timeout)
        || !positive(params.rate_hz)
        || params.rate_hz > 1000.0
    {
        bail!("limits, cmd_timeout and rate_hz (at most 1000) must be finite and positive");
    }
    if !positive(params.drive.wheel_radius) || !positive(params.drive.wheel_separation) {
        bail!("wheel_radius and wheel_separation must be positive");
    }
    Ok(params)
}

fn main() -> std::process::ExitCode {
    ros_edge::logging::init(&["chassis_bridge"]);
    let result = load().and_then(|p| ros_edge::run_ros(run(p)));
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            log::error!("{e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

async fn run(p: Params) -> Result<()> {
    let (context, domain) = ros_edge::context()?;
    let mut node = context.new_node(
        NodeName::new("/", "chassis_bridge")?,
        NodeOptions::new().enable_rosout(true),
    )?;
    let spinner = tokio::spawn(node.spinner()?.spin());
    // Every task holding a DDS reader or writer, so that shutdown can end them before the
    // node and its participant go (otherwise RustDDS logs an error for each endpoint).
    let mut tasks = tokio::task::JoinSet::new();
    ros_edge::logging::forward_to_rosout(node.logging_handle());
    let best_effort = QosProfile::subscription_default().history(History::KeepLast { depth: 1 });
    let volatile = ros_edge::reliable(10, Durability::Volatile);
    let latched = ros_edge::reliable(1, Durability::TransientLocal);
    let cmd_topic = node.create_topic(
        &Name::new("/", "cmd_vel")?,
        MessageTypeName::new("geometry_msgs", "Twist"),
        &volatile,
    )?;
    let cmd_sub = node.create_subscription::<Twist>(&cmd_topic, Some(best_effort))?;
    let lim_topic = node.create_topic(
        &Name::new("/patrol_planner", "twist_limits")?,
        MessageTypeName::new("geometry_msgs", "Twist"),
        &latched,
    )?;
    let lim_sub = node.create_subscription::<Twist>(&lim_topic, Some(latched))?;
    let wheel_topic = node.create_topic(
        &Name::new("/", "wheel_cmd")?,
        MessageTypeName::new("std_msgs", "Float64MultiArray"),
        &volatile,
    )?;
    let wheel_pub =
        node.create_publisher::<Float64MultiArray>(&wheel_topic, Some(volatile.clone()))?;
    let odom_topic = node.create_topic(
        &Name::new("/", "odom")?,
        MessageTypeName::new("nav_msgs", "Odometry"),
        &volatile,
    )?;
    let odom_pub = node.create_publisher::<Odometry>(&odom_topic, Some(volatile.clone()))?;

    // The latest command (and whether one arrived since the last tick), and the forwarded limits.
    let latest: Arc<Mutex<(Twist2, bool)>> = Arc::new(Mutex::new((Twist2::STOP, false)));
    let forwarded: Arc<Mutex<Option<TwistLimits>>> = Arc::new(Mutex::new(None));
    let l = latest.clone();
    tasks.spawn(async move {
        loop {
            if let Ok((t, _)) = cmd_sub.async_take().await {
                *l.lock().expect("lock") = (Twist2::new(t.linear.x, t.angular.z), true);
            }
        }
    });
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
    let mut car = Unicycle::new(Pose { x, y, yaw });
    let mut ticker = tokio::time::interval(Duration::from_secs_f64(dt));
    let mut term = tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate())?;
    info!(
        "chassis_bridge (sim) on ROS_DOMAIN_ID {domain}: {} Hz, timeout {} s",
        p.rate_hz, p.cmd_timeout
    );
    loop {
        tokio::select! {
            _ = ticker.tick() => {}
            _ = tokio::signal::ctrl_c() => break,
            _ = term.recv() => break,
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
        let twist = match watchdog.tick(dt) {
            Verdict::Drive => limits.apply(cmd, car.twist, dt),
            Verdict::JustTripped => {
                warn!("no /cmd_vel for {} s: wheels to zero", p.cmd_timeout);
                Twist2::STOP
            }
            Verdict::Stopped => Twist2::STOP,
        };
        let (left, right) = p.drive.wheel_speeds(twist);
        let wheels = Float64MultiArray {
            layout: MultiArrayLayout {
                dim: vec![MultiArrayDimension {
                    label: "left_right_rad_s".into(),
                    size: 2,
                    stride: 2,
                }],
                data_offset: 0,
            },
            data: vec![left, right],
        };
        if let Err(e) = wheel_pub.async_publish(wheels).await {
            warn!("/wheel_cmd: {e:?}");
        }
        car.step(twist, dt);
        let pose = car.pose;
        let odom = Odometry {
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
                    orientation: Quaternion {
                        x: 0.0,
                        y: 0.0,
                        z: (pose.yaw / 2.0).sin(),
                        w: (pose.yaw / 2.0).cos(),
                    },
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
        };
        if let Err(e) = odom_pub.async_publish(odom).await {
            warn!("/odom: {e:?}");
        }
    }
    info!("chassis_bridge stopping: wheels to zero");
    let _ = wheel_pub
        .async_publish(Float64MultiArray {
            layout: MultiArrayLayout::default(),
            data: vec![0.0, 0.0],
        })
        .await;
    ros_edge::logging::stop_forwarding();
    tasks.shutdown().await;
    // Dropping the node stops its spinner, which holds the node's own endpoints (parameter
    // services, rosout); they must go before the participant does, when `context` drops.
    drop(node);
    let _ = spinner.await;
    Ok(())
}
