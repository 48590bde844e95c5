//! `map -> odom` from `/tf_static` and `/tf`, end to end: the real `patrol_planner` binary on a
//! domain of its own, and this test as the rest of the stack (odometry, a localizer that
//! broadcasts `map -> odom`, a user sending goals). Written with ros2-client because tf2_msgs
//! has no Python wheel for the rclpy tests.
//!
//! The robot sits still at (0.1, 0.1) in `odom`. Each `map -> odom` moves where it is in the map,
//! so the plans for the same goal must start where the latest transform puts it.

use patrol_msgs::geometry_msgs::{
    Point, Pose, PoseStamped, PoseWithCovariance, Transform, TransformStamped, Vector3,
};
use patrol_msgs::nav_msgs::{Odometry, Path};
use patrol_msgs::std_msgs::Header;
use patrol_msgs::tf2_msgs::TFMessage;
use ros2_client::qos::Durability;
use ros2_client::{
    Context, ContextOptions, MessageTypeName, Name, NodeName, NodeOptions, Publisher, Subscription,
};
use std::f64::consts::FRAC_PI_2;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

const ODOM: (f64, f64) = (0.1, 0.1);
const GOAL: (f64, f64) = (6.0, 0.5);

/// The node under test, its output in `log`; killed when the test ends, passing or not, and
/// its log shown when failing.
struct NodeProcess {
    child: Child,
    log: std::path::PathBuf,
}

impl Drop for NodeProcess {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        if std::thread::panicking() {
            let text = std::fs::read_to_string(&self.log).unwrap_or_default();
            let lines: Vec<&str> = text.lines().collect();
            eprintln!("patrol_planner's log ({}):", self.log.display());
            for line in &lines[lines.len().saturating_sub(30)..] {
                eprintln!("  {line}");
            }
        }
    }
}

fn header(frame: &str) -> Header {
    Header {
        stamp: ros_edge::now(),
        frame_id: frame.into(),
    }
}

fn pose(x: f64, y: f64, yaw: f64) -> Pose {
    Pose {
        position: Point { x, y, z: 0.0 },
        orientation: ros_edge::quaternion_from_yaw(yaw),
    }
}

fn transform(parent: &str, child: &str, x: f64, y: f64, yaw: f64) -> TransformStamped {
    TransformStamped {
        header: header(parent),
        child_frame_id: child.into(),
        transform: Transform {
            translation: Vector3 { x, y, z: 0.0 },
            rotation: ros_edge::quaternion_from_yaw(yaw),
        },
    }
}

struct Stack {
    odom: Publisher<Odometry>,
    goal: Publisher<PoseStamped>,
    plans: Subscription<Path>,
}

impl Stack {
    /// Publishes odometry every 0.1 s and the goal every second until a plan for the goal starts
    /// within a cell of `expected`; fails with the starts it saw instead.
    async fn plan_starting_at(&self, expected: (f64, f64), what: &str) {
        let deadline = Instant::now() + Duration::from_secs(30);
        let mut last_goal = Instant::now() - Duration::from_secs(1);
        let mut starts = Vec::new();
        while Instant::now() < deadline {
            let odom = Odometry {
                header: header("odom"),
                child_frame_id: "base_link".into(),
                pose: PoseWithCovariance {
                    pose: pose(ODOM.0, ODOM.1, 0.0),
                    ..Default::default()
                },
                ..Default::default()
            };
            self.odom.async_publish(odom).await.expect("/odom");
            if last_goal.elapsed() >= Duration::from_secs(1) {
                let goal = PoseStamped {
                    header: header("map"),
                    pose: pose(GOAL.0, GOAL.1, 0.0),
                };
                self.goal.async_publish(goal).await.expect("/goal_pose");
                last_goal = Instant::now();
            }
            let taken = tokio::time::timeout(Duration::from_millis(100), self.plans.async_take());
            if let Ok(Ok((plan, _))) = taken.await {
                if let Some(first) = plan.poses.first() {
                    let p = &first.pose.position;
                    if (p.x - expected.0).hypot(p.y - expected.1) <= 0.15 {
                        return;
                    }
                    starts.push((p.x, p.y));
                }
            }
        }
        panic!("{what}: no plan started at {expected:?}; plans started at {starts:?}");
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn plans_start_where_the_latest_map_to_odom_puts_the_robot() {
    // A domain of its own (the rclpy tests use 100..199).
    let domain = 200 + (std::process::id() % 30) as u16;
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let folder = std::env::temp_dir().join(format!("patrol_tf_input_{}", std::process::id()));
    std::fs::create_dir_all(&folder).unwrap();
    let params = folder.join("planner.yaml");
    std::fs::write(
        &params,
        format!(
            "patrol_planner:\n  ros__parameters:\n    map_yaml: {}\n    planner: astar\n    follow_plan: false\n",
            root.join("config/maps/datacenter_100.yaml").display()
        ),
    )
    .unwrap();
    let log = folder.join("patrol_planner.log");
    let output = std::fs::File::create(&log).unwrap();
    let _node = NodeProcess {
        child: Command::new(env!("CARGO_BIN_EXE_patrol_planner"))
            .arg("--params-file")
            .arg(&params)
            .env("ROS_DOMAIN_ID", domain.to_string())
            .env("RUST_LOG", "patrol_planner=info,warn")
            .stdout(Stdio::null())
            .stderr(output)
            .spawn()
            .expect("starting patrol_planner"),
        log,
    };

    let context = Context::with_options(ContextOptions::new().domain_id(domain)).unwrap();
    let mut node = context
        .new_node(
            NodeName::new("/", "tf_input_test").unwrap(),
            NodeOptions::new(),
        )
        .unwrap();
    tokio::spawn(node.spinner().unwrap().spin());
    let latched = ros_edge::reliable(1, Durability::TransientLocal);
    let volatile = ros_edge::reliable(100, Durability::Volatile);
    let topic = |name: &str, pkg: &str, ty: &str, qos| {
        node.create_topic(
            &Name::new("/", name).unwrap(),
            MessageTypeName::new(pkg, ty),
            qos,
        )
        .unwrap()
    };
    let tf_static_topic = topic("tf_static", "tf2_msgs", "TFMessage", &latched);
    let tf_topic = topic("tf", "tf2_msgs", "TFMessage", &volatile);
    let odom_topic = topic("odom", "nav_msgs", "Odometry", &volatile);
    let goal_topic = topic("goal_pose", "geometry_msgs", "PoseStamped", &volatile);
    let plan_topic = topic("plan", "nav_msgs", "Path", &latched);
    let tf_static = node
        .create_publisher::<TFMessage>(&tf_static_topic, Some(latched.clone()))
        .unwrap();
    let tf = node
        .create_publisher::<TFMessage>(&tf_topic, Some(volatile.clone()))
        .unwrap();
    let stack = Stack {
        odom: node.create_publisher(&odom_topic, None).unwrap(),
        goal: node.create_publisher(&goal_topic, None).unwrap(),
        plans: node
            .create_subscription(&plan_topic, Some(latched))
            .unwrap(),
    };

    // A static map -> odom (as `static_transform_publisher map odom` gives), among transforms
    // the node must leave alone.
    let msg = TFMessage {
        transforms: vec![
            transform("odom", "base_link", 5.0, 5.0, 0.0),
            transform("/map", "odom", 1.0, 0.5, 0.0),
            transform("map", "laser", 9.0, 9.0, 0.0),
        ],
    };
    tf_static.async_publish(msg).await.unwrap();
    stack
        .plan_starting_at((ODOM.0 + 1.0, ODOM.1 + 0.5), "map -> odom from /tf_static")
        .await;

    // Then a localizer's correction on /tf, turned by 90 degrees: odom (0.1, 0.1) is map
    // (3.0 - 0.1, 0.6 + 0.1).
    let correction = TFMessage {
        transforms: vec![transform("map", "odom", 3.0, 0.6, FRAC_PI_2)],
    };
    let corrected = async {
        loop {
            // /tf is volatile: broadcast like a localizer, until the node has it.
            tf.async_publish(correction.clone()).await.unwrap();
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
    };
    tokio::select! {
        _ = corrected => unreachable!(),
        _ = stack.plan_starting_at((2.9, 0.7), "map -> odom from /tf") => {}
    }
    std::fs::remove_dir_all(&folder).ok();
}
