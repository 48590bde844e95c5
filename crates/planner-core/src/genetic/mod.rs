//! The improved multi-objective genetic algorithm (IMGA) of the genetic algorithm paper
//! (Li, Hu, Liu, "Path Planning of Mobile Robot Based on Improved Multiobjective Genetic
//! Algorithm", Wireless Communications and Mobile Computing 2021, sections 3.3–4.6;
//! `docs/papers.md`) and a plain GA baseline, on the population driver.
//!
//! - Chromosome: the cells of a continuous path from start to goal, no repeats, no obstacles.
//!   "Continuous" uses A*'s move rule (8-neighbours, no corner cutting), so every chromosome also
//!   passes the project's collision rule.
//! - Initial population (4.1): `[S, R, G]` with `R` a random free cell, then, while two adjacent
//!   genes are not neighbours, insert the median cell between them (eq. 3), or a random free
//!   8-neighbour of it when it is blocked or already on the path. Inflated obstacles are thicker
//!   than the paper's one-cell ones, so when all eight are blocked the next rings out are tried
//!   (up to the gap's size) before the individual is discarded (and counted). Every inserted cell
//!   is strictly closer (Chebyshev) to both genes than they are to each other, so gaps always
//!   shrink and filling ends. The plain GA fills gaps with a random cell of the gap's
//!   bounding box instead (random feasible paths).
//! - Fitness (4.2), smaller is better: `w_l * length + w_s * safety + w_e * energy`; length the
//!   sum of Euclidean steps (m); safety +5 for each node with a blocked cell in its
//!   8-neighbourhood (cells outside the map count as blocked: the robot cannot go there either);
//!   energy, per heading change, the quadrant of the new heading in the frame of the old one:
//!   first (ahead, a 45 deg turn) +1, second or fourth (a 90 deg turn) +3, third (behind: 135 or
//!   180 deg) +10, no turn 0. Weights 1.0 / 0.5 / 0.5 (`docs/papers.md`: lost from the text).
//!   Beyond the paper (issue 13): `w_c * cost`, the graded costmap cost along the path (metres
//!   at cost 252, [`PlanningGrid::cost`]), so that among equally short paths the one through the
//!   middle of the aisle is fitter; the paper's safety term only sees the cells next to an
//!   obstacle. `weight_cost: 0` (config/paper.yaml) is the paper's fitness exactly.
//! - Layered selection (4.3.1): sorted by fitness, three layers of `N / 3`; the first copied
//!   twice, the second once, the rest filled from the best of the third. The plain GA uses
//!   roulette selection on `1 / fitness`.
//! - Single-point crossover at a cell both parents share (4.3.2); eight-neighbourhood single-point
//!   mutation with reconnection by median insertion (4.3.3); loops a splice creates are cut, so
//!   children stay repeat-free. Beyond the paper, IMGA's default mutation reroutes a stretch of
//!   the path instead of moving one cell ([`GaParams::mutation`]): at 0.05 m a cell is no
//!   decision.
//! - Termination (4.4): `generations`, or `patience` generations without a better best (the
//!   paper's 40), or the interrupt callback (the best so far comes back): the population driver's
//!   one rule.
//! - The delete operation (4.5) on the best path: on by default for `imga`, off for `ga`.

pub mod operators;

use crate::driver::{drive, Budget, Population};
use crate::geometry::{Cell, Point2};
use crate::grid::inflation::PlanningGrid;
use crate::judge::PulledBest;
use crate::params::{check, check_counts, ParamError, Range};
use crate::planner::{PlanContext, PlanError, PlanStats, Planner, Problem, RawPlan};
use crate::planner_name::PlannerName;
use operators::{connect, crossover, layered_selection, mutate, reroute};
use rand::seq::{IndexedRandom, SliceRandom};
use rand::Rng;
use rustc_hash::{FxBuildHasher, FxHashMap, FxHashSet};
use serde::{Deserialize, Serialize};
use std::hash::BuildHasher;

/// Parameters of the genetic planners.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GaParams {
    /// Individuals. Default 30.
    pub population: usize,
    /// Generations. Default 50 (paper).
    pub generations: usize,
    /// Stop after this many generations without a better best (the driver's one patience rule).
    /// Default 40 (paper). Also read under its old name, `stall_generations`.
    #[serde(alias = "stall_generations")]
    pub patience: usize,
    /// Probability that a pair is crossed. Default 0.8.
    pub crossover_rate: f64,
    /// Probability that an individual is mutated. Default 0.2.
    pub mutation_rate: f64,
    /// Fitness weights of length, safety and energy. Defaults 1.0, 0.5, 0.5.
    pub weight_length: f64,
    pub weight_safety: f64,
    pub weight_energy: f64,
    /// Fitness weight of the graded costmap cost along the path (per metre at cost 252).
    /// Default 1; 0 is the paper's fitness.
    pub weight_cost: f64,
    /// Beyond the paper: the potential field's path (A*'s where the field cannot reach the goal)
    /// is the first individual, so the population is never empty where a path exists (on large
    /// maps the random initial paths often cannot be completed within the insertion budget:
    /// issue 12). Default true; false is the paper's random population (config/paper.yaml).
    pub seeded: bool,
    /// Beyond the paper: initial individuals pass through a random cell of the box around
    /// start and goal widened by this share of their distance (at least 1 m) on each side,
    /// instead of any free cell of the map. Default 0.5; 0 is the paper's (config/paper.yaml).
    pub corridor: f64,
    /// Attempts per wanted individual before the initial population is accepted as it is.
    /// Default 10.
    pub init_attempts: usize,
    /// Insertions allowed per path, as a multiple of (width + height), before an individual is
    /// discarded. Default 4.
    pub insertion_budget_factor: f64,
    /// What makes IMGA's path the answer (the plain GA's is always the fittest). `fitness` (the
    /// paper, config/paper.yaml): the fittest path of all generations. `pulled` (default): the
    /// evolution is the paper's (selection, patience and the convergence curve follow the
    /// fitness), but the answer starts as the seed and is replaced by each path that straightens
    /// (the delete operation `solve` applies) into a shorter or smoother one than the answer so
    /// far, worse on neither: each generation the `PULLED_PER_GENERATION` shortest individuals
    /// not judged before are straightened and offered. The fittest cell path weighs safety and
    /// the staircase's own turns, and after the delete operation it was seldom both shorter and
    /// smoother than the field's path it started from (issue 12: better than the seed on 4-26 %
    /// of the queries). The counters `fitness` and `fitness_*` are the fittest path's;
    /// `answer_fitness` is the answer's.
    pub judge: GaJudge,
    /// How IMGA mutates (the plain GA always uses the paper's). `neighbour` (the paper's 4.3.3,
    /// config/paper.yaml): one inner cell moves to a free 8-neighbour and the path is
    /// reconnected. `reroute` (default): a stretch of the path between two of its cells, its
    /// length drawn log-uniformly from 2 cells to the whole path, is replaced by median insertion
    /// through a random free cell near the stretch's middle (up to a quarter of the stretch's
    /// span away). A one-cell move is a decision on the paper's 20 x 20 grid; on a 0.05 m map it
    /// moves the path 5 cm, which the delete operation straightens away, so the population held
    /// no path better than the seed (issue 12: on the Nav2 warehouse every IMGA miss that was
    /// not a straight seed returned the seed's own path). Rerouting moves whole stretches, from
    /// a corner cut to a detour round another side, at every scale at once. With `reroute` and
    /// `seeded`, the places of the initial population that random paths could not fill are
    /// filled with rerouted copies of the seed (counter `seed_variants`): on warehouse maps
    /// median insertion seldom completes a random path, and the seed alone was the population.
    pub mutation: GaMutation,
    /// Beyond the paper: each generation, this many reroutes (the `reroute` mutation) of IMGA's
    /// answer, each kept when it straightens into a better answer (under `judge: pulled`
    /// only), as the colonies' `local_search` does for their best ant. The population breeds
    /// from fitness, which weighs safety and the staircase's turns, so the answer's own
    /// neighbourhood was searched only when a mutation happened to land on it. Default 1 (2
    /// found a little more at 1.2 x imga's time on the 2000 x 2000 map, past the 5 x A* bar);
    /// 0 is the paper (config/paper.yaml).
    pub local_search: usize,
}

/// See [`GaParams::mutation`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum GaMutation {
    Neighbour,
    Reroute,
}

/// See [`GaParams::judge`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum GaJudge {
    Fitness,
    Pulled,
}

/// How many individuals of a generation [`GaJudge::Pulled`] straightens (the shortest of those
/// not judged before): each straightening is a line-of-sight pass over the path.
const PULLED_PER_GENERATION: usize = 3;

impl Default for GaParams {
    fn default() -> Self {
        Self {
            population: 30,
            generations: 50,
            patience: 40,
            crossover_rate: 0.8,
            mutation_rate: 0.2,
            weight_length: 1.0,
            weight_safety: 0.5,
            weight_energy: 0.5,
            weight_cost: 1.0,
            seeded: true,
            corridor: 0.5,
            init_attempts: 10,
            insertion_budget_factor: 4.0,
            judge: GaJudge::Pulled,
            mutation: GaMutation::Reroute,
            local_search: 1,
        }
    }
}

impl GaParams {
    pub fn validate(&self) -> Result<(), ParamError> {
        check_counts(2..=3_000, &[("genetic.population", self.population)])?;
        check_counts(
            1..=1_000_000,
            &[
                ("genetic.generations", self.generations),
                ("genetic.patience", self.patience),
            ],
        )?;
        check_counts(1..=100, &[("genetic.init_attempts", self.init_attempts)])?;
        check_counts(0..=100, &[("genetic.local_search", self.local_search)])?;
        // Multiples of the map's size (the corridor of initial paths, the insertions allowed).
        check(
            Range::Within(0.0, 100.0),
            &[
                ("genetic.corridor", self.corridor),
                (
                    "genetic.insertion_budget_factor",
                    self.insertion_budget_factor,
                ),
            ],
        )?;
        check(
            Range::Share,
            &[
                ("genetic.crossover_rate", self.crossover_rate),
                ("genetic.mutation_rate", self.mutation_rate),
            ],
        )?;
        check(
            Range::NonNegative,
            &[
                ("genetic.weight_length", self.weight_length),
                ("genetic.weight_safety", self.weight_safety),
                ("genetic.weight_energy", self.weight_energy),
                ("genetic.weight_cost", self.weight_cost),
            ],
        )
    }
}

/// The two genetic planners.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GaVariant {
    Imga,
    Ga,
}

impl GaVariant {
    pub fn name(self) -> PlannerName {
        match self {
            GaVariant::Imga => PlannerName::Imga,
            GaVariant::Ga => PlannerName::Ga,
        }
    }
}

#[derive(Clone, Debug)]
pub struct GaPlanner {
    pub variant: GaVariant,
    pub params: GaParams,
    /// The potential field whose path seeds the population when `params.seeded`.
    pub apf: crate::field::ApfParams,
}

/// The three terms of a path's fitness.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FitnessTerms {
    pub length_m: f64,
    pub safety: f64,
    pub energy: f64,
    /// The costmap cost along the path: `sum cost(c) / 252 * step` (m), over the steps into
    /// each cell; computed only when it is weighted (else 0).
    pub cost_m: f64,
}

/// Energy penalty of one heading change between two 8-connected steps: the turn in 45 degree
/// steps (0 to 4) read as the quadrant of the new heading in the old one's frame.
pub fn turn_penalty(from: (i32, i32), to: (i32, i32)) -> f64 {
    // Direction index counter-clockwise from +x, in 45 degree steps.
    let index = |d: (i32, i32)| -> i32 {
        match (d.0.signum(), d.1.signum()) {
            (1, 0) => 0,
            (1, 1) => 1,
            (0, 1) => 2,
            (-1, 1) => 3,
            (-1, 0) => 4,
            (-1, -1) => 5,
            (0, -1) => 6,
            _ => 7,
        }
    };
    let diff = (index(to) - index(from)).rem_euclid(8);
    match diff.min(8 - diff) {
        0 => 0.0,
        1 => 1.0,
        2 => 3.0,
        _ => 10.0,
    }
}

/// The fitness terms of a cell path (4.2), with the cost term when `with_cost`.
pub fn fitness_terms(grid: &PlanningGrid, path: &[Cell], with_cost: bool) -> FitnessTerms {
    let res = grid.resolution();
    let length_m = crate::search::astar::cell_path_length(path) * res;
    let safety = path.iter().filter(|&&c| grid.next_to_blocked(c)).count() as f64 * 5.0;
    let energy = path
        .windows(3)
        .map(|w| {
            turn_penalty(
                (w[1].x - w[0].x, w[1].y - w[0].y),
                (w[2].x - w[1].x, w[2].y - w[1].y),
            )
        })
        .sum();
    let cost_m = if with_cost {
        let cells = grid.cell_reader();
        path.windows(2)
            .map(|w| step_length(w[0], w[1]) * cells.free_and_cost(w[1]).1 as f64 / 252.0)
            .sum::<f64>()
            * res
    } else {
        0.0
    };
    FitnessTerms {
        length_m,
        safety,
        energy,
        cost_m,
    }
}

/// The length (cells) of one step of a chromosome: 1 or the square root of 2 for the
/// 8-connected steps it is made of (the bits `hypot` gives them), `hypot` for any other.
fn step_length(a: Cell, b: Cell) -> f64 {
    match ((b.x - a.x).abs(), (b.y - a.y).abs()) {
        (1, 0) | (0, 1) => 1.0,
        (1, 1) => std::f64::consts::SQRT_2,
        (dx, dy) => (dx as f64).hypot(dy as f64),
    }
}

impl GaParams {
    fn fitness(&self, t: &FitnessTerms) -> f64 {
        let paper = self.weight_length * t.length_m
            + self.weight_safety * t.safety
            + self.weight_energy * t.energy;
        // Left out at weight 0, so the paper's fitness is computed exactly as before.
        if self.weight_cost > 0.0 {
            paper + self.weight_cost * t.cost_m
        } else {
            paper
        }
    }
}

/// A population under construction that holds each path once: a path already held is refused
/// in constant time (by its hash, then compared), where `Vec::contains` made building a large
/// population quadratic (3 000 paths, 30 000 attempts each checked against all of them).
struct DistinctPaths {
    paths: Vec<Vec<Cell>>,
    by_hash: FxHashMap<u64, Vec<usize>>,
}

impl DistinctPaths {
    fn with_capacity(n: usize) -> Self {
        Self {
            paths: Vec::with_capacity(n),
            by_hash: FxHashMap::default(),
        }
    }

    fn len(&self) -> usize {
        self.paths.len()
    }

    fn is_empty(&self) -> bool {
        self.paths.is_empty()
    }

    /// Adds `path` unless it is held already; returns whether it was added.
    fn insert(&mut self, path: Vec<Cell>) -> bool {
        let same = self
            .by_hash
            .entry(FxBuildHasher.hash_one(&path))
            .or_default();
        if same.iter().any(|&i| self.paths[i] == path) {
            return false;
        }
        same.push(self.paths.len());
        self.paths.push(path);
        true
    }
}

impl GaPlanner {
    /// Whether the answer is chosen by [`GaJudge::Pulled`]: for IMGA only, whose answer goes
    /// through the delete operation. The plain GA's answer is its cell path as it stands (no
    /// delete operation by default), which the fittest path already is: judging it by a
    /// straightened path it does not return would pick a worse staircase.
    fn pulled_judge(&self) -> bool {
        self.params.judge == GaJudge::Pulled && self.variant == GaVariant::Imga
    }
}

impl Planner for GaPlanner {
    /// A* (the paths between random points) plus the list of free cells (8 B each).
    fn working_bytes_per_cell(&self) -> u64 {
        crate::planner::ASTAR_BYTES_PER_CELL + 8
    }

    fn name(&self) -> PlannerName {
        self.variant.name()
    }

    fn smooth_by_default(&self) -> bool {
        self.variant == GaVariant::Imga
    }

    fn plan(&self, problem: &Problem<'_>, ctx: &mut PlanContext<'_>) -> Result<RawPlan, PlanError> {
        let grid = problem.grid;
        let p = &self.params;
        let generations = Generations {
            planner: self,
            problem: *problem,
            median: self.variant == GaVariant::Imga,
            insertion_budget: (p.insertion_budget_factor * (grid.width() + grid.height()) as f64)
                as usize
                + 8,
            scored: Vec::new(),
            best: (f64::INFINITY, Vec::new()),
            answer: None,
            judged: FxHashSet::default(),
            seed: None,
            seed_cells: None,
            evaluations: 0,
            failed_mutations: 0,
        };
        let budget = Budget {
            iterations: p.generations,
            patience: Some(p.patience),
        };
        drive(generations, budget, ctx)
    }
}

/// One GA run: the population sorted by fitness (best first) and the best so far. The driver
/// runs it.
struct Generations<'a> {
    planner: &'a GaPlanner,
    problem: Problem<'a>,
    /// Median insertion (IMGA) or random gap filling (plain GA).
    median: bool,
    /// Insertions allowed per path before an individual is discarded.
    insertion_budget: usize,
    scored: Vec<(f64, Vec<Cell>)>,
    best: (f64, Vec<Cell>),
    /// Under [`GaJudge::Pulled`]: the answer (its path and straightened measure) and the
    /// hashes of the paths already straightened.
    answer: Option<PulledBest>,
    judged: FxHashSet<u64>,
    /// The field's path, the first individual when `seeded` (grid coordinates), and its cells
    /// until the pulled judge takes them.
    seed: Option<Vec<Point2>>,
    seed_cells: Option<Vec<Cell>>,
    evaluations: u64,
    failed_mutations: u64,
}

impl Generations<'_> {
    fn score(&self, path: &[Cell]) -> f64 {
        self.planner.params.fitness(&fitness_terms(
            self.problem.grid,
            path,
            self.planner.params.weight_cost > 0.0,
        ))
    }

    /// [`GaJudge::Pulled`]: straightens the [`PULLED_PER_GENERATION`] shortest individuals of
    /// the population not judged before and offers each as the answer (skipping those too long
    /// to straighten into a shorter one: [`PulledBest::may_improve`]).
    fn judge_pulled(&mut self) {
        let Some(answer) = self.answer.as_mut() else {
            return;
        };
        let mut fresh: Vec<(f64, u64, usize)> = Vec::new();
        for (i, (_, path)) in self.scored.iter().enumerate() {
            let len = crate::search::astar::cell_path_length(path);
            if !answer.may_improve(len) {
                continue;
            }
            let hash = FxBuildHasher.hash_one(path);
            if !self.judged.contains(&hash) && fresh.iter().all(|f| f.1 != hash) {
                fresh.push((len, hash, i));
            }
        }
        fresh.sort_by(|a, b| a.0.total_cmp(&b.0));
        for &(_, hash, i) in fresh.iter().take(PULLED_PER_GENERATION) {
            self.judged.insert(hash);
            answer.offer(self.problem.grid, &self.scored[i].1);
        }
    }

    /// [`GaParams::local_search`]: reroutes of the answer, each offered as the answer in turn.
    fn local_search(&mut self, ctx: &mut PlanContext<'_>) {
        let grid = self.problem.grid;
        for _ in 0..self.planner.params.local_search {
            if ctx.check().is_err() {
                return;
            }
            let Some(answer) = self.answer.as_mut() else {
                return;
            };
            answer.offer_reroute(grid, self.insertion_budget, ctx.rng);
        }
    }
}

impl Population for Generations<'_> {
    /// 4.1: the initial population, sorted by fitness.
    fn init(&mut self, ctx: &mut PlanContext<'_>, stats: &mut PlanStats) -> Result<f64, PlanError> {
        let grid = self.problem.grid;
        let p = &self.planner.params;
        let (s, g) = (self.problem.start, self.problem.goal);
        // The random intermediate cell of each initial individual (4.1): any free cell of the
        // map (the paper), or, with `corridor`, one of the box around start and goal widened by
        // `corridor` x their distance (at least 1 m) on each side, drawn by rejection, so that
        // initial paths on a large map are not map-wide detours that the insertion budget
        // cannot complete (issue 12: 'no initial path could be completed').
        let free: Vec<Cell> = if p.corridor > 0.0 {
            Vec::new()
        } else {
            let info = grid.info();
            (0..info.cell_count())
                .map(|i| info.cell_at(i))
                .filter(|&c| grid.is_free(c) && c != s && c != g)
                .collect()
        };
        let corridor = {
            let half = (p.corridor * ((g.x - s.x) as f64).hypot((g.y - s.y) as f64))
                .max(1.0 / grid.resolution())
                .ceil() as i32;
            let (w, h) = (grid.width() as i32, grid.height() as i32);
            (
                (s.x.min(g.x) - half).max(0),
                (s.y.min(g.y) - half).max(0),
                (s.x.max(g.x) + half).min(w - 1),
                (s.y.max(g.y) + half).min(h - 1),
            )
        };
        let draw = |rng: &mut crate::planner::PlannerRng| -> Option<Cell> {
            if p.corridor <= 0.0 {
                return free.choose(rng).copied();
            }
            let (x0, y0, x1, y1) = corridor;
            (0..64).find_map(|_| {
                let c = Cell::new(rng.random_range(x0..=x1), rng.random_range(y0..=y1));
                (grid.is_free(c) && c != s && c != g).then_some(c)
            })
        };
        let mut pop = DistinctPaths::with_capacity(p.population);
        if p.seeded {
            let seed = crate::seed::field_or_astar(
                &self.problem,
                &self.planner.apf,
                ctx,
                stats,
                "first individual",
            )?;
            self.seed = Some(seed.iter().map(|c| c.center()).collect());
            if self.planner.pulled_judge() {
                self.seed_cells = Some(seed.clone());
            }
            pop.insert(seed);
        }
        let mut discarded = 0u64;
        // Each attempt may run a map-long median insertion: the deadline is polled before each
        // (at the largest population and attempts, 300 000 of them), and the population starts
        // with the paths made by then.
        for _ in 0..p.population * p.init_attempts {
            if pop.len() == p.population || ctx.check().is_err() {
                break;
            }
            let genes = match draw(ctx.rng) {
                Some(r) => vec![s, r, g],
                None => vec![s, g],
            };
            match connect(grid, genes, self.median, self.insertion_budget, ctx.rng) {
                Some(path) => {
                    pop.insert(path);
                }
                None => discarded += 1,
            }
        }
        stats
            .counters
            .insert("discarded_individuals".into(), discarded as f64);
        // Where random initial paths cannot be completed (long shelves and walls defeat median
        // insertion between far cells), the seed alone would be the population: no crossover,
        // a few mutations. With `reroute`, the places left are filled with rerouted copies of
        // the seed instead.
        if self.planner.variant == GaVariant::Imga && p.mutation == GaMutation::Reroute && p.seeded
        {
            if let Some(seed) = pop.paths.first().cloned() {
                let mut variants = 0u64;
                for _ in 0..p.population * p.init_attempts {
                    if pop.len() == p.population || ctx.check().is_err() {
                        break;
                    }
                    if let Some(path) = reroute(grid, &seed, self.insertion_budget, ctx.rng) {
                        if pop.insert(path) {
                            variants += 1;
                        }
                    }
                }
                if variants > 0 {
                    stats
                        .counters
                        .insert("seed_variants".into(), variants as f64);
                }
            }
        }
        if pop.is_empty() {
            ctx.check()?;
            return Err(PlanError::NoValidPath(format!(
                "no initial path could be completed ({discarded} discarded)"
            )));
        }
        self.scored = pop.paths.into_iter().map(|c| (self.score(&c), c)).collect();
        self.scored.sort_by(|a, b| a.0.total_cmp(&b.0));
        // The initial population's fitness evaluations count, as the swarms' do.
        self.evaluations += self.scored.len() as u64;
        self.best = self.scored[0].clone();
        if self.planner.pulled_judge() {
            // The seed is the answer to beat; without one, the fittest initial path.
            let first = self
                .seed_cells
                .take()
                .unwrap_or_else(|| self.best.1.clone());
            let mut answer = PulledBest::default();
            answer.set(grid, &first);
            self.judged.insert(FxBuildHasher.hash_one(&first));
            self.answer = Some(answer);
            self.judge_pulled();
        }
        Ok(self.best.0)
    }

    /// One generation: selection (layered or roulette), crossover, mutation, re-scoring.
    fn step(&mut self, _t: usize, ctx: &mut PlanContext<'_>) -> f64 {
        let grid = self.problem.grid;
        let p = &self.planner.params;
        let n = self.scored.len();
        // Each child with its parent's fitness while it is the parent's copy: a child that no
        // crossover or mutation changes is not scored again (a fifth of the children or more at
        // the default rates, and scoring walks every cell of a path).
        let mut next: Vec<(Option<f64>, Vec<Cell>)> = match self.planner.variant {
            GaVariant::Imga => layered_selection(n)
                .into_iter()
                .map(|i| (Some(self.scored[i].0), self.scored[i].1.clone()))
                .collect(),
            GaVariant::Ga => {
                let weights: Vec<f64> =
                    self.scored.iter().map(|(f, _)| 1.0 / f.max(1e-9)).collect();
                let total: f64 = weights.iter().sum();
                (0..n)
                    .map(|_| {
                        let mut r = ctx.rng.random::<f64>() * total;
                        let k = weights.iter().position(|&w| {
                            r -= w;
                            r < 0.0
                        });
                        let (fitness, path) = &self.scored[k.unwrap_or(n - 1)];
                        (Some(*fitness), path.clone())
                    })
                    .collect()
            }
        };
        // Crossover at a shared cell.
        next.shuffle(ctx.rng);
        for pair in next.chunks_exact_mut(2) {
            if ctx.rng.random::<f64>() < p.crossover_rate {
                if let [(fa, a), (fb, b)] = pair {
                    if crossover(a, b, ctx.rng) {
                        (*fa, *fb) = (None, None);
                    }
                }
            }
        }
        // Mutation. Each may run a long median insertion on a large map: the deadline is
        // polled before each child, and a generation cut short leaves the population as it was.
        let reroutes = self.planner.variant == GaVariant::Imga && p.mutation == GaMutation::Reroute;
        for (fitness, child) in next.iter_mut() {
            if ctx.check().is_err() {
                return self.best.0;
            }
            if ctx.rng.random::<f64>() < p.mutation_rate {
                let mutated = if reroutes {
                    reroute(grid, child, self.insertion_budget, ctx.rng)
                } else {
                    mutate(grid, child, self.median, self.insertion_budget, ctx.rng)
                };
                match mutated {
                    Some(m) => (*fitness, *child) = (None, m),
                    None => self.failed_mutations += 1,
                }
            }
        }
        self.scored = next
            .into_iter()
            .map(|(fitness, c)| (fitness.unwrap_or_else(|| self.score(&c)), c))
            .collect();
        self.scored.sort_by(|a, b| a.0.total_cmp(&b.0));
        // Every child's fitness counts, a copy's too: the count is the algorithm's (the budget
        // the swarms and NSGA-II are compared at), not the work of computing it.
        self.evaluations += self.scored.len() as u64;
        if self.scored[0].0 < self.best.0 - 1e-12 {
            self.best = self.scored[0].clone();
        }
        if self.planner.pulled_judge() {
            self.judge_pulled();
            self.local_search(ctx);
        }
        self.best.0
    }

    fn evaluations(&self) -> u64 {
        self.evaluations
    }

    fn finish(self, mut stats: PlanStats, _: &mut PlanContext<'_>) -> Result<RawPlan, PlanError> {
        let with_cost = self.planner.params.weight_cost > 0.0;
        // The fittest path's terms; the answer is the fittest too unless the pulled judge chose.
        let terms = fitness_terms(self.problem.grid, &self.best.1, with_cost);
        if self.failed_mutations > 0 {
            stats
                .counters
                .insert("failed_mutations".into(), self.failed_mutations as f64);
        }
        stats.counters.insert("fitness".into(), self.best.0);
        stats
            .counters
            .insert("fitness_length_m".into(), terms.length_m);
        stats.counters.insert("fitness_safety".into(), terms.safety);
        stats.counters.insert("fitness_energy".into(), terms.energy);
        if with_cost {
            stats.counters.insert("fitness_cost_m".into(), terms.cost_m);
        }
        let answer = match &self.answer {
            Some(answer) => {
                let cells = answer.cells();
                stats
                    .counters
                    .insert("answer_fitness".into(), self.score(cells));
                cells
            }
            None => &self.best.1,
        };
        Ok(RawPlan {
            waypoints: answer.iter().map(|c| c.center()).collect(),
            stats,
            pareto: Vec::new(),
            seed: self.seed,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::grid_from_rows;

    /// A genetic planner with the default parameters but `judge` (`Pulled` is the default).
    fn planner(variant: GaVariant, judge: GaJudge) -> GaPlanner {
        GaPlanner {
            variant,
            params: GaParams {
                judge,
                ..Default::default()
            },
            apf: crate::field::ApfParams::default(),
        }
    }

    /// IMGA with `mutation` and no local search on the answer (what the mutation alone does).
    fn imga_mutating_by(mutation: GaMutation) -> GaPlanner {
        GaPlanner {
            variant: GaVariant::Imga,
            params: GaParams {
                mutation,
                local_search: 0,
                ..Default::default()
            },
            apf: crate::field::ApfParams::default(),
        }
    }

    /// The local search on the answer shortens it: in the 0.05 m room, over 8 seeds, IMGA's
    /// answers with 3 reroutes of the answer per generation are shorter in all than without,
    /// and shorter on at least half of the seeds.
    #[test]
    fn the_local_search_shortens_the_answer() {
        use crate::test_support::{solve_seeded, split_room_fine};
        let (grid, q) = split_room_fine();
        let lengths = |local_search| -> Vec<f64> {
            let planner = GaPlanner {
                params: GaParams {
                    local_search,
                    ..Default::default()
                },
                ..imga_mutating_by(GaMutation::Reroute)
            };
            (1..=8)
                .map(|seed| {
                    let plan = solve_seeded(&planner, &grid, &q, seed).unwrap();
                    assert!(plan.metrics.collision_free);
                    plan.metrics.length_m
                })
                .collect()
        };
        let (without, with) = (lengths(0), lengths(3));
        let shorter = with
            .iter()
            .zip(&without)
            .filter(|&(w, o)| *w < *o - 1e-9)
            .count();
        assert!(
            with.iter().sum::<f64>() < without.iter().sum::<f64>() && shorter >= 4,
            "{without:?} -> {with:?}"
        );
    }

    /// In a hall of pillars, judged by the path it straightens into, the seeded IMGA returns an
    /// answer better than the field's path it starts from, whatever the seed; judged by fitness
    /// (the paper's answer, here with the seed) the fittest path is not (seed 5: the fitness
    /// weighs safety, so its path keeps off the pillars and is no shorter).
    #[test]
    fn the_pulled_judge_finds_a_better_answer_than_the_seed() {
        use crate::test_support::{hall, solve_seeded};
        let (grid, q) = hall(true);
        let improved = |judge, seed| {
            let plan = solve_seeded(&planner(GaVariant::Imga, judge), &grid, &q, seed).unwrap();
            assert!(plan.metrics.collision_free);
            plan.stats.counters["improved_on_seed"]
        };
        for seed in 1..=5 {
            assert_eq!(improved(GaJudge::Pulled, seed), 1.0, "seed {seed}");
        }
        assert_eq!(improved(GaJudge::Fitness, 5), 0.0);
    }

    /// At a real map's resolution ([`crate::test_support::split_room_fine`]) a one-cell move
    /// changes nothing the delete operation keeps: with the paper's mutation IMGA beats its
    /// seed on 3 of 8 seeds. With `reroute` (whole stretches rerouted, and the seed's reroutes
    /// filling the places random initial paths could not) it beats it on all 8.
    #[test]
    fn rerouting_beats_the_seed_where_one_cell_moves_do_not() {
        use crate::test_support::{runs_improved_on_seed, split_room_fine};
        let (grid, q) = split_room_fine();
        let improved =
            |mutation| runs_improved_on_seed(&imga_mutating_by(mutation), &grid, &q, 1..=8);
        assert_eq!(improved(GaMutation::Reroute), 8);
        assert!(improved(GaMutation::Neighbour) <= 4);
    }

    /// Across the hall split by a wall, median insertion from a random cell seldom gets round the
    /// wall: 291 of the 300 initial attempts are discarded. With `reroute` the places left are
    /// filled with rerouted copies of the seed, so every generation evaluates a full population;
    /// with the paper's mutation the population stays the few paths that could be completed.
    #[test]
    fn rerouted_seed_copies_fill_the_population() {
        use crate::test_support::{hall, solve_seeded};
        let (grid, q) = hall(false);
        let run = |mutation| {
            let plan = solve_seeded(&imga_mutating_by(mutation), &grid, &q, 1).unwrap();
            assert!(plan.metrics.collision_free);
            // The initial population counts as a generation.
            let per_generation = plan.stats.evaluations as f64 / (plan.stats.iterations + 1) as f64;
            let variants = plan.stats.counters.get("seed_variants").copied();
            (per_generation, variants)
        };
        let (full, variants) = run(GaMutation::Reroute);
        assert_eq!(full, 30.0);
        assert!(variants.is_some_and(|v| v >= 20.0), "{variants:?}");
        let (few, none) = run(GaMutation::Neighbour);
        assert!(few < 15.0, "{few}");
        assert_eq!(none, None);
    }

    /// The plain GA returns its cell path as it stands, so it keeps the fittest whatever the
    /// judge says: the same plan under both.
    #[test]
    fn the_plain_ga_is_judged_by_fitness() {
        use crate::test_support::{hall, solve_seeded};
        let (grid, q) = hall(true);
        let plan = |judge| solve_seeded(&planner(GaVariant::Ga, judge), &grid, &q, 5).unwrap();
        let (pulled, fitness) = (plan(GaJudge::Pulled), plan(GaJudge::Fitness));
        assert_eq!(pulled.waypoints, fitness.waypoints);
        assert!(!pulled.stats.counters.contains_key("answer_fitness"));
    }

    /// In an empty room the seed straightens into the segment to the goal: nothing improves on
    /// it, and `solve` says so (`seed_straight`), where among pillars it does not.
    #[test]
    fn a_straight_seed_is_counted_as_such() {
        use crate::planner::Query;
        use crate::test_support::{grid_with, hall, solve_seeded};
        let planner = planner(GaVariant::Imga, GaJudge::Pulled);
        let room = grid_with((40, 20), 1.0, 0.0, |_, _| false);
        let q = Query {
            start: Point2::new(2.5, 3.5),
            goal: Point2::new(36.5, 15.5),
            tolerance: 0.0,
        };
        let plan = solve_seeded(&planner, &room, &q, 1).unwrap();
        assert_eq!(plan.stats.counters["seed_straight"], 1.0);
        assert_eq!(plan.stats.counters["improved_on_seed"], 0.0);
        assert_eq!(plan.waypoints.len(), 2, "the answer is the segment too");
        let (pillars, q) = hall(true);
        let plan = solve_seeded(&planner, &pillars, &q, 1).unwrap();
        assert_eq!(plan.stats.counters["seed_straight"], 0.0);
    }

    #[test]
    fn quadrant_penalties_on_hand_made_turns() {
        assert_eq!(turn_penalty((1, 0), (1, 0)), 0.0); // straight on
        assert_eq!(turn_penalty((1, 0), (1, 1)), 1.0); // 45 deg: first quadrant
        assert_eq!(turn_penalty((1, 0), (1, -1)), 1.0);
        assert_eq!(turn_penalty((1, 0), (0, 1)), 3.0); // 90 deg: second or fourth quadrant
        assert_eq!(turn_penalty((1, 1), (-1, 1)), 3.0);
        assert_eq!(turn_penalty((0, 1), (1, 0)), 3.0);
        assert_eq!(turn_penalty((1, 0), (-1, 1)), 10.0); // 135 deg: third quadrant
        assert_eq!(turn_penalty((1, 0), (-1, 0)), 10.0); // U-turn
    }

    #[test]
    fn safety_term_on_a_hand_made_neighbourhood() {
        // One obstacle at (3, 2); of the path (1,1) .. (5,1), the nodes (2,1), (3,1), (4,1) are
        // next to it: 3 nodes x 5. (The path keeps off the map's edge, which counts as blocked.)
        let grid = grid_from_rows(&[".......", ".......", "...#...", ".......", "......."]);
        let path: Vec<Cell> = (1..6).map(|x| Cell::new(x, 1)).collect();
        let t = fitness_terms(&grid, &path, false);
        assert_eq!(t.safety, 15.0);
        assert_eq!(t.energy, 0.0);
        assert!((t.length_m - 4.0).abs() < 1e-12);
    }

    #[test]
    fn both_planners_find_valid_paths_deterministically() {
        use crate::planner::Query;
        use crate::test_support::solve_seeded;
        let grid = grid_from_rows(&[
            "..........",
            "...####...",
            "......#...",
            "......#...",
            "..........",
        ]);
        let q = Query {
            start: Cell::new(0, 0).center(),
            goal: Cell::new(9, 4).center(),
            tolerance: 0.0,
        };
        for variant in [GaVariant::Imga, GaVariant::Ga] {
            let planner = planner(variant, GaJudge::Pulled);
            let run = |seed| solve_seeded(&planner, &grid, &q, seed).unwrap();
            let plan = run(5);
            assert!(plan.metrics.collision_free, "{}", variant.name());
            assert_eq!(
                plan.waypoints,
                run(5).waypoints,
                "{}: same seed, same path",
                variant.name()
            );
        }
    }
}
