//! Stage `momentum`: a free-floating model's total momenta held at their start.
//!
//! With no support, gravity or joint damping every force is internal (rows,
//! members, latches, cable segments between joints: pairs along lines or
//! derived from potentials that rigid motions leave unchanged), so the
//! linear momentum P = sum m v and the angular momentum about the centre of
//! mass, L = sum m (x - c) x v, are constant. The trapezoid keeps P (its
//! forces cancel in pairs) but L only to its truncation,
//!     L_{n+1} - L_n = h/2 (sum m v_n x v_{n+1} - sum (x_{n+1} - x_n) x F_{n+1}),
//! and the backward-Euler sub-steps likewise. After every accepted sub-step
//! the velocities take the least change in the kinetic norm that restores
//! both,
//!     min 1/2 dV^T M dV   subject to   P(V + dV) = P_0,  L(V + dV) = L_0,
//! whose solution is a rigid motion (the constraint gradients m_i 1 and
//! m_i [x_i - c]x, weighted by M^-1):
//!     dv_i = tau + omega x (x_i - c),   M tau = P_0 - P,   I_c omega = L_0 - L,
//!     I_c = sum m (|r|^2 1 - r r^T),  r = x - c.
//! No constraint row feels it: every row is unchanged by rigid motions (the
//! test of `free_floating`), so A dV = 0 and the velocity constraints hold
//! as before. The kinetic energy changes by tau.P + omega.L + 1/2 (M |tau|^2 +
//! omega^T I_c omega), which from a state at its start's momenta is
//! -1/2 (|dP|^2 / M + dL^T I_c^-1 dL): second order in the drift.
//! `HeldMomentum` counts every correction and sums their sizes.

use crate::solver::jacobian::Jacobian;
use crate::solver::model::Model;
use crate::solver::state::HeldMomentum;
use nalgebra::{Matrix3, Vector3};

/// Whether `model` is free-floating: no gravity, no joint damping, and no
/// constraint row (every lock's included) moved by any of the six rigid
/// motions at the initial positions beyond `free_rel` (`momentum_free_rel`)
/// of max|A| max|motion|.
pub(super) fn free_floating(model: &Model, free_rel: f64) -> bool {
    if model.gravity_m_s2.iter().any(|g| *g != 0.0) || model.damping_n_s_per_m != 0.0 {
        return false;
    }
    let mut jac = Jacobian::pattern(model, &vec![true; model.elements.len()]);
    jac.fill(model, &model.x0);
    if jac.nrows == 0 {
        return true;
    }
    let amax = jac.values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let c = centre_of_mass(model, &model.x0);
    let (mut motion, mut rows) = (vec![0.0; model.n_coords()], vec![0.0; jac.nrows]);
    for k in 0..6 {
        let axis = Vector3::ith(k % 3, 1.0);
        for j in 0..model.n_joints() {
            let r = joint(&model.x0, j) - c;
            let w = if k < 3 { axis } else { axis.cross(&r) };
            motion[3 * j..3 * j + 3].copy_from_slice(w.as_slice());
        }
        let wmax = motion.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        jac.mul(&motion, &mut rows);
        let moved = rows.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        if moved > free_rel * amax * wmax {
            return false;
        }
    }
    true
}

/// The momenta of (x, v) as held: P and L about the centre of mass.
pub(super) fn at_start(model: &Model, x: &[f64], v: &[f64]) -> HeldMomentum {
    let m = Momenta::of(model, x, v);
    HeldMomentum {
        linear_n_s: m.linear.into(),
        angular_n_m_s: m.angular.into(),
        ..HeldMomentum::default()
    }
}

/// Restores the held momenta on `v` at positions `x` by the rigid motion of
/// least kinetic norm (module notes), booking the correction in `held`. A
/// system whose joints lie on one line (I_c singular) has its linear
/// momentum restored only.
pub(super) fn hold(model: &Model, x: &[f64], v: &mut [f64], held: &mut HeldMomentum) {
    let m = Momenta::of(model, x, v);
    let dp = Vector3::from(held.linear_n_s) - m.linear;
    let dl = Vector3::from(held.angular_n_m_s) - m.angular;
    if dp == Vector3::zeros() && dl == Vector3::zeros() {
        return;
    }
    let tau = dp / m.mass_kg;
    let omega = match m.inertia.cholesky() {
        Some(ch) if dl != Vector3::zeros() => ch.solve(&dl),
        _ => Vector3::zeros(),
    };
    let mut kinetic_change_j = 0.0;
    for (j, jt) in model.joints.iter().enumerate() {
        let dv = tau + omega.cross(&(joint(x, j) - m.centre));
        for k in 0..3 {
            let vi = &mut v[3 * j + k];
            kinetic_change_j += jt.mass_kg * (*vi * dv[k] + 0.5 * dv[k] * dv[k]);
            *vi += dv[k];
        }
    }
    held.corrections += 1;
    held.linear_removed_n_s += dp.norm();
    held.angular_removed_n_m_s += dl.norm();
    held.largest_angular_n_m_s = held.largest_angular_n_m_s.max(dl.norm());
    held.kinetic_change_j += kinetic_change_j;
}

/// A system's total mass, centre of mass, momenta and central inertia.
struct Momenta {
    mass_kg: f64,
    centre: Vector3<f64>,
    /// sum m v (N s) and sum m (x - c) x v (N m s).
    linear: Vector3<f64>,
    angular: Vector3<f64>,
    /// sum m (|r|^2 1 - r r^T), r = x - c (kg m^2).
    inertia: Matrix3<f64>,
}

impl Momenta {
    fn of(model: &Model, x: &[f64], v: &[f64]) -> Momenta {
        let centre = centre_of_mass(model, x);
        let (mut mass_kg, mut linear, mut angular) = (0.0, Vector3::zeros(), Vector3::zeros());
        let mut inertia = Matrix3::zeros();
        for (j, jt) in model.joints.iter().enumerate() {
            let (r, vj) = (joint(x, j) - centre, joint(v, j));
            let m = jt.mass_kg;
            mass_kg += m;
            linear += m * vj;
            angular += m * r.cross(&vj);
            inertia += m * (Matrix3::identity() * r.norm_squared() - r * r.transpose());
        }
        Momenta {
            mass_kg,
            centre,
            linear,
            angular,
            inertia,
        }
    }
}

fn centre_of_mass(model: &Model, x: &[f64]) -> Vector3<f64> {
    let (mut total, mut sum) = (0.0, Vector3::zeros());
    for (j, jt) in model.joints.iter().enumerate() {
        total += jt.mass_kg;
        sum += jt.mass_kg * joint(x, j);
    }
    sum / total
}

fn joint(x: &[f64], j: usize) -> Vector3<f64> {
    Vector3::new(x[3 * j], x[3 * j + 1], x[3 * j + 2])
}
