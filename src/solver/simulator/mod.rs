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
//! Compliant elements and latches (`crate::solver::springs`) add their forces
//! in the integrator and their energy in the ledger. With elastic members the
//! Newmark iteration holds Phi + tau Phidot + c lambda = 0 and nothing is
//! projected. `core` holds the buffers, the Jacobian, the backend and the
//! counters; every numeric policy is the model's [`SolverSettings`].

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
use super::linsolve::SolveMode;
use super::model::Model;
use super::settings::SolverSettings;
use super::state::{MadeEnergyHalving, ModelKey, Snapshot, State};
use super::stats::SolverStats;
use super::{Options, RequestError, SolverError, StepLimits};

/// The simulator: an immutable model, the state it advances, and the solver.
pub struct Simulator {
    model: Model,
    state: State,
    core: Core,
    opts: Options,
    /// The model's settings (a copy, passed to every stage).
    settings: SolverSettings,
    /// The full-step trial while a dip of a sleeve's gap is checked.
    trial_copy: TrialCopy,
    /// Positions interpolated inside a step (events), and at a sub-step's
    /// start (the missed-latch check).
    interp: Vec<f64>,
    x_start: Vec<f64>,
    /// The drive's work to the reference geometry: the ledger budget's scale
    /// before the run's own energy grows to it.
    drive_work_ref_j: f64,
    /// The caller's limits on a step's wall time.
    limits: StepLimits,
    /// The state at t = 0 (`reset` restores it).
    initial: Option<Box<Snapshot>>,
}

impl Simulator {
    pub fn new(model: Model, opts: Options) -> Result<Simulator, SolverError> {
        let settings = model.solver.clone();
        settings.validate().map_err(SolverError::Settings)?;
        let locked = vec![false; model.elements.len()];
        let core = Core::new(&model, &locked, opts.solver.make());
        let n = model.n_coords();
        let mut sim = Simulator {
            state: State::at_rest(&model),
            model,
            core,
            opts,
            settings,
            trial_copy: TrialCopy::default(),
            interp: vec![0.0; n],
            x_start: vec![0.0; n],
            drive_work_ref_j: 0.0,
            limits: StepLimits::default(),
            initial: None,
        };
        sim.drive_work_ref_j = sim.model.drive_work_to_reference_j();
        sim.initialize()?;
        sim.initial = Some(Box::new(sim.save()));
        Ok(sim)
    }

    /// The state at t = 0: the initial geometry checked and settled to
    /// roundoff, elements at their lock latched, consistent accelerations.
    fn initialize(&mut self) -> Result<(), SolverError> {
        let (model, st) = (&self.model, &self.settings);
        let mut state = State::at_rest(model);
        for &e in &model.locks {
            state.locked[e] = gap(model, e, &model.x0).abs() <= st.lock_tol_m;
        }
        let core = &mut self.core;
        core.backward_euler = false;
        core.element_springs.release_latches(None);
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
        core.consistent_accelerations(model, &state.cable_tension_cmd_n, st, &mut state.carry)?;
        core.commit_trial(&mut state); // (v = 0, as the state's)
        self.state = state;
        self.state.mechanisms = self.mechanisms_now();
        self.state.deployed = !self.model.locks.is_empty() && self.all_locked();
        Ok(())
    }

    /// Back to the initial state (same model, the model's cable tensions):
    /// its snapshot, so that the run from there is the first run again, to
    /// the bit. The solver's counters go on counting.
    pub fn reset(&mut self) -> Result<(), SolverError> {
        let (Some(initial), stats) = (self.initial.take(), self.core.stats.clone()) else {
            return self.initialize();
        };
        let restored = self.restore(&initial);
        self.initial = Some(initial);
        self.core.stats = stats;
        restored
    }

    pub fn model(&self) -> &Model {
        &self.model
    }

    /// The state with everything else a step carries to the next: the
    /// solver's counters and its kept factorizations (`Snapshot`).
    pub fn save(&self) -> Snapshot {
        Snapshot {
            model: ModelKey::of(&self.model),
            state: self.state.clone(),
            solver_stats: self.core.stats.clone(),
            kept: self.core.solver.kept(),
        }
    }

    /// Continues from a snapshot of a simulator of the same model (its name
    /// and sizes are checked): the state, the counters, and the kept
    /// factorizations made again from what they were made from, so that the
    /// steps that follow are those the saved run took, to the bit. The
    /// caller's step limits stay.
    pub fn restore(&mut self, snap: &Snapshot) -> Result<(), SolverError> {
        let key = ModelKey::of(&self.model);
        if snap.model != key {
            return Err(SolverError::Request(RequestError::SnapshotOfAnotherModel {
                snapshot: snap.model.clone(),
                model: key,
            }));
        }
        snap.state.check_sizes(&self.model)?;
        self.state.clone_from(&snap.state);
        let (model, core, s) = (&self.model, &mut self.core, &self.state);
        core.stats.clone_from(&snap.solver_stats);
        core.set_pattern(model, &s.locked);
        core.backward_euler = false;
        core.element_springs.release_latches(None);
        for tr in &s.transients {
            let (k, c) = (tr.stiffness_n_per_m, tr.damping_n_s_per_m);
            core.element_springs.engage_latch(model, tr.element, k, c);
        }
        core.motor.take_modes(s);
        core.motor.conflicted.fill(false);
        core.least_work = None;
        core.solver.restore_kept(&core.jac, &snap.kept)
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

    /// The state's multipliers (member forces, N, in the Jacobian's row order;
    /// a bar's is minus its tension) shared among redundant rows by least
    /// work: of all with the state's joint forces A^T lambda, the one
    /// minimizing sum L_i/(EA_i) lambda_i^2 (`crate::solver::least_work`).
    /// On a backend of its own: the trajectory does not depend on how often
    /// it is called.
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

    /// Sets when a step gives up early (`SolverError::Stopped`, the state at
    /// its last accepted sub-step): a deadline, a cancel flag.
    pub fn set_step_limits(&mut self, limits: StepLimits) {
        self.limits = limits;
    }

    fn cable(&self, index: usize) -> Result<&super::model::Cable, SolverError> {
        let no_such = || {
            SolverError::Request(RequestError::NoSuchCable {
                index,
                cables: self.model.cables.len(),
            })
        };
        self.model.cables.get(index).ok_or_else(no_such)
    }

    /// Sets a cable's motor-end tension from the next step on (a motor
    /// under speed control returns to tension control).
    pub fn set_cable_tension(&mut self, cable: usize, tension_n: f64) -> Result<(), SolverError> {
        let c = self.cable(cable)?;
        if !(tension_n.is_finite() && tension_n >= 0.0 && tension_n <= c.max_tension_n) {
            return Err(SolverError::Request(RequestError::Tension {
                cable: c.name.clone(),
                tension_n,
                max_tension_n: c.max_tension_n,
            }));
        }
        self.set_cable_speed(cable, None)?;
        self.state.motors[cable].tension_cmd_n = tension_n;
        if self.state.cable_tension_cmd_n[cable] != tension_n {
            self.state.cable_tension_cmd_n[cable] = tension_n;
            self.state.carry.command_changed = true;
        }
        Ok(())
    }

    /// Accelerations, multipliers and cable tensions of the state under the
    /// current commands: a command jumps at a step start, so the step starts
    /// from A(t_n+) (from the old A_n the trapezoid would take it for a ramp).
    fn restart_accelerations(&mut self) -> Result<(), SolverError> {
        let (model, core, s) = (&self.model, &mut self.core, &mut self.state);
        core.x.copy_from_slice(&s.x);
        core.v.copy_from_slice(&s.v);
        core.a_guess.copy_from_slice(&s.a);
        core.factor(model, SolveMode::Basic)?;
        core.consistent_accelerations(model, &s.cable_tension_cmd_n, &self.settings, &mut s.carry)?;
        // (the jump persists: the predictor's history moves with it)
        s.carry.accel_history.shift(&s.a, &core.a);
        s.a.copy_from_slice(&core.a);
        s.lambda.clone_from(&core.lambda);
        for (o, n) in s.cables.iter_mut().zip(&core.cables) {
            o.clone_from(n);
        }
        s.carry.command_changed = false;
        Ok(())
    }

    fn all_locked(&self) -> bool {
        self.model.locks.iter().all(|&e| self.state.locked[e])
    }

    /// Mechanisms 3n - rank A of the current constraint set: the backend's rank
    /// (dense: SVD; sparse: its probe's pivots, tested equal to the SVD's on
    /// the bundled models), else an SVD up to `rank_check_max_coords`, else
    /// the Maxwell bound 3n - rows.
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
        n.saturating_sub(rank) // (a lower bound where a pivot rank exceeds n)
    }

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

    /// `step`'s stages, per sub-step: the trial and its gates (`trial`), the
    /// latches inside it (`finish_substep`), the motors
    /// (`motors_after_substep`). The one retry route is the sub-step: cut by
    /// a failure or a gate, or taken again under the backward-Euler rule;
    /// doubled back after one that used at most a quarter of its ledger
    /// budget (doubling h multiplies the miss by 8 and its budget by 2).
    fn step_stages(&mut self, dt: f64) -> Result<usize, SolverError> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(SolverError::Request(RequestError::TimeStep { dt_s: dt }));
        }
        // (a step that failed inside left its last trial's rule)
        self.core.backward_euler = false;
        self.core.motor.conflicted.fill(false);
        if self.state.carry.command_changed {
            self.restart_accelerations()?;
        }
        let t_end = self.state.t_s + dt;
        let locks_before = self.state.locks.len();
        // (sub-steps may add up to a few units of roundoff short of t_end:
        // none that short, whose energy the ledger cannot resolve, is taken)
        let end_tol_s = (self.settings.step_end_rel * dt).max(8.0 * f64::EPSILON * t_end.abs());
        let (mut h_try, mut substeps, mut backward_euler_next) = (dt, 0, false);
        while t_end - self.state.t_s > end_tol_s {
            substeps += 1;
            self.check_step_limits(substeps, t_end)?;
            self.core.backward_euler = std::mem::take(&mut backward_euler_next);
            h_try = self.restart_substep_cap(h_try, dt);
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
            // (a failure that left the state as it was, in a latch search's
            // steps to the crossing, is retried shorter like the trial; one
            // at the shortest sub-step, or after the state moved on, stands)
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

    /// The caller's limits (`StepLimits`), and at most `max_substeps` sub-steps
    /// (four more per lockable element, for latch events) in a step.
    fn check_step_limits(&self, substeps: usize, t_end: f64) -> Result<(), SolverError> {
        if let Some(why) = self.limits.reached() {
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

    /// Elastic members: the sub-steps after a restart are backward-Euler, the
    /// k-th at most 2^k `restart_substep_fraction` dt, also where a step's end
    /// falls among them (`Core::restart_substeps_left`).
    fn restart_substep_cap(&mut self, h_try: f64, dt: f64) -> f64 {
        let (st, left) = (&self.settings, self.state.carry.restart_substeps_left);
        if left == 0 || !st.elastic_members {
            return h_try;
        }
        self.core.backward_euler = true;
        let k = st.restart_substeps.saturating_sub(left);
        h_try.min(st.restart_substep_fraction * dt * 2f64.powi(k as i32))
    }

    /// A Newmark trial of length h from the state into the core (stage
    /// `integrator`), its Newton flag carried in the state (`Carry::newton_last`).
    fn newmark_trial(&mut self, h: f64, mode: SolveMode) -> Result<(), SolverError> {
        self.core.newton_last = self.state.carry.newton_last;
        let (model, st) = (&self.model, &self.settings);
        let result = self.core.newmark(model, &self.state, h, st, mode);
        self.state.carry.newton_last = self.core.newton_last;
        result
    }

    /// A trial sub-step of length h (stage `integrator`) and its gates, each
    /// of which retries it: shorter, or once more under the backward-Euler rule.
    fn trial(&mut self, h: f64, dt: f64) -> Result<Trial, SolverError> {
        let (st, base) = (&self.settings, SolveMode::Basic);
        let above_shortest = h > dt * st.min_substep_fraction;
        let trial = self.newmark_trial(h, base);
        let st = &self.settings;
        match trial {
            // (a failed projection or iterates gone non-finite too: near a
            // singular state the shorter step stays nearer the manifold)
            Err(e) if shorter_may_converge(&e) && above_shortest => {
                self.core.stats.fallbacks.substep_halvings += 1;
                return Ok(Trial::Retry { h_s: 0.5 * h });
            }
            Err(e) => return Err(e),
            Ok(()) => {}
        }
        // A blend entry: the trial stepped over the friction blend's fast
        // transient, which the average acceleration leaves ringing
        // (docs/solver.md, Sub-steps). Elastic members: the same h under the
        // backward-Euler rule, amplification 1 / (1 + 2x) against
        // (1 - x) / (1 + x), x = h r / 2 for the transient's rate r, its own
        // term booked (`integrator_work_j`); rigid
        // members, whose projections that term does not cover: h halved.
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
        Ok(self.trial_ledger(h, dt))
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
    /// over it (not in compliant latches' transients: the run's balance
    /// covers them):
    /// - made energy: |r| beyond `substep_energy_rel` of the energy that
    ///   flowed and `substep_energy_floor_rel` of the run's scale
    ///   (`Energy::scale_j`). Halved down to `made_energy_min_substep_fraction`
    ///   of the step, below `min_substep_fraction` only while each halving at
    ///   least halves the miss per second; else accepted
    ///   (`substep_energy_accepted`).
    /// - over budget: |r| > b h E, b = `ledger_budget_rel_per_s`, E the
    ///   largest of the run's scale, the trial's kinetic energy and the drive's
    ///   work to the reference geometry: the trapezoid's O(h^3) error. Halved
    ///   down to `min_substep_fraction` (`ledger_halvings`); there accepted
    ///   (`ledger_budget_exceeded`).
    /// - else sound, with the fraction |r| / (b h E) of the budget it used.
    fn trial_ledger(&mut self, h: f64, dt: f64) -> Trial {
        if !self.state.transients.is_empty() {
            return Trial::Sound { budget_used: 0.0 };
        }
        let trial = self.trial_energy_residual_j(h);
        let st = &self.settings;
        let (rel, floor_rel) = (st.substep_energy_rel, st.substep_energy_floor_rel);
        let budget_rel_per_s = st.ledger_budget_rel_per_s;
        let scale_j = self.state.energy.scale_j(trial.kinetic_before_j);
        let miss_j = trial.residual_j.abs();
        let shortest = h <= dt * st.min_substep_fraction;
        let halved = self.state.carry.made_energy_halved.take();
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
                self.core.stats.fallbacks.substep_energy_halvings += 1;
                return Trial::Retry { h_s: 0.5 * h };
            }
            self.core.stats.fallbacks.substep_energy_accepted += 1;
            return Trial::Sound { budget_used: 0.0 };
        }
        // (the budget is the trapezoid's; a backward-Euler trial books its own term)
        if self.core.backward_euler {
            return Trial::Sound { budget_used: 0.0 };
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
                self.core.stats.ledger_halvings += 1;
                return Trial::Retry { h_s: 0.5 * h };
            }
            self.core.stats.fallbacks.ledger_budget_exceeded += 1;
            Trial::Sound { budget_used: 0.0 }
        } else {
            Trial::Sound {
                budget_used: if budget_j > 0.0 { budget_used } else { 0.0 },
            }
        }
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
        let held = |e: usize| impact::held(s, e);
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

    /// Accepts the computed trial of length h, or its part up to the first
    /// latch, then latches. A dip to a lock the step map does not confirm
    /// (the ring's radial sleeves, shortest at the flat state): the full trial
    /// is restored and the search goes on without that element.
    fn finish_substep(&mut self, h: f64) -> Result<(), SolverError> {
        let mut not_real: Vec<usize> = Vec::new();
        loop {
            let Some((target, s_hi)) = self.first_crossing(h, &not_real) else {
                self.accept(h);
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
            match self.locate_latch(target, h, s_hi)? {
                Some(h_star) => {
                    self.x_start.copy_from_slice(&self.state.x);
                    self.accept(h_star);
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

/// What a trial sub-step calls for (`Simulator::trial`).
enum Trial {
    /// It passes the gates, having used this fraction of its miss budget.
    Sound { budget_used: f64 },
    /// A sub-step of this length instead.
    Retry { h_s: f64 },
    /// The same length again under the backward-Euler rule.
    RepeatBackwardEuler,
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
