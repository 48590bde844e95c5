//! Moving AI `.scen` files: `parse_scenarios`.
//!
//! Bounds checked: at most one scenario per line, and every optimal length and tolerance is
//! finite and not negative.
#![no_main]

use libfuzzer_sys::fuzz_target;
use planner_core::grid::parsers::movingai::parse_scenarios;

fuzz_target!(|data: &[u8]| {
    if let Ok(scenarios) = parse_scenarios(data) {
        let lines = data.split(|&b| b == b'\n').count();
        assert!(scenarios.len() <= lines);
        for s in &scenarios {
            assert!(s.optimal_length.is_finite() && s.optimal_length >= 0.0);
            assert!(s.tolerance.is_finite() && s.tolerance >= 0.0, "{s:?}");
        }
    }
});
