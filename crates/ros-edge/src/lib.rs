//! What every patrol-planner ROS 2 binary (the node, the chassis bridge) does at its edge, written
//! once: a DDS context on the user's `ROS_DOMAIN_ID`, the command line (`command_line`: names,
//! parameter files, `-p` overrides), header stamps from the system clock (or `/clock`, with
//! `use_sim_time`), SIGINT and SIGTERM, the reliable QoS profile set explicitly on every topic
//! (ros2-client's defaults differ from rclpy's), logging to the terminal and `/rosout`, serving
//! a ROS 2 service (`service`), and a parameter struct as ROS parameters (`parameter_values`). The parameters the command line names are read by the
//! ros-parameters crate.

pub mod command_line;
pub mod logging;
pub mod naming;
pub mod parameter_values;
pub mod service;

use anyhow::{Context as _, Result};
use patrol_msgs::builtin_interfaces::Time;
use patrol_msgs::geometry_msgs::Quaternion;
use ros2_client::qos::{Durability, History, WhenFull};
use ros2_client::{Context, ContextOptions, QosProfile};
use std::future::Future;
use std::sync::atomic::{AtomicBool, AtomicI64, Ordering};
use std::time::{SystemTime, UNIX_EPOCH};
use tokio::signal::unix::{signal, Signal, SignalKind};

/// The domain from `ROS_DOMAIN_ID` (0 when unset or empty), as every ROS 2 node reads it;
/// ros2-client would otherwise always start on domain 0.
pub fn domain_id() -> Result<u16> {
    match std::env::var("ROS_DOMAIN_ID") {
        Ok(v) if !v.trim().is_empty() => v
            .trim()
            .parse::<u16>()
            .with_context(|| format!("ROS_DOMAIN_ID `{v}` is not a number")),
        _ => Ok(0),
    }
}

/// A DDS context on [`domain_id`], and that domain.
pub fn context() -> Result<(Context, u16)> {
    let domain = domain_id()?;
    let context =
        Context::with_options(ContextOptions::new().domain_id(domain)).context("starting DDS")?;
    Ok((context, domain))
}

/// Whether header stamps come from `/clock` ([`use_sim_time`]) instead of the system clock.
static SIM_TIME: AtomicBool = AtomicBool::new(false);
/// The latest `/clock` time, in nanoseconds since its epoch (0 until the first arrives).
static SIM_NANOS: AtomicI64 = AtomicI64::new(0);

/// From now on, stamps are the simulation's time (the latest [`set_sim_time`]), as a ROS 2
/// node with `use_sim_time` stamps them: zero until the first `/clock` arrives, as rclcpp's.
/// One clock per binary, as ROS 2 keeps one per node and each binary here runs one node.
pub fn use_sim_time() {
    SIM_TIME.store(true, Ordering::SeqCst);
}

/// The simulation's time, as the latest `/clock` message gives it.
pub fn set_sim_time(t: Time) {
    let nanos = i64::from(t.sec) * 1_000_000_000 + i64::from(t.nanosec);
    SIM_NANOS.store(nanos, Ordering::SeqCst);
}

/// Now, as a header stamp: the system clock's, or with [`use_sim_time`] the simulation's.
pub fn now() -> Time {
    if SIM_TIME.load(Ordering::SeqCst) {
        let nanos = SIM_NANOS.load(Ordering::SeqCst);
        return Time {
            sec: nanos.div_euclid(1_000_000_000) as i32,
            nanosec: nanos.rem_euclid(1_000_000_000) as u32,
        };
    }
    let d = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .unwrap_or_default();
    Time {
        sec: d.as_secs() as i32,
        nanosec: d.subsec_nanos(),
    }
}

/// A planar heading as a quaternion (a rotation about z), for every pose both binaries publish.
pub fn quaternion_from_yaw(yaw: f64) -> Quaternion {
    Quaternion {
        x: 0.0,
        y: 0.0,
        z: (yaw / 2.0).sin(),
        w: (yaw / 2.0).cos(),
    }
}

/// Reliable QoS keeping the last `depth` samples, volatile or transient local (latched).
pub fn reliable(depth: usize, durability: Durability) -> QosProfile {
    QosProfile::publisher_default()
        .reliability_reliable(WhenFull::DEFAULT)
        .durability(durability)
        .history(History::KeepLast { depth })
}

/// SIGINT (Ctrl-C) and SIGTERM, caught from the moment this is made until the binary is done.
///
/// One stream per signal, made once: a `tokio::signal::ctrl_c()` future made afresh in a loop
/// only sees a signal that lands while it is being polled, so a Ctrl-C between two ticks was
/// lost (CI saw the chassis bridge ignore SIGINT under load).
pub struct ShutdownSignals {
    interrupt: Signal,
    terminate: Signal,
}

impl ShutdownSignals {
    /// Starts catching both signals; call it inside the tokio runtime.
    pub fn new() -> Result<Self> {
        Ok(Self {
            interrupt: signal(SignalKind::interrupt()).context("catching SIGINT")?,
            terminate: signal(SignalKind::terminate()).context("catching SIGTERM")?,
        })
    }

    /// Waits for either signal (or returns at once for one already caught), and names it.
    pub async fn recv(&mut self) -> &'static str {
        tokio::select! {
            _ = self.interrupt.recv() => "SIGINT",
            _ = self.terminate.recv() => "SIGTERM",
        }
    }
}

/// Runs a ROS 2 binary's async main on the two-thread tokio runtime both binaries use.
pub fn run_ros<F>(main: F) -> Result<()>
where
    F: Future<Output = Result<()>>,
{
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .context("starting tokio")?
        .block_on(main)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// With sim time on, a stamp is the latest /clock's to the nanosecond (zero before the
    /// first). The only test in this binary that turns sim time on, as it is process-wide.
    #[test]
    fn with_sim_time_the_stamps_are_the_clocks() {
        assert!(now().sec > 1_700_000_000, "the system clock before");
        use_sim_time();
        assert_eq!(now(), Time::default(), "zero until the first /clock");
        set_sim_time(Time {
            sec: 1234,
            nanosec: 500_000_000,
        });
        assert_eq!(
            now(),
            Time {
                sec: 1234,
                nanosec: 500_000_000
            }
        );
    }
}
