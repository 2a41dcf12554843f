//! Newton steps of the Newmark iteration where the fixed-point iteration does not contract
//! (docs/solver.md, Newton switch). The iteration solves A = G(A), G(A) the constrained
//! accelerations at the Newmark (x, v) of A; its stiff explicit terms are the pulley friction's
//! blend (below the slip speed a damper of mu theta T / s_slip) and the springs of compliant
//! elements and latches (dQ/dA = -(k h^2/4 + c h/2) A^T A). Newton on R(A) = G(A) - A solves
//! (I - G') d = R(A), G' = P M_eff^-1 dQ/dA (P the constrained solve), by GMRES in the kinetic
//! inner product, one constrained solve per product; G' maps into the free motions, so GMRES needs
//! about as many iterations as there are mechanisms plus one. The friction law is piecewise smooth:
//! a line search (`newton_advance`) cuts the step back until the residual's kinetic norm
//! decreases, so only the direction uses the approximate derivative and the converged A is the
//! plain iteration's. Iterates alternating across many blends: one retry with secant slopes from
//! the best iterate (`newton_secant`).

use super::core::{Core, Pose, StepRule};
use crate::solver::cable;
use crate::solver::linsolve::gmres::weighted_dot;
use crate::solver::model::Model;
use crate::solver::settings::SolverSettings;
use crate::solver::SolverError;

impl Core {
    /// Starts the Newton steps from the current iterate (`a_guess`, its map value in `a`, cable
    /// readings and factorization at its (x, v)): accepts it, puts the first iterate in `a_guess`.
    pub(super) fn newton_start(
        &mut self,
        model: &Model,
        step: (f64, StepRule),
        st: &SolverSettings,
        pose: Pose,
    ) -> Result<(), SolverError> {
        // a fresh line search: an earlier failed search's bracket, step fraction and trial count
        // would refuse this first iterate and fail the Newton steps at once
        let nw = &mut self.newton;
        nw.norm_acc = f64::INFINITY;
        nw.gain = 0.0;
        nw.alpha = 1.0;
        nw.trials = 0;
        nw.hi = None;
        nw.kept_side = 0;
        self.newton_advance(model, step, st, pose).map(|_| ())
    }

    /// After the map value `a` of the Newton iterate `a_guess` is computed: accepts it (its
    /// residual's kinetic norm decreased enough) and puts the next Newton iterate in `a_guess`, or
    /// moves the step length along the direction. Returns false where the line search gives up.
    ///
    /// Line search: r(alpha) = <R(A + alpha d), d> changes sign where the step crosses the blend (a
    /// step from a saturated iterate is the plain one and overshoots to the other side); once a
    /// trial has bracketed that sign change, the next alpha is the bracket's Illinois point, else
    /// alpha is halved.
    pub(super) fn newton_advance(
        &mut self,
        model: &Model,
        step: (f64, StepRule),
        st: &SolverSettings,
        pose: Pose,
    ) -> Result<bool, SolverError> {
        let n = self.a.len();
        let (mut norm2, mut r_dir) = (0.0, 0.0);
        for i in 0..n {
            let r = self.a[i] - self.a_guess[i];
            norm2 += model.mass[i] * r * r;
            r_dir += model.mass[i] * r * self.newton.dir[i];
        }
        let norm = norm2.sqrt();
        let nw = &mut self.newton;
        // once bracketed, a decrease is accepted only near the sign change of <R, d>: a trial still
        // on the saturated side would start the next Newton step there and overshoot again
        let near = nw.hi.is_none() || r_dir.abs() <= st.newmark_newton_curvature * nw.r_dir0.abs();
        if norm.is_finite()
            && norm <= (1.0 - st.newmark_newton_decrease * nw.alpha) * nw.norm_acc
            && near
        {
            nw.a_acc.copy_from_slice(&self.a_guess);
            for i in 0..n {
                nw.r_acc[i] = self.a[i] - self.a_guess[i];
            }
            nw.norm_acc = norm;
            self.newton_direction(model, step, st, pose)?;
            self.stats.newton_steps += 1;
            let nw = &mut self.newton;
            nw.alpha = 1.0;
            nw.trials = 0;
            nw.lo = (0.0, weighted_dot(&model.mass, &nw.r_acc, &nw.dir));
            nw.r_dir0 = nw.lo.1;
            nw.hi = None;
            nw.kept_side = 0;
        } else {
            self.stats.newton_backtracks += 1;
            nw.trials += 1;
            if nw.trials > st.newmark_newton_line_search_max || !r_dir.is_finite() {
                return Ok(false);
            }
            let (a_lo, r_lo) = nw.lo;
            if r_dir * r_lo > 0.0 {
                nw.lo = (nw.alpha, r_dir);
                if nw.kept_side == 1 {
                    // Illinois: the far end kept twice, its value halved
                    if let Some(hi) = nw.hi.as_mut() {
                        hi.1 *= 0.5;
                    }
                }
                nw.kept_side = 1;
            } else {
                nw.hi = Some((nw.alpha, r_dir));
                if nw.kept_side == -1 {
                    nw.lo.1 *= 0.5;
                }
                nw.kept_side = -1;
            }
            nw.alpha = match nw.hi {
                Some((a_hi, r_hi)) if nw.lo.1 != r_hi => {
                    let (a_lo, r_lo) = nw.lo;
                    a_lo - r_lo * (a_hi - a_lo) / (r_hi - r_lo)
                }
                _ => {
                    // no sign change yet: back toward the accepted iterate
                    nw.lo = (a_lo, r_lo);
                    0.5 * nw.alpha
                }
            };
            if !(nw.alpha >= st.newmark_newton_min_step) {
                return Ok(false);
            }
        }
        let nw = &self.newton;
        for i in 0..n {
            self.a_guess[i] = nw.a_acc[i] + nw.alpha * nw.dir[i];
        }
        Ok(true)
    }

    /// Whether a friction blend is in play in this step (`pulleys_in_blend` from the step start):
    /// the iterates of a step across a blend can alternate between its two saturated sides.
    pub(super) fn friction_blend_active(&self, model: &Model) -> bool {
        self.pulleys_in_blend(model, &self.friction_sliding)
            .next()
            .is_some()
    }

    /// The pulleys (with friction) whose blend is in play, as (sliding now, sliding at `start`,
    /// slip speed): slower than the slip speed in the trial's cable readings or at `start`, or
    /// sliding the other way than at `start`.
    fn pulleys_in_blend<'a>(
        &'a self,
        model: &'a Model,
        start: &'a [Vec<f64>],
    ) -> impl Iterator<Item = (f64, f64, f64)> + 'a {
        model
            .cables
            .iter()
            .zip(&self.cables)
            .zip(start)
            .filter(|((c, _), _)| c.friction_mu > 0.0)
            .flat_map(|((c, e), start)| {
                let slip = c.slip_speed_m_s;
                e.sliding_m_s
                    .iter()
                    .zip(start)
                    .map(move |(&s, &s0)| (s, s0, slip))
            })
            .filter(|&(s, s0, slip)| s.abs() < slip || s0.abs() < slip || s * s0 < 0.0)
    }

    /// Whether the step went through a fast part of the friction's transient: a pulley in play
    /// (`pulleys_in_blend`) changed its sliding by more than `change_rel` times its slip speed.
    /// Inside the blend the friction is a damper whose time constant the step exceeds many times;
    /// a change of the sliding there is that transient, stepped over. The change is counted from
    /// `blend_start`: the step's start, or after a restart's short backward-Euler sub-steps
    /// (`Core::restart_substeps_left`) the restart's, whose transient those only began to damp.
    pub(super) fn friction_blend_entered(
        &self,
        model: &Model,
        change_rel: f64,
        start: &[Vec<f64>],
    ) -> bool {
        self.pulleys_in_blend(model, start)
            .any(|(s, s0, slip)| (s - s0).abs() > change_rel * slip)
    }

    /// The accepted Newton iterate back into `a_guess` (after a failed line search).
    pub(super) fn newton_best(&mut self) {
        self.a_guess.copy_from_slice(&self.newton.a_acc);
    }

    /// w = (I - G') x; G' x = P M_eff^-1 (dQ/dV (gamma h x) + dQ/dX (beta h^2 x)) (h/2 and h^2/4
    /// for the average acceleration, `StepGains`): the friction's blend and the springs of
    /// compliant elements and engaged compliant latches.
    fn newton_apply(
        &mut self,
        model: &Model,
        (h, rule): (f64, StepRule),
        pose: Pose,
        x: &[f64],
        w: &mut [f64],
    ) -> Result<(), SolverError> {
        let gains = rule.gains(h);
        let nw = &mut self.newton;
        let n = nw.n;
        for i in 0..n {
            nw.dv[i] = gains.velocity_s * x[i];
        }
        nw.dq.fill(0.0);
        for (ci, c) in model.cables.iter().enumerate() {
            let start = nw.secant.then_some(self.friction_sliding[ci].as_slice());
            cable::add_friction_derivative(c, &self.cables[ci], start, &self.x, &nw.dv, &mut nw.dq);
        }
        self.element_springs
            .add_force_derivative(model, gains, x, &mut nw.dq);
        w.copy_from_slice(x);
        if nw.dq.iter().all(|v| *v == 0.0) {
            return Ok(());
        }
        let report = if pose.rows.elastic_h().is_some() {
            self.solver.compliant_response(
                &self.jac,
                &self.inv_mass_eff,
                &self.row_d,
                &nw.dq,
                &nw.zero_c,
                &mut nw.da,
                &mut nw.lambda,
            )?
        } else {
            self.solver.accelerations(
                &self.jac,
                &self.inv_mass_eff,
                &nw.dq,
                &nw.zero_c,
                &mut nw.da,
                &mut nw.lambda,
            )?
        };
        let mut gain2 = 0.0;
        for i in 0..n {
            w[i] -= nw.da[i];
            gain2 += model.mass[i] * nw.da[i] * nw.da[i];
        }
        // `gain`: |G' x| for the unit x
        nw.gain = nw.gain.max(gain2.sqrt());
        self.book_solve(report);
        self.stats.newton_krylov_iterations += 1;
        Ok(())
    }

    /// The Newton direction: (I - G') dir = r_acc by GMRES in the kinetic inner product from 0.
    fn newton_direction(
        &mut self,
        model: &Model,
        step: (f64, StepRule),
        st: &SolverSettings,
        pose: Pose,
    ) -> Result<(), SolverError> {
        debug_assert!(pose.implicit_damping);
        // (the buffers leave the core while its operator runs)
        let mut gmres = std::mem::take(&mut self.newton.gmres);
        let (r_acc, mut dir) = (
            std::mem::take(&mut self.newton.r_acc),
            std::mem::take(&mut self.newton.dir),
        );
        let tol = st.newmark_newton_krylov_tol_rel;
        let solved = gmres.solve(&model.mass, &r_acc, tol, &mut dir, |x, w| {
            self.newton_apply(model, step, pose, x, w)
        });
        (self.newton.gmres, self.newton.r_acc, self.newton.dir) = (gmres, r_acc, dir);
        solved
    }
}
