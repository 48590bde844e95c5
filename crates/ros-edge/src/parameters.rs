//! ROS 2 parameter files (the layout `--params-file` takes and Nav2 uses), read straight into a
//! binary's own parameter struct:
//!
//! ```yaml
//! chassis_bridge:
//!   ros__parameters:
//!     backend: sim
//!     limits:
//!       max_linear: 0.6
//! ```
//!
//! Only `<node_name>: ros__parameters:` is read; other nodes' blocks (one file may configure a
//! whole launch) and other keys beside `ros__parameters` are skipped unread. The block is
//! deserialized from the file's text, not from a parsed tree, so an error says where: the file,
//! the key path and the line, as in
//!
//! ```text
//! config/chassis.yaml: chassis_bridge.ros__parameters: unknown field `backnd`, expected one of
//! `backend`, ... at line 8 column 5
//! ```
//!
//! A struct with `#[serde(deny_unknown_fields)]` thereby turns a typo into such an error.

use serde::de::{self, DeserializeOwned, DeserializeSeed, IgnoredAny, MapAccess, Visitor};
use std::fmt;
use std::marker::PhantomData;
use std::path::{Path, PathBuf};

/// Why a parameter file could not be read; every message starts with the file's path. The
/// message is whole: the underlying error is in it, not chained as a `source` (which `{:#}`
/// would print a second time).
#[derive(Debug, thiserror::Error)]
pub enum ParameterError {
    #[error("{}: {error}", path.display())]
    Io {
        path: PathBuf,
        error: std::io::Error,
    },
    /// Not YAML, or the block does not fit the parameter struct (the message names the key).
    #[error("{}: {error}", path.display())]
    Yaml {
        path: PathBuf,
        error: serde_yaml::Error,
    },
    #[error("{}: no `{node_name}: ros__parameters:` block", path.display())]
    NoBlock { path: PathBuf, node_name: String },
    /// YAML nested deeper or indented wider than a parameter file needs (the parser would
    /// take minutes on it).
    #[error("{}: {reason}", path.display())]
    TooDeep { path: PathBuf, reason: String },
}

/// The largest parameter file read (bytes): these files are a few kilobytes.
pub const MAX_PARAMETER_FILE_BYTES: u64 = input_guard::yaml::MAX_YAML_BYTES as u64;

/// The `<node_name>: ros__parameters:` block of the parameter file at `path`, as a `T`. The
/// file is read through input-guard: a FIFO, a device or a file over
/// [`MAX_PARAMETER_FILE_BYTES`] is refused before it is read, and text nested too deep before it
/// is parsed.
pub fn read<T: DeserializeOwned>(path: &Path, node_name: &str) -> Result<T, ParameterError> {
    let text = input_guard::read_file(path, MAX_PARAMETER_FILE_BYTES).map_err(|error| {
        ParameterError::Io {
            path: path.to_owned(),
            error,
        }
    })?;
    input_guard::yaml::check(&text).map_err(|reason| ParameterError::TooDeep {
        path: path.to_owned(),
        reason,
    })?;
    from_slice(&text, node_name)
        .map_err(|error| ParameterError::Yaml {
            path: path.to_owned(),
            error,
        })?
        .ok_or_else(|| ParameterError::NoBlock {
            path: path.to_owned(),
            node_name: node_name.to_owned(),
        })
}

/// The block of `node_name` in a parameter file's text; `None` when the file has none.
fn from_slice<T: DeserializeOwned>(
    text: &[u8],
    node_name: &str,
) -> Result<Option<T>, serde_yaml::Error> {
    File {
        node_name,
        block: PhantomData,
    }
    .deserialize(serde_yaml::Deserializer::from_slice(text))
}

/// The whole file: a mapping from node names to their blocks (or an empty document).
struct File<'a, T> {
    node_name: &'a str,
    block: PhantomData<T>,
}

impl<'de, T: DeserializeOwned> DeserializeSeed<'de> for File<'_, T> {
    type Value = Option<T>;

    fn deserialize<D: de::Deserializer<'de>>(self, d: D) -> Result<Option<T>, D::Error> {
        d.deserialize_any(self)
    }
}

impl<'de, T: DeserializeOwned> Visitor<'de> for File<'_, T> {
    type Value = Option<T>;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        write!(
            f,
            "a ROS 2 parameter file (node names to ros__parameters blocks)"
        )
    }

    /// An empty file (or one of comments only).
    fn visit_none<E: de::Error>(self) -> Result<Option<T>, E> {
        Ok(None)
    }

    fn visit_unit<E: de::Error>(self) -> Result<Option<T>, E> {
        Ok(None)
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Option<T>, A::Error> {
        let mut found = None;
        while let Some(key) = map.next_key::<String>()? {
            if key != self.node_name {
                map.next_value::<IgnoredAny>()?;
            } else if found.is_some() {
                return Err(de::Error::custom(format_args!(
                    "`{}` appears twice",
                    self.node_name
                )));
            } else {
                found = Some(map.next_value_seed(Node(PhantomData))?);
            }
        }
        Ok(found.flatten())
    }
}

/// One node's entry: `ros__parameters` and anything else beside it (skipped).
struct Node<T>(PhantomData<T>);

impl<'de, T: DeserializeOwned> DeserializeSeed<'de> for Node<T> {
    type Value = Option<T>;

    fn deserialize<D: de::Deserializer<'de>>(self, d: D) -> Result<Option<T>, D::Error> {
        d.deserialize_any(self)
    }
}

impl<'de, T: DeserializeOwned> Visitor<'de> for Node<T> {
    type Value = Option<T>;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        write!(f, "a node's entry with a ros__parameters block")
    }

    /// `node_name:` with nothing under it.
    fn visit_none<E: de::Error>(self) -> Result<Option<T>, E> {
        Ok(None)
    }

    fn visit_unit<E: de::Error>(self) -> Result<Option<T>, E> {
        Ok(None)
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Option<T>, A::Error> {
        let mut block = None;
        while let Some(key) = map.next_key::<String>()? {
            if key != "ros__parameters" {
                map.next_value::<IgnoredAny>()?;
            } else if block.is_some() {
                return Err(de::Error::custom("`ros__parameters` appears twice"));
            } else {
                block = Some(map.next_value::<T>()?);
            }
        }
        Ok(block)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde::Deserialize;

    #[derive(Debug, PartialEq, Deserialize)]
    #[serde(deny_unknown_fields, default)]
    struct Params {
        backend: String,
        rate_hz: f64,
        limits: Limits,
    }

    #[derive(Debug, PartialEq, Deserialize)]
    #[serde(deny_unknown_fields, default)]
    struct Limits {
        max_linear: f64,
        max_angular: f64,
    }

    impl Default for Params {
        fn default() -> Self {
            Self {
                backend: "sim".into(),
                rate_hz: 50.0,
                limits: Limits::default(),
            }
        }
    }

    impl Default for Limits {
        fn default() -> Self {
            Self {
                max_linear: 0.6,
                max_angular: 0.4,
            }
        }
    }

    /// A parameter file with `text` in it, removed when dropped.
    struct TempFile(PathBuf);

    impl TempFile {
        fn new(name: &str, text: &str) -> Self {
            let path = std::env::temp_dir().join(format!(
                "ros-edge-parameters-{}-{name}.yaml",
                std::process::id()
            ));
            std::fs::write(&path, text).expect("writing a temporary file");
            Self(path)
        }
    }

    impl Drop for TempFile {
        fn drop(&mut self) {
            let _ = std::fs::remove_file(&self.0);
        }
    }

    #[test]
    fn a_well_formed_block_reads_and_other_nodes_are_skipped() {
        let file = TempFile::new(
            "good",
            "# a launch's parameters\n\
             patrol_planner:\n  ros__parameters:\n    backend: [not, for, us]\n\
             chassis_bridge:\n  ros__parameters:\n    backend: serial\n    limits:\n      max_linear: 0.3\n\
             amcl:\n  ros__parameters:\n    anything: 1\n",
        );
        let p: Params = read(&file.0, "chassis_bridge").unwrap();
        assert_eq!(
            p,
            Params {
                backend: "serial".into(),
                rate_hz: 50.0,
                limits: Limits {
                    max_linear: 0.3,
                    max_angular: 0.4
                },
            }
        );
    }

    #[test]
    fn a_typo_at_the_top_level_is_refused_naming_the_key_and_the_file() {
        let file = TempFile::new(
            "typo",
            "chassis_bridge:\n  ros__parameters:\n    backnd: serial\n    rate_hz: 20.0\n",
        );
        let e = read::<Params>(&file.0, "chassis_bridge").unwrap_err();
        assert!(matches!(e, ParameterError::Yaml { .. }), "{e:?}");
        let message = e.to_string();
        assert!(
            message.starts_with(&format!("{}: ", file.0.display())),
            "{message}"
        );
        assert!(message.contains("unknown field `backnd`"), "{message}");
        assert!(message.contains("line 3"), "{message}");
    }

    #[test]
    fn a_bad_value_in_a_section_names_its_key_path() {
        let file = TempFile::new(
            "section",
            "chassis_bridge:\n  ros__parameters:\n    limits:\n      max_linear: fast\n",
        );
        let message = read::<Params>(&file.0, "chassis_bridge")
            .unwrap_err()
            .to_string();
        assert!(
            message.contains(&file.0.display().to_string())
                && message.contains("chassis_bridge.ros__parameters.limits.max_linear"),
            "{message}"
        );
        // And a typo inside a section too.
        let file = TempFile::new(
            "section-typo",
            "chassis_bridge:\n  ros__parameters:\n    limits:\n      max_linaer: 0.3\n",
        );
        let message = read::<Params>(&file.0, "chassis_bridge")
            .unwrap_err()
            .to_string();
        assert!(message.contains("unknown field `max_linaer`"), "{message}");
    }

    #[test]
    fn a_missing_block_or_file_names_the_file() {
        let file = TempFile::new("other", "patrol_planner:\n  ros__parameters:\n    x: 1\n");
        let e = read::<Params>(&file.0, "chassis_bridge").unwrap_err();
        assert!(matches!(e, ParameterError::NoBlock { .. }), "{e:?}");
        assert_eq!(
            e.to_string(),
            format!(
                "{}: no `chassis_bridge: ros__parameters:` block",
                file.0.display()
            )
        );
        for (name, text) in [
            ("empty", ""),
            ("comments", "# nothing yet\n"),
            ("bare", "chassis_bridge:\n"),
        ] {
            let file = TempFile::new(name, text);
            let result = read::<Params>(&file.0, "chassis_bridge");
            assert!(
                matches!(result, Err(ParameterError::NoBlock { .. })),
                "{name}: {result:?}"
            );
        }
        let gone = std::env::temp_dir().join("ros-edge-parameters-no-such-file.yaml");
        let e = read::<Params>(&gone, "chassis_bridge").unwrap_err();
        assert!(matches!(e, ParameterError::Io { .. }), "{e:?}");
        assert!(e.to_string().starts_with(&gone.display().to_string()));
    }

    /// The chassis bridge's file is read as the planner's are: a device or a FIFO (which would
    /// block the bridge's start for ever) is refused unread, and text nested 50 000 levels deep
    /// (seconds to minutes in the parser) is refused before it is parsed.
    #[test]
    fn a_device_or_deeply_nested_text_is_refused_before_parsing() {
        let e = read::<Params>(Path::new("/dev/zero"), "chassis_bridge").unwrap_err();
        assert!(matches!(e, ParameterError::Io { .. }), "{e:?}");
        assert!(e.to_string().contains("not a regular file"), "{e}");
        let deep = format!(
            "chassis_bridge:\n  ros__parameters:\n    limits: {}1{}\n",
            "[".repeat(50_000),
            "]".repeat(50_000)
        );
        let file = TempFile::new("deep", &deep);
        let e = read::<Params>(&file.0, "chassis_bridge").unwrap_err();
        assert!(matches!(e, ParameterError::TooDeep { .. }), "{e:?}");
        assert!(e.to_string().contains("nested deeper"), "{e}");
    }
}
