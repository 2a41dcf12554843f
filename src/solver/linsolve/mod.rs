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
//! minimum-norm mode (`set_min_norm`) every backend returns S^+ r, the
//! least-squares, minimum-norm multipliers; otherwise a backend may return any
//! exact set (the sparse one leaves the rows it found redundant at zero). A
//! backend is factored once per configuration and then solves as often as
//! needed.

use super::jacobian::Jacobian;
use super::SolverError;

pub mod dense;
pub mod sparse;

pub trait ConstraintSolver: Send {
    fn name(&self) -> &'static str;
    /// Factor at the Jacobian values currently in `jac`.
    fn factor(&mut self, jac: &Jacobian, inv_mass: &[f64]) -> Result<(), SolverError>;
    /// Constrained accelerations `a` and multipliers `lambda` (member forces, N).
    fn accelerations(
        &mut self,
        jac: &Jacobian,
        inv_mass: &[f64],
        q: &[f64],
        c: &[f64],
        a: &mut [f64],
        lambda: &mut [f64],
    );
    /// dx = M^-1 A^T mu with mu = S^+ r (minimum-norm multipliers).
    fn correction(
        &mut self,
        jac: &Jacobian,
        inv_mass: &[f64],
        r: &[f64],
        dx: &mut [f64],
        mu: &mut [f64],
    );
    /// Whether later solves must return the least-squares, minimum-norm
    /// multipliers S^+ r (latch impulses shared among redundant rows) or may
    /// return any exact set (faster where the backend distinguishes them).
    /// For a consistent right-hand side the motion is the same; off the
    /// constraint manifold (Newmark iterates), where redundant rows are only
    /// nearly dependent, the two differ at first order in the residual.
    /// Returns whether this backend distinguishes them at all.
    fn set_min_norm(&mut self, _on: bool) -> bool {
        false
    }
    /// The rows a basic solve keeps (the others are taken as redundant), where
    /// the backend drops any.
    fn kept_rows(&self) -> Option<&[usize]> {
        None
    }
    /// Whether minimum-norm mode is on (always false where it makes no difference).
    fn is_min_norm(&self) -> bool {
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
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SolverKind {
    Dense,
    /// Sparse LDL^T of S = A M^-1 A^T (faer), regularized, with refinement.
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
