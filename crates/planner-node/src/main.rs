//! `patrol_planner`: the ROS 2 global planner node. See `node.rs` for its topics and `README.md`
//! for how to run it beside a ROS 2 stack.
//!
//! Usage: `patrol_planner [--params-file FILE]` (also after `--ros-args`, as `ros2 run` passes
//! it). Default: `config/planner.yaml` if it exists, else built-in defaults. Log level from
//! `RUST_LOG` (default info).

mod convert;
mod node;
mod params;

use params::NodeParams;
use std::process::ExitCode;

fn main() -> ExitCode {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("info")).init();
    let (path, explicit) = ros_edge::params_file("config/planner.yaml");
    let params = if explicit || path.exists() {
        match NodeParams::load(&path) {
            Ok(p) => {
                log::info!("parameters from {}", path.display());
                p
            }
            Err(e) => {
                log::error!("{e:#}");
                return ExitCode::FAILURE;
            }
        }
    } else {
        log::warn!("no config/planner.yaml here and no --params-file: built-in defaults, no map until /map arrives");
        NodeParams::default()
    };
    let runtime = match tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
    {
        Ok(r) => r,
        Err(e) => {
            log::error!("tokio: {e}");
            return ExitCode::FAILURE;
        }
    };
    match runtime.block_on(node::run(params)) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            log::error!("{e:#}");
            ExitCode::FAILURE
        }
    }
}
