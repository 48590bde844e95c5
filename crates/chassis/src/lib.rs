//! The chassis of patrol-planner as pure functions and small state machines: twist limits (the
//! patrol car's 0.6 m/s and 0.4 rad/s, with acceleration limits, `limits`), differential-drive
//! wheel kinematics (`kinematics`), a command watchdog (`watchdog`), the planar pose in the odom
//! frame (`pose`), a simulated unicycle chassis (`sim`), a regulated pure-pursuit path follower
//! (`follower`) with its progress checker (`progress`), the spin, drive on heading and back-up of
//! Nav2's behaviours (`behavior`), the line protocol to a motor controller (`protocol`) and
//! encoder odometry (`odometry`).
//!
//! Pure: no ROS, no tokio, no clock and no I/O. Callers pass the time step and the bytes, so
//! everything here is tested and property-tested alone. The `chassis_bridge` binary (crate
//! chassis-bridge, which adds the serial device and the ROS 2 edge) and the planner node's
//! follower loop wrap it.

pub mod behavior;
pub mod follower;
pub mod kinematics;
pub mod limits;
pub mod odometry;
pub mod pose;
pub mod progress;
pub mod protocol;
pub mod sim;
pub mod watchdog;

pub use pose::Pose;

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
