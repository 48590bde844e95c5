//! `nsga2`: a textbook NSGA-II (Deb, Pratap, Agarwal, Meyarivan, "A fast and elitist
//! multiobjective genetic algorithm: NSGA-II", IEEE TEC 6(2), 2002) over the swarms' search space,
//! the baseline every multi-objective planner is compared to (issue 12).
//!
//! It lives beside the swarms because it searches exactly what they search: the same seed and
//! encoding (`super::start`), the same objectives and constraint (`Search::evaluate`: length,
//! turning, safety when weighted, blocked length as the violation, constraint domination), the
//! same initial cloud around the seed (`init_spread`) and the same eq. 19-21 choice from its
//! final front. Only the search operators differ, and they are NSGA-II's with pymoo's defaults:
//! binary tournament on (rank, crowding distance), simulated binary crossover (probability 0.9,
//! eta 15), polynomial mutation (probability 1/dimension per variable, eta 20), and elitist
//! survival of parents and offspring by non-dominated fronts, the last front cut by crowding
//! distance. The budget is counted in evaluations (`nsga2.evaluations`, default 7800: what
//! `mocmcso` spends in its 100 iterations at the defaults), so that the two compare at equal
//! cost.

use super::pareto::{crowding_distances, dominates, Eval};
use super::{start, Search, SwarmParams, Variant};
use crate::driver::{drive, Budget, Population};
use crate::field::ApfParams;
use crate::params::{check, check_counts, ParamError, Range};
use crate::planner::{ParetoMember, PlanContext, PlanError, PlanStats, Planner, Problem, RawPlan};
use crate::planner_name::PlannerName;
use rand::Rng;
use serde::{Deserialize, Serialize};

/// NSGA-II's own parameters (pymoo's defaults); the search space, the objectives' weights and
/// the initial spread are the swarms' (`swarm` section).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Nsga2Params {
    /// Individuals per generation. Default 50.
    pub population: usize,
    /// Objective evaluations in all, the initial population included. Default 7800.
    pub evaluations: usize,
    /// Probability that a pair is crossed (SBX). Default 0.9.
    pub crossover_probability: f64,
    /// SBX distribution index. Default 15.
    pub crossover_eta: f64,
    /// Polynomial mutation distribution index. Default 20.
    pub mutation_eta: f64,
}

impl Default for Nsga2Params {
    fn default() -> Self {
        Self {
            population: 50,
            evaluations: 7800,
            crossover_probability: 0.9,
            crossover_eta: 15.0,
            mutation_eta: 20.0,
        }
    }
}

impl Nsga2Params {
    pub fn validate(&self) -> Result<(), ParamError> {
        // Survival ranks 2 x population members pairwise: the population's bound is lower.
        check_counts(2..=2_000, &[("nsga2.population", self.population)])?;
        check_counts(2..=100_000_000, &[("nsga2.evaluations", self.evaluations)])?;
        check(
            Range::Share,
            &[("nsga2.crossover_probability", self.crossover_probability)],
        )?;
        check(
            Range::NonNegative,
            &[
                ("nsga2.crossover_eta", self.crossover_eta),
                ("nsga2.mutation_eta", self.mutation_eta),
            ],
        )
    }

    /// Generations after the initial population: what the evaluation budget pays for.
    fn generations(&self) -> usize {
        self.evaluations.saturating_sub(self.population) / self.population
    }
}

/// The planner.
#[derive(Clone, Debug)]
pub struct Nsga2Planner {
    pub params: Nsga2Params,
    /// The search space, initial spread and objective weights.
    pub swarm: SwarmParams,
    /// The potential field that seeds the population.
    pub apf: ApfParams,
}

impl Planner for Nsga2Planner {
    fn name(&self) -> PlannerName {
        PlannerName::Nsga2
    }

    fn plan(&self, problem: &Problem<'_>, ctx: &mut PlanContext<'_>) -> Result<RawPlan, PlanError> {
        let (enc, seed, start_stats) = start(problem, &self.swarm, &self.apf, ctx)?;
        // A multi-objective Search: only its evaluation and scalarisation are used here.
        let search = Search::new(problem.grid, &enc, &self.swarm, Variant::Mocmcso);
        let run = Nsga2 {
            params: &self.params,
            search,
            seed,
            start_stats,
            pop: Vec::new(),
        };
        let budget = Budget {
            iterations: self.params.generations(),
            patience: None,
        };
        drive(run, budget, ctx)
    }
}

/// One member: its vector, evaluation, front rank (0 = non-dominated) and crowding distance.
#[derive(Clone, Debug)]
struct Member {
    x: Vec<f64>,
    e: Eval,
    rank: usize,
    crowding: f64,
}

struct Nsga2<'a> {
    params: &'a Nsga2Params,
    search: Search<'a>,
    seed: Vec<f64>,
    start_stats: PlanStats,
    pop: Vec<Member>,
}

impl Nsga2<'_> {
    /// The best scalarised value (relative to the seed) on the first front: the convergence
    /// measure, as the swarms report it.
    fn progress(&self) -> f64 {
        self.pop
            .iter()
            .filter(|m| m.rank == 0 && m.e.feasible())
            .map(|m| self.search.scalar(&m.e))
            .fold(f64::INFINITY, f64::min)
    }

    /// Binary tournament: lower rank wins, then larger crowding distance.
    fn tournament(&self, ctx: &mut PlanContext<'_>) -> usize {
        let n = self.pop.len();
        let (a, b) = (ctx.rng.random_range(0..n), ctx.rng.random_range(0..n));
        let (ma, mb) = (&self.pop[a], &self.pop[b]);
        if ma.rank != mb.rank {
            if ma.rank < mb.rank {
                a
            } else {
                b
            }
        } else if ma.crowding >= mb.crowding {
            a
        } else {
            b
        }
    }
}

/// Simulated binary crossover (Deb and Agrawal 1995, bounded form as in pymoo) of one variable.
fn sbx(a: f64, b: f64, lo: f64, hi: f64, eta: f64, ctx: &mut PlanContext<'_>) -> (f64, f64) {
    if (a - b).abs() < 1e-14 || hi - lo < 1e-14 {
        return (a, b);
    }
    let (y1, y2) = if a < b { (a, b) } else { (b, a) };
    let u: f64 = ctx.rng.random();
    let child = |beta: f64| {
        let alpha = 2.0 - beta.powf(-(eta + 1.0));
        if u <= 1.0 / alpha {
            (u * alpha).powf(1.0 / (eta + 1.0))
        } else {
            (1.0 / (2.0 - u * alpha)).powf(1.0 / (eta + 1.0))
        }
    };
    let beta1 = 1.0 + 2.0 * (y1 - lo) / (y2 - y1);
    let c1 = 0.5 * ((y1 + y2) - child(beta1) * (y2 - y1));
    let beta2 = 1.0 + 2.0 * (hi - y2) / (y2 - y1);
    let c2 = 0.5 * ((y1 + y2) + child(beta2) * (y2 - y1));
    let (c1, c2) = (c1.clamp(lo, hi), c2.clamp(lo, hi));
    if ctx.rng.random::<bool>() {
        (c2, c1)
    } else {
        (c1, c2)
    }
}

/// Polynomial mutation (Deb and Goyal 1996, bounded form as in pymoo) of one variable.
fn polynomial(y: f64, lo: f64, hi: f64, eta: f64, ctx: &mut PlanContext<'_>) -> f64 {
    let span = hi - lo;
    if span < 1e-14 {
        return y;
    }
    let (d1, d2) = ((y - lo) / span, (hi - y) / span);
    let u: f64 = ctx.rng.random();
    let power = 1.0 / (eta + 1.0);
    let dq = if u < 0.5 {
        let v = 2.0 * u + (1.0 - 2.0 * u) * (1.0 - d1).powf(eta + 1.0);
        v.powf(power) - 1.0
    } else {
        let v = 2.0 * (1.0 - u) + 2.0 * (u - 0.5) * (1.0 - d2).powf(eta + 1.0);
        1.0 - v.powf(power)
    };
    (y + dq * span).clamp(lo, hi)
}

/// Fast non-dominated sorting and crowding (Deb et al. 2002, section III): sets every member's
/// rank and crowding distance; returns the fronts as index lists, best first.
fn rank_and_crowd(pop: &mut [Member], objectives: usize) -> Vec<Vec<usize>> {
    let n = pop.len();
    let mut dominated_by = vec![0usize; n];
    let mut dominates_list: Vec<Vec<usize>> = vec![Vec::new(); n];
    for i in 0..n {
        for j in i + 1..n {
            if dominates(&pop[i].e, &pop[j].e) {
                dominates_list[i].push(j);
                dominated_by[j] += 1;
            } else if dominates(&pop[j].e, &pop[i].e) {
                dominates_list[j].push(i);
                dominated_by[i] += 1;
            }
        }
    }
    let mut fronts = Vec::new();
    let mut current: Vec<usize> = (0..n).filter(|&i| dominated_by[i] == 0).collect();
    let mut rank = 0;
    while !current.is_empty() {
        let mut next = Vec::new();
        for &i in &current {
            pop[i].rank = rank;
            for &j in &dominates_list[i] {
                dominated_by[j] -= 1;
                if dominated_by[j] == 0 {
                    next.push(j);
                }
            }
        }
        // Infeasible members have infinite objectives; their crowding is irrelevant (rank
        // decides between them), so it is 0.
        let points: Vec<[f64; 3]> = current
            .iter()
            .map(|&i| {
                let e = &pop[i].e;
                if e.feasible() {
                    e.objectives()
                } else {
                    [0.0; 3]
                }
            })
            .collect();
        let d = crowding_distances(&points, objectives);
        for (k, &i) in current.iter().enumerate() {
            pop[i].crowding = d[k];
        }
        fronts.push(std::mem::replace(&mut current, next));
        rank += 1;
    }
    fronts
}

impl Population for Nsga2<'_> {
    /// The initial population: the seed and a cloud of `init_spread` around it, as the swarms
    /// start.
    fn init(&mut self, ctx: &mut PlanContext<'_>, stats: &mut PlanStats) -> Result<f64, PlanError> {
        let start = std::mem::take(&mut self.start_stats);
        stats.notes.extend(start.notes);
        stats.counters.extend(start.counters);
        let seed_eval = self.search.evaluate_seed(&self.seed);
        for k in 0..self.params.population {
            // A deadline during the start leaves a smaller population (the seed at least).
            if k > 0 && ctx.check().is_err() {
                break;
            }
            let (x, e) = self.search.initial_member(&self.seed, seed_eval, k, ctx);
            self.pop.push(Member {
                x,
                e,
                rank: 0,
                crowding: 0.0,
            });
        }
        rank_and_crowd(&mut self.pop, self.search.weights.objectives());
        Ok(self.progress())
    }

    /// One generation: tournament, SBX, polynomial mutation, then elitist survival.
    fn step(&mut self, _t: usize, ctx: &mut PlanContext<'_>) -> f64 {
        let p = self.params;
        let n = p.population;
        let (lo, hi) = (self.search.enc.lo(), self.search.enc.hi());
        let dim = lo.len();
        let mut offspring: Vec<Member> = Vec::with_capacity(n);
        while offspring.len() < n {
            // A deadline or a cancel does not wait for the whole generation: survival works
            // with fewer offspring.
            if ctx.check().is_err() {
                break;
            }
            let (a, b) = (self.tournament(ctx), self.tournament(ctx));
            let (mut x1, mut x2) = (self.pop[a].x.clone(), self.pop[b].x.clone());
            if ctx.rng.random::<f64>() < p.crossover_probability {
                for d in 0..dim {
                    // pymoo crosses each variable with probability 0.5.
                    if ctx.rng.random::<bool>() {
                        let (c1, c2) = sbx(x1[d], x2[d], lo[d], hi[d], p.crossover_eta, ctx);
                        x1[d] = c1;
                        x2[d] = c2;
                    }
                }
            }
            for x in [&mut x1, &mut x2] {
                for d in 0..dim {
                    if ctx.rng.random::<f64>() < 1.0 / dim as f64 {
                        x[d] = polynomial(x[d], lo[d], hi[d], p.mutation_eta, ctx);
                    }
                }
            }
            for x in [x1, x2] {
                if offspring.len() < n {
                    let e = self.search.evaluate(&x);
                    offspring.push(Member {
                        x,
                        e,
                        rank: 0,
                        crowding: 0.0,
                    });
                }
            }
        }
        let mut all = std::mem::take(&mut self.pop);
        all.extend(offspring);
        let objectives = self.search.weights.objectives();
        let fronts = rank_and_crowd(&mut all, objectives);
        let mut keep: Vec<usize> = Vec::with_capacity(n);
        for front in fronts {
            if keep.len() + front.len() <= n {
                keep.extend(front);
            } else {
                let mut last = front;
                last.sort_by(|&i, &j| all[j].crowding.total_cmp(&all[i].crowding).then(i.cmp(&j)));
                keep.extend(last.into_iter().take(n - keep.len()));
                break;
            }
        }
        let mut next: Vec<Option<Member>> = all.into_iter().map(Some).collect();
        self.pop = keep
            .iter()
            .map(|&i| next[i].take().expect("kept once"))
            .collect();
        rank_and_crowd(&mut self.pop, objectives);
        self.progress()
    }

    fn evaluations(&self) -> u64 {
        self.search.evaluations
    }

    /// The first front's feasible members (duplicates dropped), and eq. 19-21's choice from it.
    fn finish(
        mut self,
        mut stats: PlanStats,
        ctx: &mut PlanContext<'_>,
    ) -> Result<RawPlan, PlanError> {
        let enc = self.search.enc;
        let mut front: Vec<Member> = Vec::new();
        for m in self
            .pop
            .into_iter()
            .filter(|m| m.rank == 0 && m.e.feasible())
        {
            if !front.iter().any(|f| f.e.objectives() == m.e.objectives()) {
                front.push(m);
            }
        }
        let objectives: Vec<[f64; 3]> = front.iter().map(|m| m.e.objectives()).collect();
        let chosen = match super::pareto::weighted_choice(&objectives, self.search.weights) {
            Some(k) => {
                // The same polish as the swarms' (their comparison is of the search alone); a
                // polished path dominates the choice, and leaves the front every member it
                // dominates.
                let (x, e, moved) =
                    self.search
                        .polish_choice(front[k].x.clone(), front[k].e, &mut stats, ctx);
                if moved {
                    front.retain(|m| !dominates(&e, &m.e));
                    front.push(Member {
                        x: x.clone(),
                        e,
                        rank: 0,
                        crowding: 0.0,
                    });
                }
                x
            }
            None => self.seed.clone(),
        };
        if chosen == self.seed {
            stats
                .notes
                .push("NSGA-II did not move from its seed; the seed path is returned".into());
        }
        let pareto = front
            .into_iter()
            .map(|m| ParetoMember {
                f1_length_m: m.e.f1,
                f2_turning_rad: m.e.f2,
                f3_safety: m.e.f3,
                waypoints: enc.decode(&m.x),
            })
            .collect();
        Ok(RawPlan {
            waypoints: enc.decode(&chosen),
            stats,
            pareto,
            seed: Some(enc.decode(&self.seed)),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::rng;

    fn member(f1: f64, f2: f64) -> Member {
        Member {
            x: vec![f1, f2],
            e: Eval {
                f1,
                f2,
                f3: 0.0,
                violation: 0.0,
            },
            rank: 9,
            crowding: 0.0,
        }
    }

    #[test]
    fn fronts_on_a_hand_made_population() {
        // (1,4) (2,2) (4,1) are non-dominated; (3,3) is dominated by (2,2) only; (5,5) by all.
        let mut pop = vec![
            member(1.0, 4.0),
            member(3.0, 3.0),
            member(2.0, 2.0),
            member(5.0, 5.0),
            member(4.0, 1.0),
        ];
        let fronts = rank_and_crowd(&mut pop, 2);
        assert_eq!(fronts, vec![vec![0, 2, 4], vec![1], vec![3]]);
        let ranks: Vec<usize> = pop.iter().map(|m| m.rank).collect();
        assert_eq!(ranks, vec![0, 1, 0, 2, 0]);
        // The first front's ends are infinitely crowded, its middle finite.
        assert!(pop[0].crowding.is_infinite() && pop[4].crowding.is_infinite());
        assert!(pop[2].crowding.is_finite() && pop[2].crowding > 0.0);
    }

    #[test]
    fn operators_stay_in_bounds_and_keep_equal_parents() {
        let mut r = rng(5);
        let mut ctx = PlanContext::never_interrupted(&mut r);
        for _ in 0..10_000 {
            let (a, b) = (
                ctx.rng.random_range(-2.0..3.0),
                ctx.rng.random_range(-2.0..3.0),
            );
            let (c1, c2) = sbx(a, b, -2.0, 3.0, 15.0, &mut ctx);
            assert!((-2.0..=3.0).contains(&c1) && (-2.0..=3.0).contains(&c2));
            let m = polynomial(a, -2.0, 3.0, 20.0, &mut ctx);
            assert!((-2.0..=3.0).contains(&m));
        }
        assert_eq!(sbx(1.0, 1.0, 0.0, 2.0, 15.0, &mut ctx), (1.0, 1.0));
        // Children of distant parents spread around them, mostly near them at eta 15.
        let mut near = 0;
        for _ in 0..1000 {
            let (c1, c2) = sbx(0.0, 1.0, -10.0, 10.0, 15.0, &mut ctx);
            let (lo, hi) = if c1 < c2 { (c1, c2) } else { (c2, c1) };
            near += usize::from(lo.abs() < 0.35 && (hi - 1.0).abs() < 0.35);
        }
        assert!(near > 900, "{near}");
    }
}
