//! Path metrics, the same for every planner and every table: length, total turning angle
//! (patrol car paper eq. 17), number of turns, minimum and mean clearance, the costmap cost
//! along the path, and feasibility.

use crate::geometry::{wrap_angle, Cell, Point2};
use crate::grid::inflation::PlanningGrid;
use crate::grid::raycast::{path_is_free, supercover};
use rustc_hash::FxHashMap;
use serde::{Deserialize, Serialize};

/// Heading changes smaller than this (rad) are not counted as turns: they are rounding noise.
pub const TURN_EPS: f64 = 1e-6;

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PathMetrics {
    /// Sum of segment lengths (m).
    pub length_m: f64,
    /// Sum of absolute heading changes between consecutive segments (rad), eq. 17.
    pub turning_rad: f64,
    /// Number of heading changes larger than [`TURN_EPS`].
    pub turns: usize,
    /// Smallest clearance (m, cell centre to nearest obstacle cell centre) of any cell the path
    /// touches.
    pub min_clearance_m: f64,
    /// Clearance (m) averaged over the path's length: how far from obstacles the robot drives
    /// on the whole, where `min_clearance_m` says only how close it comes once. Infinite on a
    /// map without obstacles.
    pub mean_clearance_m: f64,
    /// The costmap cost (see [`PlanningGrid::cost`], 0..252 for free cells) integrated along the
    /// path, as `sum cost / 252 * ds` in metres: 0 for a path that keeps out of the inflation
    /// radius everywhere, the path's length for one that grazes the inflated band all along.
    pub path_cost: f64,
    /// The half-width (m) of the corridors the path runs through, averaged over its length: at
    /// each point, the clearance of the middle of the corridor there ([`ridge_clearance`]). The
    /// most mean clearance a path along the same corridors can have (issue 13: "or the
    /// corridor's half-width, where the corridor is narrower"); `mean_clearance_m` over it says
    /// how well the path keeps to the middle (1: on the middle line all along).
    pub corridor_half_width_m: f64,
    /// Every segment crosses only free cells of the planning grid.
    pub collision_free: bool,
}

/// Sum of segment lengths, in the points' own unit.
pub fn path_length(points: &[Point2]) -> f64 {
    // From +0.0, as `total_turning`: a one-point path is 0 m long, not -0 m.
    points
        .windows(2)
        .fold(0.0, |total, w| total + (w[1] - w[0]).norm())
}

/// The headings of the non-degenerate segments of a polyline.
fn headings(points: &[Point2]) -> impl Iterator<Item = f64> + '_ {
    points.windows(2).filter_map(|w| {
        let d = w[1] - w[0];
        (d.norm_squared() > 0.0).then(|| d.y.atan2(d.x))
    })
}

/// Total turning angle: the patrol car paper's eq. 17, `sum_j |alpha_{j+1} - alpha_j|`, with each
/// segment's heading from `atan2` and the difference wrapped to (-pi, pi] so that paths which are
/// not monotone along the start-goal axis are measured correctly too. Zero-length segments are
/// skipped (they have no heading).
pub fn total_turning(points: &[Point2]) -> f64 {
    // From +0.0: `sum()` of no floats is -0.0, which a straight path's JSON then showed.
    heading_changes(points).fold(0.0, |total, d| total + d.abs())
}

/// Number of heading changes larger than [`TURN_EPS`].
pub fn turn_count(points: &[Point2]) -> usize {
    heading_changes(points)
        .filter(|d| d.abs() > TURN_EPS)
        .count()
}

/// The signed heading change at each vertex between non-degenerate segments, wrapped to
/// (-pi, pi]. No allocation: the swarms call this for every feasible candidate.
fn heading_changes(points: &[Point2]) -> impl Iterator<Item = f64> + '_ {
    let mut previous: Option<f64> = None;
    headings(points).filter_map(move |h| previous.replace(h).map(|p| wrap_angle(h - p)))
}

/// [`path_length`] and [`total_turning`] of a polyline given one point at a time: the same
/// terms summed in the same order from the same start, so the same bits. The pulled judge
/// ([`crate::judge`]) measures a path while the delete operation is still straightening it, to
/// stop as soon as the prefix cannot win, or to resume from a beginning measured before.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunningMeasure {
    at: Point2,
    /// The heading of the last segment of nonzero length.
    heading: Option<f64>,
    /// [`path_length`] of the points so far.
    pub length: f64,
    /// [`total_turning`] of the points so far.
    pub turning: f64,
}

impl RunningMeasure {
    /// The measure of the one-point polyline `first`.
    pub fn start(first: Point2) -> Self {
        Self {
            at: first,
            heading: None,
            length: path_length(&[]),
            turning: total_turning(&[]),
        }
    }

    /// The measure with `p` appended.
    pub fn push(&mut self, p: Point2) {
        let d = p - self.at;
        self.length += d.norm();
        if d.norm_squared() > 0.0 {
            let h = d.y.atan2(d.x);
            if let Some(before) = self.heading.replace(h) {
                self.turning += wrap_angle(h - before).abs();
            }
        }
        self.at = p;
    }
}

/// Removes waypoints that lie on the straight line through their neighbours (and repeated
/// points). The geometry of the path is unchanged; only redundant vertices go.
pub fn drop_collinear(points: &[Point2]) -> Vec<Point2> {
    let mut out: Vec<Point2> = Vec::with_capacity(points.len());
    for &p in points {
        if out.last() == Some(&p) {
            continue;
        }
        if out.len() >= 2 {
            let a = out[out.len() - 2];
            let b = out[out.len() - 1];
            let (u, v) = (b - a, p - b);
            let cross = u.x * v.y - u.y * v.x;
            if cross.abs() <= 1e-9 * u.norm() * v.norm() && u.dot(&v) > 0.0 {
                out.pop();
            }
        }
        out.push(p);
    }
    out
}

/// Smallest clearance (m) over every cell the polyline (grid coordinates) touches.
pub fn min_clearance(grid: &PlanningGrid, points: &[Point2]) -> f64 {
    let mut best = f64::INFINITY;
    let mut visit = |c: Cell| {
        best = best.min(grid.clearance(c));
        true
    };
    match points {
        [] => return 0.0,
        [p] => {
            visit(Cell::containing(*p));
        }
        _ => {
            for w in points.windows(2) {
                supercover(w[0], w[1], &mut visit);
            }
        }
    }
    best
}

/// Samples a polyline (grid coordinates) every `step` cells or less: each sample's cell and the
/// length (cells) it stands for.
fn samples(points: &[Point2], step: f64) -> impl Iterator<Item = (Cell, f64)> + '_ {
    points.windows(2).flat_map(move |w| {
        let d = w[1] - w[0];
        let len = d.norm();
        let n = ((len / step).ceil() as usize).max(1);
        let ds = len / n as f64;
        (0..n).map(move |k| {
            (
                Cell::containing(w[0] + d * ((k as f64 + 0.5) / n as f64)),
                ds,
            )
        })
    })
}

/// A per-cell value averaged over the length of a polyline (grid coordinates): each sample's
/// cell weighted by the length it stands for; a polyline of no length takes its first point's.
fn length_average(points: &[Point2], mut value: impl FnMut(Cell) -> f64) -> f64 {
    let (mut sum, mut len) = (0.0, 0.0);
    for (c, ds) in samples(points, 0.25) {
        sum += value(c) * ds;
        len += ds;
    }
    if len > 0.0 {
        sum / len
    } else {
        points.first().map_or(0.0, |p| value(Cell::containing(*p)))
    }
}

/// Clearance (m) averaged over the length of a polyline (grid coordinates).
pub fn mean_clearance(grid: &PlanningGrid, points: &[Point2]) -> f64 {
    length_average(points, |c| grid.clearance(c))
}

/// The clearance (m) of the middle of the corridor at cell `c`: from `c`, step to the neighbour
/// of largest clearance while that gains at least half the step, i.e. while moving more away
/// from the nearest obstacle than along it. Across a corridor that climb runs straight from the
/// wall to the middle line, where clearance stops growing (it can only grow along the middle
/// line by less than half a step, towards a junction or a room, and the climb stops there).
/// Infinite on a map without obstacles; 0 outside the map. An approximation where the nearest
/// obstacle is the map's edge (the edge is not an obstacle to the distance field, so the climb
/// may run on towards it) or where a wide opening beside a point leads the climb into the space
/// beyond it.
pub fn ridge_clearance(grid: &PlanningGrid, c: Cell) -> f64 {
    ridge_clearance_cached(grid, c, &mut FxHashMap::default())
}

/// [`ridge_clearance`], remembering the answer of every cell a climb passed through: the climb
/// from any of them follows the same steps to the same end, so a path's many samples climb each
/// cell once.
fn ridge_clearance_cached(grid: &PlanningGrid, c: Cell, known: &mut FxHashMap<Cell, f64>) -> f64 {
    if let Some(&h) = known.get(&c) {
        return h;
    }
    let res = grid.resolution();
    let mut climb = vec![c];
    let mut here = grid.clearance(c);
    let top = if !here.is_finite() || here <= 0.0 {
        here
    } else {
        loop {
            let cur = climb[climb.len() - 1];
            let mut next = None;
            for (dx, dy) in crate::geometry::NEIGHBOURS_8 {
                let n = cur.offset(dx, dy);
                let gain = grid.clearance(n) - here;
                let step = if dx != 0 && dy != 0 {
                    std::f64::consts::SQRT_2
                } else {
                    1.0
                } * res;
                if gain >= 0.5 * step && next.is_none_or(|(_, best)| gain > best) {
                    next = Some((n, gain));
                }
            }
            match next {
                Some((n, _)) => {
                    if let Some(&h) = known.get(&n) {
                        break h;
                    }
                    climb.push(n);
                    here = grid.clearance(n);
                }
                None => break here,
            }
        }
    };
    for cell in climb {
        known.insert(cell, top);
    }
    top
}

/// [`ridge_clearance`] averaged over the length of a polyline (grid coordinates), in metres.
pub fn corridor_half_width(grid: &PlanningGrid, points: &[Point2]) -> f64 {
    let mut known = FxHashMap::default();
    length_average(points, |c| ridge_clearance_cached(grid, c, &mut known))
}

/// The costmap cost integrated along a polyline (grid coordinates): `sum cost / 252 * ds`, in
/// metres.
pub fn path_cost(grid: &PlanningGrid, points: &[Point2]) -> f64 {
    samples(points, 0.25).fold(0.0, |total, (c, ds)| {
        total + grid.cost(c) as f64 / 252.0 * ds
    }) * grid.resolution()
}

/// All metrics of a polyline given in grid coordinates; lengths are reported in metres.
pub fn measure(grid: &PlanningGrid, points: &[Point2]) -> PathMetrics {
    PathMetrics {
        length_m: path_length(points) * grid.resolution(),
        turning_rad: total_turning(points),
        turns: turn_count(points),
        min_clearance_m: min_clearance(grid, points),
        mean_clearance_m: mean_clearance(grid, points),
        path_cost: path_cost(grid, points),
        corridor_half_width_m: corridor_half_width(grid, points),
        collision_free: path_is_free(grid, points),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_4, PI};

    proptest::proptest! {
        /// A running measure is `path_length` and `total_turning` bit for bit, at every prefix of
        /// random polylines with repeated points and turns either way past pi.
        #[test]
        fn a_running_measure_is_path_length_and_total_turning(
            raw in proptest::collection::vec((-5i32..5, -5i32..5, 0u8..4), 1..24),
        ) {
            let points: Vec<Point2> = raw
                .iter()
                .map(|&(x, y, hair)| Point2::new(x as f64 + hair as f64 * 1e-3, y as f64 / 3.0))
                .collect();
            let mut running = RunningMeasure::start(points[0]);
            for n in 1..=points.len() {
                if n > 1 {
                    running.push(points[n - 1]);
                }
                proptest::prop_assert_eq!(running.length.to_bits(), path_length(&points[..n]).to_bits());
                proptest::prop_assert_eq!(running.turning.to_bits(), total_turning(&points[..n]).to_bits());
            }
        }
    }

    fn pts(v: &[(f64, f64)]) -> Vec<Point2> {
        v.iter().map(|&(x, y)| Point2::new(x, y)).collect()
    }

    #[test]
    fn eq17_on_polylines_with_known_angles() {
        // Right angle left, then right angle right: pi/2 + pi/2.
        let p = pts(&[(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (2.0, 1.0)]);
        assert!((total_turning(&p) - PI).abs() < 1e-12);
        assert_eq!(turn_count(&p), 2);
        // A 45 degree bend.
        let p = pts(&[(0.0, 0.0), (1.0, 0.0), (2.0, 1.0)]);
        assert!((total_turning(&p) - FRAC_PI_4).abs() < 1e-12);
        // Heading across the +-pi seam: from 170 deg to -170 deg is a 20 deg turn, not 340.
        let a = 170f64.to_radians();
        let p = pts(&[
            (0.0, 0.0),
            (a.cos(), a.sin()),
            (a.cos() + (-a).cos(), a.sin() + (-a).sin()),
        ]);
        assert!((total_turning(&p) - 20f64.to_radians()).abs() < 1e-9);
        // A U-turn counts pi; a straight line counts nothing, repeated points are skipped.
        assert!((total_turning(&pts(&[(0.0, 0.0), (1.0, 0.0), (0.0, 0.0)])) - PI).abs() < 1e-12);
        assert_eq!(
            total_turning(&pts(&[(0.0, 0.0), (1.0, 1.0), (1.0, 1.0), (2.0, 2.0)])),
            0.0
        );
        assert!((path_length(&pts(&[(0.0, 0.0), (3.0, 4.0), (3.0, 5.0)])) - 6.0).abs() < 1e-12);
    }

    #[test]
    fn drop_collinear_keeps_corners_only() {
        let p = pts(&[
            (0.0, 0.0),
            (1.0, 0.0),
            (2.0, 0.0),
            (2.0, 0.0),
            (3.0, 1.0),
            (4.0, 2.0),
            (4.0, 3.0),
        ]);
        assert_eq!(
            drop_collinear(&p),
            pts(&[(0.0, 0.0), (2.0, 0.0), (4.0, 2.0), (4.0, 3.0)])
        );
        // A U-turn's tip is not collinear-redundant.
        let u = pts(&[(0.0, 0.0), (1.0, 0.0), (0.0, 0.0)]);
        assert_eq!(drop_collinear(&u), u);
    }

    /// A corridor 11 cells wide (walls in rows y = 0 and y = 12, 0.1 m cells) that opens into a
    /// room 40 cells high: along the corridor the half-width is 0.6 m wherever the path runs,
    /// by the wall or on the middle line, and the climb does not run along the middle line into
    /// the room; in the room the middle is the room's.
    #[test]
    fn corridor_half_width_is_the_middles_clearance() {
        use crate::test_support::grid_with;
        let grid = grid_with((80, 42), 0.1, 0.0, |x, y| {
            let wall = y == 0 || y == 41;
            let corridor_wall = x < 40 && y >= 12;
            wall || corridor_wall || x == 79
        });
        // By the wall (clearance 0.1 m) and on the middle line (0.6 m), from x = 2 to x = 20.
        let by_wall = pts(&[(2.5, 1.5), (20.5, 1.5)]);
        let middle = pts(&[(2.5, 6.5), (20.5, 6.5)]);
        assert!((mean_clearance(&grid, &by_wall) - 0.1).abs() < 1e-9);
        assert!((mean_clearance(&grid, &middle) - 0.6).abs() < 1e-9);
        // Up to the corridor's mouth at x = 40.
        let to_mouth = pts(&[(2.5, 6.5), (39.5, 6.5)]);
        for path in [&by_wall, &middle, &to_mouth] {
            let h = corridor_half_width(&grid, path);
            assert!((h - 0.6).abs() < 1e-9, "{h}");
        }
        // Up to the last cells before the mouth, by either wall or in the middle. The one cell
        // at the corner itself climbs out of the corridor a little (0.7 m): the documented
        // approximation beside an opening, one cell wide here.
        for x in 30..40 {
            for y in [1, 6, 11] {
                let h = ridge_clearance(&grid, Cell::new(x, y));
                let want = if (x, y) == (39, 11) { 0.7 } else { 0.6 };
                assert!((h - want).abs() < 1e-9, "({x}, {y}): {h}");
            }
        }
        // In the room (x 40..78, y 1..40), far from the corridor's mouth: the room's middle,
        // 2.0 m from the floor and ceiling walls.
        let room = ridge_clearance(&grid, Cell::new(60, 3));
        assert!((room - 2.0).abs() < 0.05, "{room}");
    }
}
