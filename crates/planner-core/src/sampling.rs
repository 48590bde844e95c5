//! Random queries and routes on any map, so any map can be benchmarked without a scenario file.
//!
//! Start/goal pairs follow the rules of Nav2's planner benchmark (navigation2
//! `tools/planner_benchmarking/metrics.py`): both cells drawn uniformly away from the map's border
//! (there `randint(100, 1900)` on its 2000-cell map: a 5 % margin on each side), both with a
//! costmap cost below 210 (here also free in the planning grid), the goal more than 3 m from the
//! start. Nav2 draws with Python's `random.seed(33)`; these draws come from the planner's seeded
//! ChaCha RNG, so the same seed gives the same queries on every machine, but not Nav2's own
//! pairs. Whether a pair is connected is not checked: a benchmark reports a pair with no path as
//! such (A* answers NO_VALID_PATH), it never drops it. On a map that is mostly unknown (a SLAM
//! map on a fixed canvas) the draws over the whole map may run out before enough pairs are
//! found; the rest are then drawn among the usable cells themselves.
//!
//! Random routes draw their points from the free cells connected to their start (8-neighbour
//! moves), so that every point is reachable and an ordering's saving is measured on the whole
//! route.

use crate::geometry::{Cell, Point2};
use crate::grid::inflation::PlanningGrid;
use crate::planner::PlannerRng;
use crate::route::file::{RouteFile, RoutePoint, RoutePose};
use rand::Rng;
use std::collections::VecDeque;

/// How random start/goal pairs are drawn (defaults: Nav2's benchmark).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QuerySampling {
    /// The goal lies more than this far (m) from the start. Default 3.
    pub min_distance_m: f64,
    /// Cells within this share of the width (height) of the left and right (top and bottom)
    /// edges are never drawn. Default 0.05.
    pub border_share: f64,
    /// Both cells cost less than this (costmap_2d's 0..254 scale). Default 210.
    pub max_cost: u8,
    /// Draws tried per pair before giving up on a map with too little room. Default 10 000.
    pub attempts_per_pair: usize,
}

impl Default for QuerySampling {
    fn default() -> Self {
        Self {
            min_distance_m: 3.0,
            border_share: 0.05,
            max_cost: 210,
            attempts_per_pair: 10_000,
        }
    }
}

/// Why no queries could be drawn.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SamplingError {
    #[error("after {attempts} draws only {found} of {wanted} start/goal pairs fit the map (free cells away from the border, the goal more than {min_distance_m} m from the start)")]
    TooFewPairs {
        wanted: usize,
        found: usize,
        attempts: usize,
        min_distance_m: f64,
    },
    #[error("the map has {free} free cells connected to the start, {wanted} needed")]
    TooFewPoints { wanted: usize, free: usize },
}

/// `n` start/goal pairs in map metres (cell centres), drawn as Nav2's benchmark draws them.
pub fn random_queries(
    grid: &PlanningGrid,
    n: usize,
    rng: &mut PlannerRng,
    s: &QuerySampling,
) -> Result<Vec<(Point2, Point2)>, SamplingError> {
    let (w, h) = (grid.width() as i32, grid.height() as i32);
    let (bx, by) = (
        (w as f64 * s.border_share).floor() as i32,
        (h as f64 * s.border_share).floor() as i32,
    );
    let usable = |c: Cell| grid.is_free(c) && grid.cost(c) < s.max_cost;
    let info = grid.info();
    let draw = |rng: &mut PlannerRng| {
        let c = Cell::new(rng.random_range(bx..w - bx), rng.random_range(by..h - by));
        usable(c).then_some(c)
    };
    let mut pairs = Vec::with_capacity(n);
    let budget = s.attempts_per_pair.saturating_mul(n.max(1));
    let mut attempts = 0;
    if bx * 2 >= w || by * 2 >= h {
        return Err(SamplingError::TooFewPairs {
            wanted: n,
            found: 0,
            attempts,
            min_distance_m: s.min_distance_m,
        });
    }
    while pairs.len() < n && attempts < budget {
        attempts += 1;
        let (Some(a), Some(b)) = (draw(rng), draw(rng)) else {
            continue;
        };
        let (pa, pb) = (info.cell_to_world(a), info.cell_to_world(b));
        if (pa - pb).norm() > s.min_distance_m {
            pairs.push((pa, pb));
        }
    }
    if pairs.len() < n {
        // A SLAM map on a fixed canvas can be 97 % unknown (gmapping's 4000 x 4000 default, a
        // small mapped area in its middle), where drawing over the whole map finds too few
        // pairs. The rest are drawn among the usable cells themselves: the same uniform
        // distribution, without the wasted draws. Drawing over the map first keeps every
        // map's queries for a seed as they were before this fallback existed.
        let cells: Vec<Cell> = (by..h - by)
            .flat_map(|y| (bx..w - bx).map(move |x| Cell::new(x, y)))
            .filter(|&c| usable(c))
            .collect();
        let mut more = 0;
        while !cells.is_empty() && pairs.len() < n && more < budget {
            more += 1;
            attempts += 1;
            let a = cells[rng.random_range(0..cells.len())];
            let b = cells[rng.random_range(0..cells.len())];
            let (pa, pb) = (info.cell_to_world(a), info.cell_to_world(b));
            if (pa - pb).norm() > s.min_distance_m {
                pairs.push((pa, pb));
            }
        }
    }
    if pairs.len() < n {
        return Err(SamplingError::TooFewPairs {
            wanted: n,
            found: pairs.len(),
            attempts,
            min_distance_m: s.min_distance_m,
        });
    }
    Ok(pairs)
}

/// A route of `points` inspection points (random headings, no dwell) and a start, all on free
/// cells connected to the start (a random free cell), in the order drawn.
pub fn random_route(
    grid: &PlanningGrid,
    points: usize,
    rng: &mut PlannerRng,
) -> Result<RouteFile, SamplingError> {
    let free: Vec<Cell> = (0..grid.info().cell_count())
        .map(|i| grid.info().cell_at(i))
        .filter(|&c| grid.is_free(c))
        .collect();
    if free.len() <= points {
        return Err(SamplingError::TooFewPoints {
            wanted: points + 1,
            free: free.len(),
        });
    }
    // The start in a component with room for the route: a few tries, then the largest seen.
    let mut best: Vec<Cell> = Vec::new();
    for _ in 0..8 {
        let start = free[rng.random_range(0..free.len())];
        let component = connected(grid, start);
        if component.len() > best.len() {
            best = component;
        }
        if best.len() > points * 4 {
            break;
        }
    }
    if best.len() <= points {
        return Err(SamplingError::TooFewPoints {
            wanted: points + 1,
            free: best.len(),
        });
    }
    // The start and `points` distinct cells of the component (partial Fisher-Yates).
    for k in 0..=points {
        let j = rng.random_range(k..best.len());
        best.swap(k, j);
    }
    let info = grid.info();
    let yaw = |rng: &mut PlannerRng| rng.random_range(-std::f64::consts::PI..std::f64::consts::PI);
    let s = info.cell_to_world(best[0]);
    let start = RoutePose {
        x: s.x,
        y: s.y,
        yaw: yaw(rng),
    };
    let points = best[1..=points]
        .iter()
        .enumerate()
        .map(|(k, &c)| {
            let p = info.cell_to_world(c);
            RoutePoint {
                name: format!("p{k}"),
                x: p.x,
                y: p.y,
                yaw: yaw(rng),
                dwell: 0.0,
            }
        })
        .collect();
    Ok(RouteFile {
        start: Some(start),
        home: None,
        points,
    })
}

/// The free cells reachable from `start` by the grid's moves (breadth first).
fn connected(grid: &PlanningGrid, start: Cell) -> Vec<Cell> {
    let info = grid.info();
    let mut seen = vec![false; info.cell_count()];
    let mut out = vec![start];
    seen[info.index(start)] = true;
    let mut queue = VecDeque::from([start]);
    while let Some(c) = queue.pop_front() {
        for (_, nb) in grid.moves(c) {
            let i = info.index(nb);
            if !seen[i] {
                seen[i] = true;
                out.push(nb);
                queue.push_back(nb);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::{grid_from_rows, rng};

    #[test]
    fn pairs_keep_off_the_border_and_apart_and_repeat_with_the_seed() {
        // 40 x 40 cells of 1 m, one wall across the middle with no gap.
        let rows: Vec<String> = (0..40)
            .map(|y| {
                if y == 20 {
                    "#".repeat(40)
                } else {
                    ".".repeat(40)
                }
            })
            .collect();
        let refs: Vec<&str> = rows.iter().map(|r| r.as_str()).collect();
        let grid = grid_from_rows(&refs);
        let s = QuerySampling::default();
        let pairs = random_queries(&grid, 50, &mut rng(33), &s).unwrap();
        assert_eq!(pairs.len(), 50);
        for &(a, b) in &pairs {
            assert!((a - b).norm() > 3.0);
            for p in [a, b] {
                // 5 % of 40 cells: 2 cells of border; cell centres from 2.5 to 37.5.
                assert!(
                    p.x >= 2.5 && p.x <= 37.5 && p.y >= 2.5 && p.y <= 37.5,
                    "{p:?}"
                );
                assert!(grid.is_free(grid.info().world_to_cell(p).unwrap()));
            }
        }
        // Pairs across the wall are kept (a benchmark reports them as having no path).
        assert!(pairs.iter().any(|(a, b)| (a.y < 20.0) != (b.y < 20.0)));
        assert_eq!(random_queries(&grid, 50, &mut rng(33), &s).unwrap(), pairs);
        assert_ne!(random_queries(&grid, 50, &mut rng(34), &s).unwrap(), pairs);
    }

    #[test]
    fn a_map_that_is_mostly_unknown_still_gives_its_pairs() {
        // 400 x 400 cells of 1 m, blocked (as unknown is) but for a 12 x 12 room in the middle (0.09 % of the
        // map: 10 000 draws per pair over the whole map find one pair in about 12).
        let rows: Vec<String> = (0..400)
            .map(|y| {
                (0..400)
                    .map(|x| {
                        if (194..206).contains(&x) && (194..206).contains(&y) {
                            '.'
                        } else {
                            '#'
                        }
                    })
                    .collect()
            })
            .collect();
        let refs: Vec<&str> = rows.iter().map(|r| r.as_str()).collect();
        let grid = grid_from_rows(&refs);
        let s = QuerySampling::default();
        let pairs = random_queries(&grid, 30, &mut rng(33), &s).unwrap();
        assert_eq!(pairs.len(), 30);
        for &(a, b) in &pairs {
            assert!((a - b).norm() > 3.0);
            for p in [a, b] {
                assert!(grid.is_free(grid.info().world_to_cell(p).unwrap()), "{p:?}");
            }
        }
        assert_eq!(random_queries(&grid, 30, &mut rng(33), &s).unwrap(), pairs);
    }

    #[test]
    fn a_map_without_room_is_an_error_not_a_hang() {
        // 3 x 3 cells of 1 m: no two centres more than 3 m apart.
        let grid = grid_from_rows(&["...", "...", "..."]);
        let e = random_queries(&grid, 3, &mut rng(1), &QuerySampling::default()).unwrap_err();
        assert!(
            matches!(e, SamplingError::TooFewPairs { found: 0, .. }),
            "{e}"
        );
    }

    #[test]
    fn route_points_are_distinct_and_connected_to_the_start() {
        // Two rooms with no door: every point must be in the start's room.
        let rows: Vec<String> = (0..12)
            .map(|_| format!("{}#{}", ".".repeat(10), ".".repeat(10)))
            .collect();
        let refs: Vec<&str> = rows.iter().map(|r| r.as_str()).collect();
        let grid = grid_from_rows(&refs);
        for seed in 0..20 {
            let route = random_route(&grid, 10, &mut rng(seed)).unwrap();
            let s = route.start.unwrap();
            let left = s.x < 10.0;
            let mut cells: Vec<(i64, i64)> = vec![(s.x as i64, s.y as i64)];
            for p in &route.points {
                assert_eq!(p.x < 10.0, left, "seed {seed}: a point in the other room");
                cells.push((p.x as i64, p.y as i64));
            }
            cells.sort();
            cells.dedup();
            assert_eq!(cells.len(), 11, "seed {seed}: repeated cells");
            route.validate().unwrap();
        }
    }
}
