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
//! (`ros_parameters::Layers`). `--params-file` is also taken before
//! `--ros-args` (`patrol_planner --params-file FILE`, this project's own short form); `-r` and
//! `-p` only after it, up to a `--`, as rcl takes them.

use crate::naming::Naming;
pub use ros_parameters::{ParameterOverride, ParameterSource, MAX_NAME_SEGMENTS};
use std::path::{Path, PathBuf};

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
                    let rule = ParameterOverride::parse(&arg, &rule)?;
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

    /// Every file and rule, in order, with the binary's bundled file `default` first when the
    /// command line names no file and `default` exists (as `config/planner.yaml` is read when
    /// a user runs the node from the repository without arguments).
    pub fn parameter_sources(&self, default: &Path) -> Vec<ParameterSource> {
        let mut sources = self.parameters.clone();
        if self.params_files().next().is_none() && default.exists() {
            sources.insert(0, ParameterSource::File(default.to_owned()));
        }
        sources
    }
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

    /// The bundled file comes first when no file is named, and only if it exists; a named
    /// file replaces it.
    #[test]
    fn the_bundled_file_is_read_when_none_is_named() {
        let bundled = Path::new(env!("CARGO_MANIFEST_DIR")).join("Cargo.toml");
        let files = |args: &str, default: &Path| -> Vec<String> {
            line(args)
                .unwrap()
                .parameter_sources(default)
                .iter()
                .map(|s| match s {
                    ParameterSource::File(f) => f.display().to_string(),
                    ParameterSource::Override(o) => o.given.clone(),
                })
                .collect()
        };
        let rule = "--ros-args -p planner:=astar";
        assert_eq!(
            files(rule, &bundled),
            [bundled.display().to_string(), "-p planner:=astar".into()]
        );
        assert_eq!(
            files(rule, Path::new("no/such.yaml")),
            ["-p planner:=astar"]
        );
        assert_eq!(files("--params-file mine.yaml", &bundled), ["mine.yaml"]);
    }
}
