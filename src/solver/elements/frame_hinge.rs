//! Revolute hinge fixed in a post's fitting whose radial member shears: the member
//! p-a turns only about an axis n fixed in the body of the post p-q, while the
//! radial member p-r (the batten of a parallelogram frame) may turn about the
//! frame's normal u x v, so it is not square to the post. The post's body is
//! spanned by the post u = X_q - X_p, the frame normal u x v and the in-plane
//! direction square to the post, (u x v) x u = (u.u) v - (u.v) u; both body
//! vectors turn with the post but not with the frame's shear:
//!     b1 = ((u.u) v - (u.v) u) / h^2,   b2 = (u x v) / h,
//!     Phi = (X_a - X_p) . (alpha b1 + beta b2) / rho0,
//! h the post length, rho0 = |v| at the start. Both b1 and b2 scale with
//! |v| cos(psi) (psi the frame's shear from square), so the zero set Phi = 0 is the
//! hinge's plane for any shear short of 90 deg. With p-r square to the post
//! (psi = 0) this is `hinge_axis`. alpha, beta are set from the initial geometry
//! so that alpha b1 + beta b2 is the unit axis n0 = u x (X_a - X_p) / |...|.
//!
//! With w = X_a - X_p and G = rho0 Phi = alpha/h^2 [(u.u)(w.v) - (u.v)(w.u)] + beta/h w.(u x v):
//!     dG/dw = alpha/h^2 [(u.u) v - (u.v) u] + beta/h u x v
//!     dG/dv = alpha/h^2 [(u.u) w - (w.u) u] + beta/h w x u
//!     dG/du = alpha/h^2 [2 (w.v) u - (w.u) v - (u.v) w] + beta/h v x w
//!     dG/dX_p = -(sum of the three).
//! Adot Xdot (the second time derivative at zero acceleration): with primes for
//! the relative velocities, for T1 = (u.u)(w.v):
//!     T1'' = 2(u'.u')(w.v) + 2 (2 u.u') (w'.v + w.v') + (u.u) 2 (w'.v'),
//! for T2 = (u.v)(w.u):
//!     T2'' = 2(u'.v')(w.u) + 2 (u'.v + u.v') (w'.u + w.u') + (u.v) 2 (w'.u'),
//! and T3 = w.(u x v): T3'' = 2 [w'.(u' x v) + w'.(u x v') + w.(u' x v')];
//!     Adot Xdot = (alpha/h^2 (T1'' - T2'') + beta/h T3'') / rho0.

use super::hinge_axis::{hinge_start, hinge_vectors};
use super::{Constraint, ElementError, ElementSpec};

#[derive(Debug)]
pub struct FrameHinge {
    name: String,
    /// [p, q, r, a]
    joints: [usize; 4],
    alpha: f64,
    beta: f64,
    h: f64,
    rho0: f64,
}

pub fn build(spec: &ElementSpec, x0: &[f64]) -> Result<Box<dyn Constraint>, ElementError> {
    let ([p, q, r, a], u, v, _w, h, rho0, n0) = hinge_start(spec, x0, "frame member")?;
    let b2 = u.cross(&v) / h;
    if b2.norm() <= 1e-6 * rho0 {
        return Err(ElementError::Geometry(
            "the frame member p-r lies along the post p-q; it cannot carry a hinge axis".into(),
        ));
    }
    let b1 = (v * u.dot(&u) - u * u.dot(&v)) / (h * h);
    // b1 and b2 are orthogonal and both square to the post, as n0 is.
    let (alpha, beta) = (b1.dot(&n0) / b1.dot(&b1), b2.dot(&n0) / b2.dot(&b2));
    if (b1 * alpha + b2 * beta - n0).norm() > 1e-9 {
        return Err(ElementError::Geometry(
            "the hinge axis is not square to the post".into(),
        ));
    }
    Ok(Box::new(FrameHinge {
        name: spec.name.clone(),
        joints: [p, q, r, a],
        alpha,
        beta,
        h,
        rho0,
    }))
}

impl Constraint for FrameHinge {
    super::identity!("frame_hinge");
    fn rows(&self, _locked: bool) -> usize {
        1
    }
    fn residual(&self, x: &[f64], out: &mut [f64]) {
        let (u, v, w) = hinge_vectors(x, self.joints);
        let h2 = self.h * self.h;
        let g = self.alpha / h2 * (u.dot(&u) * w.dot(&v) - u.dot(&v) * w.dot(&u))
            + self.beta / self.h * w.dot(&u.cross(&v));
        out[0] = g / self.rho0;
    }
    fn jacobian(&self, x: &[f64], out: &mut [f64]) {
        let (u, v, w) = hinge_vectors(x, self.joints);
        let (ka, kb) = (self.alpha / (self.h * self.h), self.beta / self.h);
        let s = 1.0 / self.rho0;
        let (uu, uv, uw, vw) = (u.dot(&u), u.dot(&v), u.dot(&w), v.dot(&w));
        let ga = ((v * uu - u * uv) * ka + u.cross(&v) * kb) * s;
        let gr = ((w * uu - u * uw) * ka + w.cross(&u) * kb) * s;
        let gq = ((u * (2.0 * vw) - v * uw - w * uv) * ka + v.cross(&w) * kb) * s;
        let gp = -(ga + gr + gq);
        for (blk, g) in [gp, gq, gr, ga].iter().enumerate() {
            out[3 * blk..3 * blk + 3].copy_from_slice(g.as_slice());
        }
    }
    fn adot_xdot(&self, x: &[f64], vel: &[f64], out: &mut [f64]) {
        let (u, v, w) = hinge_vectors(x, self.joints);
        let (du, dv, dw) = hinge_vectors(vel, self.joints);
        let t1 = 2.0 * du.dot(&du) * w.dot(&v)
            + 4.0 * u.dot(&du) * (dw.dot(&v) + w.dot(&dv))
            + 2.0 * u.dot(&u) * dw.dot(&dv);
        let t2 = 2.0 * du.dot(&dv) * w.dot(&u)
            + 2.0 * (du.dot(&v) + u.dot(&dv)) * (dw.dot(&u) + w.dot(&du))
            + 2.0 * u.dot(&v) * dw.dot(&du);
        let t3 = 2.0 * (dw.dot(&du.cross(&v)) + dw.dot(&u.cross(&dv)) + w.dot(&du.cross(&dv)));
        out[0] = (self.alpha / (self.h * self.h) * (t1 - t2) + self.beta / self.h * t3) / self.rho0;
    }
}
