//! The colonies' pheromone, kept per cell and brought up to date only when a cell is read.
//!
//! Every global update of eq. 20-22 (and the ant system's evaporation) touches every cell of the
//! map, while the ants read a thin band of it: on Nav2's 2000 x 2000 benchmark map the full
//! passes were most of `eapf_iaco`'s time (issue 12: 30 x A*'s). Here a cell records how many
//! global updates it has seen; reading it replays the ones it missed, in the same order and with
//! the same floating-point operations as the full passes did, so every value is bit for bit what
//! the eager version computed (the regression recording checks it). The tables start as untouched
//! zero pages: a plan pays for the cells its ants reach, not for the map.

use crate::geometry::Cell;
use crate::grid::{MapInfo, PlanningGrid};

/// How a global update treats a cell that no ant deposits on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Evaporation {
    /// Eq. 20-22 (`eapf_iaco`): `tau *= 1 - rho`, then, on cells of positive initial pheromone,
    /// `tau = max(tau * coefficient, floor)`, the coefficient of eq. 22 for that iteration.
    Adjusted,
    /// The ant system (`aco`, `aco_apf`): `tau = max(tau * (1 - rho), floor)`.
    Plain,
}

/// The pheromone of every cell, evaporated lazily.
pub struct Pheromone<'a> {
    info: MapInfo,
    /// The initial pheromone of a cell (eq. 17-18 or uniform; 0 on blocked cells).
    initial: Box<dyn Fn(Cell) -> f64 + 'a>,
    rule: Evaporation,
    rho: f64,
    floor: f64,
    tau: Vec<f64>,
    /// `seen[i]`: 0 while cell `i` still holds its initial pheromone implicitly, else one more
    /// than the number of global updates applied to `tau[i]`.
    seen: Vec<u32>,
    /// Eq. 22's coefficient of each global update so far (1 for [`Evaporation::Plain`]).
    coefficients: Vec<f64>,
    /// Cells deposited on in the global update under way.
    touched: Vec<usize>,
}

impl<'a> Pheromone<'a> {
    pub fn new(
        grid: &'a PlanningGrid,
        initial: impl Fn(Cell) -> f64 + 'a,
        rule: Evaporation,
        rho: f64,
        floor: f64,
    ) -> Self {
        let n = grid.info().cell_count();
        Self {
            info: *grid.info(),
            initial: Box::new(initial),
            rule,
            rho,
            floor,
            tau: vec![0.0; n],
            seen: vec![0; n],
            coefficients: Vec::new(),
            touched: Vec::new(),
        }
    }

    /// The initial pheromone of cell index `i`.
    pub fn initial(&self, i: usize) -> f64 {
        (self.initial)(self.info.cell_at(i))
    }

    /// Applies the global updates cell `i` has missed, up to the first `upto`.
    fn catch_up(&mut self, i: usize, upto: usize) {
        if self.seen[i] == 0 {
            self.tau[i] = self.initial(i);
            self.seen[i] = 1;
        }
        let done = self.seen[i] as usize - 1;
        if done >= upto {
            return;
        }
        let mut v = self.tau[i];
        match self.rule {
            Evaporation::Adjusted => {
                let positive = self.initial(i) > 0.0;
                for &coeff in &self.coefficients[done..upto] {
                    v *= 1.0 - self.rho;
                    if positive {
                        v = (v * coeff).max(self.floor);
                    }
                }
            }
            Evaporation::Plain => {
                for _ in done..upto {
                    v = (v * (1.0 - self.rho)).max(self.floor);
                }
            }
        }
        self.tau[i] = v;
        self.seen[i] = upto as u32 + 1;
    }

    /// The floor pheromone never falls below, so that eq. 13 stays defined.
    pub fn floor(&self) -> f64 {
        self.floor
    }

    /// The pheromone of cell index `i` now.
    pub fn get(&mut self, i: usize) -> f64 {
        self.catch_up(i, self.coefficients.len());
        self.tau[i]
    }

    /// Eq. 19, the local update of a cell an ant moves into: `tau = max((1 - rho) tau + omega
    /// tau_0, floor)`.
    pub fn local_update(&mut self, i: usize, omega: f64) {
        let t0 = self.initial(i);
        let v = self.get(i);
        self.tau[i] = ((1.0 - self.rho) * v + omega * t0).max(self.floor);
    }

    /// One global update: evaporation everywhere, then `deposits` (cell index, amount) in their
    /// order, then (for [`Evaporation::Adjusted`]) eq. 22's `coefficient`. Only the deposited
    /// cells are written now; every other cell replays this update when it is next read.
    pub fn global_update(
        &mut self,
        deposits: impl IntoIterator<Item = (usize, f64)>,
        coefficient: f64,
    ) {
        let k = self.coefficients.len();
        self.touched.clear();
        for (i, amount) in deposits {
            if self.seen[i] as usize != k + 2 {
                // First deposit on this cell in this update: catch up, then evaporate.
                self.catch_up(i, k);
                self.tau[i] = match self.rule {
                    Evaporation::Adjusted => self.tau[i] * (1.0 - self.rho),
                    Evaporation::Plain => (self.tau[i] * (1.0 - self.rho)).max(self.floor),
                };
                self.seen[i] = k as u32 + 2;
                self.touched.push(i);
            }
            self.tau[i] += amount;
        }
        if self.rule == Evaporation::Adjusted {
            for j in 0..self.touched.len() {
                let i = self.touched[j];
                if self.initial(i) > 0.0 {
                    self.tau[i] = (self.tau[i] * coefficient).max(self.floor);
                }
            }
        }
        self.coefficients.push(match self.rule {
            Evaporation::Adjusted => coefficient,
            Evaporation::Plain => 1.0,
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::grid_from_rows;

    /// The eager passes the lazy table replaces, written out as the colony used to run them.
    fn eager(
        tau: &mut [f64],
        tau0: &[f64],
        rule: Evaporation,
        rho: f64,
        floor: f64,
        deposits: &[(usize, f64)],
        coeff: f64,
    ) {
        match rule {
            Evaporation::Adjusted => {
                for v in tau.iter_mut() {
                    *v *= 1.0 - rho;
                }
                for &(i, a) in deposits {
                    tau[i] += a;
                }
                for (v, &t0) in tau.iter_mut().zip(tau0) {
                    if t0 > 0.0 {
                        *v = (*v * coeff).max(floor);
                    }
                }
            }
            Evaporation::Plain => {
                for v in tau.iter_mut() {
                    *v = (*v * (1.0 - rho)).max(floor);
                }
                for &(i, a) in deposits {
                    tau[i] += a;
                }
            }
        }
    }

    /// Reads, local updates and global updates (repeated cells included) in a random order give
    /// the eager passes' values bit for bit, under both rules.
    #[test]
    fn lazy_replay_equals_the_full_passes_bit_for_bit() {
        use rand::{Rng, SeedableRng};
        let grid = grid_from_rows(&["....#...", "..#.....", "........", ".....#.."]);
        let n = grid.info().cell_count();
        let init = |c: Cell| {
            if grid.is_free(c) {
                0.5 + 0.1 * c.x as f64
            } else {
                0.0
            }
        };
        for rule in [Evaporation::Adjusted, Evaporation::Plain] {
            let mut rng = crate::planner::PlannerRng::seed_from_u64(9);
            let (rho, floor, omega) = (0.6, 1e-4, 0.1);
            let tau0: Vec<f64> = (0..n).map(|i| init(grid.info().cell_at(i))).collect();
            let mut want = tau0.clone();
            let mut lazy = Pheromone::new(&grid, init, rule, rho, floor);
            for t in 0..40 {
                for _ in 0..rng.random_range(0..6) {
                    let i = rng.random_range(0..n);
                    want[i] = ((1.0 - rho) * want[i] + omega * tau0[i]).max(floor);
                    lazy.local_update(i, omega);
                }
                let deposits: Vec<(usize, f64)> = (0..rng.random_range(0..5))
                    .map(|_| (rng.random_range(0..n), rng.random::<f64>()))
                    .collect();
                let coeff = 1.0 - ((t as f64 - 40.0) / 40.0).exp();
                eager(&mut want, &tau0, rule, rho, floor, &deposits, coeff);
                lazy.global_update(deposits.iter().copied(), coeff);
                if t % 7 == 0 {
                    let i = rng.random_range(0..n);
                    assert_eq!(lazy.get(i).to_bits(), want[i].to_bits(), "{rule:?} t {t}");
                }
            }
            for (i, w) in want.iter().enumerate() {
                assert_eq!(lazy.get(i).to_bits(), w.to_bits(), "{rule:?} cell {i}");
            }
        }
    }
}
