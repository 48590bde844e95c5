//! The leg matrix: a real path between every two reachable points of a route, from one
//! multi-target sweep per point.
//!
//! A sweep is Dijkstra on the 8-connected planning grid (the one move rule of
//! [`crate::grid::moves`], octile step lengths) from one point's cell, run until every target cell
//! is settled, so one sweep gives the shortest grid walk to every other point at once. Each walk
//! becomes a path from the exact point to the exact point, string-pulled by the delete operation
//! ([`crate::grid::smoothing::delete_redundant`]) and stripped of collinear vertices: close to the
//! any-angle length, and with the bends the car will really turn at.
//!
//! The sweep from the first node (the start) settles every target it can reach; the others are
//! cut off from the start. The move rule is symmetric, so every reachable point reaches every
//! other, and the sweep from node `a` only needs the nodes after it: the path `b -> a` is the path
//! `a -> b` reversed, so each leg is computed once and driven either way (its time differs by the
//! turns at its ends, see [`PathShape::reversed`]).

use super::model::{DrivingModel, PathShape};
use super::order::CostMatrix;
use super::SkipReason;
use crate::geometry::{Cell, Point2, NEIGHBOURS_8};
use crate::grid::inflation::PlanningGrid;
use crate::grid::metrics::drop_collinear;
use crate::grid::moves::{allowed, step_length};
use crate::grid::smoothing::delete_redundant;

/// The paths between the reachable nodes of a route.
#[derive(Clone, Debug)]
pub struct LegMatrix {
    /// The nodes (indices into the positions given to [`LegMatrix::build`]) that are reachable
    /// from node 0, in increasing order, node 0 first. Matrix indices are positions in this list.
    pub nodes: Vec<usize>,
    /// The nodes left out, each with why.
    pub unreachable: Vec<(usize, SkipReason)>,
    /// The cell of each matrix node.
    cells: Vec<Cell>,
    /// Upper triangle, row by row: the path (world metres) from matrix node `a` to `b > a`.
    paths: Vec<Vec<Point2>>,
    shapes: Vec<PathShape>,
}

impl LegMatrix {
    /// Sweeps from every reachable node. Positions are world metres; node 0 is the start, and an
    /// error says why it cannot be used (outside the map, or not free).
    pub fn build(grid: &PlanningGrid, positions: &[Point2]) -> Result<Self, SkipReason> {
        let info = grid.info();
        let mut usable = Vec::new();
        let mut unreachable = Vec::new();
        for (k, &p) in positions.iter().enumerate() {
            match grid.cell_at(p) {
                None => unreachable.push((k, SkipReason::OutsideMap)),
                Some(c) if !grid.is_free(c) => unreachable.push((k, SkipReason::Occupied)),
                Some(c) => usable.push((k, c)),
            }
        }
        if let Some((0, reason)) = unreachable.first() {
            return Err(*reason);
        }
        let mut sweeper = Sweeper::new(grid);
        let source = usable[0].1;
        let reached = sweeper.sweep(source, usable[1..].iter().map(|u| u.1));
        let mut nodes = vec![0];
        let mut cells = vec![source];
        for (&(k, c), ok) in usable[1..].iter().zip(reached) {
            if ok {
                nodes.push(k);
                cells.push(c);
            } else {
                unreachable.push((k, SkipReason::CutOff));
            }
        }
        unreachable.sort_by_key(|u| u.0);
        let n = nodes.len();
        let grid_point = |k: usize| info.world_to_grid(positions[nodes[k]]);
        let mut paths = Vec::with_capacity(n * n.saturating_sub(1) / 2);
        for a in 0..n {
            // The first sweep already settled every reachable node.
            if a > 0 && a + 1 < n {
                sweeper.sweep(cells[a], cells[a + 1..].iter().copied());
            }
            for (b, &cell) in cells.iter().enumerate().skip(a + 1) {
                let mut points = vec![grid_point(a)];
                points.extend(sweeper.walk_to(cell).into_iter().map(Cell::center));
                points.push(grid_point(b));
                let pulled = drop_collinear(&delete_redundant(grid, &points));
                paths.push(
                    pulled
                        .into_iter()
                        .map(|p| info.grid_to_world(p))
                        .collect::<Vec<_>>(),
                );
            }
        }
        let shapes = paths.iter().map(|p| PathShape::of(p)).collect();
        Ok(Self {
            nodes,
            unreachable,
            cells,
            paths,
            shapes,
        })
    }

    /// The number of reachable nodes.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// Whether two matrix nodes lie in one cell (their leg is the straight segment inside it).
    pub fn same_cell(&self, a: usize, b: usize) -> bool {
        self.cells[a] == self.cells[b]
    }

    fn slot(&self, a: usize, b: usize) -> usize {
        debug_assert!(a < b && b < self.len());
        let n = self.len();
        a * n - a * (a + 1) / 2 + (b - a - 1)
    }

    /// The path (world metres) from matrix node `a` to `b`.
    pub fn path(&self, a: usize, b: usize) -> Vec<Point2> {
        match a.cmp(&b) {
            std::cmp::Ordering::Less => self.paths[self.slot(a, b)].clone(),
            std::cmp::Ordering::Greater => {
                let mut p = self.paths[self.slot(b, a)].clone();
                p.reverse();
                p
            }
            std::cmp::Ordering::Equal => Vec::new(),
        }
    }

    /// The shape of the path from `a` to `b` (`None` from a node to itself).
    pub fn shape(&self, a: usize, b: usize) -> Option<PathShape> {
        match a.cmp(&b) {
            std::cmp::Ordering::Less => Some(self.shapes[self.slot(a, b)]),
            std::cmp::Ordering::Greater => Some(self.shapes[self.slot(b, a)].reversed()),
            std::cmp::Ordering::Equal => None,
        }
    }

    /// Driving times between the nodes, given each matrix node's yaw: asymmetric, because a leg
    /// driven the other way turns differently at its ends.
    pub fn times(&self, yaws: &[f64], model: &DrivingModel) -> CostMatrix {
        assert_eq!(yaws.len(), self.len(), "one yaw per matrix node");
        CostMatrix::new(self.len(), |a, b| match self.shape(a, b) {
            Some(s) => model.cost(&s, yaws[a], yaws[b]).time_s,
            None => 0.0,
        })
    }
}

/// Dijkstra sweeps over one grid, reusing their buffers.
struct Sweeper<'g> {
    grid: &'g PlanningGrid,
    /// Tentative distance (cells) per padded index.
    g: Vec<f64>,
    /// The padded index each settled cell was reached from.
    parent: Vec<u32>,
    source: usize,
    /// The open cells, `(distance bits, padded index)`, by whole cells of distance: bucket
    /// `floor(g) % 3`. See [`Sweeper::sweep`].
    buckets: [Vec<(u64, u32)>; 3],
    /// The targets the running sweep has yet to settle, by padded index: a flag read at every
    /// settled cell (a hash set's lookup there was a third of a sweep's time on a large map).
    pending: Vec<bool>,
}

impl<'g> Sweeper<'g> {
    fn new(grid: &'g PlanningGrid) -> Self {
        let len = grid.padded_free().len();
        Self {
            grid,
            g: vec![f64::INFINITY; len],
            parent: vec![u32::MAX; len],
            source: 0,
            buckets: Default::default(),
            pending: vec![false; len],
        }
    }

    fn stride(&self) -> usize {
        self.grid.width() + 2
    }

    fn padded(&self, c: Cell) -> usize {
        (c.y as usize + 1) * self.stride() + c.x as usize + 1
    }

    fn unpadded(&self, i: usize) -> Cell {
        let s = self.stride();
        Cell::new((i % s) as i32 - 1, (i / s) as i32 - 1)
    }

    /// Dijkstra from `source` (a free cell) until every target is settled or nothing is left to
    /// settle; returns, per target, whether it was reached. Ties are broken by the smaller index,
    /// so the walks are deterministic.
    fn sweep(&mut self, source: Cell, targets: impl Iterator<Item = Cell>) -> Vec<bool> {
        let targets: Vec<usize> = targets.map(|c| self.padded(c)).collect();
        if targets.is_empty() {
            return Vec::new();
        }
        let mut left = 0usize;
        for &t in &targets {
            if !self.pending[t] {
                self.pending[t] = true;
                left += 1;
            }
        }
        let stride = self.stride() as isize;
        let offsets: [isize; 8] = NEIGHBOURS_8.map(|(dx, dy)| dx as isize + dy as isize * stride);
        let free = self.grid.padded_free();
        self.g.fill(f64::INFINITY);
        for b in &mut self.buckets {
            b.clear();
        }
        self.source = self.padded(source);
        self.g[self.source] = 0.0;
        self.buckets[0].push((0f64.to_bits(), self.source as u32));
        // Dijkstra with a bucket queue (Dial's, for real weights): every step is 1 or sqrt 2
        // cells long, so a cell settled at a distance in [k, k + 1) only opens cells in the next
        // two buckets, and no cell in bucket k can improve another in it. Each bucket is sorted
        // by (distance, index) before it is settled: the cells come out in exactly the order a
        // binary heap of the same keys gives (the same walks, ties to the smaller index), in
        // 14 % less time on a 2000 x 2000 map (a 30-point route's matrix: 12.2-12.4 s -> 10.4-10.7
        // s; what is left is the distance and parent tables' cache misses). Distances are
        // non-negative, so their IEEE bits order like the numbers.
        let mut k = 0usize;
        'sweep: while self.buckets.iter().any(|b| !b.is_empty()) {
            let mut open = std::mem::take(&mut self.buckets[k % 3]);
            open.sort_unstable();
            for &(bits, index) in &open {
                let (gc, i) = (f64::from_bits(bits), index as usize);
                if gc > self.g[i] {
                    continue;
                }
                if self.pending[i] {
                    self.pending[i] = false;
                    left -= 1;
                    if left == 0 {
                        break 'sweep;
                    }
                }
                for (n, &(dx, dy)) in NEIGHBOURS_8.iter().enumerate() {
                    if !allowed(dx, dy, |x, y| {
                        free[(i as isize + x as isize + y as isize * stride) as usize]
                    }) {
                        continue;
                    }
                    let j = (i as isize + offsets[n]) as usize;
                    let ng = gc + step_length(dx, dy);
                    if ng < self.g[j] {
                        self.g[j] = ng;
                        self.parent[j] = index;
                        self.buckets[ng as usize % 3].push((ng.to_bits(), j as u32));
                    }
                }
            }
            open.clear();
            self.buckets[k % 3] = open;
            k += 1;
        }
        let reached = targets.iter().map(|&t| !self.pending[t]).collect();
        // Targets not reached (cut off from the source) leave the flags clear for the next sweep.
        for &t in &targets {
            self.pending[t] = false;
        }
        reached
    }

    /// The cells of the walk from the last sweep's source to a target it settled.
    fn walk_to(&self, target: Cell) -> Vec<Cell> {
        let mut i = self.padded(target);
        let mut cells = vec![target];
        while i != self.source {
            i = self.parent[i] as usize;
            cells.push(self.unpadded(i));
        }
        cells.reverse();
        cells
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::raycast::path_is_free;
    use crate::planner::{solve, PlanContext, Query, SolveOptions};
    use crate::search::astar::{astar_cells, cell_path_length, AStar};
    use crate::test_support::{grid_from_rows, random_grid, rng};
    use proptest::prelude::*;

    fn centre(x: i32, y: i32) -> Point2 {
        Cell::new(x, y).center()
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]
        /// On random grids, five points: every sweep (the later ones reuse the first's buffers)
        /// settles each target at A*'s optimal walk length; the matrix holds exactly the points
        /// A* reaches from the start; every leg between two of them, not only the start's, runs
        /// from point to point, is collision-free and is never longer than the A* staircase.
        #[test]
        fn sweeps_agree_with_astar(seed in any::<u64>(), density in 0.0f64..0.35) {
            let (grid, a, b) = random_grid(seed, 18, 14, density);
            let (_, c, d) = random_grid(seed ^ 0x5eed, 18, 14, 0.0);
            let (_, e, _) = random_grid(seed ^ 0xface, 18, 14, 0.0);
            let points = [a, b, c, d, e].map(|c| c.center());
            let cell = |k: usize| Cell::containing(points[k]);
            let mut r = rng(seed);
            let mut astar = |from: usize, to: usize| {
                let ctx = PlanContext::never_interrupted(&mut r);
                astar_cells(&grid, cell(from), cell(to), &ctx)
                    .ok()
                    .map(|(c, _)| cell_path_length(&c))
            };
            // `random_grid` frees its start cell, so the start is usable.
            let m = LegMatrix::build(&grid, &points).expect("the start is free");
            prop_assert_eq!(m.nodes[0], 0);
            for k in 1..points.len() {
                let in_matrix = m.nodes.contains(&k);
                let reason = m.unreachable.iter().find(|u| u.0 == k).map(|u| u.1);
                if grid.is_free(cell(k)) {
                    prop_assert_eq!(in_matrix, astar(0, k).is_some(), "node {}", k);
                    prop_assert!(in_matrix || reason == Some(SkipReason::CutOff));
                } else {
                    prop_assert_eq!(reason, Some(SkipReason::Occupied));
                }
            }
            for x in 0..m.len() {
                for y in x + 1..m.len() {
                    let (kx, ky) = (m.nodes[x], m.nodes[y]);
                    let p = m.path(x, y);
                    prop_assert_eq!(p[0], points[kx]);
                    prop_assert_eq!(*p.last().unwrap(), points[ky]);
                    prop_assert!(path_is_free(&grid, &p), "leg {} -> {}", kx, ky);
                    let staircase = astar(kx, ky).expect("both reach the start");
                    prop_assert!(m.shape(x, y).unwrap().length <= staircase + 1e-9);
                }
            }
            // The walks themselves: one sweeper for every source in turn, as `build` uses it.
            let cells: Vec<Cell> = m.nodes.iter().map(|&k| cell(k)).collect();
            let mut sweeper = Sweeper::new(&grid);
            for (x, &from) in cells.iter().enumerate() {
                let reached = sweeper.sweep(from, cells[x + 1..].iter().copied());
                prop_assert!(reached.iter().all(|&ok| ok));
                for (y, &to) in cells.iter().enumerate().skip(x + 1) {
                    let walk = sweeper.walk_to(to);
                    prop_assert_eq!((walk[0], *walk.last().unwrap()), (from, to));
                    let best = astar(m.nodes[x], m.nodes[y]).unwrap();
                    prop_assert!((cell_path_length(&walk) - best).abs() < 1e-9);
                    prop_assert!((sweeper.g[sweeper.padded(to)] - best).abs() < 1e-9);
                }
            }
        }
    }

    #[test]
    fn each_unusable_node_has_its_reason() {
        // Row 0 is the bottom row. The right column is walled off by the `#` column.
        let grid = grid_from_rows(&["...#.", "...#.", ".#.#.", "...#."]);
        let points = [
            centre(0, 0),
            centre(2, 3),
            centre(1, 1),
            centre(4, 2),
            Point2::new(-0.5, 1.0),
            Point2::new(9.0, 1.0),
        ];
        let m = LegMatrix::build(&grid, &points).unwrap();
        assert_eq!(m.nodes, vec![0, 1]);
        assert_eq!(
            m.unreachable,
            vec![
                (2, SkipReason::Occupied),
                (3, SkipReason::CutOff),
                (4, SkipReason::OutsideMap),
                (5, SkipReason::OutsideMap)
            ]
        );
        assert_eq!(
            LegMatrix::build(&grid, &[centre(1, 1), centre(0, 0)]).unwrap_err(),
            SkipReason::Occupied
        );
    }

    #[test]
    fn a_leg_is_string_pulled_and_as_long_as_any_angle_on_an_open_floor() {
        let grid = grid_from_rows(&["##......", "........", "........", "........"]);
        let (s, g) = (Point2::new(0.5, 0.5), Point2::new(7.5, 3.5));
        let m = LegMatrix::build(&grid, &[s, g]).unwrap();
        let p = m.path(0, 1);
        let mut r = rng(0);
        let q = Query {
            start: s,
            goal: g,
            tolerance: 0.0,
        };
        let astar = solve(
            &AStar::default(),
            &grid,
            &q,
            SolveOptions::default(),
            &mut PlanContext::never_interrupted(&mut r),
        )
        .unwrap();
        assert_eq!(p, vec![s, g], "the straight line is free");
        assert!(m.shape(0, 1).unwrap().length < astar.metrics.length_m);
        // A time matrix is asymmetric when the yaws make it so: facing the goal from the start,
        // and facing away from the start at the goal, costs no turn one way and two U-turns back.
        let heading = (g - s).y.atan2((g - s).x);
        let t = m.times(&[heading, heading], &DrivingModel::default());
        let straight = (g - s).norm() / 0.6;
        assert!((t.get(0, 1) - straight).abs() < 1e-9);
        let two_u_turns = 2.0 * std::f64::consts::PI / 0.4;
        assert!((t.get(1, 0) - straight - two_u_turns).abs() < 1e-9);
    }
}
