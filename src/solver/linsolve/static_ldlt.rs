//! LDL^T of a symmetric positive definite matrix whose pattern is fixed, in
//! a fill-reducing order given once (the compliant system S + D of a locked
//! set, refactored every time its Jacobian has moved).
//!
//! Up-looking (T. Davis' LDL): row k of L solves L_{0..k,0..k} D l_k = a_k,
//! the part of column k of P A P^T above the diagonal, whose nonzeros are the
//! nodes reached from a_k's rows up the elimination tree (ereach). The
//! pattern never changes between factorizations, so the tree, every row's
//! reach in elimination order, L's row indices and the permutation of A's
//! entries are computed once; a numeric factorization is then the
//! arithmetic alone: one scatter of A's column, and for every nonzero l_kj
//!     y -= L_{:,j} y_j,   l_kj = y_j / d_j,   d_k -= l_kj y_j.

use crate::solver::SolverError;

/// The factorization and the maps that make it (all sized once).
#[derive(Clone, Debug, Default)]
pub struct StaticLdlt {
    // P A P^T, upper triangle by columns (rows ascending), and where each
    // entry of the caller's upper-triangular storage lands in it.
    ap: Vec<usize>,
    ai: Vec<usize>,
    ax: Vec<f64>,
    src_pos: Vec<usize>,
    /// perm[k]: the caller's index at position k of the order.
    perm: Vec<usize>,
    /// L strictly below its diagonal by columns (rows ascending), and D.
    lp: Vec<usize>,
    li: Vec<usize>,
    lx: Vec<f64>,
    d: Vec<f64>,
    /// Row k's nonzeros l_kj (columns j < k) in an order that eliminates
    /// each after those it depends on: rj[rp[k]..rp[k + 1]].
    rp: Vec<usize>,
    rj: Vec<usize>,
    // scratch: the dense row, the entries of each column done so far, the
    // permuted right-hand side
    y: Vec<f64>,
    done: Vec<usize>,
    x: Vec<f64>,
}

impl StaticLdlt {
    /// The symbolic analysis of A (upper triangle by columns: `col_ptr`,
    /// `row_idx`, rows ascending, diagonal included) in the order `perm`
    /// (perm[k] = the index at position k).
    pub fn new(col_ptr: &[usize], row_idx: &[usize], perm: &[usize]) -> StaticLdlt {
        const NONE: usize = usize::MAX;
        let n = perm.len();
        let mut inv = vec![0; n];
        for (k, &i) in perm.iter().enumerate() {
            inv[i] = k;
        }
        // P A P^T's upper triangle: entry (i, j) of A goes to (min, max) of
        // (inv[i], inv[j]).
        let nnz = row_idx.len();
        let mut count = vec![0usize; n + 1];
        let mut at = Vec::with_capacity(nnz);
        for j in 0..n {
            for &i in &row_idx[col_ptr[j]..col_ptr[j + 1]] {
                let (a, b) = (inv[i], inv[j]);
                let (r, c) = (a.min(b), a.max(b));
                count[c + 1] += 1;
                at.push((r, c));
            }
        }
        let mut ap = vec![0; n + 1];
        for c in 0..n {
            ap[c + 1] = ap[c] + count[c + 1];
        }
        // entries of each column sorted by row; src_pos maps the caller's
        // storage to them
        let mut order: Vec<usize> = (0..nnz).collect();
        order.sort_unstable_by_key(|&q| (at[q].1, at[q].0));
        let mut ai = vec![0; nnz];
        let mut src_pos = vec![0; nnz];
        for (pos, &q) in order.iter().enumerate() {
            ai[pos] = at[q].0;
            src_pos[q] = pos;
        }
        // elimination tree and each row's reach (ldl_symbolic), the reach
        // in the order ldl_numeric eliminates it: a node before its
        // ancestors, later paths first
        let mut parent = vec![NONE; n];
        let mut flag = vec![NONE; n];
        let mut col_count = vec![0usize; n];
        let mut rp = vec![0; n + 1];
        let mut rj = Vec::new();
        let mut stack = vec![0; n];
        let mut path = Vec::with_capacity(n);
        for k in 0..n {
            flag[k] = k;
            let mut top = n;
            for &i0 in &ai[ap[k]..ap[k + 1]] {
                let mut i = i0;
                if i >= k {
                    continue;
                }
                path.clear();
                while flag[i] != k {
                    if parent[i] == NONE {
                        parent[i] = k;
                    }
                    col_count[i] += 1;
                    flag[i] = k;
                    path.push(i);
                    i = parent[i];
                }
                for &p in path.iter().rev() {
                    top -= 1;
                    stack[top] = p;
                }
            }
            rj.extend_from_slice(&stack[top..n]);
            rp[k + 1] = rj.len();
        }
        let mut lp = vec![0; n + 1];
        for j in 0..n {
            lp[j + 1] = lp[j] + col_count[j];
        }
        // L's row indices: column j gets row k in the order rows are made
        let mut li = vec![0; lp[n]];
        let mut done = vec![0usize; n];
        for k in 0..n {
            for &j in &rj[rp[k]..rp[k + 1]] {
                li[lp[j] + done[j]] = k;
                done[j] += 1;
            }
        }
        StaticLdlt {
            ax: vec![0.0; nnz],
            lx: vec![0.0; lp[n]],
            d: vec![0.0; n],
            y: vec![0.0; n],
            x: vec![0.0; n],
            done,
            ap,
            ai,
            src_pos,
            perm: perm.to_vec(),
            lp,
            li,
            rp,
            rj,
        }
    }

    crate::solver::wide::wide_method!(
        /// Numeric LDL^T of A with the values `vals` (the caller's storage, in
        /// `new`'s pattern); a pivot at or below `min_pivot` becomes `floor`
        /// (roundoff on a matrix positive definite by construction). A
        /// non-finite pivot is an error.
        pub fn factor = factor_kernel / factor_avx2 (&mut self, vals: &[f64], min_pivot: f64, floor: f64) -> Result<(), SolverError>
    );

    #[inline(always)]
    fn factor_kernel(
        &mut self,
        vals: &[f64],
        min_pivot: f64,
        floor: f64,
    ) -> Result<(), SolverError> {
        assert_eq!(vals.len(), self.src_pos.len());
        for (&pos, &v) in self.src_pos.iter().zip(vals) {
            self.ax[pos] = v;
        }
        let n = self.d.len();
        self.done.fill(0);
        let (ap, ai, ax) = (&self.ap, &self.ai, &self.ax);
        let (rp, rj, lp, li) = (&self.rp, &self.rj, &self.lp, &self.li);
        let (y, lx, d, done) = (&mut self.y, &mut self.lx, &mut self.d, &mut self.done);
        for k in 0..n {
            // SAFETY: the symbolic analysis (`new`) made every index in ap,
            // ai, rp, rj, lp and li in range: ai and li hold rows < n, rj
            // columns < k, column j of L has lp[j + 1] - lp[j] entries of
            // which `done[j]` are made (< the count: row k is one of them)
            unsafe {
                for p in *ap.get_unchecked(k)..*ap.get_unchecked(k + 1) {
                    *y.get_unchecked_mut(*ai.get_unchecked(p)) += *ax.get_unchecked(p);
                }
                let mut dk = *y.get_unchecked(k);
                *y.get_unchecked_mut(k) = 0.0;
                for &j in rj.get_unchecked(*rp.get_unchecked(k)..*rp.get_unchecked(k + 1)) {
                    let yj = *y.get_unchecked(j);
                    *y.get_unchecked_mut(j) = 0.0;
                    let (p0, p1) = (
                        *lp.get_unchecked(j),
                        *lp.get_unchecked(j) + *done.get_unchecked(j),
                    );
                    for p in p0..p1 {
                        *y.get_unchecked_mut(*li.get_unchecked(p)) -= *lx.get_unchecked(p) * yj;
                    }
                    let l_kj = yj / *d.get_unchecked(j);
                    dk -= l_kj * yj;
                    *lx.get_unchecked_mut(p1) = l_kj;
                    *done.get_unchecked_mut(j) += 1;
                }
                if !dk.is_finite() {
                    y.fill(0.0);
                    return Err(SolverError::NonFinite(format!(
                        "LDL^T of the compliant system: pivot {dk} at row {}",
                        self.perm[k]
                    )));
                }
                *d.get_unchecked_mut(k) = if dk > min_pivot { dk } else { floor };
            }
        }
        Ok(())
    }

    /// The caller's indices whose pivot the last factorization replaced by
    /// a floor at or above `floor_from`.
    pub fn floored(&self, floor_from: f64) -> impl Iterator<Item = usize> + '_ {
        (self.d.iter().zip(&self.perm)).filter_map(move |(&d, &i)| (d >= floor_from).then_some(i))
    }

    crate::solver::wide::wide_method!(
        /// b <- A^-1 b with the last factorization.
        pub fn solve = solve_kernel / solve_avx2 (&mut self, b: &mut [f64])
    );

    #[inline(always)]
    fn solve_kernel(&mut self, b: &mut [f64]) {
        let n = self.d.len();
        assert_eq!(b.len(), n);
        let (x, perm, lp, li, lx, d) = (
            &mut self.x,
            &self.perm,
            &self.lp,
            &self.li,
            &self.lx,
            &self.d,
        );
        // SAFETY: perm is a permutation of 0..n, li holds rows < n, and lp
        // column bounds within li and lx (`new`)
        unsafe {
            for k in 0..n {
                *x.get_unchecked_mut(k) = *b.get_unchecked(*perm.get_unchecked(k));
            }
            // L y = P b (unit lower), then D, then L^T
            for j in 0..n {
                let xj = *x.get_unchecked(j);
                if xj == 0.0 {
                    continue;
                }
                for p in *lp.get_unchecked(j)..*lp.get_unchecked(j + 1) {
                    *x.get_unchecked_mut(*li.get_unchecked(p)) -= *lx.get_unchecked(p) * xj;
                }
            }
            for j in 0..n {
                *x.get_unchecked_mut(j) /= *d.get_unchecked(j);
            }
            for j in (0..n).rev() {
                let mut s = 0.0;
                for p in *lp.get_unchecked(j)..*lp.get_unchecked(j + 1) {
                    s += *lx.get_unchecked(p) * *x.get_unchecked(*li.get_unchecked(p));
                }
                *x.get_unchecked_mut(j) -= s;
            }
            for k in 0..n {
                *b.get_unchecked_mut(*perm.get_unchecked(k)) = *x.get_unchecked(k);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::StaticLdlt;

    /// A x = b against the dense product, on a random sparse positive
    /// definite matrix (diagonally dominant) in a scrambled order, twice
    /// (the second factorization of new values on the same pattern).
    #[test]
    fn solves_a_sparse_system_in_any_order() {
        let n = 40;
        let mut seed = 7u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut dense = vec![vec![0.0; n]; n];
        for _ in 0..3 * n {
            let (i, j) = ((rnd() * n as f64) as usize, (rnd() * n as f64) as usize);
            if i != j {
                let v = rnd() - 0.5;
                dense[i][j] = v;
                dense[j][i] = v;
            }
        }
        // upper triangle by columns
        let (mut col_ptr, mut row_idx) = (vec![0], Vec::new());
        for j in 0..n {
            for (i, row) in dense.iter().enumerate().take(j + 1) {
                if i == j || row[j] != 0.0 {
                    row_idx.push(i);
                }
            }
            col_ptr.push(row_idx.len());
        }
        let perm: Vec<usize> = (0..n).map(|k| (7 * k + 3) % n).collect();
        let mut f = StaticLdlt::new(&col_ptr, &row_idx, &perm);
        for pass in 0..2 {
            for (i, row) in dense.iter_mut().enumerate() {
                let off: f64 = (0..n).filter(|&j| j != i).map(|j| row[j].abs()).sum();
                row[i] = off + 1.0 + pass as f64 + rnd();
            }
            let vals: Vec<f64> = (0..n)
                .flat_map(|j| {
                    row_idx[col_ptr[j]..col_ptr[j + 1]]
                        .iter()
                        .map(move |&i| (i, j))
                })
                .map(|(i, j)| dense[i][j])
                .collect();
            f.factor(&vals, 0.0, 1.0).unwrap();
            let x: Vec<f64> = (0..n).map(|_| rnd() - 0.5).collect();
            let mut b: Vec<f64> = (0..n)
                .map(|i| (0..n).map(|j| dense[i][j] * x[j]).sum())
                .collect();
            f.solve(&mut b);
            let err = x
                .iter()
                .zip(&b)
                .map(|(a, c)| (a - c).abs())
                .fold(0.0, f64::max);
            assert!(err < 1e-13, "pass {pass}: error {err:e}");
        }
    }

    /// A pivot at or below the bound becomes the floor (here the second of
    /// [[1, 1], [1, 1]]: 0 after elimination); a non-finite one is an
    /// error; no rows is no work.
    #[test]
    fn floors_small_pivots_and_refuses_non_finite_ones() {
        let (col_ptr, row_idx) = (vec![0, 1, 3], vec![0, 0, 1]);
        let mut f = StaticLdlt::new(&col_ptr, &row_idx, &[0, 1]);
        f.factor(&[1.0, 1.0, 1.0], 1e-12, 0.5).unwrap();
        // L = [[1, 0], [1, 1]], D = diag(1, 0.5): A~ = [[1, 1], [1, 1.5]]
        let mut b = vec![2.0, 2.5];
        f.solve(&mut b);
        assert!(
            (b[0] - 1.0).abs() < 1e-15 && (b[1] - 1.0).abs() < 1e-15,
            "{b:?}"
        );
        assert!(f.factor(&[1.0, f64::NAN, 1.0], 1e-12, 0.5).is_err());
        // (the scratch is clean after the error)
        f.factor(&[2.0, 0.0, 3.0], 1e-12, 0.5).unwrap();
        let mut b = vec![2.0, 3.0];
        f.solve(&mut b);
        assert_eq!(b, vec![1.0, 1.0]);
        let mut empty = StaticLdlt::new(&[0], &[], &[]);
        empty.factor(&[], 1e-12, 0.5).unwrap();
        empty.solve(&mut []);
    }
}
