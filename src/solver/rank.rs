//! The rank decision, in one place.
//!
//! Singular values. A singular value sigma of the constraint Jacobian counts
//! as zero when sigma <= `RANK_TOL` sigma_max. The test is relative, so it is
//! blind to the units of the rows (every row is a length) and to a uniform
//! scaling of the masses; it is applied alike to A (`analyze`, the
//! simulator's mobility count) and to the mass-scaled B = A M^-1/2 (the dense
//! backend), whose ranks agree in exact arithmetic. Roundoff leaves
//! ~1e-15 sigma_max on truly zero singular values; the smallest nonzero ones
//! of the bundled trusses are above 1e-4 sigma_max, so the decision has
//! six orders of margin on either side.
//!
//! Rows. A row is redundant when its component outside the span of the rows
//! before it is at most 1e-5 of its length (the sine of the angle between
//! the row and that span; `ROW_SINE_SQ_TOL` is its square). `analyze` lists
//! redundant rows by this test (Gram-Schmidt); the sparse backend's probe
//! applies it to the pivots of the unit-diagonal S~ = D^-1/2 A M^-1 A^T
//! D^-1/2, which are those squared sines in the M^-1 inner product (equal
//! to the plain ones where the joints a row touches have equal masses).
//! A sine of 1e-5 is a singular value of at most 1e-5 |row|: a row the SVD
//! counts as independent (sigma > 1e-9 sigma_max) may thus be called
//! redundant by the row test only in a truss with a singular value between
//! 1e-9 and 1e-5 of the largest, i.e. nearly singular (see
//! `ConstraintSolver::pivot_rank`).

use super::jacobian::Jacobian;

/// Relative singular-value threshold of the rank decision.
pub const RANK_TOL: f64 = 1e-9;

/// A row whose component outside the span of the rows before it is at most
/// 1e-5 of its length is redundant: this is the square of that sine.
pub const ROW_SINE_SQ_TOL: f64 = 1e-10;

/// Whether a row with squared sine `sine_sq` to the span of the rows before
/// it (a pivot of the unit-diagonal S~, or |w|^2 / |row|^2 after
/// Gram-Schmidt) is redundant.
pub fn row_is_redundant(sine_sq: f64) -> bool {
    sine_sq <= ROW_SINE_SQ_TOL
}

/// Number of singular values above `RANK_TOL` times the largest.
pub fn numerical_rank(singular_values: &[f64]) -> usize {
    let smax = singular_values.iter().cloned().fold(0.0, f64::max);
    singular_values
        .iter()
        .filter(|s| **s > RANK_TOL * smax)
        .count()
}

/// Numerical rank of A by a dense SVD.
pub fn of_jacobian(jac: &Jacobian) -> usize {
    if jac.nrows == 0 {
        return 0;
    }
    numerical_rank(jac.to_dense().singular_values().as_slice())
}

/// The thin SVD B = U diag(sigma) V^T of a dense matrix (faer's: several
/// times faster than nalgebra's at a few hundred coordinates): sigma in
/// decreasing order, U (rows x p) and V^T (p x columns), p = min(rows,
/// columns); None when the iteration does not converge.
pub fn thin_svd(
    b: &nalgebra::DMatrix<f64>,
) -> Option<(Vec<f64>, nalgebra::DMatrix<f64>, nalgebra::DMatrix<f64>)> {
    let fb = faer::Mat::<f64>::from_fn(b.nrows(), b.ncols(), |i, j| b[(i, j)]);
    let svd = fb.thin_svd().ok()?;
    let (u, v, s) = (svd.U(), svd.V(), svd.S().column_vector());
    let p = s.nrows();
    let sigma: Vec<f64> = (0..p).map(|k| s[k]).collect();
    debug_assert!(sigma.windows(2).all(|w| w[0] >= w[1]), "faer orders sigma");
    let u = nalgebra::DMatrix::from_fn(u.nrows(), p, |i, k| u[(i, k)]);
    let vt = nalgebra::DMatrix::from_fn(p, v.nrows(), |k, j| v[(j, k)]);
    Some((sigma, u, vt))
}
