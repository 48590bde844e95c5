//! Wheel odometry from encoder counts: the inverse of the kinematics in `kinematics.rs`. Each
//! pair of readings gives each wheel's turn (`2 pi dticks / ticks_per_rev`), hence the distance
//! its contact point rolled; their mean is the distance driven and their difference over the
//! wheel separation the turn, integrated as an arc (`sim.rs`'s exact unicycle step).
//!
//! Counters are 32-bit and wrap (a board running long enough overflows them); differences are
//! taken modulo 2^32, so a wrap is an ordinary step. A step no real wheel can make (faster than
//! `max_wheel_speed`) means the board reset its counters or a reading was corrupted: odometry
//! then starts again from that reading instead of jumping the robot across the map.

use crate::kinematics::DiffDrive;
use crate::sim::Unicycle;
use crate::{Pose, Twist2};
use serde::{Deserialize, Serialize};
use std::f64::consts::TAU;
use thiserror::Error;

/// The encoders' resolution and the plausibility bound.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EncoderConfig {
    /// Encoder counts per wheel revolution (after any gearbox). Default 2048.
    pub ticks_per_rev: f64,
    /// Fastest plausible wheel speed (rad/s); a faster step is a counter reset. Default 50
    /// (4 m/s on the default 0.08 m wheels, far above the 0.6 m/s limit).
    pub max_wheel_speed: f64,
}

impl Default for EncoderConfig {
    fn default() -> Self {
        Self {
            ticks_per_rev: 2048.0,
            max_wheel_speed: 50.0,
        }
    }
}

/// Why a reading was not integrated.
#[derive(Clone, Debug, PartialEq, Error)]
pub enum OdometryError {
    #[error("encoder step of {left} / {right} counts in {dt_ms} ms is faster than any wheel turns: counters reset or reading corrupted; odometry continues from this reading")]
    Implausible { left: i64, right: i64, dt_ms: u32 },
    #[error("encoder reading with the same board time as the last one ({ms} ms): skipped")]
    NoTimeStep { ms: u32 },
}

/// Odometry integrated from successive encoder readings.
#[derive(Clone, Debug)]
pub struct EncoderOdometry {
    config: EncoderConfig,
    drive: DiffDrive,
    last: Option<(u32, i32, i32)>,
    car: Unicycle,
}

impl EncoderOdometry {
    pub fn new(config: EncoderConfig, drive: DiffDrive, start: Pose) -> Self {
        Self {
            config,
            drive,
            last: None,
            car: Unicycle::new(start),
        }
    }

    /// The pose so far.
    pub fn pose(&self) -> Pose {
        self.car.pose
    }

    /// The twist over the last integrated step.
    pub fn twist(&self) -> Twist2 {
        self.car.twist
    }

    /// Integrates a reading: board time (ms) and cumulative counts. The first reading only sets
    /// the reference. Returns the new pose, or why the reading was not used.
    pub fn update(&mut self, ms: u32, left: i32, right: i32) -> Result<Pose, OdometryError> {
        let Some((ms0, l0, r0)) = self.last.replace((ms, left, right)) else {
            return Ok(self.car.pose);
        };
        let dt_ms = ms.wrapping_sub(ms0);
        if dt_ms == 0 {
            self.last = Some((ms0, l0, r0));
            return Err(OdometryError::NoTimeStep { ms });
        }
        let dt = f64::from(dt_ms) / 1000.0;
        // Modulo-2^32 differences: a counter wrap is an ordinary small step.
        let (dl, dr) = (left.wrapping_sub(l0), right.wrapping_sub(r0));
        let per_tick = TAU / self.config.ticks_per_rev;
        let (wl, wr) = (f64::from(dl) * per_tick / dt, f64::from(dr) * per_tick / dt);
        if wl.abs() > self.config.max_wheel_speed || wr.abs() > self.config.max_wheel_speed {
            self.car.twist = Twist2::STOP;
            return Err(OdometryError::Implausible {
                left: i64::from(dl),
                right: i64::from(dr),
                dt_ms,
            });
        }
        self.car.step(self.drive.twist(wl, wr), dt);
        Ok(self.car.pose)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::f64::consts::PI;

    fn odo() -> EncoderOdometry {
        EncoderOdometry::new(
            EncoderConfig::default(),
            DiffDrive::default(),
            Pose::default(),
        )
    }

    /// Counts for `rad` of wheel turn.
    fn ticks(rad: f64) -> i32 {
        (rad / TAU * EncoderConfig::default().ticks_per_rev).round() as i32
    }

    #[test]
    fn one_wheel_revolution_each_is_one_circumference_straight() {
        let mut o = odo();
        o.update(0, 0, 0).unwrap();
        let p = o.update(2000, 2048, 2048).unwrap();
        let circumference = TAU * 0.08;
        assert!((p.x - circumference).abs() < 1e-12 && p.y.abs() < 1e-12 && p.yaw.abs() < 1e-12);
        assert!((o.twist().linear - circumference / 2.0).abs() < 1e-12);
    }

    #[test]
    fn opposite_wheels_turn_in_place() {
        // Each wheel rolls a quarter of the turning circle (radius b/2): yaw += pi/2.
        let mut o = odo();
        o.update(0, 0, 0).unwrap();
        let arc = PI / 2.0 * 0.40 / 2.0; // contact-point distance
        let n = ticks(arc / 0.08);
        let p = o.update(1000, -n, n).unwrap();
        assert!(p.x.abs() < 1e-9 && p.y.abs() < 1e-9);
        assert!((p.yaw - PI / 2.0).abs() < 2e-3, "{}", p.yaw);
    }

    #[test]
    fn counter_wrap_is_an_ordinary_step() {
        let mut a = odo();
        a.update(0, i32::MAX - 100, i32::MAX - 100).unwrap();
        let pa = a.update(20, i32::MIN + 99, i32::MIN + 99).unwrap(); // +200 counts
        let mut b = odo();
        b.update(0, 0, 0).unwrap();
        let pb = b.update(20, 200, 200).unwrap();
        assert!((pa.x - pb.x).abs() < 1e-12 && pa.x > 0.0);
        // The board clock wraps too.
        let mut c = odo();
        c.update(u32::MAX - 9, 0, 0).unwrap();
        let pc = c.update(10, 200, 200).unwrap();
        assert!((pc.x - pb.x).abs() < 1e-12);
    }

    #[test]
    fn a_counter_reset_restarts_instead_of_jumping() {
        let mut o = odo();
        o.update(0, 0, 0).unwrap();
        o.update(20, 100, 100).unwrap();
        let before = o.pose();
        // The board rebooted: counters back near zero from 1e6 would be a huge step.
        let mut p = odo();
        p.update(0, 1_000_000, 1_000_000).unwrap();
        assert!(matches!(
            p.update(20, 5, 5),
            Err(OdometryError::Implausible { .. })
        ));
        assert_eq!(p.pose(), Pose::default());
        // ... and continues from the new reading.
        p.update(40, 105, 105).unwrap();
        assert!((p.pose().x - before.x).abs() < 1e-12);
        assert!(matches!(
            p.update(40, 200, 200),
            Err(OdometryError::NoTimeStep { .. })
        ));
    }

    proptest! {
        /// Encoder counts generated from a twist integrate back to the pose of the same twist
        /// driven directly (up to the quantisation of one count per wheel per step).
        #[test]
        fn encoders_reproduce_the_driven_pose(v in -0.6f64..0.6, w in -0.4f64..0.4, steps in 1usize..200) {
            let drive = DiffDrive::default();
            let (wl, wr) = drive.wheel_speeds(Twist2::new(v, w));
            let mut truth = Unicycle::new(Pose::default());
            let mut o = odo();
            o.update(0, 0, 0).unwrap();
            let (mut angle_l, mut angle_r) = (0.0, 0.0);
            for k in 1..=steps {
                truth.step(Twist2::new(v, w), 0.02);
                angle_l += wl * 0.02;
                angle_r += wr * 0.02;
                o.update(20 * k as u32, ticks(angle_l), ticks(angle_r)).unwrap();
            }
            // One count is 2 pi / 2048 rad of wheel: 0.25 mm of travel at most, per wheel.
            let p = o.pose();
            prop_assert!((p.x - truth.pose.x).abs() < 1e-3 && (p.y - truth.pose.y).abs() < 1e-3);
            let dyaw = (p.yaw - truth.pose.yaw + PI).rem_euclid(TAU) - PI;
            prop_assert!(dyaw.abs() < 2e-3);
        }
    }
}
