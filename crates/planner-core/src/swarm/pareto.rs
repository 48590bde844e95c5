//! Objectives and Pareto machinery of the multi-objective swarms.
//!
//! Objectives (patrol car paper eq. 18): f1 the path length (m), f2 the total turning angle (rad,
//! eq. 17), and (when its weight is not 0) f3 the safety cost: the costmap cost integrated along
//! the path (`raycast::blocked_and_cost_length`, metres at cost 252), which grows as clearance
//! falls; the
//! paper's first future work ("an anti-collision safety objective"). Infeasible candidates are
//! dominated by every feasible one (constraint domination) and ordered among themselves by how
//! much of their length lies in obstacles (`docs/papers.md`). The archive keeps at most
//! `capacity` non-dominated feasible solutions, pruning the most crowded (NSGA-II crowding
//! distance over the active objectives). The final choice is eq. 19–21 generalised to three
//! objectives: each normalised by its sum over the archive, then the smallest weighted sum
//! ([`Weights`]). With the safety weight 0, f3 is never computed (it stays 0) and every step is
//! the paper's two-objective one, number for number.

/// What a candidate scores.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Eval {
    /// Path length (m).
    pub f1: f64,
    /// Total turning angle (rad).
    pub f2: f64,
    /// Safety cost (m at cost 252; 0 when safety is off).
    pub f3: f64,
    /// Length (m) of the path inside blocked cells; 0 means feasible.
    pub violation: f64,
}

impl Eval {
    pub fn feasible(&self) -> bool {
        self.violation == 0.0
    }

    pub fn objectives(&self) -> [f64; 3] {
        [self.f1, self.f2, self.f3]
    }
}

/// The weights of eq. 21 over (length, turning, safety): `length * (1 - safety)`,
/// `(1 - length) * (1 - safety)` and `safety`, so that safety 0 is the paper's
/// `w L/sum L + (1 - w) Omega/sum Omega` exactly and the three always sum to 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Weights {
    pub length: f64,
    pub safety: f64,
}

impl Weights {
    pub fn vector(&self) -> [f64; 3] {
        let rest = 1.0 - self.safety;
        [self.length * rest, (1.0 - self.length) * rest, self.safety]
    }

    /// How many objectives are active: 3 with a safety weight, else the paper's 2.
    pub fn objectives(&self) -> usize {
        if self.safety > 0.0 {
            3
        } else {
            2
        }
    }

    /// `sum_k w_k v_k / scale_k`, a term with weight 0 left out (so it cannot bring a NaN in).
    pub fn scalarise(&self, v: [f64; 3], scale: [f64; 3]) -> f64 {
        let w = self.vector();
        let nor = |k: usize| if scale[k] > 0.0 { v[k] / scale[k] } else { 0.0 };
        let mut total = w[0] * nor(0) + w[1] * nor(1);
        if w[2] > 0.0 {
            total += w[2] * nor(2);
        }
        total
    }
}

/// Constraint domination: feasible beats infeasible, less violation beats more, and between
/// feasible candidates ordinary Pareto dominance on (f1, f2, f3) (f3 is 0 for all when safety
/// is off, which leaves the paper's two-objective dominance).
pub fn dominates(a: &Eval, b: &Eval) -> bool {
    match (a.feasible(), b.feasible()) {
        (true, false) => true,
        (false, true) => false,
        (false, false) => a.violation < b.violation,
        (true, true) => {
            a.f1 <= b.f1
                && a.f2 <= b.f2
                && a.f3 <= b.f3
                && (a.f1 < b.f1 || a.f2 < b.f2 || a.f3 < b.f3)
        }
    }
}

/// NSGA-II crowding distance of each point of a front over its first `objectives` values
/// (boundary points get infinity).
pub fn crowding_distances(points: &[[f64; 3]], objectives: usize) -> Vec<f64> {
    let n = points.len();
    let mut dist = vec![0.0; n];
    if n <= 2 {
        return vec![f64::INFINITY; n];
    }
    // `objective` picks a column of every point, not one point: a range is the plain way.
    #[allow(clippy::needless_range_loop)]
    for objective in 0..objectives {
        let value = |k: usize| points[k][objective];
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|&a, &b| value(a).total_cmp(&value(b)).then(a.cmp(&b)));
        let span = value(order[n - 1]) - value(order[0]);
        dist[order[0]] = f64::INFINITY;
        dist[order[n - 1]] = f64::INFINITY;
        if span > 0.0 {
            for w in 1..n - 1 {
                dist[order[w]] += (value(order[w + 1]) - value(order[w - 1])) / span;
            }
        }
    }
    dist
}

/// Eq. 19–21: index of the member with the smallest `sum_k w_k f_k / sum f_k` (with safety 0:
/// `w * L / sum L + (1 - w) * Omega / sum Omega`).
pub fn weighted_choice(front: &[[f64; 3]], weights: Weights) -> Option<usize> {
    let mut sums = [0.0; 3];
    for p in front {
        for k in 0..3 {
            sums[k] += p[k];
        }
    }
    (0..front.len()).min_by(|&a, &b| {
        let f = |k: usize| weights.scalarise(front[k], sums);
        f(a).total_cmp(&f(b)).then(a.cmp(&b))
    })
}

/// The hypervolume (area) that a front of (f1, f2) points dominates below `reference`: the
/// front-quality measure of the bench (issue 12), computed on length and turning only. Points
/// not strictly below the reference in both add nothing; dominated points add nothing either.
pub fn hypervolume_2d(points: &[(f64, f64)], reference: (f64, f64)) -> f64 {
    let mut inside: Vec<(f64, f64)> = points
        .iter()
        .copied()
        .filter(|&(a, b)| a < reference.0 && b < reference.1)
        .collect();
    inside.sort_by(|p, q| p.0.total_cmp(&q.0).then(p.1.total_cmp(&q.1)));
    // The staircase: by f1 ascending, each kept point strictly lower in f2 than the last.
    let mut stairs: Vec<(f64, f64)> = Vec::with_capacity(inside.len());
    for p in inside {
        if stairs.last().is_none_or(|last| p.1 < last.1) {
            stairs.push(p);
        }
    }
    (0..stairs.len())
        .map(|k| {
            let next = stairs.get(k + 1).map_or(reference.0, |q| q.0);
            (next - stairs[k].0) * (reference.1 - stairs[k].1)
        })
        .sum()
}

/// The external archive: non-dominated feasible solutions.
#[derive(Clone, Debug)]
pub struct Archive {
    pub capacity: usize,
    /// How many objectives crowding measures (2, or 3 with safety).
    pub objectives: usize,
    pub members: Vec<(Vec<f64>, Eval)>,
}

impl Archive {
    pub fn new(capacity: usize, objectives: usize) -> Self {
        Self {
            capacity,
            objectives,
            members: Vec::new(),
        }
    }

    /// Offers a candidate; returns whether it entered. Infeasible candidates never enter.
    pub fn offer(&mut self, x: &[f64], e: Eval) -> bool {
        if !e.feasible() {
            return false;
        }
        if self
            .members
            .iter()
            .any(|(_, m)| dominates(m, &e) || m.objectives() == e.objectives())
        {
            return false;
        }
        self.members.retain(|(_, m)| !dominates(&e, m));
        self.members.push((x.to_vec(), e));
        if self.members.len() > self.capacity {
            let d = crowding_distances(&self.objectives(), self.objectives);
            let most_crowded = (0..d.len())
                .min_by(|&a, &b| d[a].total_cmp(&d[b]).then(a.cmp(&b)))
                .expect("non-empty");
            self.members.swap_remove(most_crowded);
        }
        true
    }

    pub fn objectives(&self) -> Vec<[f64; 3]> {
        self.members.iter().map(|(_, e)| e.objectives()).collect()
    }

    /// The eq. 19–21 choice.
    pub fn choose(&self, weights: Weights) -> Option<&(Vec<f64>, Eval)> {
        weighted_choice(&self.objectives(), weights).map(|k| &self.members[k])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn e(f1: f64, f2: f64) -> Eval {
        e3(f1, f2, 0.0)
    }

    fn e3(f1: f64, f2: f64, f3: f64) -> Eval {
        Eval {
            f1,
            f2,
            f3,
            violation: 0.0,
        }
    }

    const PAPER: Weights = Weights {
        length: 0.5,
        safety: 0.0,
    };

    #[test]
    fn dominance_on_hand_made_points() {
        assert!(dominates(&e(1.0, 1.0), &e(2.0, 2.0)));
        assert!(dominates(&e(1.0, 2.0), &e(1.0, 3.0)));
        assert!(!dominates(&e(1.0, 2.0), &e(2.0, 1.0)));
        assert!(!dominates(&e(1.0, 1.0), &e(1.0, 1.0)));
        let bad = Eval {
            violation: 2.0,
            ..e(0.1, 0.0)
        };
        let worse = Eval {
            violation: 3.0,
            ..e(0.1, 0.0)
        };
        assert!(dominates(&e(100.0, 100.0), &bad));
        assert!(!dominates(&bad, &e(100.0, 100.0)));
        assert!(dominates(&bad, &worse));
        // The third objective: equal length and turning, the safer one dominates; a shorter but
        // less safe one does not.
        assert!(dominates(&e3(1.0, 1.0, 0.5), &e3(1.0, 1.0, 0.9)));
        assert!(!dominates(&e3(0.9, 1.0, 0.9), &e3(1.0, 1.0, 0.5)));
        assert!(!dominates(&e3(1.0, 1.0, 0.5), &e3(0.9, 1.0, 0.9)));
    }

    #[test]
    fn crowding_on_a_hand_made_front() {
        // Front (1,5) (2,3) (4,2) (5,1): spans 4 and 4.
        let front = [
            [1.0, 5.0, 9.0],
            [2.0, 3.0, 1.0],
            [4.0, 2.0, 0.0],
            [5.0, 1.0, 5.0],
        ];
        let d = crowding_distances(&front, 2);
        assert!(d[0].is_infinite() && d[3].is_infinite());
        // (2,3): (4-1)/4 + (5-2)/4 = 1.5; (4,2): (5-2)/4 + (3-1)/4 = 1.25. The third values are
        // not read with two objectives.
        assert!((d[1] - 1.5).abs() < 1e-12 && (d[2] - 1.25).abs() < 1e-12);
        // With three, (4,2,0) is the f3 boundary (infinite) and (2,3,1) gains (5-0)/9.
        let d = crowding_distances(&front, 3);
        assert!(d[2].is_infinite());
        assert!((d[1] - (1.5 + 5.0 / 9.0)).abs() < 1e-12);
    }

    #[test]
    fn archive_keeps_the_front_and_prunes_the_most_crowded() {
        let mut a = Archive::new(3, 2);
        assert!(a.offer(&[0.0], e(1.0, 5.0)));
        assert!(a.offer(&[1.0], e(5.0, 1.0)));
        assert!(!a.offer(&[2.0], e(6.0, 6.0)), "dominated");
        assert!(
            !a.offer(
                &[9.0],
                Eval {
                    violation: 1.0,
                    ..e(0.0, 0.0)
                }
            ),
            "infeasible"
        );
        assert!(a.offer(&[3.0], e(2.0, 3.0)));
        // A fourth point: the one with the smallest crowding distance goes.
        assert!(a.offer(&[4.0], e(2.5, 2.9)));
        assert_eq!(a.members.len(), 3);
        let kept: Vec<f64> = a.members.iter().map(|m| m.0[0]).collect();
        assert!(
            kept.contains(&0.0) && kept.contains(&1.0),
            "boundary points stay: {kept:?}"
        );
        // A point that dominates everything empties the rest.
        assert!(a.offer(&[5.0], e(0.5, 0.5)));
        assert_eq!(a.members.len(), 1);
    }

    #[test]
    fn eq19_21_on_a_hand_made_front() {
        // L = 30, 32, 40 (sum 102); Omega = 6, 3, 1 (sum 10).
        // f = 0.5 L/102 + 0.5 Omega/10 = 0.447, 0.307, 0.246: the last wins.
        let front = [[30.0, 6.0, 3.0], [32.0, 3.0, 2.0], [40.0, 1.0, 0.5]];
        let w = |length, safety| Weights { length, safety };
        assert_eq!(weighted_choice(&front, PAPER), Some(2));
        // All weight on length: the shortest.
        assert_eq!(weighted_choice(&front, w(1.0, 0.0)), Some(0));
        // 0.8 on length: 0.8*30/102+0.2*0.6 = 0.355, 0.8*32/102+0.06 = 0.311, 0.8*40/102+0.02 = 0.334.
        assert_eq!(weighted_choice(&front, w(0.8, 0.0)), Some(1));
        // Safety 0.5 with length 1 (S sum 5.5): 0.5*30/102+0.5*3/5.5 = 0.420, 0.5*32/102+0.5*2/5.5
        // = 0.339, 0.5*40/102+0.5*0.5/5.5 = 0.242: the safest.
        assert_eq!(weighted_choice(&front, w(1.0, 0.5)), Some(2));
        assert_eq!(weighted_choice(&[], PAPER), None);
    }

    #[test]
    fn hypervolume_on_hand_made_fronts() {
        let r = (4.0, 4.0);
        // One point (1, 1): a 3 x 3 square.
        assert_eq!(hypervolume_2d(&[(1.0, 1.0)], r), 9.0);
        // (1, 3) and (3, 1): 3 x 1 + 1 x 3 - 1 x 1 overlap = 5 (2 x 1 + 1 x 3).
        assert_eq!(hypervolume_2d(&[(3.0, 1.0), (1.0, 3.0)], r), 5.0);
        // A dominated point and one outside the reference add nothing.
        assert_eq!(
            hypervolume_2d(&[(3.0, 1.0), (1.0, 3.0), (3.0, 3.0), (5.0, 0.0)], r),
            5.0
        );
        assert_eq!(hypervolume_2d(&[], r), 0.0);
    }

    #[test]
    fn weights_sum_to_one_and_safety_zero_is_the_paper() {
        let v = Weights {
            length: 0.3,
            safety: 0.4,
        }
        .vector();
        assert!((v.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        assert_eq!(PAPER.vector(), [0.5, 0.5, 0.0]);
        assert_eq!(PAPER.objectives(), 2);
        // A zero-weight term with a zero scale does not bring a NaN in.
        assert_eq!(PAPER.scalarise([2.0, 4.0, 1.0], [4.0, 4.0, 0.0]), 0.75);
    }
}
