//! The serial back end: a motor controller on a serial line (USB CDC or a UART), spoken to in the
//! line protocol of the chassis crate's protocol.rs. Each control period sends one `$CMD` with the
//! wheel speeds and reads whatever the board sent since: its `$ENC` lines become odometry (the
//! chassis crate's odometry.rs).
//!
//! This is the one module of the bridge that does device I/O. It never blocks the control loop:
//! reads take only the bytes already waiting, and a write that cannot go out within the port
//! timeout is an error (a wedged or unplugged device), which the bridge answers by reopening the
//! device.

use crate::chassis::{Chassis, ChassisError, Odometry2};
use chassis::kinematics::DiffDrive;
use chassis::odometry::{EncoderConfig, EncoderOdometry};
use chassis::protocol::{self, Feedback, LineBuffer};
use chassis::Pose;
use serde::{Deserialize, Serialize};
use std::io::{Read, Write};
use std::time::Duration;

/// Where the controller is and how it counts.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SerialConfig {
    /// The serial device. Default `/dev/ttyACM0` (an Arduino's USB port).
    pub device: String,
    /// Baud rate (ignored by USB CDC devices and pseudo-terminals). Default 115200.
    pub baud: u32,
    pub encoders: EncoderConfig,
}

impl Default for SerialConfig {
    fn default() -> Self {
        Self {
            device: "/dev/ttyACM0".into(),
            baud: 115_200,
            encoders: EncoderConfig::default(),
        }
    }
}

/// Warnings kept per control period; the rest are counted.
const MAX_WARNINGS: usize = 5;

/// A motor controller on a serial line.
pub struct SerialChassis {
    device: String,
    port: Box<dyn serialport::SerialPort>,
    lines: LineBuffer,
    odometry: EncoderOdometry,
    warnings: Vec<String>,
    dropped_warnings: usize,
}

impl SerialChassis {
    /// Opens the device (raw mode, 8N1, exclusive). Odometry starts at `start` with the first
    /// encoder reading.
    pub fn open(
        config: &SerialConfig,
        drive: DiffDrive,
        start: Pose,
    ) -> Result<Self, ChassisError> {
        let port = serialport::new(&config.device, config.baud)
            .timeout(Duration::from_millis(50))
            .open()
            .map_err(|source| ChassisError::Open {
                device: config.device.clone(),
                source,
            })?;
        Ok(Self {
            device: config.device.clone(),
            port,
            lines: LineBuffer::default(),
            odometry: EncoderOdometry::new(config.encoders, drive, start),
            warnings: Vec::new(),
            dropped_warnings: 0,
        })
    }

    fn io(&self, source: std::io::Error) -> ChassisError {
        ChassisError::Io {
            device: self.device.clone(),
            source,
        }
    }

    fn warn(&mut self, text: String) {
        if self.warnings.len() < MAX_WARNINGS {
            self.warnings.push(text);
        } else {
            self.dropped_warnings += 1;
        }
    }

    fn send(&mut self, left: f64, right: f64) -> Result<(), ChassisError> {
        let line = protocol::command_line(left, right);
        self.port
            .write_all(line.as_bytes())
            .and_then(|()| self.port.flush())
            .map_err(|e| self.io(e))
    }

    /// The bytes already waiting, split into lines.
    fn receive(&mut self) -> Result<Vec<String>, ChassisError> {
        let waiting = self
            .port
            .bytes_to_read()
            .map_err(|e| self.io(std::io::Error::other(e)))? as usize;
        if waiting == 0 {
            return Ok(Vec::new());
        }
        let mut buf = vec![0u8; waiting];
        let n = self.port.read(&mut buf).map_err(|e| self.io(e))?;
        Ok(self.lines.push(&buf[..n]))
    }
}

impl Chassis for SerialChassis {
    fn drive(
        &mut self,
        left: f64,
        right: f64,
        _dt: f64,
    ) -> Result<Option<Odometry2>, ChassisError> {
        self.send(left, right)?;
        let mut fresh = false;
        for line in self.receive()? {
            match protocol::parse_line(&line) {
                Ok(Feedback::Encoders { ms, left, right }) => {
                    match self.odometry.update(ms, left, right) {
                        Ok(_) => fresh = true,
                        Err(e) => self.warn(e.to_string()),
                    }
                }
                Err(e) => self.warn(format!("from the controller: {e}")),
            }
        }
        Ok(fresh.then(|| Odometry2 {
            pose: self.odometry.pose(),
            twist: self.odometry.twist(),
        }))
    }

    fn take_warnings(&mut self) -> Vec<String> {
        let mut out = std::mem::take(&mut self.warnings);
        if self.dropped_warnings > 0 {
            out.push(format!("... and {} more", self.dropped_warnings));
            self.dropped_warnings = 0;
        }
        out
    }

    fn stop(&mut self) -> Result<(), ChassisError> {
        self.send(0.0, 0.0)
    }
}
