//! The paper's method, dense: a rank-revealing SVD of the mass-scaled Jacobian
//! B = A M^-1/2 = U S V^T gives the rank r, a basis of null(A) and the generalized
//! inverse.
//!
//! With the M-orthonormal null-space basis H = M^-1/2 V_0 (V_0 the right singular
//! vectors of zero singular value) we have H^T M H = I, and the reduced
//! equations of the paper (Eq. 8), H^T M H alpha'' = H^T (Q + M A^+ Adot Xdot), give
//! alpha'' = V_0^T M^-1/2 Q, because the M-weighted generalized inverse
//! A^+ = M^-1/2 B^+ maps into range(V_r), orthogonal to V_0. Eq. 7 then reads, in
//! scaled coordinates y = M^1/2 X:
//!     y'' = V_0 V_0^T f - B^+ c,   f = M^-1/2 Q,   c = Adot Xdot,
//! and V_0 V_0^T = I - V_r V_r^T needs only the thin SVD. Multipliers follow from
//! B^T lambda = y'' - f. The rank is the one decision of `crate::solver::rank`
//! (the one `analyze` makes), so redundant rows (states of self-stress) are
//! handled exactly and both count alike. Both modes give the minimum-norm
//! multipliers.

use super::ConstraintSolver;
use crate::solver::jacobian::Jacobian;
use crate::solver::SolverError;
use nalgebra::{DMatrix, DVector};

use super::{FactorReport, Kept, SolveMode, SolveReport};

#[derive(Default)]
pub struct DenseNullSpace {
    u: DMatrix<f64>,
    vt: DMatrix<f64>,
    sigma: Vec<f64>,
    rank: usize,
    /// What the SVD was made at (`Kept::Dense`).
    kept: Kept,
}

impl DenseNullSpace {
    /// B^+ r = V_r S^-1 U_r^T r (length: coordinates, scaled).
    fn pinv(&self, r: &[f64]) -> DVector<f64> {
        let mut w = DVector::zeros(self.rank);
        for k in 0..self.rank {
            w[k] = self
                .u
                .column(k)
                .iter()
                .zip(r)
                .map(|(a, b)| a * b)
                .sum::<f64>()
                / self.sigma[k];
        }
        self.vt.rows(0, self.rank).transpose() * w
    }
    /// (B^T)^+ g = U_r S^-1 V_r^T g (length: rows).
    fn pinv_t(&self, g: &DVector<f64>) -> DVector<f64> {
        let mut w = self.vt.rows(0, self.rank) * g;
        for k in 0..self.rank {
            w[k] /= self.sigma[k];
        }
        self.u.columns(0, self.rank) * w
    }
}

impl ConstraintSolver for DenseNullSpace {
    fn name(&self) -> &'static str {
        "dense"
    }

    fn factor(
        &mut self,
        jac: &Jacobian,
        inv_mass: &[f64],
        _mode: SolveMode,
    ) -> Result<FactorReport, SolverError> {
        let mut b = DMatrix::<f64>::zeros(jac.nrows.max(1), jac.ncols);
        jac.for_each(|r, c, a| b[(r, c)] += a * inv_mass[c].sqrt());
        if b.iter().any(|v| !v.is_finite()) {
            return Err(SolverError::NonFiniteJacobian);
        }
        let (sigma, u, vt) = crate::solver::rank::thin_svd(&b)
            .ok_or_else(|| SolverError::NonFinite("SVD of the Jacobian (no convergence)".into()))?;
        (self.sigma, self.u, self.vt) = (sigma, u, vt);
        self.rank = if jac.nrows == 0 {
            0
        } else {
            crate::solver::rank::numerical_rank(&self.sigma)
        };
        match &mut self.kept {
            Kept::Dense {
                jac_values,
                inv_mass: w,
            } => {
                jac_values.clone_from(&jac.values);
                w.clear();
                w.extend_from_slice(inv_mass);
            }
            other => {
                *other = Kept::Dense {
                    jac_values: jac.values.clone(),
                    inv_mass: inv_mass.to_vec(),
                }
            }
        }
        Ok(FactorReport {
            fresh: true,
            probed: false,
        })
    }

    fn accelerations(
        &mut self,
        _jac: &Jacobian,
        inv_mass: &[f64],
        q: &[f64],
        c: &[f64],
        a: &mut [f64],
        lambda: &mut [f64],
    ) -> Result<SolveReport, SolverError> {
        let n = q.len();
        let f = DVector::from_fn(n, |i, _| q[i] * inv_mass[i].sqrt());
        // y'' = (I - V_r V_r^T) f - B^+ c
        let vr = self.vt.rows(0, self.rank);
        let mut y = &f - vr.transpose() * (vr * &f);
        if !c.is_empty() {
            y -= self.pinv(c);
        }
        for i in 0..n {
            a[i] = y[i] * inv_mass[i].sqrt();
        }
        if !lambda.is_empty() {
            let l = self.pinv_t(&(y - f));
            lambda.copy_from_slice(&l.as_slice()[..lambda.len()]);
        }
        Ok(SolveReport::DIRECT)
    }

    fn compliant_accelerations(
        &mut self,
        jac: &Jacobian,
        inv_mass: &[f64],
        d: &[f64],
        q: &[f64],
        c: &[f64],
        a: &mut [f64],
        lambda: &mut [f64],
    ) -> Result<SolveReport, SolverError> {
        let (m, n) = (jac.nrows, jac.ncols);
        for i in 0..n {
            a[i] = q[i] * inv_mass[i];
        }
        if m == 0 {
            return Ok(SolveReport::DIRECT);
        }
        let mut b = DMatrix::<f64>::zeros(m, n);
        jac.for_each(|r, col, v| b[(r, col)] += v);
        if b.iter().any(|v| !v.is_finite()) {
            return Err(SolverError::NonFiniteJacobian);
        }
        // S + D = A M^-1 A^T + D
        let bw = DMatrix::from_fn(m, n, |r, col| b[(r, col)] * inv_mass[col]);
        let mut s = &bw * b.transpose();
        for r in 0..m {
            s[(r, r)] += d[r];
        }
        let ab = &b * DVector::from_column_slice(a);
        let rhs = DVector::from_fn(m, |r, _| -c[r] - ab[r]);
        let chol = s
            .cholesky()
            .ok_or_else(|| SolverError::NonFinite("compliant constraint operator".into()))?;
        let l = chol.solve(&rhs);
        let g = bw.transpose() * &l;
        for i in 0..n {
            a[i] += g[i];
        }
        lambda[..m].copy_from_slice(l.as_slice());
        Ok(SolveReport {
            factorizations: 1,
            ..SolveReport::DIRECT
        })
    }

    fn correction(
        &mut self,
        _jac: &Jacobian,
        inv_mass: &[f64],
        r: &[f64],
        _residual_target: f64,
        dx: &mut [f64],
        mu: &mut [f64],
    ) -> Result<SolveReport, SolverError> {
        let dy = self.pinv(r);
        for i in 0..dx.len() {
            dx[i] = dy[i] * inv_mass[i].sqrt();
        }
        // mu = S^+ r = U_r S^-2 U_r^T r
        let w = DVector::from_fn(self.rank, |k, _| {
            self.u
                .column(k)
                .iter()
                .zip(r)
                .map(|(a, b)| a * b)
                .sum::<f64>()
                / self.sigma[k].powi(2)
        });
        let m = self.u.columns(0, self.rank) * w;
        mu.copy_from_slice(&m.as_slice()[..mu.len()]);
        Ok(SolveReport::DIRECT)
    }

    fn kept(&self) -> Kept {
        self.kept.clone()
    }

    fn restore_kept(&mut self, jac: &Jacobian, kept: &Kept) -> Result<(), SolverError> {
        *self = DenseNullSpace::default();
        if let Kept::Dense {
            jac_values,
            inv_mass,
        } = kept
        {
            let mut at = jac.clone();
            at.values.clone_from(jac_values);
            self.factor(&at, inv_mass, SolveMode::Basic)?;
        }
        Ok(())
    }

    fn forget(&mut self) {
        *self = DenseNullSpace::default();
    }

    fn rank(&self) -> Option<usize> {
        Some(self.rank)
    }
}
