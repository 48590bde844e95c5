//! The chassis back ends behind one trait: what the bridge drives each control period. `sim`
//! integrates the unicycle model of the chassis crate (no hardware, the default); `serial`
//! (serial.rs) talks to a motor controller over a serial line and reads its encoders back into
//! odometry.

use chassis::kinematics::DiffDrive;
use chassis::sim::Unicycle;
use chassis::{Pose, Twist2};
use thiserror::Error;

/// Odometry in the odom frame: the pose and the twist that moved it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Odometry2 {
    pub pose: Pose,
    pub twist: Twist2,
}

/// Why a back end could not do its job. The bridge logs it and, for the serial back end, reopens
/// the device after a pause; the watchdog and the limits are upstream of every back end.
#[derive(Debug, Error)]
pub enum ChassisError {
    #[error("cannot open {device}: {source}")]
    Open {
        device: String,
        source: serialport::Error,
    },
    #[error("{device}: {source}")]
    Io {
        device: String,
        source: std::io::Error,
    },
}

/// A differential-drive chassis.
pub trait Chassis {
    /// Commands the wheel speeds (rad/s, already limited) for the next `dt` seconds, and returns
    /// the odometry when there is news since the last call (`None`: nothing new yet).
    fn drive(&mut self, left: f64, right: f64, dt: f64) -> Result<Option<Odometry2>, ChassisError>;

    /// Problems seen since the last call that did not stop the chassis (unreadable lines from a
    /// controller, implausible encoder steps), for the caller to log.
    fn take_warnings(&mut self) -> Vec<String> {
        Vec::new()
    }

    /// Stops the wheels (on shutdown).
    fn stop(&mut self) -> Result<(), ChassisError>;
}

/// The simulated chassis: a perfect differential drive.
#[derive(Clone, Debug)]
pub struct SimChassis {
    car: Unicycle,
    drive: DiffDrive,
}

impl SimChassis {
    pub fn new(drive: DiffDrive, start: Pose) -> Self {
        Self {
            car: Unicycle::new(start),
            drive,
        }
    }
}

impl Chassis for SimChassis {
    fn drive(&mut self, left: f64, right: f64, dt: f64) -> Result<Option<Odometry2>, ChassisError> {
        self.car.step(self.drive.twist(left, right), dt);
        Ok(Some(Odometry2 {
            pose: self.car.pose,
            twist: self.car.twist,
        }))
    }

    fn stop(&mut self) -> Result<(), ChassisError> {
        self.car.twist = Twist2::STOP;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sim_drives_the_twist_of_the_wheel_speeds() {
        let d = DiffDrive::default();
        let mut sim = SimChassis::new(d, Pose::default());
        let (l, r) = d.wheel_speeds(Twist2::new(0.5, 0.0));
        let odo = sim.drive(l, r, 2.0).unwrap().unwrap();
        assert!((odo.pose.x - 1.0).abs() < 1e-12 && (odo.twist.linear - 0.5).abs() < 1e-12);
    }
}
