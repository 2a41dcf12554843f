//! Right-angle fitting at joint p: members p-q and p-r stay perpendicular,
//! (X_q - X_p) . (X_r - X_p) / L_pq = 0, with the initial length L_pq as scale so that
//! the row reads in metres (the offset of r from the plane through p normal to p-q).
//! One bilinear row: dPhi/dX_q = (X_r - X_p)/L, dPhi/dX_r = (X_q - X_p)/L,
//! dPhi/dX_p = minus their sum, Adot Xdot = 2 (V_q - V_p) . (V_r - V_p) / L.
//! Used where a telescopic member is mounted square to a post, e.g. the radial
//! members of a double-ring truss.

use super::{at, Constraint, ElementError, ElementSpec};

#[derive(Debug)]
pub struct Perpendicular {
    name: String,
    /// [p, q, r]
    joints: [usize; 3],
    scale: f64,
}
/// The parameters a model file may give this element (`elements::REGISTRY`).
pub const PARAMS: &[&str] = &[];

pub fn build(spec: &ElementSpec, x0: &[f64]) -> Result<Box<dyn Constraint>, ElementError> {
    spec.expect_joints(
        3,
        "the corner p, then q and r at the ends of the two members",
    )?;
    spec.only_params(PARAMS)?;
    let j = [spec.joints[0], spec.joints[1], spec.joints[2]];
    let (l1, l2) = (
        (at(x0, j[1]) - at(x0, j[0])).norm(),
        (at(x0, j[2]) - at(x0, j[0])).norm(),
    );
    if l1 <= 1e-9 || l2 <= 1e-9 {
        return Err(ElementError::Geometry(
            "a member of zero length; check the joint positions".into(),
        ));
    }
    Ok(Box::new(Perpendicular {
        name: spec.name.clone(),
        joints: j,
        scale: 1.0 / l1,
    }))
}

impl Constraint for Perpendicular {
    super::identity!("perpendicular");
    fn rows(&self, _locked: bool) -> usize {
        1
    }
    fn residual(&self, x: &[f64], out: &mut [f64]) {
        let [p, q, r] = self.joints;
        out[0] = (at(x, q) - at(x, p)).dot(&(at(x, r) - at(x, p))) * self.scale;
    }
    fn jacobian(&self, x: &[f64], out: &mut [f64]) {
        let [p, q, r] = self.joints;
        let (u, w) = (
            (at(x, q) - at(x, p)) * self.scale,
            (at(x, r) - at(x, p)) * self.scale,
        );
        for c in 0..3 {
            out[c] = -(u[c] + w[c]);
            out[3 + c] = w[c];
            out[6 + c] = u[c];
        }
    }
    fn adot_xdot(&self, _x: &[f64], v: &[f64], out: &mut [f64]) {
        let [p, q, r] = self.joints;
        out[0] = 2.0 * (at(v, q) - at(v, p)).dot(&(at(v, r) - at(v, p))) * self.scale;
    }
}
