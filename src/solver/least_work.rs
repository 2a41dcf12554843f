//! Least-work sharing of redundant forces and impulses (Menabrea; the static
//! force method).
//!
//! With redundant rows (states of self-stress, A^T s = 0) the multipliers of a
//! rigid model are not unique: any self-stress can be added to lambda without
//! changing the joint forces f = A^T lambda or the motion. Elastic members
//! decide the split. Among all lambda with the same f, the physical one
//! minimizes the complementary energy
//!
//!   U*(lambda) = 1/2 sum_i c_i lambda_i^2,   c_i = L_i / (E A_i)  (m/N),
//!
//! (Menabrea's theorem of least work; for a linear-elastic truss it is the
//! stiffness-method answer N = (EA/L) e^T u with K u = f, K = A^T C^-1 A).
//! With W = diag(c)^(-1/2) and lambda = W mu, U* = |mu|^2 / 2 and the
//! constraint reads (W A)^T mu = f: mu is the minimum-norm solution, which is
//! the least-squares solve every backend has, on the row-scaled Jacobian:
//!
//!   mu = S_w^+ (W A) M^-1 f,   S_w = (W A) M^-1 (W A)^T.
//!
//! Equal compliances give the minimum-norm split; two parallel members share
//! in proportion to their stiffness EA/L. The same function serves member
//! forces (f = A^T lambda of the state) and latch impulses (f = M (V- - V+),
//! the joint impulses of the velocity jump).
//!
//! Rows that are not members (pivots, coplanarity, supports, hinges) are
//! rigid, as the stiffness method takes supports and pins: compliance 0. The
//! row scaling needs c > 0, so they get c = eps c_min (c_min: the stiffest
//! member's) and the limit eps -> 0 is taken by Richardson extrapolation:
//! lambda(eps) is smooth in eps with lambda(eps) = lambda_0 + eps lambda_1 +
//! O(eps^2), so 2 lambda(eps/2) - lambda(eps) = lambda_0 + O(eps^2). With
//! eps = 1e-6 the extrapolated forces are rigid-support forces to ~1e-12,
//! where one solve at eps = 1e-10 was off by 1.5e-11 (three-bar oracle) but
//! its row scaling (1e5) cost the sparse backend's regularized solve up to
//! 2.7e-6 of accuracy against dense (1-unit mast); at eps = 1e-6 the two
//! agree to 5e-10.

use super::jacobian::Jacobian;
use super::linsolve::{ConstraintSolver, SolveMode, SolverKind};
use super::model::Model;
use super::SolverError;
use faer::linalg::solvers::SolveLstsq;

/// A backend instance of its own (the stepping solver's kept factorizations,
/// counters and re-probe schedule are untouched, so the trajectory does not
/// depend on how often forces are asked for), factored afresh for every
/// split (which then depends on its inputs alone), and the row-scaled
/// Jacobian.
///
/// On the sparse backend the split is made on an explicit basis of the
/// states of self-stress (`split_by_self_stress`); on the dense one it is
/// the SVD's minimum-norm solve of the row-scaled system (`split`), which
/// also redoes a sparse split that is not exact (the kept rows lost rank at
/// a near-dependent state, or the joint forces moved), up to
/// `rank_check_max_coords`; beyond it the sparse answer is kept and counted
/// inexact. (The sparse backend's own minimum-norm solve of the row-scaled
/// system is not used: that system spreads its diagonal over
/// `least_work_rigid_row_eps`^-1, 1e6, and its iteration can find the right-hand side
/// inconsistent and stop unconverged, with multipliers whose A^T lambda is
/// not f at all.)
pub struct LeastWork {
    solver: Box<dyn ConstraintSolver>,
    /// The dense backend for the splits the sparse one cannot give exactly
    /// (made on first need).
    dense: Option<Box<dyn ConstraintSolver>>,
    /// Splits made again by the dense backend, and splits kept though the
    /// sparse solve was not exact (the model beyond `rank_check_max_coords`).
    pub dense_splits: u64,
    pub inexact_splits: u64,
    jac: Jacobian,
    /// Per row of `jac`: c_i (m/N) for members, NaN for rigid rows.
    compliance: Vec<f64>,
    /// w_i = c_i^(-1/2) at the current eps.
    weight: Vec<f64>,
    /// lambda at eps (the first of the two solves).
    lambda_eps: Vec<f64>,
    r: Vec<f64>,
    dx: Vec<f64>,
    mu: Vec<f64>,
    /// The self-stress route's scratch: the redundant rows, the kept-row
    /// N (rows x redundant rows), lambda_p, A^T lambda and A^T lambda_p.
    redundant: Vec<usize>,
    basis: nalgebra::DMatrix<f64>,
    lambda_p: Vec<f64>,
    force: Vec<f64>,
    force_p: Vec<f64>,
}

impl LeastWork {
    pub fn new(kind: SolverKind) -> LeastWork {
        LeastWork {
            solver: kind.make(),
            dense: None,
            dense_splits: 0,
            inexact_splits: 0,
            jac: Jacobian::default(),
            compliance: Vec::new(),
            weight: Vec::new(),
            lambda_eps: Vec::new(),
            r: Vec::new(),
            dx: Vec::new(),
            mu: Vec::new(),
            redundant: Vec::new(),
            basis: nalgebra::DMatrix::zeros(0, 0),
            lambda_p: Vec::new(),
            force: Vec::new(),
            force_p: Vec::new(),
        }
    }

    /// Row compliances c_i (m/N) of the active rows of `jac`: NaN for rows
    /// that are not members (rigid).
    pub fn row_compliance(model: &Model, jac: &Jacobian, out: &mut Vec<f64>) {
        out.resize(jac.nrows, f64::NAN);
        for b in &jac.blocks {
            let c = &mut out[b.row0..b.row0 + b.rows];
            model.elements[b.element].row_compliance_m_per_n(true, model.axial_stiffness_n, c);
        }
    }

    /// The least-work multipliers (into `lambda`, row order of `jac`) whose
    /// joint forces are `f` (N, or N s for impulses): `jac` is filled at the
    /// configuration and `f` must lie in the range of A^T (it is A^T of some
    /// multipliers, or M times a velocity jump onto null(A)).
    pub fn multipliers(
        &mut self,
        model: &Model,
        jac: &Jacobian,
        f: &[f64],
        lambda: &mut [f64],
    ) -> Result<(), SolverError> {
        if self.jac.structure_id != jac.structure_id || self.jac.nrows != jac.nrows {
            self.jac = jac.clone();
            Self::row_compliance(model, jac, &mut self.compliance);
            self.weight.resize(jac.nrows, 0.0);
            self.lambda_eps.resize(jac.nrows, 0.0);
            self.r.resize(jac.nrows, 0.0);
            self.mu.resize(jac.nrows, 0.0);
            self.dx.resize(jac.ncols, 0.0);
            self.force.resize(jac.ncols, 0.0);
            self.force_p.resize(jac.ncols, 0.0);
        }
        let mut lambda_eps = std::mem::take(&mut self.lambda_eps);
        let mut dense = false;
        let mut solved = if self.solver.name() == "sparse" {
            self.split_by_self_stress(model, jac, f, &mut lambda_eps, lambda)
        } else {
            self.split(model, jac, f, &mut lambda_eps, lambda, dense)
        };
        if let Ok(false) = solved {
            // (an inexact sparse split: the dense SVD's, where it is affordable)
            if jac.ncols <= model.solver.rank_check_max_coords {
                dense = true;
                self.dense_splits += 1;
                solved = self.split(model, jac, f, &mut lambda_eps, lambda, dense);
            } else {
                self.inexact_splits += 1;
            }
        }
        self.lambda_eps = lambda_eps;
        if let Ok(false) = solved {
            if dense {
                self.inexact_splits += 1;
            }
        }
        solved?;
        if lambda.iter().any(|v| !v.is_finite()) {
            return Err(SolverError::NonFinite("least-work multipliers".into()));
        }
        Ok(())
    }

    /// The split by an explicit basis of the states of self-stress (the
    /// sparse backend, whose basic solve finds the redundant rows and is
    /// exact on the others). Every split is lambda = lambda_p + N s:
    ///
    /// - lambda_p: the basic solve's multipliers with A^T lambda_p = f (the
    ///   rows found redundant at zero), mu of S_K mu = A_K M^-1 f;
    /// - column j of N, for redundant row j: the self-stress e_j - t_j with
    ///   A_K^T t_j = a_j^T (a_j: row j, A_K: the kept rows), so A^T N = 0,
    ///   t_j from the same factorization, S_K t_j = A_K M^-1 a_j^T;
    ///
    /// and least work is the small weighted least-squares problem
    ///
    ///   s = argmin | C^1/2 (lambda_p + N s) |,
    ///
    /// solved by a QR of C^1/2 N (k columns, one per redundant row: its
    /// conditioning is not squared as in the normal equations or in S_w),
    /// at eps and eps / 2 for the rigid rows with the Richardson step of
    /// `split`. Ok(whether exact: the kept rows held their rank and
    /// A^T lambda = f to `least_work_feasible_rel`, or = A^T lambda_p, the
    /// projection of f onto the range of A^T where f has a part off it, as
    /// the dense SVD's least squares gives).
    fn split_by_self_stress(
        &mut self,
        model: &Model,
        jac: &Jacobian,
        f: &[f64],
        lambda_eps: &mut [f64],
        lambda: &mut [f64],
    ) -> Result<bool, SolverError> {
        let m = jac.nrows;
        let inv_mass = &model.inv_mass;
        self.solver.forget();
        self.solver.factor(jac, inv_mass, SolveMode::Basic)?;
        let mut redundant = std::mem::take(&mut self.redundant);
        self.solver.redundant_rows(&mut redundant);
        self.redundant = redundant;
        if let Some(kept) = self.solver.kept_rows() {
            if self.solver.pivot_rank() != Some(kept.len()) {
                return Ok(false);
            }
        }
        // lambda_p
        for ((d, fi), im) in self.dx.iter_mut().zip(f).zip(inv_mass) {
            *d = fi * im;
        }
        jac.mul(&self.dx, &mut self.r);
        let report = self
            .solver
            .correction(jac, inv_mass, &self.r, 0.0, &mut self.dx, lambda)?;
        if !report.converged || report.least_squares {
            return Ok(false);
        }
        // (the joint forces the split must keep: f where f is in the range
        // of A^T, else its projection, the dense SVD's least squares too)
        jac.mul_t(lambda, &mut self.force_p);
        let k = self.redundant.len();
        if k > 0 {
            // N, column by column
            self.basis = nalgebra::DMatrix::zeros(m, k);
            for (col, &j) in self.redundant.iter().enumerate() {
                self.r.fill(0.0);
                self.r[j] = 1.0;
                jac.mul_t(&self.r, &mut self.force);
                for (d, im) in self.force.iter_mut().zip(inv_mass) {
                    *d *= im;
                }
                jac.mul(&self.force, &mut self.r);
                let report = self.solver.correction(
                    jac,
                    inv_mass,
                    &self.r,
                    0.0,
                    &mut self.dx,
                    &mut self.mu,
                )?;
                if !report.converged || report.least_squares {
                    return Ok(false);
                }
                let mut column = self.basis.column_mut(col);
                for (c, t) in column.iter_mut().zip(&self.mu) {
                    *c = -t;
                }
                column[j] = 1.0;
            }
            // the least-squares problem at eps and eps / 2, extrapolated
            self.lambda_p.clear();
            self.lambda_p.extend_from_slice(lambda);
            let eps0 = model.solver.least_work_rigid_row_eps;
            for (slot, eps) in [eps0, 0.5 * eps0].into_iter().enumerate() {
                for (w, c) in self.weight.iter_mut().zip(&self.compliance) {
                    // (relative to the stiffest member's: rigid rows at eps)
                    let rel = if c.is_finite() {
                        c / model.stiffest_compliance_m_per_n
                    } else {
                        eps
                    };
                    *w = rel.sqrt();
                }
                // (faer's blocked Householder QR; Q^T h by its reflections)
                let g = faer::Mat::<f64>::from_fn(m, k, |i, c| self.weight[i] * self.basis[(i, c)]);
                let qr = g.qr();
                let r = qr.thin_R();
                if (0..k.min(m)).any(|i| r[(i, i)] == 0.0) || m < k {
                    return Ok(false);
                }
                let h = faer::Mat::<f64>::from_fn(m, 1, |i, _| self.weight[i] * self.lambda_p[i]);
                let s = qr.solve_lstsq(&h);
                let s = nalgebra::DVector::from_fn(k, |i, _| s[(i, 0)]);
                let target: &mut [f64] = if slot == 0 { lambda_eps } else { lambda };
                let split = &self.basis * s;
                for ((l, p), ns) in target.iter_mut().zip(&self.lambda_p).zip(split.iter()) {
                    *l = p - ns;
                }
            }
            for (l, le) in lambda.iter_mut().zip(lambda_eps.iter()) {
                *l = 2.0 * *l - le; // Richardson, as in `split`
            }
        }
        // A^T lambda as f, or as A^T lambda_p where f has a part off the
        // range of A^T (A^T N = 0), relative to the size of its terms. (f
        // is the better reference where it is in the range: the basic
        // solve's own A^T lambda_p is off f by a median 2.4e-9 of these
        // terms over the bundled models' steps, the split's by at most
        // 4.3e-12 on the deploying ring, the dense SVD's by 1.2e-10.)
        jac.mul_t(lambda, &mut self.force);
        let amax = jac.values.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let lmax = lambda.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let fmax = self.force_p.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let off = |reference: &[f64]| {
            self.force
                .iter()
                .zip(reference)
                .fold(0.0f64, |a, (g, fp)| a.max((g - fp).abs()))
        };
        let tol = model.solver.least_work_feasible_rel * (fmax + amax * lmax);
        Ok(off(f) <= tol || off(&self.force_p) <= tol)
    }

    /// The split at eps and eps / 2 and their Richardson extrapolation into
    /// `lambda` (`lambda_eps`: scratch), on the dense backend or the
    /// model's; Ok(whether both solves were exact: converged, not answered
    /// in least squares by an iteration).
    fn split(
        &mut self,
        model: &Model,
        jac: &Jacobian,
        f: &[f64],
        lambda_eps: &mut [f64],
        lambda: &mut [f64],
        dense: bool,
    ) -> Result<bool, SolverError> {
        let eps = model.solver.least_work_rigid_row_eps;
        let exact_eps = self.solve(model, jac, f, eps, lambda_eps, dense)?;
        let exact_half = self.solve(model, jac, f, 0.5 * eps, lambda, dense)?;
        for (l, le) in lambda.iter_mut().zip(lambda_eps.iter()) {
            *l = 2.0 * *l - le; // Richardson: the limit of rigid non-member rows
        }
        Ok(exact_eps && exact_half)
    }

    /// lambda minimizing sum c_i lambda_i^2 with A^T lambda = f, rows that are
    /// not members at c = eps c_min; Ok(whether the solve was exact).
    fn solve(
        &mut self,
        model: &Model,
        jac: &Jacobian,
        f: &[f64],
        eps: f64,
        lambda: &mut [f64],
        dense: bool,
    ) -> Result<bool, SolverError> {
        let rigid = eps * model.stiffest_compliance_m_per_n;
        for (w, c) in self.weight.iter_mut().zip(&self.compliance) {
            *w = 1.0 / if c.is_finite() { *c } else { rigid }.sqrt();
        }
        // rows of W A: each block's row-major rows scaled by their weight
        self.jac.values.copy_from_slice(&jac.values);
        for b in &self.jac.blocks {
            let width = Jacobian::width(b);
            for r in 0..b.rows {
                let w = self.weight[b.row0 + r];
                let start = b.offset + r * width;
                for v in &mut self.jac.values[start..start + width] {
                    *v *= w;
                }
            }
        }
        // mu = S_w^+ r with r = (W A) M^-1 f; lambda = W mu
        for ((d, fi), im) in self.dx.iter_mut().zip(f).zip(&model.inv_mass) {
            *d = fi * im;
        }
        self.jac.mul(&self.dx, &mut self.r);
        // (a fresh factorization: the split depends on the state alone,
        // not on the solves before it)
        let solver = if dense {
            self.dense.get_or_insert_with(|| SolverKind::Dense.make())
        } else {
            &mut self.solver
        };
        solver.forget();
        solver.factor(&self.jac, &model.inv_mass, SolveMode::MinNorm)?;
        let report = solver.correction(
            &self.jac,
            &model.inv_mass,
            &self.r,
            0.0,
            &mut self.dx,
            &mut self.mu,
        )?;
        for ((l, m), w) in lambda.iter_mut().zip(&self.mu).zip(&self.weight) {
            *l = m * w;
        }
        // (the dense SVD's least squares is exact: the iterative one's is not)
        Ok(report.converged && (dense || !report.least_squares))
    }
}
