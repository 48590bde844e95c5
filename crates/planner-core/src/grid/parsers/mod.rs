//! Parsers from bytes for the map formats users have: ROS map_server (YAML + PGM/PNG), Moving AI
//! benchmark maps and scenarios, and this project's bench scenario files. Reading the files is the
//! caller's job (see the `planner-io` crate), so everything here is testable on in-memory data.

pub mod map_server;
pub mod movingai;
pub mod scenarios;
