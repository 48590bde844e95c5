//! The visiting order: an asymmetric travelling-salesman path over a cost matrix, from a fixed
//! start (node 0) to anywhere, to a fixed end, or back to the start.
//!
//! - [`held_karp`]: exact dynamic programming over subsets (Held & Karp, 1962), `O(n^2 2^n)` time
//!   and `O(n 2^n)` memory; costs may be asymmetric. [`best_order`] uses it up to
//!   [`EXACT_LIMIT`] points.
//! - [`heuristic`]: a nearest-neighbour tour, then local search to a local optimum, then an
//!   iterated local search: `kicks` times a double-bridge kick (three cuts, the middle two
//!   segments swapped: no segment is reversed, so the kick suits asymmetric costs) followed by
//!   local search, keeping the best tour. The kicks draw from a [`PlannerRng`] seeded with
//!   `seed`, so the answer is deterministic. The local search alternates two neighbourhoods until
//!   neither improves:
//!   - 2-opt, reversal-aware: reversing positions `i..=j` reverses every leg inside the segment,
//!     which on asymmetric costs changes their cost too; prefix sums of the tour's legs taken
//!     forwards and backwards price each move in O(1) anyway;
//!   - Or-opt: a segment of 1 to 3 nodes moved elsewhere, kept as it is or reversed (a reversed
//!     segment's inner legs are priced backwards).
//!
//! Tours are sequences of node indices starting with node 0; a closed tour does not repeat it.

use crate::planner::PlannerRng;
use rand::{Rng, SeedableRng};
use serde::{Deserialize, Serialize};

/// Up to this many points (the start not counted) the order is exact.
pub const EXACT_LIMIT: usize = 12;
/// The most points [`held_karp`] accepts: its table has `n 2^n` entries.
pub const HELD_KARP_MAX: usize = 16;

/// Moves must gain more than this (the cost's unit, seconds here): rounding noise never makes the
/// local search cycle.
const EPS: f64 = 1e-9;

/// A dense square matrix of leg costs; `get(a, b)` is the cost of going from `a` to `b`.
#[derive(Clone, Debug, PartialEq)]
pub struct CostMatrix {
    n: usize,
    data: Vec<f64>,
}

impl CostMatrix {
    /// An `n x n` matrix of `cost(a, b)`.
    pub fn new(n: usize, mut cost: impl FnMut(usize, usize) -> f64) -> Self {
        let mut data = Vec::with_capacity(n * n);
        for a in 0..n {
            for b in 0..n {
                data.push(cost(a, b));
            }
        }
        Self { n, data }
    }

    pub fn len(&self) -> usize {
        self.n
    }

    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    #[inline]
    pub fn get(&self, a: usize, b: usize) -> f64 {
        self.data[a * self.n + b]
    }
}

/// Where a tour ends.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TourEnd {
    /// At whichever node is visited last (an open route).
    Anywhere,
    /// At this node (an open route to `home`); `At(0)` is the same as `Start`.
    At(usize),
    /// Back at node 0 (a closed loop).
    Start,
}

impl TourEnd {
    fn normalised(self) -> Self {
        match self {
            TourEnd::At(0) => TourEnd::Start,
            e => e,
        }
    }
}

/// A visiting order and its cost.
#[derive(Clone, Debug, PartialEq)]
pub struct Tour {
    /// Node indices, node 0 first; the fixed end node last; node 0 not repeated at the end of a
    /// closed tour.
    pub order: Vec<usize>,
    pub cost: f64,
}

/// How the order was found.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum OrderMethod {
    HeldKarp,
    Heuristic,
}

/// The heuristic's parameters.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct HeuristicParams {
    /// Double-bridge kicks of the iterated local search. Default 40.
    pub kicks: usize,
    /// Seed of the kicks. Default 0.
    pub seed: u64,
}

impl Default for HeuristicParams {
    fn default() -> Self {
        Self { kicks: 40, seed: 0 }
    }
}

/// The cost of a tour (legs between consecutive nodes, and back to node 0 for a closed one).
pub fn tour_cost(costs: &CostMatrix, order: &[usize], end: TourEnd) -> f64 {
    let legs: f64 = order.windows(2).map(|w| costs.get(w[0], w[1])).sum();
    match (end.normalised(), order.last()) {
        (TourEnd::Start, Some(&last)) => legs + costs.get(last, 0),
        _ => legs,
    }
}

/// Held-Karp when the points (nodes other than node 0) number at most `exact_limit` (capped at
/// [`HELD_KARP_MAX`]), else the heuristic.
pub fn best_order(
    costs: &CostMatrix,
    end: TourEnd,
    exact_limit: usize,
    params: &HeuristicParams,
) -> (Tour, OrderMethod) {
    if costs.len().saturating_sub(1) <= exact_limit.min(HELD_KARP_MAX) {
        (held_karp(costs, end), OrderMethod::HeldKarp)
    } else {
        (heuristic(costs, end, params), OrderMethod::Heuristic)
    }
}

/// The nodes a tour may order freely (all but node 0 and a fixed end), and that end.
fn free_nodes(n: usize, end: TourEnd) -> (Vec<usize>, Option<usize>) {
    let fixed = match end {
        TourEnd::At(e) => Some(e),
        _ => None,
    };
    ((1..n).filter(|&k| Some(k) != fixed).collect(), fixed)
}

/// The exact order. Panics on an empty matrix, an end outside it, or more than
/// [`HELD_KARP_MAX`] free nodes.
pub fn held_karp(costs: &CostMatrix, end: TourEnd) -> Tour {
    let n = costs.len();
    let end = end.normalised();
    assert!(n > 0, "a tour needs its start");
    if let TourEnd::At(e) = end {
        assert!(e < n, "end node {e} outside the {n} x {n} matrix");
    }
    let (free, fixed) = free_nodes(n, end);
    let m = free.len();
    assert!(m <= HELD_KARP_MAX, "{m} nodes is too many for Held-Karp");
    // The cost of finishing after `k`.
    let closing = |k: usize| match end {
        TourEnd::Anywhere => 0.0,
        TourEnd::Start => costs.get(k, 0),
        TourEnd::At(e) => costs.get(k, e),
    };
    let finish = |mut order: Vec<usize>, cost: f64| {
        order.extend(fixed);
        Tour { order, cost }
    };
    if m == 0 {
        return finish(vec![0], closing(0));
    }
    // dp[mask * m + k]: the cheapest walk from node 0 through the free nodes in `mask`, ending at
    // free[k]; pred: the index of the free node before it (m for node 0).
    let full = (1usize << m) - 1;
    let mut dp = vec![f64::INFINITY; (full + 1) * m];
    let mut pred = vec![u8::MAX; (full + 1) * m];
    for (k, &node) in free.iter().enumerate() {
        dp[(1 << k) * m + k] = costs.get(0, node);
        pred[(1 << k) * m + k] = m as u8;
    }
    for mask in 1..=full {
        for k in 0..m {
            let d = dp[mask * m + k];
            if mask & (1 << k) == 0 || d == f64::INFINITY {
                continue;
            }
            for next in 0..m {
                if mask & (1 << next) != 0 {
                    continue;
                }
                let slot = (mask | 1 << next) * m + next;
                let v = d + costs.get(free[k], free[next]);
                if v < dp[slot] {
                    dp[slot] = v;
                    pred[slot] = k as u8;
                }
            }
        }
    }
    let (mut k, mut best) = (0, f64::INFINITY);
    for j in 0..m {
        let v = dp[full * m + j] + closing(free[j]);
        if v < best {
            (k, best) = (j, v);
        }
    }
    let mut order = Vec::with_capacity(n);
    let mut mask = full;
    while k != m {
        order.push(free[k]);
        let p = pred[mask * m + k] as usize;
        mask &= !(1 << k);
        k = p;
    }
    order.push(0);
    order.reverse();
    finish(order, best)
}

/// A good order for any size: see the module doc. Panics on an empty matrix or an end outside it.
pub fn heuristic(costs: &CostMatrix, end: TourEnd, params: &HeuristicParams) -> Tour {
    let n = costs.len();
    let end = end.normalised();
    assert!(n > 0, "a tour needs its start");
    if let TourEnd::At(e) = end {
        assert!(e < n, "end node {e} outside the {n} x {n} matrix");
    }
    let (free, fixed) = free_nodes(n, end);
    let search = LocalSearch {
        costs,
        end,
        sentinel: n,
    };
    let mut seq = Vec::with_capacity(free.len() + 2);
    seq.push(0);
    seq.extend(nearest_neighbour(costs, &free));
    seq.push(search.sentinel);
    search.descend(&mut seq);
    let mut best_cost = search.cost(&seq);
    let interior = seq.len() - 2;
    if interior >= 4 {
        let mut rng = PlannerRng::seed_from_u64(params.seed);
        for _ in 0..params.kicks {
            let mut candidate = seq.clone();
            double_bridge(&mut candidate[1..=interior], &mut rng);
            search.descend(&mut candidate);
            let c = search.cost(&candidate);
            if c < best_cost - EPS {
                (seq, best_cost) = (candidate, c);
            }
        }
    }
    seq.pop();
    seq.extend(fixed);
    Tour {
        cost: tour_cost(costs, &seq, end),
        order: seq,
    }
}

/// From node 0, always to the cheapest unvisited node (the first on ties).
fn nearest_neighbour(costs: &CostMatrix, free: &[usize]) -> Vec<usize> {
    let mut left = free.to_vec();
    let mut order = Vec::with_capacity(free.len());
    let mut at = 0;
    while !left.is_empty() {
        let k = (0..left.len())
            .min_by(|&a, &b| costs.get(at, left[a]).total_cmp(&costs.get(at, left[b])))
            .expect("not empty");
        at = left.remove(k);
        order.push(at);
    }
    order
}

/// Cuts a sequence into A B C D at three random points and makes it A C B D.
fn double_bridge(seq: &mut [usize], rng: &mut PlannerRng) {
    let len = seq.len();
    let mut cuts = [0usize; 3];
    loop {
        for c in &mut cuts {
            *c = rng.random_range(1..len);
        }
        cuts.sort_unstable();
        if cuts[0] < cuts[1] && cuts[1] < cuts[2] {
            break;
        }
    }
    let [p, q, r] = cuts;
    // A [0, p) B [p, q) C [q, r) D [r, len): rotating B C left by |B| gives C B.
    seq[p..r].rotate_left(q - p);
}

/// Local search on sequences `[0, free nodes..., sentinel]`: the sentinel stands for the end
/// (nothing, node 0, or the fixed end node), so every neighbourhood only moves interior nodes.
struct LocalSearch<'a> {
    costs: &'a CostMatrix,
    end: TourEnd,
    sentinel: usize,
}

impl LocalSearch<'_> {
    #[inline]
    fn c(&self, a: usize, b: usize) -> f64 {
        if b == self.sentinel {
            match self.end {
                TourEnd::Anywhere => 0.0,
                TourEnd::Start => self.costs.get(a, 0),
                TourEnd::At(e) => self.costs.get(a, e),
            }
        } else if a == self.sentinel {
            // Never priced: no move reverses the leg into the sentinel.
            0.0
        } else {
            self.costs.get(a, b)
        }
    }

    fn cost(&self, seq: &[usize]) -> f64 {
        seq.windows(2).map(|w| self.c(w[0], w[1])).sum()
    }

    /// Applies improving moves until none is left.
    fn descend(&self, seq: &mut Vec<usize>) {
        let (mut fwd, mut back) = (Vec::new(), Vec::new());
        loop {
            let reversed = self.two_opt(seq, &mut fwd, &mut back);
            let moved = self.or_opt(seq);
            if !reversed && !moved {
                return;
            }
        }
    }

    /// `fwd[k]`: the cost of the first `k` legs; `back[k]`: the same legs driven backwards.
    fn prefix_sums(&self, seq: &[usize], fwd: &mut Vec<f64>, back: &mut Vec<f64>) {
        fwd.clear();
        back.clear();
        let (mut f, mut b) = (0.0, 0.0);
        fwd.push(f);
        back.push(b);
        for w in seq.windows(2) {
            f += self.c(w[0], w[1]);
            b += self.c(w[1], w[0]);
            fwd.push(f);
            back.push(b);
        }
    }

    /// One pass of reversal-aware 2-opt over interior segments `i..=j`; whether anything changed.
    fn two_opt(&self, seq: &mut [usize], fwd: &mut Vec<f64>, back: &mut Vec<f64>) -> bool {
        let l = seq.len();
        let mut improved = false;
        self.prefix_sums(seq, fwd, back);
        for i in 1..l.saturating_sub(2) {
            for j in i + 1..=l - 2 {
                let (a, b) = (seq[i - 1], seq[j + 1]);
                let old = self.c(a, seq[i]) + (fwd[j] - fwd[i]) + self.c(seq[j], b);
                let new = self.c(a, seq[j]) + (back[j] - back[i]) + self.c(seq[i], b);
                if new < old - EPS {
                    seq[i..=j].reverse();
                    self.prefix_sums(seq, fwd, back);
                    improved = true;
                }
            }
        }
        improved
    }

    /// One pass of Or-opt: segments of 1 to 3 interior nodes moved between two other nodes, kept
    /// or reversed; whether anything changed.
    fn or_opt(&self, seq: &mut Vec<usize>) -> bool {
        let mut improved = false;
        for k in 1..=3 {
            let mut i = 1;
            // The segment seq[i..i + k] must leave the sentinel where it is.
            while i + k < seq.len() {
                if let Some((p, reverse)) = self.best_insertion(seq, i, k) {
                    let mut segment: Vec<usize> = seq.drain(i..i + k).collect();
                    if reverse {
                        segment.reverse();
                    }
                    let at = if p < i { p + 1 } else { p + 1 - k };
                    seq.splice(at..at, segment);
                    improved = true;
                } else {
                    i += 1;
                }
            }
        }
        improved
    }

    /// The first place to move `seq[i..i + k]` to that gains: insert it after position `p`
    /// (forwards, or reversed when the flag says so).
    fn best_insertion(&self, seq: &[usize], i: usize, k: usize) -> Option<(usize, bool)> {
        let (a, b) = (seq[i - 1], seq[i + k]);
        let (first, last) = (seq[i], seq[i + k - 1]);
        let gain = self.c(a, first) + self.c(last, b) - self.c(a, b);
        let inner: f64 = seq[i..i + k].windows(2).map(|w| self.c(w[0], w[1])).sum();
        let inner_back: f64 = seq[i..i + k].windows(2).map(|w| self.c(w[1], w[0])).sum();
        for p in 0..seq.len() - 1 {
            if p + 1 >= i && p < i + k {
                continue;
            }
            let (x, y) = (seq[p], seq[p + 1]);
            let base = self.c(x, y);
            if self.c(x, first) + self.c(last, y) - base < gain - EPS {
                return Some((p, false));
            }
            if k > 1 && self.c(x, last) + inner_back - inner + self.c(first, y) - base < gain - EPS
            {
                return Some((p, true));
            }
        }
        None
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::geometry::Point2;
    use crate::route::model::{DrivingModel, PathShape};
    use crate::test_support::rng;

    /// Every order of the free nodes, tried.
    fn brute_force(costs: &CostMatrix, end: TourEnd) -> f64 {
        let (mut free, fixed) = free_nodes(costs.len(), end.normalised());
        let mut best = f64::INFINITY;
        permute(&mut free, 0, &mut |perm| {
            let mut order = vec![0];
            order.extend_from_slice(perm);
            order.extend(fixed);
            best = best.min(tour_cost(costs, &order, end));
        });
        best
    }

    fn permute(v: &mut [usize], k: usize, visit: &mut dyn FnMut(&[usize])) {
        if k == v.len() {
            visit(v);
            return;
        }
        for i in k..v.len() {
            v.swap(k, i);
            permute(v, k + 1, visit);
            v.swap(k, i);
        }
    }

    /// Random points in a 20 m x 20 m room with random yaws, straight legs, the default driving
    /// model: the asymmetric costs of a real route.
    pub(crate) fn geometric(seed: u64, n: usize) -> CostMatrix {
        let mut r = rng(seed);
        let poses: Vec<(Point2, f64)> = (0..n)
            .map(|_| {
                let p = Point2::new(r.random_range(0.0..20.0), r.random_range(0.0..20.0));
                (
                    p,
                    r.random_range(-std::f64::consts::PI..std::f64::consts::PI),
                )
            })
            .collect();
        let model = DrivingModel::default();
        CostMatrix::new(n, |a, b| {
            let shape = PathShape::of(&[poses[a].0, poses[b].0]);
            model.cost(&shape, poses[a].1, poses[b].1).time_s
        })
    }

    fn uniform(seed: u64, n: usize) -> CostMatrix {
        let mut r = rng(seed);
        CostMatrix::new(n, |a, b| {
            if a == b {
                0.0
            } else {
                r.random_range(1.0..100.0)
            }
        })
    }

    fn ends(n: usize, seed: u64) -> [TourEnd; 3] {
        [
            TourEnd::Anywhere,
            TourEnd::Start,
            TourEnd::At((seed as usize % n.max(2)).min(n - 1)),
        ]
    }

    fn valid(t: &Tour, n: usize, end: TourEnd) {
        let mut sorted = t.order.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..n).collect::<Vec<_>>(), "{:?}", t.order);
        assert_eq!(t.order[0], 0);
        if let TourEnd::At(e) = end.normalised() {
            assert_eq!(*t.order.last().unwrap(), e);
        }
    }

    #[test]
    fn held_karp_equals_brute_force_up_to_8_points() {
        for seed in 0..60u64 {
            for n in 1..=9 {
                for costs in [geometric(seed, n), uniform(seed, n)] {
                    for end in ends(n, seed) {
                        let t = held_karp(&costs, end);
                        valid(&t, n, end);
                        let exact = brute_force(&costs, end);
                        assert!(
                            (t.cost - exact).abs() < 1e-9,
                            "{n} {end:?}: {} vs {exact}",
                            t.cost
                        );
                        assert!((tour_cost(&costs, &t.order, end) - t.cost).abs() < 1e-9);
                    }
                }
            }
        }
    }

    #[test]
    fn held_karp_knows_direction() {
        // 0 -> 1 -> 2 is cheap, 0 -> 2 -> 1 dear: the asymmetric costs decide.
        let c = [[0.0, 1.0, 9.0], [9.0, 0.0, 1.0], [1.0, 9.0, 0.0]];
        let costs = CostMatrix::new(3, |a, b| c[a][b]);
        assert_eq!(held_karp(&costs, TourEnd::Start).order, vec![0, 1, 2]);
        assert_eq!(held_karp(&costs, TourEnd::Start).cost, 3.0);
        assert_eq!(held_karp(&costs, TourEnd::At(1)).order, vec![0, 2, 1]);
        assert_eq!(
            held_karp(&costs, TourEnd::At(0)).cost,
            3.0,
            "home at the start: a loop"
        );
        assert_eq!(
            heuristic(&costs, TourEnd::At(1), &HeuristicParams::default()).cost,
            18.0
        );
    }

    /// The heuristic on 200 random instances of 10 to 12 points, against Held-Karp.
    /// `cargo test -p planner-core route::order -- --nocapture` prints the gaps.
    #[test]
    fn heuristic_within_two_percent_of_held_karp() {
        let mut gaps = Vec::new();
        for seed in 0..200u64 {
            let n = 11 + (seed % 3) as usize;
            let costs = geometric(1000 + seed, n);
            let end = ends(n, seed)[(seed % 3) as usize];
            let exact = held_karp(&costs, end);
            let h = heuristic(&costs, end, &HeuristicParams::default());
            valid(&h, n, end);
            assert!((tour_cost(&costs, &h.order, end) - h.cost).abs() < 1e-9);
            gaps.push(h.cost / exact.cost - 1.0);
        }
        let mean = gaps.iter().sum::<f64>() / gaps.len() as f64;
        let worst = gaps.iter().copied().fold(0.0, f64::max);
        let optimal = gaps.iter().filter(|&&g| g < 1e-9).count();
        eprintln!(
            "heuristic vs Held-Karp on {} instances of 10-12 points: mean gap {:.4} %, worst {:.4} %, optimal {}",
            gaps.len(),
            100.0 * mean,
            100.0 * worst,
            optimal
        );
        assert!(gaps.iter().all(|&g| g > -1e-9), "never better than exact");
        assert!(mean <= 0.005, "mean gap {mean}");
        assert!(worst <= 0.02, "worst gap {worst}");
    }

    #[test]
    fn heuristic_is_deterministic_and_handles_tiny_tours() {
        let costs = geometric(5, 60);
        let p = HeuristicParams::default();
        assert_eq!(
            heuristic(&costs, TourEnd::Start, &p),
            heuristic(&costs, TourEnd::Start, &p)
        );
        for n in 1..=5 {
            let costs = geometric(n as u64, n);
            for end in ends(n, 1) {
                let t = heuristic(&costs, end, &p);
                valid(&t, n, end);
                assert!(
                    (t.cost - held_karp(&costs, end).cost).abs() < 1e-9,
                    "{n} {end:?}"
                );
            }
        }
    }

    #[test]
    fn the_local_search_never_leaves_a_2opt_or_oropt_move() {
        let costs = uniform(9, 40);
        for end in [TourEnd::Anywhere, TourEnd::Start, TourEnd::At(7)] {
            let t = heuristic(&costs, end, &HeuristicParams { kicks: 0, seed: 0 });
            let search = LocalSearch {
                costs: &costs,
                end,
                sentinel: 40,
            };
            let mut seq: Vec<usize> = t
                .order
                .iter()
                .copied()
                .filter(|&k| TourEnd::At(k) != end)
                .collect();
            seq.push(40);
            let before = search.cost(&seq);
            assert!(!search.two_opt(&mut seq.clone(), &mut Vec::new(), &mut Vec::new()));
            assert!(!search.or_opt(&mut seq.clone()));
            assert!((before - t.cost).abs() < 1e-9);
            // The same, asked without the search's own pricing: every reversal and every move
            // of one to three nodes (kept or reversed), priced by `tour_cost` on the plain
            // order, costs at least the tour's.
            let (lo, hi) = match end {
                TourEnd::At(_) => (1, t.order.len() - 1),
                _ => (1, t.order.len()),
            };
            let priced = |order: &[usize]| tour_cost(&costs, order, end);
            assert!((priced(&t.order) - t.cost).abs() < 1e-9);
            for i in lo..hi {
                for j in i + 1..hi {
                    let mut o = t.order.clone();
                    o[i..=j].reverse();
                    assert!(priced(&o) >= t.cost - 1e-9, "{end:?}: reversing {i}..={j}");
                }
                for len in 1..=3 {
                    if i + len > hi {
                        break;
                    }
                    for reversed in [false, true] {
                        let mut rest = t.order.clone();
                        let mut segment: Vec<usize> = rest.drain(i..i + len).collect();
                        if reversed {
                            segment.reverse();
                        }
                        for at in lo..=hi - len {
                            let mut o = rest.clone();
                            o.splice(at..at, segment.iter().copied());
                            assert!(
                                priced(&o) >= t.cost - 1e-9,
                                "{end:?}: moving {i}+{len} to {at}, reversed {reversed}"
                            );
                        }
                    }
                }
            }
        }
    }
}
