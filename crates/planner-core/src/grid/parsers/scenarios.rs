//! This project's bench scenario files (`*.scen.yaml` beside the bench maps): a map_server YAML
//! and named start/goal pairs in map-frame metres.
//!
//! ```yaml
//! map: datacenter_100.yaml
//! scenarios:
//!   - {name: corner_to_corner, start: [0.100, 0.100], goal: [19.900, 19.900]}
//! ```

use crate::geometry::Point2;
use crate::grid::MapError;
use serde::Deserialize;

#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScenarioFile {
    /// The map's YAML, relative to the scenario file's folder.
    pub map: String,
    pub scenarios: Vec<Scenario>,
}

#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    pub name: String,
    pub start: [f64; 2],
    pub goal: [f64; 2],
}

impl Scenario {
    pub fn start(&self) -> Point2 {
        Point2::new(self.start[0], self.start[1])
    }
    pub fn goal(&self) -> Point2 {
        Point2::new(self.goal[0], self.goal[1])
    }
}

impl ScenarioFile {
    pub fn parse(text: &[u8]) -> Result<Self, MapError> {
        input_guard::yaml::check(text)
            .map_err(|e| MapError::Format(format!("scenario file: {e}")))?;
        let file: Self = serde_yaml::from_slice(text)
            .map_err(|e| MapError::Format(format!("scenario file: {e}")))?;
        if file.scenarios.is_empty() {
            return Err(MapError::Format("scenario file: no scenarios".into()));
        }
        // A query off the map or on an obstacle is a query like any other (the planners answer
        // it with their codes); a coordinate that is no number is not.
        if let Some(s) = file
            .scenarios
            .iter()
            .find(|s| !s.start.iter().chain(&s.goal).all(|v| v.is_finite()))
        {
            return Err(MapError::Format(format!(
                "scenario file: `{}` has a start or goal that is not a finite number: {:?} -> {:?}",
                s.name, s.start, s.goal
            )));
        }
        Ok(file)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_no_scenarios_and_coordinates_that_are_no_numbers() {
        for (text, word) in [
            (&b"map: m.yaml\nscenarios: []\n"[..], "no scenarios"),
            (
                b"map: m.yaml\nscenarios:\n  - {name: a, start: [.nan, 1], goal: [3, 4]}\n",
                "`a`",
            ),
            (
                b"map: m.yaml\nscenarios:\n  - {name: b, start: [1, 1], goal: [.inf, 4]}\n",
                "`b`",
            ),
        ] {
            let err = ScenarioFile::parse(text).unwrap_err().to_string();
            assert!(err.contains(word), "{err}");
        }
    }

    #[test]
    fn parses_the_bench_layout() {
        let f = ScenarioFile::parse(
            b"# c\nmap: m.yaml\nscenarios:\n  - {name: a, start: [0.1, 0.2], goal: [3, 4]}\n",
        )
        .unwrap();
        assert_eq!(f.map, "m.yaml");
        assert_eq!(f.scenarios[0].goal(), Point2::new(3.0, 4.0));
        assert!(ScenarioFile::parse(
            b"map: m.yaml\nscenarios: [{name: a, start: [0], goal: [1, 2]}]"
        )
        .is_err());
    }
}
