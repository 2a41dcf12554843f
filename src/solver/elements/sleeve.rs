//! Sleeve: a telescopic member between joints a and b. It imposes nothing while it
//! slides; when its length reaches the design length L_lock it latches and becomes
//! a bar of length L_lock (Phi = |X_b - X_a| - L_lock). The latch condition is the
//! zero of the gap g(X) = |X_b - X_a| - L_lock, approached from either side.

use super::kernels::Distance;
use super::{at, Constraint, ElementError, ElementSpec, LockCondition};

#[derive(Debug)]
pub struct Sleeve {
    name: String,
    joints: [usize; 2],
    pub lock_length_m: f64,
    /// EA of the latched member (N); the model's default when None.
    pub axial_stiffness_n: Option<f64>,
    /// Compliant latch: stiffness (N/m) and damping (N s/m); rigid when None.
    pub latch_spring: Option<(f64, f64)>,
}

impl Sleeve {
    pub fn new(name: &str, a: usize, b: usize, lock_length_m: f64) -> Self {
        Sleeve {
            name: name.to_string(),
            joints: [a, b],
            lock_length_m,
            axial_stiffness_n: None,
            latch_spring: None,
        }
    }
    fn row(&self) -> Distance {
        Distance {
            a: self.joints[0],
            b: self.joints[1],
            length_m: self.lock_length_m,
        }
    }
}

/// The parameters a model file may give this element (`elements::REGISTRY`).
pub const PARAMS: &[&str] = &[
    "lock_length_m",
    super::AXIAL_STIFFNESS_KEY,
    "latch_stiffness_n_per_m",
    "latch_damping_n_s_per_m",
];

pub fn build(spec: &ElementSpec, x0: &[f64]) -> Result<Box<dyn Constraint>, ElementError> {
    spec.expect_joints(2, "its two end joints")?;
    spec.only_params(PARAMS)?;
    let (a, b) = (spec.joints[0], spec.joints[1]);
    let l0 = (at(x0, b) - at(x0, a)).norm();
    if l0 <= 1e-9 {
        return Err(ElementError::Geometry(format!(
            "zero-length sleeve (its joints are {l0:.3e} m apart); move one end joint"
        )));
    }
    let lock = spec.num("lock_length_m")?.ok_or_else(|| {
        ElementError::Param(
            "a sleeve needs `lock_length_m`, the design length at which it latches".into(),
        )
    })?;
    if lock <= 1e-9 {
        return Err(ElementError::Param(format!(
            "`lock_length_m` = {lock} must be positive"
        )));
    }
    let latch_spring = spec.spring_damper(
        "latch_stiffness_n_per_m",
        "latch_damping_n_s_per_m",
        "a compliant latch",
    )?;
    Ok(Box::new(Sleeve {
        axial_stiffness_n: spec.axial_stiffness()?,
        latch_spring,
        ..Sleeve::new(&spec.name, a, b, lock)
    }))
}

impl Constraint for Sleeve {
    super::identity!("sleeve");
    fn rows(&self, locked: bool) -> usize {
        usize::from(locked)
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
        if let Some(c) = out.first_mut() {
            *c = super::member_compliance(self.lock_length_m, self.axial_stiffness_n, ea_default_n);
        }
    }
    fn latch_spring(&self) -> Option<(f64, f64)> {
        self.latch_spring
    }
    fn lock_gap(&self, x: &[f64]) -> Option<f64> {
        Some(self.row().residual(x))
    }
    /// g = |X_b - X_a| - L_lock, dg/dt = e . (Xdot_b - Xdot_a).
    fn lock_condition(&self, x: &[f64], v: &[f64]) -> Option<LockCondition> {
        let (_, rate_m_s) = self.extension(x, v)?;
        Some(LockCondition {
            gap_m: self.row().residual(x),
            rate_m_s,
        })
    }
    fn members(&self) -> &'static [[usize; 2]] {
        &[[0, 1]]
    }
    fn extension(&self, x: &[f64], v: &[f64]) -> Option<(f64, f64)> {
        let d = at(x, self.joints[1]) - at(x, self.joints[0]);
        let w = at(v, self.joints[1]) - at(v, self.joints[0]);
        let l = d.norm();
        Some((l, d.dot(&w) / l))
    }
}
