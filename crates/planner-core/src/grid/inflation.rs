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

use crate::geometry::{Cell, Point2, NEIGHBOURS_8};
use crate::grid::map::{GridMap, MapError, MapInfo, UNKNOWN};
use crate::params::{check, ParamError, Range};
use serde::{Deserialize, Serialize};
use std::borrow::Cow;

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
    /// Plan on the map at this many times its cell size, as Nav2's Smac planners do with
    /// `downsample_costmap` and `downsampling_factor`: the map is inflated and graded at its
    /// own resolution, then each block of cells becomes one, blocked if any of its cells is,
    /// costing its highest cost ([`planning_grid`], [`PlanningGrid::downsampled`]). Every
    /// planner's work grows with the cells it searches, so 2 makes a 16 M-cell map at 0.05 m
    /// a 4 M-cell one at 0.1 m. A path free on the coarse grid is free on the full one: it
    /// gives up cells (a gap just wide enough may close), never clearance. 1: the map as it
    /// is (default); at most 16.
    pub downsampling_factor: u32,
}

/// The largest `downsampling_factor`: 16 x 0.05 m is 0.8 m cells, wider than the robot.
pub const MAX_DOWNSAMPLING: u32 = 16;

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
            downsampling_factor: 1,
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
        // Metres: no robot or inflation is 100 m wide, and a radius of 1e308 overflows the
        // cells it is measured in.
        check(
            Range::Within(0.0, 100.0),
            &[
                ("robot_radius", self.robot_radius),
                ("safety_margin", self.safety_margin),
                ("inflation_radius", self.inflation_radius),
            ],
        )?;
        check(
            Range::Within(0.0, 1_000.0),
            &[("cost_scaling_factor", self.cost_scaling_factor)],
        )?;
        // An occupancy of at least this is an obstacle: 0 would make every known cell one.
        if !(1..=100).contains(&self.occupied_threshold) {
            return Err(ParamError::new(
                "occupied_threshold",
                format!("{} is not within 1..=100", self.occupied_threshold),
            ));
        }
        if !(1..=MAX_DOWNSAMPLING).contains(&self.downsampling_factor) {
            return Err(ParamError::new(
                "downsampling_factor",
                format!(
                    "{} is not within 1..={MAX_DOWNSAMPLING}",
                    self.downsampling_factor
                ),
            ));
        }
        Ok(())
    }
}

/// `map`'s planning grid and the map it is drawn and published with, cell for cell: the
/// node's inflation of `map` by `cfg` (or, with `as_costmap`, the map taken as a costmap,
/// already inflated and graded), downsampled by `cfg.downsampling_factor` as Nav2's Smac
/// planners downsample their inflated costmap ([`PlanningGrid::downsampled`]): the inflation is
/// made at the map's own resolution first, so a path free on the coarse grid is free on the
/// full one. The map comes back borrowed at factor 1, downsampled alike otherwise
/// ([`GridMap::downsampled`]: a costmap's inscribed and lethal cells, 99 and 100, or a raw map's
/// cells at or above `occupied_threshold`, count as its obstacles).
///
/// A `keepout` mask (Nav2's keepout filter: [`PlanningGrid::with_keepout`]) is laid over the
/// grid at the map's own resolution, before downsampling, as costmap_2d applies its filters to
/// the master grid.
pub fn planning_grid<'a>(
    map: &'a GridMap,
    cfg: &InflationConfig,
    as_costmap: bool,
    keepout: Option<&GridMap>,
) -> Result<(Cow<'a, GridMap>, PlanningGrid), ParamError> {
    cfg.validate()?;
    let full = if as_costmap {
        PlanningGrid::from_costmap(map, cfg.allow_unknown)
    } else {
        PlanningGrid::new(map, cfg)?
    };
    let full = match keepout {
        Some(mask) => full.with_keepout(mask),
        None => full,
    };
    let factor = cfg.downsampling_factor;
    if factor <= 1 {
        return Ok((Cow::Borrowed(map), full));
    }
    let obstacle_at = if as_costmap {
        99
    } else {
        cfg.occupied_threshold
    };
    let refused = |e: MapError| ParamError::new("downsampling_factor", e.to_string());
    let coarse_map = map.downsampled(factor, obstacle_at).map_err(refused)?;
    Ok((
        Cow::Owned(coarse_map),
        full.downsampled(factor).map_err(refused)?,
    ))
}

/// The cost model by squared clearance in cells, as costmap_2d's inflation layer caches its costs
/// by cell distance (`cached_costs_`): entry `d2` of the table is [`LETHAL`] at 0 (an obstacle
/// cell), [`INSCRIBED`] up to the free radius, then [`CostModel::cost_at`] of `sqrt(d2)` cells.
/// It turns the distance transform into every cell's cost in one pass over the map, with no
/// exponential per cell (but past the end of a table that hit its size limit).
#[derive(Clone, Debug)]
struct CostsByClearance {
    /// Entry `d2`: the cost at `sqrt(d2)` cells. Ends where the cost has fallen to 0 for good
    /// (it never rises with distance), or at [`CostsByClearance::MAX_LEN`] entries.
    table: Vec<u8>,
    /// A cell is free when its squared clearance is above this: the rule the free mask was made
    /// by (see [`PlanningGrid::from_obstacles`]), in integers. [`NO_OBSTACLE`] is above it.
    free_above: u32,
    /// Whether every squared clearance past the table costs 0 (the table ends where the cost
    /// did, not at its size limit).
    zero_beyond: bool,
    model: CostModel,
    resolution: f64,
}

impl CostsByClearance {
    /// At most 1 MB: an inflation radius of 10 m at 1 cm cells. A larger one (or finer cells)
    /// computes the costs beyond the table from the model.
    const MAX_LEN: usize = 1 << 20;

    /// The table for `model` on cells of `resolution` m, where a cell is free when its squared
    /// clearance (cells) is above `free_r2`.
    fn new(model: CostModel, resolution: f64, free_r2: f64) -> Self {
        // `d2 as f64 > free_r2` for an integer d2 is `d2 > floor(free_r2)`; kept below
        // NO_OBSTACLE, which is always free. A NaN compares false: only NO_OBSTACLE is free.
        let free_above = if free_r2.is_nan() {
            NO_OBSTACLE - 1
        } else {
            free_r2.max(0.0).floor().min((NO_OBSTACLE - 1) as f64) as u32
        };
        let at = |d2: u32| match d2 {
            0 => LETHAL,
            d2 if d2 <= free_above => INSCRIBED,
            d2 => model.cost_at((d2 as f64).sqrt() * resolution),
        };
        let mut table = Vec::new();
        let mut zero_beyond = false;
        while table.len() < Self::MAX_LEN {
            let cost = at(table.len() as u32);
            // The cost only falls with distance: the first 0 is the last entry that matters.
            if cost == 0 {
                zero_beyond = true;
                break;
            }
            table.push(cost);
        }
        Self {
            table,
            free_above,
            zero_beyond,
            model,
            resolution,
        }
    }

    /// The cost of a cell at squared clearance `d2` (cells; [`NO_OBSTACLE`] where there is
    /// none): exactly [`LETHAL`] (`d2` 0), [`INSCRIBED`] (not [`CostsByClearance::free`]) or
    /// [`CostModel::cost_at`] of its clearance.
    #[inline]
    fn cost(&self, d2: u32) -> u8 {
        match self.table.get(d2 as usize) {
            Some(&cost) => cost,
            // Most cells of a large map: far from every wall.
            None if self.zero_beyond => 0,
            None => self.past_a_full_table(d2),
        }
    }

    /// Whether a cell at squared clearance `d2` may hold the robot's centre: the one rule the
    /// free mask is made by.
    #[inline]
    fn free(&self, d2: u32) -> bool {
        d2 > self.free_above
    }

    /// The cost past the end of a table that hit its size limit.
    #[cold]
    fn past_a_full_table(&self, d2: u32) -> u8 {
        if d2 == NO_OBSTACLE {
            0
        } else if d2 <= self.free_above {
            INSCRIBED
        } else {
            self.model.cost_at((d2 as f64).sqrt() * self.resolution)
        }
    }
}

/// [`PlanningGrid::cell_reader`]: freedom and cost of cells of one grid.
#[derive(Clone, Copy)]
pub struct CellReader<'a> {
    grid: &'a PlanningGrid,
}

impl CellReader<'_> {
    /// [`PlanningGrid::is_free`] and [`PlanningGrid::cost`] of one cell with one bounds check,
    /// and one read where the cost says whether the cell is free.
    #[inline]
    pub fn free_and_cost(&self, c: Cell) -> (bool, u8) {
        let g = self.grid;
        if !g.info.contains(c) {
            return (false, LETHAL);
        }
        let cost = g.costs[g.info.index(c)];
        if g.free_by_cost {
            return (cost < INSCRIBED, cost);
        }
        let free = g.padded_free[(c.y as usize + 1) * (g.width() + 2) + c.x as usize + 1];
        (free, cost)
    }
}

/// The model's cost of every cell, from the distance transform.
fn model_costs(clearance2: &[u32], model: &CostsByClearance) -> Vec<u8> {
    clearance2.iter().map(|&d2| model.cost(d2)).collect()
}

/// Whether a cell's cost alone says whether it is free: below [`INSCRIBED`] on every free cell
/// and not below it on every other (one read instead of two). So with the model's costs when
/// the free radius is at least the inscribed radius, as on every grid built from a map, and on a
/// costmap whose unknown cells are not free.
fn cost_says_free(costs: &[u8], padded_free: &[bool], w: usize) -> bool {
    costs
        .chunks_exact(w.max(1))
        .zip(padded_free.chunks_exact(w + 2).skip(1))
        .all(|(costs, free)| {
            costs
                .iter()
                .zip(&free[1..=w])
                .all(|(&cost, &free)| (cost < INSCRIBED) == free)
        })
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

/// The grid every planner searches: which cells the robot's centre may occupy, and how far each
/// cell is from the nearest obstacle. Cells outside the map are blocked.
#[derive(Clone, Debug)]
pub struct PlanningGrid {
    info: MapInfo,
    /// The map this grid stands for: `info` itself, or, for a [downsampled] grid, the map at
    /// full resolution, whose far edges the coarse cells reach past. A point is on the map when
    /// it is inside this ([`PlanningGrid::cell_at`]), not merely inside a coarse edge cell.
    ///
    /// [downsampled]: PlanningGrid::downsampled
    extent: MapInfo,
    /// Squared distance from each cell centre to the nearest obstacle cell centre, in cells
    /// (`u32::MAX` where there is none). The root is taken only when asked: most cells are never
    /// queried, and a million roots cost a third of the transform.
    clearance2: Vec<u32>,
    inflation_radius: f64,
    /// Each cell's cost on costmap_2d's scale (see [`PlanningGrid::cost`]), row-major: the
    /// model's, computed for the whole map when the grid is made (as costmap_2d fills its master
    /// grid), or a costmap's own. 1 B per cell, read directly: the safety objective reads the
    /// same cells thousands of times per plan, and cost-aware A* reads millions of cells once
    /// each on a large map (where a lazily filled memo cost a second cache miss per cell).
    costs: Vec<u8>,
    /// The model the costs were made by; `None` for a costmap's own.
    cost_model: Option<CostModel>,
    /// [`cost_says_free`] of this grid.
    free_by_cost: bool,
    /// The squared clearance (cells, with its slack) above which a cell is free, as the free
    /// mask was made: the model's costs are rebuilt with it.
    free_r2: f64,
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
        let model = CostModel {
            inscribed_radius: cfg.robot_radius,
            inflation_radius: cfg.inflation_radius,
            cost_scaling_factor: cfg.cost_scaling_factor,
        };
        Ok(Self::grown(*map.info(), obstacle, cfg.radius(), model))
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
        let costs = data.iter().map(|&v| cost_from_occupancy(v)).collect();
        Self::from_obstacles(*map.info(), lethal, 0.0).with_own_costs(|i| data[i] == 99, costs)
    }

    /// The grid at `factor` times its cell size, as Nav2's Smac planners downsample their
    /// inflated costmap (`downsampling_factor`): a coarse cell is an obstacle when its block
    /// holds one, is blocked when it holds a blocked cell or reaches past the map's edge, and
    /// costs its block's highest cost. So every cell inside a free coarse cell is free here,
    /// and a path free on the coarse grid is free on this one: downsampling gives up cells,
    /// never clearance. Clearances are then measured to the coarse obstacle cells, up to half
    /// a coarse cell's diagonal off. The costs are kept as they are (as a costmap's are).
    /// The coarse grid's [cells](PlanningGrid::cell_at) still hold only this grid's map. Factor 1 (or
    /// 0) is the grid itself.
    pub fn downsampled(&self, factor: u32) -> Result<Self, MapError> {
        if factor <= 1 {
            return Ok(self.clone());
        }
        let (w, h) = (self.width(), self.height());
        let info = MapInfo {
            width: self.info.width.div_ceil(factor),
            height: self.info.height.div_ceil(factor),
            resolution: self.info.resolution * factor as f64,
            origin: self.info.origin,
        };
        info.validate(u64::MAX)?;
        let (k, cw) = (factor as usize, info.width as usize);
        let blocks = |i: usize| {
            let (x0, y0) = ((i % cw) * k, (i / cw) * k);
            let whole = x0 + k <= w && y0 + k <= h;
            let cells =
                (y0..(y0 + k).min(h)).flat_map(move |y| (x0..(x0 + k).min(w)).map(move |x| (x, y)));
            (whole, cells)
        };
        let n = info.cell_count();
        let lethal: Vec<bool> = (0..n)
            .map(|i| blocks(i).1.any(|(x, y)| self.clearance2[y * w + x] == 0))
            .collect();
        let blocked: Vec<bool> = (0..n)
            .map(|i| {
                let (whole, mut cells) = blocks(i);
                !whole || cells.any(|(x, y)| !self.is_free(Cell::new(x as i32, y as i32)))
            })
            .collect();
        let costs = (0..n)
            .map(|i| {
                let (whole, cells) = blocks(i);
                let highest = cells.map(|(x, y)| self.costs[y * w + x]).max();
                // A block cut by the map's edge is blocked, so at least inscribed.
                let floor = if whole { 0 } else { INSCRIBED };
                highest.unwrap_or(LETHAL).max(floor)
            })
            .collect();
        let mut coarse =
            Self::from_obstacles(info, lethal, 0.0).with_own_costs(|i| blocked[i], costs);
        coarse.extent = self.extent;
        Ok(coarse)
    }

    /// This grid with cells `blocked(i)` blocked as well and `costs` as its own (a costmap's,
    /// not a model's).
    fn with_own_costs(mut self, blocked: impl Fn(usize) -> bool, costs: Vec<u8>) -> Self {
        let w = self.width();
        for i in (0..self.info.cell_count()).filter(|&i| blocked(i)) {
            self.padded_free[(i / w + 1) * (w + 2) + i % w + 1] = false;
        }
        self.blocked_sums = blocked_sums(w, self.height(), &self.padded_free);
        self.costs = costs;
        self.cost_model = None;
        self.free_by_cost = cost_says_free(&self.costs, &self.padded_free, w);
        self
    }

    /// This grid under a keepout mask, as Nav2's keepout filter (costmap_2d's `KeepoutFilter`)
    /// lays its mask over the master costmap: each cell takes the higher of its cost and the
    /// cost of the mask cell under its centre, the mask's occupancy 0..100 scaled linearly to
    /// 0..254 (the filter's `getMaskCost`); a cell of unknown cost takes the mask's. Cells
    /// outside the mask, or under an unknown (negative) mask cell, keep theirs. So a mask cell
    /// of 100 (a mask map's black) is lethal: the robot's centre stays out of it, as Nav2 keeps
    /// it out (the zone is not inflated, as the filter does not inflate it); a lesser value
    /// (a grey "preferred lanes" mask) is a cost the cost-aware searches and the safety
    /// objective weigh. The mask is sampled at each cell's centre, whatever its resolution,
    /// origin and rotation, in the map's frame.
    pub fn with_keepout(mut self, mask: &GridMap) -> Self {
        let mut costs = std::mem::take(&mut self.costs);
        let mut kept_out = vec![false; costs.len()];
        for (i, cost) in costs.iter_mut().enumerate() {
            let centre = self.info.cell_to_world(self.info.cell_at(i));
            let Some(under) = mask.info().world_to_cell(centre) else {
                continue;
            };
            let Some(keep) = keepout_cost(mask.value(under)) else {
                continue;
            };
            if *cost == NO_INFORMATION || keep > *cost {
                *cost = keep;
            }
            kept_out[i] = keep >= INSCRIBED;
        }
        self.with_own_costs(|i| kept_out[i], costs)
    }

    /// The same grid with another cost model (a costmap keeps its own costs).
    pub fn with_costs(mut self, model: CostModel) -> Self {
        if self.cost_model.is_some() {
            let table = CostsByClearance::new(model, self.info.resolution, self.free_r2);
            self.costs = model_costs(&self.clearance2, &table);
            self.cost_model = Some(model);
            self.free_by_cost = cost_says_free(&self.costs, &self.padded_free, self.width());
        }
        self
    }

    /// Builds a grid from an obstacle mask (row-major, `info.cell_count()` long), growing the
    /// obstacles by `radius` metres.
    pub fn from_obstacles(info: MapInfo, obstacle: Vec<bool>, radius: f64) -> Self {
        let model = CostModel {
            inscribed_radius: radius,
            inflation_radius: default_inflation_radius().max(radius),
            cost_scaling_factor: default_cost_scaling_factor(),
        };
        Self::grown(info, obstacle, radius, model)
    }

    /// [`PlanningGrid::from_obstacles`] with the costs of `model`: each cell's cost is computed
    /// once, by the model it keeps (on a map of millions of cells a second pass is not free).
    fn grown(info: MapInfo, obstacle: Vec<bool>, radius: f64, model: CostModel) -> Self {
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
        let table = CostsByClearance::new(model, info.resolution, r2);
        let mut padded_free = vec![false; (w + 2) * (h + 2)];
        for (row, d2) in padded_free
            .chunks_exact_mut(w + 2)
            .skip(1)
            .zip(clearance2.chunks_exact(w))
        {
            for (p, &d) in row[1..=w].iter_mut().zip(d2) {
                *p = table.free(d);
            }
        }
        let costs = model_costs(&clearance2, &table);
        Self {
            blocked_sums: blocked_sums(w, h, &padded_free),
            free_by_cost: cost_says_free(&costs, &padded_free, w),
            info,
            extent: info,
            clearance2,
            inflation_radius: radius,
            costs,
            cost_model: Some(model),
            free_r2: r2,
            padded_free,
        }
    }

    pub fn info(&self) -> &MapInfo {
        &self.info
    }
    /// The cell holding `p` (world metres), if `p` is on the map: inside the map the grid was
    /// made from, not merely in one of a downsampled grid's edge cells that reach past it.
    pub fn cell_at(&self, p: Point2) -> Option<Cell> {
        self.extent.world_to_cell(p)?;
        self.info.world_to_cell(p)
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
        self.costs[self.info.index(c)]
    }

    /// Every cell's cost (see [`PlanningGrid::cost`]), row-major as the map's data.
    pub fn costs(&self) -> &[u8] {
        &self.costs
    }

    /// A reader of [`PlanningGrid::is_free`] and [`PlanningGrid::cost`] together: the swarms'
    /// safety objective and the weighted delete operation ask both of every cell a candidate
    /// path crosses, thousands of times per plan, in one read where the cost says both.
    #[inline]
    pub fn cell_reader(&self) -> CellReader<'_> {
        CellReader { grid: self }
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
/// costmap_2d's cost of a cell of unknown cost (an unknown map cell).
pub const NO_INFORMATION: u8 = 255;

/// A cost as costmap_2d publishes it on a nav_msgs/OccupancyGrid (its publisher's translation
/// table): 0 -> 0, 1..252 -> 1 + 97 * (cost - 1) / 251, 253 (inscribed) -> 99, 254 (lethal) ->
/// 100, 255 (unknown) -> -1, the values RViz's "costmap" colour scheme and Nav2's tools read.
pub fn occupancy_from_cost(cost: u8) -> i8 {
    match cost {
        0 => 0,
        1..=MAX_NON_OBSTACLE => (1 + 97 * (cost as i32 - 1) / 251) as i8,
        INSCRIBED => 99,
        LETHAL => 100,
        _ => -1,
    }
}

/// A costmap cell's cost from its OccupancyGrid value, inverting [`occupancy_from_cost`].
pub fn cost_from_occupancy(v: i8) -> u8 {
    match v {
        100.. => LETHAL,
        99 => INSCRIBED,
        1..=98 => (1 + (v as u32 - 1) * 251 / 97).min(MAX_NON_OBSTACLE as u32) as u8,
        0 => 0,
        _ => NO_INFORMATION,
    }
}

/// The cost of a keepout mask's occupancy value, as Nav2's costmap filters read a mask
/// (`CostmapFilter::getMaskCost`): 0..100 scaled linearly to 0..254 (above 100, lethal);
/// `None` for unknown (negative) values, which leave the cell as it is.
pub fn keepout_cost(v: i8) -> Option<u8> {
    (v >= 0).then(|| (f64::from(v.min(100)) * f64::from(LETHAL) / 100.0).round() as u8)
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

    /// The reader agrees with `is_free` and `cost` cell by cell, the border outside included, and
    /// `cost` with the cost model applied to each cell's clearance (lethal on an obstacle,
    /// inscribed where the robot's centre may not be): on grids built from a map, with a cost
    /// model whose inscribed radius passes the free radius (free cells that cost 253), and on a
    /// costmap.
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
            grid_with((40, 30), 0.1, 0.3, blocked).with_keepout(&costmap),
            PlanningGrid::from_costmap(&costmap, true).with_keepout(&costmap),
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
                    if let Some(model) = grid.cost_model {
                        let d = grid.clearance(c);
                        let by_model = if d <= 0.0 {
                            LETHAL
                        } else if !grid.is_free(c) {
                            INSCRIBED
                        } else {
                            model.cost_at(d)
                        };
                        assert_eq!(grid.cost(c), by_model, "grid {k} {c:?}");
                    }
                    free += usize::from(grid.is_free(c));
                }
            }
            assert!(free > 100, "grid {k}: {free} free cells");
        }
        // With the inscribed radius past the free radius, free cells cost 253.
        let wide = &grids[3];
        assert!((0..30).any(|y| (0..40).any(|x| {
            let c = Cell::new(x, y);
            wide.is_free(c) && wide.cost(c) == INSCRIBED
        })));
    }

    proptest! {
        /// The table by squared clearance gives every clearance the free mask's rule and the
        /// model's cost (lethal at 0, inscribed where not free): inside the table, past its end
        /// (0 where the cost has run out, computed where the table hit its size limit: a wide
        /// inflation radius on fine cells), and where no obstacle exists.
        #[test]
        fn costs_by_clearance_are_the_models(
            inscribed in 0.0f64..1.0,
            inflation in 0.0f64..12.0,
            factor in 0.0f64..10.0,
            resolution in prop::sample::select(vec![0.005, 0.01, 0.02, 0.05, 0.1, 1.0]),
            free_r2 in prop_oneof![
                0.0f64..2000.0,
                (0u32..2000).prop_map(|k| k as f64 + 1e-9),
                Just(f64::NAN),
            ],
            d2s in prop::collection::vec(any::<u32>(), 50),
        ) {
            let model = CostModel {
                inscribed_radius: inscribed,
                inflation_radius: inflation,
                cost_scaling_factor: factor,
            };
            let costs = CostsByClearance::new(model, resolution, free_r2);
            let by_rule = |d2: u32| {
                // The rule in floating point, as the free mask and `model_cost` were made before.
                let free = d2 == NO_OBSTACLE || d2 as f64 > free_r2;
                let d = if d2 == NO_OBSTACLE { f64::INFINITY } else { (d2 as f64).sqrt() * resolution };
                let cost = if d <= 0.0 {
                    LETHAL
                } else if !free {
                    INSCRIBED
                } else {
                    model.cost_at(d)
                };
                (free, cost)
            };
            let near = costs.table.len() as u32;
            let probes = d2s
                .iter()
                .map(|&d2| d2 % (2 * near + 2))
                .chain(d2s.iter().copied())
                .chain([0, 1, near.saturating_sub(1), near, near + 1, NO_OBSTACLE - 1, NO_OBSTACLE]);
            for d2 in probes {
                prop_assert_eq!((costs.free(d2), costs.cost(d2)), by_rule(d2), "d2 {}", d2);
            }
        }

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

    /// Downsampling gives up cells, never clearance: on random maps (sizes no multiple of the
    /// factor, obstacles grown at full resolution), every fine cell inside a free coarse cell is
    /// free, a coarse cell costs at least each of its cells, and it is an obstacle exactly when
    /// its block holds one.
    #[test]
    fn a_downsampled_grid_frees_only_cells_free_at_full_resolution() {
        use crate::test_support::{grid_with, rng};
        use rand::Rng;
        let mut r = rng(21);
        for _ in 0..6 {
            let (w, h) = (r.random_range(20..41), r.random_range(20..41));
            let obstacle: Vec<bool> = (0..w * h).map(|_| r.random_bool(0.02)).collect();
            let fine = grid_with((w, h), 0.05, 0.12, |x, y| obstacle[y * w + x]);
            for factor in [2u32, 3, 4] {
                let k = factor as i32;
                let coarse = fine.downsampled(factor).unwrap();
                assert_eq!(coarse.info().resolution, 0.05 * factor as f64);
                assert_eq!(coarse.width(), w.div_ceil(factor as usize));
                for cy in 0..coarse.height() as i32 {
                    for cx in 0..coarse.width() as i32 {
                        let c = Cell::new(cx, cy);
                        let block: Vec<Cell> = (0..k * k)
                            .map(|i| Cell::new(cx * k + i % k, cy * k + i / k))
                            .collect();
                        if coarse.is_free(c) {
                            assert!(block.iter().all(|&f| fine.is_free(f)), "{c:?} x{factor}");
                        }
                        let in_map: Vec<Cell> = block
                            .into_iter()
                            .filter(|f| (f.x as usize) < w && (f.y as usize) < h)
                            .collect();
                        let highest = in_map.iter().map(|&f| fine.cost(f)).max().unwrap();
                        let whole = in_map.len() == (k * k) as usize;
                        if whole {
                            // And conversely: a whole block of free cells is a free coarse cell,
                            // costing its block's highest cost, no more.
                            let all_free = in_map.iter().all(|&f| fine.is_free(f));
                            assert_eq!(coarse.is_free(c), all_free, "{c:?} x{factor}");
                            assert_eq!(coarse.cost(c), highest, "{c:?} x{factor}");
                        } else {
                            assert!(!coarse.is_free(c) && coarse.cost(c) >= highest);
                        }
                        let holds_obstacle = in_map.iter().any(|&f| fine.clearance(f) == 0.0);
                        assert_eq!(coarse.clearance(c) == 0.0, holds_obstacle, "{c:?}");
                    }
                }
                // The coarse edge cells reach past the map; a point there is off the map.
                let edge = |g: &PlanningGrid| g.info().width as f64 * g.resolution();
                assert!(edge(&coarse) >= edge(&fine));
                let inside = Point2::new(edge(&fine) - 0.01, 0.3);
                let past = Point2::new(edge(&fine) + 0.01, 0.3);
                assert!(coarse.cell_at(inside).is_some() && fine.cell_at(inside).is_some());
                assert_eq!((coarse.cell_at(past), fine.cell_at(past)), (None, None));
            }
        }
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

    /// A flat cost out to 10 m on 5 mm cells needs more squared clearances than the table holds:
    /// the ones past it are computed, and still the model's (252 to the radius, then 0).
    #[test]
    fn costs_past_a_full_table_are_computed() {
        let model = CostModel {
            inscribed_radius: 0.2,
            inflation_radius: 10.0,
            cost_scaling_factor: 0.0,
        };
        let costs = CostsByClearance::new(model, 0.005, 1600.0);
        assert_eq!(costs.table.len(), CostsByClearance::MAX_LEN);
        assert!(!costs.zero_beyond);
        let at_m = |m: f64| costs.cost(((m / 0.005) * (m / 0.005)) as u32);
        assert_eq!(at_m(9.9), 252);
        assert_eq!(at_m(10.1), 0);
        assert_eq!(
            (costs.free(NO_OBSTACLE), costs.cost(NO_OBSTACLE)),
            (true, 0)
        );
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
            let v = occupancy_from_cost(cost as u8);
            assert_eq!(v as u32, 1 + 97 * (cost - 1) / 251, "costmap_2d's table");
            let back = cost_from_occupancy(v) as u32;
            assert!(back <= cost && cost - back <= 3, "{cost} -> {v} -> {back}");
        }
        // The fixed points of the scale, both ways.
        for (cost, v) in [(0, 0), (252, 98), (253, 99), (254, 100), (255, -1)] {
            assert_eq!(occupancy_from_cost(cost), v);
            assert_eq!(cost_from_occupancy(v), cost);
        }
    }

    /// Nav2's keepout filter: a mask of another resolution and origin, sampled at each cell's
    /// centre; its 100 lethal (the cell blocked, on the coarse grid too), its 50 a cost of 127
    /// (the cell still free), its unknown and the cells it does not cover left as they were; a
    /// lower mask cost never lowers a cell's, and an unknown cell takes the mask's.
    #[test]
    fn a_keepout_mask_is_laid_over_the_grid_as_nav2s_filter_lays_it() {
        let info = MapInfo {
            width: 20,
            height: 10,
            resolution: 0.1,
            origin: Pose2::default(),
        };
        let mut data = vec![0i8; 200];
        data[0] = 100; // an obstacle at cell (0, 0)
        data[9 * 20 + 9] = -1; // an unknown cell at (9, 9)
        let map = GridMap::new(info, data).unwrap();
        // 0.2 m cells from (0.4, 0): columns 0-1 (x 0.4-0.8 m) 100, 2 (0.8-1.0) 50, 3 -1, 4 0.
        let mask_info = MapInfo {
            width: 5,
            height: 5,
            resolution: 0.2,
            origin: Pose2::new(0.4, 0.0, 0.0),
        };
        let mask_row = [100i8, 100, 50, -1, 0];
        let mask = GridMap::new(mask_info, mask_row.repeat(5)).unwrap();
        let cfg = InflationConfig {
            allow_unknown: true,
            ..InflationConfig::none()
        };
        let plain = PlanningGrid::new(&map, &cfg).unwrap();
        let g = plain.clone().with_keepout(&mask);
        for y in 0..10 {
            for x in 0..20 {
                let c = Cell::new(x, y);
                let (cost, free) = (g.cost(c), g.is_free(c));
                match x {
                    4..=7 => assert!(cost == LETHAL && !free, "{c:?} is kept out"),
                    8 | 9 => assert!(cost == 127 && free, "{c:?}: {cost} {free}"),
                    _ => assert_eq!((cost, free), (plain.cost(c), plain.is_free(c)), "{c:?}"),
                }
            }
        }
        // On the map taken as a costmap, the unknown cell (9, 9) costs NO_INFORMATION; a mask
        // over the whole map gives it the mask's cost.
        let as_costmap = PlanningGrid::from_costmap(&map, true);
        assert_eq!(as_costmap.cost(Cell::new(9, 9)), NO_INFORMATION);
        let cover_all = GridMap::new(
            MapInfo {
                width: 1,
                height: 1,
                resolution: 10.0,
                origin: Pose2::default(),
            },
            vec![10],
        )
        .unwrap();
        let g = as_costmap.with_keepout(&cover_all);
        assert_eq!(
            g.cost(Cell::new(9, 9)),
            25,
            "an unknown cell takes the mask's cost"
        );
        assert_eq!(
            g.cost(Cell::new(0, 0)),
            LETHAL,
            "a lower mask cost lowers nothing"
        );
        assert!(!g.is_free(Cell::new(0, 0)) && g.is_free(Cell::new(1, 0)));
        // Laid over before downsampling: the coarse cells over the zone are blocked.
        let cfg = InflationConfig {
            downsampling_factor: 2,
            ..cfg
        };
        let (_, coarse) = planning_grid(&map, &cfg, false, Some(&mask)).unwrap();
        assert!(
            (0..5).all(|y| !coarse.is_free(Cell::new(2, y)) && !coarse.is_free(Cell::new(3, y)))
        );
        assert!(coarse.is_free(Cell::new(4, 2)) && coarse.is_free(Cell::new(8, 2)));
        assert_eq!(keepout_cost(-1), None);
        assert_eq!(
            [0, 1, 50, 99, 100, 127].map(|v| keepout_cost(v).unwrap()),
            [0, 3, 127, 251, 254, 254]
        );
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
