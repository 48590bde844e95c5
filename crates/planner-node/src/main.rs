//! `patrol_planner`: the ROS 2 global planner node. See `node.rs` for its topics and `README.md`
//! for how to run it beside a ROS 2 stack.
//!
//! Usage: `patrol_planner [--params-file FILE] [--ros-args [-r FROM:=TO] [--params-file FILE]
//! [-p [NODE:]NAME:=VALUE]]`, as `ros2 run` and launch_ros pass them: every parameter file and
//! `-p` with rclcpp's precedence (`/**` values, then the node's own over them; see
//! `planner_io::parameters::load_parameters_for`). Default: `config/planner.yaml` if it exists,
//! else built-in defaults. Log level from `RUST_LOG` (default info).

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
mod obstacle_layer;
mod outputs;
mod params;
mod patrol;
mod photo_at_waypoint;
mod planning;
mod result;
mod state;
mod tf_buffer;

use planner_io::parameters::{load_parameters_for, ParameterFile};
use std::path::Path;
use std::process::ExitCode;

fn main() -> ExitCode {
    // The node's own records (and, at debug level, the planners' notes; /diagnostics carries
    // them always) also go to /rosout once the node exists.
    ros_edge::logging::init(&["patrol_planner", "planner_core", "planner_io"]);
    let line = match ros_edge::command_line::CommandLine::from_env("patrol_planner") {
        Ok(line) => line,
        Err(e) => {
            log::error!("command line: {e}");
            return ExitCode::FAILURE;
        }
    };
    // Every --params-file and -p in order (config/planner.yaml first when no file is given and
    // it exists), applied with rclcpp's precedence (planner_io::parameters::load_parameters_for).
    let sources = line.parameter_sources(Path::new("config/planner.yaml"));
    let params = if sources.is_empty() {
        log::warn!("no config/planner.yaml here and no --params-file: built-in defaults, no map until /map arrives");
        ParameterFile::default()
    } else {
        // In each file, the block of the node's own name (as a Nav2 params file has
        // `planner_server:`), else patrol_planner's, with rclcpp's wildcard `/**` under it.
        let naming = &line.naming;
        let full = naming.node_path();
        let names = [full.as_str(), naming.node.as_str(), "/**", "patrol_planner"];
        match load_parameters_for(&sources, &names) {
            Ok(p) => {
                for source in &sources {
                    log::info!("{source}");
                }
                for w in &p.warnings {
                    log::warn!("{w}");
                }
                p
            }
            Err(e) => {
                // The same message `patrol-plan --config` gives for the same file.
                log::error!("{e}");
                return ExitCode::FAILURE;
            }
        }
    };
    match ros_edge::run_ros(node::run(params, line.naming)) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            log::error!("{e:#}");
            ExitCode::FAILURE
        }
    }
}
