//! The command watchdog: when no command has arrived for `timeout` seconds, the wheels stop, and
//! that is reported once (not on every tick) so the log says when and why the chassis stopped.

/// Tracks the age of the last command.
#[derive(Clone, Debug, PartialEq)]
pub struct Watchdog {
    timeout: f64,
    since_command: f64,
    tripped: bool,
}

/// What a tick of the watchdog says.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Commands are fresh: drive.
    Drive,
    /// Commands stopped just now: stop and log it.
    JustTripped,
    /// Still no commands: stay stopped (already logged).
    Stopped,
}

impl Watchdog {
    /// A watchdog that trips after `timeout` seconds without a command; it starts tripped, so a
    /// chassis never moves before its first command.
    pub fn new(timeout: f64) -> Self {
        Self {
            timeout,
            since_command: f64::INFINITY,
            tripped: true,
        }
    }

    /// A command arrived.
    pub fn feed(&mut self) {
        self.since_command = 0.0;
        self.tripped = false;
    }

    /// `dt` seconds passed.
    pub fn tick(&mut self, dt: f64) -> Verdict {
        self.since_command += dt.max(0.0);
        if self.since_command <= self.timeout {
            Verdict::Drive
        } else if self.tripped {
            Verdict::Stopped
        } else {
            self.tripped = true;
            Verdict::JustTripped
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stops_after_the_timeout_and_reports_once() {
        let mut w = Watchdog::new(0.5);
        assert_eq!(w.tick(0.01), Verdict::Stopped, "no command yet");
        w.feed();
        for _ in 0..4 {
            assert_eq!(w.tick(0.1), Verdict::Drive);
        }
        assert_eq!(w.tick(0.1), Verdict::Drive); // 0.5 s exactly
        assert_eq!(w.tick(0.1), Verdict::JustTripped);
        assert_eq!(w.tick(0.1), Verdict::Stopped);
        w.feed();
        assert_eq!(w.tick(0.1), Verdict::Drive);
    }
}
