//! ROS 2 parameters as rcl reads them off a command line and rclcpp applies them, for every
//! binary here (patrol_planner through planner-io, chassis_bridge): parameter files in the
//! layout `--params-file` takes and Nav2 uses,
//!
//! ```yaml
//! chassis_bridge:
//!   ros__parameters:
//!     backend: sim
//!     limits: {max_linear: 0.5}
//! /**:
//!   ros__parameters:
//!     use_sim_time: true
//! ```
//!
//! and `-p [node:]name:=value` rules. launch_ros passes one `--params-file` per entry of a Node's
//! `parameters=[...]` (a dict such as `{'use_sim_time': True}` becomes a file of its own), and
//! `ros2 run ... -p name:=value` is how users set one value, so a binary that read only its
//! first file would lose a launch's settings without a word.
//!
//! rclcpp's precedence (rclcpp#1094, launch_ros' Node documentation; rcl's arguments.c files a
//! rule without a node name under `/**`): every value for the wildcard `/**` (a file's `/**`
//! block, a plain `-p`) in command-line order, then every value for the node's own name (its
//! block in a file, a `-p` prefixed with its name) over them, in command-line order. Sections
//! merge key by key; a dotted name is a nested key. [`Layers::gather`] reads the sources into
//! those two layers; [`read`] makes a binary's parameter struct of them.
//!
//! Pure: files are read through input-guard (a FIFO, a device or a file over
//! [`MAX_PARAMETER_FILE_BYTES`] refused before it is read, text nested too deep before it is
//! parsed); nothing here talks ROS.

use serde::{de::DeserializeOwned, Serialize};
use serde_yaml::{Mapping, Value};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// rclcpp's wildcard node name: its block applies to every node.
pub const WILDCARD: &str = "/**";

/// The most segments a dotted parameter name may have (`swarm.safety_weight` has two): the
/// name becomes nested mappings, and a name of thousands would nest as deep.
pub const MAX_NAME_SEGMENTS: usize = 16;

/// The largest parameter file read (bytes): these files are a few kilobytes.
pub const MAX_PARAMETER_FILE_BYTES: u64 = input_guard::yaml::MAX_YAML_BYTES as u64;

/// Why parameters could not be read.
#[derive(Debug, thiserror::Error)]
pub enum ParameterError {
    /// The file could not be read: missing, not a regular file, too large.
    #[error("{}: {error}", path.display())]
    Io {
        path: PathBuf,
        error: std::io::Error,
    },
    /// The file is no parameter file: not YAML, nested too deep, a block that is no mapping.
    #[error("{}: {message}", path.display())]
    File { path: PathBuf, message: String },
    /// The values taken together are at fault (no block for the node in any file, an unknown
    /// key, a value of the wrong type): `sources` names the one file read, or every source
    /// (`a.yaml + b.yaml + -p`), and `only_file` is that one file.
    #[error("{sources}: {message}")]
    Values {
        sources: String,
        message: String,
        only_file: Option<PathBuf>,
    },
}

/// One `-p [node:]name:=value`: the value parsed as YAML, as rcl parses it (`true`, `0.5`,
/// `[1, 2]`, `astar`), the name dotted for a nested key (`swarm.safety_weight`), the node's plain
/// name when one is written (rcl files a rule without one under the wildcard `/**`).
#[derive(Clone, Debug, PartialEq)]
pub struct ParameterOverride {
    pub node: Option<String>,
    pub name: String,
    pub value: Value,
    /// As written, for messages: `-p swarm.safety_weight:=0.5`.
    pub given: String,
}

impl ParameterOverride {
    /// `[node:]name:=value` of a `-p` (`flag`, as written: `-p` or `--param`): the node a plain
    /// node name, the name a dotted parameter name, the value YAML. Refused as rcl refuses it.
    pub fn parse(flag: &str, rule: &str) -> Result<Self, String> {
        let given = format!("{flag} {rule}");
        let (target, text) = rule
            .split_once(":=")
            .ok_or_else(|| format!("{given}: a parameter rule is `[node:]name:=value`"))?;
        let (node, name) = match target.split_once(':') {
            Some((node, name)) => (Some(node), name),
            None => (None, target),
        };
        // rcl takes one name token before the `:` (no namespace, no wildcard).
        if let Some(node) = node {
            if !is_token(node) {
                return Err(format!(
                    "{given}: `{node}` is not a node name (rcl takes a plain name before `:`)"
                ));
            }
        }
        let segments: Vec<&str> = name.split('.').collect();
        if !segments.iter().all(|s| is_token(s)) {
            return Err(format!("{given}: `{name}` is not a parameter name"));
        }
        if segments.len() > MAX_NAME_SEGMENTS {
            return Err(format!(
                "{given}: a parameter name of more than {MAX_NAME_SEGMENTS} dotted parts"
            ));
        }
        // The value's text is the user's: the nesting check keeps `[[[[...` from the parser.
        input_guard::yaml::check(text.as_bytes()).map_err(|e| format!("{given}: {e}"))?;
        let value: Value = serde_yaml::from_str(text)
            .map_err(|e| format!("{given}: the value is not YAML: {e}"))?;
        if value.is_null() {
            return Err(format!("{given}: no value after `:=`"));
        }
        Ok(Self {
            node: node.map(String::from),
            name: name.to_owned(),
            value,
            given,
        })
    }
}

/// A plain ROS name token: letters, digits and underscores, not empty.
fn is_token(s: &str) -> bool {
    !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// A parameter file or a `-p`, in command-line order.
#[derive(Clone, Debug, PartialEq)]
pub enum ParameterSource {
    File(PathBuf),
    Override(ParameterOverride),
}

/// As a binary's log names each source at start: `parameters from config/planner.yaml`,
/// `parameter -p swarm.safety_weight:=0.5`.
impl std::fmt::Display for ParameterSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ParameterSource::File(path) => write!(f, "parameters from {}", path.display()),
            ParameterSource::Override(rule) => write!(f, "parameter {}", rule.given),
        }
    }
}

/// A ROS 2 parameter file as a YAML document, read once for every block looked up in it
/// ([`node_block`]).
pub fn read_document(path: &Path) -> Result<Value, ParameterError> {
    let text = input_guard::read_file(path, MAX_PARAMETER_FILE_BYTES).map_err(|error| {
        ParameterError::Io {
            path: path.to_owned(),
            error,
        }
    })?;
    let file_err = |message: String| ParameterError::File {
        path: path.to_owned(),
        message,
    };
    input_guard::yaml::check(&text).map_err(file_err)?;
    serde_yaml::from_slice(&text).map_err(|e| file_err(e.to_string()))
}

/// The `ros__parameters` block of `node_name` in a parameter file's document, if it has one. A
/// fully qualified name (`/robot1/planner_server`) is found as one key or nested by namespace
/// (`robot1: planner_server:`, as Nav2's launch writes a namespaced file); a node in the root
/// namespace is found by its plain name, which callers try next.
pub fn node_block<'a>(doc: &'a Value, node_name: &str) -> Option<&'a Value> {
    let segments: Vec<&str> = node_name.split('/').filter(|s| !s.is_empty()).collect();
    let nested = || {
        (node_name.starts_with('/') && segments.len() > 1)
            .then(|| segments.iter().try_fold(doc, |v, segment| v.get(segment)))
            .flatten()
    };
    doc.get(node_name)
        .or_else(nested)
        .and_then(|n| n.get("ros__parameters"))
}

/// `over`'s keys into `base`, a mapping under a key merged key by key (a wildcard's
/// `swarm: {population: 30}` under the node's `swarm: {patience: 5}` keeps both), anything else
/// replaced.
pub fn merge_into(base: &mut Mapping, over: Mapping) {
    for (key, value) in over {
        match (base.get_mut(&key), value) {
            (Some(Value::Mapping(b)), Value::Mapping(o)) => merge_into(b, o),
            (_, value) => {
                base.insert(key, value);
            }
        }
    }
}

/// `value` under the dotted `name` (`swarm.safety_weight`) as a mapping to merge.
fn nested(name: &str, value: &Value) -> Mapping {
    let mut nested = value.clone();
    for segment in name.rsplit('.') {
        let mut m = Mapping::new();
        m.insert(Value::from(segment), nested);
        nested = Value::Mapping(m);
    }
    match nested {
        Value::Mapping(m) => m,
        _ => Mapping::new(),
    }
}

/// Whether `mapping` sets the dotted `name`.
fn sets(mapping: &Mapping, name: &str) -> bool {
    let mut segments = name.split('.');
    let Some(first) = segments.next() else {
        return false;
    };
    let mut at = mapping.get(first);
    for segment in segments {
        at = at.and_then(|v| v.get(segment));
    }
    at.is_some()
}

/// A ROS name as rclcpp keys a node's parameters: fully qualified (`/planner_server`).
fn qualified(name: &str) -> String {
    match name.starts_with('/') {
        true => name.to_owned(),
        false => format!("/{name}"),
    }
}

/// The top-level keys a default value serialises to: a parameter struct's field names.
pub fn field_names<T: Serialize>(value: &T) -> Vec<String> {
    match serde_yaml::to_value(value) {
        Ok(Value::Mapping(m)) => m
            .keys()
            .filter_map(|k| k.as_str().map(String::from))
            .collect(),
        _ => Vec::new(),
    }
}

/// A node's parameters from its command line's sources, as rclcpp's two layers.
#[derive(Clone, Debug, Default)]
pub struct Layers {
    /// The `/**` values: every file's wildcard block and every plain `-p`, in order.
    pub wildcard: Mapping,
    /// The node's own values, applied over the wildcard's: its block in every file, every `-p`
    /// prefixed with its name, in order.
    pub own: Mapping,
    /// The name the node's own block was found under (the first file's that has one); `None`
    /// when no file has one (the wildcard's values are then the node's own).
    pub own_block: Option<String>,
    /// What was read past so far, one line each, for the reader to log: a file with no block
    /// for the node (when there are several), a rule for another node, a wildcard key that is
    /// another node's, a plain rule that the node's own value overrides.
    pub warnings: Vec<String>,
    /// The file that last set each top-level key of the wildcard layer.
    wildcard_from: BTreeMap<String, PathBuf>,
    /// The rule that last set each top-level key, for an unknown key's error.
    set_by: BTreeMap<String, String>,
    /// The plain rules: name, value, as written.
    plain: Vec<(String, Value, String)>,
    files: Vec<PathBuf>,
    any_override: bool,
    /// The plain name to write a node's rule with (`planner_server`, not `/r1/planner_server`).
    plain_node: String,
}

impl Layers {
    /// Reads `sources` for the node known by `node_names` (say the fully qualified name, the
    /// plain name, then a default name; [`WILDCARD`] among them to read `/**` blocks). A
    /// file's own block is the first it has of those names; `resolve` sees each block a file
    /// gives, with that file's path, before it is merged (a path in it may be relative to the
    /// file's folder). A `-p` for another node's name is passed over with a warning. With
    /// several files, one without a block for the node is passed over with a warning; with one,
    /// or when no file has one, it is an error.
    pub fn gather(
        sources: &[ParameterSource],
        node_names: &[&str],
        resolve: impl Fn(&Path, &mut Mapping),
    ) -> Result<Self, ParameterError> {
        let mut layers = Layers {
            plain_node: node_names
                .first()
                .and_then(|n| n.rsplit('/').next())
                .unwrap_or_default()
                .to_owned(),
            ..Layers::default()
        };
        let own_names: Vec<String> = node_names
            .iter()
            .filter(|n| **n != WILDCARD)
            .map(|n| qualified(n))
            .collect();
        let mut empty = Vec::new();
        for source in sources {
            match source {
                ParameterSource::File(path) => {
                    layers.files.push(path.clone());
                    let blocks = file_blocks(path, node_names, &resolve)?;
                    if blocks.wildcard.is_none() && blocks.own.is_none() {
                        empty.push(path);
                    }
                    if let Some(w) = blocks.wildcard {
                        for key in w.keys().filter_map(Value::as_str) {
                            layers.wildcard_from.insert(key.to_owned(), path.clone());
                        }
                        merge_into(&mut layers.wildcard, w);
                    }
                    if let Some((name, o)) = blocks.own {
                        layers.own_block.get_or_insert_with(|| name.to_owned());
                        merge_into(&mut layers.own, o);
                    }
                }
                ParameterSource::Override(rule) => {
                    layers.any_override = true;
                    // rcl files a rule without a node name under `/**`.
                    let plain_rule = match rule.node.as_deref().map(qualified) {
                        None => true,
                        Some(n) if n == WILDCARD => true,
                        Some(n) if own_names.contains(&n) => false,
                        Some(_) => {
                            layers.warnings.push(format!(
                                "`{}` is for another node: not applied (this node is {})",
                                rule.given, layers.plain_node
                            ));
                            continue;
                        }
                    };
                    let layer = match plain_rule {
                        true => &mut layers.wildcard,
                        false => &mut layers.own,
                    };
                    merge_into(layer, nested(&rule.name, &rule.value));
                    if plain_rule {
                        let plain = (rule.name.clone(), rule.value.clone(), rule.given.clone());
                        layers.plain.push(plain);
                    }
                    let top = rule.name.split('.').next().unwrap_or_default();
                    layers.set_by.insert(top.to_owned(), rule.given.clone());
                }
            }
        }
        if !layers.files.is_empty() && empty.len() == layers.files.len() {
            return Err(layers.error(format!(
                "no `<node>: ros__parameters:` block for any of {}",
                node_names.join(", ")
            )));
        }
        if layers.files.len() > 1 {
            for path in empty {
                layers.warnings.push(format!(
                    "{}: no `<node>: ros__parameters:` block for any of {}: nothing read from it",
                    path.display(),
                    node_names.join(", ")
                ));
            }
        }
        Ok(layers)
    }

    /// The one file the values came from, when they came from one file alone.
    pub fn only_file(&self) -> Option<&Path> {
        match (self.files.as_slice(), self.any_override) {
            ([one], false) => Some(one),
            _ => None,
        }
    }

    /// What a message about the values taken together names: the one file, or every source
    /// (`a.yaml + b.yaml + -p`).
    pub fn label(&self) -> String {
        if let Some(one) = self.only_file() {
            return one.display().to_string();
        }
        let mut named: Vec<String> = self.files.iter().map(|f| f.display().to_string()).collect();
        if self.any_override {
            named.push("-p".into());
        }
        named.join(" + ")
    }

    /// An error of the values taken together.
    pub fn error(&self, message: String) -> ParameterError {
        ParameterError::Values {
            sources: self.label(),
            message,
            only_file: self.only_file().map(Path::to_path_buf),
        }
    }

    /// The `-p` that last set the top-level `key`, as written.
    pub fn set_by(&self, key: &str) -> Option<&str> {
        self.set_by.get(key).map(String::as_str)
    }

    /// When some file has a block of the node's own, the `/**` blocks' keys that `known` does
    /// not take are other nodes' (one file may configure a whole launch): dropped with a
    /// warning each, as rclcpp nodes ignore the wildcard's undeclared parameters. A key a `-p`
    /// set stays: a rule is this node's, and its unknown key is the reader's error to give.
    /// Without a block of the node's own, the wildcard's values are the node's: all kept.
    pub fn drop_other_nodes_wildcard_keys(&mut self, known: impl Fn(&str) -> bool) {
        if self.own_block.is_none() {
            return;
        }
        let label = self.label();
        let (set_by, from) = (&self.set_by, &self.wildcard_from);
        let warnings = &mut self.warnings;
        self.wildcard.retain(|key, _| {
            let k = key.as_str().unwrap_or_default();
            let keep = known(k) || set_by.contains_key(k);
            if !keep {
                let file = from.get(k).map_or(label.clone(), |f| f.display().to_string());
                warnings.push(format!(
                    "{file}: ignored `{WILDCARD}` key `{k}`: not a parameter of this node (rclcpp nodes ignore the wildcard's undeclared parameters)"
                ));
            }
            keep
        });
    }

    /// The node's values: the own layer over the wildcard's, taken out of the layers (so once,
    /// after [`Layers::drop_other_nodes_wildcard_keys`]). A plain rule that the node's own
    /// value overrides does nothing, as in rclcpp: said in a warning with the rule to write (a
    /// mapping value merges key by key, so only a scalar or a list is said to be overridden).
    pub fn merge(&mut self) -> Mapping {
        for (name, value, given) in &self.plain {
            if !value.is_mapping() && sets(&self.own, name) {
                self.warnings.push(format!(
                    "`{given}` does nothing: a value for the node's own name sets `{name}` (its block in a file, or a `-p {node}:` rule), which rclcpp applies over `/**` values and a -p without a node name; write `-p {node}:{name}:=...`",
                    node = self.plain_node
                ));
            }
        }
        let mut block = std::mem::take(&mut self.wildcard);
        merge_into(&mut block, std::mem::take(&mut self.own));
        block
    }
}

/// One file's blocks for the node (see [`Layers::gather`]): rclcpp's wildcard `/**` (when
/// `node_names` has it) and the first of the node's own names it has, each through `resolve`.
/// The file is read and parsed once for every name.
fn file_blocks<'n>(
    path: &Path,
    node_names: &[&'n str],
    resolve: &impl Fn(&Path, &mut Mapping),
) -> Result<FileBlocks<'n>, ParameterError> {
    let doc = read_document(path)?;
    let block_of = |name: &str| {
        let mut block = match node_block(&doc, name) {
            None => return Ok(None),
            Some(Value::Mapping(m)) => m.clone(),
            Some(Value::Null) => Mapping::new(),
            Some(other) => {
                return Err(ParameterError::File {
                    path: path.to_owned(),
                    message: format!("`{name}: ros__parameters:` is not a mapping but {other:?}"),
                })
            }
        };
        resolve(path, &mut block);
        Ok(Some(block))
    };
    let wildcard = match node_names.contains(&WILDCARD) {
        true => block_of(WILDCARD)?,
        false => None,
    };
    let mut own = None;
    for name in node_names.iter().filter(|n| **n != WILDCARD) {
        if let Some(block) = block_of(name)? {
            own = Some((*name, block));
            break;
        }
    }
    Ok(FileBlocks { wildcard, own })
}

/// What [`file_blocks`] finds in one file.
struct FileBlocks<'n> {
    wildcard: Option<Mapping>,
    own: Option<(&'n str, Mapping)>,
}

/// A binary's parameter struct `T` from its command line's sources, for the node known by
/// `node_names` (see [`Layers::gather`]), with the warnings to log. `T`'s fields are the keys it
/// knows: the wildcard's other keys are other nodes' when a file has the node's own block;
/// a `T` with `#[serde(deny_unknown_fields)]` refuses any other unknown key, naming it. A value
/// of the wrong type is named by its key path (`limits.max_linear: invalid type: ...`), and the
/// error names the sources. No sources: `T`'s defaults (as far as `T` has them).
pub fn read<T: DeserializeOwned + Serialize + Default>(
    sources: &[ParameterSource],
    node_names: &[&str],
) -> Result<(T, Vec<String>), ParameterError> {
    let mut layers = Layers::gather(sources, node_names, |_, _| {})?;
    let known = field_names(&T::default());
    layers.drop_other_nodes_wildcard_keys(|k| known.iter().any(|n| n == k));
    let block = layers.merge();
    let values = serde_path_to_error::deserialize(Value::Mapping(block)).map_err(|e| {
        let at = e.path().to_string();
        let place = match at.split('.').next().and_then(|top| layers.set_by(top)) {
            Some(given) => format!(" (set by `{given}`)"),
            None => String::new(),
        };
        layers.error(format!("parameter `{at}`{place}: {}", e.inner()))
    })?;
    Ok((values, std::mem::take(&mut layers.warnings)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde::Deserialize;

    /// A binary's parameters, as the chassis bridge's are made: strict, defaults for what is
    /// not given.
    #[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
    #[serde(deny_unknown_fields, default)]
    struct Params {
        backend: String,
        rate_hz: f64,
        limits: Limits,
    }

    #[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
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

    const NAMES: [&str; 3] = ["/chassis_bridge", "chassis_bridge", WILDCARD];

    /// A parameter file with `text` in it, removed when dropped.
    struct TempFile(PathBuf);

    impl TempFile {
        fn new(name: &str, text: &str) -> Self {
            let path = std::env::temp_dir()
                .join(format!("ros-parameters-{}-{name}.yaml", std::process::id()));
            std::fs::write(&path, text).expect("writing a temporary file");
            Self(path)
        }

        fn source(&self) -> ParameterSource {
            ParameterSource::File(self.0.clone())
        }
    }

    impl Drop for TempFile {
        fn drop(&mut self) {
            let _ = std::fs::remove_file(&self.0);
        }
    }

    fn rule(text: &str) -> ParameterSource {
        ParameterSource::Override(ParameterOverride::parse("-p", text).unwrap())
    }

    fn read_params(sources: &[ParameterSource]) -> Result<(Params, Vec<String>), ParameterError> {
        read(sources, &NAMES)
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
        let (p, warnings) = read_params(&[file.source()]).unwrap();
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
        assert!(warnings.is_empty(), "{warnings:?}");
        assert_eq!(read_params(&[]).unwrap().0, Params::default());
    }

    /// launch_ros' `parameters=[chassis.yaml, {'use_sim_time': True}]` and `-p` rules, with
    /// rclcpp's precedence: every `/**` value (a wildcard block, a plain rule) in order, then
    /// every value of the node's own (its block, a rule with its name) over them; sections
    /// merged key by key. Each assertion fails under plain in-order application.
    #[test]
    fn files_and_rules_apply_with_rclcpps_precedence() {
        let own = TempFile::new(
            "own",
            "chassis_bridge:\n  ros__parameters:\n    rate_hz: 20.0\n    limits: {max_linear: 0.3}\n",
        );
        let dict = TempFile::new(
            "dict",
            "/**:\n  ros__parameters:\n    rate_hz: 99.0\n    use_sim_time: true\n    limits: {max_angular: 0.2}\n",
        );
        let (p, warnings) = read_params(&[
            own.source(),
            dict.source(),
            rule("chassis_bridge:backend:=serial"),
            rule("backend:=sim"),
            rule("limits.max_linear:=0.5"),
        ])
        .unwrap();
        // The own block's rate over the later wildcard file's; the wildcard's max_angular merged
        // under the own block's limits; the prefixed rule over the later plain one; the plain
        // rule's max_linear under the own block's.
        assert_eq!(p.rate_hz, 20.0);
        assert_eq!(
            p.limits,
            Limits {
                max_linear: 0.3,
                max_angular: 0.2
            }
        );
        assert_eq!(p.backend, "serial");
        let said = warnings.join("\n");
        // use_sim_time is another node's (this one has a block of its own): ignored, named.
        assert!(
            said.contains(&format!(
                "{}: ignored `/**` key `use_sim_time`",
                dict.0.display()
            )),
            "{said}"
        );
        // The plain rules that the node's own values override are named, with what to write.
        assert!(said.contains("`-p backend:=sim` does nothing"), "{said}");
        assert!(
            said.contains("write `-p chassis_bridge:backend:=...`"),
            "{said}"
        );
        assert!(
            said.contains("`-p limits.max_linear:=0.5` does nothing"),
            "{said}"
        );
        assert_eq!(warnings.len(), 3, "{said}");
    }

    /// Without a block of the node's own, a `/**` block is the node's: its unknown key refused.
    /// A rule for another node is passed over with a warning; a file with no block among
    /// several, too; one file with none is an error.
    #[test]
    fn wildcard_alone_is_the_nodes_and_other_nodes_rules_are_passed_over() {
        let dict = TempFile::new(
            "dict-alone",
            "/**:\n  ros__parameters:\n    use_sim_time: true\n",
        );
        let e = read_params(&[dict.source()]).unwrap_err();
        assert!(
            e.to_string().contains("unknown field `use_sim_time`"),
            "{e}"
        );
        let rate = TempFile::new("rate", "/**:\n  ros__parameters:\n    rate_hz: 10.0\n");
        let other = TempFile::new("other", "amcl:\n  ros__parameters:\n    x: 1\n");
        let (p, warnings) =
            read_params(&[rate.source(), other.source(), rule("amcl:rate_hz:=1.0")]).unwrap();
        assert_eq!(p.rate_hz, 10.0);
        let said = warnings.join("\n");
        assert!(
            said.contains("`-p amcl:rate_hz:=1.0` is for another node"),
            "{said}"
        );
        assert!(
            said.contains(&format!(
                "{}: no `<node>: ros__parameters:` block",
                other.0.display()
            )),
            "{said}"
        );
        let e = read_params(&[other.source()]).unwrap_err();
        assert!(
            matches!(
                e,
                ParameterError::Values {
                    only_file: Some(_),
                    ..
                }
            ),
            "{e:?}"
        );
        assert!(
            e.to_string().starts_with(&format!(
                "{}: no `<node>: ros__parameters:` block",
                other.0.display()
            )),
            "{e}"
        );
    }

    #[test]
    fn a_typo_or_a_bad_value_is_refused_naming_its_key_path_and_sources() {
        let typo = TempFile::new(
            "typo",
            "chassis_bridge:\n  ros__parameters:\n    backnd: serial\n    rate_hz: 20.0\n",
        );
        let e = read_params(&[typo.source()]).unwrap_err();
        let message = e.to_string();
        assert!(
            message.starts_with(&format!("{}: ", typo.0.display())),
            "{message}"
        );
        assert!(message.contains("unknown field `backnd`"), "{message}");
        let section = TempFile::new(
            "section",
            "chassis_bridge:\n  ros__parameters:\n    limits:\n      max_linear: fast\n",
        );
        let message = read_params(&[section.source(), rule("rate_hz:=5.0")])
            .unwrap_err()
            .to_string();
        assert!(
            message.starts_with(&format!("{} + -p: ", section.0.display()))
                && message.contains("parameter `limits.max_linear`"),
            "{message}"
        );
        let message = read_params(&[rule("limits.max_linaer:=0.3")])
            .unwrap_err()
            .to_string();
        assert!(message.contains("unknown field `max_linaer`"), "{message}");
        assert!(
            message.contains("set by `-p limits.max_linaer:=0.3`"),
            "{message}"
        );
    }

    #[test]
    fn a_missing_block_or_file_names_the_file() {
        for (name, text) in [
            ("empty", ""),
            ("comments", "# nothing yet\n"),
            ("bare", "chassis_bridge:\n"),
        ] {
            let file = TempFile::new(name, text);
            let result = read_params(&[file.source()]);
            assert!(
                matches!(result, Err(ParameterError::Values { .. })),
                "{name}: {result:?}"
            );
        }
        let scalar = TempFile::new("scalar", "chassis_bridge:\n  ros__parameters: 3\n");
        let e = read_params(&[scalar.source()]).unwrap_err();
        assert!(e.to_string().contains("is not a mapping"), "{e}");
        let gone = std::env::temp_dir().join("ros-parameters-no-such-file.yaml");
        let e = read_params(&[ParameterSource::File(gone.clone())]).unwrap_err();
        assert!(matches!(e, ParameterError::Io { .. }), "{e:?}");
        assert!(e.to_string().starts_with(&gone.display().to_string()));
    }

    /// A device or a FIFO (which would block a binary's start for ever) is refused unread, and
    /// text nested 50 000 levels deep (seconds to minutes in the parser) before it is parsed.
    #[test]
    fn a_device_or_deeply_nested_text_is_refused_before_parsing() {
        let e = read_params(&[ParameterSource::File("/dev/zero".into())]).unwrap_err();
        assert!(matches!(e, ParameterError::Io { .. }), "{e:?}");
        assert!(e.to_string().contains("not a regular file"), "{e}");
        let deep = format!(
            "chassis_bridge:\n  ros__parameters:\n    limits: {}1{}\n",
            "[".repeat(50_000),
            "]".repeat(50_000)
        );
        let file = TempFile::new("deep", &deep);
        let e = read_params(&[file.source()]).unwrap_err();
        assert!(matches!(e, ParameterError::File { .. }), "{e:?}");
        assert!(e.to_string().contains("nested deeper"), "{e}");
    }

    #[test]
    fn a_source_names_itself_as_the_log_says_it() {
        let file = ParameterSource::File(PathBuf::from("config/chassis.yaml"));
        assert_eq!(file.to_string(), "parameters from config/chassis.yaml");
        let rule = ParameterOverride::parse("-p", "chassis_bridge:cmd_timeout:=0.25").unwrap();
        assert_eq!(
            ParameterSource::Override(rule).to_string(),
            "parameter -p chassis_bridge:cmd_timeout:=0.25"
        );
    }

    /// A namespaced node's block is found under its fully qualified name, as one key or nested
    /// by namespace, before its plain name.
    #[test]
    fn a_namespaced_block_is_found_either_way() {
        for text in [
            "/r1/chassis_bridge:\n  ros__parameters:\n    rate_hz: 7.0\n",
            "r1:\n  chassis_bridge:\n    ros__parameters:\n      rate_hz: 7.0\n",
        ] {
            let file = TempFile::new("namespaced", text);
            let (p, _): (Params, _) = read(
                &[file.source()],
                &["/r1/chassis_bridge", "chassis_bridge", WILDCARD],
            )
            .unwrap();
            assert_eq!(p.rate_hz, 7.0, "{text}");
        }
    }
}
