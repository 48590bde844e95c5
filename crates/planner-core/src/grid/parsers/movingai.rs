//! Moving AI grid benchmarks (N. Sturtevant, "Benchmarks for Grid-Based Pathfinding", 2012).
//!
//! `.map`: `type octile`, `height H`, `width W`, `map`, then H rows; `.` and `G` are free,
//! `@`, `T`, `O`, `S` and `W` are blocked. A map becomes a [`GridMap`] with 1 m cells and origin
//! (0, 0); its rows are flipped so that the picture keeps its orientation in ROS's bottom-left
//! convention. Scenario coordinates `(x, y)` count rows from the top, so use
//! [`MovingAiMap::cell`] to convert them.
//!
//! `.scen`: a `version 1` (tab separated) or `version 1.0` (space separated) header, then rows
//! `bucket map width height sx sy gx gy optimal_length`.

use crate::geometry::{Cell, Pose2};
use crate::grid::map::DEFAULT_MAX_CELLS;
use crate::grid::{GridMap, MapError, MapInfo};

/// A parsed Moving AI map.
#[derive(Clone, Debug)]
pub struct MovingAiMap {
    pub grid: GridMap,
}

impl MovingAiMap {
    pub fn parse(text: &[u8]) -> Result<Self, MapError> {
        let text = std::str::from_utf8(text).map_err(|_| fmt_err("map is not text"))?;
        let mut lines = text.lines();
        let mut header_bytes = 0usize;
        let mut height = None;
        let mut width = None;
        for line in lines.by_ref() {
            header_bytes += line.len() + 1;
            let mut words = line.split_whitespace();
            match (words.next(), words.next()) {
                (Some("type"), _) => {}
                (Some("height"), Some(v)) => height = Some(parse_dim(v)?),
                (Some("width"), Some(v)) => width = Some(parse_dim(v)?),
                (Some("map"), None) => break,
                (None, _) => {}
                _ => return Err(fmt_err(&format!("unexpected header line `{line}`"))),
            }
        }
        let (Some(h), Some(w)) = (height, width) else {
            return Err(fmt_err("header lacks height or width"));
        };
        let info = MapInfo {
            width: w,
            height: h,
            resolution: 1.0,
            origin: Pose2::default(),
        };
        // The header chooses the size: check it, and that the file can hold that many cells,
        // before allocating anything.
        info.validate(DEFAULT_MAX_CELLS)?;
        let cells = w as u64 * h as u64;
        if ((text.len() - header_bytes.min(text.len())) as u64) < cells {
            return Err(fmt_err(&format!(
                "the header says {w} x {h} cells, but the file holds fewer characters"
            )));
        }
        let mut data = vec![0i8; cells as usize];
        let mut rows = 0u32;
        for line in lines.filter(|l| !l.trim().is_empty()) {
            if rows == h {
                return Err(fmt_err(&format!("more than {h} rows")));
            }
            let line = line.trim_end_matches('\r');
            if line.len() != w as usize {
                return Err(fmt_err(&format!(
                    "row {rows} has {} cells, expected {w}",
                    line.len()
                )));
            }
            let y = (h - 1 - rows) as usize;
            for (x, ch) in line.bytes().enumerate() {
                data[y * w as usize + x] = match ch {
                    b'.' | b'G' => 0,
                    b'@' | b'T' | b'O' | b'S' | b'W' => 100,
                    other => return Err(fmt_err(&format!("unknown terrain `{}`", other as char))),
                };
            }
            rows += 1;
        }
        if rows != h {
            return Err(fmt_err(&format!("{rows} rows, expected {h}")));
        }
        Ok(Self {
            grid: GridMap::new(info, data)?,
        })
    }

    /// The grid cell of a scenario coordinate (x = column, y = row from the top).
    pub fn cell(&self, x: u32, y: u32) -> Cell {
        Cell::new(x as i32, self.grid.height() as i32 - 1 - y as i32)
    }
}

/// One scenario row.
#[derive(Clone, Debug, PartialEq)]
pub struct MovingAiScenario {
    pub bucket: u32,
    /// The base name of the map column (`maps/dao/arena.map` -> `arena.map`).
    pub map: String,
    pub start: (u32, u32),
    pub goal: (u32, u32),
    pub optimal_length: f64,
    /// One unit (plus a little) in the last printed digit of `optimal_length`: the tolerance a
    /// comparison with this file's precision can honestly use. Not half a unit: the MAPF
    /// benchmark files truncate (107.970562748 is printed as 107.97056274). Plus one part in 1e9
    /// of the length: long paths in `maze512` drift by ~1e-10 relative (their generator summed a
    /// rounded sqrt 2). Any other octile length differs by far more (a + b sqrt 2 is irrational).
    pub tolerance: f64,
}

/// Parses a `.scen` file (both header variants).
pub fn parse_scenarios(text: &[u8]) -> Result<Vec<MovingAiScenario>, MapError> {
    let text = std::str::from_utf8(text).map_err(|_| fmt_err("scen is not text"))?;
    let mut out = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let words: Vec<&str> = line.split_whitespace().collect();
        if words.is_empty() || words[0] == "version" {
            continue;
        }
        if words.len() != 9 {
            return Err(fmt_err(&format!(
                "scen line {}: expected 9 columns, found {}",
                n + 1,
                words.len()
            )));
        }
        let num = |i: usize| -> Result<u32, MapError> {
            words[i]
                .parse()
                .map_err(|_| fmt_err(&format!("scen line {}: bad number `{}`", n + 1, words[i])))
        };
        let opt_text = words[8];
        let optimal_length: f64 = opt_text
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite() && *v >= 0.0)
            .ok_or_else(|| {
                fmt_err(&format!(
                    "scen line {}: optimal length `{opt_text}` is not a finite non-negative number",
                    n + 1
                ))
            })?;
        // The unit of the last printed digit. A number without a point comes from `%g`, which
        // drops trailing zeros: `1` is 1.00000, six significant digits.
        let last_digit = match opt_text.split_once('.') {
            Some((_, frac)) => 10f64.powi(-(frac.len() as i32)),
            None => 10f64.powi(opt_text.trim_start_matches('-').len() as i32 - 6),
        };
        out.push(MovingAiScenario {
            bucket: num(0)?,
            map: words[1]
                .rsplit(['/', '\\'])
                .next()
                .unwrap_or(words[1])
                .to_string(),
            start: (num(4)?, num(5)?),
            goal: (num(6)?, num(7)?),
            optimal_length,
            tolerance: 1.01 * last_digit + 1e-9 * optimal_length,
        });
    }
    Ok(out)
}

fn parse_dim(v: &str) -> Result<u32, MapError> {
    v.parse()
        .map_err(|_| fmt_err(&format!("bad dimension `{v}`")))
}

fn fmt_err(msg: &str) -> MapError {
    MapError::Format(format!("moving ai: {msg}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_map_and_flips_rows() {
        let m = MovingAiMap::parse(b"type octile\nheight 2\nwidth 3\nmap\n.@T\nGOS\n").unwrap();
        // Top row of the file becomes grid row 1.
        assert_eq!(m.grid.data(), &[0, 100, 100, 0, 100, 100]);
        assert_eq!(m.cell(1, 0), Cell::new(1, 1));
        assert_eq!(m.grid.info().resolution, 1.0);
    }

    #[test]
    fn rejects_bad_maps() {
        assert!(MovingAiMap::parse(b"type octile\nheight 2\nwidth 2\nmap\n..\n").is_err());
        assert!(MovingAiMap::parse(b"type octile\nheight 1\nwidth 2\nmap\n.X\n").is_err());
        assert!(MovingAiMap::parse(b"type octile\nwidth 2\nmap\n..\n").is_err());
    }

    /// Inputs the fuzzer found: a header that asks for more than the file holds (or than the
    /// cell cap allows) is refused before anything is allocated, and an overflowing height is an
    /// error, not a panic.
    #[test]
    fn the_header_cannot_choose_the_allocation() {
        for text in [
            "type octile\nheight 4294967295\nwidth 1\nmap\n.\n",
            "type octile\nheight 4294967295\nwidth 4294967295\nmap\n",
            "type octile\nheight 100000\nwidth 100000\nmap\n..\n",
            "type octile\nheight 3000\nwidth 3000\nmap\n...\n",
            "type octile\nheight 0\nwidth 5\nmap\n",
        ] {
            assert!(MovingAiMap::parse(text.as_bytes()).is_err(), "{text}");
        }
    }

    #[test]
    fn a_scen_with_a_nan_inf_or_negative_optimum_is_malformed() {
        for opt in ["inf", "-inf", "NaN", "-1.5"] {
            let text = format!("version 1\n0\ta.map\t9\t9\t1\t1\t1\t2\t{opt}\n");
            let err = parse_scenarios(text.as_bytes()).unwrap_err().to_string();
            assert!(err.contains("line 2") && err.contains(opt), "{err}");
        }
    }

    #[test]
    fn both_scen_headers_and_precision() {
        let v1 = parse_scenarios(
            b"version 1\n0\tmaps/dao/arena.map\t49\t49\t1\t11\t1\t12\t1.41421356\n",
        )
        .unwrap();
        assert_eq!(v1[0].map, "arena.map");
        assert_eq!(v1[0].start, (1, 11));
        assert!((v1[0].tolerance - (1.01e-8 + 1.41421356e-9)).abs() < 1e-20);
        let v10 = parse_scenarios(
            b"version 1.0\n61 maps/bgmaps/AR0011SR.map 512 512 210 395 87 201 244.95\n",
        )
        .unwrap();
        assert_eq!(v10[0].goal, (87, 201));
        assert!((v10[0].tolerance - (0.0101 + 244.95e-9)).abs() < 1e-12);
        assert!(parse_scenarios(b"version 1\n0 a.map 1 1 0 0\n").is_err());
        // `%g` integers carry six significant digits.
        let g = parse_scenarios(b"version 1\n0 a.map 9 9 1 1 1 2 1\n").unwrap();
        assert!((g[0].tolerance - (1.01e-5 + 1e-9)).abs() < 1e-15);
    }
}
