//! The stepping loop: Newmark average-acceleration integration of the constrained
//! equations of motion, projection onto the constraint manifold, and latch events
//! located inside the step.
//!
//! One step of length h from (X_n, V_n, A_n):
//!   X_{n+1} = X_n + h V_n + h^2/4 (A_n + A_{n+1}),   V_{n+1} = V_n + h/2 (A_n + A_{n+1}),
//! with A_{n+1} the constrained acceleration at (X_{n+1}, V_{n+1}), found by fixed-point
//! iteration (each iterate is one constrained solve). Then X_{n+1} is projected
//! back onto Phi = 0 and V_{n+1} onto A V = 0 by mass-orthogonal corrections
//! (Bayo and Ledesma), so no constraint drift accumulates.
//!
//! Latches: when a sleeve's gap g = l - L_lock changes sign inside the step, or
//! the step's cubic Hermite interpolant shows it touching zero and turning back
//! (both ends on the same side; confirmed on the step map), the step is redone
//! with the length h* at which g(h*) = 0 (root of the step map itself, by the
//! Illinois method), the sleeve becomes a bar, and the velocities jump to the
//! new constraint manifold by the mass-orthogonal projection (an inelastic
//! latch). The rest of the step follows from there.
//!
//! Cable commands are piecewise constant with jumps at step starts: a step
//! that starts at a change starts from the accelerations under the new
//! command.

use super::cable::{self, CableEval};
use super::jacobian::Jacobian;
use super::linsolve::{ConstraintSolver, SolverKind};
use super::model::Model;
use super::state::{Energy, LockEvent, State};
use super::SolverError;

#[derive(Clone, Debug)]
pub struct Options {
    pub solver: SolverKind,
    /// Positions are projected until max |Phi| is below this (m).
    pub projection_tol_m: f64,
    /// Sleeves within this distance of their design length at a latch event latch together (m).
    pub lock_tol_m: f64,
    /// The latch time is refined until |g| is below this (m).
    pub root_tol_m: f64,
    pub max_newmark_iters: usize,
    /// An initial geometry whose residual exceeds this is rejected (m).
    pub initial_tol_m: f64,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            solver: SolverKind::Sparse,
            projection_tol_m: 1e-12,
            lock_tol_m: 1e-9,
            root_tol_m: 1e-13,
            max_newmark_iters: 60,
            initial_tol_m: 1e-6,
        }
    }
}

/// Largest model (coordinates) whose mobility the simulator counts by a dense SVD
/// when the solver reveals no rank (at the start and at latches).
const RANK_CHECK_MAX_COORDS: usize = 1500;

/// Safety factor on the contraction rate estimated from one ratio of
/// successive Newmark changes (see `Core::newmark`).
const RHO_SAFETY: f64 = 20.0;

/// Smallest sub-step, as a fraction of the requested step, tried before a
/// non-converging Newmark iteration is reported.
const MIN_SUBSTEP: f64 = 1.0 / 1024.0;

/// Buffers and the factorization, reused across steps.
struct Core {
    jac: Jacobian,
    solver: Box<dyn ConstraintSolver>,
    q: Vec<f64>,
    c: Vec<f64>,
    r: Vec<f64>,
    dx: Vec<f64>,
    mu: Vec<f64>,
    // trial state of the step being computed
    x: Vec<f64>,
    v: Vec<f64>,
    a: Vec<f64>,
    a_guess: Vec<f64>,
    lambda: Vec<f64>,
    cables: Vec<CableEval>,
    violation_m: f64,
    pub factorizations: u64,
    /// Set (to the step length) while a Newmark step treats damping implicitly.
    implicit_h: Option<f64>,
    inv_mass_eff: Vec<f64>,
    v_star: Vec<f64>,
    /// Per cable, the pulley sliding speeds at the step start, and whether the
    /// current iteration takes the friction direction from them.
    friction_sliding: Vec<Vec<f64>>,
    lagged_friction: bool,
    /// Accelerations at the start of the last accepted step, and its length (None
    /// after a latch or a reset: no extrapolation across a velocity jump).
    a_prev: Vec<f64>,
    prev_h: Option<f64>,
    a_prev2: Vec<f64>,
    prev_h2: Option<f64>,
    /// The backend that computes minimum-norm multipliers on request
    /// (`Simulator::min_norm_multipliers`), made at the first request.
    aux_solver: Option<Box<dyn ConstraintSolver>>,
}

impl Core {
    fn new(model: &Model, locked: &[bool], solver: Box<dyn ConstraintSolver>) -> Core {
        let n = model.n_coords();
        let jac = Jacobian::pattern(model, locked);
        let m = jac.nrows;
        Core {
            jac,
            solver,
            q: vec![0.0; n],
            c: vec![0.0; m],
            r: vec![0.0; m],
            dx: vec![0.0; n],
            mu: vec![0.0; m],
            x: model.x0.clone(),
            v: vec![0.0; n],
            a: vec![0.0; n],
            a_guess: vec![0.0; n],
            lambda: vec![0.0; m],
            cables: model.cables.iter().map(CableEval::for_cable).collect(),
            violation_m: 0.0,
            factorizations: 0,
            implicit_h: None,
            inv_mass_eff: model.inv_mass.clone(),
            v_star: vec![0.0; n],
            friction_sliding: model
                .cables
                .iter()
                .map(|c| vec![0.0; c.path.len().saturating_sub(2)])
                .collect(),
            lagged_friction: false,
            a_prev: vec![0.0; n],
            prev_h: None,
            a_prev2: vec![0.0; n],
            prev_h2: None,
            aux_solver: None,
        }
    }

    fn set_pattern(&mut self, model: &Model, locked: &[bool]) {
        self.jac = Jacobian::pattern(model, locked);
        let m = self.jac.nrows;
        for b in [&mut self.c, &mut self.r, &mut self.mu, &mut self.lambda] {
            b.resize(m, 0.0);
        }
    }

    fn factor(&mut self, model: &Model) -> Result<(), SolverError> {
        self.jac.fill(model, &self.x);
        self.factorizations += 1;
        let w = if self.implicit_h.is_some() {
            &self.inv_mass_eff
        } else {
            &model.inv_mass
        };
        self.solver.factor(&self.jac, w)
    }

    /// Applied forces Q at the trial (x, v): cables, damping, gravity. The cable
    /// inertia term uses `a_guess` as the acceleration estimate.
    fn applied_forces(&mut self, model: &Model, cmd: &[f64]) {
        self.q.fill(0.0);
        for (ci, c) in model.cables.iter().enumerate() {
            let direction = if self.lagged_friction {
                Some(self.friction_sliding[ci].as_slice())
            } else {
                None
            };
            cable::evaluate_with_direction(
                c,
                cmd[ci],
                &self.x,
                &self.v,
                Some(&self.a_guess),
                direction,
                &mut self.cables[ci],
            );
            cable::add_forces(c, &self.cables[ci], &self.x, &mut self.q);
        }
        let g = model.gravity_m_s2;
        let damp_v = if self.implicit_h.is_some() {
            &self.v_star
        } else {
            &self.v
        };
        for i in 0..self.q.len() {
            self.q[i] += model.mass[i] * g[i % 3] - model.damping_n_s_per_m * damp_v[i];
        }
    }

    /// Constrained accelerations at the trial (x, v) into `a` and `lambda`.
    fn accelerations(
        &mut self,
        model: &Model,
        cmd: &[f64],
        refactor: bool,
    ) -> Result<(), SolverError> {
        if refactor {
            self.factor(model)?;
        }
        self.applied_forces(model, cmd);
        self.jac.adot_xdot(model, &self.x, &self.v, &mut self.c);
        let w = if self.implicit_h.is_some() {
            &self.inv_mass_eff
        } else {
            &model.inv_mass
        };
        self.solver.accelerations(
            &self.jac,
            w,
            &self.q,
            &self.c,
            &mut self.a,
            &mut self.lambda,
        );
        if self.a.iter().any(|v| !v.is_finite()) {
            return Err(SolverError::NonFinite("accelerations".into()));
        }
        Ok(())
    }

    /// Constrained accelerations at the trial (x, v) from a current
    /// factorization, where nothing better than `a_guess` is known of them (the
    /// start, a latch, a command change). Cables with mass take their inertia
    /// term from `a_guess`: the evaluation is repeated to its fixed point (a
    /// contraction like the Newmark iteration's).
    fn consistent_accelerations(&mut self, model: &Model, cmd: &[f64]) -> Result<(), SolverError> {
        self.accelerations(model, cmd, false)?;
        if !model.cables.iter().any(|c| c.line_density_kg_per_m > 0.0) {
            return Ok(());
        }
        for _ in 0..20 {
            let (mut change, mut scale) = (0.0f64, 0.0f64);
            for (a, g) in self.a.iter().zip(&self.a_guess) {
                change = change.max((a - g).abs());
                scale = scale.max(a.abs());
            }
            if change <= 1e-13 * scale {
                break;
            }
            self.a_guess.copy_from_slice(&self.a);
            self.accelerations(model, cmd, false)?;
        }
        Ok(())
    }

    /// Newton iterations X <- X - M^-1 A^T S^+ Phi(X) until max |Phi| <= tol.
    fn project_positions(
        &mut self,
        model: &Model,
        tol: f64,
        factored: bool,
    ) -> Result<(), SolverError> {
        let mut factored = factored;
        // Newton with basic solves converges on the kept rows; where the dropped
        // ones are only nearly redundant (e.g. every sleeve just latched at the
        // flat deployed state) their residual stalls, and the least-squares
        // (minimum-norm) iteration takes over.
        let (mut min_norm, mut last) = (false, f64::INFINITY);
        let result = (|| {
            for _ in 0..25 {
                self.jac.residual(model, &self.x, &mut self.r);
                self.violation_m = self.r.iter().fold(0.0, |m, v| m.max(v.abs()));
                if self.violation_m <= tol {
                    return Ok(());
                }
                if !min_norm
                    && self.violation_m > 0.25 * last
                    && !self.solver.is_min_norm()
                    && self.solver.set_min_norm(true)
                {
                    min_norm = true;
                    factored = false;
                    if self.violation_m > last {
                        // the last basic correction made things worse: undo it
                        for (x, d) in self.x.iter_mut().zip(&self.dx) {
                            *x += d;
                        }
                        self.jac.residual(model, &self.x, &mut self.r);
                        self.violation_m = self.r.iter().fold(0.0, |m, v| m.max(v.abs()));
                    }
                }
                last = self.violation_m;
                if !factored {
                    self.factor(model)?;
                }
                factored = false;
                self.subtract_correction(model, false);
            }
            if self.violation_m <= 1e3 * tol {
                return Ok(()); // converged to roundoff of a large structure
            }
            Err(SolverError::Projection {
                violation_m: self.violation_m,
            })
        })();
        if min_norm {
            self.solver.set_min_norm(false);
        }
        result
    }

    /// V <- V - M^-1 A^T S^+ A V (needs a current factorization at x). Returns the
    /// multipliers in `mu` and A V (before) in `r`.
    fn project_velocities(&mut self, model: &Model) -> Result<(), SolverError> {
        self.jac.mul(&self.v, &mut self.r);
        self.subtract_correction(model, true);
        // A V is consistent by construction, so what is left of it is roundoff
        // alike on every row, unless the rows a basic solve dropped are not
        // redundant any more (a rank change the probe has not seen): then their
        // residual stands out and the projection is redone with least squares.
        // Dropped rows that are only nearly redundant leave up to ~5e-12 |A||v|
        // (18-ring near its flat state; ~6e-13 on a 180-ring at any time);
        // that is accepted: redoing every such step cost the 180-ring 15x.
        // (`c` is scratch until the accelerations that follow recompute it.)
        let Some(kept) = self.solver.kept_rows() else {
            return Ok(());
        };
        if self.solver.is_min_norm() {
            return Ok(());
        }
        self.jac.mul(&self.v, &mut self.c);
        let all = self.c.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let on_kept = kept.iter().fold(0.0f64, |m, &i| m.max(self.c[i].abs()));
        let vmax = self.v.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let amax = self.jac.values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        if all <= (100.0 * on_kept).max(1e-10 * amax * vmax) || !self.solver.set_min_norm(true) {
            return Ok(());
        }
        for (v, d) in self.v.iter_mut().zip(&self.dx) {
            *v += d;
        }
        let redone = self
            .factor(model)
            .map(|()| self.subtract_correction(model, true));
        self.solver.set_min_norm(false);
        redone
    }

    /// The mass-orthogonal correction dX = M^-1 A^T S^+ r of r in `r`
    /// (multipliers into `mu`), subtracted from the velocities or the positions.
    fn subtract_correction(&mut self, model: &Model, velocities: bool) {
        self.solver.correction(
            &self.jac,
            &model.inv_mass,
            &self.r,
            &mut self.dx,
            &mut self.mu,
        );
        let target = if velocities { &mut self.v } else { &mut self.x };
        for (t, d) in target.iter_mut().zip(&self.dx) {
            *t -= d;
        }
    }

    /// The minimum-norm multipliers S^+ (A M^-1 A^T lambda) of the state
    /// (x, lambda) into `mu`: the same joint forces A^T lambda, split among
    /// redundant rows by least squares. Returns false (and leaves `mu`) where
    /// the backend's multipliers are minimum-norm already.
    fn min_norm_multipliers(
        &mut self,
        model: &Model,
        kind: SolverKind,
        x: &[f64],
        lambda: &[f64],
    ) -> Result<bool, SolverError> {
        // A second instance of the backend does the least-squares solve, so
        // the stepping solver's kept factorizations, counters and re-probe
        // schedule stay as they were: the trajectory does not depend on how
        // often this is called (the node calls it at its publish rate).
        let aux = self.aux_solver.get_or_insert_with(|| kind.make());
        if !aux.set_min_norm(true) {
            return Ok(false);
        }
        self.x.copy_from_slice(x);
        self.jac.fill(model, &self.x);
        // r = S lambda, consistent by construction
        self.jac.mul_t(lambda, &mut self.dx);
        for (d, w) in self.dx.iter_mut().zip(&model.inv_mass) {
            *d *= w;
        }
        self.jac.mul(&self.dx, &mut self.r);
        aux.factor(&self.jac, &model.inv_mass)?;
        aux.correction(
            &self.jac,
            &model.inv_mass,
            &self.r,
            &mut self.dx,
            &mut self.mu,
        );
        Ok(true)
    }

    /// One Newmark step of length h from `s` into the trial state.
    fn newmark(
        &mut self,
        model: &Model,
        s: &State,
        h: f64,
        opts: &Options,
    ) -> Result<(), SolverError> {
        let cmd = &s.cable_tension_cmd_n;
        // Predictor: A_{n+1} extrapolated from the last step starts of equal length,
        // quadratically from three (error O(h^3): ~0.5 fewer iterations per step on
        // the ring than linear), linearly from two, else A_n. Only the start of the
        // fixed-point iteration changes, not its converged result.
        if self.prev_h == Some(h) && self.prev_h2 == Some(h) {
            for i in 0..self.a_guess.len() {
                self.a_guess[i] = 3.0 * s.a[i] - 3.0 * self.a_prev[i] + self.a_prev2[i];
            }
        } else if self.prev_h == Some(h) {
            for i in 0..self.a_guess.len() {
                self.a_guess[i] = 2.0 * s.a[i] - self.a_prev[i];
            }
        } else {
            self.a_guess.copy_from_slice(&s.a);
        }
        self.implicit_h = None;
        // Viscous damping C (diagonal) is taken implicitly: with
        // V_{n+1} = V* + h/2 A_{n+1}, V* = V_n + h/2 A_n, the damping force -C V_{n+1}
        // moves to the left: (M + h/2 C) A_{n+1} = Q - C V* + A^T lambda. The
        // fixed-point iteration then contracts however stiff the damping is.
        let c_damp = model.damping_n_s_per_m;
        for (w, m) in self.inv_mass_eff.iter_mut().zip(&model.mass) {
            *w = 1.0 / (m + 0.5 * h * c_damp);
        }
        self.implicit_h = Some(h);
        for i in 0..self.v_star.len() {
            self.v_star[i] = s.v[i] + 0.5 * h * s.a[i];
        }
        for (dst, src) in self.friction_sliding.iter_mut().zip(&s.cables) {
            dst.copy_from_slice(&src.sliding_m_s);
        }
        let amax = s.a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let mut converged = false;
        // The friction direction follows the current iterate. Near zero sliding
        // the steep blend of the direction can make the iteration cycle between
        // two iterates; once the change stops shrinking for a few iterations the
        // step restarts with the direction taken from the step start.
        self.lagged_friction = false;
        let mut min_norm = false;
        let (mut last_change, mut stalls) = (f64::INFINITY, 0);
        let (mut best_change, mut no_progress) = (f64::INFINITY, 0);
        for _ in 0..opts.max_newmark_iters {
            for i in 0..self.x.len() {
                let asum = s.a[i] + self.a_guess[i];
                self.x[i] = s.x[i] + h * s.v[i] + 0.25 * h * h * asum;
                self.v[i] = s.v[i] + 0.5 * h * asum;
            }
            if let Err(e) = self.accelerations(model, cmd, true) {
                self.implicit_h = None;
                if min_norm {
                    self.solver.set_min_norm(false);
                }
                return Err(e);
            }
            let mut change = 0.0f64;
            let mut scale = amax;
            for i in 0..self.a.len() {
                change = change.max((self.a[i] - self.a_guess[i]).abs());
                scale = scale.max(self.a[i].abs());
            }
            self.a_guess.copy_from_slice(&self.a);
            // Error of this iterate: |a_k - a*| <= rho / (1 - rho) |a_k - a_{k-1}|
            // for a contraction of rate rho. One ratio of successive changes
            // underestimates rho (the first change is dominated by the
            // predictor's error in fast-converging components): the true error
            // exceeded the estimate by up to 13x on the bundled models, hence
            // the factor RHO_SAFETY (with it, iterating on past every such stop
            // found none beyond the tolerance); and never more than the change
            // itself (the plain criterion).
            // (rho is 0 after the first iterate, whose last change is infinite)
            let rho = change / last_change;
            let error = if rho > 0.0 && rho < 0.1 {
                (RHO_SAFETY * rho / (1.0 - rho) * change).min(change)
            } else {
                change
            };
            if error <= 1e-12 * scale || 0.25 * error * h * h <= 1e-14 {
                converged = true;
                break;
            }
            stalls = if change >= 0.9 * last_change {
                stalls + 1
            } else {
                0
            };
            last_change = change;
            // (no progress on the best iterate so far also catches a cycle whose
            // change alternates up and down)
            no_progress = if change >= 0.9 * best_change {
                no_progress + 1
            } else {
                0
            };
            best_change = best_change.min(change);
            if (stalls >= 4 || no_progress >= 4)
                && !min_norm
                && !self.solver.is_min_norm()
                && self.solver.set_min_norm(true)
            {
                // Basic solves (redundant rows dropped) make a less contractive
                // map than least-squares ones where the iterates leave the
                // manifold; retry the step with the latter first.
                min_norm = true;
                self.a_guess.copy_from_slice(&s.a);
                (last_change, stalls) = (f64::INFINITY, 0);
                (best_change, no_progress) = (f64::INFINITY, 0);
            } else if stalls >= 4 && !self.lagged_friction && !model.cables.is_empty() {
                self.lagged_friction = true;
                self.a_guess.copy_from_slice(&s.a);
                (last_change, stalls) = (f64::INFINITY, 0);
            }
        }
        if min_norm {
            self.solver.set_min_norm(false);
        }
        self.implicit_h = None;
        let lagged = self.lagged_friction;
        self.lagged_friction = false;
        if !converged {
            return Err(SolverError::NoConvergence { t_s: s.t_s + h });
        }
        for i in 0..self.x.len() {
            let asum = s.a[i] + self.a_guess[i];
            self.x[i] = s.x[i] + h * s.v[i] + 0.25 * h * h * asum;
            self.v[i] = s.v[i] + 0.5 * h * asum;
        }
        self.project_positions(model, opts.projection_tol_m, false)?;
        self.factor(model)?;
        self.project_velocities(model)?;
        // A_{n+1} (and the segment tensions the energy ledger books) under the
        // friction directions the iteration converged with: evaluated with the
        // current directions instead, a pulley sliding slower than its slip
        // speed gets a friction force the step never applied, so the next
        // step starts from accelerations inconsistent with this one (the
        // rerouted-cable ring booked a balance error of 6.5e-2 by t = 0.1 s).
        self.lagged_friction = lagged;
        let result = self.accelerations(model, cmd, false);
        self.lagged_friction = false;
        result
    }
}

/// A copy of a trial step, to come back to after trials of other lengths.
#[derive(Default)]
struct TrialCopy {
    x: Vec<f64>,
    v: Vec<f64>,
    a: Vec<f64>,
    lambda: Vec<f64>,
    cables: Vec<CableEval>,
    violation_m: f64,
}

impl Core {
    fn save_trial(&self, to: &mut TrialCopy) {
        to.x.clone_from(&self.x);
        to.v.clone_from(&self.v);
        to.a.clone_from(&self.a);
        to.lambda.clone_from(&self.lambda);
        to.cables.clone_from(&self.cables);
        to.violation_m = self.violation_m;
    }

    fn restore_trial(&mut self, from: &TrialCopy) {
        self.x.clone_from(&from.x);
        self.v.clone_from(&from.v);
        self.a.clone_from(&from.a);
        self.lambda.clone_from(&from.lambda);
        self.cables.clone_from(&from.cables);
        self.violation_m = from.violation_m;
    }
}

/// The simulator: an immutable model, the state it advances, and the solver.
pub struct Simulator {
    model: Model,
    state: State,
    core: Core,
    opts: Options,
    /// A cable command changed since the state's accelerations were computed.
    command_changed: bool,
    /// The full-step trial while a dip of a sleeve's gap is checked.
    trial_copy: TrialCopy,
}

fn gap(model: &Model, e: usize, x: &[f64]) -> f64 {
    model.elements[e].lock_gap(x).unwrap_or(f64::NAN)
}

/// Cubic Hermite interpolant of joint j at fraction s of a step of length h.
fn hermite(x0: &[f64], v0: &[f64], x1: &[f64], v1: &[f64], h: f64, s: f64, j: usize) -> [f64; 3] {
    let (s2, s3) = (s * s, s * s * s);
    let (h00, h10, h01, h11) = (
        2.0 * s3 - 3.0 * s2 + 1.0,
        s3 - 2.0 * s2 + s,
        -2.0 * s3 + 3.0 * s2,
        s3 - s2,
    );
    let mut p = [0.0; 3];
    for k in 0..3 {
        let i = 3 * j + k;
        p[k] = h00 * x0[i] + h10 * h * v0[i] + h01 * x1[i] + h11 * h * v1[i];
    }
    p
}

impl Simulator {
    pub fn new(model: Model, opts: Options) -> Result<Simulator, SolverError> {
        let locked = vec![false; model.elements.len()];
        let core = Core::new(&model, &locked, opts.solver.make());
        let mut sim = Simulator {
            state: blank_state(&model),
            model,
            core,
            opts,
            command_changed: false,
            trial_copy: TrialCopy::default(),
        };
        sim.initialize()?;
        Ok(sim)
    }

    /// Puts the state at t = 0: checks the initial geometry, settles it to
    /// roundoff, latches sleeves that start at their design length, and computes
    /// the consistent initial accelerations and mobility.
    fn initialize(&mut self) -> Result<(), SolverError> {
        let model = &self.model;
        let mut state = blank_state(model);
        for &e in &model.locks {
            state.locked[e] = gap(model, e, &model.x0).abs() <= self.opts.lock_tol_m;
        }
        let core = &mut self.core;
        core.prev_h = None;
        core.set_pattern(model, &state.locked);
        core.x.copy_from_slice(&model.x0);
        if let Some((e, row, residual_m)) = model.initial_violation(self.opts.initial_tol_m) {
            let el = &model.elements[e];
            return Err(SolverError::InitialViolation {
                element: el.name().to_string(),
                kind: el.kind(),
                row,
                residual_m,
            });
        }
        core.project_positions(model, self.opts.projection_tol_m, false)?;
        core.v.fill(0.0);
        core.factor(model)?;
        core.a_guess.fill(0.0);
        core.consistent_accelerations(model, &state.cable_tension_cmd_n)?;
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
    pub fn reset(&mut self) -> Result<(), SolverError> {
        self.initialize()
    }

    pub fn model(&self) -> &Model {
        &self.model
    }
    pub fn state(&self) -> &State {
        &self.state
    }
    pub fn options(&self) -> &Options {
        &self.opts
    }
    pub fn jacobian(&self) -> &Jacobian {
        &self.core.jac
    }
    pub fn factorizations(&self) -> u64 {
        self.core.factorizations
    }
    /// The solver's counters, for benchmarks.
    pub fn solver_diagnostics(&self) -> String {
        self.core.solver.diagnostics()
    }

    /// The state's multipliers with the minimum-norm split among redundant
    /// rows (member forces of a statically indeterminate latched truss, e.g.
    /// sleeves that latched together): solver-independent. The sparse
    /// backend's `State::lambda` gives the whole share to the rows it keeps
    /// (same joint forces); this costs one least-squares solve there and
    /// nothing with the dense backend, whose multipliers are minimum-norm.
    pub fn min_norm_multipliers(&mut self) -> Result<Vec<f64>, SolverError> {
        let (model, core, s) = (&self.model, &mut self.core, &self.state);
        if core.min_norm_multipliers(model, self.opts.solver, &s.x, &s.lambda)? {
            Ok(core.mu.clone())
        } else {
            Ok(s.lambda.clone())
        }
    }

    /// Sets a cable's motor-end tension from the next step on.
    pub fn set_cable_tension(&mut self, cable: usize, tension_n: f64) -> Result<(), SolverError> {
        let c = self
            .model
            .cables
            .get(cable)
            .ok_or_else(|| SolverError::Invalid(format!("no cable with index {cable}")))?;
        if !(tension_n.is_finite() && tension_n >= 0.0 && tension_n <= c.max_tension_n) {
            return Err(SolverError::Invalid(format!(
                "tension {tension_n} N for cable `{}` must be finite, >= 0 and <= {} N",
                c.name, c.max_tension_n
            )));
        }
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
        core.factor(model)?;
        core.consistent_accelerations(model, &self.state.cable_tension_cmd_n)?;
        // The Newmark predictor extrapolates the accelerations of the last
        // steps: shift them by the jump, which the command makes persist.
        for i in 0..core.a.len() {
            let jump = core.a[i] - self.state.a[i];
            core.a_prev[i] += jump;
            core.a_prev2[i] += jump;
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
    /// tested), else a dense SVD up to RANK_CHECK_MAX_COORDS, else the Maxwell
    /// lower bound 3n - rows.
    fn mechanisms_now(&self) -> usize {
        let n = self.model.n_coords();
        let solver = &self.core.solver;
        let rank = match solver.rank().or_else(|| solver.pivot_rank()) {
            Some(r) => r,
            None if n <= RANK_CHECK_MAX_COORDS => super::mobility::rank(&self.core.jac),
            None => return n.saturating_sub(self.core.jac.nrows),
        };
        // (a pivot rank can exceed n on a nearly singular giant truss: see
        // pivot_rank; the count is then a lower bound)
        n.saturating_sub(rank)
    }

    /// Advances the state by exactly `dt` seconds, latching sleeves on the way.
    /// Returns the number of latch events in this step.
    pub fn step(&mut self, dt: f64) -> Result<usize, SolverError> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(SolverError::Invalid(format!(
                "time step {dt} s must be positive and finite"
            )));
        }
        if self.command_changed {
            self.restart_accelerations()?;
        }
        let t_end = self.state.t_s + dt;
        let mut events = 0;
        let mut guard = 0;
        // Sub-step length: halved when the Newmark iteration does not converge
        // (near singular configurations), doubled back after each success.
        let mut h_try = dt;
        while t_end - self.state.t_s > 1e-12 * dt {
            guard += 1;
            if guard > 10_000 + 4 * self.model.locks.len() {
                return Err(SolverError::Invalid(
                    "too many sub-steps or latch events inside one step".into(),
                ));
            }
            let h = h_try.min(t_end - self.state.t_s);
            match self.core.newmark(&self.model, &self.state, h, &self.opts) {
                Err(SolverError::NoConvergence { .. }) if h > dt * MIN_SUBSTEP => {
                    h_try = 0.5 * h;
                    continue;
                }
                other => other?,
            }
            // Sleeves whose interpolated dip to zero the step map did not
            // confirm (e.g. the ring's radial sleeves, whose length is least
            // at the flat state its diagonals latch in): the full-step trial is
            // restored and the search goes on without them.
            let mut not_real: Vec<usize> = Vec::new();
            loop {
                let Some((target, s_hi)) = self.first_crossing(h, &not_real) else {
                    self.accept(h);
                    break;
                };
                if s_hi < 1.0 {
                    self.core.save_trial(&mut self.trial_copy);
                }
                // The trial steps of the root search all lie just short of
                // a latch, typically the flat deployed state where redundant
                // rows are only nearly redundant: least-squares solves there.
                let _ = self.core.solver.set_min_norm(true);
                let located = self.locate_latch(target, h, s_hi);
                let _ = self.core.solver.set_min_norm(false);
                match located? {
                    Some(h_star) => {
                        self.accept(h_star);
                        events += self.latch()?;
                        break;
                    }
                    None => {
                        self.core.restore_trial(&self.trial_copy);
                        not_real.push(target);
                    }
                }
            }
            h_try = (2.0 * h_try).min(dt);
        }
        self.state.t_s = t_end.max(self.state.t_s);
        self.state.steps += 1;
        Ok(events)
    }

    /// The unlocked sleeve whose gap reaches zero first in the trial step, by the
    /// Hermite interpolant of the step, with the fraction s_hi of the step by
    /// which it has crossed: 1 when the gap changes sign over the step, less
    /// when it touches zero and turns back inside the step (both ends on the
    /// same side; s_hi is then the interpolant's turning point).
    /// Dips of the sleeves in `no_dips` (found not real on the step map) are
    /// not considered again; their sign changes are.
    fn first_crossing(&self, h: f64, no_dips: &[usize]) -> Option<(usize, f64)> {
        let (s, c) = (&self.state, &self.core);
        let mut best: Option<(f64, usize, f64)> = None;
        for &e in &self.model.locks {
            if s.locked[e] {
                continue;
            }
            let (g0, g1) = (gap(&self.model, e, &s.x), gap(&self.model, e, &c.x));
            if g0 == 0.0 || g0.is_nan() || g1.is_nan() {
                continue;
            }
            // A sign change over the step, or else a touch and turn: the gap
            // closes at the start (g0 gdot0 < 0) and opens at the end
            // (g1 gdot1 > 0); then the interpolant's extremum (golden section
            // on the g0-signed gap, unimodal over one turn) decides.
            let el = &self.model.elements[e];
            let crossed = g0 * g1 <= 0.0;
            if !crossed {
                let rate = |x: &[f64], v: &[f64]| el.extension(x, v).map_or(0.0, |(_, r)| r);
                if no_dips.contains(&e)
                    || !(g0 * rate(&s.x, &s.v) < 0.0 && g1 * rate(&c.x, &c.v) > 0.0)
                {
                    continue;
                }
            }
            let (ja, jb) = (el.joints()[0], el.joints()[1]);
            let (pa0, pb0) = (super::elements::at(&s.x, ja), super::elements::at(&s.x, jb));
            let lock_len = (pb0 - pa0).norm() - g0;
            let g_at = |sf: f64| {
                let (pa, pb) = (
                    hermite(&s.x, &s.v, &c.x, &c.v, h, sf, ja),
                    hermite(&s.x, &s.v, &c.x, &c.v, h, sf, jb),
                );
                ((pb[0] - pa[0]).powi(2) + (pb[1] - pa[1]).powi(2) + (pb[2] - pa[2]).powi(2)).sqrt()
                    - lock_len
            };
            let s_hi = if crossed {
                1.0
            } else {
                let f = |sf: f64| g0.signum() * g_at(sf);
                let r = 0.5 * (5f64.sqrt() - 1.0);
                let (mut lo, mut hi) = (0.0, 1.0);
                let (mut m1, mut m2) = (hi - r * (hi - lo), lo + r * (hi - lo));
                let (mut f1, mut f2) = (f(m1), f(m2));
                for _ in 0..60 {
                    if f1 < f2 {
                        hi = m2;
                        (m2, f2) = (m1, f1);
                        m1 = hi - r * (hi - lo);
                        f1 = f(m1);
                    } else {
                        lo = m1;
                        (m1, f1) = (m2, f2);
                        m2 = lo + r * (hi - lo);
                        f2 = f(m2);
                    }
                }
                let s_min = 0.5 * (lo + hi);
                if f(s_min) >= 0.0 {
                    continue;
                }
                s_min
            };
            // bisection on the interpolant for the fraction of the step
            let (mut lo, mut hi) = (0.0, s_hi);
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if g_at(mid) * g0 > 0.0 {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            if best.map_or(true, |(sb, _, _)| hi < sb) {
                best = Some((hi, e, s_hi));
            }
        }
        best.map(|(_, e, s_hi)| (e, s_hi))
    }

    /// Finds h* in (0, h] with gap_target(step(h*)) = 0 by the Illinois method on the
    /// step map, leaving the trial at h*. If another sleeve turns out to cross
    /// earlier, it becomes the target.
    ///
    /// `s_hi` < 1 (a touch and turn inside the step): the step map is first
    /// evaluated at s_hi h for a bracket. A gap there within the latch
    /// tolerance is a touch: h* = s_hi h. A gap that has not crossed after
    /// all (the interpolant's dip was not real), or a failed step there, gives
    /// None, with the trial left at whatever it last computed.
    fn locate_latch(
        &mut self,
        mut target: usize,
        h: f64,
        s_hi: f64,
    ) -> Result<Option<f64>, SolverError> {
        let mut b = h;
        if s_hi < 1.0 {
            b = s_hi * h;
            if self
                .core
                .newmark(&self.model, &self.state, b, &self.opts)
                .is_err()
            {
                return Ok(None);
            }
            // A sleeve that has crossed by then comes first (e.g. the ring's
            // diagonals, just before its radial sleeves touch at the flat state).
            if let Some(other) = self.crossed_by(b, target) {
                target = other;
            } else {
                let (g0, gb) = (
                    gap(&self.model, target, &self.state.x),
                    gap(&self.model, target, &self.core.x),
                );
                if gb.abs() <= self.opts.lock_tol_m {
                    return Ok(Some(b));
                }
                if gb * g0 > 0.0 {
                    return Ok(None);
                }
            }
        }
        let g0 = gap(&self.model, target, &self.state.x);
        let (mut a, mut ga) = (0.0, g0);
        let mut gb = gap(&self.model, target, &self.core.x);
        let mut side = 0i32;
        let mut h_star = b;
        for _ in 0..100 {
            // Illinois step (regula falsi with halving of the stale end)
            let mut m = (a * gb - b * ga) / (gb - ga);
            if !(m > a && m < b) {
                m = 0.5 * (a + b);
            }
            self.core.newmark(&self.model, &self.state, m, &self.opts)?;
            let gm = gap(&self.model, target, &self.core.x);
            h_star = m;
            // did another sleeve already cross before m?
            if let Some(other) = self.crossed_by(m, target) {
                target = other;
                let g0o = gap(&self.model, target, &self.state.x);
                a = 0.0;
                ga = g0o;
                b = m;
                gb = gap(&self.model, target, &self.core.x);
                side = 0;
                continue;
            }
            if gm.abs() <= self.opts.root_tol_m || (b - a) <= 1e-15 * h {
                return Ok(Some(h_star));
            }
            if gm * ga > 0.0 {
                a = m;
                ga = gm;
                if side == -1 {
                    gb *= 0.5;
                }
                side = -1;
            } else {
                b = m;
                gb = gm;
                if side == 1 {
                    ga *= 0.5;
                }
                side = 1;
            }
        }
        // Accept the best point found; the latch projection closes the remaining gap.
        let _ = h_star;
        self.core.newmark(&self.model, &self.state, b, &self.opts)?;
        Ok(Some(b))
    }

    /// Another unlocked sleeve whose gap has changed sign (beyond the latch
    /// tolerance) in the current trial of length m.
    fn crossed_by(&self, _m: f64, target: usize) -> Option<usize> {
        let (s, c) = (&self.state, &self.core);
        self.model.locks.iter().copied().find(|&e| {
            if e == target || s.locked[e] {
                return false;
            }
            let (g0, g1) = (gap(&self.model, e, &s.x), gap(&self.model, e, &c.x));
            g0 != 0.0 && g0 * g1 < 0.0 && g1.abs() > self.opts.lock_tol_m
        })
    }

    /// Commits the trial step of length h to the state, with the energy ledger.
    fn accept(&mut self, h: f64) {
        std::mem::swap(&mut self.core.a_prev, &mut self.core.a_prev2);
        self.core.prev_h2 = self.core.prev_h;
        self.core.a_prev.copy_from_slice(&self.state.a);
        self.core.prev_h = Some(h);
        let (m, s, c) = (&self.model, &mut self.state, &self.core);
        let e = &mut s.energy;
        for (ci, cab) in m.cables.iter().enumerate() {
            let (old, new) = (&s.cables[ci], &c.cables[ci]);
            // motor tension is the command, constant over the step: exact work
            e.motor_work_j += s.cable_tension_cmd_n[ci] * (old.length_m - new.length_m);
            let mut seg_work = 0.0;
            for j in 0..cab.path.len() - 1 {
                seg_work -= 0.5
                    * (old.segment_tension_n[j] + new.segment_tension_n[j])
                    * (new.segment_length_m[j] - old.segment_length_m[j]);
            }
            e.cable_work_j += seg_work;
            e.friction_loss_j +=
                s.cable_tension_cmd_n[ci] * (old.length_m - new.length_m) - seg_work;
        }
        let g = m.gravity_m_s2;
        for i in 0..s.x.len() {
            let dx = c.x[i] - s.x[i];
            e.damping_loss_j += m.damping_n_s_per_m * 0.5 * (s.v[i] + c.v[i]) * dx;
            e.gravity_work_j += m.mass[i] * g[i % 3] * dx;
        }
        s.t_s += h;
        s.x.copy_from_slice(&c.x);
        s.v.copy_from_slice(&c.v);
        s.a.copy_from_slice(&c.a);
        s.lambda.clone_from(&c.lambda);
        for (o, n) in s.cables.iter_mut().zip(&c.cables) {
            o.clone_from(n);
        }
        s.max_violation_m = s.max_violation_m.max(c.violation_m);
    }

    /// Latches every sleeve at its design length (within the latch tolerance),
    /// applies the inelastic latch to the velocities and records the events.
    fn latch(&mut self) -> Result<usize, SolverError> {
        let model = &self.model;
        let newly: Vec<usize> = model
            .locks
            .iter()
            .copied()
            .filter(|&e| {
                !self.state.locked[e]
                    && gap(model, e, &self.state.x).abs()
                        <= self.opts.lock_tol_m.max(10.0 * self.opts.root_tol_m)
            })
            .collect();
        if newly.is_empty() {
            return Ok(0);
        }
        for &e in &newly {
            self.state.locked[e] = true;
        }
        let core = &mut self.core;
        core.prev_h = None;
        core.set_pattern(model, &self.state.locked);
        core.x.copy_from_slice(&self.state.x);
        core.v.copy_from_slice(&self.state.v);
        // Least-squares (minimum-norm) solves through the latch: simultaneous
        // latches of redundant members share the impulse by the minimum-norm
        // split (statically indeterminate otherwise), and a truss that latches
        // into its flat deployed state has rows only nearly redundant there,
        // on which basic solves are ill-conditioned.
        let _ = core.solver.set_min_norm(true);
        let settled = (|| {
            core.project_positions(model, self.opts.projection_tol_m, false)?;
            core.factor(model)?;
            core.project_velocities(model)?; // r = A v before, mu = impulses
            core.a_guess.copy_from_slice(&self.state.a);
            core.consistent_accelerations(model, &self.state.cable_tension_cmd_n)
        })();
        let _ = core.solver.set_min_norm(false);
        settled?;
        // A basic factorization of the new locked set at the latched state (the
        // next step starts from it): its probe counts the rank for large models.
        core.factor(model)?;
        let ke_before = self.state.kinetic_energy_j(model);
        let t = self.state.t_s;
        for &e in &newly {
            let b = core
                .jac
                .blocks
                .iter()
                .find(|b| b.element == e)
                .expect("latched element has a row");
            let (mu, rate) = (core.mu[b.row0], core.r[b.row0]);
            self.state.locks.push(LockEvent {
                element: e,
                name: model.elements[e].name().to_string(),
                time_s: t,
                impulse_ns: mu.abs(),
                energy_lost_j: 0.5 * mu * rate,
                closing_speed_m_s: rate,
            });
        }
        let s = &mut self.state;
        s.x.copy_from_slice(&core.x);
        s.v.copy_from_slice(&core.v);
        s.a.copy_from_slice(&core.a);
        s.lambda.clone_from(&core.lambda);
        s.max_violation_m = s.max_violation_m.max(core.violation_m);
        let ke_after = s.kinetic_energy_j(model);
        s.energy.lock_loss_j += ke_before - ke_after;
        self.state.mechanisms = self.mechanisms_now();
        // Rigid before every sleeve latched: trusted from an SVD only (the
        // dense solver's, or one confirming a pivot rank; not past
        // RANK_CHECK_MAX_COORDS). Once every sleeve has latched the truss is
        // deployed whatever the count, and the SVD (~4 % of a ring's whole
        // deployment) is skipped.
        let deployed = self.all_locked()
            || (self.state.mechanisms == 0
                && self.model.n_coords() <= RANK_CHECK_MAX_COORDS
                && (self.core.solver.rank().is_some()
                    || super::mobility::rank(&self.core.jac) == self.model.n_coords()));
        if deployed {
            self.state.deployed = true;
            self.state.deploy_time_s.get_or_insert(t);
        }
        Ok(newly.len())
    }
}

fn blank_state(model: &Model) -> State {
    let n = model.n_coords();
    State {
        t_s: 0.0,
        x: model.x0.clone(),
        v: vec![0.0; n],
        a: vec![0.0; n],
        locked: vec![false; model.elements.len()],
        cable_tension_cmd_n: model.cables.iter().map(|c| c.tension_n).collect(),
        cables: model.cables.iter().map(CableEval::for_cable).collect(),
        lambda: Vec::new(),
        energy: Energy::default(),
        locks: Vec::new(),
        max_violation_m: 0.0,
        mechanisms: 0,
        deployed: false,
        deploy_time_s: None,
        steps: 0,
    }
}
