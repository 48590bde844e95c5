//! The line protocol between the bridge and a motor controller (an Arduino-class board such as the
//! patrol car paper's, section IV.C), over a serial line. ASCII sentences in the NMEA 0183 style,
//! so a few lines of C on the board can speak it and a terminal can read it:
//!
//! ```text
//! host -> board   $CMD,<left>,<right>*HH\r\n           wheel angular speed targets, rad/s
//! board -> host   $ENC,<ms>,<left>,<right>*HH\r\n      board clock (ms, u32, wraps) and the
//!                                                       cumulative encoder counts (i32, wrap)
//! ```
//!
//! `HH` is the XOR of every byte between `$` and `*`, as two hex digits. The host sends one `$CMD`
//! per control period (so a board with its own watchdog stops when the host goes quiet); the
//! board sends `$ENC` at its own rate (50 Hz is typical). The board's clock, not the host's,
//! times the encoder deltas, so serial-line jitter does not show up as speed noise.
//!
//! Anything else the board prints (boot banners, debug text) is skipped: a line that does not
//! parse is an error the caller counts and logs, never a stop.

use thiserror::Error;

/// Longest line kept; longer runs of bytes without a newline are line noise and are dropped.
pub const MAX_LINE: usize = 128;

/// A sentence from the board.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Feedback {
    /// The board's clock (ms) and the cumulative left and right encoder counts.
    Encoders { ms: u32, left: i32, right: i32 },
}

/// Why a line from the board was not understood.
#[derive(Clone, Debug, PartialEq, Eq, Error)]
pub enum ProtocolError {
    #[error("not a sentence (no leading `$` or no `*` checksum): {0:?}")]
    NotASentence(String),
    #[error("checksum {got:02X} does not match the line's {want:02X}: {line:?}")]
    Checksum { line: String, got: u8, want: u8 },
    #[error("unknown sentence `{0}`")]
    Unknown(String),
    #[error("malformed `{sentence}` sentence: {line:?}")]
    Malformed {
        sentence: &'static str,
        line: String,
    },
}

/// The NMEA checksum: XOR of the bytes between `$` and `*`.
pub fn checksum(body: &str) -> u8 {
    body.bytes().fold(0, |acc, b| acc ^ b)
}

/// Frames a sentence body (without `$`, `*HH` and the line end).
fn sentence(body: &str) -> String {
    format!("${body}*{:02X}\r\n", checksum(body))
}

/// The `$CMD` line for wheel speed targets (rad/s). Non-finite speeds are sent as a stop: the
/// limits upstream already turn NaN into a stop; this is the last line of defence.
pub fn command_line(left: f64, right: f64) -> String {
    let (l, r) = if left.is_finite() && right.is_finite() {
        (left, right)
    } else {
        (0.0, 0.0)
    };
    // -0.0000 would read oddly on a terminal and means the same.
    let fmt = |x: f64| {
        let s = format!("{x:.4}");
        if s == "-0.0000" {
            "0.0000".to_string()
        } else {
            s
        }
    };
    sentence(&format!("CMD,{},{}", fmt(l), fmt(r)))
}

/// The `$ENC` line a board sends (what a controller's firmware prints; used by the tests' fake
/// board and handy for a bench check with a terminal).
pub fn encoder_line(ms: u32, left: i32, right: i32) -> String {
    sentence(&format!("ENC,{ms},{left},{right}"))
}

/// Parses one line from the board (without its line end).
pub fn parse_line(line: &str) -> Result<Feedback, ProtocolError> {
    let line = line.trim();
    let not_a_sentence = || ProtocolError::NotASentence(line.to_string());
    let rest = line.strip_prefix('$').ok_or_else(not_a_sentence)?;
    let (body, hex) = rest.rsplit_once('*').ok_or_else(not_a_sentence)?;
    let want = u8::from_str_radix(hex, 16)
        .ok()
        .filter(|_| hex.len() == 2)
        .ok_or_else(not_a_sentence)?;
    let got = checksum(body);
    if got != want {
        return Err(ProtocolError::Checksum {
            line: line.to_string(),
            got,
            want,
        });
    }
    let mut fields = body.split(',');
    match fields.next() {
        Some("ENC") => {
            let malformed = || ProtocolError::Malformed {
                sentence: "ENC",
                line: line.to_string(),
            };
            let values: Vec<&str> = fields.collect();
            let [ms, left, right] = values.as_slice() else {
                return Err(malformed());
            };
            Ok(Feedback::Encoders {
                ms: ms.parse().map_err(|_| malformed())?,
                left: left.parse().map_err(|_| malformed())?,
                right: right.parse().map_err(|_| malformed())?,
            })
        }
        Some(other) => Err(ProtocolError::Unknown(other.to_string())),
        None => Err(not_a_sentence()),
    }
}

/// Splits a byte stream into lines: bytes arrive in whatever pieces the serial driver hands over.
#[derive(Clone, Debug, Default)]
pub struct LineBuffer {
    pending: Vec<u8>,
    /// Set while skipping an over-long run, until its newline.
    overflowed: bool,
}

impl LineBuffer {
    /// Appends bytes and returns the complete lines they finish (line ends stripped, invalid
    /// UTF-8 replaced). Over-long lines are dropped whole.
    pub fn push(&mut self, bytes: &[u8]) -> Vec<String> {
        let mut lines = Vec::new();
        for &b in bytes {
            if b == b'\n' {
                if !self.overflowed {
                    let text = String::from_utf8_lossy(&self.pending);
                    let text = text.trim_end_matches('\r');
                    if !text.is_empty() {
                        lines.push(text.to_string());
                    }
                }
                self.pending.clear();
                self.overflowed = false;
            } else if self.pending.len() < MAX_LINE {
                self.pending.push(b);
            } else {
                self.overflowed = true;
            }
        }
        lines
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn nmea_checksum_of_a_known_sentence() {
        // The classic GPGGA example from the NMEA 0183 literature ends in *47.
        let body = "GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,";
        assert_eq!(checksum(body), 0x47);
    }

    #[test]
    fn command_lines() {
        assert_eq!(
            command_line(1.25, -0.5),
            format!(
                "$CMD,1.2500,-0.5000*{:02X}\r\n",
                checksum("CMD,1.2500,-0.5000")
            )
        );
        assert!(command_line(-0.0, 0.0).starts_with("$CMD,0.0000,0.0000*"));
        assert_eq!(command_line(f64::NAN, 1.0), command_line(0.0, 0.0));
        assert_eq!(command_line(1.0, f64::INFINITY), command_line(0.0, 0.0));
    }

    #[test]
    fn encoder_lines_round_trip() {
        for (ms, l, r) in [(0, 0, 0), (u32::MAX, i32::MIN, i32::MAX), (1234, -56, 78)] {
            let line = encoder_line(ms, l, r);
            assert_eq!(
                parse_line(line.trim_end()),
                Ok(Feedback::Encoders {
                    ms,
                    left: l,
                    right: r
                })
            );
        }
    }

    #[test]
    fn bad_lines_are_errors_not_panics() {
        let good = encoder_line(10, 1, 2);
        let flipped = good.replacen("ENC,10", "ENC,11", 1);
        assert!(matches!(
            parse_line(&flipped),
            Err(ProtocolError::Checksum { .. })
        ));
        assert!(matches!(
            parse_line("hello from the bootloader"),
            Err(ProtocolError::NotASentence(_))
        ));
        assert!(matches!(
            parse_line("$ENC,1,2,3"),
            Err(ProtocolError::NotASentence(_))
        ));
        assert!(matches!(
            parse_line("$ENC,1,2,3*ZZ"),
            Err(ProtocolError::NotASentence(_))
        ));
        let unknown = format!("$FOO,1*{:02X}", checksum("FOO,1"));
        assert_eq!(
            parse_line(&unknown),
            Err(ProtocolError::Unknown("FOO".into()))
        );
        for body in [
            "ENC,1,2",
            "ENC,1,2,3,4",
            "ENC,x,2,3",
            "ENC,-1,2,3",
            "ENC,1,2,99999999999",
        ] {
            let line = format!("${body}*{:02X}", checksum(body));
            assert!(
                matches!(parse_line(&line), Err(ProtocolError::Malformed { .. })),
                "{body}"
            );
        }
    }

    #[test]
    fn line_buffer_reassembles_and_drops_noise() {
        let mut b = LineBuffer::default();
        assert!(b.push(b"$ENC,1,").is_empty());
        assert_eq!(b.push(b"2,3*00\r\n$E"), vec!["$ENC,1,2,3*00".to_string()]);
        assert_eq!(b.push(b"NC\n\n"), vec!["$ENC".to_string()]);
        let noise = vec![b'x'; MAX_LINE * 3];
        assert!(b.push(&noise).is_empty());
        assert_eq!(b.push(b"tail\nok\n"), vec!["ok".to_string()]);
    }

    proptest! {
        /// Whatever bytes arrive, the parser answers (no panic) and a valid sentence split at
        /// any point is still read.
        #[test]
        fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..400), split in 0usize..30) {
            let mut b = LineBuffer::default();
            for line in b.push(&bytes) {
                let _ = parse_line(&line);
            }
            let mut b = LineBuffer::default();
            let good = encoder_line(7, -3, 4);
            let (x, y) = good.as_bytes().split_at(split.min(good.len()));
            let mut lines = b.push(b"\n");
            lines.extend(b.push(x));
            lines.extend(b.push(y));
            prop_assert_eq!(lines.len(), 1);
            prop_assert_eq!(parse_line(&lines[0]), Ok(Feedback::Encoders { ms: 7, left: -3, right: 4 }));
        }
    }
}
