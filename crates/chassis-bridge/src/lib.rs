//! The chassis side of patrol-planner, as pure functions and small state machines: twist limits
//! (the patrol car's 0.6 m/s and 0.4 rad/s, with acceleration limits), differential-drive wheel
//! kinematics, a command watchdog, a simulated unicycle chassis, a path follower, the line
//! protocol to a motor controller and encoder odometry. No ROS and no clock: callers pass the time
//! step, so everything here is tested and property-tested alone. The one module with I/O is
//! `serial` (the serial back end's device). The `chassis_bridge` binary and the node's follower
//! wrap these.

pub mod chassis;
pub mod follower;
pub mod kinematics;
pub mod limits;
pub mod odometry;
pub mod protocol;
pub mod serial;
pub mod sim;
pub mod watchdog;

/// A planar velocity command: forward speed (m/s) and turn rate (rad/s), as in geometry_msgs/Twist
/// (`linear.x`, `angular.z`).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Twist2 {
    pub linear: f64,
    pub angular: f64,
}

impl Twist2 {
    pub const STOP: Twist2 = Twist2 {
        linear: 0.0,
        angular: 0.0,
    };

    pub fn new(linear: f64, angular: f64) -> Self {
        Self { linear, angular }
    }
}
