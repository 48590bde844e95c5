//! Parameters that cannot be used stop the node at start with a message that names them: a
//! misspelt key in a parameter file (the same message `patrol-plan --config` gives, since both
//! read the file through `planner_io::parameters`), and a `-p` override that is malformed or out
//! of range (as rclcpp refuses to start on a malformed rule).

use std::io::Read;
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// A parameter file of this text in the tests' folder.
fn write(name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("patrol-planner-params-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join(name);
    std::fs::write(&file, text).unwrap();
    file
}

/// Runs the node with `args`, which it must refuse: it exits unsuccessfully within 10 s.
/// Returns what it wrote on stderr.
fn refused(args: &[&str]) -> String {
    let mut child = Command::new(env!("CARGO_BIN_EXE_patrol_planner"))
        .args(args)
        // A domain nobody else uses, should it get as far as DDS (it must not).
        .env("ROS_DOMAIN_ID", "177")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the node runs");
    let started = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if started.elapsed() > Duration::from_secs(10) {
            let _ = child.kill();
            let _ = child.wait();
            panic!("the node accepted {args:?} and kept running");
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    assert!(!status.success(), "the node accepted {args:?}");
    let mut stderr = String::new();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut stderr)
        .unwrap();
    stderr
}

#[test]
fn a_top_level_typo_stops_the_node_naming_the_key() {
    let file = write(
        "typo.yaml",
        "patrol_planner:\n  ros__parameters:\n    planer: astar\n",
    );
    let expected = planner_io::parameters::load_parameter_file(&file)
        .unwrap_err()
        .to_string();
    assert!(expected.contains("`planer`"), "{expected}");
    let stderr = refused(&["--params-file", file.to_str().unwrap()]);
    assert!(stderr.contains(&expected), "{stderr}");
}

#[test]
fn a_bad_override_stops_the_node_naming_it() {
    let file = write(
        "override.yaml",
        "patrol_planner:\n  ros__parameters:\n    map_yaml: ''\n    planner: astar\n",
    );
    let file = file.to_str().unwrap();
    // Out of range for its type: named by its key path, the sources named.
    let stderr = refused(&[
        "--params-file",
        file,
        "--ros-args",
        "-p",
        "swarm.population:=-5",
    ]);
    assert!(
        stderr.contains(&format!("{file} + -p: parameter `swarm.population`")),
        "{stderr}"
    );
    // A key the node does not have: the -p that set it is named.
    let stderr = refused(&["--params-file", file, "--ros-args", "-p", "planer:=astar"]);
    assert!(
        stderr.contains("unknown parameter `planer` set by `-p planer:=astar`"),
        "{stderr}"
    );
    // Not `name:=value`: refused before any file is read.
    let stderr = refused(&["--ros-args", "-p", "planner"]);
    assert!(stderr.contains("command line: -p planner:"), "{stderr}");
}
