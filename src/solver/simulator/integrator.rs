//! Stage `integrator`: one Newmark trial step and its convergence policy.
//!
//!   X_{n+1} = X_n + h V_n + h^2/4 (A_n + A_{n+1}),   V_{n+1} = V_n + h/2 (A_n + A_{n+1}),
//!
//! A_{n+1} the constrained acceleration at (X_{n+1}, V_{n+1}) by fixed-point
//! iteration (one constrained solve per iterate), then projected (stage
//! `projection`; elastic members: nothing projected). Also the applied
//! forces Q and the consistent accelerations of a state.

use super::core::{Core, Pose, Rows, Solve, StepRule, MEMBER_PIN};
use crate::solver::cable;
use crate::solver::linsolve::{max_abs, SolveMode};
use crate::solver::model::Model;
use crate::solver::settings::SolverSettings;
use crate::solver::state::{Carry, State};
use crate::solver::SolverError;

impl Core {
    /// Applied forces Q at the trial (x, v): cables (inertia from `a_guess`),
    /// compliant elements and latches, damping (on V* where `pose` takes it
    /// implicit), gravity.
    fn applied_forces(&mut self, model: &Model, cmd: &[f64], pose: Pose) {
        self.q.fill(0.0);
        for (ci, c) in model.cables.iter().enumerate() {
            let direction = if pose.lagged_friction {
                Some(self.friction_sliding[ci].as_slice())
            } else {
                None
            };
            if self.motor_tracks(ci) {
                // (its tension is solved for: `motor_tensions`)
                let sliding = std::mem::take(&mut self.friction_sliding[ci]);
                let dir = pose.lagged_friction.then_some(sliding.as_slice());
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
        // compliant elements and latches: -A^T (k Phi + c A Xdot)
        self.element_springs
            .add_forces(model, &self.x, &self.v, &mut self.q);
        let g = model.gravity_m_s2;
        let damp_v = if pose.implicit_damping {
            &self.v_star
        } else {
            &self.v
        };
        for i in 0..self.q.len() {
            self.q[i] += model.mass[i] * g[i % 3] - model.damping_n_s_per_m * damp_v[i];
        }
    }

    /// Constrained accelerations at the trial (x, v) into `a` and `lambda`,
    /// from a new factorization in `mode` (`Some`) or the current one
    /// (`None`), posed as `pose` says.
    pub fn accelerations(
        &mut self,
        model: &Model,
        cmd: &[f64],
        refactor: Option<SolveMode>,
        pose: Pose,
    ) -> Result<(), SolverError> {
        if let Some(mode) = refactor {
            if pose.rows.elastic_h().is_some() {
                self.jac.fill(model, &self.x); // (S + D factored by the solve)
            } else {
                self.factor(model, mode, pose)?;
            }
        }
        self.applied_forces(model, cmd, pose);
        if let Rows::ElasticStep { h, rule } = pose.rows {
            // Index 3: Phi + tau A V + c lambda = 0 at the X, V of A,
            // linearized at the iterate A_g: b A (A - A_g) + Phi + tau A V
            // + c lambda = 0, b = beta h^2 + tau gamma h, so
            // A A + D lambda = -((Phi + tau A V) / b - A A_g)
            //                = -(Phi / b + A ((tau / b) V - A_g)): one product.
            self.jac.residual(model, &self.x, &mut self.row_phi);
            let (tau, beta) = (self.relaxation_s, self.step_relaxation_beta(h, rule));
            let k = tau / beta;
            for ((w, v), g) in self.coord_rate.iter_mut().zip(&self.v).zip(&self.a_guess) {
                *w = k * v - g;
            }
            self.jac.mul(&self.coord_rate, &mut self.c);
            for (c, phi) in self.c.iter_mut().zip(&self.row_phi) {
                *c += phi / beta;
            }
        } else {
            self.jac.adot_xdot(model, &self.x, &self.v, &mut self.c);
            if let Rows::ElasticForces { h } = pose.rows {
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
        self.solve_accelerations(model, pose)?;
        if self.motor.any_tracking() {
            self.motor_tensions(model, pose)?;
        }
        if self.a.iter().any(|v| !v.is_finite()) {
            return Err(SolverError::NonFinite("accelerations".into()));
        }
        Ok(())
    }

    /// Constrained accelerations at the trial (x, v) from a current
    /// factorization, from scratch (start, latch, command change). Cables with
    /// mass take their inertia from `a_guess`: repeated to the fixed point
    /// (`consistent_unconverged` at the limit).
    /// With elastic members a restart: `carry` takes its backward-Euler
    /// sub-steps, releases a held blend start and the state's member forces.
    pub fn consistent_accelerations(
        &mut self,
        model: &Model,
        cmd: &[f64],
        st: &SolverSettings,
        carry: &mut Carry,
    ) -> Result<(), SolverError> {
        let mut pose = Pose::PLAIN;
        if st.elastic_members {
            pose.rows = Rows::ElasticForces { h: model.dt_s };
            carry.restart_substeps_left = st.restart_substeps;
            carry.blend_start_held = false;
        }
        let result = self.consistent_fixed_point(model, cmd, st, pose);
        if st.elastic_members {
            self.state_member_forces(&mut carry.member_force_n);
        }
        result
    }

    fn consistent_fixed_point(
        &mut self,
        model: &Model,
        cmd: &[f64],
        st: &SolverSettings,
        pose: Pose,
    ) -> Result<(), SolverError> {
        self.accelerations(model, cmd, None, pose)?;
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
            self.accelerations(model, cmd, None, pose)?;
        }
        self.stats.fallbacks.consistent_unconverged += 1;
        Ok(())
    }

    /// One Newmark step of length h from `s` under `rule` into the trial
    /// state, solves in `base` mode.
    pub fn newmark(
        &mut self,
        model: &Model,
        s: &State,
        (h, rule): (f64, StepRule),
        st: &SolverSettings,
        base: SolveMode,
    ) -> Result<(), SolverError> {
        self.stats.newmark_steps += 1;
        let cmd = &s.cable_tension_cmd_n;
        // Predictor: the candidate that would have predicted A_n best
        // (docs/solver.md, Predictor); only the iteration's start changes.
        let best = self.predictor(model, s, h);
        let [p1, p2, p3, _] = &s.carry.accel_history.a;
        for i in 0..self.a_guess.len() {
            let a = s.a[i];
            self.a_guess[i] = match best {
                Predictor::Constant => a,
                Predictor::Linear => 2.0 * a - p1[i],
                Predictor::Alternation => p1[i],
                Predictor::Smooth => 3.0 * a - 3.0 * p1[i] + p2[i],
                Predictor::Ringing => a + p1[i] - p2[i],
                Predictor::Parity => 2.0 * p1[i] - p3[i],
            };
        }
        // Damping implicit: V_{n+1} = V* + gamma h A_{n+1}, V* = V_n +
        // (1 - gamma) h A_n, so (M + gamma h C) A_{n+1} = Q - C V* + A^T lambda,
        // contracting however stiff the damping.
        let c_damp = model.damping_n_s_per_m;
        let gains = rule.gains(h);
        for (w, m) in self.inv_mass_eff.iter_mut().zip(&model.mass) {
            *w = 1.0 / (m + gains.velocity_s * c_damp);
        }
        for i in 0..self.v_star.len() {
            self.v_star[i] = s.v[i] + (h - gains.velocity_s) * s.a[i];
        }
        for (dst, src) in self.friction_sliding.iter_mut().zip(&s.cables) {
            dst.copy_from_slice(&src.sliding_m_s);
        }
        let motors = self.motor.any_tracking();
        if motors {
            self.motor.set_targets(s, h);
        }
        let trial = Pose {
            rows: if st.elastic_members {
                Rows::ElasticStep { h, rule }
            } else {
                Rows::Rigid
            },
            implicit_damping: true,
            lagged_friction: false,
            solve: Solve::Exact,
        };
        let lagged = self.newmark_iterate(model, s, (h, rule), st, base, trial)?;
        self.newmark_update(s, h, rule);
        if st.elastic_members {
            self.elastic_finish(model);
            return Ok(());
        }
        self.project_positions(model, st, base)?;
        if motors {
            self.project_motor_positions(model, st, base)?;
        }
        self.factor(model, base, Pose::PLAIN)?;
        self.project_velocities(model, st, base)?;
        if motors {
            self.project_motor_velocities(model, Pose::PLAIN)?;
        }
        // A_{n+1} and the segment tensions under the friction directions the
        // iteration converged with: with the current ones a pulley slower than
        // its slip speed gets a force the step never applied.
        let end = Pose {
            lagged_friction: lagged,
            ..Pose::PLAIN
        };
        self.accelerations(model, cmd, None, end)
    }

    /// The end of an elastic-member step (nothing projected): the violation
    /// is what is left of Phi + tau A V + c lambda = 0 and of the motors'
    /// |L - L_target|; strain energy and member forces for the ledger.
    fn elastic_finish(&mut self, model: &Model) {
        self.jac.fill(model, &self.x);
        let (strain, worst) = self.elastic_readings(model);
        self.strain_trial_j = strain;
        self.violation_m = worst.max(self.motor.length_miss_m(model, &self.x));
        self.jac.mul_t(&self.lambda, &mut self.member_force_trial);
    }

    /// The predictor of A_{n+1} for a step h from `s`: each candidate judged
    /// by the kinetic norm of its miss of A_n, where the history allows it.
    fn predictor(&self, model: &Model, s: &State, h: f64) -> Predictor {
        let miss = |predicted: &dyn Fn(usize) -> f64| -> f64 {
            (0..s.a.len())
                .map(|i| model.mass[i] * (predicted(i) - s.a[i]).powi(2))
                .sum()
        };
        let [p1, p2, p3, p4] = &s.carry.accel_history.a;
        let prev = &s.carry.accel_history.h;
        let equal = |k: usize| prev[k] == Some(h);
        if equal(0) && equal(1) && equal(2) {
            let smooth = miss(&|i| 3.0 * p1[i] - 3.0 * p2[i] + p3[i]);
            let ring = miss(&|i| p1[i] + p2[i] - p3[i]);
            let parity = if equal(3) {
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
        if equal(0) && equal(1) {
            let linear = miss(&|i| 2.0 * p1[i] - p2[i]);
            let alternation = miss(&|i| p2[i]);
            return if alternation < linear {
                Predictor::Alternation
            } else {
                Predictor::Linear
            };
        }
        // (after a change of h only the alternation, whose V stays put,
        // against the constant guess)
        if prev[0].is_some() && prev[1].is_some() && miss(&|i| p2[i]) < miss(&|i| p1[i]) {
            Predictor::Alternation
        } else if equal(0) {
            Predictor::Linear
        } else {
            Predictor::Constant
        }
    }

    /// The trial (x, v) from `s` and A_{n+1} = `a_guess`:
    /// X_{n+1} = X_n + h V_n + h^2 ((1/2 - beta) A_n + beta A_{n+1}),
    /// V_{n+1} = V_n + h ((1 - gamma) A_n + gamma A_{n+1}).
    fn newmark_update(&mut self, s: &State, h: f64, rule: StepRule) {
        if rule == StepRule::BackwardEuler {
            // (beta = 1/2, gamma = 1: A_n drops out)
            let g = rule.gains(h);
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

    /// The fixed-point iteration of A_{n+1} into `a_guess` (docs/solver.md,
    /// Integration): converged where min(safety rho / (1 - rho), 1) |change|
    /// is within tolerance (`newmark_rho_safety`). Where the friction blend or
    /// a stiff spring keeps the map from contracting: Newton steps (stage
    /// `newton`). A stall restarts with least-squares solves, then with the
    /// step start's friction direction (counted fallbacks). The solves are
    /// posed as `pose` says; returns whether the converged iterate took the
    /// friction's directions lagged (the step's end takes them too).
    fn newmark_iterate(
        &mut self,
        model: &Model,
        s: &State,
        (h, rule): (f64, StepRule),
        st: &SolverSettings,
        base: SolveMode,
        mut pose: Pose,
    ) -> Result<bool, SolverError> {
        let cmd = &s.cable_tension_cmd_n;
        let amax = max_abs(&s.a);
        self.newton.secant = false;
        self.blend_entry = false;
        // Modified Newton (elastic members, no tracking motor): each plain
        // iterate corrects the multipliers once from the last iterate's (the
        // state's at the first) with the factorization of S + D made at the
        // trial's first iterate, made again where the iteration contracts
        // slower than `newmark_refresh_rho` (docs/solver.md, Integration).
        // (Kept across trials it does not serve: the states of self-stress
        // make S + D nearly singular, D / S ~ 1e-5, and a factorization one
        // step old makes the bundled ring's first iterate diverge.)
        let modified = st.newmark_modified_newton
            && matches!(pose.rows, Rows::ElasticStep { .. })
            && !self.motor.any_tracking();
        if modified {
            self.lambda.copy_from_slice(&s.lambda);
        }
        // (the first iterate of a trial makes its factorization at the trial's start)
        let (mut refresh, mut refreshed) = (modified, false);
        let mut mode = base;
        let (mut last_change, mut stalls) = (f64::INFINITY, 0);
        let (mut best_change, mut no_progress) = (f64::INFINITY, 0);
        let (mut newton, mut tried_newton) = (false, false);
        // (Newton restarts at the next iterate: the secant retry)
        let mut restart_newton = false;
        let gains = rule.gains(h);
        // (whether the friction blend was in play when Newton started: the
        // Newton gain then measures it, not only a stiff spring's)
        let mut newton_for_friction = false;
        for _ in 0..st.newmark_max_iterations {
            self.stats.newmark_iterations += 1;
            self.newmark_update(s, h, rule);
            pose.solve = if modified && !newton {
                refreshed = std::mem::take(&mut refresh);
                Solve::Correction { refresh: refreshed }
            } else {
                Solve::Exact
            };
            self.accelerations(model, cmd, Some(mode), pose)?;
            let mut change = 0.0f64;
            let mut scale = amax;
            for i in 0..self.a.len() {
                change = change.max((self.a[i] - self.a_guess[i]).abs());
                scale = scale.max(self.a[i].abs());
            }
            // (rho is 0 after the first iterate; a Newton iterate's error is
            // its change)
            let rho = change / last_change;
            let error = if !newton && rho > 0.0 && rho < st.newmark_rho_max {
                (st.newmark_rho_safety * rho / (1.0 - rho) * change).min(change)
            } else {
                change
            };
            // (beta: position per unit A per h^2)
            let per_a = rule.gains(1.0).position_s2;
            if error <= st.newmark_tol_rel * scale
                || per_a * error * h * h <= st.newmark_tol_position_m
            {
                self.a_guess.copy_from_slice(&self.a);
                // (only where the blend was stiff)
                // (from the trial's start, or a held restart's: `Carry::blend_start`)
                let start = if s.carry.blend_start_held {
                    &s.carry.blend_start
                } else {
                    &self.friction_sliding
                };
                self.blend_entry = tried_newton
                    && newton_for_friction
                    && self.newton.gain >= 1.0
                    && self.friction_blend_entered(model, st.blend_change_rel, start);
                self.newton_last = tried_newton;
                return Ok(pose.lagged_friction);
            }
            if newton {
                if self.newton_advance(model, (h, rule), st, pose)? {
                    continue;
                }
                // (the line search failed: once with the friction's secant
                // slopes, else the plain iteration from the best iterate)
                self.stats.fallbacks.newmark_newton_failed += 1;
                newton = false;
                self.newton_best();
                if newton_for_friction && !self.newton.secant {
                    self.newton.secant = true;
                    self.stats.fallbacks.newmark_newton_secant += 1;
                    restart_newton = true;
                }
                (last_change, stalls) = (f64::INFINITY, 0);
                (best_change, no_progress) = (f64::INFINITY, 0);
                continue;
            }
            // A modified Newton iterate that contracts slowly: its
            // factorization made afresh for the next (what is left of the
            // rate is then the map's own)
            if modified && !refreshed && rho > st.newmark_refresh_rho && rho.is_finite() {
                self.stats.newmark_refreshes += 1;
                refresh = true;
                self.a_guess.copy_from_slice(&self.a);
                last_change = change;
                best_change = best_change.min(change);
                continue;
            }
            // Newton where the friction blend or a stiff compliant element
            // (`ElementSprings::max_gain`) keeps the map from contracting;
            // from the first iterate if the last step needed it
            let stiff = (rho >= st.newmark_newton_trigger || self.newton_last || restart_newton)
                && !pose.lagged_friction
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
                self.stats.newton_switches += 1;
                // (Newton starts from the map's exact value at the iterate)
                if let Solve::Correction { .. } = pose.solve {
                    pose.solve = Solve::Exact;
                    self.accelerations(model, cmd, None, pose)?;
                }
                self.newton_start(model, (h, rule), st, pose)?;
                continue;
            }
            self.a_guess.copy_from_slice(&self.a);
            stalls = if change >= st.newmark_stall_ratio * last_change {
                stalls + 1
            } else {
                0
            };
            last_change = change;
            // (no progress on the best iterate: a cycle)
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
            } else if stalled && !pose.lagged_friction && !model.cables.is_empty() {
                pose.lagged_friction = true;
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
