//! End stop: the stroke end of a telescopic member between joints a and b (a
//! sleeve's tube bottoming out). Free while the length l = |X_b - X_a| stays
//! within the stroke, at or below `max_length_m` (and at or above
//! `min_length_m` when given); past it a stiff spring-damper pushes back on
//! the overrun
//!     Phi = max(0, l - L_max) + min(0, l - L_min),
//! with the force -A^T f, f = k Phi + c A Xdot where it pushes (the sign of
//! Phi) and 0 where it would pull, A = dPhi/dX = [-e, e] (e the unit
//! vector a->b) while engaged and 0 while free, and the elastic energy
//! 1/2 k Phi^2 (a compliant element, `Constraint::spring`; the springs of
//! `solver::springs` carry it, implicit in the Newmark step).
//! The contact's onset and release (the overrun's sign changes,
//! `contact_distance_m`) are located: a trial sub-step across one is cut to
//! end just past it (`[solver] contact_cut_rel`), so no trapezoid spans the
//! kink of the force (measured in tests/compliant_elements.rs: the energy
//! balance 7.1e-4, 3.7e-5, 4.6e-5, 8.3e-6 at 16, 31, 63 and 125 steps per
//! contact time, against 3.4e-2, 4.4e-3, 7.3e-3, 2.1e-3 unlocated). The
//! contact only pushes (`ElementSpring::unilateral`): where the overrun
//! closes faster than k Phi / c the damper would pull the sleeve back into
//! the stop, and the force is 0 instead.
//! With each sleeve's stroke sized to the lengths its deployment takes, a bay
//! can neither fold tighter than that nor shear the wrong way past it.

use super::{at, Constraint, ElementError, ElementSpec, ElementSpring};

#[derive(Debug)]
pub struct EndStop {
    name: String,
    joints: [usize; 2],
    /// The stroke: l within [min_length_m, max_length_m] is free (m).
    pub min_length_m: f64,
    pub max_length_m: f64,
    /// Spring-damper on the overrun: stiffness (N/m) and damping (N s/m).
    pub stop: (f64, f64),
}

/// The parameters a model file may give this element (`elements::REGISTRY`).
pub const PARAMS: &[&str] = &[
    "max_length_m",
    "min_length_m",
    "stiffness_n_per_m",
    "damping_n_s_per_m",
];

pub fn build(spec: &ElementSpec, x0: &[f64]) -> Result<Box<dyn Constraint>, ElementError> {
    spec.expect_joints(2, "the telescopic member's two end joints")?;
    spec.only_params(PARAMS)?;
    let (a, b) = (spec.joints[0], spec.joints[1]);
    let l0 = (at(x0, b) - at(x0, a)).norm();
    let max = spec.num("max_length_m")?.unwrap_or(f64::INFINITY);
    let min = spec.num("min_length_m")?.unwrap_or(0.0);
    if max == f64::INFINITY && min == 0.0 {
        return Err(ElementError::Param(
            "an end stop needs `max_length_m` and/or `min_length_m`, the ends of the stroke (m)"
                .into(),
        ));
    }
    if !(min >= 0.0 && max > min) {
        return Err(ElementError::Param(format!(
            "the stroke from `min_length_m` = {min} to `max_length_m` = {max} must have 0 <= min < max"
        )));
    }
    // A start outside the stroke would begin with the stop already loaded.
    let slack = 1e-9 * max.min(1e3).max(1.0);
    if l0 > max + slack || l0 < min - slack {
        return Err(ElementError::Geometry(format!(
            "its joints start {l0} m apart, outside the stroke [{min}, {max}] m; move a joint or widen the stroke"
        )));
    }
    let stop = spec
        .spring_damper("stiffness_n_per_m", "damping_n_s_per_m", "an end stop")?
        .ok_or_else(|| {
            ElementError::Param(
                "an end stop needs `stiffness_n_per_m`, the stiffness of the stop (N/m)".into(),
            )
        })?;
    Ok(Box::new(EndStop {
        name: spec.name.clone(),
        joints: [a, b],
        min_length_m: min,
        max_length_m: max,
        stop,
    }))
}

impl EndStop {
    /// The overrun Phi (m) and the unit vector a->b.
    fn overrun(&self, x: &[f64]) -> (f64, [f64; 3]) {
        let d = at(x, self.joints[1]) - at(x, self.joints[0]);
        let l = d.norm();
        let phi = (l - self.max_length_m).max(0.0) + (l - self.min_length_m).min(0.0);
        let e = if l > 0.0 { d / l } else { d };
        (phi, [e.x, e.y, e.z])
    }
}

impl Constraint for EndStop {
    super::identity!("end_stop");
    fn rows(&self, _locked: bool) -> usize {
        0
    }
    fn spring(&self) -> Option<ElementSpring> {
        Some(ElementSpring {
            rows: 1,
            stiffness_n_per_m: self.stop.0,
            damping_n_s_per_m: self.stop.1,
            unilateral: true,
        })
    }
    fn residual(&self, x: &[f64], out: &mut [f64]) {
        out[0] = self.overrun(x).0;
    }
    /// [-e, e] while engaged (Phi != 0), zero while free.
    fn jacobian(&self, x: &[f64], out: &mut [f64]) {
        let (phi, e) = self.overrun(x);
        let on = if phi != 0.0 { 1.0 } else { 0.0 };
        for k in 0..3 {
            out[k] = -on * e[k];
            out[3 + k] = on * e[k];
        }
    }
    fn adot_xdot(&self, _x: &[f64], _v: &[f64], out: &mut [f64]) {
        out[0] = 0.0;
    }
    /// max(l - L_max, L_min - l): the overrun past the nearer stroke end,
    /// negative within the stroke.
    fn contact_distance_m(&self, x: &[f64]) -> Option<f64> {
        let l = (at(x, self.joints[1]) - at(x, self.joints[0])).norm();
        Some((l - self.max_length_m).max(self.min_length_m - l))
    }
}
