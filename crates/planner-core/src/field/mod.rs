//! The artificial potential field (the patrol car paper, Zhao et al., IEEE Access 2020, eq. 1–9)
//! and its local-minimum escape by a virtual traction point (the substation paper, Wang et al.,
//! "Robot Path Planning Method Combining Enhanced APF and Improved ACO Algorithm for Power
//! Emergency Maintenance", eq. 3–11; both in `docs/papers.md`). Planners `apf` and `eapf` use it
//! alone; the swarms and the improved colony start from its path (see [`crate::seed`]); the
//! colonies' heuristic reuses the field.
//!
//! Potential of a cell at distance `d_g` (m) from the goal and `rho` (m, from the distance
//! transform) from the nearest obstacle:
//! - attraction, eq. 4: `0.5 * epsilon * d_g^2`;
//! - repulsion, eq. 1 with the goal-distance factor of eq. 9:
//!   `0.5 * eta * (1/rho - 1/rho0)^2 * (1 - exp(-d_g^2 / R^2))` for `rho < rho0`, else 0, where `R`
//!   is the chassis radius, so the repulsion vanishes at the goal and a goal beside an obstacle
//!   stays reachable.
//!
//! The path descends the potential over the 8-neighbour grid (the same moves as A*: no corner
//! cutting, no revisits). It is stalled (a local minimum) when no unvisited neighbour is lower, or
//! when it moved less than `stall_distance` over the last `stall_window` steps (the substation
//! paper's detection). Then it escapes: the obstacle that blocks the way to the goal is found by
//! sweeping rays from the robot away from the goal direction, alternately left and right, until one
//! is clear; the last blocked ray's hit point is "the obstacle at the outermost end of the U".
//! Around it a circle of radius `r` gives a tangent point (eq. 3–5) and a virtual traction point
//! `d` beyond it along the robot-tangent line (the paper's text; its eq. 6–8 are garbled in the
//! source and contradict the text, see `docs/papers.md`). The path then descends a field whose
//! attraction pulls towards the traction point with a gain that grows exponentially with the steps
//! spent escaping (eq. 10's speed-up term `iota^n`, switched on by the stall, eq. 11) until it
//! reaches the traction point and the goal's attraction takes over again. Escapes are bounded by a
//! step budget; when it runs out the caller falls back to A* and says so.
//!
//! That is the papers' field (`apf.attraction: paper`, config/paper.yaml). At real scale its
//! quadratic Euclidean attraction leaves local minima behind every wall, and on large maps the
//! escape rarely finds its way (issue 12: every answer on the large-map queries was A*'s). The
//! default, `attraction: navigation`, replaces eq. 4's `d_g`, the straight-line distance to the
//! goal, by the wavefront distance through free space (a search from the goal over the same
//! 8-neighbour moves, guided toward the start as A* is): a navigation function, with no local minimum but the goal. The repulsion
//! (eq. 1, eq. 9) is kept, so the path still keeps off the walls where it has room; where the
//! repulsion alone would hold it (a narrow passage), the step follows the wavefront downhill
//! instead (counted as `wavefront_steps`), so the descent always reaches the goal on its own.

use crate::geometry::{Cell, Point2, Vector2};
use crate::grid::inflation::PlanningGrid;
use crate::grid::raycast::line_of_sight;
use serde::{Deserialize, Serialize};

/// Parameters of the field and of its escape. Distances in metres.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ApfParams {
    /// epsilon of eq. 4: attraction gain (1/m^2 of potential per m^2). Default 1.0.
    pub attractive_gain: f64,
    /// eta of eq. 1: repulsion gain. Default 4.0: enough to keep a patrol car's path off the
    /// inflated band where it has room, not so much that it cannot pass a 1 m aisle.
    pub repulsive_gain: f64,
    /// rho0 of eq. 1: distance (m) within which obstacles repel. Default 1.0.
    pub influence_distance: f64,
    /// R of eq. 9: the chassis radius (m). Unset: the costmap's `robot_radius` (see
    /// [`crate::config::PlannerConfig::field`]), so the robot has one radius; 0.25 where no
    /// costmap is at hand.
    pub chassis_radius: Option<f64>,
    /// Stall detection: the window (steps) over which the distance moved is measured. Default 8.
    pub stall_window: usize,
    /// Stall detection: the path is stalled when it moved less than this (m) over the window.
    /// Default 0.3.
    pub stall_distance: f64,
    /// r of eq. 3–5: radius (m) of the circle around the blocking obstacle's end. Default 1.0.
    pub traction_radius: f64,
    /// d of eq. 7–8: distance (m) of the traction point beyond the tangent point. Default 1.0.
    pub traction_distance: f64,
    /// iota of eq. 10 (> 1): growth per step of the traction gain while escaping. Default 1.2.
    pub traction_growth: f64,
    /// Angular step (deg) of the ray sweep that finds the obstacle's end. Default 5.
    pub sweep_step_deg: f64,
    /// Total step budget, as a multiple of (width + height) of the grid. Default 4.
    pub step_budget_factor: f64,
    /// Apply eq. 9's goal-distance factor to the repulsion (the patrol car paper's field). The
    /// substation paper's EAPF (planner `eapf`, and the ant colony's force field) has none and
    /// switches it off. Default true.
    pub goal_distance_factor: bool,
    /// What `d_g` of eq. 4 measures: `navigation` (default), the wavefront distance through
    /// free space; `paper`, the straight-line distance with the traction-point escape.
    pub attraction: Attraction,
}

/// The attraction's distance to the goal (see the module doc).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Attraction {
    /// The papers' eq. 4: straight-line distance; local minima escaped by traction points.
    Paper,
    /// The wavefront distance through free space: a navigation function, no local minima.
    #[default]
    Navigation,
}

impl Default for ApfParams {
    fn default() -> Self {
        Self {
            attractive_gain: 1.0,
            repulsive_gain: 4.0,
            influence_distance: 1.0,
            chassis_radius: None,
            stall_window: 8,
            stall_distance: 0.3,
            traction_radius: 1.0,
            traction_distance: 1.0,
            traction_growth: 1.2,
            sweep_step_deg: 5.0,
            step_budget_factor: 4.0,
            goal_distance_factor: true,
            attraction: Attraction::Navigation,
        }
    }
}

impl ApfParams {
    /// R of eq. 9 (m): the set chassis radius, or the default robot radius.
    pub fn radius(&self) -> f64 {
        self.chassis_radius
            .unwrap_or_else(crate::grid::inflation::default_robot_radius)
    }

    pub fn validate(&self) -> Result<(), crate::params::ParamError> {
        use crate::params::{check, check_counts, Range};
        check(
            Range::Positive,
            &[
                ("apf.attractive_gain", self.attractive_gain),
                ("apf.influence_distance", self.influence_distance),
                ("apf.chassis_radius", self.radius()),
                ("apf.traction_radius", self.traction_radius),
                ("apf.traction_distance", self.traction_distance),
            ],
        )?;
        // The escape sweeps pi / step directions; the descent runs this many (width + height)
        // steps between two polls of the deadline.
        check(
            Range::Within(0.05, 180.0),
            &[("apf.sweep_step_deg", self.sweep_step_deg)],
        )?;
        check(
            Range::PositiveUpTo(100.0),
            &[("apf.step_budget_factor", self.step_budget_factor)],
        )?;
        check(
            Range::NonNegative,
            &[
                ("apf.repulsive_gain", self.repulsive_gain),
                ("apf.stall_distance", self.stall_distance),
            ],
        )?;
        check(
            Range::Above(1.0),
            &[("apf.traction_growth", self.traction_growth)],
        )?;
        check_counts(1..=10_000, &[("apf.stall_window", self.stall_window)])
    }
}

/// The field over one planning grid and goal.
pub struct PotentialField<'a> {
    grid: &'a PlanningGrid,
    params: &'a ApfParams,
    goal: Point2,
}

impl<'a> PotentialField<'a> {
    /// `goal` in grid coordinates.
    pub fn new(grid: &'a PlanningGrid, params: &'a ApfParams, goal: Point2) -> Self {
        Self { grid, params, goal }
    }

    /// Repulsion of eq. 1 at distance `rho` (m) from the nearest obstacle.
    pub fn repulsion(&self, rho: f64) -> f64 {
        let p = self.params;
        if rho >= p.influence_distance {
            0.0
        } else {
            let rho = rho.max(1e-6);
            0.5 * p.repulsive_gain * (1.0 / rho - 1.0 / p.influence_distance).powi(2)
        }
    }

    /// Eq. 9's factor: 0 at the goal, towards 1 a few chassis radii away (1 everywhere when the
    /// field has no goal-distance factor).
    pub fn goal_factor(&self, p: Point2) -> f64 {
        if !self.params.goal_distance_factor {
            return 1.0;
        }
        let d2 = ((p - self.goal) * self.grid.resolution()).norm_squared();
        let r2 = self.params.radius().powi(2);
        if r2 <= 0.0 {
            // A point robot (`costmap.robot_radius: 0`, which the field inherits): the factor's
            // limit, 0 at the goal and 1 elsewhere, not 0 / 0 at the goal.
            return if d2 > 0.0 { 1.0 } else { 0.0 };
        }
        1.0 - (-d2 / r2).exp()
    }

    /// The potential of eq. 7 (with eq. 9's repulsion) at a cell, attracted towards `target`
    /// (the goal, or a traction point) with `gain`.
    pub fn potential_towards(&self, c: Cell, target: Point2, gain: f64) -> f64 {
        let p = c.center();
        let d2 = ((p - target) * self.grid.resolution()).norm_squared();
        0.5 * gain * d2 + self.repulsion(self.grid.clearance(c)) * self.goal_factor(p)
    }

    /// The potential at a cell.
    pub fn potential(&self, c: Cell) -> f64 {
        self.potential_towards(c, self.goal, self.params.attractive_gain)
    }

    /// The resultant force (eq. 8, `-grad Phi`) at a cell, by central differences over the
    /// neighbouring cells (per metre). Used by the ant colony's heuristic.
    pub fn force(&self, c: Cell) -> Vector2 {
        let h = 2.0 * self.grid.resolution();
        let phi = |dx, dy| {
            let n = c.offset(dx, dy);
            if self.grid.info().contains(n) {
                self.potential(n)
            } else {
                self.potential(c)
            }
        };
        -Vector2::new((phi(1, 0) - phi(-1, 0)) / h, (phi(0, 1) - phi(0, -1)) / h)
    }
}

/// Which way around the obstacle the traction point lies, seen from the robot.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// Counter-clockwise from the robot-obstacle direction.
    Left,
    Right,
}

/// The virtual traction point of eq. 3–8 (in any consistent unit): the tangent from the robot
/// `x0` to the circle of radius `r` around the obstacle point `a` (eq. 3: `l = |a - x0|`,
/// `alpha = asin(r / l)`, `s = sqrt(l^2 - r^2)`, eq. 4–5: the tangent point `s` along the direction
/// turned by `alpha` from the robot-obstacle direction), then `d` further along the same line.
/// `None` when the robot is inside the circle (no tangent exists).
pub fn traction_point(
    x0: Point2,
    a: Point2,
    r: f64,
    d: f64,
    side: Side,
) -> Option<(Point2, Point2)> {
    let to_a = a - x0;
    let l = to_a.norm();
    if l <= r {
        return None;
    }
    let alpha = (r / l).asin();
    let s = (l * l - r * r).sqrt();
    let theta = to_a.y.atan2(to_a.x) + if side == Side::Left { alpha } else { -alpha };
    let dir = Vector2::new(theta.cos(), theta.sin());
    let tangent = x0 + dir * s;
    Some((tangent, tangent + dir * d))
}

/// Why the potential field could not reach the goal.
#[derive(Clone, Debug, PartialEq)]
pub struct ApfFailure {
    pub reason: String,
    pub steps: usize,
    pub escapes: usize,
}

/// A potential-field path and what it took.
#[derive(Clone, Debug, PartialEq)]
pub struct ApfPath {
    pub cells: Vec<Cell>,
    /// Local minima met (each escaped by a traction point; paper mode).
    pub escapes: usize,
    /// Steps that followed the wavefront where the repulsion held the descent (navigation mode).
    pub wavefront_steps: usize,
}

/// Descends the field from `start` to `goal` (both free cells), escaping local minima.
pub fn descend(
    grid: &PlanningGrid,
    params: &ApfParams,
    start: Cell,
    goal: Cell,
) -> Result<ApfPath, ApfFailure> {
    descend_checked(grid, params, start, goal, &|| Ok(()))
        .expect("never interrupted without a check")
}

/// [`descend`], polling `check` (a plan's deadline and cancel) while the navigation mode's
/// wavefront spreads: that search is as large as A*'s and must stop when the plan is given up.
/// The outer error is the interrupt; the inner one the field's own failure.
pub fn descend_checked(
    grid: &PlanningGrid,
    params: &ApfParams,
    start: Cell,
    goal: Cell,
    check: &dyn Fn() -> Result<(), crate::planner::PlanError>,
) -> Result<Result<ApfPath, ApfFailure>, crate::planner::PlanError> {
    descend_on(grid, params, start, goal, check, None)
}

/// [`descend_checked`] on a [`Wavefront`] the caller already has for this start and goal (the
/// colonies' guidance), so that it is not searched twice; `None` searches it here.
pub fn descend_on(
    grid: &PlanningGrid,
    params: &ApfParams,
    start: Cell,
    goal: Cell,
    check: &dyn Fn() -> Result<(), crate::planner::PlanError>,
    known: Option<&Wavefront>,
) -> Result<Result<ApfPath, ApfFailure>, crate::planner::PlanError> {
    Ok(match params.attraction {
        Attraction::Paper => descend_with(grid, params, start, goal, true),
        Attraction::Navigation => {
            let searched;
            let d = match known {
                Some(d) => d,
                None => match wavefront(grid, start, goal, check)? {
                    Some(d) => {
                        searched = d;
                        &searched
                    }
                    None => {
                        return Ok(Err(ApfFailure {
                            reason: "the goal is not reachable from the start".into(),
                            steps: 0,
                            escapes: 0,
                        }))
                    }
                },
            };
            descend_navigation(grid, params, start, goal, d)
        }
    })
}

/// The wavefront distance (m) from `goal` through free space, over the cells a goal-rooted
/// search toward `start` reached.
///
/// The search is A* run backwards (from the goal, the octile distance to the start as its
/// heuristic) rather than a Dijkstra to every cell up to the start's distance: on a large open
/// map that visits a disc around the goal, A* the ellipse around the straight line, which is
/// what made the field 4.3 x A*'s time on Nav2's 2000 x 2000 benchmark map (issue 12). The
/// heuristic is consistent, so every settled cell's distance is exact; a cell reached but not
/// settled holds an upper bound set from a settled parent with a smaller one. Either way each
/// reached cell other than the goal has a neighbour strictly closer, which is all the descent
/// needs to reach the goal without stalling.
pub struct Wavefront {
    d: Vec<f64>,
    /// Each cell's state in the search: [`UNREACHED`], [`REACHED`] (`d[i]` is an upper bound)
    /// or [`SETTLED`] (`d[i]` is exact). One byte per cell, read with the distance on every
    /// relaxation. Both tables start all-zero (untouched zero pages): the search pays for the
    /// cells it reaches, not for the map.
    state: Vec<u8>,
}

const UNREACHED: u8 = 0;
const REACHED: u8 = 1;
const SETTLED: u8 = 2;

impl Wavefront {
    /// The distance of cell index `i`, infinite where the search did not reach.
    pub fn at(&self, i: usize) -> f64 {
        if self.state[i] != UNREACHED {
            self.d[i]
        } else {
            f64::INFINITY
        }
    }
}

/// The [`Wavefront`] from `goal`; `None` when `start` is not connected to `goal`. Polls `check`
/// every 4096 cells.
pub fn wavefront(
    grid: &PlanningGrid,
    start: Cell,
    goal: Cell,
    check: &dyn Fn() -> Result<(), crate::planner::PlanError>,
) -> Result<Option<Wavefront>, crate::planner::PlanError> {
    use crate::geometry::NEIGHBOURS_8;
    use crate::grid::moves::{allowed, step_length};
    use crate::search::astar::octile;
    use std::cmp::Reverse;
    use std::collections::BinaryHeap;
    let info = grid.info();
    let res = grid.resolution();
    let mut w = Wavefront {
        d: vec![0.0; info.cell_count()],
        state: vec![UNREACHED; info.cell_count()],
    };
    w.state[info.index(goal)] = REACHED;
    // The moves are tested on the grid's padded free mask, by the one move rule A* applies to
    // it ([`allowed`]), so no neighbour needs a bounds check: a free neighbour lies in the map.
    let (width, stride) = (info.width as isize, info.width as isize + 2);
    let free = grid.padded_free();
    let mut heap = BinaryHeap::new();
    // Keys are non-negative: their bit patterns order like the numbers; ties on f go to the
    // smaller index. The entries are small (16 B) because the heap is most of the time. The
    // order among equal keys changes no value: every cell with f at most the stop value below
    // is settled with its exact distance, and a reached cell's bound is the least over its
    // settled neighbours, whatever the order they were settled in.
    let key = |d: f64, c: Cell, i: usize| {
        let f = d + octile(c, start) * res;
        Reverse((f.to_bits(), i as u32))
    };
    heap.push(key(0.0, goal, info.index(goal)));
    let mut popped = 0u64;
    // Once the start is settled at f*, the search goes on until f passes f* + WAVEFRONT_MARGIN_M:
    // every cell of a path at most that much longer than the shortest is then settled with its
    // exact distance, so the descent has a band of true values to choose from around the
    // shortest path (stopping at the start left its neighbours with upper bounds, and the
    // descent staircased along the search's own order: 2 x the turning).
    let mut stop_at = f64::INFINITY;
    while let Some(Reverse((f_bits, i))) = heap.pop() {
        let i = i as usize;
        if w.state[i] == SETTLED {
            continue;
        }
        if f64::from_bits(f_bits) > stop_at {
            break;
        }
        w.state[i] = SETTLED;
        popped += 1;
        if popped.is_multiple_of(4096) {
            check()?;
        }
        let di = w.d[i];
        let c = info.cell_at(i);
        if c == start {
            stop_at = di + WAVEFRONT_MARGIN_M;
        }
        let padded = (c.y as isize + 1) * stride + c.x as isize + 1;
        for &(dx, dy) in &NEIGHBOURS_8 {
            if !allowed(dx, dy, |x, y| {
                free[(padded + x as isize + y as isize * stride) as usize]
            }) {
                continue;
            }
            let step = step_length(dx, dy);
            let j = (i as isize + dx as isize + dy as isize * width) as usize;
            let dn = di + step * res;
            let sj = w.state[j];
            if sj == UNREACHED || (sj == REACHED && dn < w.d[j]) {
                w.d[j] = dn;
                w.state[j] = REACHED;
                heap.push(key(dn, c.offset(dx, dy), j));
            }
        }
    }
    Ok((w.state[info.index(start)] == SETTLED).then_some(w))
}

/// How much longer than the shortest a path may be and still have its cells' wavefront
/// distances exact (see [`wavefront`]).
const WAVEFRONT_MARGIN_M: f64 = 1.0;

/// Navigation mode: each step goes to the neighbour of least potential `0.5 epsilon D^2 +
/// repulsion` (`D` the wavefront distance) among those strictly closer to the goal by the
/// wavefront. `D` falls at every step, so the descent cannot loop or stall and reaches the goal
/// in at most as many steps as there are cells closer than the start; among the downhill moves
/// (up to five) the repulsion picks the one away from the walls. Where the field's own steepest
/// move would have gone uphill in `D` (the repulsion pushing back, the papers' local minimum),
/// the step is counted in `wavefront_steps`.
fn descend_navigation(
    grid: &PlanningGrid,
    params: &ApfParams,
    start: Cell,
    goal: Cell,
    d: &Wavefront,
) -> Result<ApfPath, ApfFailure> {
    let info = grid.info();
    let field = PotentialField::new(grid, params, goal.center());
    let potential = |c: Cell| {
        let dc = d.at(info.index(c));
        0.5 * params.attractive_gain * dc * dc
            + field.repulsion(grid.clearance(c)) * field.goal_factor(c.center())
    };
    let mut cells = vec![start];
    let mut wavefront_steps = 0;
    let mut cur = start;
    while cur != goal {
        let here = d.at(info.index(cur));
        let least = |it: &mut dyn Iterator<Item = Cell>| {
            it.map(|n| (potential(n), n))
                .min_by(|a, b| a.0.total_cmp(&b.0).then_with(|| a.1.cmp(&b.1)))
        };
        let next = least(&mut admissible_moves(grid, cur).filter(|n| d.at(info.index(*n)) < here))
            .expect("a reached cell other than the goal has a neighbour closer to it")
            .1;
        let steepest = least(&mut admissible_moves(grid, cur));
        if steepest.is_some_and(|(_, n)| n != next) {
            wavefront_steps += 1;
        }
        cells.push(next);
        cur = next;
    }
    Ok(ApfPath {
        cells,
        escapes: 0,
        wavefront_steps,
    })
}

/// The same, with escapes switched off: the plain APF that stalls in a U trap (for comparison
/// and tests).
pub fn descend_plain(
    grid: &PlanningGrid,
    params: &ApfParams,
    start: Cell,
    goal: Cell,
) -> Result<ApfPath, ApfFailure> {
    descend_with(grid, params, start, goal, false)
}

fn descend_with(
    grid: &PlanningGrid,
    params: &ApfParams,
    start: Cell,
    goal: Cell,
    escape: bool,
) -> Result<ApfPath, ApfFailure> {
    let field = PotentialField::new(grid, params, goal.center());
    let budget = (params.step_budget_factor * (grid.width() + grid.height()) as f64) as usize;
    let stall_cells = params.stall_distance / grid.resolution();
    let mut visited = std::collections::HashSet::new();
    let mut cells = vec![start];
    visited.insert(start);
    let mut escapes = 0;
    // The active traction point and the steps spent towards it.
    let mut traction: Option<(Point2, usize)> = None;
    let mut last_escape_at = 0;
    let fail = |reason: &str, steps: usize, escapes: usize| ApfFailure {
        reason: reason.into(),
        steps,
        escapes,
    };
    while *cells.last().unwrap() != goal {
        let steps = cells.len() - 1;
        if steps >= budget {
            return Err(fail("the step budget ran out", steps, escapes));
        }
        let cur = *cells.last().unwrap();
        let (target, gain) = match traction {
            Some((t, n)) => (
                t,
                params.attractive_gain * (1.0 + params.traction_growth.powi(n.min(200) as i32)),
            ),
            None => (goal.center(), params.attractive_gain),
        };
        let best = admissible_moves(grid, cur)
            .filter(|n| !visited.contains(n))
            .map(|n| (field.potential_towards(n, target, gain), n))
            .min_by(|a, b| a.0.total_cmp(&b.0).then_with(|| a.1.cmp(&b.1)));
        let Some((p_best, next)) = best else {
            // Every neighbour is blocked or already on the path.
            return Err(fail("boxed in by its own path", steps, escapes));
        };
        if traction.is_none() {
            let here = field.potential_towards(cur, target, gain);
            let window_stall = steps >= last_escape_at + params.stall_window
                && (cells[steps - params.stall_window].center() - cur.center()).norm()
                    < stall_cells;
            if p_best >= here || window_stall {
                if !escape {
                    return Err(fail("local minimum of the potential field", steps, escapes));
                }
                let Some(t) = find_traction_point(grid, params, cur, goal) else {
                    return Err(fail(
                        "no traction point leads out of the local minimum",
                        steps,
                        escapes,
                    ));
                };
                escapes += 1;
                last_escape_at = steps;
                traction = Some((t, 0));
                continue;
            }
        }
        cells.push(next);
        visited.insert(next);
        if let Some((t, n)) = traction {
            // Reached the traction point (or sees the goal): the goal's attraction takes over.
            let arrived = (next.center() - t).norm() <= 1.0;
            let sees_goal = line_of_sight(grid, next.center(), goal.center());
            traction = if arrived || sees_goal {
                None
            } else {
                Some((t, n + 1))
            };
            if traction.is_none() {
                last_escape_at = cells.len() - 1;
            }
        }
    }
    Ok(ApfPath {
        cells,
        escapes,
        wavefront_steps: 0,
    })
}

/// The 8-neighbour moves A* allows from a cell (the one move rule of [`crate::grid::moves`]).
fn admissible_moves(grid: &PlanningGrid, c: Cell) -> impl Iterator<Item = Cell> + '_ {
    grid.moves(c).map(|(_, n)| n)
}

/// Sweeps rays from `cur` away from the goal direction, alternately left and right, for the first
/// clear one; the previous (blocked) ray on that side hits the obstacle's outer end, around which
/// eq. 3–8 place the traction point. Returns it in grid coordinates, inside a free cell.
fn find_traction_point(
    grid: &PlanningGrid,
    params: &ApfParams,
    cur: Cell,
    goal: Cell,
) -> Option<Point2> {
    let res = grid.resolution();
    let x0 = cur.center();
    let to_goal = goal.center() - x0;
    let theta_g = to_goal.y.atan2(to_goal.x);
    let reach = to_goal
        .norm()
        .min(4.0 * (params.traction_radius + params.traction_distance) / res)
        .max(2.0);
    let hit = |theta: f64| -> Option<Point2> {
        // The first blocked cell along the ray, if any within reach.
        let end = x0 + Vector2::new(theta.cos(), theta.sin()) * reach;
        let mut first = None;
        crate::grid::raycast::supercover(x0, end, |c| {
            if grid.is_free(c) {
                true
            } else {
                first = Some(c.center());
                false
            }
        });
        first
    };
    let step = params.sweep_step_deg.to_radians();
    let steps = (std::f64::consts::PI / step).ceil() as i32;
    let mut last_hit = [hit(theta_g), hit(theta_g)];
    let (r, d) = (params.traction_radius / res, params.traction_distance / res);
    for k in 1..=steps {
        for (i, (sign, side)) in [(1.0, Side::Left), (-1.0, Side::Right)]
            .into_iter()
            .enumerate()
        {
            let theta = theta_g + sign * k as f64 * step;
            match hit(theta) {
                Some(h) => last_hit[i] = Some(h),
                None => {
                    // This side opens. The obstacle's end is the last blocked ray's hit point.
                    let Some(a) = last_hit[i] else { continue };
                    let candidate = traction_point(x0, a, r.min((a - x0).norm() * 0.9), d, side)
                        .map(|(_, t)| t)
                        .unwrap_or_else(|| x0 + Vector2::new(theta.cos(), theta.sin()) * d);
                    if let Some(t) = pull_back_into_free(grid, x0, candidate) {
                        return Some(t);
                    }
                }
            }
        }
    }
    None
}

/// The point nearest to `target` along `from -> target` that is in a free cell and visible from
/// `from`, if the segment leaves `from`'s cell at all.
fn pull_back_into_free(grid: &PlanningGrid, from: Point2, target: Point2) -> Option<Point2> {
    for k in (1..=10).rev() {
        let p = from + (target - from) * (k as f64 / 10.0);
        if Cell::containing(p) != Cell::containing(from) && line_of_sight(grid, from, p) {
            return Some(Cell::containing(p).center());
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::grid_from_rows;
    use ordered_float::OrderedFloat;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// Against Dijkstra from the goal (the `pathfinding` crate, A*'s move rule) as an oracle,
        /// on 0.25 m cells: the wavefront answers exactly when the start is connected; every
        /// cell whose exact distance plus its octile distance to the start is within
        /// `WAVEFRONT_MARGIN_M` of the shortest (the search's own stop rule, so every cell of a
        /// path that much longer than the shortest) has its exact distance, the start included;
        /// every reached cell has at least its exact distance and, but for the goal, a neighbour
        /// it may move to with a smaller one (what the descent needs).
        #[test]
        fn exact_in_its_band_and_downhill_everywhere(seed in any::<u64>(), density in 0.0f64..0.35) {
            let (grid, start, goal) = crate::test_support::random_grid(seed, 30, 24, density);
            // The same cells at 0.25 m, so that cells and metres cannot be confused.
            let res = 0.25;
            let grid = crate::test_support::grid_with((30, 24), res, 0.0, |x, y| {
                !grid.is_free(Cell::new(x as i32, y as i32))
            });
            let info = *grid.info();
            let exact = pathfinding::directed::dijkstra::dijkstra_all(&goal, |&c| {
                crate::search::astar::successors(&grid, c)
                    .map(|(n, w)| (n, OrderedFloat(w * res)))
                    .collect::<Vec<_>>()
            });
            let exact = |c: Cell| if c == goal { Some(0.0) } else { exact.get(&c).map(|(_, d)| d.0) };
            let w = wavefront(&grid, start, goal, &|| Ok(())).unwrap();
            prop_assert_eq!(w.is_some(), exact(start).is_some());
            let Some(w) = w else { return Ok(()) };
            let shortest = exact(start).unwrap();
            prop_assert!((w.at(info.index(start)) - shortest).abs() < 1e-9);
            for i in 0..info.cell_count() {
                let c = info.cell_at(i);
                let Some(e) = exact(c) else {
                    prop_assert!(w.at(i).is_infinite(), "{:?} is not connected", c);
                    continue;
                };
                let d = w.at(i);
                if e + crate::search::astar::octile(c, start) * res
                    <= shortest + WAVEFRONT_MARGIN_M - 1e-9
                {
                    prop_assert!((d - e).abs() < 1e-9, "{:?}: {} against {}", c, d, e);
                }
                if d.is_finite() {
                    prop_assert!(d >= e - 1e-9);
                    if c != goal {
                        prop_assert!(grid
                            .moves(c)
                            .any(|(_, n)| w.at(info.index(n)) < d));
                    }
                }
            }
        }
    }

    #[test]
    fn traction_point_on_a_hand_computed_case() {
        // Robot at the origin, obstacle 10 away on +x, circle radius 6: l = 10, alpha =
        // asin(0.6), s = 8, so the left tangent point is 8 * (0.8, 0.6) = (6.4, 4.8); 2 beyond it
        // along the same line is (8, 6).
        let (t, p) = traction_point(
            Point2::origin(),
            Point2::new(10.0, 0.0),
            6.0,
            2.0,
            Side::Left,
        )
        .unwrap();
        assert!((t - Point2::new(6.4, 4.8)).norm() < 1e-12);
        assert!((p - Point2::new(8.0, 6.0)).norm() < 1e-12);
        let (t, _) = traction_point(
            Point2::origin(),
            Point2::new(10.0, 0.0),
            6.0,
            2.0,
            Side::Right,
        )
        .unwrap();
        assert!((t - Point2::new(6.4, -4.8)).norm() < 1e-12);
        // The tangent point is on the circle and the tangent is perpendicular to the radius.
        let a = Point2::new(10.0, 0.0);
        assert!(((t - a).norm() - 6.0).abs() < 1e-12);
        assert!((t - Point2::origin()).dot(&(t - a)).abs() < 1e-9);
        assert_eq!(
            traction_point(Point2::origin(), a, 11.0, 2.0, Side::Left),
            None
        );
    }

    #[test]
    fn eq9_repulsion_vanishes_at_the_goal() {
        let grid = grid_from_rows(&["....", "..#.", "...."]);
        let params = ApfParams {
            influence_distance: 3.0,
            ..ApfParams::default()
        };
        let goal = Cell::new(1, 1);
        let field = PotentialField::new(&grid, &params, goal.center());
        // The goal is next to an obstacle: repulsion is strong there...
        assert!(field.repulsion(grid.clearance(goal)) > 0.1);
        // ...but eq. 9's factor removes it at the goal, so the goal is the field's minimum there.
        assert_eq!(field.goal_factor(goal.center()), 0.0);
        assert_eq!(field.potential(goal), 0.0);
        assert!(admissible_moves(&grid, goal).all(|n| field.potential(n) > 0.0));
        // And away from the goal the factor tends to 1.
        assert!(field.goal_factor(Cell::new(3, 2).center()) > 0.99);
    }

    /// A point robot (radius 0, as `costmap.robot_radius: 0` hands down): eq. 9's factor is
    /// its limit, not 0 / 0 at the goal, whose NaN potential had kept every ant of `aco_apf`
    /// from ever choosing the goal.
    #[test]
    fn eq9_factor_of_a_point_robot_is_its_limit() {
        let grid = grid_from_rows(&["....", "..#.", "...."]);
        let params = ApfParams {
            chassis_radius: Some(0.0),
            ..ApfParams::default()
        };
        let goal = Cell::new(1, 1);
        let field = PotentialField::new(&grid, &params, goal.center());
        assert_eq!(field.goal_factor(goal.center()), 0.0);
        assert_eq!(field.goal_factor(Cell::new(0, 1).center()), 1.0);
        assert_eq!(field.potential(goal), 0.0);
        assert!(admissible_moves(&grid, goal).all(|n| field.potential(n).is_finite()));
    }

    #[test]
    fn force_points_downhill() {
        let grid = grid_from_rows(&["......", "......", "......"]);
        let params = ApfParams::default();
        let field = PotentialField::new(&grid, &params, Cell::new(5, 1).center());
        let f = field.force(Cell::new(1, 1));
        assert!(f.x > 0.0 && f.y.abs() < 1e-9);
    }
}
