//! The planar pose every part of the chassis speaks: where the simulator and the encoder odometry
//! put the robot, and where the follower steers it from.

/// Pose in the odom frame: x, y (m), yaw (rad, counter-clockwise from x).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Pose {
    pub x: f64,
    pub y: f64,
    pub yaw: f64,
}
