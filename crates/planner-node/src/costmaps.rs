//! The services of a Nav2 stack's two costmaps (costmap_2d's `global_costmap` and
//! `local_costmap` nodes), for a node standing alone (`follow_plan`), which is its own planner
//! and controller and so holds the costmaps those would: nav2_simple_commander's
//! `getGlobalCostmap()`, `getLocalCostmap()`, `clearGlobalCostmap()`, `clearLocalCostmap()` and
//! `clearAllCostmaps()`, and the clearing a behaviour tree's ClearEntireCostmap nodes ask for,
//! are answered here instead of waiting for ever for servers that do not exist.
//!
//! | service | type | answer |
//! |---|---|---|
//! | `global_costmap/get_costmap` | nav2_msgs/srv/GetCostmap | the whole planning grid |
//! | `local_costmap/get_costmap` | nav2_msgs/srv/GetCostmap | a `local_costmap.width` x `height` window of it round the robot |
//! | `<costmap>/clear_entirely_<costmap>` | nav2_msgs/srv/ClearEntireCostmap | nothing to clear (below) |
//! | `<costmap>/clear_around_<costmap>` | nav2_msgs/srv/ClearCostmapAroundRobot | nothing to clear |
//! | `<costmap>/clear_except_<costmap>` | nav2_msgs/srv/ClearCostmapExceptRegion | nothing to clear |
//! | `<costmap>/clear_around_pose_<costmap>` | nav2_msgs/srv/ClearCostmapAroundPose | nothing to clear |
//!
//! The clearing services are costmap_2d's names (its ClearCostmapService), and clear what
//! costmap_2d clears: the clearable layers (obstacle, voxel and range layers, which mark what
//! the sensors saw). The node's grid has none: it is the map, its inflation and the keepout
//! filter, none of which costmap_2d clears either (its static layer, inflation layer and
//! costmap filters are not clearable). So each request is answered at once, leaves the grid as
//! it is, and says so in the log. With `costmap_topic` the global costmap is another node's,
//! which serves its own services; the node then serves only the local costmap's.

use crate::outputs::Outputs;
use crate::state::Shared;
use log::{info, warn};
use patrol_msgs::nav2_msgs::{
    ClearCostmapAroundPoseRequest, ClearCostmapAroundRobotRequest, ClearCostmapExceptRegionRequest,
    ClearCostmapResponse, ClearEntireCostmapRequest, Costmap, GetCostmapRequest,
    GetCostmapResponse,
};
use planner_core::geometry::Point2;
use ros2_client::Message;
use ros_edge::naming::Naming;
use ros_edge::service::ServiceServer;
use std::sync::Arc;

/// Serves both costmaps' services (the table above) on `node`, each on a task of `tasks`.
pub fn serve(
    node: &mut ros2_client::Node,
    naming: &Naming,
    tasks: &mut tokio::task::JoinSet<()>,
    shared: &Arc<Shared>,
    out: &Outputs,
) -> anyhow::Result<()> {
    // With costmap_topic the global costmap's own node serves its services: two servers of
    // one name would answer in turn, and ours from the 0-100 scale the topic carries.
    let mine: &[Which] = if shared.params.costmap_topic.is_empty() {
        &[Which::Global, Which::Local]
    } else {
        &[Which::Local]
    };
    for &which in mine {
        let name = format!("{}/get_costmap", which.name());
        let server = ServiceServer::new(node, naming, &name, "nav2_msgs", "GetCostmap")?;
        tasks.spawn(serve_get_costmap(
            shared.clone(),
            out.clone(),
            which,
            server,
        ));
        clear_service::<ClearEntireCostmapRequest>(node, naming, tasks, which)?;
        clear_service::<ClearCostmapAroundRobotRequest>(node, naming, tasks, which)?;
        clear_service::<ClearCostmapExceptRegionRequest>(node, naming, tasks, which)?;
        clear_service::<ClearCostmapAroundPoseRequest>(node, naming, tasks, which)?;
    }
    Ok(())
}

/// Costmap `which`'s clearing service for requests `R`, served on a task of `tasks`.
fn clear_service<R: ClearRequest>(
    node: &mut ros2_client::Node,
    naming: &Naming,
    tasks: &mut tokio::task::JoinSet<()>,
    which: Which,
) -> anyhow::Result<()> {
    let name = format!("{0}/{1}{0}", which.name(), R::PREFIX);
    let server = ServiceServer::<R, _>::new(node, naming, &name, "nav2_msgs", R::TYPE)?;
    tasks.spawn(serve_clear(which, server));
    Ok(())
}

/// Which of a Nav2 stack's costmaps a service stands for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Which {
    /// planner_server's: the whole grid.
    Global,
    /// controller_server's: a rolling window of the grid round the robot.
    Local,
}

impl Which {
    /// costmap_2d's node name, which is also its namespace and the suffix of its services.
    pub fn name(self) -> &'static str {
        match self {
            Self::Global => "global_costmap",
            Self::Local => "local_costmap",
        }
    }
}

/// `<costmap>/get_costmap` (nav2_msgs/srv/GetCostmap), as costmap_2d serves it to
/// nav2_simple_commander's `getGlobalCostmap()` and `getLocalCostmap()`: each cell's cost on
/// costmap_2d's scale; an empty costmap (with a warning) before any map, or, for the local
/// costmap, before the robot's pose is known.
pub async fn serve_get_costmap(
    s: Arc<Shared>,
    o: Outputs,
    which: Which,
    server: ServiceServer<GetCostmapRequest, GetCostmapResponse>,
) {
    loop {
        let (id, _request) = server.next_request().await;
        let robot = match which {
            Which::Global => None,
            Which::Local => s.robot_pose().await.map(|p| Point2::new(p.x, p.y)),
        };
        let (shared, header) = (s.clone(), o.header(&s));
        // One pass over the map, as the costmap publisher makes its message: off the async
        // threads on a map of millions of cells.
        let costmap = tokio::task::spawn_blocking(move || -> Result<Costmap, &'static str> {
            let map = shared.current_map().ok_or("no map yet")?;
            let info = map.map().info();
            let (frame, stamp) = (&header.frame_id, header.stamp);
            let unknown = |i| map.is_unknown(i);
            Ok(match which {
                Which::Global => {
                    crate::convert::costmap_costs(info, &map.grid, unknown, frame, stamp)
                }
                Which::Local => {
                    let robot = robot.ok_or("no robot pose yet")?;
                    let size = &shared.params.local_costmap;
                    crate::convert::costmap_window(
                        info,
                        &map.grid,
                        unknown,
                        robot,
                        (size.width, size.height),
                        frame,
                        stamp,
                    )
                }
            })
        })
        .await
        .unwrap_or(Err("the costmap could not be made"));
        let response = match costmap {
            Ok(map) => GetCostmapResponse { map },
            Err(why) => {
                warn!("{}/get_costmap: {why}: an empty costmap", which.name());
                GetCostmapResponse::default()
            }
        };
        server.respond(id, response).await;
    }
}

/// One of costmap_2d's clearing requests: its service, and what it asks in words.
pub trait ClearRequest: Message + Clone + Send + Sync + 'static {
    /// The service's name before the costmap's, as costmap_2d names it (`clear_entirely_`).
    const PREFIX: &'static str;
    /// The nav2_msgs service type.
    const TYPE: &'static str;
    /// What was asked, in words.
    fn asked(&self) -> String;
}

impl ClearRequest for ClearEntireCostmapRequest {
    const PREFIX: &'static str = "clear_entirely_";
    const TYPE: &'static str = "ClearEntireCostmap";
    fn asked(&self) -> String {
        "clear everything".into()
    }
}

impl ClearRequest for ClearCostmapAroundRobotRequest {
    const PREFIX: &'static str = "clear_around_";
    const TYPE: &'static str = "ClearCostmapAroundRobot";
    fn asked(&self) -> String {
        format!("clear a {} m square round the robot", self.reset_distance)
    }
}

impl ClearRequest for ClearCostmapExceptRegionRequest {
    const PREFIX: &'static str = "clear_except_";
    const TYPE: &'static str = "ClearCostmapExceptRegion";
    fn asked(&self) -> String {
        format!(
            "clear all but a {} m square round the robot",
            self.reset_distance
        )
    }
}

impl ClearRequest for ClearCostmapAroundPoseRequest {
    const PREFIX: &'static str = "clear_around_pose_";
    const TYPE: &'static str = "ClearCostmapAroundPose";
    fn asked(&self) -> String {
        let p = &self.pose.pose.position;
        format!(
            "clear a {} m square round ({}, {}) in `{}`",
            self.reset_distance, p.x, p.y, self.pose.header.frame_id
        )
    }
}

/// A clearing service of costmap `which` (see the module's comment): answered at once, the
/// grid left as it is (nothing in it is clearable), the request and why logged.
pub async fn serve_clear<R: ClearRequest>(
    which: Which,
    server: ServiceServer<R, ClearCostmapResponse>,
) {
    loop {
        let (id, request) = server.next_request().await;
        info!(
            "{}: asked to {}: nothing to clear in the {} (the node's costmap is the map, \
             its inflation and the keepout filter, none of them a layer costmap_2d clears)",
            server.name(),
            request.asked(),
            which.name()
        );
        server.respond(id, ClearCostmapResponse::default()).await;
    }
}
