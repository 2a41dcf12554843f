//! Sparse backend: a sparse LDL^T factorization (faer) of the mass-weighted
//! constraint operator S = A M^-1 A^T, regularized as S + delta I, with iterated
//! preconditioned conjugate gradients towards the minimum-norm solution S^+ r.
//!
//! Pattern. S couples two rows exactly when their elements share a joint, so its
//! pattern follows from the Jacobian's block structure alone. It is built, with a
//! flat list of the products that make up every stored entry (an index map), the
//! first time a block structure is seen and again only when it changes (the locked
//! set changed); the fill-reducing ordering and the symbolic factorization are
//! redone then. Every factor() only refills the values and runs the numeric
//! LDL^T; no solve allocates (all work buffers and faer's scratch are kept).
//!
//! Redundant rows. States of self-stress make S singular. With
//! delta = `REG_REL` * max diag(S) the regularized matrix R = S + delta I is
//! positive definite and its LDL^T is used as the preconditioner of conjugate
//! gradients on S lambda = r, with S applied exactly as A M^-1 A^T. The
//! preconditioner is P = R^-1 S R^-1 (two triangular-solve pairs): it is zero
//! on null(S), so the iterates stay in range(S) and converge to the
//! minimum-norm multipliers S^+ r, and the preconditioned spectrum
//! (s / (s + delta))^2 is 1 to ~1e-8 except for the few directions with s near
//! delta (long flat masts), which CG resolves in a few more steps. Typically 2-3
//! steps; convergence is measured on g = M^-1 A^T lambda (the motion).
//! A right-hand side with a component along null(S) (inconsistent; not produced
//! by the simulator, whose right-hand sides are consistent to roundoff) makes
//! CG stall on roundoff; that is detected by the true residual, and g is then
//! computed by the projected Richardson iteration (no data-dependent step
//! length) and lambda = S^+ (A g) by CG again: the least-squares answer of the
//! dense SVD.
//!
//! Accuracy: g (accelerations, corrections, A^T lambda) to roundoff of the
//! dense result; the split of lambda among redundant rows (states of
//! self-stress) to about eps / REG_REL ~ 1e-7 relative, the roundoff of a solve
//! with R along null(S). `rank()` is not revealed (None).

use super::ConstraintSolver;
use crate::solver::jacobian::Jacobian;
use crate::solver::SolverError;
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::ldlt::factor::LdltRegularization;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, LdltRef, SymbolicCholesky, SymmetricOrdering,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};

/// Regularization relative to the largest diagonal entry of S.
pub const REG_REL: f64 = 1e-10;
/// Refinement stops when the (estimated) error of g is below this, relative to g.
const REFINE_TOL: f64 = 1e-15;
/// Updates that no longer shrink and are below this (relative to g) are roundoff.
const ROUNDOFF_FLOOR: f64 = 1e-12;
const MAX_REFINE: usize = 40;
/// CG steps longer than this are impossible for the preconditioned spectrum
/// (s / (s + delta))^2 unless s < 1e-4 delta: roundoff along null(S).
const ALPHA_MAX: f64 = 1e8;
/// A CG update of g this many times larger than g itself is roundoff.
const JUMP_MAX: f64 = 100.0;
/// A final relative residual above this marks a right-hand side with a
/// component along null(S) (roundoff alone leaves ~1e-15).
const INCONSISTENT: f64 = 1e-11;

/// One product of an entry of S: S[s] += sum_k A[o1 + k] A[o2 + k] / m[c0 + k].
#[derive(Clone, Copy, Debug)]
struct Contrib {
    s: u32,
    o1: u32,
    o2: u32,
    c0: u32,
}

/// A numeric LDL^T of S + delta I kept as the preconditioner of later solves.
/// CG always applies the exact S = A M^-1 A^T of the current configuration, so a
/// factorization from a nearby configuration only costs a few more iterations;
/// it is redone when the iterations grow, when it is `MAX_AGE` calls old, or
/// when the mass matrix changes.
#[derive(Default)]
struct Slot {
    l_vals: Vec<f64>,
    delta: f64,
    inv_mass: Vec<f64>,
    valid: bool,
    age: usize,
    /// Most CG iterations a solve needed with this factorization.
    worst_iterations: usize,
}

/// A kept factorization is refreshed once a solve needs more CG iterations.
const REUSE_MAX_ITERATIONS: usize = 6;
/// ... or after this many factor() calls.
const MAX_AGE: usize = 64;

#[derive(Default)]
pub struct SparseSchur {
    // Block structure the pattern was built for.
    sig_rows: usize,
    sig_cols: usize,
    sig_blocks: Vec<(usize, usize, usize, usize)>,
    sig_joints: Vec<usize>,
    ready: bool,
    // Upper triangle of S (CSC, sorted rows), and the index map.
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    s_vals: Vec<f64>,
    diag_pos: Vec<usize>,
    contrib: Vec<Contrib>,
    // Factorization: the symbolic analysis, and two numeric factorizations kept
    // for reuse (one per mass matrix in use: M, and M + h/2 C in damped steps).
    symbolic: Option<SymbolicCholesky<usize>>,
    slots: [Slot; 2],
    active: usize,
    signs: Vec<i8>,
    mem: Option<MemBuffer>,
    factored: bool,
    /// Numeric factorizations done, and factor() calls served by a kept one.
    pub numeric_factorizations: u64,
    pub reused_factorizations: u64,
    /// Minimum-norm solves and the CG iterations they took.
    pub solves: u64,
    pub cg_iterations: u64,
    // Work buffers (rows: m, coordinates: n).
    res: Vec<f64>,
    dl: Vec<f64>,
    lam: Vec<f64>,
    rhs2: Vec<f64>,
    rhs_keep: Vec<f64>,
    p: Vec<f64>,
    q: Vec<f64>,
    g: Vec<f64>,
    dg: Vec<f64>,
    g_keep: Vec<f64>,
    last_iterations: usize,
    /// Refinement steps of the last solve (diagnostics).
    pub total_iterations: usize,
    /// Solves whose right-hand side had a component along null(S) (diagnostics).
    pub inconsistent_solves: u64,
}

impl SparseSchur {
    fn same_structure(&self, jac: &Jacobian) -> bool {
        if !self.ready
            || self.sig_rows != jac.nrows
            || self.sig_cols != jac.ncols
            || self.sig_blocks.len() != jac.blocks.len()
        {
            return false;
        }
        let mut k = 0;
        for (b, s) in jac.blocks.iter().zip(&self.sig_blocks) {
            if (b.element, b.row0, b.rows, b.offset) != *s {
                return false;
            }
            for &c in &b.cols {
                if self.sig_joints.get(k) != Some(&c) {
                    return false;
                }
                k += 1;
            }
        }
        k == self.sig_joints.len()
    }

    /// Builds the pattern of S, the index map and the symbolic factorization.
    fn setup(&mut self, jac: &Jacobian) -> Result<(), SolverError> {
        let (m, n) = (jac.nrows, jac.ncols);
        self.sig_rows = m;
        self.sig_cols = n;
        self.sig_blocks = jac
            .blocks
            .iter()
            .map(|b| (b.element, b.row0, b.rows, b.offset))
            .collect();
        self.sig_joints = jac
            .blocks
            .iter()
            .flat_map(|b| b.cols.iter().copied())
            .collect();
        self.ready = true;
        self.factored = false;

        // Incidences (block, local joint) of every joint.
        let njoints = n / 3;
        let mut inc: Vec<Vec<(usize, usize)>> = vec![Vec::new(); njoints];
        for (bi, b) in jac.blocks.iter().enumerate() {
            for (jj, &c0) in b.cols.iter().enumerate() {
                inc[c0 / 3].push((bi, jj));
            }
        }
        // Pattern: upper triangle, per column j the rows i <= j.
        let mut cols: Vec<Vec<usize>> = vec![Vec::new(); m];
        for i in 0..m {
            cols[i].push(i);
        }
        for list in &inc {
            for &(b1, _) in list {
                for &(b2, _) in list {
                    let (p, q) = (&jac.blocks[b1], &jac.blocks[b2]);
                    for i in p.row0..p.row0 + p.rows {
                        for j in q.row0..q.row0 + q.rows {
                            if i <= j {
                                cols[j].push(i);
                            }
                        }
                    }
                }
            }
        }
        self.col_ptr.clear();
        self.row_idx.clear();
        self.col_ptr.push(0);
        for c in &mut cols {
            c.sort_unstable();
            c.dedup();
            self.row_idx.extend_from_slice(c);
            self.col_ptr.push(self.row_idx.len());
        }
        let nnz = self.row_idx.len();
        if nnz > u32::MAX as usize || jac.values.len() > u32::MAX as usize {
            return Err(SolverError::Invalid(
                "constraint system too large for the sparse solver".into(),
            ));
        }
        let pos = |i: usize, j: usize| -> usize {
            let lo = self.col_ptr[j];
            lo + self.row_idx[lo..self.col_ptr[j + 1]]
                .binary_search(&i)
                .expect("entry in pattern")
        };
        self.diag_pos = (0..m).map(|i| pos(i, i)).collect();
        let mut contrib = Vec::new();
        for (joint, list) in inc.iter().enumerate() {
            for &(b1, jj1) in list {
                for &(b2, jj2) in list {
                    let (p, q) = (&jac.blocks[b1], &jac.blocks[b2]);
                    let (w1, w2) = (Jacobian::width(p), Jacobian::width(q));
                    for r1 in 0..p.rows {
                        for r2 in 0..q.rows {
                            let (i, j) = (p.row0 + r1, q.row0 + r2);
                            if i > j {
                                continue;
                            }
                            contrib.push(Contrib {
                                s: pos(i, j) as u32,
                                o1: (p.offset + r1 * w1 + 3 * jj1) as u32,
                                o2: (q.offset + r2 * w2 + 3 * jj2) as u32,
                                c0: (3 * joint) as u32,
                            });
                        }
                    }
                }
            }
        }
        // Entries in storage order: the refill then streams through S.
        contrib.sort_unstable_by_key(|c| (c.s, c.o1, c.o2));
        self.contrib = contrib;
        self.s_vals = vec![0.0; nnz];
        self.signs = vec![1; m];
        for b in [
            &mut self.res,
            &mut self.dl,
            &mut self.lam,
            &mut self.rhs2,
            &mut self.rhs_keep,
            &mut self.p,
            &mut self.q,
        ] {
            *b = vec![0.0; m];
        }
        for b in [&mut self.g, &mut self.dg, &mut self.g_keep] {
            *b = vec![0.0; n];
        }
        for slot in &mut self.slots {
            *slot = Slot::default();
        }
        if m == 0 {
            self.symbolic = None;
            self.mem = None;
            return Ok(());
        }
        let sym = SymbolicSparseColMatRef::new_checked(m, m, &self.col_ptr, None, &self.row_idx);
        let symbolic = factorize_symbolic_cholesky(
            sym,
            Side::Upper,
            SymmetricOrdering::Amd,
            Default::default(),
        )
        .map_err(|e| SolverError::Invalid(format!("sparse symbolic factorization: {e:?}")))?;
        let req = StackReq::any_of(&[
            symbolic.factorize_numeric_ldlt_scratch::<f64>(Par::Seq, Default::default()),
            symbolic.solve_in_place_scratch::<f64>(1, Par::Seq),
        ]);
        for slot in &mut self.slots {
            slot.l_vals = vec![0.0; symbolic.len_val()];
        }
        self.mem = Some(MemBuffer::new(req));
        self.symbolic = Some(symbolic);
        Ok(())
    }

    /// Numeric LDL^T of S + delta I at the current Jacobian values into slot k.
    fn refactor(&mut self, jac: &Jacobian, inv_mass: &[f64], k: usize) -> Result<(), SolverError> {
        self.factored = false;
        self.active = k;
        let v = &jac.values;
        self.s_vals.fill(0.0);
        for c in &self.contrib {
            let (o1, o2, c0) = (c.o1 as usize, c.o2 as usize, c.c0 as usize);
            self.s_vals[c.s as usize] += v[o1] * v[o2] * inv_mass[c0]
                + v[o1 + 1] * v[o2 + 1] * inv_mass[c0 + 1]
                + v[o1 + 2] * v[o2 + 2] * inv_mass[c0 + 2];
        }
        if self.s_vals.iter().any(|x| !x.is_finite()) {
            return Err(SolverError::NonFinite("constraint Jacobian".into()));
        }
        let dmax = self
            .diag_pos
            .iter()
            .fold(0.0f64, |a, &p| a.max(self.s_vals[p]));
        let mut delta = REG_REL * dmax;
        if delta == 0.0 {
            delta = f64::MIN_POSITIVE;
        }
        for &p in &self.diag_pos {
            self.s_vals[p] += delta;
        }
        let slot = &mut self.slots[k];
        slot.delta = delta;
        slot.inv_mass.clear();
        slot.inv_mass.extend_from_slice(inv_mass);
        slot.valid = true;
        slot.age = 0;
        slot.worst_iterations = 0;
        self.numeric_factorizations += 1;
        let (Some(sym), Some(mem)) = (self.symbolic.as_ref(), self.mem.as_mut()) else {
            self.factored = true;
            return Ok(()); // no rows
        };
        let m = self.sig_rows;
        let a = SparseColMatRef::new(
            SymbolicSparseColMatRef::new_checked(m, m, &self.col_ptr, None, &self.row_idx),
            &self.s_vals,
        );
        // Pivots are at least delta in exact arithmetic; guard against roundoff.
        let reg = LdltRegularization {
            dynamic_regularization_signs: Some(&self.signs),
            dynamic_regularization_delta: delta,
            dynamic_regularization_epsilon: 0.5 * delta,
        };
        sym.factorize_numeric_ldlt(
            &mut self.slots[k].l_vals,
            a,
            Side::Upper,
            reg,
            Par::Seq,
            MemStack::new(mem),
            Default::default(),
        )
        .map_err(|e| SolverError::NonFinite(format!("sparse LDLT of S ({e:?})")))?;
        self.factored = true;
        Ok(())
    }

    /// dl <- R^-1 dl with the current factorization.
    fn ldlt_solve(&mut self) {
        let (Some(sym), Some(mem)) = (self.symbolic.as_ref(), self.mem.as_mut()) else {
            return;
        };
        let m = self.dl.len();
        LdltRef::new(sym, &self.slots[self.active].l_vals).solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(&mut self.dl, m, 1),
            Par::Seq,
            MemStack::new(mem),
        );
    }

    /// z <- P r for the preconditioner P = R^-1, or P = R^-1 S R^-1 =
    /// R^-1 (I - delta R^-1) when `projected` (r in `self.res`, z in `self.dl`).
    fn precondition(&mut self, projected: bool) {
        self.dl.copy_from_slice(&self.res);
        self.ldlt_solve();
        if projected {
            let delta = self.slots[self.active].delta;
            for (d, r) in self.dl.iter_mut().zip(&self.res) {
                *d = r - delta * *d;
            }
            self.ldlt_solve();
        }
    }

    /// Preconditioned conjugate gradients on S lambda = rhs (rhs in `self.res`
    /// on entry), with S applied as A M^-1 A^T and the regularized factorization
    /// as the preconditioner: the preconditioned spectrum s / (s + delta) is 1 up
    /// to roundoff except for the few ill-conditioned directions, which CG
    /// resolves in a few more steps. Leaves lambda in `self.lam`,
    /// g = M^-1 A^T lambda in `self.g`, the true final residual rhs - A g in
    /// `self.res` (rhs kept in `rhs2`), and returns max |residual| / max |rhs|.
    ///
    /// `projected`: with P = R^-1 S R^-1 the iterates stay in range(S) even when
    /// the rhs has a component along null(S) (inconsistent); CG then converges
    /// to the least-squares, minimum-norm solution. With P = R^-1 such a
    /// component is amplified by 1 / delta and has to be detected (the true
    /// residual stays large) and the solve redone.
    fn pcg(&mut self, jac: &Jacobian, inv_mass: &[f64], projected: bool) -> f64 {
        self.rhs2.copy_from_slice(&self.res);
        self.lam.fill(0.0);
        self.g.fill(0.0);
        let rmax = self.rhs2.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        if rmax == 0.0 {
            self.last_iterations = 0;
            return 0.0;
        }
        self.precondition(projected);
        self.p.copy_from_slice(&self.dl);
        let mut rz = dot(&self.res, &self.dl);
        let (mut it, mut dprev, mut gprev) = (0, f64::INFINITY, 0.0f64);
        while rz > 0.0 {
            it += 1;
            // h = M^-1 A^T p, q = A h = S p
            jac.mul_t(&self.p, &mut self.dg);
            for (h, im) in self.dg.iter_mut().zip(inv_mass) {
                *h *= im;
            }
            jac.mul(&self.dg, &mut self.q);
            let pq = dot(&self.p, &self.q);
            let alpha = rz / pq;
            let dmax = alpha * self.dg.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            // Safeguards: a non-positive curvature, or a step far beyond what the
            // preconditioned spectrum allows or far larger than the solution
            // itself, come from roundoff along null(S) (a slightly inconsistent
            // rhs), not from the solution: stop with what we have.
            if !(pq > 0.0 && alpha.is_finite())
                || alpha > ALPHA_MAX
                || (it >= 2 && dmax > JUMP_MAX * gprev)
            {
                it -= 1;
                break;
            }
            for i in 0..self.lam.len() {
                self.lam[i] += alpha * self.p[i];
                self.res[i] -= alpha * self.q[i];
            }
            let mut gmax = 0.0f64;
            for (g, h) in self.g.iter_mut().zip(&self.dg) {
                *g += alpha * h;
                gmax = gmax.max(g.abs());
            }
            gprev = gmax;
            // Stop when the update is negligible, when the error left after it,
            // dmax rho / (1 - rho) with the observed contraction rho, is, or when
            // the updates stagnate at the roundoff floor.
            let rho = dmax / dprev;
            dprev = dmax;
            if dmax <= REFINE_TOL * gmax
                || (it >= 2 && rho < 0.5 && dmax * rho / (1.0 - rho) <= REFINE_TOL * gmax)
                || (it >= 2 && rho >= 0.5 && dmax <= ROUNDOFF_FLOOR * gmax)
                || it >= MAX_REFINE
            {
                break;
            }
            self.precondition(projected);
            let rz_new = dot(&self.res, &self.dl);
            let beta = rz_new / rz;
            rz = rz_new;
            for (p, z) in self.p.iter_mut().zip(&self.dl) {
                *p = z + beta * *p;
            }
        }
        self.last_iterations = it;
        // true residual rhs - A g  (= rhs - S lambda)
        jac.mul(&self.g, &mut self.res);
        for (r, b) in self.res.iter_mut().zip(&self.rhs2) {
            *r = b - *r;
        }
        self.res.iter().fold(0.0f64, |a, v| a.max(v.abs())) / rmax
    }

    /// Projected iterated regularization (Richardson with P = R^-1 S R^-1) on
    /// S lambda = rhs, for right-hand sides with a component along null(S):
    /// no step length is computed from the data, so roundoff along null(S)
    /// cannot blow up; each step contracts the error by 1 - (s / (s + delta))^2.
    /// Same inputs and outputs as `pcg`, lambda aside (not minimum-norm).
    fn richardson(&mut self, jac: &Jacobian, inv_mass: &[f64]) {
        self.rhs2.copy_from_slice(&self.res);
        self.lam.fill(0.0);
        self.g.fill(0.0);
        let mut dprev = f64::INFINITY;
        for it in 1..=MAX_REFINE {
            self.precondition(true);
            jac.mul_t(&self.dl, &mut self.dg);
            let (mut dmax, mut gmax) = (0.0f64, 0.0f64);
            for i in 0..self.g.len() {
                self.dg[i] *= inv_mass[i];
                self.g[i] += self.dg[i];
                dmax = dmax.max(self.dg[i].abs());
                gmax = gmax.max(self.g[i].abs());
            }
            jac.mul(&self.g, &mut self.res);
            for (r, b) in self.res.iter_mut().zip(&self.rhs2) {
                *r = b - *r;
            }
            self.last_iterations = it;
            let rho = dmax / dprev;
            dprev = dmax;
            if dmax <= REFINE_TOL * gmax
                || (it >= 2 && rho < 0.5 && dmax * rho / (1.0 - rho) <= REFINE_TOL * gmax)
                || (it >= 2 && rho >= 0.5 && dmax <= ROUNDOFF_FLOOR * gmax)
            {
                break;
            }
        }
    }

    /// S^+ rhs: rhs in `self.res`; g and the minimum-norm lambda on return.
    fn solve_min_norm(&mut self, jac: &Jacobian, inv_mass: &[f64]) {
        self.rhs_keep.copy_from_slice(&self.res);
        let mut rel_res = self.pcg(jac, inv_mass, true);
        self.total_iterations = self.last_iterations;
        self.solves += 1;
        self.cg_iterations += self.last_iterations as u64;
        let slot = &mut self.slots[self.active];
        slot.worst_iterations = slot.worst_iterations.max(self.last_iterations);
        if rel_res > INCONSISTENT && slot.age > 0 {
            // A kept factorization may be too far off: refactor here and retry.
            if self.refactor(jac, inv_mass, self.active).is_ok() {
                self.res.copy_from_slice(&self.rhs_keep);
                rel_res = self.pcg(jac, inv_mass, true);
                self.total_iterations += self.last_iterations;
            }
        }
        if rel_res <= INCONSISTENT {
            return;
        }
        // The rhs has a component along null(S) (or CG stalled): g by the
        // robust projected iteration, then lambda = S^+ (A g), a consistent rhs,
        // by CG for the minimum-norm multipliers (g kept from the first).
        self.inconsistent_solves += 1;
        self.res.copy_from_slice(&self.rhs_keep);
        self.richardson(jac, inv_mass);
        self.total_iterations += self.last_iterations;
        self.g_keep.copy_from_slice(&self.g);
        jac.mul(&self.g_keep, &mut self.res);
        self.pcg(jac, inv_mass, true);
        self.total_iterations += self.last_iterations;
        std::mem::swap(&mut self.g, &mut self.g_keep);
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

impl ConstraintSolver for SparseSchur {
    fn name(&self) -> &'static str {
        "sparse"
    }

    fn factor(&mut self, jac: &Jacobian, inv_mass: &[f64]) -> Result<(), SolverError> {
        if !self.same_structure(jac) {
            self.setup(jac)?;
        }
        if jac.values.iter().any(|x| !x.is_finite()) {
            return Err(SolverError::NonFinite("constraint Jacobian".into()));
        }
        // Reuse a kept factorization for this mass matrix while it still
        // preconditions well; otherwise refactor into its slot (or the other one).
        let matching = (0..2).find(|&k| self.slots[k].valid && self.slots[k].inv_mass == inv_mass);
        if let Some(k) = matching {
            let slot = &mut self.slots[k];
            slot.age += 1;
            if slot.worst_iterations <= REUSE_MAX_ITERATIONS && slot.age <= MAX_AGE {
                self.active = k;
                self.factored = true;
                self.reused_factorizations += 1;
                return Ok(());
            }
        }
        let k = matching.unwrap_or(1 - self.active);
        self.refactor(jac, inv_mass, k)
    }

    fn accelerations(
        &mut self,
        jac: &Jacobian,
        inv_mass: &[f64],
        q: &[f64],
        c: &[f64],
        a: &mut [f64],
        lambda: &mut [f64],
    ) {
        let n = q.len();
        // a0 = M^-1 Q; lambda = S^+ (-c - A a0); a = a0 + M^-1 A^T lambda.
        for i in 0..n {
            a[i] = q[i] * inv_mass[i];
        }
        if jac.nrows == 0 {
            return;
        }
        jac.mul(a, &mut self.res);
        for (i, r) in self.res.iter_mut().enumerate() {
            *r = -c.get(i).copied().unwrap_or(0.0) - *r;
        }
        self.solve_min_norm(jac, inv_mass);
        for i in 0..n {
            a[i] += self.g[i];
        }
        let k = lambda.len().min(self.lam.len());
        lambda[..k].copy_from_slice(&self.lam[..k]);
    }

    fn correction(
        &mut self,
        jac: &Jacobian,
        inv_mass: &[f64],
        r: &[f64],
        dx: &mut [f64],
        mu: &mut [f64],
    ) {
        if jac.nrows == 0 {
            dx.fill(0.0);
            mu.fill(0.0);
            return;
        }
        self.res.copy_from_slice(&r[..jac.nrows]);
        self.solve_min_norm(jac, inv_mass);
        dx.copy_from_slice(&self.g[..dx.len()]);
        let k = mu.len().min(self.lam.len());
        mu[..k].copy_from_slice(&self.lam[..k]);
    }

    fn rank(&self) -> Option<usize> {
        None
    }

    fn diagnostics(&self) -> String {
        format!(
            "{} numeric factorizations ({} reused), {} solves, {:.2} CG iterations per solve",
            self.numeric_factorizations,
            self.reused_factorizations,
            self.solves,
            self.cg_iterations as f64 / self.solves.max(1) as f64
        )
    }
}
