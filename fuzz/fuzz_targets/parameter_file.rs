//! The node's parameter file (`config/planner.yaml`): `planner_io::parameters::load_parameter_file`
//! itself (it takes a path: the input goes to one scratch file per fuzzing process, in
//! $PATROL_FUZZ_SCRATCH, else /dev/shm when there is one), and the in-memory part alone, serde_yaml straight into `PlannerConfig` and
//! `NodeParams` and their `validate`.
//!
//! Checked: a loaded file validates again (both parts), and its numbers are finite where the
//! validators say so.
#![no_main]

use libfuzzer_sys::fuzz_target;
use planner_core::config::PlannerConfig;
use planner_io::parameters::{load_parameter_file, NodeParams};
use std::path::PathBuf;
use std::sync::OnceLock;

fn scratch() -> &'static PathBuf {
    static PATH: OnceLock<PathBuf> = OnceLock::new();
    PATH.get_or_init(|| {
        // scripts/fuzz points PATROL_FUZZ_SCRATCH at a folder it removes afterwards.
        let shm = PathBuf::from("/dev/shm");
        let dir = match std::env::var_os("PATROL_FUZZ_SCRATCH") {
            Some(dir) => PathBuf::from(dir),
            None if shm.is_dir() => shm,
            None => std::env::temp_dir(),
        };
        dir.join(format!("patrol-fuzz-params-{}.yaml", std::process::id()))
    })
}

fuzz_target!(|data: &[u8]| {
    // The file as the node reads it.
    let path = scratch();
    std::fs::write(path, data).expect("scratch file");
    if let Ok(file) = load_parameter_file(path) {
        file.planning
            .validate()
            .expect("loaded planning part validates again");
        file.node
            .validate()
            .expect("loaded node part validates again");
        assert!(file.node.map_to_odom.iter().all(|v| v.is_finite()));
    }
    // The in-memory part: each struct straight from the bytes.
    if input_guard::yaml::check(data).is_err() {
        return;
    }
    if let Ok(config) = serde_yaml::from_slice::<PlannerConfig>(data) {
        let _ = config.validate();
    }
    if let Ok(node) = serde_yaml::from_slice::<NodeParams>(data) {
        if node.validate().is_ok() {
            assert!(node.control_rate_hz > 0.0 && node.control_rate_hz <= 200.0);
            assert!(node.pose_timeout.is_finite() && node.pose_timeout > 0.0);
        }
    }
});
