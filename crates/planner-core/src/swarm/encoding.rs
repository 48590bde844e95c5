//! How a cat (or particle) is a path.
//!
//! - [`Encoding::Lateral`], the patrol car paper's eq. 15–16: rotate the frame so that X' runs from
//!   the start to the goal, cut it into `i + 1` equal parts, and let a cat be the `i` lateral
//!   offsets `y'_j` at those stations. Compact and the paper's own, but it can only express paths
//!   that move monotonically along X'.
//! - [`Encoding::General`]: `i` free 2-D waypoints (`2 i` numbers), for maps where no monotone path
//!   exists (a U trap between start and goal, `docs/papers.md`).
//!
//! [`Encoding::choose`] keeps the paper's encoding wherever the seed path can be expressed in it
//! without collision, and reports which one it used.

use crate::geometry::{Point2, Vector2};
use crate::grid::inflation::PlanningGrid;
use crate::grid::raycast::path_is_free;

#[derive(Clone, Debug)]
pub enum Encoding {
    Lateral {
        start: Point2,
        goal: Point2,
        /// Unit vector along X' (start to goal) and its left normal Y'.
        along: Vector2,
        normal: Vector2,
        /// X' of each station, `j * L / (i + 1)`.
        stations: Vec<f64>,
        lo: Vec<f64>,
        hi: Vec<f64>,
    },
    General {
        start: Point2,
        goal: Point2,
        lo: Vec<f64>,
        hi: Vec<f64>,
    },
}

impl Encoding {
    /// The paper's encoding with `i` stations; each offset ranges over the part of its station's
    /// normal line that lies inside the map. `None` when start and goal coincide.
    pub fn lateral(grid: &PlanningGrid, start: Point2, goal: Point2, i: usize) -> Option<Self> {
        let d = goal - start;
        let len = d.norm();
        if len < 1e-9 {
            return None;
        }
        let along = d / len;
        let normal = Vector2::new(-along.y, along.x);
        let (w, h) = (grid.width() as f64, grid.height() as f64);
        let mut stations = Vec::with_capacity(i);
        let (mut lo, mut hi) = (Vec::with_capacity(i), Vec::with_capacity(i));
        for j in 1..=i {
            let x = j as f64 * len / (i + 1) as f64;
            let base = start + along * x;
            // Slab intersection of the normal line with the map rectangle.
            let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
            for (b, n, size) in [(base.x, normal.x, w), (base.y, normal.y, h)] {
                if n.abs() < 1e-12 {
                    continue;
                }
                let (a, c) = ((0.0 - b) / n, (size - b) / n);
                t0 = t0.max(a.min(c));
                t1 = t1.min(a.max(c));
            }
            stations.push(x);
            lo.push(t0);
            hi.push(t1);
        }
        Some(Encoding::Lateral {
            start,
            goal,
            along,
            normal,
            stations,
            lo,
            hi,
        })
    }

    /// `i` free waypoints anywhere in the map.
    pub fn general(grid: &PlanningGrid, start: Point2, goal: Point2, i: usize) -> Self {
        let (w, h) = (grid.width() as f64, grid.height() as f64);
        let lo = vec![0.0; 2 * i];
        let hi = (0..2 * i).map(|k| if k % 2 == 0 { w } else { h }).collect();
        Encoding::General {
            start,
            goal,
            lo,
            hi,
        }
    }

    pub fn name(&self) -> &'static str {
        match self {
            Encoding::Lateral { .. } => "lateral (eq. 15-16)",
            Encoding::General { .. } => "general (free waypoints)",
        }
    }

    pub fn dim(&self) -> usize {
        self.lo().len()
    }

    pub fn lo(&self) -> &[f64] {
        match self {
            Encoding::Lateral { lo, .. } | Encoding::General { lo, .. } => lo,
        }
    }

    pub fn hi(&self) -> &[f64] {
        match self {
            Encoding::Lateral { hi, .. } | Encoding::General { hi, .. } => hi,
        }
    }

    /// Narrows every dimension's range to `centre[d] +- half_width` (grid units), within the range
    /// it had: a corridor around the seed, so that the search (and its steps, which are shares
    /// of each range) scales with the query rather than with the map.
    pub fn narrow(&mut self, centre: &[f64], half_width: f64) {
        let (Encoding::Lateral { lo, hi, .. } | Encoding::General { lo, hi, .. }) = self;
        for ((l, h), &c) in lo.iter_mut().zip(hi.iter_mut()).zip(centre) {
            *l = l.max(c - half_width);
            *h = h.min(c + half_width);
        }
    }

    /// The number of waypoints a vector holds (its dimension for lateral, half of it for general).
    pub fn waypoints(&self) -> usize {
        match self {
            Encoding::Lateral { stations, .. } => stations.len(),
            Encoding::General { lo, .. } => lo.len() / 2,
        }
    }

    /// One step of Laplacian smoothing on waypoints `from..to`: each moves `lambda` of the way
    /// to the midpoint of its two neighbours (the start and the goal at the ends), all from the
    /// old positions. A path's turning falls and its length never grows where the step applies;
    /// whether the smoothed path is still free is for the evaluation to say. Lateral: the
    /// offsets, since the stations are evenly spaced and start and goal sit at offset 0.
    pub fn smooth(&self, x: &mut [f64], from: usize, to: usize, lambda: f64) {
        let to = to.min(self.waypoints());
        if from >= to {
            return;
        }
        let old: Vec<f64> = x.to_vec();
        match self {
            Encoding::Lateral { .. } => {
                let at = |j: isize| -> f64 {
                    if j < 0 || j as usize >= old.len() {
                        0.0
                    } else {
                        old[j as usize]
                    }
                };
                for j in from..to {
                    let mid = 0.5 * (at(j as isize - 1) + at(j as isize + 1));
                    x[j] += lambda * (mid - old[j]);
                }
            }
            Encoding::General { start, goal, .. } => {
                let n = old.len() / 2;
                let at = |j: isize| -> Point2 {
                    if j < 0 {
                        *start
                    } else if j as usize >= n {
                        *goal
                    } else {
                        Point2::new(old[2 * j as usize], old[2 * j as usize + 1])
                    }
                };
                for j in from..to {
                    let (a, b) = (at(j as isize - 1), at(j as isize + 1));
                    let mid = a + (b - a) * 0.5;
                    x[2 * j] += lambda * (mid.x - old[2 * j]);
                    x[2 * j + 1] += lambda * (mid.y - old[2 * j + 1]);
                }
            }
        }
    }

    /// The polyline `[start, M_1, ..., M_i, goal]` (grid coordinates) of a vector, into `out`.
    pub fn decode_into(&self, x: &[f64], out: &mut Vec<Point2>) {
        out.clear();
        match self {
            Encoding::Lateral {
                start,
                goal,
                along,
                normal,
                stations,
                ..
            } => {
                out.push(*start);
                // Eq. 15: M_j = N_0 + R(phi) [x'_j, y'_j].
                out.extend(
                    stations
                        .iter()
                        .zip(x)
                        .map(|(&xs, &y)| start + along * xs + normal * y),
                );
                out.push(*goal);
            }
            Encoding::General { start, goal, .. } => {
                out.push(*start);
                out.extend(x.chunks_exact(2).map(|p| Point2::new(p[0], p[1])));
                out.push(*goal);
            }
        }
    }

    pub fn decode(&self, x: &[f64]) -> Vec<Point2> {
        let mut v = Vec::new();
        self.decode_into(x, &mut v);
        v
    }

    /// The vector that best represents a path (grid coordinates, from start to goal):
    /// lateral: the path's offset where it first crosses each station's normal line (`None` if it
    /// misses one); general: its vertices, with the longest segments split until there are
    /// exactly `i` (`None` if it has more than `i` interior vertices).
    pub fn encode(&self, path: &[Point2]) -> Option<Vec<f64>> {
        match self {
            Encoding::Lateral {
                start,
                along,
                normal,
                stations,
                ..
            } => {
                let proj: Vec<(f64, f64)> = path
                    .iter()
                    .map(|p| ((p - start).dot(along), (p - start).dot(normal)))
                    .collect();
                stations
                    .iter()
                    .map(|&xs| {
                        proj.windows(2).find_map(|w| {
                            let ((x0, y0), (x1, y1)) = (w[0], w[1]);
                            let crosses = (x0 - xs) * (x1 - xs) <= 0.0 && (x1 - x0).abs() > 1e-12;
                            crosses.then(|| y0 + (y1 - y0) * (xs - x0) / (x1 - x0))
                        })
                    })
                    .collect()
            }
            Encoding::General { .. } => {
                let i = self.dim() / 2;
                let mut pts = path.to_vec();
                if pts.len() < 2 || pts.len() - 2 > i {
                    return None;
                }
                while pts.len() - 2 < i {
                    let k = (0..pts.len() - 1)
                        .max_by(|&a, &b| {
                            (pts[a + 1] - pts[a])
                                .norm()
                                .total_cmp(&(pts[b + 1] - pts[b]).norm())
                        })
                        .expect("at least one segment");
                    let mid = pts[k] + (pts[k + 1] - pts[k]) * 0.5;
                    pts.insert(k + 1, mid);
                }
                Some(
                    pts[1..pts.len() - 1]
                        .iter()
                        .flat_map(|p| [p.x, p.y])
                        .collect(),
                )
            }
        }
    }

    /// Chooses the encoding for a feasible seed path: the paper's lateral one when the seed,
    /// expressed in it, is still collision-free; otherwise the general one (with more waypoints
    /// than `i` when the seed has more corners, so the seed itself is always expressible).
    /// Returns the encoding and the seed's vector, which decodes to a collision-free path.
    pub fn choose(
        grid: &PlanningGrid,
        seed: &[Point2],
        i: usize,
        allow_lateral: bool,
    ) -> (Self, Vec<f64>) {
        let (start, goal) = (seed[0], seed[seed.len() - 1]);
        if allow_lateral {
            if let Some(enc) = Encoding::lateral(grid, start, goal, i) {
                if let Some(x) = enc.encode(seed) {
                    if path_is_free(grid, &enc.decode(&x)) {
                        return (enc, x);
                    }
                }
            }
        }
        let enc = Encoding::general(grid, start, goal, i.max(seed.len().saturating_sub(2)));
        let x = enc
            .encode(seed)
            .expect("the general encoding has room for every seed vertex");
        (enc, x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::grid_from_rows;

    #[test]
    fn eq15_round_trip_and_geometry() {
        let grid = grid_from_rows(&[".........."; 8]);
        let (s, g) = (Point2::new(1.0, 1.0), Point2::new(9.0, 7.0));
        let enc = Encoding::lateral(&grid, s, g, 4).unwrap();
        let x = vec![0.5, -1.0, 2.0, 0.0];
        let path = enc.decode(&x);
        assert_eq!(path.len(), 6);
        assert_eq!(path[0], s);
        assert_eq!(path[5], g);
        // Stations are equally spaced along the start-goal axis (|sg| = 10, i + 1 = 5 parts).
        let along = (g - s) / 10.0;
        for (j, p) in path[1..5].iter().enumerate() {
            assert!(((p - s).dot(&along) - 2.0 * (j + 1) as f64).abs() < 1e-12);
        }
        let back = enc.encode(&path).unwrap();
        for (a, b) in back.iter().zip(&x) {
            assert!((a - b).abs() < 1e-12);
        }
        // Bounds: each station's normal line clipped to the map.
        for ((&l, &h), p) in enc.lo().iter().zip(enc.hi()).zip(&path[1..5]) {
            assert!(l < 0.0 && h > 0.0);
            let (n, base) = (
                Vector2::new(-along.y, along.x),
                p - Vector2::new(-along.y, along.x) * 0.0,
            );
            for t in [l, h] {
                let q = base + n * (t - (p - s).dot(&n));
                assert!(q.x > -1e-9 && q.x < 10.0 + 1e-9 && q.y > -1e-9 && q.y < 8.0 + 1e-9);
            }
        }
    }

    #[test]
    fn smoothing_moves_each_waypoint_half_way_to_its_neighbours_midpoint() {
        use crate::grid::metrics::{path_length, total_turning};
        let grid = grid_from_rows(&[".........."; 8]);
        let (s, g) = (Point2::new(1.0, 4.0), Point2::new(9.0, 4.0));
        let enc = Encoding::lateral(&grid, s, g, 4).unwrap();
        // Lateral: the ends' neighbours are the start and the goal, at offset 0; every new value
        // comes from the old ones (a Jacobi step): j0 mid (0 + -1)/2, j1 mid (1 + 1)/2, ...
        let zigzag = vec![1.0, -1.0, 1.0, -1.0];
        let mut x = zigzag.clone();
        enc.smooth(&mut x, 0, 4, 0.5);
        assert_eq!(x, vec![0.25, 0.0, 0.0, -0.25]);
        let (before, after) = (enc.decode(&zigzag), enc.decode(&x));
        assert!(total_turning(&after) < total_turning(&before));
        assert!(path_length(&after) < path_length(&before));
        // Only the run asked for moves; a run past the end is cut to the waypoints there are.
        let mut y = zigzag.clone();
        enc.smooth(&mut y, 1, 99, 1.0);
        assert_eq!(y, vec![1.0, 1.0, -1.0, 0.5]);
        // General: 2-D waypoints, the same rule per coordinate.
        let gen = Encoding::general(&grid, s, g, 2);
        let mut z = vec![3.0, 6.0, 5.0, 2.0];
        gen.smooth(&mut z, 0, 2, 0.5);
        // Waypoint 0: mid of (1, 4) and (5, 2) = (3, 3); waypoint 1: mid of (3, 6) and (9, 4) = (6, 5).
        assert_eq!(z, vec![3.0, 4.5, 5.5, 3.5]);
    }

    #[test]
    fn a_wall_keeps_the_lateral_encoding_but_a_u_trap_needs_the_general_one() {
        // A wall between S and G: going over it is monotone along S-G, so the paper's encoding
        // expresses the seed.
        let wall = grid_from_rows(&[
            "..........",
            "..........",
            "....#.....",
            "....#.....",
            ".S..#..G..",
            "....#.....",
        ]);
        let seed = vec![
            Point2::new(1.5, 1.5),
            Point2::new(3.5, 5.5),
            Point2::new(5.5, 5.5),
            Point2::new(7.5, 1.5),
        ];
        assert!(path_is_free(&wall, &seed));
        let (enc, x) = Encoding::choose(&wall, &seed, 8, true);
        assert!(matches!(enc, Encoding::Lateral { .. }));
        assert!(path_is_free(&wall, &enc.decode(&x)));
        // G inside a U that opens away from S: every path overshoots G's station and comes back.
        let u = grid_from_rows(&[
            "...........",
            "..#######..",
            "..#........",
            "S.#...G....",
            "..#........",
            "..#######..",
            "...........",
        ]);
        let hook = vec![
            Point2::new(0.5, 3.5),
            Point2::new(1.5, 6.5),
            Point2::new(9.5, 6.5),
            Point2::new(9.5, 3.5),
            Point2::new(6.5, 3.5),
        ];
        assert!(path_is_free(&u, &hook));
        let (enc, x) = Encoding::choose(&u, &hook, 6, true);
        assert!(matches!(enc, Encoding::General { .. }), "{}", enc.name());
        assert_eq!(enc.dim(), 12);
        assert!(path_is_free(&u, &enc.decode(&x)));
        // With more corners than waypoints, the dimension grows to keep the seed expressible.
        let (enc, _) = Encoding::choose(&u, &hook, 2, false);
        assert_eq!(enc.dim(), 6);
    }
}
