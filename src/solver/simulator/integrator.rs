//! Stage `integrator`: Newmark average-acceleration integration of one trial
//! step and its convergence policy.
//!
//! One step of length h from (X_n, V_n, A_n):
//!   X_{n+1} = X_n + h V_n + h^2/4 (A_n + A_{n+1}),   V_{n+1} = V_n + h/2 (A_n + A_{n+1}),
//! with A_{n+1} the constrained acceleration at (X_{n+1}, V_{n+1}), found by
//! fixed-point iteration (each iterate is one constrained solve), then
//! projected (stage `projection`). Also here: the applied forces Q (cables,
//! damping, gravity) and the accelerations consistent with a state where a
//! step starts from scratch.

use super::core::{Core, MEMBER_PIN};
use crate::solver::cable;
use crate::solver::linsolve::SolveMode;
use crate::solver::model::Model;
use crate::solver::settings::SolverSettings;
use crate::solver::state::State;
use crate::solver::SolverError;

impl Core {
    /// Applied forces Q at the trial (x, v): cables, compliant elements and
    /// latches, damping, gravity. The cable
    /// inertia term uses `a_guess` as the acceleration estimate.
    fn applied_forces(&mut self, model: &Model, cmd: &[f64]) {
        self.q.fill(0.0);
        for (ci, c) in model.cables.iter().enumerate() {
            let direction = if self.lagged_friction {
                Some(self.friction_sliding[ci].as_slice())
            } else {
                None
            };
            if self.motor_tracks(ci) {
                // (a speed-controlled motor's tension is solved for:
                // `motor_tensions`)
                let sliding = std::mem::take(&mut self.friction_sliding[ci]);
                let dir = self.lagged_friction.then_some(sliding.as_slice());
                self.motor_unit_forces(model, ci, dir);
                self.friction_sliding[ci] = sliding;
                continue;
            }
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
        // Compliant elements and engaged compliant latches:
        // -A^T (k Phi + c A Xdot).
        self.element_springs
            .add_forces(model, &self.x, &self.v, &mut self.q);
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

    /// Constrained accelerations at the trial (x, v) into `a` and `lambda`,
    /// from a new factorization in `mode` (`Some`) or the current one (`None`).
    pub fn accelerations(
        &mut self,
        model: &Model,
        cmd: &[f64],
        refactor: Option<SolveMode>,
    ) -> Result<(), SolverError> {
        if let Some(mode) = refactor {
            if self.compliant.is_some() {
                // (compliant solves factor S + D themselves)
                self.jac.fill(model, &self.x);
            } else {
                self.factor(model, mode)?;
            }
        }
        self.applied_forces(model, cmd);
        if let Some((h, true)) = self.compliant {
            // Index 3: Phi(X) + tau A V + c lambda = 0 at X, V of A
            // linearized at the iterate A_g (X, V move by beta h^2 and
            // gamma h per unit A, `StepGains`): b A (A - A_g) + Phi + tau A V
            // + c lambda = 0 with b = beta h^2 + tau gamma h, i.e.
            // A A + D lambda = -((Phi + tau A V) / b - A A_g).
            self.jac.residual(model, &self.x, &mut self.row_phi);
            self.jac.mul(&self.v, &mut self.row_rate);
            self.jac.mul(&self.a_guess, &mut self.c);
            let (tau, beta) = (self.relaxation_s, self.step_relaxation_beta(h));
            for i in 0..self.c.len() {
                self.c[i] = (self.row_phi[i] + tau * self.row_rate[i]) / beta - self.c[i];
            }
        } else {
            self.jac.adot_xdot(model, &self.x, &self.v, &mut self.c);
            if let Some((h, false)) = self.compliant {
                // members: A A + D lambda = -c with D lambda = -D (Phi + tau A V) / c
                self.jac.residual(model, &self.x, &mut self.row_phi);
                self.jac.mul(&self.v, &mut self.row_rate);
                let k = MEMBER_PIN / self.relaxation_beta(h);
                for i in 0..self.c.len() {
                    if self.row_member[i] {
                        self.c[i] = k * (self.row_phi[i] + self.relaxation_s * self.row_rate[i]);
                    }
                }
            }
        }
        self.solve_accelerations(model)?;
        if self.motor.any_tracking() {
            self.motor_tensions(model)?;
        }
        if self.a.iter().any(|v| !v.is_finite()) {
            return Err(SolverError::NonFinite("accelerations".into()));
        }
        Ok(())
    }

    /// Constrained accelerations at the trial (x, v) from a current
    /// factorization, where nothing better than `a_guess` is known of them (the
    /// start, a latch, a command change). Cables with mass take their inertia
    /// term from `a_guess`: the evaluation is repeated to its fixed point (a
    /// contraction like the Newmark iteration's); stopping at the iteration
    /// limit is a counted fallback.
    pub fn consistent_accelerations(
        &mut self,
        model: &Model,
        cmd: &[f64],
        st: &SolverSettings,
    ) -> Result<(), SolverError> {
        if st.elastic_members {
            self.compliant = Some((model.dt_s, false));
            self.restart_substeps_left = st.restart_substeps;
            // (the blend entry after them is judged from this restart)
            self.blend_start_held = false;
        }
        let result = self.consistent_fixed_point(model, cmd, st);
        self.compliant = None;
        if st.elastic_members {
            self.store_state_member_forces();
        }
        result
    }

    fn consistent_fixed_point(
        &mut self,
        model: &Model,
        cmd: &[f64],
        st: &SolverSettings,
    ) -> Result<(), SolverError> {
        self.accelerations(model, cmd, None)?;
        if !model.cables.iter().any(|c| c.line_density_kg_per_m > 0.0) {
            return Ok(());
        }
        for _ in 0..st.consistent_max_iterations {
            let (mut change, mut scale) = (0.0f64, 0.0f64);
            for (a, g) in self.a.iter().zip(&self.a_guess) {
                change = change.max((a - g).abs());
                scale = scale.max(a.abs());
            }
            if change <= st.consistent_tol_rel * scale {
                return Ok(());
            }
            self.a_guess.copy_from_slice(&self.a);
            self.accelerations(model, cmd, None)?;
        }
        self.stats.fallbacks.consistent_unconverged += 1;
        Ok(())
    }

    /// One Newmark step of length h from `s` into the trial state, with solves
    /// in `base` mode (escalated to least squares where the iteration stalls).
    pub fn newmark(
        &mut self,
        model: &Model,
        s: &State,
        h: f64,
        st: &SolverSettings,
        base: SolveMode,
    ) -> Result<(), SolverError> {
        self.stats.newmark_steps += 1;
        let cmd = &s.cable_tension_cmd_n;
        // Predictor: A_{n+1} extrapolated from the last step starts, by the
        // candidate (`Predictor`) that would have predicted A_n best: quadratic
        // in A for smooth motion, quadratic in V (A_n + A_{n-1} - A_{n-2}) for
        // a stiff damped mode whose A alternates in sign from step to step
        // (a pulley stuck inside its friction blend), linear along each
        // parity for such a mode whose amplitude drifts (docs/solver.md,
        // Predictor). Only the iteration's start changes, not its result.
        let best = self.predictor(model, s, h);
        for i in 0..self.a_guess.len() {
            let a = s.a[i];
            self.a_guess[i] = match best {
                Predictor::Constant => a,
                Predictor::Linear => 2.0 * a - self.a_prev[i],
                Predictor::Alternation => self.a_prev[i],
                Predictor::Smooth => 3.0 * a - 3.0 * self.a_prev[i] + self.a_prev2[i],
                Predictor::Ringing => a + self.a_prev[i] - self.a_prev2[i],
                Predictor::Parity => 2.0 * self.a_prev[i] - self.a_prev3[i],
            };
        }
        // Viscous damping C (diagonal) is taken implicitly: with
        // V_{n+1} = V* + gamma h A_{n+1}, V* = V_n + (1 - gamma) h A_n, the
        // damping force -C V_{n+1} moves to the left:
        // (M + gamma h C) A_{n+1} = Q - C V* + A^T lambda. The fixed-point
        // iteration then contracts however stiff the damping is.
        let c_damp = model.damping_n_s_per_m;
        let gains = self.step_gains(h);
        for (w, m) in self.inv_mass_eff.iter_mut().zip(&model.mass) {
            *w = 1.0 / (m + gains.velocity_s * c_damp);
        }
        self.implicit_h = Some(h);
        for i in 0..self.v_star.len() {
            self.v_star[i] = s.v[i] + (h - gains.velocity_s) * s.a[i];
        }
        for (dst, src) in self.friction_sliding.iter_mut().zip(&s.cables) {
            dst.copy_from_slice(&src.sliding_m_s);
        }
        if !self.blend_start_held {
            for (dst, src) in self.blend_start.iter_mut().zip(&s.cables) {
                dst.copy_from_slice(&src.sliding_m_s);
            }
        }
        let motors = self.motor.any_tracking();
        if motors {
            // (the lengths they hold at the trial's end)
            self.motor.set_targets(s, h);
        }
        if st.elastic_members {
            self.compliant = Some((h, true));
        }
        let iterated = self.newmark_iterate(model, s, h, st, base);
        self.compliant = None;
        self.implicit_h = None;
        let lagged = self.lagged_friction;
        self.lagged_friction = false;
        iterated?;
        self.newmark_update(s, h);
        if st.elastic_members {
            self.elastic_finish(model);
            return Ok(());
        }
        self.project_positions(model, st, base)?;
        if motors {
            self.project_motor_positions(model, st, base)?;
        }
        self.factor(model, base)?;
        self.project_velocities(model, st, base)?;
        if motors {
            self.project_motor_velocities(model)?;
        }
        // A_{n+1} (and the segment tensions the energy ledger books) under the
        // friction directions the iteration converged with: evaluated with the
        // current directions instead, a pulley sliding slower than its slip
        // speed gets a friction force the step never applied, so the next
        // step starts from accelerations inconsistent with this one (the
        // rerouted-cable ring booked a balance error of 6.5e-2 by t = 0.1 s).
        self.lagged_friction = lagged;
        let result = self.accelerations(model, cmd, None);
        self.lagged_friction = false;
        result
    }

    /// The end of an elastic-member step: the iteration left X_{n+1},
    /// V_{n+1} with Phi + tau A V + c lambda = 0 (and the tracking motors'
    /// e + tau edot = 0, e = L(X_{n+1}) - L_target) and A_{n+1}, lambda
    /// consistent with them; nothing is projected. The violation reported
    /// is what is left of the rows' equation and the motors' miss |e|; the
    /// members' strain energy and dampers' rate are read for the ledger.
    fn elastic_finish(&mut self, model: &Model) {
        self.jac.fill(model, &self.x);
        let (strain, worst) = self.elastic_readings(model);
        self.strain_trial_j = strain;
        self.violation_m = worst.max(self.motor.length_miss_m(model, &self.x));
        self.jac.mul_t(&self.lambda, &mut self.member_force_trial);
    }

    /// The predictor of A_{n+1} for a step of length h from `s` (see
    /// `newmark`): each candidate judged by its back-test, the kinetic norm
    /// of what it would have predicted for A_n less A_n, where the history
    /// of step starts (a_prev = A_{n-1}, a_prev2 = A_{n-2}, ...) allows it.
    fn predictor(&self, model: &Model, s: &State, h: f64) -> Predictor {
        let miss = |predicted: &dyn Fn(usize) -> f64| -> f64 {
            (0..s.a.len())
                .map(|i| model.mass[i] * (predicted(i) - s.a[i]).powi(2))
                .sum()
        };
        let (p1, p2, p3, p4) = (&self.a_prev, &self.a_prev2, &self.a_prev3, &self.a_prev4);
        let equal = |prev: Option<f64>| prev == Some(h);
        if equal(self.prev_h) && equal(self.prev_h2) && equal(self.prev_h3) {
            let smooth = miss(&|i| 3.0 * p1[i] - 3.0 * p2[i] + p3[i]);
            let ring = miss(&|i| p1[i] + p2[i] - p3[i]);
            let parity = if equal(self.prev_h4) {
                miss(&|i| 2.0 * p2[i] - p4[i])
            } else {
                f64::INFINITY
            };
            return if parity <= ring && parity <= smooth {
                Predictor::Parity
            } else if ring < smooth {
                Predictor::Ringing
            } else {
                Predictor::Smooth
            };
        }
        if equal(self.prev_h) && equal(self.prev_h2) {
            let linear = miss(&|i| 2.0 * p1[i] - p2[i]);
            let alternation = miss(&|i| p2[i]);
            return if alternation < linear {
                Predictor::Alternation
            } else {
                Predictor::Linear
            };
        }
        // (after a change of h: the alternation holds for the ringing mode
        // whatever the step lengths, since its V stays put; it is judged
        // against the constant guess, the linear extrapolation's own
        // back-test having no meaning across the change)
        if self.prev_h.is_some() && self.prev_h2.is_some() && miss(&|i| p2[i]) < miss(&|i| p1[i]) {
            Predictor::Alternation
        } else if equal(self.prev_h) {
            Predictor::Linear
        } else {
            Predictor::Constant
        }
    }

    /// The trial (x, v) from the step start `s` and A_{n+1} = `a_guess`:
    /// X_{n+1} = X_n + h V_n + h^2 ((1/2 - beta) A_n + beta A_{n+1}),
    /// V_{n+1} = V_n + h ((1 - gamma) A_n + gamma A_{n+1}) (`StepGains`;
    /// the average-acceleration rule's beta = 1/4, gamma = 1/2:
    /// X_n + h V_n + h^2/4 (A_n + A_{n+1}), V_n + h/2 (A_n + A_{n+1})).
    fn newmark_update(&mut self, s: &State, h: f64) {
        if self.backward_euler {
            // (beta = 1/2, gamma = 1: A_n drops out)
            let g = self.step_gains(h);
            for i in 0..self.x.len() {
                let a1 = self.a_guess[i];
                self.x[i] = s.x[i] + h * s.v[i] + g.position_s2 * a1;
                self.v[i] = s.v[i] + g.velocity_s * a1;
            }
            return;
        }
        for i in 0..self.x.len() {
            let asum = s.a[i] + self.a_guess[i];
            self.x[i] = s.x[i] + h * s.v[i] + 0.25 * h * h * asum;
            self.v[i] = s.v[i] + 0.5 * h * asum;
        }
    }

    /// The fixed-point iteration of A_{n+1} (converged value in `a_guess`;
    /// docs/solver.md, Integration). Converged where the error estimate
    /// min(safety rho / (1 - rho), 1) |change| is within tolerance: one ratio
    /// of successive changes underestimates the contraction rate rho (by up to
    /// 13x on the bundled models), hence `newmark_rho_safety`. Where the
    /// friction blend or a stiff spring keeps the map from contracting, it
    /// goes on with Newton steps (stage `newton`; the same equations). A
    /// stall restarts with least-squares solves (basic ones make a less
    /// contractive map off the manifold), then with the friction direction of
    /// the step start (an iteration cycling across a blend): counted fallbacks.
    fn newmark_iterate(
        &mut self,
        model: &Model,
        s: &State,
        h: f64,
        st: &SolverSettings,
        base: SolveMode,
    ) -> Result<(), SolverError> {
        let cmd = &s.cable_tension_cmd_n;
        let amax = s.a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        self.lagged_friction = false;
        self.newton_secant = false;
        self.blend_entry = false;
        let mut mode = base;
        let (mut last_change, mut stalls) = (f64::INFINITY, 0);
        let (mut best_change, mut no_progress) = (f64::INFINITY, 0);
        let (mut newton, mut tried_newton) = (false, false);
        // (Newton restarts at the next iterate: the secant retry)
        let mut restart_newton = false;
        let gains = self.step_gains(h);
        // (whether the friction blend was in play when Newton started: the
        // Newton gain then measures it, not only a stiff spring's)
        let mut newton_for_friction = false;
        for _ in 0..st.newmark_max_iterations {
            self.stats.newmark_iterations += 1;
            self.newmark_update(s, h);
            self.accelerations(model, cmd, Some(mode))?;
            let mut change = 0.0f64;
            let mut scale = amax;
            for i in 0..self.a.len() {
                change = change.max((self.a[i] - self.a_guess[i]).abs());
                scale = scale.max(self.a[i].abs());
            }
            // (rho is 0 after the first iterate, whose last change is
            // infinite; Newton iterates do not contract geometrically: their
            // error is taken as the change)
            let rho = change / last_change;
            let error = if !newton && rho > 0.0 && rho < st.newmark_rho_max {
                (st.newmark_rho_safety * rho / (1.0 - rho) * change).min(change)
            } else {
                change
            };
            // (position per unit A per h^2: beta, 1/4 or 1/2 backward-Euler)
            let per_a = self.step_gains(1.0).position_s2;
            if error <= st.newmark_tol_rel * scale
                || per_a * error * h * h <= st.newmark_tol_position_m
            {
                self.a_guess.copy_from_slice(&self.a);
                // (only where the blend was stiff: a Newton switch at a stall
                // of another origin changes no step length)
                self.blend_entry = tried_newton
                    && newton_for_friction
                    && self.newton.gain >= 1.0
                    && self.friction_blend_entered(model, st.blend_change_rel);
                self.newton_last = tried_newton;
                return Ok(());
            }
            if newton {
                if self.newton_advance(model, h, st)? {
                    continue;
                }
                // (the line search failed: once more with the friction's
                // secant slopes where it steered the Newton steps, else on
                // with the plain iteration from the best iterate, and its
                // stall fallbacks)
                self.stats.fallbacks.newmark_newton_failed += 1;
                newton = false;
                self.newton_best();
                if newton_for_friction && !self.newton_secant {
                    self.newton_secant = true;
                    self.stats.fallbacks.newmark_newton_secant += 1;
                    restart_newton = true;
                }
                (last_change, stalls) = (f64::INFINITY, 0);
                (best_change, no_progress) = (f64::INFINITY, 0);
                continue;
            }
            // Newton where the friction blend or a stiff compliant element
            // (its row gain at h, `ElementSprings::max_gain`) is what keeps
            // the iteration from contracting (not a stall at the roundoff
            // floor of the solves: that is the least-squares restart's)
            // (from the first iterate where the last Newmark step needed
            // Newton: the plain iterates would run off to a saturated side)
            let stiff = (rho >= st.newmark_newton_trigger || self.newton_last || restart_newton)
                && !self.lagged_friction
                && (!tried_newton || restart_newton);
            restart_newton = false;
            let friction = stiff && self.friction_blend_active(model);
            if friction
                || (stiff
                    && self.element_springs.max_gain(model, &self.x, gains)
                        >= st.newmark_newton_trigger)
            {
                newton_for_friction = friction;
                newton = true;
                tried_newton = true;
                self.stats.fallbacks.newmark_newton += 1;
                self.newton_start(model, h, st)?;
                continue;
            }
            self.a_guess.copy_from_slice(&self.a);
            stalls = if change >= st.newmark_stall_ratio * last_change {
                stalls + 1
            } else {
                0
            };
            last_change = change;
            // (no progress on the best iterate so far also catches a cycle whose
            // change alternates up and down)
            no_progress = if change >= st.newmark_stall_ratio * best_change {
                no_progress + 1
            } else {
                0
            };
            best_change = best_change.min(change);
            let stalled = stalls >= st.newmark_stall_count;
            if (stalled || no_progress >= st.newmark_stall_count)
                && mode == SolveMode::Basic
                && self.solver.distinguishes_modes()
            {
                mode = SolveMode::MinNorm;
                self.stats.fallbacks.newmark_min_norm += 1;
                self.a_guess.copy_from_slice(&s.a);
                (last_change, stalls) = (f64::INFINITY, 0);
                (best_change, no_progress) = (f64::INFINITY, 0);
            } else if stalled && !self.lagged_friction && !model.cables.is_empty() {
                self.lagged_friction = true;
                self.stats.fallbacks.newmark_lagged_friction += 1;
                self.a_guess.copy_from_slice(&s.a);
                (last_change, stalls) = (f64::INFINITY, 0);
            }
        }
        self.newton_last = false;
        Err(SolverError::NoConvergence { t_s: s.t_s + h })
    }
}

/// The Newmark predictor's extrapolations of A_{n+1} (`Core::newmark`).
#[derive(Clone, Copy)]
enum Predictor {
    /// A_n.
    Constant,
    /// Linear in A: 2 A_n - A_{n-1}.
    Linear,
    /// The alternation of a ringing mode: A_{n-1}.
    Alternation,
    /// Quadratic in A: 3 A_n - 3 A_{n-1} + A_{n-2}.
    Smooth,
    /// Quadratic in V: A_n + A_{n-1} - A_{n-2}.
    Ringing,
    /// Linear along each parity: 2 A_{n-1} - A_{n-3}.
    Parity,
}
