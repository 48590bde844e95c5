//! The node as its own map server, when it loads its map itself (`map_yaml`): the map latched on
//! `/map`, map_server's `map_server/load_map` (nav2_msgs/srv/LoadMap), which
//! nav2_simple_commander's `changeMap()` calls to switch maps (another floor of a substation,
//! another equipment room) without restarting anything, and `map_server/map`
//! (nav_msgs/srv/GetMap), which hands the map to whoever asks for it rather than subscribing
//! (`ros2 service call`, tools, a localizer started late).
//!
//! A map is read, made the planning grid, and only then published and answered: a file that
//! cannot be read, or a map the node cannot plan on, is refused with map_server's result code
//! and the reason in the log, and the current map stays, on `/map` and for planning. A goal
//! being driven is checked against the new map as against any new `/map` (inputs.rs): planned
//! again if the map blocks the rest of its path.
//!
//! With a Nav2 stack's map_server running, `map_yaml` is empty and none of this is served, so
//! that only one node answers `load_map`.

use crate::convert;
use crate::inputs::replan_if_blocked;
use crate::planning::install_map;
use crate::state::{GoalSlot, Shared};
use log::{info, warn};
use patrol_msgs::nav2_msgs::{LoadMapRequest, LoadMapResponse};
use patrol_msgs::nav_msgs::{GetMapRequest, GetMapResponse, OccupancyGrid};
use planner_io::LoadError;
use ros2_client::Publisher;
use ros_edge::service::ServiceServer;
use std::path::Path;
use std::sync::{Arc, RwLock};
use tokio::sync::watch;

/// What the node serves as map server: the publisher latching `/map`, and the map it last
/// latched there, which `map_server/map` answers with.
pub struct MapServer {
    pub map_pub: Arc<Publisher<OccupancyGrid>>,
    served: RwLock<Option<OccupancyGrid>>,
}

impl MapServer {
    pub fn new(map_pub: Arc<Publisher<OccupancyGrid>>) -> Self {
        Self {
            map_pub,
            served: RwLock::new(None),
        }
    }

    /// The map last latched on `/map`, if one has been.
    fn served(&self) -> Option<OccupancyGrid> {
        self.served.read().expect("lock").clone()
    }
}

/// Why a map was not loaded: map_server's result code (LoadMap's `RESULT_*`) and the reason.
#[derive(Debug)]
pub struct Refused {
    pub result: u8,
    pub reason: String,
}

/// The LoadMap result code for a map file that could not be loaded, by LoadMap's definitions:
/// the YAML not there (or not a readable regular file: 1), its fields wrong (3), its image (2).
/// map_server itself answers 3 for a YAML that is not there too (its YAML parser's exception):
/// any code but 0 is a failure to nav2_simple_commander's changeMap(), and 1 says which.
fn result_code(e: &LoadError) -> u8 {
    match e {
        LoadError::Io { .. } => LoadMapResponse::RESULT_MAP_DOES_NOT_EXIST,
        LoadError::Map { .. } => LoadMapResponse::RESULT_INVALID_MAP_METADATA,
        LoadError::MapImage { .. } => LoadMapResponse::RESULT_INVALID_MAP_DATA,
        LoadError::Config { .. } | LoadError::Parameters { .. } => {
            LoadMapResponse::RESULT_UNDEFINED_FAILURE
        }
    }
}

/// The file a LoadMap `map_url` names: a path, as map_server takes it (a leading `~/` is the
/// `home` directory, as map_server expands it), or a `file://` URL (the form LoadMap's
/// definition shows). `package://` URLs are not resolved (map_server does not either): refused
/// as a map that does not exist, with the reason.
fn file_of(map_url: &str, home: Option<&str>) -> Result<String, Refused> {
    let path = map_url.strip_prefix("file://").unwrap_or(map_url);
    if path.is_empty() || path.contains("://") {
        return Err(Refused {
            result: LoadMapResponse::RESULT_MAP_DOES_NOT_EXIST,
            reason: format!("`{map_url}` is not a map file: give a path to a map YAML"),
        });
    }
    Ok(match (path.strip_prefix("~/"), home) {
        (Some(rest), Some(home)) => format!("{}/{rest}", home.trim_end_matches('/')),
        _ => path.to_owned(),
    })
}

/// Who asks for a map.
pub enum Asked<'a> {
    /// The node, starting, for `map_yaml`: a map it can read is latched on `/map` even if it
    /// cannot plan on it (AMCL and RViz still need it; the log says why planning waits).
    Startup,
    /// A `load_map` request: a map the node cannot plan on is refused, and the current map
    /// stays, on `/map` too. The goal slot takes a replan the new map makes necessary.
    Request(&'a watch::Sender<GoalSlot>),
}

/// Loads the map_server map at `path` (off the async threads), makes it the planning grid
/// (unless the node plans on a costmap topic) and latches it on `/map`; returns the message.
/// Refused, nothing changes (but see [`Asked::Startup`]).
pub async fn load(
    s: &Arc<Shared>,
    server: &MapServer,
    path: &str,
    asked: Asked<'_>,
) -> Result<OccupancyGrid, Refused> {
    let file = path.to_owned();
    let loaded =
        tokio::task::spawn_blocking(move || planner_io::load_map_server(Path::new(&file))).await;
    let map = match loaded {
        Ok(Ok(map)) => map,
        Ok(Err(e)) => {
            return Err(Refused {
                result: result_code(&e),
                reason: e.to_string(),
            })
        }
        Err(e) => {
            return Err(Refused {
                result: LoadMapResponse::RESULT_UNDEFINED_FAILURE,
                reason: format!("the map task failed: {e}"),
            })
        }
    };
    let msg = convert::msg_from_grid(&map, &s.params.global_frame, ros_edge::now());
    // With a costmap topic the costmap is the planning grid (inputs.rs); the map is only served.
    if s.params.costmap_topic.is_empty() {
        match (install_map(s, map, path, log::Level::Info).await, asked) {
            (Some(state), Asked::Request(slot)) => {
                replan_if_blocked(s, slot, &state, "the loaded map", log::Level::Info)
            }
            (Some(_), Asked::Startup) => {}
            (None, Asked::Request(_)) => {
                return Err(Refused {
                    result: LoadMapResponse::RESULT_INVALID_MAP_DATA,
                    reason: "the node cannot plan on it (the log says why)".into(),
                })
            }
            (None, Asked::Startup) => warn!("{path}: served on /map, but not planned on"),
        }
    }
    *server.served.write().expect("lock") = Some(msg.clone());
    if let Err(e) = server.map_pub.async_publish(msg.clone()).await {
        warn!("publishing the map on /map: {e:?}");
    }
    Ok(msg)
}

/// `map_server/load_map` (nav2_msgs/srv/LoadMap), as map_server serves it: the map at
/// `map_url` loaded, planned on and latched on `/map`, and returned with `RESULT_SUCCESS`; a
/// map that cannot be loaded gets its result code (the reason in the log) and the current map
/// stays. While the node is not active, `RESULT_UNDEFINED_FAILURE`, as map_server answers.
pub async fn serve_load_map(
    s: Arc<Shared>,
    map_server: Arc<MapServer>,
    server: ServiceServer<LoadMapRequest, LoadMapResponse>,
    slot: watch::Sender<GoalSlot>,
) {
    loop {
        let (id, request) = server.next_request().await;
        let home = std::env::var("HOME").ok();
        let answer = match (s.refusal(), file_of(&request.map_url, home.as_deref())) {
            (Some(f), _) => Err(Refused {
                result: LoadMapResponse::RESULT_UNDEFINED_FAILURE,
                reason: f.message,
            }),
            (None, Err(refused)) => Err(refused),
            (None, Ok(path)) => load(&s, &map_server, &path, Asked::Request(&slot)).await,
        };
        let response = match answer {
            Ok(map) => {
                info!("load_map: {} now the map", request.map_url);
                LoadMapResponse {
                    map,
                    result: LoadMapResponse::RESULT_SUCCESS,
                }
            }
            Err(refused) => {
                warn!(
                    "load_map `{}` refused ({}), keeping the current map: {}",
                    request.map_url, refused.result, refused.reason
                );
                LoadMapResponse {
                    map: OccupancyGrid::default(),
                    result: refused.result,
                }
            }
        };
        server.respond(id, response).await;
    }
}

/// `map_server/map` (nav_msgs/srv/GetMap), as map_server serves it: the map last latched on
/// `/map` (the one loaded at startup or by `load_map`). While the node is not active, or before
/// any map loaded, an empty map, with the reason in the log (map_server answers an inactive
/// request with an empty response too; GetMap has no field to say why).
pub async fn serve_get_map(
    s: Arc<Shared>,
    map_server: Arc<MapServer>,
    server: ServiceServer<GetMapRequest, GetMapResponse>,
) {
    loop {
        let (id, _) = server.next_request().await;
        let map = match (s.refusal(), map_server.served()) {
            (Some(f), _) => {
                warn!("map_server/map: answered with an empty map: {}", f.message);
                OccupancyGrid::default()
            }
            (None, None) => {
                warn!("map_server/map: answered with an empty map: no map loaded (map_yaml)");
                OccupancyGrid::default()
            }
            (None, Some(map)) => map,
        };
        server.respond(id, GetMapResponse { map }).await;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn map_urls_are_paths_or_file_urls() {
        let home = Some("/home/patrol/");
        assert_eq!(file_of("/maps/f.yaml", home).unwrap(), "/maps/f.yaml");
        assert_eq!(
            file_of("file:///maps/f.yaml", home).unwrap(),
            "/maps/f.yaml"
        );
        assert_eq!(file_of("maps/f.yaml", home).unwrap(), "maps/f.yaml");
        assert_eq!(
            file_of("~/maps/f.yaml", home).unwrap(),
            "/home/patrol/maps/f.yaml"
        );
        assert_eq!(file_of("~/maps/f.yaml", None).unwrap(), "~/maps/f.yaml");
        for bad in [
            "",
            "file://",
            "package://patrol/maps/f.yaml",
            "http://x/m.yaml",
        ] {
            let refused = file_of(bad, home).unwrap_err();
            assert_eq!(
                refused.result,
                LoadMapResponse::RESULT_MAP_DOES_NOT_EXIST,
                "{bad}"
            );
        }
    }

    #[test]
    fn load_errors_get_map_servers_result_codes() {
        let dir = std::env::temp_dir().join(format!("patrol_load_map_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let code = |yaml: &str| {
            let path = dir.join("m.yaml");
            std::fs::write(&path, yaml).unwrap();
            result_code(&planner_io::load_map_server(&path).unwrap_err())
        };
        let missing = planner_io::load_map_server(&dir.join("absent.yaml")).unwrap_err();
        assert_eq!(
            result_code(&missing),
            LoadMapResponse::RESULT_MAP_DOES_NOT_EXIST
        );
        assert_eq!(
            code("image: m.pgm\nresolution: -1\norigin: [0, 0, 0]\n"),
            LoadMapResponse::RESULT_INVALID_MAP_METADATA
        );
        std::fs::write(dir.join("m.pgm"), b"P5\n2 2\n255\n\x00").unwrap();
        assert_eq!(
            code("image: m.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n"),
            LoadMapResponse::RESULT_INVALID_MAP_DATA,
            "a truncated image"
        );
        assert_eq!(
            code("image: gone.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n"),
            LoadMapResponse::RESULT_INVALID_MAP_DATA,
            "an image that is not there"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
