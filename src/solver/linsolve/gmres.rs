//! GMRES for a linear operator given only by its action, B x = b, in the
//! inner product <u, v> = sum w_i u_i v_i (modified Gram-Schmidt, Givens
//! rotations, from x = 0, no restart). The buffers are made once.

/// GMRES buffers for systems of size n, at most `kmax` iterations.
#[derive(Debug, Default)]
pub struct Gmres {
    kmax: usize,
    n: usize,
    /// Krylov basis (kmax + 1 vectors), Hessenberg matrix (column-major,
    /// (kmax + 1) x kmax), Givens rotations, rhs and solution.
    basis: Vec<f64>,
    hess: Vec<f64>,
    cs: Vec<f64>,
    sn: Vec<f64>,
    g: Vec<f64>,
    y: Vec<f64>,
}

/// <a, b> in the weights w.
pub fn weighted_dot(w: &[f64], a: &[f64], b: &[f64]) -> f64 {
    w.iter()
        .zip(a.iter().zip(b))
        .map(|(m, (x, y))| m * x * y)
        .sum()
}

impl Gmres {
    pub fn new(kmax: usize, n: usize) -> Gmres {
        Gmres {
            kmax,
            n,
            basis: vec![0.0; (kmax + 1) * n],
            hess: vec![0.0; (kmax + 1) * kmax],
            cs: vec![0.0; kmax],
            sn: vec![0.0; kmax],
            g: vec![0.0; kmax + 1],
            y: vec![0.0; kmax],
        }
    }

    /// x with B x = b: iterates until the residual's norm is at most
    /// `tol_rel` |b| or `kmax` iterations are made (x is then the best in
    /// their Krylov space). `apply(v, out)` sets out = B v.
    pub fn solve<E>(
        &mut self,
        w: &[f64],
        b: &[f64],
        tol_rel: f64,
        x: &mut [f64],
        mut apply: impl FnMut(&[f64], &mut [f64]) -> Result<(), E>,
    ) -> Result<(), E> {
        let (n, kmax) = (self.n, self.kmax);
        let beta = weighted_dot(w, b, b).sqrt();
        x.fill(0.0);
        if beta == 0.0 {
            return Ok(());
        }
        for i in 0..n {
            self.basis[i] = b[i] / beta;
        }
        self.g.fill(0.0);
        self.g[0] = beta;
        let ld = kmax + 1; // leading dimension of hess
        let mut k = 0; // columns made
        while k < kmax {
            let (done, rest) = self.basis.split_at_mut((k + 1) * n);
            let v = &mut rest[..n];
            apply(&done[k * n..], v)?;
            for i in 0..=k {
                let vi = &done[i * n..(i + 1) * n];
                let hik = weighted_dot(w, vi, v);
                self.hess[k * ld + i] = hik;
                for (vv, u) in v.iter_mut().zip(vi) {
                    *vv -= hik * u;
                }
            }
            let hk1 = weighted_dot(w, v, v).sqrt();
            self.hess[k * ld + k + 1] = hk1;
            if hk1 > 0.0 {
                for vv in v.iter_mut() {
                    *vv /= hk1;
                }
            }
            // previous rotations on the new column, then its own
            for i in 0..k {
                let (a, b) = (self.hess[k * ld + i], self.hess[k * ld + i + 1]);
                self.hess[k * ld + i] = self.cs[i] * a + self.sn[i] * b;
                self.hess[k * ld + i + 1] = -self.sn[i] * a + self.cs[i] * b;
            }
            let (a, b) = (self.hess[k * ld + k], self.hess[k * ld + k + 1]);
            let r = a.hypot(b);
            let (c, s) = if r == 0.0 { (1.0, 0.0) } else { (a / r, b / r) };
            self.cs[k] = c;
            self.sn[k] = s;
            self.hess[k * ld + k] = r;
            self.hess[k * ld + k + 1] = 0.0;
            self.g[k + 1] = -s * self.g[k];
            self.g[k] *= c;
            k += 1;
            if self.g[k].abs() <= tol_rel * beta || hk1 == 0.0 {
                break;
            }
        }
        for i in (0..k).rev() {
            let mut v = self.g[i];
            for j in i + 1..k {
                v -= self.hess[j * ld + i] * self.y[j];
            }
            let d = self.hess[i * ld + i];
            self.y[i] = if d == 0.0 { 0.0 } else { v / d };
        }
        for i in 0..k {
            let yi = self.y[i];
            for (d, v) in x.iter_mut().zip(&self.basis[i * n..(i + 1) * n]) {
                *d += yi * v;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::Gmres;

    /// A nonsymmetric 6 x 6 system, I + a small full part, solved to
    /// roundoff in 6 iterations (weights not all 1): B x matches b.
    #[test]
    fn solves_a_small_system_to_roundoff() {
        let n = 6;
        let bmat: Vec<f64> = (0..n * n)
            .map(|k| {
                let (i, j) = (k / n, k % n);
                f64::from(u8::from(i == j)) + 0.1 * (((i * 7 + j * 3) % 5) as f64 - 2.0)
            })
            .collect();
        let w: Vec<f64> = (0..n).map(|i| 1.0 + i as f64).collect();
        let b: Vec<f64> = (0..n).map(|i| (i as f64 - 2.5) / 3.0).collect();
        let mut x = vec![0.0; n];
        let mut gm = Gmres::new(n, n);
        let mul = |v: &[f64], out: &mut [f64]| {
            for i in 0..n {
                out[i] = (0..n).map(|j| bmat[i * n + j] * v[j]).sum();
            }
        };
        gm.solve(&w, &b, 1e-14, &mut x, |v, out| {
            mul(v, out);
            Ok::<(), ()>(())
        })
        .unwrap();
        let mut bx = vec![0.0; n];
        mul(&x, &mut bx);
        for i in 0..n {
            assert!((bx[i] - b[i]).abs() <= 1e-12, "{i}: {} vs {}", bx[i], b[i]);
        }
        // Two iterations: the x in span{b, B b} whose residual is least in
        // the weighted norm, against the 2 x 2 normal equations
        // (K^T B^T W B K) y = K^T B^T W b, K = [b, B b].
        let mut gm2 = Gmres::new(2, n);
        let mut calls = 0;
        gm2.solve(&w, &b, 1e-14, &mut x, |v, out| {
            calls += 1;
            mul(v, out);
            Ok::<(), ()>(())
        })
        .unwrap();
        assert_eq!(calls, 2);
        let mut bb = vec![0.0; n];
        mul(&b, &mut bb);
        let (mut c0, mut c1) = (vec![0.0; n], vec![0.0; n]);
        mul(&b, &mut c0);
        mul(&bb, &mut c1);
        let dot = |p: &[f64], q: &[f64]| (0..n).map(|i| w[i] * p[i] * q[i]).sum::<f64>();
        let (a00, a01, a11) = (dot(&c0, &c0), dot(&c0, &c1), dot(&c1, &c1));
        let (r0, r1) = (dot(&c0, &b), dot(&c1, &b));
        let det = a00 * a11 - a01 * a01;
        let (y0, y1) = ((a11 * r0 - a01 * r1) / det, (a00 * r1 - a01 * r0) / det);
        for i in 0..n {
            let want = y0 * b[i] + y1 * bb[i];
            assert!((x[i] - want).abs() <= 1e-12, "{i}: {} vs {want}", x[i]);
        }
        // (and unweighted, the answer differs: the weights matter)
        let plain = |p: &[f64], q: &[f64]| p.iter().zip(q).map(|(a, b)| a * b).sum::<f64>();
        let (p00, p01, p11) = (plain(&c0, &c0), plain(&c0, &c1), plain(&c1, &c1));
        let (q0, q1) = (plain(&c0, &b), plain(&c1, &b));
        let pdet = p00 * p11 - p01 * p01;
        let py0 = (p11 * q0 - p01 * q1) / pdet;
        assert!((py0 - y0).abs() > 1e-6, "{py0} vs {y0}");
        // A loose tolerance stops early.
        let mut calls = 0;
        gm.solve(&w, &b, 0.5, &mut x, |v, out| {
            calls += 1;
            mul(v, out);
            Ok::<(), ()>(())
        })
        .unwrap();
        assert!(calls < n, "{calls} iterations");
    }
}
