//! The obstacle layer's parameters, read as Nav2's global costmap has them: the layer's keys and
//! a block per observation source that `observation_sources` names.

use planner_core::grid::obstacle_layer::SourceRules;
use serde::{Deserialize, Serialize};
use serde_yaml::Value;
use std::collections::BTreeMap;

/// Nav2's ObstacleLayer, with its parameters as a global costmap's `obstacle_layer:` block has
/// them: the layer's own keys and `observation_sources`, a space-separated list of source
/// names, each with a block of its own (`scan: {topic: /scan, data_type: LaserScan, ...}`), so
/// a Nav2 user's block is read as it stands, a laser scanner and a depth camera together. Each
/// reading, placed through TF at its stamp, clears the cells its rays cross and marks the cells
/// its returns fall in; the marks are laid on the map as obstacles and inflated with it, so plans
/// go round what the robot sees (an open cabinet door, a trolley left in an aisle) and a path
/// being followed that a new obstacle blocks is planned again.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "ObstacleLayerBlock", into = "ObstacleLayerBlock")]
pub struct ObstacleLayerParams {
    /// Run the layer (when a reading arrives). Default true, as in Nav2's global costmap.
    pub enabled: bool,
    /// Clear the cells under the robot (its radius round its pose), so that a return off the
    /// robot's own body or off someone walking past does not leave it inside an obstacle
    /// (Nav2's `footprint_clearing_enabled`). Default true.
    pub footprint_clearing_enabled: bool,
    /// The layer's own heights (m, z in the global frame; Nav2's 0 and 2): a return a source
    /// keeps outside them clears its ray but is not marked.
    pub min_obstacle_height: f64,
    pub max_obstacle_height: f64,
    /// How often (Hz) what the readings changed is laid on the planning grid, which is then
    /// made again (Nav2's global costmap `update_frequency`, 1 Hz). Within 0.1..=20.
    pub update_frequency: f64,
    /// The observation sources, in `observation_sources`' order. Default: one, `scan`.
    pub sources: Vec<ObservationSource>,
}

/// One observation source of the obstacle layer: Nav2's keys of a source block. A key left out
/// takes the value nav2_params.yaml gives its `scan` source (marking and clearing, 0 to 2 m
/// high), not costmap_2d's code default (`clearing: false`, `max_obstacle_height: 0`, which
/// would keep nothing a sensor above the floor sees); the topic defaults to the source's name,
/// as in Nav2.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ObservationSource {
    /// Its name in `observation_sources` (the key of its block).
    #[serde(skip)]
    pub name: String,
    /// The readings' topic (best effort, as drivers publish them), in the node's namespace
    /// when relative. Default: the source's name.
    pub topic: String,
    /// What the topic carries (Nav2's `data_type`): `LaserScan` (default) or `PointCloud2` (a
    /// depth camera, a 3-D lidar).
    pub data_type: ObservationType,
    /// The sensor's frame, used instead of the readings' own `frame_id` when set (Nav2's
    /// `sensor_frame`). Default empty: the readings'.
    pub sensor_frame: String,
    /// Its returns mark their cells (Nav2's `marking`). Default true.
    pub marking: bool,
    /// Its rays clear the cells they cross (Nav2's `clearing`). Default true.
    pub clearing: bool,
    /// Returns lower or higher than these (m, their z in the global frame) are dropped: they
    /// neither clear nor mark (the floor and the ceiling). Default 0 and 2.
    pub min_obstacle_height: f64,
    pub max_obstacle_height: f64,
    /// Returns nearer than this are not marked (m). Default 0.
    pub obstacle_min_range: f64,
    /// Returns farther than this are not marked (m). Nav2's default 2.5.
    pub obstacle_max_range: f64,
    /// Cells nearer the sensor than this are not cleared (m). Default 0.
    pub raytrace_min_range: f64,
    /// Rays clear the cells they cross up to this far (m). Nav2's default 3. At most 50.
    pub raytrace_max_range: f64,
    /// An infinite range is "nothing up to the sensor's range" and clears (Nav2's
    /// `inf_is_valid`); otherwise it is no reading. Default false, as Nav2's.
    pub inf_is_valid: bool,
    /// How long (s) a reading is kept and applied again at each update (Nav2's
    /// `observation_persistence`): only 0, Nav2's default: each reading is applied once, as it
    /// comes, and what it marked stays until a ray clears it.
    pub observation_persistence: f64,
    /// How often (s) a reading should come (Nav2's `expected_update_rate`, a period despite
    /// its name): a source silent for longer is warned of in the log, once, until it speaks
    /// again. 0 (default): never.
    pub expected_update_rate: f64,
}

/// What an observation source's topic carries (Nav2's `data_type`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ObservationType {
    LaserScan,
    PointCloud2,
}

impl ObservationSource {
    /// A source named `name` with the defaults: its topic is its name.
    pub fn named(name: &str) -> Self {
        Self {
            name: name.to_owned(),
            topic: name.to_owned(),
            ..Self::default()
        }
    }

    /// How the layer reads this source's readings, the layer's heights with its own.
    pub fn rules(&self, layer: &ObstacleLayerParams) -> SourceRules {
        SourceRules {
            obstacle_min_range: self.obstacle_min_range,
            obstacle_max_range: self.obstacle_max_range,
            raytrace_min_range: self.raytrace_min_range,
            raytrace_max_range: self.raytrace_max_range,
            inf_is_valid: self.inf_is_valid,
            min_obstacle_height: self.min_obstacle_height,
            max_obstacle_height: self.max_obstacle_height,
            layer_min_obstacle_height: layer.min_obstacle_height,
            layer_max_obstacle_height: layer.max_obstacle_height,
            marking: self.marking,
            clearing: self.clearing,
        }
    }
}

impl Default for ObservationSource {
    /// nav2_params.yaml's `scan` source, on planner_core's [`SourceRules`] defaults.
    fn default() -> Self {
        let nav2 = SourceRules::default();
        Self {
            name: String::new(),
            topic: String::new(),
            data_type: ObservationType::LaserScan,
            sensor_frame: String::new(),
            marking: nav2.marking,
            clearing: nav2.clearing,
            min_obstacle_height: nav2.min_obstacle_height,
            max_obstacle_height: nav2.max_obstacle_height,
            obstacle_min_range: nav2.obstacle_min_range,
            obstacle_max_range: nav2.obstacle_max_range,
            raytrace_min_range: nav2.raytrace_min_range,
            raytrace_max_range: nav2.raytrace_max_range,
            inf_is_valid: nav2.inf_is_valid,
            observation_persistence: 0.0,
            expected_update_rate: 0.0,
        }
    }
}

impl Default for ObstacleLayerParams {
    /// Nav2's global costmap's obstacle layer, with nav2_params.yaml's one `scan` source.
    fn default() -> Self {
        let nav2 = SourceRules::default();
        Self {
            enabled: true,
            footprint_clearing_enabled: true,
            min_obstacle_height: nav2.layer_min_obstacle_height,
            max_obstacle_height: nav2.layer_max_obstacle_height,
            update_frequency: 1.0,
            sources: vec![ObservationSource::named("scan")],
        }
    }
}

/// The most observation sources the layer reads: each is a subscription and a task.
pub const MAX_OBSERVATION_SOURCES: usize = 16;

/// The layer's own keys ([`ObstacleLayerBlock`]'s fields): every other key of the block is a
/// source's, and no source may be named like one of these.
const LAYER_KEYS: [&str; 7] = [
    "plugin",
    "enabled",
    "observation_sources",
    "footprint_clearing_enabled",
    "min_obstacle_height",
    "max_obstacle_height",
    "update_frequency",
];

/// The Nav2 plugin an `obstacle_layer.plugin` may name: the layer this node runs.
const OBSTACLE_LAYER_PLUGIN: &str = "nav2_costmap_2d::ObstacleLayer";

/// `obstacle_layer:` as written: the layer's keys, and the source blocks under the names
/// `observation_sources` lists, which [`ObstacleLayerParams`] is read from and written back to
/// (so `ros2 param get /patrol_planner obstacle_layer.scan.topic` answers, as Nav2's does).
#[derive(Serialize, Deserialize)]
#[serde(default)]
struct ObstacleLayerBlock {
    /// Nav2's `plugin` key, accepted when it names the ObstacleLayer.
    #[serde(skip_serializing_if = "String::is_empty")]
    plugin: String,
    enabled: bool,
    observation_sources: String,
    footprint_clearing_enabled: bool,
    min_obstacle_height: f64,
    max_obstacle_height: f64,
    update_frequency: f64,
    /// The source blocks, and any other key (refused).
    #[serde(flatten)]
    blocks: BTreeMap<String, Value>,
}

impl Default for ObstacleLayerBlock {
    fn default() -> Self {
        ObstacleLayerParams::default().into()
    }
}

impl From<ObstacleLayerParams> for ObstacleLayerBlock {
    fn from(p: ObstacleLayerParams) -> Self {
        let names: Vec<&str> = p.sources.iter().map(|s| s.name.as_str()).collect();
        Self {
            plugin: String::new(),
            enabled: p.enabled,
            observation_sources: names.join(" "),
            footprint_clearing_enabled: p.footprint_clearing_enabled,
            min_obstacle_height: p.min_obstacle_height,
            max_obstacle_height: p.max_obstacle_height,
            update_frequency: p.update_frequency,
            blocks: p
                .sources
                .iter()
                .map(|s| (s.name.clone(), serde_yaml::to_value(s).unwrap_or_default()))
                .collect(),
        }
    }
}

impl TryFrom<ObstacleLayerBlock> for ObstacleLayerParams {
    type Error = String;

    /// Each name in `observation_sources` read from its block (the defaults where it has
    /// none); a name twice, a block no name lists or a key of neither kind is refused by name.
    fn try_from(mut b: ObstacleLayerBlock) -> Result<Self, String> {
        if !b.plugin.is_empty() && b.plugin != OBSTACLE_LAYER_PLUGIN {
            return Err(format!(
                "obstacle_layer.plugin `{}`: this node runs `{OBSTACLE_LAYER_PLUGIN}` only",
                b.plugin
            ));
        }
        let names: Vec<&str> = b.observation_sources.split_whitespace().collect();
        if names.len() > MAX_OBSERVATION_SOURCES {
            return Err(format!(
                "obstacle_layer.observation_sources: {} sources, at most {MAX_OBSERVATION_SOURCES}",
                names.len()
            ));
        }
        let mut sources: Vec<ObservationSource> = Vec::with_capacity(names.len());
        for name in &names {
            if LAYER_KEYS.contains(name) {
                return Err(format!(
                    "obstacle_layer.observation_sources names `{name}`, a key of the layer's own: name the source otherwise"
                ));
            }
            if sources.iter().any(|s| s.name == *name) {
                return Err(format!(
                    "obstacle_layer.observation_sources names `{name}` twice"
                ));
            }
            let source = match b.blocks.remove(*name) {
                None => ObservationSource::named(name),
                Some(block) => {
                    let mut source: ObservationSource = serde_yaml::from_value(block)
                        .map_err(|e| format!("obstacle_layer.{name}: {e}"))?;
                    source.name = (*name).to_owned();
                    if source.topic.is_empty() {
                        source.topic = (*name).to_owned();
                    }
                    source
                }
            };
            sources.push(source);
        }
        if let Some(key) = b.blocks.keys().next() {
            return Err(format!(
                "unknown parameter `obstacle_layer.{key}`: neither a key of the layer ({}) nor a source `observation_sources` names (`{}`)",
                LAYER_KEYS.join(", "),
                b.observation_sources
            ));
        }
        Ok(Self {
            enabled: b.enabled,
            footprint_clearing_enabled: b.footprint_clearing_enabled,
            min_obstacle_height: b.min_obstacle_height,
            max_obstacle_height: b.max_obstacle_height,
            update_frequency: b.update_frequency,
            sources,
        })
    }
}

impl ObstacleLayerParams {
    /// Ranges, heights and rates within bounds (the layer's, then each source's, named).
    pub fn validate(&self) -> Result<(), String> {
        let within = |v: f64, lo: f64, hi: f64| (lo..=hi).contains(&v);
        if !within(self.update_frequency, 0.1, 20.0)
            || !within(self.min_obstacle_height, -100.0, self.max_obstacle_height)
            || !within(self.max_obstacle_height, -100.0, 100.0)
        {
            return Err("obstacle_layer: heights within +-100 m, min at most max, update_frequency within 0.1..=20 Hz".into());
        }
        for source in &self.sources {
            if !within(source.obstacle_min_range, 0.0, source.obstacle_max_range)
                || !within(source.obstacle_max_range, 0.0, 50.0)
                || !within(source.raytrace_min_range, 0.0, source.raytrace_max_range)
                || !within(source.raytrace_max_range, 0.0, 50.0)
                || !within(
                    source.min_obstacle_height,
                    -100.0,
                    source.max_obstacle_height,
                )
                || !within(source.max_obstacle_height, -100.0, 100.0)
                || !within(source.expected_update_rate, 0.0, 3_600.0)
            {
                return Err(format!("obstacle_layer.{}: ranges from 0 to at most 50 m, heights within +-100 m, each min at most its max, expected_update_rate within 0..=3600 s", source.name));
            }
            if source.observation_persistence != 0.0 {
                return Err(format!("obstacle_layer.{}.observation_persistence: only 0 (Nav2's default: each reading applied once, as it comes), not {}", source.name, source.observation_persistence));
            }
            if source.topic.is_empty() {
                return Err(format!("obstacle_layer.{}.topic: a topic", source.name));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`LAYER_KEYS`] are the block's own fields, written out in full (with a plugin named).
    #[test]
    fn the_layer_keys_are_the_blocks_fields() {
        let mut block = ObstacleLayerBlock::from(ObstacleLayerParams {
            sources: vec![],
            ..ObstacleLayerParams::default()
        });
        block.plugin = OBSTACLE_LAYER_PLUGIN.into();
        let written = ros_parameters::field_names(&block);
        let mut keys: Vec<&str> = written.iter().map(String::as_str).collect();
        let mut expected = LAYER_KEYS.to_vec();
        keys.sort_unstable();
        expected.sort_unstable();
        assert_eq!(keys, expected);
    }
}
