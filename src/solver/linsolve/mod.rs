//! Solvers of the constrained linear systems a step needs. Every one of them is
//! a solve with the mass-weighted constraint operator S = A M^-1 A^T:
//!
//! - accelerations: M Xddot = Q + A^T lambda, A Xddot = -c  (c = Adot Xdot);
//! - the mass-orthogonal correction dX = M^-1 A^T S^+ r, the smallest change in
//!   the M-norm with A dX = r, used for position and velocity projection and for
//!   latch impulses (its multipliers mu = S^+ r are the impulses).
//!
//! Redundant rows make S singular. The motion (accelerations, corrections,
//! joint forces A^T lambda) is unique; the multipliers are not. In
//! minimum-norm mode (`SolveMode::MinNorm`, an argument of `factor`) every backend returns S^+ r, the
//! least-squares, minimum-norm multipliers; otherwise a backend may return any
//! exact set (the sparse one leaves the rows it found redundant at zero). A
//! backend is factored once per configuration and then solves as often as
//! needed.

use super::jacobian::Jacobian;
use super::SolverError;

pub mod dense;
pub mod gmres;
pub mod sparse;
mod static_ldlt;

/// max |a|: f64::max's fold, by eight independent lanes and
/// compare-and-select so that it vectorizes (the same maximum; NaN is
/// skipped as f64::max skips it).
#[inline]
pub fn max_abs(a: &[f64]) -> f64 {
    const LANES: usize = 8;
    let mut m = [0.0f64; LANES];
    let chunks = a.chunks_exact(LANES);
    let tail = chunks.remainder();
    for c in chunks {
        let c: &[f64; LANES] = c.try_into().expect("a lane group");
        for k in 0..LANES {
            let v = c[k].abs();
            m[k] = if v > m[k] { v } else { m[k] };
        }
    }
    m.iter().chain(tail).fold(0.0f64, |x, v| x.max(v.abs()))
}

/// Which multipliers a factorization's solves return. For a consistent
/// right-hand side the motion is the same; off the constraint manifold
/// (Newmark iterates), where redundant rows are only nearly dependent, the two
/// differ at first order in the residual.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SolveMode {
    /// Any exact set of multipliers (the sparse backend leaves the rows it
    /// found redundant at zero): the stepping loop.
    Basic,
    /// The least-squares, minimum-norm multipliers S^+ r: latch impulses
    /// shared among redundant rows, the latch search, stalled iterations.
    MinNorm,
}

/// What a `factor` request did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FactorReport {
    /// A numeric factorization was made (else a kept one serves).
    pub fresh: bool,
    /// The redundant rows were probed (a rejecting factorization of every row).
    pub probed: bool,
}

/// What a solve did: its iterations, its final relative residual, whether it
/// met its tolerance, and the fallbacks it took on the way.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SolveReport {
    pub iterations: usize,
    /// Max |rhs - S lambda| / max |rhs| of the answer (0 for a direct solve).
    pub residual_rel: f64,
    /// False when the last iteration stopped at its iteration limit.
    pub converged: bool,
    /// The kept factorization was redone inside the solve.
    pub refactored: bool,
    /// The redundant rows were probed again inside the solve.
    pub reprobed: bool,
    /// The right-hand side was inconsistent: answered in least squares.
    pub least_squares: bool,
    /// Numeric factorizations the solve made itself (compliant solves
    /// factor S + D inside the solve when the kept one no longer serves),
    /// and whether a kept one served it (false when it was redone).
    pub factorizations: u32,
    pub reused_factorization: bool,
}

impl SolveReport {
    /// A direct solve (nothing iterated, nothing to fall back on).
    pub const DIRECT: SolveReport = SolveReport {
        iterations: 0,
        residual_rel: 0.0,
        converged: true,
        refactored: false,
        reprobed: false,
        least_squares: false,
        factorizations: 0,
        reused_factorization: false,
    };
}

/// What a backend keeps between calls that its answers depend on (a kept
/// factorization serves as a preconditioner, so the answers differ with it
/// at roundoff), as the inputs it was made from: `restore_kept` makes it
/// again from them, the same to the bit. Part of a `Snapshot`.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Kept {
    /// Nothing kept (a backend not yet factored).
    #[default]
    Nothing,
    /// The dense backend: the Jacobian values and inverse masses of its SVD.
    Dense {
        jac_values: Vec<f64>,
        inv_mass: Vec<f64>,
    },
    Sparse(sparse::SparseKept),
}

/// A backend for the solves with S = A M^-1 A^T. `factor` is asked for a
/// factorization at the Jacobian values in `jac` in a given mode (it may serve
/// a kept one); the solves that follow use it, whatever they need to redo
/// inside is reported.
pub trait ConstraintSolver: Send {
    fn name(&self) -> &'static str;
    /// Factor (or reuse a kept factorization) at the Jacobian values currently
    /// in `jac`, for solves in `mode`.
    fn factor(
        &mut self,
        jac: &Jacobian,
        inv_mass: &[f64],
        mode: SolveMode,
    ) -> Result<FactorReport, SolverError>;
    /// Constrained accelerations `a` and multipliers `lambda` (member forces, N).
    #[allow(clippy::too_many_arguments)]
    fn accelerations(
        &mut self,
        jac: &Jacobian,
        inv_mass: &[f64],
        q: &[f64],
        c: &[f64],
        a: &mut [f64],
        lambda: &mut [f64],
    ) -> Result<SolveReport, SolverError>;
    /// Accelerations of elastic members: M a = Q + A^T lambda with
    /// A a + D lambda = -c, D = diag(`d`) > 0 (a compliance per row, scaled
    /// to the step), so (S + D) lambda = -c - A M^-1 Q: positive definite
    /// however redundant or nearly redundant the rows are. Factors by itself
    /// at the Jacobian values in `jac` (a kept factorization serves while it
    /// preconditions well).
    #[allow(clippy::too_many_arguments)]
    fn compliant_accelerations(
        &mut self,
        jac: &Jacobian,
        inv_mass: &[f64],
        d: &[f64],
        q: &[f64],
        c: &[f64],
        a: &mut [f64],
        lambda: &mut [f64],
    ) -> Result<SolveReport, SolverError>;
    /// The system of `compliant_accelerations` solved once with the kept
    /// factorization of S + D, without refinement: the operator of a Newton
    /// direction (stage `newton`), where an error of the order of the
    /// factorization's age (Jacobian entries within `COMPLIANT_REUSE_TOL`)
    /// only bends the direction; the line search judges every iterate on
    /// the exact residual. Backends without a kept factorization solve
    /// exactly.
    #[allow(clippy::too_many_arguments)]
    fn compliant_response(
        &mut self,
        jac: &Jacobian,
        inv_mass: &[f64],
        d: &[f64],
        q: &[f64],
        c: &[f64],
        a: &mut [f64],
        lambda: &mut [f64],
    ) -> Result<SolveReport, SolverError> {
        self.compliant_accelerations(jac, inv_mass, d, q, c, a, lambda)
    }
    /// One correction of the system of `compliant_accelerations` from the
    /// multipliers in `lambda` (a warm start, overwritten by the corrected
    /// ones): lambda += P (rhs - (S + D) lambda) with P the kept
    /// factorization of S + D, made afresh where none serves (another D or
    /// other masses) or `refresh` asks, and a = M^-1 (Q + A^T lambda). The
    /// step of a modified Newton iteration (Exudyn's): the iteration around
    /// it converges to the exact solution whatever the factorization's age,
    /// at a rate its age sets. Backends without a kept factorization solve
    /// exactly.
    #[allow(clippy::too_many_arguments)]
    fn compliant_correction(
        &mut self,
        jac: &Jacobian,
        inv_mass: &[f64],
        d: &[f64],
        (q, c): (&[f64], &[f64]),
        a: &mut [f64],
        lambda: &mut [f64],
        _refresh: bool,
    ) -> Result<SolveReport, SolverError> {
        self.compliant_accelerations(jac, inv_mass, d, q, c, a, lambda)
    }
    /// dx = M^-1 A^T mu with mu = S^+ r (in the mode of the factorization).
    /// An iterative backend may stop once max |r - A dx| over the rows it
    /// solves is at most `residual_target` (a Newton correction whose
    /// caller checks the result; 0: as accurate as the factorization allows).
    fn correction(
        &mut self,
        jac: &Jacobian,
        inv_mass: &[f64],
        r: &[f64],
        residual_target: f64,
        dx: &mut [f64],
        mu: &mut [f64],
    ) -> Result<SolveReport, SolverError>;
    /// Whether the two modes give different multipliers with this backend
    /// (the dense one always returns the minimum-norm ones).
    fn distinguishes_modes(&self) -> bool {
        false
    }
    /// The rows a basic solve keeps (the others are taken as redundant), where
    /// the backend drops any.
    fn kept_rows(&self) -> Option<&[usize]> {
        None
    }
    /// The rows a basic solve leaves at zero into `out` (ascending): those
    /// the probe took as redundant and those the last basic factorization
    /// rejected (a rank drop since the probe); false where the backend drops
    /// none (its solves return minimum-norm multipliers).
    fn redundant_rows(&self, _out: &mut Vec<usize>) -> bool {
        false
    }
    /// Rank of A by pivot rejection (redundant rows found by a factorization),
    /// at the last basic factorization: far cheaper than an SVD and equal to it
    /// on well-conditioned trusses, but on a nearly singular one (a 360-sided
    /// ring folded at 35 deg: pivots of independent rows down to 4e-8, of
    /// redundant ones up to 6e-8) it can miscount, even above n.
    fn pivot_rank(&self) -> Option<usize> {
        None
    }
    /// Rank of A at the last factorization, where the method reveals it.
    fn rank(&self) -> Option<usize>;
    /// Counters for benchmarks (factorizations, iterations), as one line.
    fn diagnostics(&self) -> String {
        String::new()
    }
    /// What it keeps between calls (`Kept`).
    fn kept(&self) -> Kept;
    /// Makes the kept factorizations again from `kept`, for the block
    /// structure of `jac` (its values are not used).
    fn restore_kept(&mut self, jac: &Jacobian, kept: &Kept) -> Result<(), SolverError>;
    /// Drops every kept factorization: the next solves depend on their
    /// inputs alone.
    fn forget(&mut self);
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SolverKind {
    Dense,
    /// Sparse LDL^T of S = A M^-1 A^T (faer), regularized, with refinement.
    #[default]
    Sparse,
}

impl SolverKind {
    pub fn make(self) -> Box<dyn ConstraintSolver> {
        match self {
            SolverKind::Dense => Box::new(dense::DenseNullSpace::default()),
            SolverKind::Sparse => Box::new(sparse::SparseSchur::default()),
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            SolverKind::Dense => "dense",
            SolverKind::Sparse => "sparse",
        }
    }
}

/// Solves a small dense k x k system `mat` y = `rhs` (row-major) in place
/// (Gaussian elimination, partial pivoting). Err(col) where the pivot of
/// column `col` is below `tiny` times the largest diagonal: that column is
/// (nearly) 0, or a combination of the columns before it.
pub fn solve_small(mat: &mut [f64], rhs: &mut [f64], tiny: f64) -> Result<(), usize> {
    let k = rhs.len();
    let scale = (0..k).map(|i| mat[i * k + i].abs()).fold(0.0, f64::max);
    for col in 0..k {
        let p = (col..k)
            .max_by(|&a, &b| mat[a * k + col].abs().total_cmp(&mat[b * k + col].abs()))
            .unwrap_or(col);
        if !(mat[p * k + col].abs() > tiny * scale) {
            return Err(col);
        }
        if p != col {
            for j in 0..k {
                mat.swap(p * k + j, col * k + j);
            }
            rhs.swap(p, col);
        }
        for r in col + 1..k {
            let f = mat[r * k + col] / mat[col * k + col];
            for j in col..k {
                mat[r * k + j] -= f * mat[col * k + j];
            }
            rhs[r] -= f * rhs[col];
        }
    }
    for col in (0..k).rev() {
        let mut sum = rhs[col];
        for j in col + 1..k {
            sum -= mat[col * k + j] * rhs[j];
        }
        rhs[col] = sum / mat[col * k + col];
    }
    Ok(())
}
