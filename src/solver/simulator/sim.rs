//! The simulator: an immutable model, the state it advances and the
//! workspace it advances it with; construction, the caller's commands, save
//! and restore. The step itself is `step.rs`.

use super::core::{Core, Pose, TrialCopy};
use crate::solver::jacobian::Jacobian;
use crate::solver::linsolve::SolveMode;
use crate::solver::model::Model;
use crate::solver::settings::SolverSettings;
use crate::solver::state::{ModelKey, Snapshot, State};
use crate::solver::stats::SolverStats;
use crate::solver::{Options, RequestError, SolverError, StepLimits};

/// The simulator: an immutable model, the state it advances, and the solver.
pub struct Simulator {
    pub(super) model: Model,
    pub(super) state: State,
    pub(super) core: Core,
    pub(super) opts: Options,
    /// The model's settings (a copy, passed to every stage).
    pub(super) settings: SolverSettings,
    /// The full-step trial while a dip of a sleeve's gap is checked.
    pub(super) trial_copy: TrialCopy,
    /// Positions interpolated inside a step (events), and at a sub-step's
    /// start (the missed-latch check).
    pub(super) interp: Vec<f64>,
    pub(super) x_start: Vec<f64>,
    /// The drive's work to the reference geometry: the ledger budget's scale
    /// before the run's own energy grows to it.
    pub(super) drive_work_ref_j: f64,
    /// The caller's limits on a step's wall time.
    pub(super) limits: StepLimits,
    /// The state at t = 0 (`reset` restores it).
    pub(super) initial: Option<Box<Snapshot>>,
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
    pub(super) fn initialize(&mut self) -> Result<(), SolverError> {
        let (model, st) = (&self.model, &self.settings);
        let mut state = State::at_rest(model);
        for &e in &model.locks {
            state.locked[e] = model.lock_gap_m(e, &model.x0).abs() <= st.lock_tol_m;
        }
        let core = &mut self.core;
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
        core.factor(model, SolveMode::Basic, Pose::PLAIN)?;
        core.a_guess.fill(0.0);
        core.consistent_accelerations(model, &state.cable_tension_cmd_n, st, &mut state.carry)?;
        core.commit_trial(&mut state); // (v = 0, as the state's)
        if st.momentum_projection && super::momentum::free_floating(model, st.momentum_free_rel) {
            state.momentum = Some(super::momentum::at_start(model, &state.x, &state.v));
        }
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

    /// How nearly dependent the constraint rows are at the state
    /// (`mobility::near_dependence`: a dense SVD, up to
    /// `rank_check_max_coords`; None above it).
    pub fn near_dependence(&mut self) -> Option<crate::solver::mobility::NearDependence> {
        if self.model.n_coords() > self.settings.rank_check_max_coords {
            return None;
        }
        self.core.jac.fill(&self.model, &self.state.x);
        Some(crate::solver::mobility::near_dependence(
            &self.model,
            &self.core.jac,
        ))
    }

    /// Sets when a step gives up early (`SolverError::Stopped`, the state at
    /// its last accepted sub-step): a deadline, a cancel flag.
    pub fn set_step_limits(&mut self, limits: StepLimits) {
        self.limits = limits;
    }

    pub(super) fn cable(&self, index: usize) -> Result<&crate::solver::model::Cable, SolverError> {
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
    pub(super) fn restart_accelerations(&mut self) -> Result<(), SolverError> {
        let (model, core, s) = (&self.model, &mut self.core, &mut self.state);
        core.x.copy_from_slice(&s.x);
        core.v.copy_from_slice(&s.v);
        core.a_guess.copy_from_slice(&s.a);
        core.factor(model, SolveMode::Basic, Pose::PLAIN)?;
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

    pub(super) fn all_locked(&self) -> bool {
        self.model.locks.iter().all(|&e| self.state.locked[e])
    }

    /// Mechanisms 3n - rank A of the current constraint set: the backend's rank
    /// (dense: SVD; sparse: its probe's pivots, tested equal to the SVD's on
    /// the bundled models), else an SVD up to `rank_check_max_coords`, else
    /// the Maxwell bound 3n - rows.
    pub(super) fn mechanisms_now(&self) -> usize {
        let n = self.model.n_coords();
        let solver = &self.core.solver;
        let rank = match solver.rank().or_else(|| solver.pivot_rank()) {
            Some(r) => r,
            None if n <= self.settings.rank_check_max_coords => {
                crate::solver::rank::of_jacobian(&self.core.jac)
            }
            None => return n.saturating_sub(self.core.jac.nrows),
        };
        n.saturating_sub(rank) // (a lower bound where a pivot rank exceeds n)
    }
}
