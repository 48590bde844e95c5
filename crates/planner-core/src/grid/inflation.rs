//! The planning grid: the raw map's obstacles grown by the robot's radius plus a safety margin,
//! so that every planner can treat the robot as a point.
//!
//! Obstacle growth uses an exact Euclidean distance transform (Meijster, Roerdink & Hesselink,
//! "A general algorithm for computing distance transforms in linear time", 2000): two linear
//! passes with integer arithmetic, so a 1000 x 1000 map inflates in a few milliseconds. The same
//! transform gives every cell's clearance, which the metrics and the potential fields reuse.
//!
//! Distances are measured between cell centres, as Nav2's costmap inflation does: a cell is
//! blocked when an obstacle cell's centre lies within `robot_radius + safety_margin` of its centre.

use crate::geometry::{Cell, NEIGHBOURS_8};
use crate::grid::map::{GridMap, MapInfo, UNKNOWN};
use crate::params::{check, ParamError, Range};
use serde::{Deserialize, Serialize};

/// How the raw map becomes the planning grid.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct InflationConfig {
    /// Radius of the circle that contains the chassis (m). Default 0.25.
    pub robot_radius: f64,
    /// Extra distance kept from obstacles (m). Default 0.20: the patrol car paper's 20 cm
    /// collision threshold.
    pub safety_margin: f64,
    /// A cell whose occupancy is at or above this (0..=100) is an obstacle. Default 65.
    pub occupied_threshold: i8,
    /// Whether unknown (-1) cells may be crossed. Default false.
    pub allow_unknown: bool,
    /// Graded costs (costmap_2d's inflation layer): within this distance (m) of an obstacle a
    /// free cell costs `252 * exp(-cost_scaling_factor * (d - robot_radius))`, beyond it 0.
    /// Default 1.75, with `cost_scaling_factor` 2.58: the gentle field Nav2's tuning guide
    /// recommends for cost-weighing planners ("a consistent potential field around the entire
    /// map"), so that aisles have a cheapest middle. With the earlier 1.0 / 3.0 the cost was 0
    /// from 1 m off a wall, nothing rewarded more, and the safety objective moved the paths of
    /// few scenarios by 1.3 x A*'s clearance (issue 13: 4 of 20, now 9).
    pub inflation_radius: f64,
    /// How fast the cost falls with distance (1/m), costmap_2d's `cost_scaling_factor`.
    /// Default 2.58.
    pub cost_scaling_factor: f64,
}

pub fn default_robot_radius() -> f64 {
    0.25
}
pub fn default_safety_margin() -> f64 {
    0.20
}
pub fn default_occupied_threshold() -> i8 {
    65
}
pub fn default_inflation_radius() -> f64 {
    1.75
}
pub fn default_cost_scaling_factor() -> f64 {
    2.58
}

impl Default for InflationConfig {
    fn default() -> Self {
        Self {
            robot_radius: default_robot_radius(),
            safety_margin: default_safety_margin(),
            occupied_threshold: default_occupied_threshold(),
            allow_unknown: false,
            inflation_radius: default_inflation_radius(),
            cost_scaling_factor: default_cost_scaling_factor(),
        }
    }
}

impl InflationConfig {
    /// No growth at all: the grid's own obstacles only (Moving AI benchmarks, unit tests).
    pub fn none() -> Self {
        Self {
            robot_radius: 0.0,
            safety_margin: 0.0,
            ..Self::default()
        }
    }

    pub fn radius(&self) -> f64 {
        self.robot_radius + self.safety_margin
    }

    pub fn validate(&self) -> Result<(), ParamError> {
        check(
            Range::NonNegative,
            &[
                ("robot_radius", self.robot_radius),
                ("safety_margin", self.safety_margin),
                ("inflation_radius", self.inflation_radius),
                ("cost_scaling_factor", self.cost_scaling_factor),
            ],
        )?;
        check(
            Range::NonNegative,
            &[("occupied_threshold", self.occupied_threshold as f64)],
        )?;
        if self.occupied_threshold > 100 {
            return Err(ParamError::new(
                "occupied_threshold",
                format!("{} is above 100", self.occupied_threshold),
            ));
        }
        Ok(())
    }
}

/// The memo of [`PlanningGrid::cost`]: a clone starts empty (it fills again as asked).
#[derive(Debug, Default)]
struct CostMemo(std::sync::OnceLock<Vec<std::sync::atomic::AtomicU8>>);

impl Clone for CostMemo {
    fn clone(&self) -> Self {
        Self::default()
    }
}

/// Where a grid's costs are: given cell by cell, or the model's memo.
#[derive(Clone, Copy)]
enum CostTable<'a> {
    Given(&'a [u8]),
    /// The model's memo. `free_by_cost`: every free cell's model cost is below [`INSCRIBED`]
    /// and every other cell's is not (the grid's free radius is at least the model's inscribed
    /// radius, as every grid built from a map has it), so the cost alone says whether a cell
    /// is free: one table read instead of two.
    Memo {
        memo: &'a [std::sync::atomic::AtomicU8],
        free_by_cost: bool,
    },
}

/// [`PlanningGrid::cell_reader`]: freedom and cost of cells of one grid.
#[derive(Clone, Copy)]
pub struct CellReader<'a> {
    grid: &'a PlanningGrid,
    table: CostTable<'a>,
}

impl CellReader<'_> {
    /// [`PlanningGrid::is_free`] and [`PlanningGrid::cost`] of one cell with one bounds check.
    #[inline]
    pub fn free_and_cost(&self, c: Cell) -> (bool, u8) {
        let g = self.grid;
        if !g.info.contains(c) {
            return (false, LETHAL);
        }
        let i = g.info.index(c);
        if let CostTable::Memo {
            free_by_cost: true, ..
        } = self.table
        {
            let v = self.cost_at_index(c, i);
            return (v < INSCRIBED, v);
        }
        let free = g.padded_free[(c.y as usize + 1) * (g.width() + 2) + c.x as usize + 1];
        (free, self.cost_at_index(c, i))
    }

    /// The cost of cell `c`, inside the map, at row-major index `i`.
    #[inline]
    fn cost_at_index(&self, c: Cell, i: usize) -> u8 {
        use std::sync::atomic::Ordering;
        match self.table {
            CostTable::Given(given) => given[i],
            CostTable::Memo { memo, .. } => match memo[i].load(Ordering::Relaxed) {
                NOT_YET => self.fill(c, i, memo),
                v => v,
            },
        }
    }

    /// A model cost computed for the first time, and kept.
    #[cold]
    #[inline(never)]
    fn fill(&self, c: Cell, i: usize, memo: &[std::sync::atomic::AtomicU8]) -> u8 {
        let v = self.grid.model_cost(c);
        memo[i].store(v, std::sync::atomic::Ordering::Relaxed);
        v
    }
}

/// [`PlanningGrid::blocked_sums`] of a `w x h` grid from its padded free mask.
fn blocked_sums(w: usize, h: usize, padded_free: &[bool]) -> Vec<u32> {
    let stride = w + 1;
    let mut sums = vec![0u32; stride * (h + 1)];
    for y in 0..h {
        let row = &padded_free[(y + 1) * (w + 2) + 1..][..w];
        let mut in_row = 0u32;
        for (x, &free) in row.iter().enumerate() {
            in_row = in_row.wrapping_add(u32::from(!free));
            sums[(y + 1) * stride + x + 1] = sums[y * stride + x + 1].wrapping_add(in_row);
        }
    }
    sums
}

/// A cell whose model cost is not computed yet (the model never gives 255, costmap_2d's
/// NO_INFORMATION).
const NOT_YET: u8 = 255;

/// The grid every planner searches: which cells the robot's centre may occupy, and how far each
/// cell is from the nearest obstacle. Cells outside the map are blocked.
#[derive(Clone, Debug)]
pub struct PlanningGrid {
    info: MapInfo,
    /// Squared distance from each cell centre to the nearest obstacle cell centre, in cells
    /// (`u32::MAX` where there is none). The root is taken only when asked: most cells are never
    /// queried, and a million roots cost a third of the transform.
    clearance2: Vec<u32>,
    inflation_radius: f64,
    /// How clearance becomes a graded cost (see [`PlanningGrid::cost`]).
    costs: CostModel,
    /// Costs given cell by cell (a costmap received as is), instead of the model's.
    given_costs: Option<Vec<u8>>,
    /// The model's cost of each cell, computed on its first [`PlanningGrid::cost`] call (an
    /// exponential and a square root) and kept: the safety objective and the cost terms ask for
    /// the same cells thousands of times per plan. [`NOT_YET`] until then; 1 B per cell,
    /// allocated on the first call. Atomic, because plans share the grid across threads (a
    /// race only computes the same value twice).
    model_costs: CostMemo,
    /// Free cells, with a one-cell blocked border (row stride `width + 2`): lets the graph
    /// searches step to any 8-neighbour without a bounds check.
    padded_free: Vec<bool>,
    /// The summed-area table of the cells that are not free: `blocked_sums[y * (width + 1) + x]`
    /// counts them in the rectangle of cells `[0, x) x [0, y)`, so any rectangle's count takes
    /// four reads ([`PlanningGrid::box_is_free`]). Lets a long line-of-sight test clear whole
    /// stretches of a segment at once instead of cell by cell (4 B per cell). Wrapping sums:
    /// differences stay exact for any rectangle of fewer than 2^32 cells.
    blocked_sums: Vec<u32>,
}

impl PlanningGrid {
    /// Inflates a map.
    pub fn new(map: &GridMap, cfg: &InflationConfig) -> Result<Self, ParamError> {
        cfg.validate()?;
        let obstacle: Vec<bool> = map
            .data()
            .iter()
            .map(|&v| {
                if v == UNKNOWN {
                    !cfg.allow_unknown
                } else {
                    v >= cfg.occupied_threshold
                }
            })
            .collect();
        Ok(
            Self::from_obstacles(*map.info(), obstacle, cfg.radius()).with_costs(CostModel {
                inscribed_radius: cfg.robot_radius,
                inflation_radius: cfg.inflation_radius,
                cost_scaling_factor: cfg.cost_scaling_factor,
            }),
        )
    }

    /// A grid from a costmap as costmap_2d publishes it on a nav_msgs/OccupancyGrid (Nav2's
    /// `/global_costmap/costmap`): 100 lethal, 99 inscribed, 1..98 the graded costs, 0 free, -1
    /// unknown. Its obstacles are already inflated, so nothing is grown: the robot's centre may
    /// be in every cell below inscribed (and in unknown ones with `allow_unknown`), and each
    /// cell's cost is the costmap's own, translated back to the 0..254 scale.
    pub fn from_costmap(map: &GridMap, allow_unknown: bool) -> Self {
        let data = map.data();
        let lethal: Vec<bool> = data
            .iter()
            .map(|&v| v >= 100 || (v == UNKNOWN && !allow_unknown))
            .collect();
        let mut grid = Self::from_obstacles(*map.info(), lethal, 0.0);
        let w = grid.width();
        for (i, &v) in data.iter().enumerate() {
            if v == 99 {
                grid.padded_free[(i / w + 1) * (w + 2) + i % w + 1] = false;
            }
        }
        grid.blocked_sums = blocked_sums(w, grid.height(), &grid.padded_free);
        grid.given_costs = Some(data.iter().map(|&v| cost_from_occupancy(v)).collect());
        grid
    }

    /// The same grid with another cost model.
    pub fn with_costs(mut self, costs: CostModel) -> Self {
        self.costs = costs;
        self.model_costs = CostMemo::default();
        self
    }

    /// Builds a grid from an obstacle mask (row-major, `info.cell_count()` long), growing the
    /// obstacles by `radius` metres.
    pub fn from_obstacles(info: MapInfo, obstacle: Vec<bool>, radius: f64) -> Self {
        assert_eq!(
            obstacle.len(),
            info.cell_count(),
            "obstacle mask does not match the map size"
        );
        let (w, h) = (info.width as usize, info.height as usize);
        let r_cells = radius / info.resolution;
        // A tiny slack so that a radius of exactly k cells blocks the cells at distance k despite
        // floating rounding.
        let r2 = r_cells * r_cells + 1e-9;
        let mut clearance2 = vec![0u32; w * h];
        squared_distance_transform_in_place(w, h, &obstacle, &mut clearance2);
        drop(obstacle);
        let mut padded_free = vec![false; (w + 2) * (h + 2)];
        for (row, d2) in padded_free
            .chunks_exact_mut(w + 2)
            .skip(1)
            .zip(clearance2.chunks_exact(w))
        {
            for (p, &d) in row[1..=w].iter_mut().zip(d2) {
                *p = d == NO_OBSTACLE || d as f64 > r2;
            }
        }
        Self {
            blocked_sums: blocked_sums(w, h, &padded_free),
            info,
            clearance2,
            inflation_radius: radius,
            costs: CostModel {
                inscribed_radius: radius,
                inflation_radius: default_inflation_radius().max(radius),
                cost_scaling_factor: default_cost_scaling_factor(),
            },
            given_costs: None,
            model_costs: CostMemo::default(),
            padded_free,
        }
    }

    pub fn info(&self) -> &MapInfo {
        &self.info
    }
    pub fn width(&self) -> usize {
        self.info.width as usize
    }
    pub fn height(&self) -> usize {
        self.info.height as usize
    }
    pub fn resolution(&self) -> f64 {
        self.info.resolution
    }
    pub fn inflation_radius(&self) -> f64 {
        self.inflation_radius
    }

    /// Whether the robot's centre may be in this cell (false outside the map).
    #[inline]
    pub fn is_free(&self, c: Cell) -> bool {
        // Shifted by the border, a cell inside the map has 1 <= x + 1 <= width; one unsigned
        // comparison per axis rejects both sides (a negative wraps to a huge value, and so does
        // i32::MAX + 1, the cell of any point beyond i32's range).
        let (px, py) = (
            c.x.wrapping_add(1) as u32 as usize,
            c.y.wrapping_add(1) as u32 as usize,
        );
        let stride = self.width() + 2;
        px.wrapping_sub(1) < self.width()
            && py.wrapping_sub(1) < self.height()
            && self.padded_free[py * stride + px]
    }

    /// Whether any of the cell's eight neighbours is not free (outside the map counts as not
    /// free): the genetic paper's safety term counts the path cells next to an obstacle. Inside
    /// the map, three reads of the padded mask's rows instead of eight bounds-checked
    /// [`PlanningGrid::is_free`] calls; IMGA asks it of every cell of every child.
    #[inline]
    pub fn next_to_blocked(&self, c: Cell) -> bool {
        let (px, py) = (
            c.x.wrapping_add(1) as u32 as usize,
            c.y.wrapping_add(1) as u32 as usize,
        );
        if px.wrapping_sub(1) >= self.width() || py.wrapping_sub(1) >= self.height() {
            return NEIGHBOURS_8
                .iter()
                .any(|&(dx, dy)| !self.is_free(c.offset(dx, dy)));
        }
        // Inside the map, every neighbour is inside the padded mask (its border blocked).
        let stride = self.width() + 2;
        let row = |y: usize| &self.padded_free[y * stride + px - 1..=y * stride + px + 1];
        let middle = row(py);
        !(row(py - 1).iter().all(|&f| f)
            && middle[0]
            && middle[2]
            && row(py + 1).iter().all(|&f| f))
    }

    /// Whether every cell of the rectangle `[x0, x1] x [y0, y1]` (inclusive) is free; false when
    /// any of it lies outside the map. Four reads, whatever the rectangle's size.
    #[inline]
    pub fn box_is_free(&self, x0: i32, y0: i32, x1: i32, y1: i32) -> bool {
        let (w, h) = (self.width() as i64, self.height() as i64);
        let (x0, y0, x1, y1) = (x0 as i64, y0 as i64, x1 as i64 + 1, y1 as i64 + 1);
        if x0 < 0 || y0 < 0 || x1 > w || y1 > h || x0 >= x1 || y0 >= y1 {
            return x0 >= 0 && y0 >= 0 && x1 <= w && y1 <= h; // empty: trivially free
        }
        self.blocked_in(x0, y0, x1, y1) == 0
    }

    /// Whether no cell of the rectangle `[x0, x1] x [y0, y1]` (inclusive) is free, the part
    /// outside the map counting as not free: four reads, whatever the rectangle's size. Lets a
    /// search pass over a stretch of blocked cells at once.
    pub fn none_free(&self, x0: i32, y0: i32, x1: i32, y1: i32) -> bool {
        let (w, h) = (self.width() as i64, self.height() as i64);
        let (x0, y0) = ((x0 as i64).max(0), (y0 as i64).max(0));
        let (x1, y1) = ((x1 as i64 + 1).min(w), (y1 as i64 + 1).min(h));
        if x0 >= x1 || y0 >= y1 {
            return true;
        }
        u64::from(self.blocked_in(x0, y0, x1, y1)) == ((x1 - x0) * (y1 - y0)) as u64
    }

    /// The cells that are not free in `[x0, x1) x [y0, y1)`, a non-empty rectangle inside the
    /// map (half-open), from the four corners of the summed-area table.
    #[inline]
    fn blocked_in(&self, x0: i64, y0: i64, x1: i64, y1: i64) -> u32 {
        let stride = self.width() + 1;
        let at = |x: i64, y: i64| self.blocked_sums[y as usize * stride + x as usize];
        at(x1, y1)
            .wrapping_sub(at(x0, y1))
            .wrapping_sub(at(x1, y0))
            .wrapping_add(at(x0, y0))
    }

    /// The free mask with a one-cell blocked border (row stride `width + 2`; cell (x, y) is at
    /// `(y + 1) * (width + 2) + x + 1`).
    pub fn padded_free(&self) -> &[bool] {
        &self.padded_free
    }

    /// The cell's cost on costmap_2d's scale: [`LETHAL`] for an obstacle cell or outside the
    /// map, [`INSCRIBED`] where the robot's centre may not be (the inflated band), else
    /// `252 * exp(-cost_scaling_factor * (d - inscribed_radius))` at clearance `d` up to the
    /// inflation radius, and 0 beyond: the costmap Nav2's planners weigh.
    #[inline]
    pub fn cost(&self, c: Cell) -> u8 {
        if !self.info.contains(c) {
            return LETHAL;
        }
        self.cost_at_index(c, self.info.index(c))
    }

    /// A reader of [`PlanningGrid::is_free`] and [`PlanningGrid::cost`] together, with the cost
    /// table looked up once: the swarms' safety objective and the weighted delete operation ask
    /// both of every cell a candidate path crosses, thousands of times per plan: which table holds
    /// the costs (and, for the model's, whether it exists yet) is then settled once per path, not
    /// once per cell.
    #[inline]
    pub fn cell_reader(&self) -> CellReader<'_> {
        let table = match &self.given_costs {
            Some(given) => CostTable::Given(given),
            None => CostTable::Memo {
                memo: self.model_costs.0.get_or_init(|| {
                    use std::sync::atomic::AtomicU8;
                    (0..self.info.cell_count())
                        .map(|_| AtomicU8::new(NOT_YET))
                        .collect()
                }),
                // A free cell's clearance is above the free radius, so above the inscribed
                // radius: its model cost is at most 252; other cells get 253 or 254. (An
                // infinite inscribed radius would make the free cells far from any obstacle
                // inscribed too.)
                free_by_cost: self.costs.inscribed_radius <= self.inflation_radius
                    && self.costs.inscribed_radius.is_finite(),
            },
        };
        CellReader { grid: self, table }
    }

    /// The cost of cell `c`, inside the map, at row-major index `i`.
    #[inline]
    fn cost_at_index(&self, c: Cell, i: usize) -> u8 {
        self.cell_reader().cost_at_index(c, i)
    }

    /// [`PlanningGrid::cost`] of a cell inside the map by the cost model.
    fn model_cost(&self, c: Cell) -> u8 {
        let d = self.clearance(c);
        if d <= 0.0 {
            LETHAL
        } else if !self.is_free(c) {
            INSCRIBED
        } else {
            self.costs.cost_at(d)
        }
    }

    /// Distance (m) from a cell's centre to the nearest obstacle cell's centre; 0 outside the map.
    pub fn clearance(&self, c: Cell) -> f64 {
        if self.info.contains(c) {
            match self.clearance2[self.info.index(c)] {
                u32::MAX => f64::INFINITY,
                d2 => (d2 as f64).sqrt() * self.info.resolution,
            }
        } else {
            0.0
        }
    }

    /// The nearest free cell to `c` (a cell of the map) within `radius_cells` (Euclidean, centre
    /// to centre), ties broken by the order of rows then columns (the lowest `dy`, then `dx`), so
    /// the answer is deterministic.
    ///
    /// Bounded by the map, whatever the radius: rings of growing Chebyshev distance are scanned,
    /// only their parts inside the map, and the search stops as soon as no further ring can hold
    /// a nearer cell, or the rings leave the map. A tolerance of a million metres costs no more
    /// than the map itself.
    pub fn nearest_free(&self, c: Cell, radius_cells: f64) -> Option<Cell> {
        if self.is_free(c) {
            return Some(c);
        }
        if radius_cells.is_nan() || radius_cells < 1.0 || !self.info.contains(c) {
            return None;
        }
        let (w, h) = (self.width() as i64, self.height() as i64);
        let (cx, cy) = (c.x as i64, c.y as i64);
        let to_edge = cx.max(w - 1 - cx).max(cy).max(h - 1 - cy);
        let r_max = (radius_cells.floor() as i64).min(to_edge);
        let limit2 = radius_cells * radius_cells;
        // (d2, dy, dx) of the best so far: the smallest distance, then the first in scan order.
        let mut best: Option<(i64, i64, i64)> = None;
        let consider = |dx: i64, dy: i64, best: &mut Option<(i64, i64, i64)>| {
            let (x, y) = (cx + dx, cy + dy);
            if x < 0 || y < 0 || x >= w || y >= h {
                return;
            }
            let d2 = dx * dx + dy * dy;
            if (d2 as f64) > limit2 || best.is_some_and(|b| (d2, dy, dx) >= b) {
                return;
            }
            if self.is_free(Cell::new(x as i32, y as i32)) {
                *best = Some((d2, dy, dx));
            }
        };
        for r in 1..=r_max {
            // Every cell of ring r is at least r away: once the best is within r, no cell of this
            // ring or a later one is nearer; a tie needs this ring still (same d2, earlier order).
            if best.is_some_and(|(d2, _, _)| d2 < r * r) {
                break;
            }
            let (x_lo, x_hi) = ((-r).max(-cx), r.min(w - 1 - cx));
            for dy in [-r, r] {
                for dx in x_lo..=x_hi {
                    consider(dx, dy, &mut best);
                }
            }
            let (y_lo, y_hi) = ((-r + 1).max(-cy), (r - 1).min(h - 1 - cy));
            for dx in [-r, r] {
                for dy in y_lo..=y_hi {
                    consider(dx, dy, &mut best);
                }
            }
        }
        best.map(|(_, dy, dx)| Cell::new((cx + dx) as i32, (cy + dy) as i32))
    }
}

/// costmap_2d's cost of an obstacle cell.
pub const LETHAL: u8 = 254;
/// costmap_2d's cost of a cell within the robot's inscribed radius of an obstacle.
pub const INSCRIBED: u8 = 253;
/// The highest cost of a cell the robot may be in.
pub const MAX_NON_OBSTACLE: u8 = 252;

/// A costmap cell's cost from its OccupancyGrid value, inverting costmap_2d's publisher (which
/// maps 0 -> 0, 1..252 -> 1 + 97 * (cost - 1) / 251, 253 -> 99, 254 -> 100, 255 -> -1).
pub fn cost_from_occupancy(v: i8) -> u8 {
    match v {
        100.. => LETHAL,
        99 => INSCRIBED,
        1..=98 => (1 + (v as u32 - 1) * 251 / 97).min(MAX_NON_OBSTACLE as u32) as u8,
        0 => 0,
        _ => 255,
    }
}

/// costmap_2d's inflation layer: how a free cell's clearance becomes its cost.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CostModel {
    /// Clearance (m) at and below which a cell is inscribed (the robot's radius).
    pub inscribed_radius: f64,
    /// Clearance (m) beyond which a cell costs nothing.
    pub inflation_radius: f64,
    /// costmap_2d's `cost_scaling_factor` (1/m).
    pub cost_scaling_factor: f64,
}

impl CostModel {
    /// The cost of a free cell at clearance `d` (m).
    pub fn cost_at(&self, d: f64) -> u8 {
        if d > self.inflation_radius {
            0
        } else if d <= self.inscribed_radius {
            INSCRIBED
        } else {
            let c = MAX_NON_OBSTACLE as f64
                * (-self.cost_scaling_factor * (d - self.inscribed_radius)).exp();
            c.clamp(0.0, MAX_NON_OBSTACLE as f64) as u8
        }
    }
}

/// Exact squared Euclidean distance (in cells, centre to centre) from every cell to the nearest
/// `true` cell of `obstacle`; `None` where there is none. Meijster et al. 2000.
pub fn squared_distance_transform(
    width: usize,
    height: usize,
    obstacle: &[bool],
) -> Vec<Option<u64>> {
    let mut d2 = vec![0u32; width * height];
    squared_distance_transform_in_place(width, height, obstacle, &mut d2);
    d2.into_iter()
        .map(|d| (d != NO_OBSTACLE).then_some(d as u64))
        .collect()
}

/// The squared distance reported where no obstacle exists.
pub const NO_OBSTACLE: u32 = u32::MAX;

/// The transform, written into `d2` (row-major, `width * height` long): squared distances,
/// saturated at `u32::MAX - 1` (65535 cells), or [`NO_OBSTACLE`]. The buffer doubles as the first
/// phase's scratch space, so the transform allocates nothing of the map's size.
pub fn squared_distance_transform_in_place(
    width: usize,
    height: usize,
    obstacle: &[bool],
    d2: &mut [u32],
) {
    assert_eq!(obstacle.len(), width * height);
    assert_eq!(d2.len(), width * height);
    // "Infinity" must stay finite so that the separator arithmetic below is exact.
    let inf = (width + height) as u32;
    // Phase 1: per column, the vertical distance to the nearest obstacle. Swept row by row (down,
    // then up) so that memory is read in order.
    let g = d2;
    for x in 0..width {
        g[x] = if obstacle[x] { 0 } else { inf };
    }
    for y in 1..height {
        let (prev, cur) = g.split_at_mut(y * width);
        let prev = &prev[(y - 1) * width..];
        let obst = &obstacle[y * width..(y + 1) * width];
        for ((c, &p), &o) in cur[..width].iter_mut().zip(prev).zip(obst) {
            *c = if o { 0 } else { (p + 1).min(inf) };
        }
    }
    for y in (0..height.saturating_sub(1)).rev() {
        let (cur, next) = g.split_at_mut((y + 1) * width);
        for (c, &n) in cur[y * width..].iter_mut().zip(&next[..width]) {
            *c = (*c).min(n + 1);
        }
    }
    // Phase 2: per row, the lower envelope of the parabolas (x - i)^2 + g(i)^2, kept as a stack
    // of (apex column s, first column t where it is lowest, g(s)^2). The row's g is copied out
    // first, so the result can overwrite it.
    let mut envelope: Vec<(i64, i64, i64)> = Vec::with_capacity(width);
    let mut g2 = vec![0i64; width];
    let w = width as i64;
    for row in g.chunks_exact_mut(width) {
        if row.iter().all(|&v| v >= inf) {
            row.fill(NO_OBSTACLE);
            continue;
        }
        for (d, &v) in g2.iter_mut().zip(row.iter()) {
            *d = (v as i64).pow(2);
        }
        envelope.clear();
        envelope.push((0, 0, g2[0]));
        for (u, &gu) in g2.iter().enumerate().skip(1) {
            let u = u as i64;
            while let Some(&(s, t, gs)) = envelope.last() {
                if (t - s).pow(2) + gs > (t - u).pow(2) + gu {
                    envelope.pop();
                } else {
                    break;
                }
            }
            match envelope.last() {
                None => envelope.push((u, 0, gu)),
                Some(&(s, _, gs)) => {
                    let start = 1 + (u * u - s * s + gu - gs) / (2 * (u - s));
                    if start < w {
                        envelope.push((u, start, gu));
                    }
                }
            }
        }
        // Each parabola owns the columns from its t to the next one's t.
        for (k, &(s, t, gs)) in envelope.iter().enumerate() {
            let end = envelope.get(k + 1).map_or(w, |e| e.1);
            for (x, o) in (t..end).zip(&mut row[t as usize..end as usize]) {
                *o = ((x - s).pow(2) + gs).min(NO_OBSTACLE as i64 - 1) as u32;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Pose2;
    use proptest::prelude::*;

    fn brute_force(width: usize, height: usize, obstacle: &[bool]) -> Vec<Option<u64>> {
        (0..width * height)
            .map(|i| {
                let (x, y) = ((i % width) as i64, (i / width) as i64);
                obstacle
                    .iter()
                    .enumerate()
                    .filter(|(_, &o)| o)
                    .map(|(j, _)| {
                        let (ox, oy) = ((j % width) as i64, (j / width) as i64);
                        ((x - ox).pow(2) + (y - oy).pow(2)) as u64
                    })
                    .min()
                    .map(Some)
                    .unwrap_or(None)
            })
            .collect()
    }

    /// The reader's one-read path (freedom from the model cost) and its two-read path agree
    /// with `is_free` and `cost` cell by cell, the border outside included: on grids built from
    /// a map, with a cost model whose inscribed radius passes the free radius (two reads), and
    /// on a costmap.
    #[test]
    fn the_cell_reader_agrees_with_is_free_and_cost() {
        use crate::test_support::{grid_with, rng};
        use rand::Rng;
        let mut r = rng(9);
        let mask: Vec<bool> = (0..40 * 30).map(|_| r.random_bool(0.04)).collect();
        let blocked = |x: usize, y: usize| mask[y * 40 + x];
        let model = |inscribed: f64| CostModel {
            inscribed_radius: inscribed,
            inflation_radius: 1.0,
            cost_scaling_factor: 3.0,
        };
        let levels: Vec<i8> = (0..40 * 30).map(|_| r.random_range(-1..=100)).collect();
        let costmap = GridMap::new(
            MapInfo {
                width: 40,
                height: 30,
                resolution: 0.1,
                origin: Pose2::default(),
            },
            levels,
        )
        .unwrap();
        let grids = [
            grid_with((40, 30), 0.1, 0.3, blocked),
            grid_with((40, 30), 0.1, 0.3, blocked).with_costs(model(0.2)),
            grid_with((40, 30), 0.1, 0.3, blocked).with_costs(model(0.3)),
            grid_with((40, 30), 0.1, 0.3, blocked).with_costs(model(0.5)),
            grid_with((40, 30), 0.1, 0.0, blocked),
            PlanningGrid::from_costmap(&costmap, true),
            PlanningGrid::from_costmap(&costmap, false),
        ];
        for (k, grid) in grids.iter().enumerate() {
            let reader = grid.cell_reader();
            let mut free = 0;
            for y in -1..31 {
                for x in -1..41 {
                    let c = Cell::new(x, y);
                    assert_eq!(
                        reader.free_and_cost(c),
                        (grid.is_free(c), grid.cost(c)),
                        "grid {k} {c:?}"
                    );
                    free += usize::from(grid.is_free(c));
                }
            }
            assert!(free > 100, "grid {k}: {free} free cells");
        }
        // With the inscribed radius past the free radius, free cells cost 253: the two-read path.
        let wide = &grids[3];
        assert!((0..30).any(|y| (0..40).any(|x| {
            let c = Cell::new(x, y);
            wide.is_free(c) && wide.cost(c) == INSCRIBED
        })));
    }

    proptest! {
        #[test]
        fn distance_transform_is_exact(w in 1usize..24, h in 1usize..24, seed in any::<u64>(), density in 0.0f64..0.3) {
            use rand::{Rng, SeedableRng};
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let obstacle: Vec<bool> = (0..w * h).map(|_| rng.random_bool(density)).collect();
            prop_assert_eq!(squared_distance_transform(w, h, &obstacle), brute_force(w, h, &obstacle));
        }

        /// `none_free` is "no cell of the rectangle is free", cell by cell, for rectangles
        /// inside, across and outside the map's edges.
        #[test]
        fn none_free_is_every_cell_blocked(w in 1usize..12, h in 1usize..12, seed in any::<u64>(), density in 0.5f64..1.0, x0 in -3i32..14, y0 in -3i32..14, dx in 0i32..8, dy in 0i32..8) {
            use rand::{Rng, SeedableRng};
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let obstacle: Vec<bool> = (0..w * h).map(|_| rng.random_bool(density)).collect();
            let info = MapInfo { width: w as u32, height: h as u32, resolution: 1.0, origin: Pose2::default() };
            let g = PlanningGrid::from_obstacles(info, obstacle, 0.0);
            let (x1, y1) = (x0 + dx, y0 + dy);
            let cells = (x0..=x1).flat_map(|x| (y0..=y1).map(move |y| Cell::new(x, y)));
            prop_assert_eq!(g.none_free(x0, y0, x1, y1), cells.clone().all(|c| !g.is_free(c)));
        }

        /// `next_to_blocked` is the eight `is_free` reads it replaces, for every cell of a random
        /// map, the ring just outside it, and cells far outside (as far as a neighbour stays an
        /// `i32`).
        #[test]
        fn next_to_blocked_is_eight_is_free_reads(w in 1usize..12, h in 1usize..12, seed in any::<u64>(), density in 0.0f64..0.4) {
            use rand::{Rng, SeedableRng};
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let obstacle: Vec<bool> = (0..w * h).map(|_| rng.random_bool(density)).collect();
            let info = MapInfo { width: w as u32, height: h as u32, resolution: 1.0, origin: Pose2::default() };
            let g = PlanningGrid::from_obstacles(info, obstacle, 0.0);
            let (w, h) = (w as i32, h as i32);
            let far = [i32::MIN + 1, -3, i32::MAX - 1];
            let cells = (-1..=w).flat_map(|x| (-1..=h).map(move |y| Cell::new(x, y)))
                .chain(far.iter().flat_map(|&x| far.iter().map(move |&y| Cell::new(x, y))))
                .chain(far.iter().map(|&x| Cell::new(x, 0)));
            for c in cells {
                let reads = NEIGHBOURS_8.iter().any(|&(dx, dy)| !g.is_free(c.offset(dx, dy)));
                prop_assert_eq!(g.next_to_blocked(c), reads, "{:?}", c);
            }
        }
    }

    #[test]
    fn inflation_blocks_the_disc_and_reports_clearance() {
        let info = MapInfo {
            width: 9,
            height: 9,
            resolution: 0.1,
            origin: Pose2::default(),
        };
        let mut obstacle = vec![false; 81];
        obstacle[4 * 9 + 4] = true;
        let g = PlanningGrid::from_obstacles(info, obstacle, 0.2);
        assert!(!g.is_free(Cell::new(4, 4)));
        assert!(!g.is_free(Cell::new(6, 4))); // exactly 2 cells = 0.2 m away
        assert!(g.is_free(Cell::new(6, 5))); // sqrt(5) cells
        assert!(!g.is_free(Cell::new(-1, 0)));
        assert!((g.clearance(Cell::new(7, 8)) - 0.5).abs() < 1e-6);
        // The nearest free cells are sqrt(5) away; the first in scan order wins.
        assert_eq!(g.nearest_free(Cell::new(4, 4), 3.0), Some(Cell::new(3, 2)));
        assert_eq!(g.nearest_free(Cell::new(4, 4), 2.0), None);
    }

    /// The ring search equals the plain scan of the whole square (the old implementation) on
    /// random grids, and a huge radius costs no more than the map.
    #[test]
    fn nearest_free_equals_the_full_scan_and_is_bounded_by_the_map() {
        use crate::test_support::random_grid;
        let scan = |g: &PlanningGrid, c: Cell, radius: f64| -> Option<Cell> {
            let r = radius.floor() as i32;
            let mut best: Option<(i64, Cell)> = None;
            for dy in -r..=r {
                for dx in -r..=r {
                    let d2 = (dx * dx + dy * dy) as i64;
                    let n = c.offset(dx, dy);
                    if (d2 as f64) <= radius * radius
                        && g.is_free(n)
                        && best.is_none_or(|(b, _)| d2 < b)
                    {
                        best = Some((d2, n));
                    }
                }
            }
            best.map(|(_, n)| n)
        };
        for seed in 0..40 {
            let (g, a, b) = random_grid(seed, 23, 17, 0.8);
            for c in [a, b, Cell::new(0, 0), Cell::new(22, 16), Cell::new(11, 8)] {
                for radius in [0.5, 1.0, 1.5, 2.9, 4.0, 7.3, 40.0] {
                    assert_eq!(
                        g.nearest_free(c, radius),
                        scan(&g, c, radius),
                        "seed {seed} {c:?} r {radius}"
                    );
                }
            }
        }
        // A fully blocked 2000 x 2000 grid and a tolerance of 1e9 cells: one pass over the map.
        let info = MapInfo {
            width: 2000,
            height: 2000,
            resolution: 0.05,
            origin: Pose2::default(),
        };
        let g = PlanningGrid::from_obstacles(info, vec![true; 4_000_000], 0.0);
        assert_eq!(g.nearest_free(Cell::new(1000, 1000), 1e9), None);
    }

    /// costmap_2d's scale: lethal on the obstacle, inscribed in the band, the exponential decay
    /// beyond it, 0 past the inflation radius.
    #[test]
    fn costs_follow_the_inflation_layer() {
        let m = CostModel {
            inscribed_radius: 0.25,
            inflation_radius: 1.0,
            cost_scaling_factor: 3.0,
        };
        assert_eq!(m.cost_at(0.2), INSCRIBED);
        assert_eq!(m.cost_at(0.25), INSCRIBED);
        assert_eq!(m.cost_at(0.5), (252.0 * (-3.0f64 * 0.25).exp()) as u8);
        assert!(m.cost_at(0.5) > m.cost_at(0.8) && m.cost_at(0.8) > 0);
        assert_eq!(m.cost_at(1.01), 0);
        let info = MapInfo {
            width: 20,
            height: 1,
            resolution: 0.1,
            origin: Pose2::default(),
        };
        let mut obstacle = vec![false; 20];
        obstacle[0] = true;
        let g = PlanningGrid::from_obstacles(info, obstacle, 0.2).with_costs(m);
        assert_eq!(g.cost(Cell::new(0, 0)), LETHAL);
        assert_eq!(g.cost(Cell::new(1, 0)), INSCRIBED); // blocked band
        assert_eq!(g.cost(Cell::new(-1, 0)), LETHAL);
        let costs: Vec<u8> = (3..20).map(|x| g.cost(Cell::new(x, 0))).collect();
        assert!(costs.windows(2).all(|w| w[0] >= w[1]), "{costs:?}");
        assert_eq!(g.cost(Cell::new(19, 0)), 0);
    }

    /// A costmap as costmap_2d publishes it plans as it is: lethal and inscribed cells blocked,
    /// nothing grown, the graded values back on the 0..252 scale.
    #[test]
    fn a_published_costmap_is_taken_as_is() {
        let info = MapInfo {
            width: 6,
            height: 1,
            resolution: 0.1,
            origin: Pose2::default(),
        };
        let map = GridMap::new(info, vec![100, 99, 98, 50, 0, -1]).unwrap();
        let g = PlanningGrid::from_costmap(&map, false);
        let free: Vec<bool> = (0..6).map(|x| g.is_free(Cell::new(x, 0))).collect();
        assert_eq!(free, vec![false, false, true, true, true, false]);
        let costs: Vec<u8> = (0..6).map(|x| g.cost(Cell::new(x, 0))).collect();
        assert_eq!(costs, vec![254, 253, 252, 127, 0, 255]);
        assert!(PlanningGrid::from_costmap(&map, true).is_free(Cell::new(5, 0)));
        // Round trip of costmap_2d's own translation for every graded cost.
        for cost in 1u32..=252 {
            let v = (1 + 97 * (cost - 1) / 251) as i8;
            let back = cost_from_occupancy(v) as u32;
            assert!(back <= cost && cost - back <= 3, "{cost} -> {v} -> {back}");
        }
    }

    #[test]
    fn unknown_is_an_obstacle_unless_allowed() {
        let info = MapInfo {
            width: 3,
            height: 1,
            resolution: 1.0,
            origin: Pose2::default(),
        };
        let map = GridMap::new(info, vec![0, -1, 64]).unwrap();
        let g = PlanningGrid::new(&map, &InflationConfig::none()).unwrap();
        assert!(
            g.is_free(Cell::new(0, 0)) && !g.is_free(Cell::new(1, 0)) && g.is_free(Cell::new(2, 0))
        );
        let cfg = InflationConfig {
            allow_unknown: true,
            occupied_threshold: 64,
            ..InflationConfig::none()
        };
        let g = PlanningGrid::new(&map, &cfg).unwrap();
        assert!(g.is_free(Cell::new(1, 0)) && !g.is_free(Cell::new(2, 0)));
        assert!(PlanningGrid::new(
            &map,
            &InflationConfig {
                robot_radius: f64::NAN,
                ..cfg
            }
        )
        .is_err());
    }
}
