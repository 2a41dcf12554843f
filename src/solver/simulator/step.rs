//! `Simulator::step`: the stages of a step, read top down.
//!
//! ```text
//! step(dt)
//!  ├─ start: a changed command restarts the accelerations
//!  └─ per sub-step (h, rule) = plan:
//!       trial   integrator::newmark (h, rule)            verdict: sound, or Retry
//!       gates   blend entry, contact cut, ledger         verdict: sound, or Retry
//!       finish  events, ledger::accept, impact           verdict: done, or Retry
//!       motors  release / engage                         (the next sub-step no longer)
//!       momentum  a free-floating model's P and L held     (momentum::hold)
//!       Retry   book_retry(why): the one place a retry is decided and counted
//! ```
//!
//! Every gate returns a verdict; a `Retry` names why (`RetryWhy`) and the
//! length and rule of the sub-step to take instead, and the loop in
//! `step_stages` is the only place that takes it.

use super::core::StepRule;
use super::sim::Simulator;
use crate::solver::linsolve::SolveMode;
use crate::solver::state::MadeEnergyHalving;
use crate::solver::SolverError;

/// Why a sub-step is taken again (`Retry`), each counted in `book_retry`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum RetryWhy {
    /// The Newmark trial failed (no convergence, a failed projection,
    /// non-finite iterates): near a singular state a shorter one stays
    /// nearer the manifold (`fallbacks.substep_halvings`).
    TrialFailed,
    /// A latch search failed with the state unchanged: shorter
    /// (`fallbacks.substep_halvings`).
    LatchSearchFailed,
    /// Elastic members: the trial stepped over the friction blend's fast
    /// transient: the same h under the backward-Euler rule
    /// (`fallbacks.blend_entry_backward_euler`).
    BlendEntryBackwardEuler,
    /// Rigid members, the same: shorter (`fallbacks.blend_entry_halvings`).
    BlendEntryHalving,
    /// An end stop's contact starts or ends inside the trial: cut just past
    /// the crossing (`contact_cuts`).
    ContactCut,
    /// The trial made energy (`fallbacks.substep_energy_halvings`).
    MadeEnergy,
    /// The ledger's miss is over its budget (`ledger_halvings`).
    LedgerBudget,
}

/// A sub-step to take instead of the one tried.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Retry {
    pub why: RetryWhy,
    pub h_s: f64,
    pub rule: StepRule,
}

/// What the ledger's gate says of a trial (`trial_ledger`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum LedgerVerdict {
    /// Sound, having used this fraction of its miss budget.
    Sound {
        budget_used: f64,
    },
    /// Accepted at the shortest sub-step although it made energy
    /// (`fallbacks.substep_energy_accepted`).
    AcceptedMadeEnergy,
    /// Accepted at the shortest sub-step although over its budget
    /// (`fallbacks.ledger_budget_exceeded`).
    AcceptedOverBudget,
    Retry(Retry),
}

impl Simulator {
    /// Advances the state by exactly `dt` seconds, latching elements on the
    /// way. Returns the number of latch events in this step. A non-finite
    /// constraint Jacobian names the element whose rows it is in.
    pub fn step(&mut self, dt: f64) -> Result<usize, SolverError> {
        self.step_stages(dt).map_err(|e| match e {
            SolverError::NonFiniteJacobian => {
                SolverError::NonFinite(self.core.jac.describe_non_finite(&self.model))
            }
            e => e,
        })
    }

    /// The sub-steps of a step. The one retry route is the sub-step: cut by
    /// a failure or a gate, or taken again under the backward-Euler rule
    /// (`Retry`); doubled back after one that used at most a quarter of its
    /// ledger budget (doubling h multiplies the miss by 8 and its budget by 2).
    fn step_stages(&mut self, dt: f64) -> Result<usize, SolverError> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(SolverError::Request(
                crate::solver::RequestError::TimeStep { dt_s: dt },
            ));
        }
        self.core.motor.conflicted.fill(false);
        if self.state.carry.command_changed {
            self.restart_accelerations()?;
        }
        let t_end = self.state.t_s + dt;
        let locks_before = self.state.locks.len();
        // (sub-steps may add up to a few units of roundoff short of t_end:
        // none that short, whose energy the ledger cannot resolve, is taken)
        let end_tol_s = (self.settings.step_end_rel * dt).max(8.0 * f64::EPSILON * t_end.abs());
        let (mut h_try, mut substeps) = (dt, 0);
        let mut asked_rule = StepRule::AverageAcceleration;
        while t_end - self.state.t_s > end_tol_s {
            substeps += 1;
            self.check_step_limits(substeps, t_end)?;
            let (h_cap, rule) = self.substep_rule(h_try, dt, asked_rule);
            let h = h_cap
                .min(t_end - self.state.t_s)
                .min(self.transient_step_s());
            let verdict = match self.trial(h, rule, dt)? {
                Ok(budget_used) => self
                    .finish(h, rule, dt)?
                    .map(|motors| (budget_used, motors)),
                Err(retry) => Err(retry),
            };
            match verdict {
                Ok((budget_used, motors_changed)) => {
                    self.hold_momentum();
                    asked_rule = StepRule::AverageAcceleration;
                    h_try = h_cap;
                    if motors_changed {
                        h_try = h_try.min(h);
                    } else if budget_used <= 0.25 {
                        h_try = (2.0 * h_try).min(dt);
                    }
                }
                Err(retry) => {
                    self.book_retry(retry.why);
                    (h_try, asked_rule) = (retry.h_s, retry.rule);
                }
            }
        }
        self.state.t_s = t_end.max(self.state.t_s);
        self.state.steps += 1;
        self.core.stats.steps += 1;
        Ok(self.state.locks.len() - locks_before)
    }

    /// Stage `momentum`: a free-floating model's P and L restored after an
    /// accepted sub-step (`momentum::hold`).
    fn hold_momentum(&mut self) {
        let s = &mut self.state;
        if let Some(held) = &mut s.momentum {
            super::momentum::hold(&self.model, &s.x, &mut s.v, held);
        }
    }

    /// Counts a retry (the one place a retry is booked).
    fn book_retry(&mut self, why: RetryWhy) {
        let s = &mut self.core.stats;
        let f = &mut s.fallbacks;
        match why {
            RetryWhy::TrialFailed | RetryWhy::LatchSearchFailed => f.substep_halvings += 1,
            RetryWhy::BlendEntryBackwardEuler => f.blend_entry_backward_euler += 1,
            RetryWhy::BlendEntryHalving => f.blend_entry_halvings += 1,
            RetryWhy::ContactCut => s.contact_cuts += 1,
            RetryWhy::MadeEnergy => f.substep_energy_halvings += 1,
            RetryWhy::LedgerBudget => s.ledger_halvings += 1,
        }
    }

    /// The caller's limits (`StepLimits`), and at most `max_substeps` sub-steps
    /// (four more per lockable element, for latch events) in a step.
    fn check_step_limits(&self, substeps: usize, t_end: f64) -> Result<(), SolverError> {
        if let Some(why) = self.limits.reached(self.core.stats.accepting_fallbacks()) {
            return Err(SolverError::Stopped {
                t_s: self.state.t_s,
                why,
            });
        }
        let max = self.settings.max_substeps;
        if substeps > max + 4 * self.model.locks.len() {
            return Err(SolverError::SubstepBudget {
                max_substeps: max,
                t_end_s: t_end,
            });
        }
        Ok(())
    }

    /// The next sub-step's longest length and rule: the one asked (a retry's),
    /// except with elastic members after a restart (consistent
    /// accelerations), whose sub-steps are backward-Euler, the k-th at most
    /// 2^k `restart_substep_fraction` dt, also where a step's end falls among
    /// them (`Carry::restart_substeps_left`).
    fn substep_rule(&self, h_try: f64, dt: f64, asked: StepRule) -> (f64, StepRule) {
        let (st, left) = (&self.settings, self.state.carry.restart_substeps_left);
        if left == 0 || !st.elastic_members {
            return (h_try, asked);
        }
        let k = st.restart_substeps.saturating_sub(left);
        let cap = st.restart_substep_fraction * dt * 2f64.powi(k as i32);
        (h_try.min(cap), StepRule::BackwardEuler)
    }

    /// A Newmark trial of length h under `rule` from the state into the core
    /// (stage `integrator`), its Newton flag carried in the state
    /// (`Carry::newton_last`).
    pub(super) fn newmark_trial(
        &mut self,
        h: f64,
        rule: StepRule,
        mode: SolveMode,
    ) -> Result<(), SolverError> {
        self.core.newton_last = self.state.carry.newton_last;
        let (model, st) = (&self.model, &self.settings);
        let result = self.core.newmark(model, &self.state, (h, rule), st, mode);
        self.state.carry.newton_last = self.core.newton_last;
        result
    }

    /// A trial sub-step of length h under `rule` (stage `integrator`) and its
    /// gates: Ok(the fraction of its miss budget it used), or the retry one
    /// of them asks for. A failure no shorter sub-step may cure is an error.
    fn trial(
        &mut self,
        h: f64,
        rule: StepRule,
        dt: f64,
    ) -> Result<Result<f64, Retry>, SolverError> {
        let above_shortest = h > dt * self.settings.min_substep_fraction;
        let halve = |why| {
            Err(Retry {
                why,
                h_s: 0.5 * h,
                rule: StepRule::AverageAcceleration,
            })
        };
        match self.newmark_trial(h, rule, SolveMode::Basic) {
            Err(e) if shorter_may_converge(&e) && above_shortest => {
                return Ok(halve(RetryWhy::TrialFailed))
            }
            Err(e) => return Err(e),
            Ok(()) => {}
        }
        if let Some(retry) = self.blend_entry_gate(h, rule, above_shortest) {
            return Ok(Err(retry));
        }
        if let Some(h_cut) = self.contact_cut(h, dt) {
            let cut = Retry {
                why: RetryWhy::ContactCut,
                h_s: h_cut,
                rule: StepRule::AverageAcceleration,
            };
            return Ok(Err(cut));
        }
        Ok(match self.trial_ledger(h, rule, dt) {
            LedgerVerdict::Sound { budget_used } => Ok(budget_used),
            LedgerVerdict::AcceptedMadeEnergy => {
                self.core.stats.fallbacks.substep_energy_accepted += 1;
                Ok(0.0)
            }
            LedgerVerdict::AcceptedOverBudget => {
                self.core.stats.fallbacks.ledger_budget_exceeded += 1;
                Ok(0.0)
            }
            LedgerVerdict::Retry(retry) => Err(retry),
        })
    }

    /// A blend entry: the trial stepped over the friction blend's fast
    /// transient, which the average acceleration leaves ringing
    /// (docs/solver.md, Sub-steps). Elastic members: the same h under the
    /// backward-Euler rule, amplification 1 / (1 + 2x) against
    /// (1 - x) / (1 + x), x = h r / 2 for the transient's rate r, its own
    /// term booked (`integrator_work_j`); rigid members, whose projections
    /// that term does not cover: h halved.
    fn blend_entry_gate(&self, h: f64, rule: StepRule, above_shortest: bool) -> Option<Retry> {
        if !self.core.blend_entry || rule == StepRule::BackwardEuler {
            return None;
        }
        if self.settings.elastic_members {
            return Some(Retry {
                why: RetryWhy::BlendEntryBackwardEuler,
                h_s: h,
                rule: StepRule::BackwardEuler,
            });
        }
        above_shortest.then_some(Retry {
            why: RetryWhy::BlendEntryHalving,
            h_s: 0.5 * h,
            rule: StepRule::AverageAcceleration,
        })
    }

    /// Where the trial crosses a unilateral spring's contact (its
    /// `contact_distance_m` d changes sign, first at s = d0 / (d0 - d1)), the
    /// sub-step length (s + `contact_cut_rel`) h; None where nothing crosses,
    /// within `contact_cut_rel` of the end, or the cut is below the shortest
    /// sub-step.
    fn contact_cut(&self, h: f64, dt: f64) -> Option<f64> {
        let st = &self.settings;
        let (x0, x1) = (&self.state.x, &self.core.x);
        let s = self
            .model
            .contacts
            .iter()
            .filter_map(|&e| {
                let el = &self.model.elements[e];
                let (d0, d1) = (el.contact_distance_m(x0)?, el.contact_distance_m(x1)?);
                ((d0 > 0.0) != (d1 > 0.0)).then(|| d0 / (d0 - d1))
            })
            .fold(f64::INFINITY, f64::min);
        let cut = (s + st.contact_cut_rel) * h;
        (s.is_finite() && s < 1.0 - 2.0 * st.contact_cut_rel && cut > dt * st.min_substep_fraction)
            .then_some(cut)
    }

    /// The ledger's gate on the trial sub-step of length h (stage `ledger`),
    /// from its residual r, the change of kinetic energy less the work booked
    /// over it (compliant latches' transients included; with rigid members
    /// not gated under a transient, whose velocity projections the ledger
    /// does not book: the run's balance covers them):
    /// - made energy: |r| beyond `substep_energy_rel` of the energy that
    ///   flowed and `substep_energy_floor_rel` of the run's scale
    ///   (`Energy::scale_j`). Halved down to `made_energy_min_substep_fraction`
    ///   of the step, below `min_substep_fraction` only while each halving at
    ///   least halves the miss per second; else accepted.
    /// - over budget: |r| > b h E, b = `ledger_budget_rel_per_s`, E the
    ///   largest of the run's scale, the trial's kinetic energy and the drive's
    ///   work to the reference geometry: the trapezoid's O(h^3) error. Halved
    ///   down to `min_substep_fraction`; there sound if |r| is within
    ///   `substep_energy_floor_rel` of the run's scale, else accepted.
    /// - else sound, with the fraction |r| / (b h E) of the budget it used.
    pub(super) fn trial_ledger(&mut self, h: f64, rule: StepRule, dt: f64) -> LedgerVerdict {
        if !self.state.transients.is_empty() && !self.settings.elastic_members {
            return LedgerVerdict::Sound { budget_used: 0.0 };
        }
        let trial = self.trial_energy_residual_j(h, rule);
        let st = &self.settings;
        let (rel, floor_rel) = (st.substep_energy_rel, st.substep_energy_floor_rel);
        let budget_rel_per_s = st.ledger_budget_rel_per_s;
        let scale_j = self.state.energy.scale_j(trial.kinetic_before_j);
        let miss_j = trial.residual_j.abs();
        let shortest = h <= dt * st.min_substep_fraction;
        let halved = self.state.carry.made_energy_halved.take();
        let halve = |why| {
            LedgerVerdict::Retry(Retry {
                why,
                h_s: 0.5 * h,
                rule: StepRule::AverageAcceleration,
            })
        };
        if miss_j > rel * trial.flow_j && miss_j > floor_rel * scale_j {
            // (at the shortest sub-step only while halving helps: a half that
            // misses more than a quarter as much has not halved the miss per
            // second, which is then no O(h^3) error but a power the solution
            // makes near a singular state)
            let helps = match halved {
                Some(prev) if (prev.h_s / h - 2.0).abs() < 1e-9 => miss_j < 0.25 * prev.miss_j,
                _ => true,
            };
            if h > dt * st.made_energy_min_substep_fraction && (!shortest || helps) {
                self.state.carry.made_energy_halved = Some(MadeEnergyHalving { h_s: h, miss_j });
                return halve(RetryWhy::MadeEnergy);
            }
            return LedgerVerdict::AcceptedMadeEnergy;
        }
        // (the budget is the trapezoid's; a backward-Euler trial books its own term)
        if rule == StepRule::BackwardEuler {
            return LedgerVerdict::Sound { budget_used: 0.0 };
        }
        // (the trial's kinetic energy: a run from rest without drive has no scale)
        let budget_j = budget_rel_per_s
            * h
            * scale_j
                .max(trial.kinetic_trial_j)
                .max(self.drive_work_ref_j);
        let budget_used = miss_j / budget_j;
        // (0/0: the control is off, or nothing has an energy yet)
        if budget_used > 1.0 && budget_j > 0.0 {
            if !shortest {
                return halve(RetryWhy::LedgerBudget);
            }
            // (a miss below the ledger's floor is no error it can resolve)
            if miss_j <= floor_rel * scale_j {
                return LedgerVerdict::Sound { budget_used: 0.0 };
            }
            LedgerVerdict::AcceptedOverBudget
        } else {
            LedgerVerdict::Sound {
                budget_used: if budget_j > 0.0 { budget_used } else { 0.0 },
            }
        }
    }

    /// The end of a sound trial: its latches (`finish_substep`), then the
    /// motors (`motors_after_substep`): Ok(whether a motor changed), or the
    /// retry a latch search that failed with the state unchanged asks for (at
    /// the shortest sub-step, or after the state moved on, its error stands).
    fn finish(
        &mut self,
        h: f64,
        rule: StepRule,
        dt: f64,
    ) -> Result<Result<bool, Retry>, SolverError> {
        let before = self.state_mark();
        match self.finish_substep(h, rule) {
            Ok(()) => {}
            Err(e)
                if shorter_may_converge(&e)
                    && self.state_mark() == before
                    && h > dt * self.settings.min_substep_fraction =>
            {
                return Ok(Err(Retry {
                    why: RetryWhy::LatchSearchFailed,
                    h_s: 0.5 * h,
                    rule: StepRule::AverageAcceleration,
                }));
            }
            Err(e) => return Err(e),
        }
        self.motors_after_substep().map(Ok)
    }

    /// What a failing sub-step may have changed: time, events, transients, latches.
    fn state_mark(&self) -> (f64, usize, usize, usize) {
        let s = &self.state;
        (
            s.t_s,
            s.locks.len(),
            s.transients.len(),
            s.locked.iter().filter(|l| **l).count(),
        )
    }

    /// No sleeve crossed its lock without latching (or engaging) between the
    /// positions `x_start` and the state's: else a `MissedLatch` error.
    fn check_nothing_missed(&self) -> Result<(), SolverError> {
        let (model, s) = (&self.model, &self.state);
        let held = |e: usize| super::events::held(s, e);
        let tol = self.settings.lock_tol_m;
        match super::events::crossed_unlatched(model, &held, &self.x_start, &s.x, tol, None) {
            Some(e) => Err(SolverError::MissedLatch {
                element: model.elements[e].name().to_string(),
                t_s: s.t_s,
                gap_m: model.lock_gap_m(e, &s.x),
            }),
            None => Ok(()),
        }
    }

    /// Accepts the computed trial of length h (under `rule`), or its part up
    /// to the first latch, then latches. A dip to a lock the step map does not
    /// confirm (the ring's radial sleeves, shortest at the flat state): the
    /// full trial is restored and the search goes on without that element.
    fn finish_substep(&mut self, h: f64, rule: StepRule) -> Result<(), SolverError> {
        let mut not_real: Vec<usize> = Vec::new();
        loop {
            let Some((target, s_hi)) = self.first_crossing(h, &not_real) else {
                self.accept(h, rule);
                // (a compliant latch turning rigid moves the joints by T/k:
                // nothing may pass its lock on that move)
                if !self.state.transients.is_empty() {
                    self.x_start.copy_from_slice(&self.state.x);
                }
                if self.settle_transients()? > 0 {
                    self.check_nothing_missed()?;
                }
                return Ok(());
            };
            if s_hi < 1.0 {
                self.core.save_trial(&mut self.trial_copy);
            }
            match self.locate_latch(target, (h, rule), s_hi)? {
                Some(h_star) => {
                    self.x_start.copy_from_slice(&self.state.x);
                    self.accept(h_star, rule);
                    self.settle_transients()?;
                    self.latch()?;
                    self.check_nothing_missed()?;
                    return Ok(());
                }
                None => {
                    self.core.stats.fallbacks.dips_rejected += 1;
                    self.core.restore_trial(&self.trial_copy);
                    not_real.push(target);
                }
            }
        }
    }
}

/// Failures a shorter sub-step may cure (near a singular configuration it
/// stays nearer the manifold).
fn shorter_may_converge(e: &SolverError) -> bool {
    matches!(
        e,
        SolverError::NoConvergence { .. }
            | SolverError::Projection { .. }
            | SolverError::NonFinite(_)
            | SolverError::NonFiniteJacobian
    )
}

#[cfg(test)]
mod tests {
    use super::{LedgerVerdict, Retry, RetryWhy};
    use crate::model::generate::{self, MastParams};
    use crate::solver::linsolve::SolveMode;
    use crate::solver::simulator::core::StepRule;
    use crate::solver::{Options, Simulator};

    /// The sub-step energy check: over a sound trial of the deploying mast (cable, pulleys,
    /// damping) the kinetic energy changes by the net work to the trapezoid's error, far below
    /// `substep_energy_rel` of the flow, and the trial passes; with every velocity doubled
    /// (kinetic energy from nowhere) it is caught.
    #[test]
    fn a_trial_that_makes_energy_is_caught() {
        let text = generate::mast(&MastParams::default()).unwrap().to_toml();
        let model = crate::model::parse(&text, "mast.toml").unwrap().model;
        let mut sim = Simulator::new(model, Options::default()).unwrap();
        for _ in 0..20 {
            sim.step(0.05).unwrap();
        }
        let (h, st) = (0.05, sim.settings.clone());
        let rule = StepRule::AverageAcceleration;
        sim.newmark_trial(h, rule, SolveMode::Basic).unwrap();
        let trial = sim.trial_energy_residual_j(h, rule);
        let (residual, flow) = (trial.residual_j, trial.flow_j);
        println!("residual {residual:e} J of a flow {flow:e} J");
        assert!(
            flow > 0.0 && residual.abs() < 1e-2 * flow,
            "{residual} {flow}"
        );
        // (made energy: retried shorter, or accepted at the shortest sub-step)
        let verdict = |sim: &mut Simulator, h_trial: f64| sim.trial_ledger(h_trial, rule, h);
        let halved = |v: LedgerVerdict| {
            matches!(
                v,
                LedgerVerdict::Retry(Retry {
                    why: RetryWhy::MadeEnergy,
                    ..
                })
            )
        };
        assert!(!halved(verdict(&mut sim, h)));
        for v in sim.core.v.iter_mut() {
            *v *= 2.0;
        }
        assert!(halved(verdict(&mut sim, h)));
        // still halved at the other halvings' shortest sub-step...
        let shortest = h * st.min_substep_fraction;
        assert!(halved(verdict(&mut sim, shortest)));
        // ... not where half the length misses as much (a miss not falling with h is no step error)
        assert_eq!(
            verdict(&mut sim, 0.5 * shortest),
            LedgerVerdict::AcceptedMadeEnergy
        );
        // nor at its own shortest: accepted
        assert!(halved(verdict(&mut sim, shortest)));
        assert_eq!(
            verdict(&mut sim, h * st.made_energy_min_substep_fraction),
            LedgerVerdict::AcceptedMadeEnergy
        );
    }
}
