//! Stage `projection`: positions and velocities back onto the constraint manifold by
//! mass-orthogonal corrections (Bayo and Ledesma), so no constraint drift accumulates, and the
//! least-work multipliers of a state (docs/solver.md, Integration).

use super::core::{Core, Pose};
use crate::solver::linsolve::{max_abs, SolveMode, SolverKind};
use crate::solver::model::Model;
use crate::solver::settings::SolverSettings;
use crate::solver::SolverError;

impl Core {
    /// Newton iterations X <- X - M^-1 A^T S^+ Phi(X) until max |Phi| <= `projection_tol_m`,
    /// with solves in `base` mode. Basic solves converge on the kept rows; where the dropped ones
    /// are only nearly redundant (e.g. every sleeve just latched at the flat deployed state) their
    /// residual stalls and the least-squares iteration takes over
    /// (`fallbacks.projection_min_norm`). Ending within `projection_accept_factor` of the tolerance
    /// is the roundoff floor of a large structure; beyond that it is an error.
    pub fn project_positions(
        &mut self,
        model: &Model,
        st: &SolverSettings,
        base: SolveMode,
    ) -> Result<(), SolverError> {
        let tol = st.projection_tol_m;
        let mut mode = base;
        let mut last = f64::INFINITY;
        for _ in 0..st.projection_max_iterations {
            self.jac.residual(model, &self.x, &mut self.r);
            self.violation_m = self.r.iter().fold(0.0, |m, v| m.max(v.abs()));
            if self.violation_m <= tol {
                return Ok(());
            }
            if mode == SolveMode::Basic
                && self.violation_m > st.projection_min_contraction * last
                && self.solver.distinguishes_modes()
            {
                mode = SolveMode::MinNorm;
                self.stats.fallbacks.projection_min_norm += 1;
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
            self.factor(model, mode, Pose::PLAIN)?;
            self.subtract_correction(model, false, st.projection_solve_fraction * tol)?;
        }
        if self.violation_m <= st.projection_accept_factor * tol {
            return Ok(());
        }
        Err(SolverError::Projection {
            violation_m: self.violation_m,
        })
    }

    /// V <- V - M^-1 A^T S^+ A V with the current factorization at x, made in `mode`. Returns the
    /// multipliers S^+ A V (a velocity jump's impulses) in `mu` and A V (before) in `r`.
    ///
    /// A V is consistent by construction: what is left is roundoff alike on every row, unless rows
    /// a basic solve dropped are no longer redundant (a rank change the probe has not seen). Their
    /// residual then stands out (beyond `velocity_redo_ratio` times the kept rows' and
    /// `velocity_redo_floor_rel` max|A| max|V|) and the projection is redone in least squares
    /// (`fallbacks.velocity_min_norm`). Nearly redundant dropped rows leave up to ~5e-12 |A||v|
    /// (18-ring near flat; ~6e-13 on a 180-ring at any time), accepted: redoing every such step
    /// cost the 180-ring 15x.
    pub fn project_velocities(
        &mut self,
        model: &Model,
        st: &SolverSettings,
        mode: SolveMode,
    ) -> Result<(), SolverError> {
        self.jac.mul(&self.v, &mut self.r);
        let amax = max_abs(&self.jac.values);
        let vmax = max_abs(&self.v);
        self.subtract_correction(model, true, st.velocity_solve_rel * amax * vmax)?;
        // (`c` is scratch until the accelerations that follow recompute it.)
        let Some(kept) = self.solver.kept_rows() else {
            return Ok(());
        };
        if mode == SolveMode::MinNorm {
            return Ok(());
        }
        self.jac.mul(&self.v, &mut self.c);
        let all = max_abs(&self.c);
        let on_kept = kept.iter().fold(0.0f64, |m, &i| m.max(self.c[i].abs()));
        let vmax = max_abs(&self.v);
        if all <= (st.velocity_redo_ratio * on_kept).max(st.velocity_redo_floor_rel * amax * vmax)
            || !self.solver.distinguishes_modes()
        {
            return Ok(());
        }
        self.stats.fallbacks.velocity_min_norm += 1;
        for (v, d) in self.v.iter_mut().zip(&self.dx) {
            *v += d;
        }
        self.factor(model, SolveMode::MinNorm, Pose::PLAIN)?;
        self.subtract_correction(model, true, 0.0)
    }

    /// Subtracts dX = M^-1 A^T S^+ r of `r` (multipliers into `mu`) from velocities or
    /// positions, solved to `residual_target` (`Core::correction`).
    fn subtract_correction(
        &mut self,
        model: &Model,
        velocities: bool,
        residual_target: f64,
    ) -> Result<(), SolverError> {
        self.correction(model, residual_target)?;
        let target = if velocities { &mut self.v } else { &mut self.x };
        for (t, d) in target.iter_mut().zip(&self.dx) {
            *t -= d;
        }
        Ok(())
    }

    /// The state's (x, lambda) multipliers with the same joint forces
    /// A^T lambda, split among redundant rows by least work, into `mu`.
    pub fn least_work_multipliers(
        &mut self,
        model: &Model,
        kind: SolverKind,
        x: &[f64],
        lambda: &[f64],
    ) -> Result<(), SolverError> {
        self.x.copy_from_slice(x);
        self.jac.fill(model, &self.x);
        self.jac.mul_t(lambda, &mut self.dx); // f = A^T lambda
        self.least_work_split(model, kind)
    }
}
