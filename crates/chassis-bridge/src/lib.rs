//! The chassis back ends of the `chassis_bridge` binary (src/main.rs): the `Chassis` trait the
//! bridge drives each control period (chassis.rs), the simulated back end over the pure `chassis`
//! crate's unicycle, and the serial back end (serial.rs), a motor controller on a serial line.
//!
//! This library is the bridge's I/O edge without ROS: `serial` opens and talks to a device, and
//! nothing here knows DDS or tokio. The pure parts (limits, kinematics, watchdog, simulator, line
//! protocol, encoder odometry, follower) live in the `chassis` crate.

pub mod chassis;
pub mod serial;
