//! Objectives and Pareto machinery of the multi-objective swarms.
//!
//! Objectives (patrol car paper eq. 18): f1 the path length (m), f2 the total turning angle (rad,
//! eq. 17). Infeasible candidates are dominated by every feasible one (constraint domination) and
//! ordered among themselves by how much of their length lies in obstacles (`docs/papers.md`). The
//! archive keeps at most `capacity` non-dominated feasible solutions, pruning the most crowded
//! (NSGA-II crowding distance). The final choice is eq. 19–21: each objective normalised by its
//! sum over the archive, then the smallest weighted sum (weight 0.5: the "midpoint" of the front).

/// What a candidate scores.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Eval {
    /// Path length (m).
    pub f1: f64,
    /// Total turning angle (rad).
    pub f2: f64,
    /// Length (m) of the path inside blocked cells; 0 means feasible.
    pub violation: f64,
}

impl Eval {
    pub fn feasible(&self) -> bool {
        self.violation == 0.0
    }
}

/// Constraint domination: feasible beats infeasible, less violation beats more, and between
/// feasible candidates ordinary Pareto dominance on (f1, f2).
pub fn dominates(a: &Eval, b: &Eval) -> bool {
    match (a.feasible(), b.feasible()) {
        (true, false) => true,
        (false, true) => false,
        (false, false) => a.violation < b.violation,
        (true, true) => a.f1 <= b.f1 && a.f2 <= b.f2 && (a.f1 < b.f1 || a.f2 < b.f2),
    }
}

/// NSGA-II crowding distance of each point of a front (boundary points get infinity).
pub fn crowding_distances(points: &[(f64, f64)]) -> Vec<f64> {
    let n = points.len();
    let mut dist = vec![0.0; n];
    if n <= 2 {
        return vec![f64::INFINITY; n];
    }
    for objective in 0..2 {
        let value = |k: usize| {
            if objective == 0 {
                points[k].0
            } else {
                points[k].1
            }
        };
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

/// Eq. 19–21: index of the member with the smallest `w * L / sum L + (1 - w) * Omega / sum Omega`.
pub fn equal_weight_choice(front: &[(f64, f64)], length_weight: f64) -> Option<usize> {
    let sum_l: f64 = front.iter().map(|p| p.0).sum();
    let sum_o: f64 = front.iter().map(|p| p.1).sum();
    let nor = |v: f64, sum: f64| if sum > 0.0 { v / sum } else { 0.0 };
    (0..front.len()).min_by(|&a, &b| {
        let f = |k: usize| {
            length_weight * nor(front[k].0, sum_l) + (1.0 - length_weight) * nor(front[k].1, sum_o)
        };
        f(a).total_cmp(&f(b)).then(a.cmp(&b))
    })
}

/// The external archive: non-dominated feasible solutions.
#[derive(Clone, Debug)]
pub struct Archive {
    pub capacity: usize,
    pub members: Vec<(Vec<f64>, Eval)>,
}

impl Archive {
    pub fn new(capacity: usize) -> Self {
        Self {
            capacity,
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
            .any(|(_, m)| dominates(m, &e) || (m.f1 == e.f1 && m.f2 == e.f2))
        {
            return false;
        }
        self.members.retain(|(_, m)| !dominates(&e, m));
        self.members.push((x.to_vec(), e));
        if self.members.len() > self.capacity {
            let pts: Vec<(f64, f64)> = self.objectives();
            let d = crowding_distances(&pts);
            let most_crowded = (0..d.len())
                .min_by(|&a, &b| d[a].total_cmp(&d[b]).then(a.cmp(&b)))
                .expect("non-empty");
            self.members.swap_remove(most_crowded);
        }
        true
    }

    pub fn objectives(&self) -> Vec<(f64, f64)> {
        self.members.iter().map(|(_, e)| (e.f1, e.f2)).collect()
    }

    /// The eq. 19–21 choice.
    pub fn choose(&self, length_weight: f64) -> Option<&(Vec<f64>, Eval)> {
        equal_weight_choice(&self.objectives(), length_weight).map(|k| &self.members[k])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn e(f1: f64, f2: f64) -> Eval {
        Eval {
            f1,
            f2,
            violation: 0.0,
        }
    }

    #[test]
    fn dominance_on_hand_made_points() {
        assert!(dominates(&e(1.0, 1.0), &e(2.0, 2.0)));
        assert!(dominates(&e(1.0, 2.0), &e(1.0, 3.0)));
        assert!(!dominates(&e(1.0, 2.0), &e(2.0, 1.0)));
        assert!(!dominates(&e(1.0, 1.0), &e(1.0, 1.0)));
        let bad = Eval {
            f1: 0.1,
            f2: 0.0,
            violation: 2.0,
        };
        let worse = Eval {
            f1: 0.1,
            f2: 0.0,
            violation: 3.0,
        };
        assert!(dominates(&e(100.0, 100.0), &bad));
        assert!(!dominates(&bad, &e(100.0, 100.0)));
        assert!(dominates(&bad, &worse));
    }

    #[test]
    fn crowding_on_a_hand_made_front() {
        // Front (1,5) (2,3) (4,2) (5,1): spans 4 and 4.
        let d = crowding_distances(&[(1.0, 5.0), (2.0, 3.0), (4.0, 2.0), (5.0, 1.0)]);
        assert!(d[0].is_infinite() && d[3].is_infinite());
        // (2,3): (4-1)/4 + (5-2)/4 = 1.5; (4,2): (5-2)/4 + (3-1)/4 = 1.25.
        assert!((d[1] - 1.5).abs() < 1e-12 && (d[2] - 1.25).abs() < 1e-12);
    }

    #[test]
    fn archive_keeps_the_front_and_prunes_the_most_crowded() {
        let mut a = Archive::new(3);
        assert!(a.offer(&[0.0], e(1.0, 5.0)));
        assert!(a.offer(&[1.0], e(5.0, 1.0)));
        assert!(!a.offer(&[2.0], e(6.0, 6.0)), "dominated");
        assert!(
            !a.offer(
                &[9.0],
                Eval {
                    f1: 0.0,
                    f2: 0.0,
                    violation: 1.0
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
        let front = [(30.0, 6.0), (32.0, 3.0), (40.0, 1.0)];
        assert_eq!(equal_weight_choice(&front, 0.5), Some(2));
        // All weight on length: the shortest.
        assert_eq!(equal_weight_choice(&front, 1.0), Some(0));
        // 0.8 on length: 0.8*30/102+0.2*0.6 = 0.355, 0.8*32/102+0.06 = 0.311, 0.8*40/102+0.02 = 0.334.
        assert_eq!(equal_weight_choice(&front, 0.8), Some(1));
        assert_eq!(equal_weight_choice(&[], 0.5), None);
    }
}
