//! A binary's command line, walked once, as rclcpp reads `ros2 run` and launch_ros arguments:
//!
//! ```text
//! patrol_planner --ros-args -r __node:=planner_server --params-file nav2_params.yaml \
//!     --params-file /tmp/launch_params_x -p planner:=astar -p swarm.safety_weight:=0.5
//! ```
//!
//! launch_ros passes one `--params-file` per entry of a Node's `parameters=[...]` (a dict such
//! as `{'use_sim_time': True}` becomes a file of its own), so a node that read only the first
//! would lose the launch's settings without a word. Every file is kept, in order, for the
//! reader to apply one over the other, then each `-p name:=value` over them all, as rclcpp does.
//! `--params-file` is also taken before `--ros-args` (`patrol_planner --params-file FILE`, this
//! project's own short form); `-r` and `-p` only after it, up to a `--`, as rclcpp takes them.

use crate::naming::Naming;
use std::path::PathBuf;

/// One `-p name:=value`: the value parsed as YAML, as rclcpp parses it (`true`, `0.5`, `[1, 2]`,
/// `astar`), the name dotted for a nested key (`swarm.safety_weight`).
#[derive(Clone, Debug, PartialEq)]
pub struct ParameterOverride {
    pub name: String,
    pub value: serde_yaml::Value,
    /// As written, for messages: `-p swarm.safety_weight:=0.5`.
    pub given: String,
}

/// What a binary takes from its command line.
#[derive(Clone, Debug, PartialEq)]
pub struct CommandLine {
    pub naming: Naming,
    /// Every `--params-file`, in the order given: a later file's keys override an earlier one's.
    pub params_files: Vec<PathBuf>,
    /// Every `-p`, in the order given, applied over the files.
    pub overrides: Vec<ParameterOverride>,
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
            params_files: Vec::new(),
            overrides: Vec::new(),
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
                "--params-file" => line.params_files.push(PathBuf::from(operand()?)),
                "-r" | "--remap" if in_ros_args => {
                    let rule = operand()?;
                    let (from, to) = rule
                        .split_once(":=")
                        .ok_or_else(|| format!("remap rule `{rule}` is not `from:=to`"))?;
                    line.naming.add_rule(from.trim(), to.trim())?;
                }
                "-p" | "--param" if in_ros_args => {
                    let rule = operand()?;
                    line.overrides.push(parameter_override(&arg, &rule)?);
                }
                _ => {}
            }
        }
        Ok(line)
    }

    /// For a binary that reads only the first parameter file and no `-p`: what it reads past,
    /// one warning each, so that a user who gave them learns that they did nothing.
    pub fn unread_by_a_one_file_reader(&self) -> Vec<String> {
        let files = self.params_files.iter().skip(1).map(|f| {
            format!(
                "--params-file {}: only the first --params-file is read; put its keys in that one",
                f.display()
            )
        });
        let params = self.overrides.iter().map(|o| {
            format!(
                "{}: parameters are read from the --params-file only; set it there",
                o.given
            )
        });
        files.chain(params).collect()
    }
}

/// `name:=value` of a `-p` (`flag`): the name a dotted parameter name, the value YAML.
fn parameter_override(flag: &str, rule: &str) -> Result<ParameterOverride, String> {
    let given = format!("{flag} {rule}");
    let (name, text) = rule
        .split_once(":=")
        .ok_or_else(|| format!("{given}: a parameter override is `name:=value`"))?;
    let valid_name = !name.is_empty()
        && name
            .split('.')
            .all(|s| !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || c == '_'));
    if !valid_name {
        return Err(format!("{given}: `{name}` is not a parameter name"));
    }
    // The value's text is the user's: the nesting check keeps `[[[[...` from the parser.
    input_guard::yaml::check(text.as_bytes()).map_err(|e| format!("{given}: {e}"))?;
    let value: serde_yaml::Value =
        serde_yaml::from_str(text).map_err(|e| format!("{given}: the value is not YAML: {e}"))?;
    if value.is_null() {
        return Err(format!("{given}: no value after `:=`"));
    }
    Ok(ParameterOverride {
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

    /// Every file in order (before `--ros-args` too), every `-p` with its YAML value, remaps
    /// after `--ros-args` only.
    #[test]
    fn files_overrides_and_remaps_in_the_order_given() {
        let l = line(
            "--params-file a.yaml -p x:=1 --ros-args -r __ns:=/r1 -p planner:=astar \
             --param swarm.safety_weight:=0.5 --params-file b.yaml -p use_sim_time:=true \
             -p ids:=[GridBased,Smooth] --log-level debug",
        )
        .unwrap();
        assert_eq!(
            l.params_files,
            vec![PathBuf::from("a.yaml"), PathBuf::from("b.yaml")]
        );
        assert_eq!(l.naming.node_path(), "/r1/patrol_planner");
        let got: Vec<(&str, &serde_yaml::Value)> = l
            .overrides
            .iter()
            .map(|o| (o.name.as_str(), &o.value))
            .collect();
        let ids: serde_yaml::Value = serde_yaml::from_str("[GridBased, Smooth]").unwrap();
        assert_eq!(
            got,
            vec![
                ("planner", &serde_yaml::Value::from("astar")),
                ("swarm.safety_weight", &serde_yaml::Value::from(0.5)),
                ("use_sim_time", &serde_yaml::Value::from(true)),
                ("ids", &ids),
            ],
            "the -p before --ros-args is not a ROS argument"
        );
        assert_eq!(l.overrides[1].given, "--param swarm.safety_weight:=0.5");
        // After `--`, the ROS arguments end.
        assert!(line("--ros-args -- -p x:=1").unwrap().overrides.is_empty());
    }

    /// A rule that rclcpp would refuse stops the binary with a reason naming it.
    #[test]
    fn malformed_rules_are_refused_naming_them() {
        for (args, word) in [
            ("--ros-args -p planner", "`name:=value`"),
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
        assert!(unread[0].starts_with("--params-file b.yaml"), "{unread:?}");
        assert!(unread[1].starts_with("-p planner:=astar"), "{unread:?}");
        assert!(line("--params-file a.yaml")
            .unwrap()
            .unread_by_a_one_file_reader()
            .is_empty());
    }
}
