//! Stage `motor`: speed-controlled drive motors (docs/solver.md, Speed-controlled motors). A
//! tracking motor holds its cable length L(X) = sum_j |x_{p_j+1} - x_{p_j}| on
//! L(t) = L_e - s (t - t_e), a rheonomic constraint whose multiplier is the motor tension T:
//! - accelerations: A = A_0 + sum_k T_k A_1k (A_1k the response to the joint forces g_k of a unit
//!   tension), and Lddot_i = 0 gives the k x k system sum_k (grad L_i . A_1k) T_k = -Lddot_i(A_0);
//! - positions and velocities: mass-orthogonal corrections along d_k, the structure's response to
//!   grad L_k (A d_k = 0), onto L_i(t) and -s_i;
//! - elastic members (nothing projected): the system holds e + tau edot = 0 instead, inside the
//!   Newmark iteration (`Core::motor_tensions`); an engagement's velocity jump takes the members
//!   at their step compliance, as a latch's (`impact`).
//!
//! The tension stays in [0, `max_tension_n`]: the motor releases beyond it and at every rigid
//! latch, and engages again at its commanded speed by a velocity jump (`motor_engage`).

use super::core::{Core, Pose, Rows, StepRule};
use super::sim::Simulator;
use crate::solver::cable;
use crate::solver::model::Model;
use crate::solver::settings::SolverSettings;
use crate::solver::state::{kinetic_energy_j, MotorHold};
use crate::solver::{RequestError, SolverError};

impl Core {
    /// Whether cable `ci` tracks a speed in the current solve.
    pub fn motor_tracks(&self, ci: usize) -> bool {
        self.motor.speed_m_s[ci].is_some()
    }

    /// The joint forces of a unit motor tension on tracking cable `ci` at
    /// the trial (x, v), into the motor's buffer (its segment tensions per
    /// unit motor tension stay in `cables[ci]` until the solve scales them).
    pub fn motor_unit_forces(&mut self, model: &Model, ci: usize, direction: Option<&[f64]>) {
        let c = &model.cables[ci];
        cable::evaluate_with_direction(
            c,
            1.0,
            &self.x,
            &self.v,
            None,
            direction,
            &mut self.cables[ci],
        );
        let g = &mut self.motor.g[ci];
        g.fill(0.0);
        cable::add_forces(c, &self.cables[ci], &self.x, g);
    }

    /// The tracking motors' tensions, with the accelerations `a_0` and multipliers of the other
    /// forces already solved in `a`, `lambda`: one more solve per motor (its unit forces), then the
    /// k x k system for Lddot = 0, or in elastic members' Newmark iteration for e + tau edot = 0.
    /// `a`, `lambda`, `q` and the cable readings end with the motors' tensions in them.
    pub fn motor_tensions(&mut self, model: &Model, pose: Pose) -> Result<(), SolverError> {
        let mw = &mut self.motor;
        mw.a0.copy_from_slice(&self.a);
        let m = self.jac.nrows;
        mw.lambda0[..m].copy_from_slice(&self.lambda[..m]);
        mw.q_save.copy_from_slice(&self.q);
        mw.c_save[..m].copy_from_slice(&self.c[..m]);
        self.motor_responses(model, true, pose)?;
        // (elastic members' Newmark iteration, nothing projected: X and tau V move by
        // b = beta h^2 + tau gamma h per unit of A)
        let index3 = match pose.rows {
            Rows::ElasticStep { h, rule } => {
                Some((self.step_relaxation_beta(h, rule), self.relaxation_s))
            }
            _ => None,
        };
        let mw = &mut self.motor;
        self.q.copy_from_slice(&mw.q_save);
        self.c[..m].copy_from_slice(&mw.c_save[..m]);
        let k = mw.order.len();
        mw.rhs.clear();
        for &ci in &mw.order {
            let c = &model.cables[ci];
            mw.rhs.push(match index3 {
                // e + tau edot = 0, e = L(X) - L_target, edot = Ldot + s, linearized at the
                // iterate A_g's (X, V): b grad L . (A - A_g) + e + tau edot = 0, so
                // sum_k (grad L . A_1k) T_k = -(e + tau edot) / b - grad L . (A_0 - A_g)
                Some((b, tau)) => {
                    let e = c.length_m(&self.x) - mw.target_m[ci];
                    let edot = c.length_rate(&self.x, &self.v) + mw.speed_m_s[ci].unwrap_or(0.0);
                    -(e + tau * edot) / b - c.length_rate(&self.x, &mw.a0)
                        + c.length_rate(&self.x, &self.a_guess)
                }
                // Lddot = grad L . A + Xdot^T H_L Xdot = 0
                None => -c.length_accel(&self.x, &self.v, &mw.a0),
            });
        }
        mw.solve(model)?;
        self.a.copy_from_slice(&mw.a0);
        self.lambda[..m].copy_from_slice(&mw.lambda0[..m]);
        for oi in 0..k {
            let (ci, t) = (mw.order[oi], mw.rhs[oi]);
            for (a, r) in self.a.iter_mut().zip(&mw.resp[ci]) {
                *a += t * r;
            }
            for (l, r) in self.lambda[..m].iter_mut().zip(&mw.resp_lambda[ci][..m]) {
                *l += t * r;
            }
            for (q, g) in self.q.iter_mut().zip(&mw.g[ci]) {
                *q += t * g;
            }
            for s in self.cables[ci].segment_tension_n.iter_mut() {
                *s *= t;
            }
        }
        Ok(())
    }

    /// The structure's responses at the current factorization (accelerations into `resp`,
    /// multipliers into `resp_lambda`) to the tracking cables' (`order`) joint forces: a unit
    /// motor tension's (`g`), or (`unit_tension` false, plain masses) grad L_k, the projections'
    /// directions d_k. Also the k x k matrix grad L_i . resp_k into `mat`, and into `free` each
    /// cable's mobility were the structure free, grad L . W q (W the solves' inverse masses).
    fn motor_responses(
        &mut self,
        model: &Model,
        unit_tension: bool,
        pose: Pose,
    ) -> Result<(), SolverError> {
        debug_assert!(unit_tension || !pose.implicit_damping);
        let m = self.jac.nrows;
        self.motor.take_order();
        for oi in 0..self.motor.order.len() {
            let ci = self.motor.order[oi];
            let cable = &model.cables[ci];
            if unit_tension {
                self.q.copy_from_slice(&self.motor.g[ci]);
            } else {
                self.q.fill(0.0);
                cable.add_length_gradient(&self.x, 1.0, &mut self.q);
            }
            let w = Self::weights(pose, &self.inv_mass_eff, model);
            let mw = &mut self.motor;
            for ((s, q), wi) in mw.scratch.iter_mut().zip(&self.q).zip(w) {
                *s = q * wi;
            }
            mw.free[ci] = cable.length_rate(&self.x, &mw.scratch);
            self.c[..m].fill(0.0);
            self.solve_accelerations(model, pose)?;
            self.motor.resp[ci].copy_from_slice(&self.a);
            self.motor.resp_lambda[ci][..m].copy_from_slice(&self.lambda[..m]);
        }
        let mw = &mut self.motor;
        mw.mat.clear();
        for &ci in &mw.order {
            for &ck in &mw.order {
                mw.mat
                    .push(model.cables[ci].length_rate(&self.x, &mw.resp[ck]));
            }
        }
        Ok(())
    }

    /// Whether the tracking motors' system (`speed_m_s`) is solvable at the current
    /// factorization: an error naming the cables where it is not (`MotorWork::solve`).
    fn motors_solvable(&mut self, model: &Model, pose: Pose) -> Result<(), SolverError> {
        self.motor_responses(model, false, pose)?;
        let mw = &mut self.motor;
        mw.rhs.clear();
        mw.rhs.resize(mw.order.len(), 0.0);
        mw.solve(model)
    }

    /// Subtracts sum_k y_k d_k from `x` (positions) or `v` with y the
    /// solution of the k x k system for the residuals in `rhs`.
    fn motor_correct(&mut self, model: &Model, positions: bool) -> Result<(), SolverError> {
        let mw = &mut self.motor;
        mw.solve(model)?;
        let target = if positions { &mut self.x } else { &mut self.v };
        for (oi, &ci) in mw.order.iter().enumerate() {
            for (t, d) in target.iter_mut().zip(&mw.resp[ci]) {
                *t -= mw.rhs[oi] * d;
            }
        }
        Ok(())
    }

    /// Positions onto L_i(X) = target_i of the tracking motors, the structure's constraints held by
    /// its projection after each correction, until |L_i - target_i| <= `projection_tol_m`.
    pub fn project_motor_positions(
        &mut self,
        model: &Model,
        st: &SolverSettings,
        mode: crate::solver::linsolve::SolveMode,
    ) -> Result<(), SolverError> {
        for _ in 0..st.projection_max_iterations {
            if self.motor.length_miss_m(model, &self.x) <= st.projection_tol_m {
                return Ok(());
            }
            self.factor(model, mode, Pose::PLAIN)?;
            self.motor_responses(model, false, Pose::PLAIN)?;
            let mw = &mut self.motor;
            mw.rhs.clear();
            for &ci in &mw.order {
                mw.rhs
                    .push(model.cables[ci].length_m(&self.x) - mw.target_m[ci]);
            }
            self.motor_correct(model, true)?;
            self.project_positions(model, st, mode)?;
        }
        Err(SolverError::Projection {
            violation_m: self.motor.length_miss_m(model, &self.x),
        })
    }

    /// Velocities onto Ldot_i = -s_i of the tracking motors, with the current factorization at x:
    /// one correction, exact (the constraint is linear in V and A d_k = 0).
    pub fn project_motor_velocities(
        &mut self,
        model: &Model,
        pose: Pose,
    ) -> Result<(), SolverError> {
        self.motor_responses(model, false, pose)?;
        let mw = &mut self.motor;
        mw.rhs.clear();
        for &ci in &mw.order {
            let speed = mw.speed_m_s[ci].unwrap_or(0.0);
            mw.rhs
                .push(model.cables[ci].length_rate(&self.x, &self.v) + speed);
        }
        self.motor_correct(model, false)
    }
}

impl Simulator {
    /// Sets a cable's motor to reel in at `speed_m_s` (m/s; negative pays out) from the next step
    /// on, its tension up to the cable's `max_tension_n`; None returns it to tension control at
    /// its last commanded tension.
    pub fn set_cable_speed(
        &mut self,
        cable: usize,
        speed_m_s: Option<f64>,
    ) -> Result<(), SolverError> {
        let c = self.cable(cable)?;
        if let Some(s) = speed_m_s {
            if !s.is_finite() {
                return Err(SolverError::Request(RequestError::Speed {
                    cable: c.name.clone(),
                    speed_m_s: s,
                }));
            }
            if c.line_density_kg_per_m > 0.0 {
                return Err(SolverError::Request(RequestError::SpeedOfMassiveCable {
                    cable: c.name.clone(),
                }));
            }
        }
        let m = &mut self.state.motors[cable];
        if m.speed_cmd_m_s == speed_m_s {
            return Ok(());
        }
        match speed_m_s {
            None => {
                m.speed_cmd_m_s = None;
                m.hold = MotorHold::Tension;
                self.state.cable_tension_cmd_n[cable] = m.tension_cmd_n;
            }
            Some(s) => {
                let before = (m.clone(), self.state.cable_tension_cmd_n[cable]);
                if m.speed_cmd_m_s.is_none() {
                    m.tension_cmd_n = self.state.cable_tension_cmd_n[cable];
                }
                m.speed_cmd_m_s = Some(s);
                // (the velocities jump to the new speed; one the tracking motors' system cannot
                // take is refused, the motor left as it was)
                if let Some(e) = self.motor_engage(cable)? {
                    (
                        self.state.motors[cable],
                        self.state.cable_tension_cmd_n[cable],
                    ) = before;
                    self.core.motor.take_modes(&self.state);
                    return Err(e);
                }
            }
        }
        self.core.motor.take_modes(&self.state);
        self.state.carry.command_changed = true;
        Ok(())
    }

    /// Engages released motor `ci` at the state: the velocities jump onto Ldot = -s (the drive's
    /// impulsive tension; the jump's change of kinetic energy booked as its work), and the length
    /// it holds from here on is the state's. A structure that cannot move along the cable leaves
    /// it at its tension limit. Where the tracking motors with it would drive one motion (their
    /// system singular), nothing changes: the error naming the cables is returned.
    fn motor_engage(&mut self, ci: usize) -> Result<Option<SolverError>, SolverError> {
        let (model, core) = (&self.model, &mut self.core);
        let s = &mut self.state;
        debug_assert!(s.motors[ci].speed_cmd_m_s.is_some(), "a speed command");
        core.x.copy_from_slice(&s.x);
        core.v.copy_from_slice(&s.v);
        let mut pose = Pose::PLAIN;
        if self.settings.elastic_members {
            // (members at their step compliance c / beta(dt) under the average acceleration's
            // beta, as a latch's jump; the compliant solves factor S + D themselves, well posed
            // at the flat state, as in a latch's elastic velocity jump)
            core.jac.fill(model, &core.x);
            pose.rows = Rows::ElasticStep {
                h: model.dt_s,
                rule: StepRule::AverageAcceleration,
            };
        } else {
            core.factor(model, crate::solver::linsolve::SolveMode::Basic, pose)?;
        }
        // (this motor alone: the others keep their velocities' rates)
        core.motor.take_modes_with(s, ci, false);
        let moved = core.project_motor_velocities(model, pose);
        // (with the motors tracking already: one system for all of them)
        let others =
            (0..s.motors.len()).any(|j| j != ci && s.motors[j].hold == MotorHold::Tracking);
        let solvable = match moved {
            Ok(()) if others => {
                core.motor.take_modes_with(s, ci, true);
                core.motors_solvable(model, pose)
            }
            _ => Ok(()),
        };
        match solvable {
            Ok(()) => {}
            Err(e @ SolverError::MotorConflict(_)) => {
                // (the jump is not taken: the state is as it was)
                core.motor.take_modes(s);
                return Ok(Some(e));
            }
            Err(e) => return Err(e),
        }
        match moved {
            Ok(()) => {
                let jump_j = kinetic_energy_j(model, &core.v) - kinetic_energy_j(model, &s.v);
                s.energy.motor_work_j += jump_j;
                s.energy.cable_work_j += jump_j;
                s.v.copy_from_slice(&core.v);
                s.motors[ci].hold = MotorHold::Tracking;
                s.motors[ci].length_ref_m = model.cables[ci].length_m(&s.x);
                core.stats.motor_engagements += 1;
            }
            Err(SolverError::MotorConflict(_)) => {
                s.motors[ci].hold = MotorHold::AtLimit;
                s.cable_tension_cmd_n[ci] = model.cables[ci].max_tension_n;
            }
            Err(e) => return Err(e),
        }
        core.motor.take_modes(s);
        s.carry.accel_history.forget();
        Ok(None)
    }

    /// Releases every tracking motor to its tension limit (before a rigid
    /// latch's velocity jump: a drive cannot deliver an impulse).
    pub(super) fn motors_release_for_impact(&mut self) {
        for ci in 0..self.state.motors.len() {
            if self.state.motors[ci].hold == MotorHold::Tracking {
                self.release_motor(ci, MotorHold::AtLimit);
            }
        }
    }

    /// Motor `ci` back to tension control: at its limit, or slack.
    fn release_motor(&mut self, ci: usize, hold: MotorHold) {
        let at_limit = hold == MotorHold::AtLimit;
        self.state.motors[ci].hold = hold;
        self.state.cable_tension_cmd_n[ci] = if at_limit {
            self.model.cables[ci].max_tension_n
        } else {
            0.0
        };
        self.core.stats.motor_releases += 1;
        self.core.motor.take_modes(&self.state);
        self.core.motor.conflicted.fill(false);
    }

    /// After an accepted sub-step: a tracking motor whose tension left [0, T_max] releases (to the
    /// limit, or slack); a released one whose cable runs at the commanded speed again engages.
    /// Either restarts the accelerations. Returns whether any motor changed.
    pub(super) fn motors_after_substep(&mut self) -> Result<bool, SolverError> {
        let mut changed = false;
        for ci in 0..self.model.cables.len() {
            let (m, c) = (&self.state.motors[ci], &self.model.cables[ci]);
            let Some(speed) = m.speed_cmd_m_s else {
                continue;
            };
            let reel_in = -c.length_rate(&self.state.x, &self.state.v);
            let t = self.state.cables[ci].segment_tension_n[0];
            let engage = match m.hold {
                MotorHold::Tracking if t > c.max_tension_n || t < 0.0 => {
                    let hold = if t < 0.0 {
                        MotorHold::Slack
                    } else {
                        MotorHold::AtLimit
                    };
                    self.release_motor(ci, hold);
                    changed = true;
                    false
                }
                MotorHold::AtLimit => reel_in >= speed,
                MotorHold::Slack => reel_in <= speed,
                _ => false,
            };
            // (one whose speed the tracking ones' system cannot take stays, untried in this step
            // unless a motor changes)
            if engage && !self.core.motor.conflicted[ci] {
                let conflict = self.motor_engage(ci)?.is_some();
                self.core.motor.conflicted[ci] = conflict;
                self.core.stats.motor_conflicts += u64::from(conflict);
                changed |= !conflict;
            }
        }
        if changed {
            self.core.motor.conflicted.fill(false);
            self.state.carry.accel_history.forget();
            self.restart_accelerations()?;
        }
        Ok(changed)
    }
}
