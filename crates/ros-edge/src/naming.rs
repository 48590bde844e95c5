//! ROS 2 names from the command line, as `ros2 run` and launch files pass them:
//! `--ros-args -r __node:=planner_server -r __ns:=/robot1 -r map:=/shared_map`. The node name
//! and namespace replace the built-in ones; a relative topic name (`map`) resolves inside the
//! namespace (`/robot1/map`), a private one (`~/make_plan`) inside the node
//! (`/robot1/planner_server/make_plan`), an absolute one (`/tf`) stays as it is; a remap rule
//! replaces a name, matched as written in the code or fully qualified. So the node can take
//! planner_server's place in a Nav2 launch, and several robots can each run one.

use ros2_client::names::NameError;
use ros2_client::Name;

/// The node's name, namespace and remap rules.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Naming {
    pub node: String,
    /// Absolute, `/` for the root.
    pub namespace: String,
    remaps: Vec<(String, String)>,
}

impl Naming {
    /// `default_node` in the root namespace, no remaps: what a command line without `-r`
    /// rules gives ([`crate::command_line::CommandLine`] adds them).
    pub fn new(default_node: &str) -> Self {
        Naming {
            node: default_node.into(),
            namespace: "/".into(),
            remaps: Vec::new(),
        }
    }

    pub(crate) fn add_rule(&mut self, from: &str, to: &str) -> Result<(), String> {
        let valid = |s: &str| {
            !s.is_empty()
                && s.chars()
                    .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '/' | '~'))
        };
        if !valid(from) || !valid(to) {
            return Err(format!(
                "remap rule `{from}:={to}` is not a valid ROS name rule"
            ));
        }
        match from {
            "__node" | "__name" => self.node = to.into(),
            "__ns" => {
                let ns = format!("/{}", to.trim_matches('/'));
                self.namespace = if ns == "/" {
                    ns
                } else {
                    ns.trim_end_matches('/').into()
                };
            }
            _ => self.remaps.push((from.into(), to.into())),
        }
        Ok(())
    }

    /// The fully qualified form of `name` (relative, `~/private` or `/absolute`).
    pub fn qualify(&self, name: &str) -> String {
        let join = |ns: &str, rest: &str| {
            if ns == "/" {
                format!("/{rest}")
            } else {
                format!("{ns}/{rest}")
            }
        };
        if let Some(rest) = name.strip_prefix("~/") {
            join(&self.node_path(), rest)
        } else if name.starts_with('/') {
            name.into()
        } else {
            join(&self.namespace, name)
        }
    }

    /// The node's own fully qualified name (`/robot1/planner_server`).
    pub fn node_path(&self) -> String {
        if self.namespace == "/" {
            format!("/{}", self.node)
        } else {
            format!("{}/{}", self.namespace, self.node)
        }
    }

    /// `name` after remapping, fully qualified: the first rule whose `from` equals the name as
    /// written or as qualified wins.
    pub fn resolve(&self, name: &str) -> String {
        let qualified = self.qualify(name);
        for (from, to) in &self.remaps {
            if from == name || self.qualify(from) == qualified {
                return self.qualify(to);
            }
        }
        qualified
    }

    /// The resolved name as ros2-client's [`Name`] (namespace and base).
    pub fn name(&self, name: &str) -> Result<Name, NameError> {
        Name::parse(&self.resolve(name))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::command_line::CommandLine;

    fn naming(args: &str) -> Naming {
        CommandLine::from_args(args.split_whitespace().map(String::from), "patrol_planner")
            .unwrap()
            .naming
    }

    #[test]
    fn node_namespace_and_remaps_as_ros2_resolves_them() {
        let plain = naming("--params-file config/planner.yaml");
        assert_eq!(plain.resolve("map"), "/map");
        assert_eq!(plain.resolve("~/make_plan"), "/patrol_planner/make_plan");
        let n = naming(
            "--ros-args -r __node:=planner_server -r __ns:=/robot1 -r map:=/shared_map --params-file x.yaml -r /robot1/odom:=wheel_odom",
        );
        assert_eq!(n.node_path(), "/robot1/planner_server");
        assert_eq!(n.resolve("plan"), "/robot1/plan");
        assert_eq!(n.resolve("~/make_plan"), "/robot1/planner_server/make_plan");
        assert_eq!(n.resolve("/tf"), "/tf");
        assert_eq!(n.resolve("map"), "/shared_map");
        assert_eq!(n.resolve("odom"), "/robot1/wheel_odom");
        let parsed = n.name("~/make_plan").unwrap();
        assert_eq!(parsed.to_string(), "/robot1/planner_server/make_plan");
        // Remaps outside --ros-args are not ROS arguments (bad rules: command_line's tests).
        assert_eq!(naming("-r __node:=x").node, "patrol_planner");
    }
}
