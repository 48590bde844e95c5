//! `patrol_planner`: the ROS 2 global planner node. See `node.rs` for its topics and `README.md`
//! for how to run it beside a ROS 2 stack.
//!
//! Usage: `patrol_planner [--params-file FILE]` (also after `--ros-args`, as `ros2 run` passes
//! it). Default: `config/planner.yaml` if it exists, else built-in defaults. Log level from
//! `RUST_LOG` (default info).

mod action_server;
mod actions;
mod assisted_teleop;
mod behaviors;
mod convert;
mod costmap_filters;
mod costmaps;
mod drive;
mod follow;
mod follow_path;
mod inputs;
mod lifecycle;
mod lifecycle_services;
mod localization;
mod map_server;
mod navigate;
mod node;
mod outputs;
mod params;
mod patrol;
mod planning;
mod result;
mod state;

use planner_io::parameters::{load_parameter_file_for, ParameterFile};
use std::process::ExitCode;

fn main() -> ExitCode {
    // The node's own records (and, at debug level, the planners' notes; /diagnostics carries
    // them always) also go to /rosout once the node exists.
    ros_edge::logging::init(&["patrol_planner", "planner_core", "planner_io"]);
    let naming = match ros_edge::naming::Naming::from_env("patrol_planner") {
        Ok(n) => n,
        Err(e) => {
            log::error!("command line: {e}");
            return ExitCode::FAILURE;
        }
    };
    for unread in ros_edge::unread_args() {
        log::warn!("command line: {unread}");
    }
    let (path, explicit) = ros_edge::params_file("config/planner.yaml");
    let params = if explicit || path.exists() {
        // The block of the node's own name (as a Nav2 params file has `planner_server:`), else
        // patrol_planner's, with rclcpp's wildcard `/**` applied under it.
        let full = naming.node_path();
        let names = [full.as_str(), naming.node.as_str(), "/**", "patrol_planner"];
        match load_parameter_file_for(&path, &names) {
            Ok(p) => {
                log::info!("parameters from {}", path.display());
                for w in &p.warnings {
                    log::warn!("{}: {w}", path.display());
                }
                p
            }
            Err(e) => {
                // The same message `patrol-plan --config` gives for the same file.
                log::error!("{e}");
                return ExitCode::FAILURE;
            }
        }
    } else {
        log::warn!("no config/planner.yaml here and no --params-file: built-in defaults, no map until /map arrives");
        ParameterFile::default()
    };
    match ros_edge::run_ros(node::run(params, naming)) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            log::error!("{e:#}");
            ExitCode::FAILURE
        }
    }
}
