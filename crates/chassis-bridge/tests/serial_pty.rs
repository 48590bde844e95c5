//! The serial back end against a fake motor controller on a pseudo-terminal: the real device code
//! path (open by name, raw mode, non-blocking reads), no hardware. The fake board is written here
//! from the protocol's description, independently of the chassis crate's `protocol.rs`, so a
//! symmetric mistake in the bridge's encoder and decoder cannot pass unnoticed.

use chassis::kinematics::DiffDrive;
use chassis::odometry::EncoderConfig;
use chassis::{Pose, Twist2};
use chassis_bridge::chassis::{Chassis, ChassisError};
use chassis_bridge::serial::{SerialChassis, SerialConfig};
use serialport::{SerialPort, TTYPort};
use std::io::{Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread;
use std::time::Duration;

const TICKS_PER_REV: f64 = 2048.0;
const R: f64 = 0.08;
const B: f64 = 0.40;

/// What the fake board knows: the commands it obeyed and its true pose.
#[derive(Default)]
struct BoardState {
    commands: Vec<(f64, f64)>,
    x: f64,
    y: f64,
    yaw: f64,
}

fn nmea_sum(body: &str) -> u8 {
    body.bytes().fold(0u8, |a, b| a ^ b)
}

/// Runs a board on the pty master: obeys `$CMD` lines, integrates its wheels every 20 ms of its own
/// clock and reports `$ENC` (counts starting at `offset`, so they wrap). Prints `noise` lines first.
fn fake_board(
    mut master: TTYPort,
    offset: i32,
    noise: Vec<String>,
    state: Arc<Mutex<BoardState>>,
    stop: Arc<AtomicBool>,
) -> thread::JoinHandle<()> {
    thread::spawn(move || {
        master.set_timeout(Duration::from_millis(5)).unwrap();
        for line in noise {
            master.write_all(line.as_bytes()).unwrap();
        }
        let (mut wl, mut wr) = (0.0f64, 0.0f64);
        let (mut al, mut ar) = (0.0f64, 0.0f64);
        let mut ms: u32 = 1_000;
        let mut pending = String::new();
        let mut buf = [0u8; 256];
        while !stop.load(Ordering::SeqCst) {
            if let Ok(n) = master.read(&mut buf) {
                pending.push_str(&String::from_utf8_lossy(&buf[..n]));
            }
            while let Some(end) = pending.find('\n') {
                let line: String = pending.drain(..=end).collect();
                let line = line.trim();
                let (body, sum) = line[1..].split_once('*').expect("a $...*HH line");
                assert!(line.starts_with('$'), "{line}");
                assert_eq!(
                    u8::from_str_radix(sum, 16).unwrap(),
                    nmea_sum(body),
                    "{line}"
                );
                let f: Vec<&str> = body.split(',').collect();
                assert_eq!(f[0], "CMD", "{line}");
                (wl, wr) = (f[1].parse().unwrap(), f[2].parse().unwrap());
                state.lock().unwrap().commands.push((wl, wr));
            }
            // 20 ms of the board's life (real time only paces it).
            thread::sleep(Duration::from_millis(20));
            ms = ms.wrapping_add(20);
            al += wl * 0.02;
            ar += wr * 0.02;
            {
                let mut s = state.lock().unwrap();
                let (v, w) = (R * (wr + wl) / 2.0, R * (wr - wl) / B);
                // Midpoint integration: exact enough over 20 ms for the comparison below.
                let mid = s.yaw + w * 0.01;
                s.x += v * 0.02 * mid.cos();
                s.y += v * 0.02 * mid.sin();
                s.yaw += w * 0.02;
            }
            let count = |a: f64| {
                offset.wrapping_add((a / std::f64::consts::TAU * TICKS_PER_REV).round() as i32)
            };
            let body = format!("ENC,{ms},{},{}", count(al), count(ar));
            let line = format!("${body}*{:02X}\r\n", nmea_sum(&body));
            if master.write_all(line.as_bytes()).is_err() {
                break;
            }
        }
    })
}

fn config(device: &str) -> SerialConfig {
    SerialConfig {
        device: device.to_string(),
        baud: 115_200,
        encoders: EncoderConfig {
            ticks_per_rev: TICKS_PER_REV,
            max_wheel_speed: 50.0,
        },
    }
}

fn drive() -> DiffDrive {
    DiffDrive {
        wheel_radius: R,
        wheel_separation: B,
    }
}

/// Drives `twist` for `ticks` control periods of 20 ms; returns the last odometry.
fn run(
    chassis: &mut SerialChassis,
    twist: Twist2,
    ticks: usize,
) -> Option<chassis_bridge::chassis::Odometry2> {
    let (l, r) = drive().wheel_speeds(twist);
    let mut last = None;
    for _ in 0..ticks {
        if let Some(o) = chassis.drive(l, r, 0.02).expect("serial I/O") {
            last = Some(o);
        }
        thread::sleep(Duration::from_millis(20));
    }
    last
}

#[test]
fn odometry_follows_the_board_through_noise_and_counter_wrap() {
    let (master, slave) = TTYPort::pair().expect("a pseudo-terminal");
    let device = slave.name().expect("the pty's name");
    let state = Arc::new(Mutex::new(BoardState::default()));
    let stop = Arc::new(AtomicBool::new(false));
    let bad = "ENC,5,1,1";
    let noise = vec![
        "Motor board v1.2 ready\r\n".to_string(),
        format!("${bad}*{:02X}\r\n", nmea_sum(bad) ^ 0x5A), // wrong checksum
    ];
    // Counts start 3000 short of i32::MAX: they wrap within the first metres.
    let board = fake_board(master, i32::MAX - 3000, noise, state.clone(), stop.clone());
    let mut chassis =
        SerialChassis::open(&config(&device), drive(), Pose::default()).expect("open the pty");

    // Odometry counts from the first reading it sees: let the board report once at rest.
    run(&mut chassis, Twist2::STOP, 5).expect("a first reading");
    run(&mut chassis, Twist2::new(0.3, 0.0), 60);
    run(&mut chassis, Twist2::new(0.2, 0.4), 60);
    run(&mut chassis, Twist2::STOP, 10);
    chassis.stop().unwrap();
    thread::sleep(Duration::from_millis(100));
    let odo = run(&mut chassis, Twist2::STOP, 3)
        .or_else(|| run(&mut chassis, Twist2::STOP, 5))
        .expect("odometry");
    stop.store(true, Ordering::SeqCst);
    board.join().unwrap();

    let s = state.lock().unwrap();
    // The board obeyed what the bridge sent: straight, then a left arc, then stop.
    assert!(s.commands.len() > 100, "{} commands", s.commands.len());
    let (l, r) = drive().wheel_speeds(Twist2::new(0.3, 0.0));
    assert!(s
        .commands
        .iter()
        .any(|&(a, b)| (a - l).abs() < 1e-4 && (b - r).abs() < 1e-4));
    assert_eq!(*s.commands.last().unwrap(), (0.0, 0.0));
    // It drove somewhere real: about 0.3 m/s for 1.2 s, then an arc to the left.
    assert!(
        s.x > 0.3 && s.y > 0.02 && s.yaw > 0.2,
        "board at ({}, {}, {})",
        s.x,
        s.y,
        s.yaw
    );
    // The bridge's odometry is the board's true pose, to encoder quantisation.
    let p = odo.pose;
    assert!(
        (p.x - s.x).abs() < 5e-3 && (p.y - s.y).abs() < 5e-3 && (p.yaw - s.yaw).abs() < 5e-3,
        "odometry ({}, {}, {}) vs board ({}, {}, {})",
        p.x,
        p.y,
        p.yaw,
        s.x,
        s.y,
        s.yaw
    );
    // The banner and the corrupted line were reported, not obeyed; nothing else was.
    drop(s);
    assert_eq!(chassis.take_warnings().len(), 2);
    drop(slave);
}

#[test]
fn unreadable_lines_are_reported_as_warnings() {
    let (master, slave) = TTYPort::pair().expect("a pseudo-terminal");
    let device = slave.name().unwrap();
    let mut chassis = SerialChassis::open(&config(&device), drive(), Pose::default()).unwrap();
    let state = Arc::new(Mutex::new(BoardState::default()));
    let stop = Arc::new(AtomicBool::new(false));
    let bad = "ENC,5,1,1";
    let noise = vec![
        "Motor board v1.2 ready\r\n".to_string(),
        format!("${bad}*{:02X}\r\n", nmea_sum(bad) ^ 0x5A),
    ];
    let board = fake_board(master, 0, noise, state, stop.clone());
    let mut warnings = Vec::new();
    for _ in 0..20 {
        chassis.drive(0.0, 0.0, 0.02).unwrap();
        warnings.extend(chassis.take_warnings());
        thread::sleep(Duration::from_millis(20));
    }
    stop.store(true, Ordering::SeqCst);
    board.join().unwrap();
    assert_eq!(warnings.len(), 2, "{warnings:?}");
    assert!(
        warnings[0].contains("not a sentence") && warnings[1].contains("checksum"),
        "{warnings:?}"
    );
    drop(slave);
}

#[test]
fn an_unplugged_controller_is_an_error_not_a_hang() {
    let (master, slave) = TTYPort::pair().unwrap();
    let device = slave.name().unwrap();
    let mut chassis = SerialChassis::open(&config(&device), drive(), Pose::default()).unwrap();
    assert!(chassis.drive(0.0, 0.0, 0.02).is_ok());
    drop(master); // the board goes away
    let t0 = std::time::Instant::now();
    let err = (0..50)
        .find_map(|_| {
            thread::sleep(Duration::from_millis(10));
            chassis.drive(1.0, 1.0, 0.02).err()
        })
        .expect("an error once the other end is gone");
    assert!(matches!(err, ChassisError::Io { .. }), "{err}");
    assert!(t0.elapsed() < Duration::from_secs(2));
    drop(slave);
}

#[test]
fn a_missing_device_is_an_open_error() {
    let err = SerialChassis::open(
        &config("/dev/patrol-planner-no-such-tty"),
        drive(),
        Pose::default(),
    )
    .err()
    .expect("no such device");
    assert!(
        matches!(err, ChassisError::Open { .. }) && err.to_string().contains("no-such-tty"),
        "{err}"
    );
}
