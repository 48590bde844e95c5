//! A parameter file with a misspelt key stops the node at start with the message that names the
//! key and the file: the same message `patrol-plan --config` gives, since both read the file
//! through `planner_io::parameters`.

use std::io::Read;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

#[test]
fn a_top_level_typo_stops_the_node_naming_the_key() {
    let dir = std::env::temp_dir().join(format!("patrol-planner-params-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("typo.yaml");
    std::fs::write(
        &file,
        "patrol_planner:\n  ros__parameters:\n    planer: astar\n",
    )
    .unwrap();
    let expected = planner_io::parameters::load_parameter_file(&file)
        .unwrap_err()
        .to_string();
    assert!(expected.contains("`planer`"), "{expected}");
    let mut child = Command::new(env!("CARGO_BIN_EXE_patrol_planner"))
        .arg("--params-file")
        .arg(&file)
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
            panic!("the node accepted a misspelt key and kept running");
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    assert!(!status.success(), "the node accepted a misspelt key");
    let mut stderr = String::new();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut stderr)
        .unwrap();
    assert!(stderr.contains(&expected), "{stderr}");
}
