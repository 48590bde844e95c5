//! map_server maps: `MapYaml::parse` on YAML bytes and `MapYaml::decode` on image bytes.
//!
//! The first byte chooses how the rest is used:
//! - 0: all of it is the YAML (parse only);
//! - 1, 2, 3: a fixed valid YAML in trinary / scale / raw mode (negate from bit 2), the rest is
//!   the image;
//! - otherwise: YAML up to the first NUL byte, the image after it (parse, then decode if valid).
//!
//! Bounds checked: a decoded grid never has more than the cell cap and its size is the image's;
//! every value is -1..=100. libFuzzer's `-malloc_limit_mb` makes an allocation past the cap
//! (before refusing) a crash.
#![no_main]

use libfuzzer_sys::fuzz_target;
use planner_core::grid::map::DEFAULT_MAX_CELLS;
use planner_core::grid::parsers::map_server::MapYaml;

fn decode(yaml: &MapYaml, image: &[u8]) {
    if let Ok(grid) = yaml.decode(image) {
        let cells = grid.width() as u64 * grid.height() as u64;
        assert!(cells <= DEFAULT_MAX_CELLS, "{cells} cells past the cap");
        assert_eq!(grid.data().len() as u64, cells);
        assert!(grid.data().iter().all(|&v| (-1..=100).contains(&v)));
    }
}

fuzz_target!(|data: &[u8]| {
    let Some((&selector, rest)) = data.split_first() else {
        return;
    };
    match selector {
        0 => {
            let _ = MapYaml::parse(rest);
        }
        1..=3 | 5..=7 => {
            let mode = ["trinary", "scale", "raw"][usize::from(selector & 3) - 1];
            let negate = u8::from(selector & 4 != 0);
            let text = format!(
                "image: fuzz.pgm\nmode: {mode}\nresolution: 0.05\norigin: [-1.0, -2.0, 0.0]\n\
                 negate: {negate}\noccupied_thresh: 0.65\nfree_thresh: 0.196\n"
            );
            let yaml = MapYaml::parse(text.as_bytes()).expect("the fixed YAML is valid");
            decode(&yaml, rest);
        }
        _ => {
            let (text, image) = match rest.iter().position(|&b| b == 0) {
                Some(i) => (&rest[..i], &rest[i + 1..]),
                None => (rest, &[][..]),
            };
            if let Ok(yaml) = MapYaml::parse(text) {
                assert!(yaml.resolution.is_finite() && yaml.resolution > 0.0);
                assert!(yaml.free_thresh < yaml.occupied_thresh);
                decode(&yaml, image);
            }
        }
    }
});
