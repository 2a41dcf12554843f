//! Revolute hinge with its axis fixed in a post's body: the member p-a turns only
//! about an axis n that is fixed in the body made of the post p-q and the member
//! p-r (square to the post), so it stays perpendicular to n:
//!     Phi = (X_a - X_p) . n / rho0,   n = alpha v + beta (u x v) / h,
//! with u = X_q - X_p (the post, length h), v = X_r - X_p. The coefficients alpha,
//! beta are set from the initial geometry so that n is the axis perpendicular to
//! the post and to the member (n0 = u x (X_a - X_p), normalised). v and u x v both
//! scale with |v|, so n keeps its direction in the body even when p-r is
//! telescopic. This is the "angle constraint of the revolute joints" the paper
//! cites: it fixes the member's azimuth about the post.
//! Jacobian (w = X_a - X_p): dPhi/dX_a = n / rho0,
//! dPhi/dX_r = (alpha w + beta (w x u) / h) / rho0, dPhi/dX_q = beta (v x w) / (h rho0),
//! dPhi/dX_p = minus their sum.
//! Adot Xdot = [2 alpha w'.v' + 2 beta/h (w'.(u' x v) + w'.(u x v') + w.(u' x v'))] / rho0.

use super::{at, Constraint, ElementError, ElementSpec};
use crate::solver::vec3::Vec3;

/// The post u = X_q - X_p, the body member v = X_r - X_p and the hinged member
/// w = X_a - X_p of a hinge on joints [p, q, r, a] (positions or velocities).
pub(super) fn hinge_vectors(x: &[f64], [p, q, r, a]: [usize; 4]) -> (Vec3, Vec3, Vec3) {
    (
        at(x, q) - at(x, p),
        at(x, r) - at(x, p),
        at(x, a) - at(x, p),
    )
}

#[derive(Debug)]
pub struct HingeAxis {
    name: String,
    /// [p, q, r, a]
    joints: [usize; 4],
    alpha: f64,
    beta: f64,
    h: f64,
    rho0: f64,
}
/// The parameters a model file may give this element (`elements::REGISTRY`).
pub const PARAMS: &[&str] = &[];

/// A hinge's joints [p, q, r, a] from its spec, the vectors u, v, w of
/// `hinge_vectors` at the start, the post length h = |u|, rho0 = |v| and the unit
/// hinge axis n0 = u x w / |u x w|; `member` names p-r in the error messages.
pub(super) fn hinge_start(
    spec: &ElementSpec,
    x0: &[f64],
    member: &str,
) -> Result<([usize; 4], Vec3, Vec3, Vec3, f64, f64, Vec3), ElementError> {
    spec.expect_joints(
        4,
        &format!("hinge p, post end q, {member} end r, hinged member end a"),
    )?;
    spec.only_params(PARAMS)?;
    let joints = [
        spec.joints[0],
        spec.joints[1],
        spec.joints[2],
        spec.joints[3],
    ];
    let (u, v, w) = hinge_vectors(x0, joints);
    let (h, rho0) = (u.norm(), v.norm());
    let n0 = u.cross(&w);
    if h <= 1e-9 || rho0 <= 1e-9 || n0.norm() <= 1e-9 * h * w.norm() {
        return Err(ElementError::Geometry(format!("the post, the {member} or the hinged member has zero length, or the member lies along the post")));
    }
    Ok((joints, u, v, w, h, rho0, n0.normalize()))
}

pub fn build(spec: &ElementSpec, x0: &[f64]) -> Result<Box<dyn Constraint>, ElementError> {
    let ([p, q, r, a], u, v, _w, h, rho0, n0) = hinge_start(spec, x0, "body member")?;
    // n0 = alpha v + beta (u x v)/h, least squares on the two body vectors
    let (b1, b2) = (v, u.cross(&v) / h);
    let (g11, g12, g22) = (b1.dot(&b1), b1.dot(&b2), b2.dot(&b2));
    let det = g11 * g22 - g12 * g12;
    if det.abs() <= 1e-12 * g11 * g22 {
        return Err(ElementError::Geometry(
            "the body member p-r lies along the post p-q; it cannot carry a hinge axis".into(),
        ));
    }
    let (r1, r2) = (b1.dot(&n0), b2.dot(&n0));
    let (alpha, beta) = ((r1 * g22 - r2 * g12) / det, (r2 * g11 - r1 * g12) / det);
    if (alpha * b1 + beta * b2 - n0).norm() > 1e-9 {
        return Err(ElementError::Geometry("the hinge axis is not in the plane square to the post; mount the body member p-r square to the post".into()));
    }
    Ok(Box::new(HingeAxis {
        name: spec.name.clone(),
        joints: [p, q, r, a],
        alpha,
        beta,
        h,
        rho0,
    }))
}

impl Constraint for HingeAxis {
    super::identity!("hinge_axis");
    fn rows(&self, _locked: bool) -> usize {
        1
    }
    fn residual(&self, x: &[f64], out: &mut [f64]) {
        let (u, v, w) = hinge_vectors(x, self.joints);
        let n = v * self.alpha + u.cross(&v) * (self.beta / self.h);
        out[0] = w.dot(&n) / self.rho0;
    }
    fn jacobian(&self, x: &[f64], out: &mut [f64]) {
        let (u, v, w) = hinge_vectors(x, self.joints);
        let s = 1.0 / self.rho0;
        let ga = (v * self.alpha + u.cross(&v) * (self.beta / self.h)) * s;
        let gr = (w * self.alpha + w.cross(&u) * (self.beta / self.h)) * s;
        let gq = v.cross(&w) * (self.beta / self.h * s);
        let gp = -(ga + gr + gq);
        for (blk, g) in [gp, gq, gr, ga].iter().enumerate() {
            out[3 * blk..3 * blk + 3].copy_from_slice(g.as_slice());
        }
    }
    fn adot_xdot(&self, x: &[f64], vel: &[f64], out: &mut [f64]) {
        let (u, v, w) = hinge_vectors(x, self.joints);
        let (du, dv, dw) = hinge_vectors(vel, self.joints);
        let bilinear = 2.0 * self.alpha * dw.dot(&dv);
        let trilinear = 2.0 * self.beta / self.h
            * (dw.dot(&du.cross(&v)) + dw.dot(&u.cross(&dv)) + w.dot(&du.cross(&dv)));
        out[0] = (bilinear + trilinear) / self.rho0;
    }
}
