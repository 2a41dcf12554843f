//! The stepping loop, as a pipeline of stages (one module each):
//!
//! ```text
//! step(dt) ─┬─ command changed? ── integrator::consistent_accelerations (restart)
//!           └─ per sub-step h:
//!                integrator::newmark ──── projection (positions, velocities)
//!                                         motor (speed-controlled cables)
//!                events::first_crossing ─ none ──────────────── ledger::accept
//!                        │ a crossing or a touch
//!                events::locate_latch (root of the step map) ── ledger::accept
//!                impact::latch (velocity jump, impulses, mobility)
//!                motor::motors_after_substep (release, engage)
//! ```
//!
//! Compliant elements and engaged compliant latches (`crate::solver::springs`)
//! add their forces in the integrator and their energy in the ledger. With elastic members
//! (`SolverSettings::elastic_members`) the Newmark iteration holds
//! Phi + tau Phidot + c lambda = 0 itself and nothing is projected.
//!
//! `core` holds the buffers, the Jacobian, the backend and the counters;
//! every numeric policy comes from the model's [`SolverSettings`], passed to
//! each stage. Cable commands are piecewise constant with jumps at step
//! starts: a step that starts at a change starts from the accelerations under
//! the new command.

mod core;
mod events;
mod impact;
mod integrator;
mod ledger;
mod motor;
mod newton;
mod projection;

use self::core::{Core, TrialCopy};
use self::events::gap;
use super::jacobian::Jacobian;
use super::linsolve::{SolveMode, SolverKind};
use super::model::Model;
use super::settings::SolverSettings;
use super::state::State;
use super::stats::SolverStats;
use super::{SolverError, StopWhy};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Instant;

/// How to run a model: the backend. Every numeric setting is the model's
/// ([`Model::solver`], from the model file's `[solver]` table).
#[derive(Clone, Debug)]
pub struct Options {
    pub solver: SolverKind,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            solver: SolverKind::Sparse,
        }
    }
}

/// When a step gives up before its end (`SolverError::Stopped`), checked
/// before every sub-step: a step near a singular state can take thousands of
/// sub-steps, and a caller's wall limit or signal must not wait for them.
#[derive(Clone, Debug, Default)]
pub struct StepLimits {
    /// The wall-clock instant past which no sub-step starts.
    pub deadline: Option<Instant>,
    /// A flag that, once raised, stops the step before its next sub-step.
    pub cancel: Option<Arc<AtomicBool>>,
}

impl StepLimits {
    /// Which limit holds now, if any.
    fn reached(&self) -> Option<StopWhy> {
        if self
            .cancel
            .as_ref()
            .is_some_and(|c| c.load(Ordering::Relaxed))
        {
            Some(StopWhy::Cancelled)
        } else if self.deadline.is_some_and(|d| Instant::now() >= d) {
            Some(StopWhy::Deadline)
        } else {
            None
        }
    }
}

/// The simulator: an immutable model, the state it advances, and the solver.
pub struct Simulator {
    model: Model,
    state: State,
    core: Core,
    opts: Options,
    /// The model's settings (a copy, passed to every stage).
    settings: SolverSettings,
    /// A cable command changed since the state's accelerations were computed.
    command_changed: bool,
    /// The full-step trial while a dip of a sleeve's gap is checked.
    trial_copy: TrialCopy,
    /// Positions interpolated inside a step (events), and at a sub-step's
    /// start (the missed-latch check).
    interp: Vec<f64>,
    x_start: Vec<f64>,
    /// The drive's work to the reference geometry
    /// (`Model::drive_work_to_reference_j`): the ledger budget's scale
    /// before the run's own energy grows to it.
    drive_work_ref_j: f64,
    /// The last trial that made energy and was halved: its length and miss
    /// (s, J), for the halvings below the shortest sub-step (`trial_ledger`).
    made_energy_halved: Option<(f64, f64)>,
    /// The caller's limits on a step's wall time.
    limits: StepLimits,
}

impl Simulator {
    pub fn new(model: Model, opts: Options) -> Result<Simulator, SolverError> {
        let settings = model.solver.clone();
        settings.validate().map_err(SolverError::Invalid)?;
        let locked = vec![false; model.elements.len()];
        let core = Core::new(&model, &locked, opts.solver.make());
        let n = model.n_coords();
        let mut sim = Simulator {
            state: State::at_rest(&model),
            model,
            core,
            opts,
            settings,
            command_changed: false,
            trial_copy: TrialCopy::default(),
            interp: vec![0.0; n],
            x_start: vec![0.0; n],
            drive_work_ref_j: 0.0,
            made_energy_halved: None,
            limits: StepLimits::default(),
        };
        sim.drive_work_ref_j = sim.model.drive_work_to_reference_j();
        sim.initialize()?;
        Ok(sim)
    }

    /// Puts the state at t = 0: checks the initial geometry, settles it to
    /// roundoff, latches elements that start at their lock, and computes the
    /// consistent initial accelerations and mobility.
    fn initialize(&mut self) -> Result<(), SolverError> {
        let (model, st) = (&self.model, &self.settings);
        let mut state = State::at_rest(model);
        for &e in &model.locks {
            state.locked[e] = gap(model, e, &model.x0).abs() <= st.lock_tol_m;
        }
        let core = &mut self.core;
        core.prev_h = None;
        core.backward_euler = false;
        core.blend_start_held = false;
        // (a reset in a compliant latch's transient: its spring goes with it)
        core.element_springs.release_latches(None);
        core.waiting.clear();
        core.motor.take_modes(&state);
        core.set_pattern(model, &state.locked);
        core.x.copy_from_slice(&model.x0);
        if let Some((e, row, residual_m)) = model.initial_violation(st.initial_tol_m) {
            let el = &model.elements[e];
            return Err(SolverError::InitialViolation {
                element: el.name().to_string(),
                kind: el.kind(),
                row,
                residual_m,
                limit_m: st.initial_tol_m,
            });
        }
        core.project_positions(model, st, SolveMode::Basic)?;
        core.v.fill(0.0);
        core.factor(model, SolveMode::Basic)?;
        core.a_guess.fill(0.0);
        core.consistent_accelerations(model, &state.cable_tension_cmd_n, st)?;
        state.x.copy_from_slice(&core.x);
        state.a.copy_from_slice(&core.a);
        state.lambda.clone_from(&core.lambda);
        state.cables.clone_from(&core.cables);
        state.max_violation_m = core.violation_m;
        self.state = state;
        self.state.mechanisms = self.mechanisms_now();
        self.state.deployed = !self.model.locks.is_empty() && self.all_locked();
        self.command_changed = false;
        Ok(())
    }

    /// Back to the initial state (same model, the model's cable tensions).
    /// The solver's counters go on counting.
    pub fn reset(&mut self) -> Result<(), SolverError> {
        self.initialize()
    }

    pub fn model(&self) -> &Model {
        &self.model
    }
    pub fn state(&self) -> &State {
        &self.state
    }
    pub fn jacobian(&self) -> &Jacobian {
        &self.core.jac
    }
    /// Factorization requests so far (made or served by a kept one).
    pub fn factorizations(&self) -> u64 {
        self.core.stats.factorizations + self.core.stats.factorizations_reused
    }
    /// What the solver did so far (since the simulator was made).
    pub fn solver_stats(&self) -> &SolverStats {
        &self.core.stats
    }
    /// The backend's own counters, for benchmarks.
    pub fn solver_diagnostics(&self) -> String {
        self.core.solver.diagnostics()
    }

    /// The state's multipliers (member forces, N, row order of the current
    /// Jacobian; a bar's multiplier is minus its tension) with redundant
    /// rows sharing by least work: among all multipliers with the state's
    /// joint forces A^T lambda, the one minimizing sum L_i/(EA_i) lambda_i^2
    /// (`crate::solver::least_work`). Solver-independent (the sparse
    /// backend's `State::lambda` gives the whole share to the rows it keeps);
    /// two least-squares solves with a backend of its own, so the trajectory
    /// does not depend on how often it is called (the node calls it at its
    /// publish rate).
    pub fn least_work_multipliers(&mut self) -> Result<Vec<f64>, SolverError> {
        let (model, core, s) = (&self.model, &mut self.core, &self.state);
        core.least_work_multipliers(model, self.opts.solver, &s.x, &s.lambda)?;
        Ok(core.mu.clone())
    }

    /// The force through a compliant latch while it engages (N, tension
    /// positive: T = k (l - L_lock) + c ldot); None for a sleeve that is
    /// free, latched rigid, or whose transient has settled.
    pub fn latch_spring_force_n(&self, element: usize) -> Option<f64> {
        self.state
            .transients
            .iter()
            .find(|t| t.element == element)
            .map(|t| t.force_n)
    }

    /// Sets when a step gives up early (`SolverError::Stopped`, the state
    /// left at its last accepted sub-step): a wall-clock deadline, a cancel
    /// flag. None by default.
    pub fn set_step_limits(&mut self, limits: StepLimits) {
        self.limits = limits;
    }

    fn cable(&self, index: usize) -> Result<&super::model::Cable, SolverError> {
        let no_such = || SolverError::Invalid(format!("no cable with index {index}"));
        self.model.cables.get(index).ok_or_else(no_such)
    }

    /// Sets a cable's motor-end tension from the next step on (a motor
    /// under speed control returns to tension control).
    pub fn set_cable_tension(&mut self, cable: usize, tension_n: f64) -> Result<(), SolverError> {
        let c = self.cable(cable)?;
        if !(tension_n.is_finite() && tension_n >= 0.0 && tension_n <= c.max_tension_n) {
            return Err(SolverError::Invalid(format!(
                "tension {tension_n} N for cable `{}` must be finite, >= 0 and <= {} N",
                c.name, c.max_tension_n
            )));
        }
        self.set_cable_speed(cable, None)?;
        self.state.motors[cable].tension_cmd_n = tension_n;
        if self.state.cable_tension_cmd_n[cable] != tension_n {
            self.state.cable_tension_cmd_n[cable] = tension_n;
            self.command_changed = true;
        }
        Ok(())
    }

    /// Accelerations (and multipliers, cable tensions) of the state under the
    /// current commands. The tension is piecewise constant in time with its
    /// jumps at step starts, so a step that starts at a command change must
    /// start from A(t_n+) under the new command; Newmark from the old A_n
    /// would apply half the change over that step (the average-acceleration
    /// rule takes a force jump for a ramp).
    fn restart_accelerations(&mut self) -> Result<(), SolverError> {
        let (model, core) = (&self.model, &mut self.core);
        core.x.copy_from_slice(&self.state.x);
        core.v.copy_from_slice(&self.state.v);
        core.a_guess.copy_from_slice(&self.state.a);
        core.factor(model, SolveMode::Basic)?;
        core.consistent_accelerations(model, &self.state.cable_tension_cmd_n, &self.settings)?;
        // The Newmark predictor extrapolates the accelerations of the last
        // steps: shift them by the jump, which the command makes persist.
        for i in 0..core.a.len() {
            let jump = core.a[i] - self.state.a[i];
            core.a_prev[i] += jump;
            core.a_prev2[i] += jump;
            core.a_prev3[i] += jump;
            core.a_prev4[i] += jump;
        }
        let s = &mut self.state;
        s.a.copy_from_slice(&core.a);
        s.lambda.clone_from(&core.lambda);
        for (o, n) in s.cables.iter_mut().zip(&core.cables) {
            o.clone_from(n);
        }
        self.command_changed = false;
        Ok(())
    }

    fn all_locked(&self) -> bool {
        self.model.locks.iter().all(|&e| self.state.locked[e])
    }

    /// Mechanisms 3n - rank A of the current constraint set: the rank the
    /// solver reveals (dense: SVD; sparse: the pivots of its redundant-row probe
    /// at the last factorization, equal to the SVD rank on the bundled models:
    /// tested), else a dense SVD up to `rank_check_max_coords`, else the
    /// Maxwell lower bound 3n - rows.
    fn mechanisms_now(&self) -> usize {
        let n = self.model.n_coords();
        let solver = &self.core.solver;
        let rank = match solver.rank().or_else(|| solver.pivot_rank()) {
            Some(r) => r,
            None if n <= self.settings.rank_check_max_coords => {
                super::rank::of_jacobian(&self.core.jac)
            }
            None => return n.saturating_sub(self.core.jac.nrows),
        };
        // (a pivot rank can exceed n on a nearly singular giant truss: see
        // pivot_rank; the count is then a lower bound)
        n.saturating_sub(rank)
    }

    /// Advances the state by exactly `dt` seconds, latching elements on the
    /// way. Returns the number of latch events in this step (the entries it
    /// added to the lock table). A non-finite constraint Jacobian names the
    /// element whose rows it is in.
    pub fn step(&mut self, dt: f64) -> Result<usize, SolverError> {
        self.step_stages(dt).map_err(|e| match e {
            SolverError::NonFiniteJacobian => {
                SolverError::NonFinite(self.core.jac.describe_non_finite(&self.model))
            }
            e => e,
        })
    }

    /// `step`'s stages: sub-steps (integrator, events, impact, ledger) to
    /// the step's end.
    fn step_stages(&mut self, dt: f64) -> Result<usize, SolverError> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(SolverError::Invalid(format!(
                "time step {dt} s must be positive and finite"
            )));
        }
        // (a step that failed inside left its last trial's rule)
        self.core.backward_euler = false;
        if self.command_changed {
            self.restart_accelerations()?;
        }
        let t_end = self.state.t_s + dt;
        // (the step's latch events: the new entries of the lock table)
        let locks_before = self.state.locks.len();
        let mut substeps = 0;
        // Sub-step length: halved when the Newmark iteration does not converge
        // (near singular configurations), doubled back after each success.
        let mut h_try = dt;
        // (late in a run a step's sub-steps may add up to one or two units
        // of roundoff of t short of its end: no sub-step of that length,
        // whose energy the ledger cannot resolve, is taken)
        let end_tol_s = (self.settings.step_end_rel * dt).max(8.0 * f64::EPSILON * t_end.abs());
        // (the next trial repeats a blend entry's under the backward-Euler rule)
        let mut backward_euler_next = false;
        while t_end - self.state.t_s > end_tol_s {
            self.core.backward_euler = std::mem::take(&mut backward_euler_next);
            // (the sub-steps after a restart, elastic members:
            // `Core::restart_substeps_left`, the k-th at most 2^k times the
            // first, also where a step's end falls among them)
            let st = &self.settings;
            let restart_left = self.core.restart_substeps_left;
            if restart_left > 0 && st.elastic_members {
                self.core.backward_euler = true;
                let k = st.restart_substeps.saturating_sub(restart_left);
                let cap = st.restart_substep_fraction * dt * 2f64.powi(k as i32);
                h_try = h_try.min(cap);
            }
            if let Some(why) = self.limits.reached() {
                return Err(SolverError::Stopped {
                    t_s: self.state.t_s,
                    why,
                });
            }
            substeps += 1;
            if substeps > self.settings.max_substeps + 4 * self.model.locks.len() {
                return Err(SolverError::Invalid(format!(
                    "more than {} sub-steps or latch events inside the step ending at t = {t_end:.6} s \
                     (raise [solver] max_substeps, or use a smaller --dt)",
                    self.settings.max_substeps
                )));
            }
            let h = h_try
                .min(t_end - self.state.t_s)
                .min(self.transient_step_s());
            let budget_used = match self.trial(h, dt)? {
                Trial::Sound { budget_used } => budget_used,
                Trial::Retry { h_s } => {
                    h_try = h_s;
                    continue;
                }
                Trial::RepeatBackwardEuler => {
                    backward_euler_next = true;
                    h_try = h;
                    continue;
                }
            };
            // (a failure that left the state as it was: in a latch search,
            // whose steps to the crossing did not converge; retried shorter
            // like the trial itself, the crossing is then searched inside a
            // shorter step, or falls after it; at the shortest sub-step, or
            // after the state moved on, in a latch's own projection, it
            // stands)
            let before = self.state_mark();
            match self.finish_substep(h) {
                Ok(()) => {}
                Err(e)
                    if shorter_may_converge(&e)
                        && self.state_mark() == before
                        && h > dt * self.settings.min_substep_fraction =>
                {
                    self.core.stats.fallbacks.substep_halvings += 1;
                    h_try = 0.5 * h;
                    continue;
                }
                Err(e) => return Err(e),
            }
            if self.motors_after_substep()? {
                h_try = h_try.min(h);
                continue;
            }
            // (doubling h multiplies the miss by 8 and its budget by 2)
            if budget_used <= 0.25 {
                h_try = (2.0 * h_try).min(dt);
            }
        }
        self.core.backward_euler = false;
        self.state.t_s = t_end.max(self.state.t_s);
        self.state.steps += 1;
        self.core.stats.steps += 1;
        Ok(self.state.locks.len() - locks_before)
    }

    /// A trial sub-step of length h (stage `integrator`) and the gates on
    /// it, each of which retries the sub-step (the one retry route: a
    /// shorter h, or the same h once more under the backward-Euler rule).
    fn trial(&mut self, h: f64, dt: f64) -> Result<Trial, SolverError> {
        let (st, base) = (&self.settings, SolveMode::Basic);
        let above_shortest = h > dt * st.min_substep_fraction;
        match self.core.newmark(&self.model, &self.state, h, st, base) {
            // (a projection that fails at the trial is retried shorter too:
            // near a singular configuration the shorter step stays nearer
            // the manifold; so is a trial whose iterates diverged to
            // non-finite values from the finite accepted state)
            Err(e) if shorter_may_converge(&e) && above_shortest => {
                self.core.stats.fallbacks.substep_halvings += 1;
                return Ok(Trial::Retry { h_s: 0.5 * h });
            }
            Err(e) => return Err(e),
            Ok(()) => {}
        }
        // The trial stepped over the friction blend's fast transient
        // (a damper whose time constant the step exceeds many times),
        // which the average-acceleration rule leaves ringing. With
        // elastic members: the same step again under the backward-Euler
        // rule, which leaves it at rest (amplification 1 / (1 + 2x)
        // against (1 - x) / (1 + x), x = h/2 times the damper's rate),
        // the ledger booking that rule's own term (`integrator_work_j`).
        // With rigid members, whose projections that term does not
        // cover, the transient is resolved by halving h (docs/solver.md).
        if self.core.blend_entry && !self.core.backward_euler {
            if st.elastic_members {
                self.core.stats.fallbacks.blend_entry_backward_euler += 1;
                return Ok(Trial::RepeatBackwardEuler);
            }
            if above_shortest {
                self.core.stats.fallbacks.blend_entry_halvings += 1;
                return Ok(Trial::Retry { h_s: 0.5 * h });
            }
        }
        if let Some(h_cut) = self.contact_cut(h, dt) {
            self.core.stats.contact_cuts += 1;
            return Ok(Trial::Retry { h_s: h_cut });
        }
        Ok(match self.trial_ledger(h, dt) {
            TrialLedger::MadeEnergy => {
                self.core.stats.fallbacks.substep_energy_halvings += 1;
                Trial::Retry { h_s: 0.5 * h }
            }
            TrialLedger::OverBudget => {
                self.core.stats.ledger_halvings += 1;
                Trial::Retry { h_s: 0.5 * h }
            }
            TrialLedger::Sound { budget_used } => Trial::Sound { budget_used },
        })
    }

    /// The computed trial of length h crosses a unilateral spring's contact
    /// (onset or release: `contact_distance_m` d changes sign from the
    /// state to the trial): the sub-step length that ends `contact_cut_rel`
    /// of h past the first crossing, s h with s = d0 / (d0 - d1) (linear in
    /// d). None where nothing crosses, the crossing lies within
    /// `contact_cut_rel` of the trial's end, or the cut would be shorter
    /// than the shortest sub-step.
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

    /// The ledger's verdict on the trial sub-step of length h (stage
    /// `ledger`), from its residual r (the change of kinetic energy less the
    /// work booked over it). Not checked in compliant latches' transients
    /// (the run's balance check covers them).
    /// - `MadeEnergy`: |r| beyond `substep_energy_rel` of the energy that
    ///   flowed in it and beyond `substep_energy_floor_rel` of the run's
    ///   energy scale (`Energy::scale_j`): a Newmark solution that made
    ///   energy no force accounts for. Down to
    ///   `made_energy_min_substep_fraction` of the step, below the shortest
    ///   sub-step of the other halvings while each halving at least halves
    ///   the miss per second; else `Sound` (counted as
    ///   `substep_energy_accepted`).
    /// - `OverBudget`: |r| > b h E with b = `ledger_budget_rel_per_s` and E
    ///   the largest of the run's scale, the trial's kinetic energy and the
    ///   drive's work to the reference geometry: the trapezoid's error (of
    ///   order h^3) in fast motion. Above the shortest sub-step
    ///   (`min_substep_fraction`); there `Sound` (counted as
    ///   `ledger_budget_exceeded`).
    /// - `Sound`, with the fraction |r| / (b h E) of the budget it used.
    fn trial_ledger(&mut self, h: f64, dt: f64) -> TrialLedger {
        if !self.state.transients.is_empty() {
            return TrialLedger::Sound { budget_used: 0.0 };
        }
        let trial = self.trial_energy_residual_j(h);
        let st = &self.settings;
        let (rel, floor_rel) = (st.substep_energy_rel, st.substep_energy_floor_rel);
        let budget_rel_per_s = st.ledger_budget_rel_per_s;
        let scale_j = self.state.energy.scale_j(trial.kinetic_before_j);
        let miss_j = trial.residual_j.abs();
        let shortest = h <= dt * st.min_substep_fraction;
        let halved = self.made_energy_halved.take();
        if miss_j > rel * trial.flow_j && miss_j > floor_rel * scale_j {
            // (at and below the shortest sub-step, only while halving helps:
            // a trial of half the length that misses more than a quarter as
            // much has not halved the miss per second; that energy is not
            // the step length's error, which falls as h^3, but a power the
            // solution makes near the singular state, and shorter sub-steps
            // would add up as much of it over the same time)
            let helps = match halved {
                Some((h_prev, miss_prev)) if (h_prev / h - 2.0).abs() < 1e-9 => {
                    miss_j < 0.25 * miss_prev
                }
                _ => true,
            };
            if h > dt * st.made_energy_min_substep_fraction && (!shortest || helps) {
                self.made_energy_halved = Some((h, miss_j));
                return TrialLedger::MadeEnergy;
            }
            self.core.stats.fallbacks.substep_energy_accepted += 1;
            return TrialLedger::Sound { budget_used: 0.0 };
        }
        // (the budget controls the average-acceleration rule's error, which
        // falls as h^3; a backward-Euler trial books its own term, and
        // halving it only hands the transient back to the other rule)
        if self.core.backward_euler {
            return TrialLedger::Sound { budget_used: 0.0 };
        }
        // (the trial's own kinetic energy too: a run from rest, with no
        // drive, has no scale before its first sub-step)
        let budget_j = budget_rel_per_s
            * h
            * scale_j
                .max(trial.kinetic_trial_j)
                .max(self.drive_work_ref_j);
        let budget_used = miss_j / budget_j;
        // (0/0: the control is off, or nothing has an energy yet)
        if budget_used > 1.0 && budget_j > 0.0 {
            if !shortest {
                return TrialLedger::OverBudget;
            }
            self.core.stats.fallbacks.ledger_budget_exceeded += 1;
            TrialLedger::Sound { budget_used: 0.0 }
        } else {
            TrialLedger::Sound {
                budget_used: if budget_j > 0.0 { budget_used } else { 0.0 },
            }
        }
    }

    /// What a sub-step changes of the state before it fails, if anything:
    /// its time, latch events, engaging latches and latched elements.
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
        let held = |e: usize| s.locked[e] || self.engaged(e);
        let tol = self.settings.lock_tol_m;
        match events::crossed_unlatched(model, &held, &self.x_start, &s.x, tol, None) {
            Some(e) => Err(SolverError::MissedLatch {
                element: model.elements[e].name().to_string(),
                t_s: s.t_s,
                gap_m: gap(model, e, &s.x),
            }),
            None => Ok(()),
        }
    }

    /// The trial sub-step of length h is computed: accept it, or the part of
    /// it up to the first latch (then latch). Elements whose interpolated dip
    /// to their lock the step map did not confirm (e.g. the ring's radial
    /// sleeves, whose length is least at the flat state its diagonals latch
    /// in): the full-step trial is restored and the search goes on without
    /// them.
    fn finish_substep(&mut self, h: f64) -> Result<(), SolverError> {
        let mut not_real: Vec<usize> = Vec::new();
        loop {
            let Some((target, s_hi)) = self.first_crossing(h, &not_real) else {
                self.accept(h);
                // a compliant latch turning rigid moves the joints back by its
                // deflection T/k: nothing may pass its lock on that move
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
            match self.locate_latch(target, h, s_hi)? {
                Some(h_star) => {
                    self.x_start.copy_from_slice(&self.state.x);
                    self.accept(h_star);
                    self.settle_transients()?;
                    self.latch()?;
                    // Nothing may have passed its lock without latching
                    // (a target short of its lock goes on in the next sub-step).
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

/// What a trial sub-step calls for (`Simulator::trial`).
enum Trial {
    /// It passes the gates, having used this fraction of its miss budget.
    Sound { budget_used: f64 },
    /// A sub-step of this length instead.
    Retry { h_s: f64 },
    /// The same length again under the backward-Euler rule.
    RepeatBackwardEuler,
}

/// The ledger's verdict on a trial sub-step (`Simulator::trial_ledger`).
enum TrialLedger {
    /// It passes, having used this fraction of its miss budget.
    Sound { budget_used: f64 },
    /// It made or lost energy no force accounts for: halved (a fallback).
    MadeEnergy,
    /// It missed by more than its budget: halved (step-size control).
    OverBudget,
}

/// Failures a shorter sub-step may cure: a Newmark iteration that did not
/// converge, a projection that failed, iterates or a Jacobian gone
/// non-finite (near a singular configuration the shorter step stays nearer
/// the manifold).
fn shorter_may_converge(e: &SolverError) -> bool {
    matches!(
        e,
        SolverError::NoConvergence { .. }
            | SolverError::Projection { .. }
            | SolverError::NonFinite(_)
            | SolverError::NonFiniteJacobian
    )
}
