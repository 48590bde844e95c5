//! The simulated chassis: a unicycle integrated exactly over each time step (an arc of a circle
//! when turning), so the pose it reports as odometry is the pose a perfect differential drive
//! would reach with the same wheel speeds.

use crate::{Pose, Twist2};

/// The simulated chassis.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Unicycle {
    pub pose: Pose,
    pub twist: Twist2,
}

impl Unicycle {
    pub fn new(pose: Pose) -> Self {
        Self {
            pose,
            twist: Twist2::STOP,
        }
    }

    /// Drives with `twist` for `dt` seconds.
    pub fn step(&mut self, twist: Twist2, dt: f64) {
        let (v, w) = (twist.linear, twist.angular);
        let p = &mut self.pose;
        if w.abs() < 1e-9 {
            p.x += v * dt * p.yaw.cos();
            p.y += v * dt * p.yaw.sin();
        } else {
            let r = v / w;
            let yaw1 = p.yaw + w * dt;
            p.x += r * (yaw1.sin() - p.yaw.sin());
            p.y -= r * (yaw1.cos() - p.yaw.cos());
            p.yaw = (yaw1 + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                - std::f64::consts::PI;
        }
        self.twist = twist;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn straight_and_quarter_circle() {
        let mut u = Unicycle::default();
        u.step(Twist2::new(0.5, 0.0), 2.0);
        assert!((u.pose.x - 1.0).abs() < 1e-12 && u.pose.y.abs() < 1e-12);
        // A quarter circle of radius 1 to the left: 0.4 rad/s for pi/2 / 0.4 s at 0.4 m/s.
        let mut u = Unicycle::default();
        u.step(Twist2::new(0.4, 0.4), (PI / 2.0) / 0.4);
        assert!(
            (u.pose.x - 1.0).abs() < 1e-9
                && (u.pose.y - 1.0).abs() < 1e-9
                && (u.pose.yaw - PI / 2.0).abs() < 1e-9
        );
        // Small steps agree with one big one.
        let mut v = Unicycle::default();
        for _ in 0..1000 {
            v.step(Twist2::new(0.4, 0.4), (PI / 2.0) / 0.4 / 1000.0);
        }
        assert!((v.pose.x - u.pose.x).abs() < 1e-9 && (v.pose.y - u.pose.y).abs() < 1e-9);
    }
}
