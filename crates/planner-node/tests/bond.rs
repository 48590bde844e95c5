//! The bond heartbeat Nav2's lifecycle manager waits for after activating a server: the real
//! `patrol_planner` binary, active (autostart), sends `bond/Status` on `bond` with its node name as
//! the bond id, `active: true`, at `bond_heartbeat_period`. Written with ros2-client because the
//! `bond` package has no Python wheel for the rclpy tests.

use patrol_msgs::bond::Status;
use ros2_client::qos::Durability;
use ros2_client::{Context, ContextOptions, MessageTypeName, Name, NodeName, NodeOptions};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_active_node_sends_the_bond_heartbeat() {
    // A domain of its own, apart from the rclpy tests (100..199) and tf_input (200..229).
    let domain = 230 + (std::process::id() % 2) as u16;
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let folder = std::env::temp_dir().join(format!("patrol_bond_{}", std::process::id()));
    std::fs::create_dir_all(&folder).unwrap();
    let params = folder.join("planner.yaml");
    std::fs::write(
        &params,
        format!(
            "planner_server:\n  ros__parameters:\n    map_yaml: {}\n    follow_plan: false\n    bond_heartbeat_period: 0.2\n",
            root.join("config/maps/datacenter_100.yaml").display()
        ),
    )
    .unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_patrol_planner"))
        .arg("--params-file")
        .arg(&params)
        .args(["--ros-args", "-r", "__node:=planner_server"])
        .env("ROS_DOMAIN_ID", domain.to_string())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("starting patrol_planner");

    let context = Context::with_options(ContextOptions::new().domain_id(domain)).unwrap();
    let mut node = context
        .new_node(NodeName::new("/", "bond_test").unwrap(), NodeOptions::new())
        .unwrap();
    tokio::spawn(node.spinner().unwrap().spin());
    let qos = ros_edge::reliable(10, Durability::Volatile);
    let topic = node
        .create_topic(
            &Name::new("/", "bond").unwrap(),
            MessageTypeName::new("bond", "Status"),
            &qos,
        )
        .unwrap();
    let bond = node
        .create_subscription::<Status>(&topic, Some(qos))
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(20);
    let mut beats = Vec::new();
    while Instant::now() < deadline && beats.len() < 3 {
        if let Ok(Ok((status, _))) =
            tokio::time::timeout(Duration::from_millis(500), bond.async_take()).await
        {
            beats.push((Instant::now(), status));
        }
    }
    let _ = child.kill();
    let _ = child.wait();
    std::fs::remove_dir_all(&folder).ok();
    assert!(beats.len() >= 3, "{} heartbeats in 20 s", beats.len());
    for (_, s) in &beats {
        assert_eq!(s.id, "planner_server");
        assert!(s.active);
        assert!(!s.instance_id.is_empty());
        assert!((s.heartbeat_period - 0.2).abs() < 1e-6);
    }
    assert!(beats
        .windows(2)
        .all(|w| w[0].1.instance_id == w[1].1.instance_id));
    let span = beats[2].0 - beats[0].0;
    assert!(span < Duration::from_secs(2), "heartbeats {span:?} apart");
}
