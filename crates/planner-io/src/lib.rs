//! File loading for patrol-planner: the thin I/O edge around planner-core's parsers, shared by
//! the CLI and the node so both read maps, scenarios and parameters the same way, and name a
//! failed plan the same way ([`result_code`]).

pub mod parameters;
pub mod result_code;

use planner_core::config::PlannerConfig;
use planner_core::grid::parsers::map_server::MapYaml;
use planner_core::grid::parsers::movingai::{self, MovingAiMap, MovingAiScenario};
use planner_core::grid::parsers::scenarios::ScenarioFile;
use planner_core::grid::{GridMap, MapError};
use std::path::{Path, PathBuf};

/// Everything that can go wrong loading a file, with the path in the message. The reason is
/// part of the message and not also the error's `source()`, so a chain printer (anyhow's
/// `{:#}`) says it once.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    #[error("{path}: {reason}")]
    Io {
        path: PathBuf,
        reason: std::io::Error,
    },
    #[error("{path}: {reason}")]
    Map { path: PathBuf, reason: MapError },
    /// A map_server map whose image (or what its YAML says of it) is at fault: both files named.
    #[error("{yaml} (image {image}): {reason}")]
    MapImage {
        yaml: PathBuf,
        image: PathBuf,
        reason: String,
    },
    #[error("{path}: {message}")]
    Config { path: PathBuf, message: String },
    /// Parameters merged from several sources (parameter files, `-p` overrides), named together
    /// (`a.yaml + b.yaml + -p`), as the merged block is at fault rather than one file.
    #[error("{sources}: {message}")]
    Parameters { sources: String, message: String },
}

/// A parameter file's error as the loaders give it: a file at fault names the file (`Io`,
/// `Config`); values merged from several sources name them all (`Parameters`).
impl From<ros_parameters::ParameterError> for LoadError {
    fn from(e: ros_parameters::ParameterError) -> Self {
        use ros_parameters::ParameterError as P;
        match e {
            P::Io { path, error } => LoadError::Io {
                path,
                reason: error,
            },
            P::File { path, message }
            | P::Values {
                only_file: Some(path),
                message,
                ..
            } => LoadError::Config { path, message },
            P::Values {
                sources, message, ..
            } => LoadError::Parameters { sources, message },
        }
    }
}

/// The largest file read (bytes): a map of the cell cap (100 M cells) as a 16-bit PGM is 200 MB.
/// Anything larger, or anything that is not a regular file (`/dev/zero`, a FIFO), is refused
/// before it is read, so no file can exhaust memory.
pub const MAX_FILE_BYTES: u64 = 256 << 20;

/// A whole input file, refused before it is read when it is not a regular file or is larger
/// than [`MAX_FILE_BYTES`]; every loader here reads through it, and so should any other.
pub fn read(path: &Path) -> Result<Vec<u8>, LoadError> {
    input_guard::read_file(path, MAX_FILE_BYTES).map_err(|reason| LoadError::Io {
        path: path.to_owned(),
        reason,
    })
}

fn map_err(path: &Path) -> impl FnOnce(MapError) -> LoadError + '_ {
    move |reason| LoadError::Map {
        path: path.to_owned(),
        reason,
    }
}

/// A map_server map: the YAML, then its image (relative to the YAML's folder unless absolute).
pub fn load_map_server(yaml_path: &Path) -> Result<GridMap, LoadError> {
    let yaml = MapYaml::parse(&read(yaml_path)?).map_err(map_err(yaml_path))?;
    let image_path = yaml_path
        .parent()
        .unwrap_or(Path::new("."))
        .join(&yaml.image);
    let in_image = |reason: String| LoadError::MapImage {
        yaml: yaml_path.to_owned(),
        image: image_path.clone(),
        reason,
    };
    let image = read(&image_path).map_err(|e| match e {
        LoadError::Io { reason, .. } => in_image(reason.to_string()),
        other => other,
    })?;
    yaml.decode(&image).map_err(|e| in_image(e.to_string()))
}

/// A Moving AI `.map` file.
pub fn load_movingai_map(path: &Path) -> Result<MovingAiMap, LoadError> {
    MovingAiMap::parse(&read(path)?).map_err(map_err(path))
}

/// A Moving AI `.scen` file.
pub fn load_movingai_scenarios(path: &Path) -> Result<Vec<MovingAiScenario>, LoadError> {
    movingai::parse_scenarios(&read(path)?).map_err(map_err(path))
}

/// Any map users give us: `.map` is Moving AI (1 m cells), anything else map_server YAML.
pub fn load_map(path: &Path) -> Result<GridMap, LoadError> {
    if path.extension().is_some_and(|e| e == "map") {
        Ok(load_movingai_map(path)?.grid)
    } else {
        load_map_server(path)
    }
}

/// A bench scenario file, with the path of the map it names.
pub fn load_scenario_file(path: &Path) -> Result<(ScenarioFile, PathBuf), LoadError> {
    let file = ScenarioFile::parse(&read(path)?).map_err(map_err(path))?;
    let map_path = path.parent().unwrap_or(Path::new(".")).join(&file.map);
    Ok((file, map_path))
}

/// The planning part of a parameter file, validated: the `patrol_planner` block's planning keys.
/// The node's own keys are accepted (the CLI reads the node's file), any other key is an error
/// naming it (see [`parameters::load_parameter_file`]).
pub fn load_planner_config(path: &Path) -> Result<PlannerConfig, LoadError> {
    Ok(parameters::load_parameter_file(path)?.planning)
}
