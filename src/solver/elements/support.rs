//! Support: fixes some of a joint's Cartesian coordinates at their initial values,
//! Phi_c = X_c - X0_c for each fixed axis c (one row each, linear, Adot Xdot = 0).

use super::{Constraint, ElementError, ElementSpec};

#[derive(Debug)]
pub struct Support {
    name: String,
    joints: [usize; 1],
    /// (axis 0..3, fixed value in m)
    fixed: Vec<(usize, f64)>,
}
/// The parameters a model file may give this element (`elements::REGISTRY`).
pub const PARAMS: &[&str] = &["fix"];

pub fn build(spec: &ElementSpec, x0: &[f64]) -> Result<Box<dyn Constraint>, ElementError> {
    spec.expect_joints(1, "the supported joint")?;
    spec.only_params(PARAMS)?;
    let fix = spec.text("fix")?.unwrap_or("xyz");
    let j = spec.joints[0];
    let mut fixed = Vec::new();
    for (axis, c) in ['x', 'y', 'z'].iter().enumerate() {
        if fix.contains(*c) {
            fixed.push((axis, x0[3 * j + axis]));
        }
    }
    if fixed.is_empty() || fix.chars().any(|c| !"xyz".contains(c)) {
        return Err(ElementError::Geometry(format!(
            "`fix` = \"{fix}\"; give the fixed axes as letters from \"xyz\", e.g. \"xz\""
        )));
    }
    Ok(Box::new(Support {
        name: spec.name.clone(),
        joints: [j],
        fixed,
    }))
}

impl Constraint for Support {
    super::identity!("support");
    fn rows(&self, _locked: bool) -> usize {
        self.fixed.len()
    }
    fn residual(&self, x: &[f64], out: &mut [f64]) {
        for (r, (axis, value)) in self.fixed.iter().enumerate() {
            out[r] = x[3 * self.joints[0] + axis] - value;
        }
    }
    fn jacobian(&self, _x: &[f64], out: &mut [f64]) {
        out[..3 * self.fixed.len()].fill(0.0);
        for (r, (axis, _)) in self.fixed.iter().enumerate() {
            out[3 * r + axis] = 1.0;
        }
    }
    fn adot_xdot(&self, _x: &[f64], _v: &[f64], out: &mut [f64]) {
        out[..self.fixed.len()].fill(0.0);
    }
}
