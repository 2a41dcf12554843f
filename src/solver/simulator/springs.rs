//! Compliant elements (`Constraint::spring`): an element whose rows are held
//! by a spring-damper instead of being imposed. On its residual Phi (m) and
//! rate A Xdot it applies the force
//!     Q = -A^T (k Phi + c A Xdot)
//! (stage `integrator`, with the cables and damping; implicit in the
//! Newmark step, whose iteration takes their stiffness into its Newton
//! steps, stage `newton`), stores the elastic
//! energy 1/2 k |Phi|^2 and dissipates c |A Xdot|^2 (stage `ledger`). The
//! buffers are made once, with the model.

use super::core::StepGains;
use crate::solver::elements::ElementSpring;
use crate::solver::model::Model;

/// One compliant element's buffers: its residual and rate rows at the last
/// evaluation and the one before, and its Jacobian rows.
#[derive(Debug)]
struct SpringWork {
    element: usize,
    spring: ElementSpring,
    phi: Vec<f64>,
    rate: Vec<f64>,
    phi_before: Vec<f64>,
    rate_before: Vec<f64>,
    jac: Vec<f64>,
}

/// A spring row's force f = k Phi + c A Xdot (N; the force on the joints is
/// -A^T f); a unilateral row (a contact) only pushes: 0 where f and Phi
/// differ in sign (the damper would pull the members back into the contact).
fn row_force(spring: &ElementSpring, phi: f64, rate: f64) -> f64 {
    let f = spring.stiffness_n_per_m * phi + spring.damping_n_s_per_m * rate;
    if spring.unilateral && f * phi <= 0.0 {
        0.0
    } else {
        f
    }
}

/// Every compliant element of a model.
#[derive(Debug, Default)]
pub(super) struct ElementSprings {
    work: Vec<SpringWork>,
}

impl ElementSprings {
    pub fn new(model: &Model) -> ElementSprings {
        let work = model
            .elements
            .iter()
            .enumerate()
            .filter_map(|(e, el)| {
                let spring = el.spring()?;
                let r = spring.rows;
                Some(SpringWork {
                    element: e,
                    spring,
                    phi: vec![0.0; r],
                    rate: vec![0.0; r],
                    phi_before: vec![0.0; r],
                    rate_before: vec![0.0; r],
                    jac: vec![0.0; r * 3 * el.joints().len()],
                })
            })
            .collect();
        ElementSprings { work }
    }

    pub fn is_empty(&self) -> bool {
        self.work.is_empty()
    }

    /// Phi and A Xdot of every compliant element at (x, v); the previous
    /// values move to `*_before`.
    fn eval(&mut self, model: &Model, x: &[f64], v: &[f64]) {
        for w in &mut self.work {
            let el = &model.elements[w.element];
            std::mem::swap(&mut w.phi, &mut w.phi_before);
            std::mem::swap(&mut w.rate, &mut w.rate_before);
            el.residual(x, &mut w.phi);
            el.jacobian(x, &mut w.jac);
            let joints = el.joints();
            let width = 3 * joints.len();
            for (r, rate) in w.rate.iter_mut().enumerate() {
                let row = &w.jac[r * width..(r + 1) * width];
                *rate = row
                    .iter()
                    .enumerate()
                    .map(|(col, a)| a * v[3 * joints[col / 3] + col % 3])
                    .sum();
            }
        }
    }

    /// The largest gain of the Newmark fixed-point map on a spring row in a
    /// step of `gains` (beta h^2, gamma h), (beta h^2 k + gamma h c) w, with w = sum A_j^2 / m_j the row's
    /// inverse mass over its free joints (a bound on the constrained one):
    /// at 1 and above the springs alone keep the plain iteration from
    /// contracting. 0 without compliant elements.
    pub fn max_gain(&mut self, model: &Model, x: &[f64], gains: StepGains) -> f64 {
        let mut gain = 0.0f64;
        for w in &mut self.work {
            let el = &model.elements[w.element];
            el.jacobian(x, &mut w.jac);
            let joints = el.joints();
            let width = 3 * joints.len();
            let (k, c) = (w.spring.stiffness_n_per_m, w.spring.damping_n_s_per_m);
            for r in 0..w.spring.rows {
                let inv_mass: f64 = w.jac[r * width..(r + 1) * width]
                    .iter()
                    .enumerate()
                    .map(|(col, a)| a * a * model.inv_mass[3 * joints[col / 3] + col % 3])
                    .sum();
                gain = gain.max(gains.spring(k, c) * inv_mass);
            }
        }
        gain
    }

    /// Adds the springs' forces -A^T (k Phi + c A Xdot) at (x, v) to `q`.
    pub fn add_forces(&mut self, model: &Model, x: &[f64], v: &[f64], q: &mut [f64]) {
        self.eval(model, x, v);
        for w in &self.work {
            let joints = model.elements[w.element].joints();
            let width = 3 * joints.len();
            for (r, (&phi, &rate)) in w.phi.iter().zip(&w.rate).enumerate() {
                let f = row_force(&w.spring, phi, rate);
                for (col, a) in w.jac[r * width..(r + 1) * width].iter().enumerate() {
                    q[3 * joints[col / 3] + col % 3] -= f * a;
                }
            }
        }
    }

    /// Adds the springs' force change along a change dA of the Newmark
    /// iterate's accelerations to `dq`: with dX = beta h^2 dA and
    /// dV = gamma h dA (`gains`; h^2/4 and h/2 for the average acceleration),
    ///     dQ = -A^T (k A dX + c A dV) = -(k beta h^2 + c gamma h) A^T A dA,
    /// at the Jacobian of the last force evaluation (the geometric term
    /// (dA^T/dX) (k Phi + c A Xdot) is left out: this is the Newton
    /// direction's derivative, whose residual is exact); a unilateral row
    /// whose force was 0 there adds none.
    pub fn add_force_derivative(
        &self,
        model: &Model,
        gains: StepGains,
        da: &[f64],
        dq: &mut [f64],
    ) {
        for w in &self.work {
            let joints = model.elements[w.element].joints();
            let width = 3 * joints.len();
            let (k, c) = (w.spring.stiffness_n_per_m, w.spring.damping_n_s_per_m);
            let gain = gains.spring(k, c);
            for r in 0..w.spring.rows {
                if w.spring.unilateral && row_force(&w.spring, w.phi[r], w.rate[r]) == 0.0 {
                    continue;
                }
                let row = &w.jac[r * width..(r + 1) * width];
                let rate: f64 = row
                    .iter()
                    .enumerate()
                    .map(|(col, a)| a * da[3 * joints[col / 3] + col % 3])
                    .sum();
                for (col, a) in row.iter().enumerate() {
                    dq[3 * joints[col / 3] + col % 3] -= gain * rate * a;
                }
            }
        }
    }

    /// Over a move of the joints from (x0, v0) to (x1, v1): the change of the
    /// springs' elastic energy, sum 1/2 k (|Phi_1|^2 - |Phi_0|^2) (exact), and
    /// the dampers' dissipation, sum c 1/2 (rate_0 + rate_1) . (Phi_1 - Phi_0)
    /// (the trapezoid, as the joint damping's) (J); on a unilateral row the
    /// damper's force is what the contact adds to the spring's, f - k Phi
    /// (-k Phi where the contact lets go), by the same trapezoid.
    pub fn book_move(
        &mut self,
        model: &Model,
        (x0, v0): (&[f64], &[f64]),
        (x1, v1): (&[f64], &[f64]),
    ) -> (f64, f64) {
        if self.work.is_empty() {
            return (0.0, 0.0);
        }
        self.eval(model, x0, v0);
        self.eval(model, x1, v1);
        let (mut elastic_j, mut damper_j) = (0.0, 0.0);
        for w in &self.work {
            let (k, c) = (w.spring.stiffness_n_per_m, w.spring.damping_n_s_per_m);
            for r in 0..w.phi.len() {
                let (p0, p1) = (w.phi_before[r], w.phi[r]);
                elastic_j += 0.5 * k * (p1 * p1 - p0 * p0);
                damper_j += if w.spring.unilateral {
                    let f0 = row_force(&w.spring, p0, w.rate_before[r]) - k * p0;
                    let f1 = row_force(&w.spring, p1, w.rate[r]) - k * p1;
                    0.5 * (f0 + f1) * (p1 - p0)
                } else {
                    c * 0.5 * (w.rate_before[r] + w.rate[r]) * (p1 - p0)
                };
            }
        }
        (elastic_j, damper_j)
    }
}

/// The engaged compliant latches of a transient, each (element, k, c): the
/// tension T = k g + c gdot along the sleeve's unit axis u (`Core::springs`).
/// Its derivative per unit change dA of the accelerations (X and V move by
/// beta h^2 and gamma h per unit A, `gains`):
/// dT = (k beta h^2 + c gamma h) u . (dA_b - dA_a),
/// pulling a by dT u and b by -dT u. Left out are the terms from the turn
/// of u: the transverse force T/l (I - u u^T) h^2/4 and the damper's
/// c (v_b - v_a) . du (at a latch's load and a transient's sub-steps both
/// are far below the joints' mass; Newton's line search judges every
/// iterate on the exact residual). Adds it to `dq`.
pub fn add_latch_spring_derivative(
    model: &Model,
    springs: &[(usize, f64, f64)],
    x: &[f64],
    gains: StepGains,
    da: &[f64],
    dq: &mut [f64],
) {
    for &(e, k, c) in springs {
        let Some((ja, jb, u)) = sleeve_axis(model, e, x) else {
            continue;
        };
        let gain = gains.spring(k, c);
        let rate: f64 = (0..3)
            .map(|k3| u[k3] * (da[3 * jb + k3] - da[3 * ja + k3]))
            .sum();
        for k3 in 0..3 {
            let f = gain * rate * u[k3];
            dq[3 * ja + k3] += f;
            dq[3 * jb + k3] -= f;
        }
    }
}

/// The largest gain of the Newmark fixed-point map on an engaged compliant
/// latch in a step of `gains`, (k beta h^2 + c gamma h) u^T (W_a + W_b) u (W the joints'
/// inverse masses): at 1 and above the latches alone keep the plain
/// iteration from contracting (as `ElementSprings::max_gain`). 0 with none.
pub fn latch_springs_max_gain(
    model: &Model,
    springs: &[(usize, f64, f64)],
    x: &[f64],
    gains: StepGains,
) -> f64 {
    let mut max_gain = 0.0f64;
    for &(e, k, c) in springs {
        let Some((ja, jb, u)) = sleeve_axis(model, e, x) else {
            continue;
        };
        let inv_mass: f64 = (0..3)
            .map(|k3| u[k3] * u[k3] * (model.inv_mass[3 * ja + k3] + model.inv_mass[3 * jb + k3]))
            .sum();
        max_gain = max_gain.max(gains.spring(k, c) * inv_mass);
    }
    max_gain
}

/// A sleeve's end joints (a, b) and unit axis u = (X_b - X_a) / l at x;
/// None at zero length.
fn sleeve_axis(model: &Model, e: usize, x: &[f64]) -> Option<(usize, usize, [f64; 3])> {
    let joints = model.elements[e].joints();
    let (ja, jb) = (joints[0], joints[1]);
    let mut u = [0.0; 3];
    for (k3, u) in u.iter_mut().enumerate() {
        *u = x[3 * jb + k3] - x[3 * ja + k3];
    }
    let l = (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt();
    if l <= 0.0 {
        return None;
    }
    u.iter_mut().for_each(|u| *u /= l);
    Some((ja, jb, u))
}

#[cfg(test)]
mod tests {
    use super::{add_latch_spring_derivative, latch_springs_max_gain, StepGains};
    use crate::model::generate::{self, LatchParams, MastParams};

    /// The latch springs' derivative against central differences of the
    /// tension along the sleeve, T = k g + c gdot from the element's own
    /// gap and extension rate, at X + (h^2/4) eps dA, V + (h/2) eps dA (the
    /// Newmark move per unit A), from rest (where the terms of the turn of
    /// u that the derivative leaves out vanish): the axial part of the force
    /// on each joint, u . dQ, is dT to first order (the transverse part
    /// T du is orthogonal to u).
    #[test]
    fn latch_spring_derivative_matches_finite_differences() {
        let params = MastParams {
            latch: Some(LatchParams {
                stiffness_n_per_m: 2e5,
                damping_n_s_per_m: 300.0,
            }),
            ..MastParams::default()
        };
        let text = generate::mast(&params).unwrap().to_toml();
        let model = crate::model::parse(&text, "mast.toml").unwrap().model;
        let n = model.n_coords();
        let springs: Vec<(usize, f64, f64)> = model
            .elements
            .iter()
            .enumerate()
            .filter_map(|(e, el)| el.latch_spring().map(|(k, c)| (e, k, c)))
            .collect();
        assert!(!springs.is_empty(), "the mast has compliant latches");
        let x = model.x0.clone();
        let v = vec![0.0; n];
        let da: Vec<f64> = (0..n).map(|i| ((i * 5 % 13) as f64 - 6.0) / 6.0).collect();
        let h = 1e-3;
        for &(e, k, c) in &springs {
            // (one spring at a time: the mast's sleeves share joints)
            let mut dq = vec![0.0; n];
            let gains = StepGains::trapezoid(h);
            add_latch_spring_derivative(&model, &[(e, k, c)], &x, gains, &da, &mut dq);
            let gain = latch_springs_max_gain(&model, &[(e, k, c)], &x, gains);
            let el = &model.elements[e];
            let (ja, jb) = (el.joints()[0], el.joints()[1]);
            // (the mast's joints have one mass in every direction)
            let w_free = model.inv_mass[3 * ja] + model.inv_mass[3 * jb];
            let want = (0.25 * h * h * k + 0.5 * h * c) * w_free;
            assert!(
                (gain - want).abs() <= 1e-12 * want,
                "{}: gain {gain} vs {want}",
                el.name()
            );
            let tension = |eps: f64| {
                let xe: Vec<f64> = (0..n).map(|i| x[i] + 0.25 * h * h * eps * da[i]).collect();
                let ve: Vec<f64> = (0..n).map(|i| v[i] + 0.5 * h * eps * da[i]).collect();
                k * el.lock_gap(&xe).unwrap() + c * el.extension(&xe, &ve).unwrap().1
            };
            let eps = 1e-3;
            let dt_fd = (tension(eps) - tension(-eps)) / (2.0 * eps);
            let l: f64 = (0..3)
                .map(|k3| (x[3 * jb + k3] - x[3 * ja + k3]).powi(2))
                .sum::<f64>()
                .sqrt();
            let axial = |j: usize| -> f64 {
                (0..3)
                    .map(|k3| (x[3 * jb + k3] - x[3 * ja + k3]) / l * dq[3 * j + k3])
                    .sum()
            };
            assert!(
                (axial(ja) - dt_fd).abs() <= 1e-7 * dt_fd.abs().max(1.0),
                "{}: {} vs {dt_fd}",
                el.name(),
                axial(ja)
            );
            assert!(
                (axial(jb) + dt_fd).abs() <= 1e-7 * dt_fd.abs().max(1.0),
                "{}: {} vs {}",
                el.name(),
                axial(jb),
                -dt_fd
            );
        }
    }
}
