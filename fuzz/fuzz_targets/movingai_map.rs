//! Moving AI `.map` files: `MovingAiMap::parse`.
//!
//! Bounds checked: a parsed map never has more cells than the cap, nor more cells than the file
//! has bytes (the parser checks the header's size against the file before allocating), and every
//! cell is 0 or 100.
#![no_main]

use libfuzzer_sys::fuzz_target;
use planner_core::grid::map::DEFAULT_MAX_CELLS;
use planner_core::grid::parsers::movingai::MovingAiMap;

fuzz_target!(|data: &[u8]| {
    if let Ok(map) = MovingAiMap::parse(data) {
        let g = &map.grid;
        let cells = g.width() as u64 * g.height() as u64;
        assert!(cells <= DEFAULT_MAX_CELLS);
        assert!(
            cells <= data.len() as u64,
            "{cells} cells from {} bytes",
            data.len()
        );
        assert_eq!(g.data().len() as u64, cells);
        assert!(g.data().iter().all(|&v| v == 0 || v == 100));
        // Scenario coordinates of every corner map to cells inside the grid.
        for (x, y) in [(0, 0), (g.width() - 1, g.height() - 1)] {
            assert!(g.info().contains(map.cell(x, y)));
        }
    }
});
