//! Bar: a member of constant length between joints a and b.
//! Phi = |X_b - X_a| - L, one row. L is the initial distance unless `length_m` is given.

use super::kernels::Distance;
use super::{at, Constraint, ElementError, ElementSpec};

#[derive(Debug)]
pub struct Bar {
    name: String,
    joints: [usize; 2],
    pub length_m: f64,
    /// EA of the member (N); the model's default when None.
    pub axial_stiffness_n: Option<f64>,
}

impl Bar {
    pub fn new(name: &str, a: usize, b: usize, length_m: f64) -> Self {
        Bar {
            name: name.to_string(),
            joints: [a, b],
            length_m,
            axial_stiffness_n: None,
        }
    }
    fn row(&self) -> Distance {
        Distance {
            a: self.joints[0],
            b: self.joints[1],
            length_m: self.length_m,
        }
    }
}
/// The parameters a model file may give this element (`elements::REGISTRY`).
pub const PARAMS: &[&str] = &["length_m", super::AXIAL_STIFFNESS_KEY];

pub fn build(spec: &ElementSpec, x0: &[f64]) -> Result<Box<dyn Constraint>, ElementError> {
    spec.expect_joints(2, "its two end joints")?;
    spec.only_params(PARAMS)?;
    let (a, b) = (spec.joints[0], spec.joints[1]);
    let l0 = (at(x0, b) - at(x0, a)).norm();
    let length_m = spec.num("length_m")?.unwrap_or(l0);
    if length_m <= 1e-9 || l0 <= 1e-9 {
        return Err(ElementError::Geometry(format!("zero-length member (its joints are {l0:.3e} m apart); move one end joint or remove the member")));
    }
    Ok(Box::new(Bar {
        axial_stiffness_n: spec.axial_stiffness()?,
        ..Bar::new(&spec.name, a, b, length_m)
    }))
}

impl Constraint for Bar {
    super::identity!("bar");
    fn members(&self) -> &'static [[usize; 2]] {
        &[[0, 1]]
    }
    fn rows(&self, _locked: bool) -> usize {
        1
    }
    fn residual(&self, x: &[f64], out: &mut [f64]) {
        out[0] = self.row().residual(x);
    }
    fn jacobian(&self, x: &[f64], out: &mut [f64]) {
        self.row().jacobian(x, out, 0, 3);
    }
    fn adot_xdot(&self, x: &[f64], v: &[f64], out: &mut [f64]) {
        out[0] = self.row().adot_xdot(x, v);
    }
    fn row_compliance_m_per_n(&self, _locked: bool, ea_default_n: f64, out: &mut [f64]) {
        out[0] = super::member_compliance(self.length_m, self.axial_stiffness_n, ea_default_n);
    }
}
