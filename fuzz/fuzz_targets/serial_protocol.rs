//! The chassis controller's serial line protocol and encoder odometry (crates/chassis):
//! `LineBuffer::push` on the raw byte stream (fed in chunks), `parse_line` on each line, every
//! `ENC` reading into `EncoderOdometry::update`; and the encoders `command_line` / `encoder_line`
//! on numbers taken from the input.
//!
//! Checked: lines stay bounded (MAX_LINE bytes, at most 3x after lossy UTF-8 repair); odometry
//! stays finite; `encoder_line` round-trips through `parse_line` within MAX_LINE; `command_line`
//! is always a sentence with a valid checksum (and within MAX_LINE for wheel speeds up to 1e6).
#![no_main]

use chassis::kinematics::DiffDrive;
use chassis::odometry::{EncoderConfig, EncoderOdometry};
use chassis::pose::Pose;
use chassis::protocol::{
    command_line, encoder_line, parse_line, Feedback, LineBuffer, ProtocolError, MAX_LINE,
};
use libfuzzer_sys::fuzz_target;

fn word<const N: usize>(data: &[u8], at: usize) -> [u8; N] {
    let mut out = [0u8; N];
    for (i, b) in out.iter_mut().enumerate() {
        *b = data.get(at + i).copied().unwrap_or(0);
    }
    out
}

fuzz_target!(|data: &[u8]| {
    let Some((&chunk, stream)) = data.split_first() else {
        return;
    };
    let chunk = usize::from(chunk).max(1);
    let mut buffer = LineBuffer::default();
    let mut odo = EncoderOdometry::new(
        EncoderConfig::default(),
        DiffDrive::default(),
        Pose::default(),
    );
    for piece in stream.chunks(chunk) {
        for line in buffer.push(piece) {
            assert!(
                !line.is_empty() && line.len() <= 3 * MAX_LINE,
                "{} bytes",
                line.len()
            );
            if let Ok(Feedback::Encoders { ms, left, right }) = parse_line(&line) {
                if let Ok(p) = odo.update(ms, left, right) {
                    assert!(
                        p.x.is_finite() && p.y.is_finite() && p.yaw.is_finite(),
                        "{p:?}"
                    );
                }
                let t = odo.twist();
                assert!(t.linear.is_finite() && t.angular.is_finite());
            }
        }
    }
    // The encoders, on numbers from the input.
    let (ms, left, right) = (
        u32::from_le_bytes(word(data, 1)),
        i32::from_le_bytes(word(data, 5)),
        i32::from_le_bytes(word(data, 9)),
    );
    let enc = encoder_line(ms, left, right);
    assert!(enc.len() <= MAX_LINE);
    assert_eq!(parse_line(&enc), Ok(Feedback::Encoders { ms, left, right }));
    let (l, r) = (
        f64::from_le_bytes(word(data, 13)),
        f64::from_le_bytes(word(data, 21)),
    );
    let cmd = command_line(l, r);
    assert!(
        matches!(parse_line(&cmd), Err(ProtocolError::Unknown(s)) if s == "CMD"),
        "{cmd:?}"
    );
    if l.abs() <= 1e6 && r.abs() <= 1e6 {
        assert!(cmd.len() <= MAX_LINE, "{cmd:?}");
    }
});
