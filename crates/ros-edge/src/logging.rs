//! Logging for a ROS 2 binary: `env_logger` on the terminal (filtered by `RUST_LOG`, as before)
//! and, once the node exists, the binary's own records on `/rosout` too, so `ros2 topic echo
//! /rosout`, rqt_console and launch logs show why a goal was refused, as they do for any rclcpp
//! node. Records from dependencies (RustDDS's discovery chatter) stay on the terminal only.

use ros2_client::log::LogLevel;
use ros2_client::rosout::{NodeLoggingHandle, RosoutRaw};
use std::sync::{Mutex, OnceLock};

/// The rosout handle, set by [`forward_to_rosout`] once the node exists.
static ROSOUT: OnceLock<Mutex<Option<NodeLoggingHandle>>> = OnceLock::new();

struct TeeLogger {
    terminal: env_logger::Logger,
    /// Module-path prefixes of the records that also go to `/rosout`.
    own: &'static [&'static str],
}

impl TeeLogger {
    fn is_own(&self, target: &str) -> bool {
        self.own.iter().any(|p| target.starts_with(p))
    }
}

impl log::Log for TeeLogger {
    fn enabled(&self, metadata: &log::Metadata) -> bool {
        self.terminal.enabled(metadata)
    }

    fn log(&self, record: &log::Record) {
        if !self.terminal.matches(record) {
            return;
        }
        self.terminal.log(record);
        if !self.is_own(record.target()) {
            return;
        }
        let Some(lock) = ROSOUT.get() else { return };
        let Ok(guard) = lock.lock() else { return };
        if let Some(handle) = guard.as_ref() {
            handle.rosout_raw(
                ros2_client::builtin_interfaces::Time::now(),
                rosout_level(record.level()),
                handle.base_name(),
                &record.args().to_string(),
                record.file().unwrap_or(""),
                record.module_path().unwrap_or(""),
                record.line().unwrap_or(0),
            );
        }
    }

    fn flush(&self) {
        self.terminal.flush();
    }
}

/// rcl_interfaces/Log levels for `log`'s (trace folds into debug, as rcl has no trace).
fn rosout_level(level: log::Level) -> LogLevel {
    match level {
        log::Level::Error => LogLevel::Error,
        log::Level::Warn => LogLevel::Warn,
        log::Level::Info => LogLevel::Info,
        log::Level::Debug | log::Level::Trace => LogLevel::Debug,
    }
}

/// The filter without `RUST_LOG`: `info` for the binary's own records, `warn` for its
/// dependencies (RustDDS logs every discovery step at `info`, dozens of lines a second at start).
fn default_filter(own: &[&str]) -> String {
    std::iter::once("warn".to_string())
        .chain(own.iter().map(|p| format!("{p}=info")))
        .collect::<Vec<_>>()
        .join(",")
}

/// Installs the logger: `RUST_LOG` filtering (by default `default_filter`), and records whose
/// module path starts with one of `own` also to `/rosout` once [`forward_to_rosout`] is called.
pub fn init(own: &'static [&'static str]) {
    let terminal = env_logger::Builder::from_env(
        env_logger::Env::default().default_filter_or(default_filter(own)),
    )
    .build();
    let max = terminal.filter();
    if log::set_boxed_logger(Box::new(TeeLogger { terminal, own })).is_ok() {
        log::set_max_level(max);
    }
}

/// From now on, the binary's own records also go to `/rosout` through this node's handle.
pub fn forward_to_rosout(handle: NodeLoggingHandle) {
    let lock = ROSOUT.get_or_init(|| Mutex::new(None));
    if let Ok(mut guard) = lock.lock() {
        *guard = Some(handle);
    }
}

/// Stops forwarding (before the node is dropped, so a late record never writes to a dead node).
pub fn stop_forwarding() {
    if let Some(lock) = ROSOUT.get() {
        if let Ok(mut guard) = lock.lock() {
            *guard = None;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use log::Log as _;

    #[test]
    fn levels_map_to_rcl() {
        assert_eq!(rosout_level(log::Level::Error) as u8, 40);
        assert_eq!(rosout_level(log::Level::Warn) as u8, 30);
        assert_eq!(rosout_level(log::Level::Info) as u8, 20);
        assert_eq!(rosout_level(log::Level::Trace) as u8, 10);
    }

    #[test]
    fn by_default_own_records_from_info_and_dependencies_from_warn() {
        let filter = default_filter(&["patrol_planner", "planner_core"]);
        assert_eq!(filter, "warn,patrol_planner=info,planner_core=info");
        let logger = env_logger::Builder::new().parse_filters(&filter).build();
        let at = |level, target| {
            logger.enabled(&log::Metadata::builder().level(level).target(target).build())
        };
        assert!(at(log::Level::Info, "patrol_planner::planning"));
        assert!(at(log::Level::Info, "planner_core"));
        assert!(!at(log::Level::Debug, "patrol_planner::planning"));
        assert!(!at(log::Level::Info, "rustdds::rtps::writer"));
        assert!(at(log::Level::Warn, "rustdds::rtps::writer"));
    }

    #[test]
    fn only_own_targets_are_forwarded() {
        let t = TeeLogger {
            terminal: env_logger::Builder::new().build(),
            own: &["patrol_planner", "planner_core"],
        };
        assert!(t.is_own("patrol_planner::node"));
        assert!(t.is_own("planner_core"));
        assert!(!t.is_own("rustdds::rtps::writer"));
    }
}
