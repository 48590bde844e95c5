//! The one loop of every population planner (the swarms, the colonies, the genetic algorithms),
//! in the spirit of argmin's executor: a family says how to start ([`Population::init`]), how to
//! take one iteration ([`Population::step`]) and how to finish ([`Population::finish`]); [`drive`]
//! owns everything they used to repeat: the interrupt poll, the iteration count, the budget and
//! the one patience rule, the convergence curve, the best iteration, the observer hook, and the
//! typed [`Termination`] that the result carries (both defined with the result, in
//! [`crate::planner`]).

use crate::planner::{Iteration, PlanContext, PlanError, PlanStats, RawPlan, Termination};

/// Improvements smaller than this do not count (they are rounding, not progress).
const MIN_IMPROVEMENT: f64 = 1e-12;

/// How long a population planner may run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Budget {
    /// The most iterations (generations) to run.
    pub iterations: usize,
    /// Stop after this many iterations in a row without a better best value, counted once there
    /// is a best (a finite value); `None` never stops early. One name and one meaning for every
    /// family.
    pub patience: Option<usize>,
}

/// A population planner's operators; [`drive`] runs them.
pub trait Population {
    /// Builds the initial population; returns the best value in it (`f64::INFINITY` when there
    /// is none yet). Notes and counters of the start go into `stats`.
    fn init(&mut self, ctx: &mut PlanContext<'_>, stats: &mut PlanStats) -> Result<f64, PlanError>;

    /// Iteration `t` (0-based); returns the best value so far, which must never increase.
    fn step(&mut self, t: usize, ctx: &mut PlanContext<'_>) -> f64;

    /// Objective evaluations so far (the bench's and `/diagnostics`' `evaluations`).
    fn evaluations(&self) -> u64;

    /// The chosen path (and front), with the family's counters added to `stats`. Called after
    /// the loop, whatever ended it; `stats.termination` is already set. Work done here (the
    /// swarms' polish) polls `ctx` like an iteration.
    fn finish(self, stats: PlanStats, ctx: &mut PlanContext<'_>) -> Result<RawPlan, PlanError>;
}

/// Runs a population: init, then steps until the budget, the patience or the interrupt ends the
/// run, then finish. The statistics (iterations, evaluations, convergence, best iteration,
/// `cut_short`, termination) are the driver's; the family adds its own counters and notes.
pub fn drive<P: Population>(
    mut pop: P,
    budget: Budget,
    ctx: &mut PlanContext<'_>,
) -> Result<RawPlan, PlanError> {
    let mut stats = PlanStats::default();
    let mut best = pop.init(ctx, &mut stats)?;
    let mut stalled = 0usize;
    let mut termination = Termination::MaxIterations;
    for t in 0..budget.iterations {
        if let Some(interrupt) = (ctx.interrupt)() {
            stats.cut_short = true;
            termination = Termination::Interrupted(interrupt);
            break;
        }
        stats.iterations += 1;
        let value = pop.step(t, ctx);
        stats.convergence.push(value);
        if value < best - MIN_IMPROVEMENT {
            best = value;
            stats.best_iteration = Some(t as u64 + 1);
            stalled = 0;
        } else if best.is_finite() {
            // Patience counts only once there is an answer to improve on: a colony without a
            // seed may take more than `patience` iterations before its first ant arrives.
            stalled += 1;
        }
        if let Some(observe) = ctx.observer.as_mut() {
            observe(&Iteration {
                number: t as u64 + 1,
                best: value,
            });
        }
        if let Some(patience) = budget.patience.filter(|&p| stalled >= p) {
            termination = Termination::Converged { patience };
            break;
        }
    }
    stats.evaluations = pop.evaluations();
    stats.termination = Some(termination);
    pop.finish(stats, ctx)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::planner::Interrupt;
    use crate::test_support::rng;

    /// A population whose best value follows a script.
    struct Scripted {
        initial: f64,
        values: Vec<f64>,
        evaluations: u64,
    }

    impl Population for Scripted {
        fn init(&mut self, _: &mut PlanContext<'_>, _: &mut PlanStats) -> Result<f64, PlanError> {
            Ok(self.initial)
        }
        fn step(&mut self, t: usize, _: &mut PlanContext<'_>) -> f64 {
            self.evaluations += 2;
            self.values[t.min(self.values.len() - 1)]
        }
        fn evaluations(&self) -> u64 {
            self.evaluations
        }
        fn finish(self, stats: PlanStats, _: &mut PlanContext<'_>) -> Result<RawPlan, PlanError> {
            Ok(RawPlan {
                stats,
                ..RawPlan::default()
            })
        }
    }

    fn run(values: &[f64], budget: Budget, interrupt: &dyn Fn() -> Option<Interrupt>) -> PlanStats {
        run_from(10.0, values, budget, interrupt)
    }

    fn run_from(
        initial: f64,
        values: &[f64],
        budget: Budget,
        interrupt: &dyn Fn() -> Option<Interrupt>,
    ) -> PlanStats {
        let mut r = rng(0);
        let mut ctx = PlanContext::new(&mut r, interrupt);
        let pop = Scripted {
            initial,
            values: values.to_vec(),
            evaluations: 0,
        };
        drive(pop, budget, &mut ctx).unwrap().stats
    }

    #[test]
    fn budget_patience_and_best_iteration() {
        let values = [9.0, 9.0, 8.0, 8.0, 8.0, 8.0, 7.0];
        let all = run(
            &values,
            Budget {
                iterations: 7,
                patience: None,
            },
            &|| None,
        );
        assert_eq!(all.termination, Some(Termination::MaxIterations));
        assert_eq!((all.iterations, all.evaluations), (7, 14));
        assert_eq!(all.best_iteration, Some(7));
        assert_eq!(all.convergence, values);
        // Three iterations without improvement after the third: stop at the sixth.
        let early = run(
            &values,
            Budget {
                iterations: 7,
                patience: Some(3),
            },
            &|| None,
        );
        assert_eq!(
            early.termination,
            Some(Termination::Converged { patience: 3 })
        );
        assert_eq!(early.iterations, 6);
        assert_eq!(early.best_iteration, Some(3));
        assert!(!early.cut_short);
    }

    /// Without an answer yet (an infinite best, as a colony without a seed has until its first
    /// ant arrives) no iteration counts against the patience: the run goes on until one comes,
    /// and the patience counts from there.
    #[test]
    fn patience_waits_for_the_first_answer() {
        let inf = f64::INFINITY;
        let values = [inf, inf, inf, inf, inf, 6.0, 6.0, 6.0, 6.0];
        let budget = Budget {
            iterations: 9,
            patience: Some(3),
        };
        let stats = run_from(inf, &values, budget, &|| None);
        assert_eq!(stats.best_iteration, Some(6));
        assert_eq!(stats.iterations, 9);
        assert_eq!(
            stats.termination,
            Some(Termination::Converged { patience: 3 })
        );
    }

    #[test]
    fn an_interrupt_stops_before_the_next_iteration() {
        let calls = std::cell::Cell::new(0);
        let interrupt = || {
            calls.set(calls.get() + 1);
            (calls.get() > 2).then_some(Interrupt::Deadline)
        };
        let stats = run(
            &[5.0],
            Budget {
                iterations: 10,
                patience: None,
            },
            &interrupt,
        );
        assert_eq!(stats.iterations, 2);
        assert!(stats.cut_short);
        assert_eq!(
            stats.termination,
            Some(Termination::Interrupted(Interrupt::Deadline))
        );
        assert_eq!(
            Termination::Interrupted(Interrupt::Cancelled).as_str(),
            "cancelled"
        );
    }

    #[test]
    fn the_observer_sees_every_iteration() {
        let mut seen = Vec::new();
        let mut observe = |i: &Iteration| seen.push((i.number, i.best));
        let mut r = rng(0);
        let mut ctx = PlanContext::new(&mut r, &|| None);
        ctx.observer = Some(&mut observe);
        let pop = Scripted {
            initial: 10.0,
            values: vec![4.0, 3.0],
            evaluations: 0,
        };
        drive(
            pop,
            Budget {
                iterations: 2,
                patience: None,
            },
            &mut ctx,
        )
        .unwrap();
        assert_eq!(seen, vec![(1, 4.0), (2, 3.0)]);
    }
}
