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
//! | `<costmap>/clear_entirely_<costmap>` | nav2_msgs/srv/ClearEntireCostmap | the obstacle layer forgets all it saw |
//! | `<costmap>/clear_around_<costmap>` | nav2_msgs/srv/ClearCostmapAroundRobot | ... what it saw in a `reset_distance` square round the robot |
//! | `<costmap>/clear_except_<costmap>` | nav2_msgs/srv/ClearCostmapExceptRegion | ... everywhere but in that square |
//! | `<costmap>/clear_around_pose_<costmap>` | nav2_msgs/srv/ClearCostmapAroundPose | ... in a `reset_distance` square round the pose |
//!
//! The clearing services are costmap_2d's names (its ClearCostmapService), and clear what
//! costmap_2d clears: the clearable layers, here the obstacle layer (obstacle_layer.rs, what the
//! scans marked), with costmap_2d's regions (`CostmapLayer::clearArea`); the map, its inflation
//! and the keepout filter stay, as costmap_2d's static layer, inflation layer and costmap
//! filters are not clearable. The grid is made again at once, so the next plan (a recovery's)
//! no longer sees what was cleared, until a scan sees it again. The local costmap is a window of
//! the global grid, so clearing either clears the one layer. With `costmap_topic` the global
//! costmap is another node's, which serves its own services; the node then serves only the
//! local costmap's.

use crate::outputs::Outputs;
use crate::state::Shared;
use log::{info, warn};
use patrol_msgs::geometry_msgs::PoseStamped;
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
        clear_service::<ClearEntireCostmapRequest>(node, naming, tasks, shared, which)?;
        clear_service::<ClearCostmapAroundRobotRequest>(node, naming, tasks, shared, which)?;
        clear_service::<ClearCostmapExceptRegionRequest>(node, naming, tasks, shared, which)?;
        clear_service::<ClearCostmapAroundPoseRequest>(node, naming, tasks, shared, which)?;
    }
    Ok(())
}

/// Costmap `which`'s clearing service for requests `R`, served on a task of `tasks`.
fn clear_service<R: ClearRequest>(
    node: &mut ros2_client::Node,
    naming: &Naming,
    tasks: &mut tokio::task::JoinSet<()>,
    shared: &Arc<Shared>,
    which: Which,
) -> anyhow::Result<()> {
    let name = format!("{0}/{1}{0}", which.name(), R::PREFIX);
    let server = ServiceServer::<R, _>::new(node, naming, &name, "nav2_msgs", R::TYPE)?;
    tasks.spawn(serve_clear(shared.clone(), which, server));
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

/// One of costmap_2d's clearing requests: its service, what it asks in words, and where.
pub trait ClearRequest: Message + Clone + Send + Sync + 'static {
    /// The service's name before the costmap's, as costmap_2d names it (`clear_entirely_`).
    const PREFIX: &'static str;
    /// The nav2_msgs service type.
    const TYPE: &'static str;
    /// What was asked, in words.
    fn asked(&self) -> String;
    /// Where to clear.
    fn region(&self) -> Region;
}

/// Where a clearing request clears.
pub enum Region {
    Everything,
    /// A square of this side (m) round the robot (`true`), or all but it (`false`).
    RoundRobot(f64, bool),
    /// A square of this side (m) round the pose.
    RoundPose(Box<PoseStamped>, f64),
}

impl ClearRequest for ClearEntireCostmapRequest {
    const PREFIX: &'static str = "clear_entirely_";
    const TYPE: &'static str = "ClearEntireCostmap";
    fn asked(&self) -> String {
        "clear everything".into()
    }
    fn region(&self) -> Region {
        Region::Everything
    }
}

impl ClearRequest for ClearCostmapAroundRobotRequest {
    const PREFIX: &'static str = "clear_around_";
    const TYPE: &'static str = "ClearCostmapAroundRobot";
    fn asked(&self) -> String {
        format!("clear a {} m square round the robot", self.reset_distance)
    }
    fn region(&self) -> Region {
        Region::RoundRobot(f64::from(self.reset_distance), true)
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
    fn region(&self) -> Region {
        Region::RoundRobot(f64::from(self.reset_distance), false)
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
    fn region(&self) -> Region {
        Region::RoundPose(Box::new(self.pose.clone()), self.reset_distance)
    }
}

/// A clearing service of costmap `which` (see the module's comment): the obstacle layer cleared
/// where the request says and laid on the grid at once; answered in any case (the service has
/// no error to answer with), what was done or why nothing was logged.
pub async fn serve_clear<R: ClearRequest>(
    s: Arc<Shared>,
    which: Which,
    server: ServiceServer<R, ClearCostmapResponse>,
) {
    loop {
        let (id, request) = server.next_request().await;
        let name = server.name();
        match clear(&s, request.region()).await {
            Ok(Some(marked)) => info!(
                "{name}: asked to {}: done in the {}'s obstacle layer, {marked} cells seen \
                 occupied left",
                request.asked(),
                which.name()
            ),
            Ok(None) => info!(
                "{name}: asked to {}: nothing seen there to clear (the map, its inflation and \
                 the keepout filter are not layers costmap_2d clears)",
                request.asked()
            ),
            Err(why) => warn!("{name}: asked to {}: not done: {why}", request.asked()),
        }
        server.respond(id, ClearCostmapResponse::default()).await;
    }
}

/// Clears `region` of the obstacle layer; returns how many cells stay marked, `None` when
/// nothing was cleared.
async fn clear(s: &Arc<Shared>, region: Region) -> Result<Option<usize>, String> {
    let side_ok = |side: f64| {
        if side.is_finite() && side >= 0.0 {
            Ok(side)
        } else {
            Err(format!("reset_distance {side} is not a finite length"))
        }
    };
    // Where, before the layer is locked: a pose may wait for its transform.
    let square = match region {
        Region::Everything => None,
        Region::RoundRobot(side, inside) => {
            let side = side_ok(side)?;
            let robot = s.robot_pose().await.ok_or("the robot has no pose yet")?;
            Some((robot.position(), side, inside))
        }
        Region::RoundPose(pose, side) => {
            let side = side_ok(side)?;
            let at = s.pose_in_global(&pose).await.map_err(|f| f.message)?;
            Some((at.position(), side, true))
        }
    };
    let counts = s.clear_obstacles_off_thread(square).await?;
    Ok(counts
        .filter(|(before, after)| before != after)
        .map(|(_, after)| after))
}
