//! Bench scenario files (`*.scen.yaml`): `ScenarioFile::parse`.
//!
//! Bounds checked: no more scenarios than the input has bytes (YAML aliases must not multiply
//! them).
#![no_main]

use libfuzzer_sys::fuzz_target;
use planner_core::grid::parsers::scenarios::ScenarioFile;

fuzz_target!(|data: &[u8]| {
    if let Ok(file) = ScenarioFile::parse(data) {
        assert!(file.scenarios.len() <= data.len());
        for s in &file.scenarios {
            let _ = (s.start(), s.goal());
        }
    }
});
