//! A binary's command line, walked once, as rcl reads `ros2 run` and launch_ros arguments:
//!
//! ```text
//! patrol_planner --ros-args -r __node:=planner_server --params-file nav2_params.yaml \
//!     --params-file /tmp/launch_params_x -p use_sim_time:=true -p planner_server:planner:=astar
//! ```
//!
//! launch_ros passes one `--params-file` per entry of a Node's `parameters=[...]` (a dict such
//! as `{'use_sim_time': True}` becomes a file of its own), so a node that read only the first
//! would lose the launch's settings without a word. Every file and every `-p [node:]name:=value`
//! is kept in command-line order, for the reader to apply with rclcpp's precedence
//! (`planner_io::parameters::load_parameters_for`). `--params-file` is also taken before
//! `--ros-args` (`patrol_planner --params-file FILE`, this project's own short form); `-r` and
//! `-p` only after it, up to a `--`, as rcl takes them.

use crate::naming::Naming;
use std::path::{Path, PathBuf};

/// The most segments a dotted parameter name may have (`swarm.safety_weight` has two): the
/// name becomes nested mappings, and a name of thousands would nest as deep.
pub const MAX_NAME_SEGMENTS: usize = 16;

/// One `-p [node:]name:=value`: the value parsed as YAML, as rcl parses it (`true`, `0.5`,
/// `[1, 2]`, `astar`), the name dotted for a nested key (`swarm.safety_weight`), the node's plain
/// name when one is written (rcl files a rule without one under the wildcard `/**`).
#[derive(Clone, Debug, PartialEq)]
pub struct ParameterOverride {
    pub node: Option<String>,
    pub name: String,
    pub value: serde_yaml::Value,
    /// As written, for messages: `-p swarm.safety_weight:=0.5`.
    pub given: String,
}

/// A parameter file or a `-p`, in command-line order.
#[derive(Clone, Debug, PartialEq)]
pub enum ParameterSource {
    File(PathBuf),
    Override(ParameterOverride),
}

/// What a binary takes from its command line.
#[derive(Clone, Debug, PartialEq)]
pub struct CommandLine {
    pub naming: Naming,
    /// Every `--params-file` and `-p`, in the order given.
    pub parameters: Vec<ParameterSource>,
}

impl CommandLine {
    /// The process's command line; the node is `default_node` unless `__node` is remapped.
    pub fn from_env(default_node: &str) -> Result<Self, String> {
        Self::from_args(std::env::args().skip(1), default_node)
    }

    /// From arguments (without the program's name). A malformed remap or `-p` is refused, as
    /// rclcpp refuses to start on one.
    pub fn from_args(
        args: impl IntoIterator<Item = String>,
        default_node: &str,
    ) -> Result<Self, String> {
        let mut line = CommandLine {
            naming: Naming::new(default_node),
            parameters: Vec::new(),
        };
        let mut in_ros_args = false;
        let mut args = args.into_iter();
        while let Some(arg) = args.next() {
            let mut operand = || {
                args.next()
                    .ok_or_else(|| format!("`{arg}` needs an argument"))
            };
            match arg.as_str() {
                "--ros-args" => in_ros_args = true,
                "--" => in_ros_args = false,
                "--params-file" => {
                    let file = PathBuf::from(operand()?);
                    line.parameters.push(ParameterSource::File(file));
                }
                "-r" | "--remap" if in_ros_args => {
                    let rule = operand()?;
                    let (from, to) = rule
                        .split_once(":=")
                        .ok_or_else(|| format!("remap rule `{rule}` is not `from:=to`"))?;
                    line.naming.add_rule(from.trim(), to.trim())?;
                }
                "-p" | "--param" if in_ros_args => {
                    let rule = operand()?;
                    let rule = parameter_override(&arg, &rule)?;
                    line.parameters.push(ParameterSource::Override(rule));
                }
                _ => {}
            }
        }
        Ok(line)
    }

    /// Every `--params-file`, in order.
    pub fn params_files(&self) -> impl Iterator<Item = &Path> {
        self.parameters.iter().filter_map(|p| match p {
            ParameterSource::File(f) => Some(f.as_path()),
            ParameterSource::Override(_) => None,
        })
    }

    /// For a binary that reads only the first parameter file and no `-p`: what it reads past,
    /// one warning each, so that a user who gave them learns that they did nothing.
    pub fn unread_by_a_one_file_reader(&self) -> Vec<String> {
        let mut files = 0;
        let mut unread = Vec::new();
        for p in &self.parameters {
            match p {
                ParameterSource::File(f) => {
                    files += 1;
                    if files > 1 {
                        unread.push(format!(
                            "--params-file {}: only the first --params-file is read; put its keys in that one",
                            f.display()
                        ));
                    }
                }
                ParameterSource::Override(o) => unread.push(format!(
                    "{}: parameters are read from the --params-file only; set it there",
                    o.given
                )),
            }
        }
        unread
    }
}

/// `[node:]name:=value` of a `-p` (`flag`): the node a plain node name, the name a dotted
/// parameter name, the value YAML.
fn parameter_override(flag: &str, rule: &str) -> Result<ParameterOverride, String> {
    let given = format!("{flag} {rule}");
    let (target, text) = rule
        .split_once(":=")
        .ok_or_else(|| format!("{given}: a parameter rule is `[node:]name:=value`"))?;
    let (node, name) = match target.split_once(':') {
        Some((node, name)) => (Some(node), name),
        None => (None, target),
    };
    // rcl takes one name token before the `:` (no namespace, no wildcard) and refuses the rest.
    if let Some(node) = node {
        let valid = !node.is_empty() && node.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
        if !valid {
            return Err(format!(
                "{given}: `{node}` is not a node name (rcl takes a plain name before `:`)"
            ));
        }
    }
    let segments: Vec<&str> = name.split('.').collect();
    let valid_name = segments
        .iter()
        .all(|s| !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || c == '_'));
    if !valid_name {
        return Err(format!("{given}: `{name}` is not a parameter name"));
    }
    if segments.len() > MAX_NAME_SEGMENTS {
        return Err(format!(
            "{given}: a parameter name of more than {MAX_NAME_SEGMENTS} dotted parts"
        ));
    }
    // The value's text is the user's: the nesting check keeps `[[[[...` from the parser.
    input_guard::yaml::check(text.as_bytes()).map_err(|e| format!("{given}: {e}"))?;
    let value: serde_yaml::Value =
        serde_yaml::from_str(text).map_err(|e| format!("{given}: the value is not YAML: {e}"))?;
    if value.is_null() {
        return Err(format!("{given}: no value after `:=`"));
    }
    Ok(ParameterOverride {
        node: node.map(String::from),
        name: name.to_owned(),
        value,
        given,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(args: &str) -> Result<CommandLine, String> {
        CommandLine::from_args(args.split_whitespace().map(String::from), "patrol_planner")
    }

    /// Files and rules in the order given (a file before `--ros-args` too), each `-p` with its
    /// YAML value and node prefix, remaps after `--ros-args` only.
    #[test]
    fn files_and_rules_in_the_order_given() {
        let l = line(
            "--params-file a.yaml -p x:=1 --ros-args -r __ns:=/r1 -p planner:=astar \
             --param swarm.safety_weight:=0.5 --params-file b.yaml \
             -p planner_server:use_sim_time:=true -p ids:=[GridBased,Smooth] --log-level debug",
        )
        .unwrap();
        assert_eq!(
            l.params_files().collect::<Vec<_>>(),
            vec![Path::new("a.yaml"), Path::new("b.yaml")]
        );
        assert_eq!(l.naming.node_path(), "/r1/patrol_planner");
        let order: Vec<String> = l
            .parameters
            .iter()
            .map(|p| match p {
                ParameterSource::File(f) => f.display().to_string(),
                ParameterSource::Override(o) => {
                    let node = o.node.as_deref().unwrap_or("-");
                    format!("{node} {} {}", o.name, yaml_text(&o.value))
                }
            })
            .collect();
        assert_eq!(
            order,
            [
                "a.yaml",
                "- planner astar",
                "- swarm.safety_weight 0.5",
                "b.yaml",
                "planner_server use_sim_time true",
                "- ids - GridBased\n- Smooth",
            ],
            "the -p before --ros-args is not a ROS argument"
        );
        // After `--`, the ROS arguments end.
        assert_eq!(line("--ros-args -- -p x:=1").unwrap().parameters, []);
    }

    fn yaml_text(v: &serde_yaml::Value) -> String {
        serde_yaml::to_string(v).unwrap().trim_end().to_owned()
    }

    /// A rule that rclcpp would refuse stops the binary with a reason naming it.
    #[test]
    fn malformed_rules_are_refused_naming_them() {
        for (args, word) in [
            ("--ros-args -p planner", "`[node:]name:=value`"),
            ("--ros-args -p no-de:x:=1", "not a node name"),
            ("--ros-args -p :x:=1", "not a node name"),
            ("--ros-args -p /ns/node:x:=1", "not a node name"),
            ("--ros-args -p /**:x:=1", "not a node name"),
            ("--ros-args -p :=astar", "not a parameter name"),
            ("--ros-args -p swarm..x:=1", "not a parameter name"),
            ("--ros-args -p a-b:=1", "not a parameter name"),
            ("--ros-args -p planner:=", "no value"),
            ("--ros-args -p planner:=[1,", "not YAML"),
            ("--ros-args -p", "needs an argument"),
            ("--params-file", "needs an argument"),
            ("--ros-args -r nonsense", "not `from:=to`"),
        ] {
            let err = line(args).unwrap_err();
            assert!(err.contains(word), "{args}: {err}");
        }
        let spaced = ["--ros-args", "-r", "a b:=c"].map(String::from);
        let err = CommandLine::from_args(spaced, "n").unwrap_err();
        assert!(err.contains("not a valid ROS name rule"), "{err}");
        let long = format!(
            "--ros-args -p {}:=1",
            vec!["a"; MAX_NAME_SEGMENTS + 1].join(".")
        );
        assert!(line(&long).unwrap_err().contains("dotted parts"));
        let deep = format!("--ros-args -p x:={}", "[".repeat(10_000));
        assert!(line(&deep).unwrap_err().contains("-p x:="));
    }

    /// A one-file reader (the chassis bridge) names what it reads past.
    #[test]
    fn a_one_file_reader_names_what_it_reads_past() {
        let l =
            line("--params-file a.yaml --ros-args -p planner:=astar --params-file b.yaml").unwrap();
        let unread = l.unread_by_a_one_file_reader();
        assert_eq!(unread.len(), 2, "{unread:?}");
        assert!(unread[0].starts_with("-p planner:=astar"), "{unread:?}");
        assert!(unread[1].starts_with("--params-file b.yaml"), "{unread:?}");
        assert!(line("--params-file a.yaml")
            .unwrap()
            .unread_by_a_one_file_reader()
            .is_empty());
    }
}
