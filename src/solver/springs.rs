//! The spring-damper force law of compliant elements and compliant latches.
//!
//! Compliant elements (`Constraint::spring`): an element whose rows are held
//! by a spring-damper instead of being imposed. On its residual Phi (m) and
//! rate A Xdot it applies the force
//!     Q = -A^T (k Phi + c A Xdot)
//! (stage `integrator`, with the cables and damping; implicit in the
//! Newmark step, whose iteration takes their stiffness into its Newton
//! steps, stage `newton`), stores the elastic
//! energy 1/2 k |Phi|^2 and dissipates c |A Xdot|^2 (stage `ledger`). The
//! buffers are made once, with the model.
//!
//! An engaged compliant latch is the same law on its sleeve's lock row,
//! Phi = l - L_lock: the tension T = k g + c ldot along the sleeve
//! (`engage_latch`, until it turns rigid, `release_latches`). Its energy and
//! dissipation are booked per latch by the ledger (`book_move` leaves it
//! out).

use super::elements::ElementSpring;
use super::model::Model;
use super::state::{LatchTransient, LockEvent};

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

/// Every compliant element of a model, then the engaged compliant latches.
#[derive(Debug, Default)]
pub(crate) struct ElementSprings {
    work: Vec<SpringWork>,
    /// How many of `work` are the model's compliant elements.
    elements: usize,
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
            .collect::<Vec<_>>();
        ElementSprings {
            elements: work.len(),
            work,
        }
    }

    /// Whether the model has compliant elements (latches aside).
    pub fn has_elements(&self) -> bool {
        self.elements > 0
    }

    /// A compliant latch of stiffness k and damping c engages on sleeve `e`.
    pub fn engage_latch(&mut self, model: &Model, e: usize, k: f64, c: f64) {
        let spring = ElementSpring {
            rows: 1,
            stiffness_n_per_m: k,
            damping_n_s_per_m: c,
            unilateral: false,
        };
        self.work.push(SpringWork {
            element: e,
            spring,
            phi: vec![0.0],
            rate: vec![0.0],
            phi_before: vec![0.0],
            rate_before: vec![0.0],
            jac: vec![0.0; 3 * model.elements[e].joints().len()],
        });
    }

    /// The latches on the sleeves `turned` leave (they turned rigid), or all.
    pub fn release_latches(&mut self, turned: Option<&[usize]>) {
        let n = self.elements;
        let mut i = 0;
        self.work.retain(|w| {
            i += 1;
            i <= n || turned.is_some_and(|t| !t.contains(&w.element))
        });
    }

    /// Phi and A Xdot at (x, v) of every compliant element, and of the
    /// engaged latches where `latches`; the previous values move to
    /// `*_before`.
    fn eval(&mut self, model: &Model, x: &[f64], v: &[f64], latches: bool) {
        let upto = if latches {
            self.work.len()
        } else {
            self.elements
        };
        for w in &mut self.work[..upto] {
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
    /// contracting. 0 without compliant elements and engaged latches.
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
        self.eval(model, x, v, true);
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
        if self.elements == 0 {
            return (0.0, 0.0);
        }
        self.eval(model, x0, v0, false);
        self.eval(model, x1, v1, false);
        let (mut elastic_j, mut damper_j) = (0.0, 0.0);
        for w in &self.work[..self.elements] {
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

/// A Newmark step's X_{n+1} = X_n + h V_n + h^2 ((1/2 - beta) A_n + beta A_{n+1}),
/// V_{n+1} = V_n + h ((1 - gamma) A_n + gamma A_{n+1}): what X_{n+1} and
/// V_{n+1} move per unit of A_{n+1}, beta h^2 (s^2) and gamma h (s).
#[derive(Clone, Copy, Debug)]
pub struct StepGains {
    pub position_s2: f64,
    pub velocity_s: f64,
}

impl StepGains {
    /// The average-acceleration rule: beta = 1/4, gamma = 1/2.
    pub fn trapezoid(h: f64) -> StepGains {
        StepGains {
            position_s2: 0.25 * h * h,
            velocity_s: 0.5 * h,
        }
    }

    /// A spring-damper's force change per unit of A_{n+1} along it:
    /// k beta h^2 + c gamma h.
    pub fn spring(&self, k: f64, c: f64) -> f64 {
        k * self.position_s2 + c * self.velocity_s
    }
}

/// A sleeve's lock gap g = l - L_lock (m) and extension rate ldot (m/s) at
/// (x, v).
pub(crate) fn sleeve_motion_at(
    model: &Model,
    e: usize,
    x: &[f64],
    v: &[f64],
) -> Option<(f64, f64)> {
    let el = &model.elements[e];
    Some((el.lock_gap(x)?, el.extension(x, v)?.1))
}

/// After an accepted step from t0 of length h: a compliant latch's tension
/// at the new state, the peak of sign * T (the largest force through the
/// latch) located inside the step, and the extremes over the current window.
/// Inside the step the gap is the cubic Hermite interpolant of its values
/// and rates at both ends,
///   G(s) = g0 + h r0 s + A s^2 + B s^3,  A = 3 (g1 - g0) - h (2 r0 + r1),
///   B = h (r0 + r1) - 2 (g1 - g0),
/// and the tension T(s) = k G(s) + (c / h) G'(s), a cubic in s. It is built
/// from positions and velocities only: the accelerations of the
/// average-acceleration rule ring on the stiff modes a sub-step does not
/// resolve (elastic members), and a rate c l'' taken from them would make
/// peaks that are not there. A peak is reported once the force has turned;
/// a later maximum replaces it only where it exceeds it by more than
/// `settle_rel` (an undamped latch repeats its first peak every period).
pub(crate) fn track_transient(
    model: &Model,
    tr: &mut LatchTransient,
    ev: &mut LockEvent,
    t0: f64,
    h: f64,
    (x, v): (&[f64], &[f64]),
    settle_rel: f64,
) {
    let Some((g1, r1)) = sleeve_motion_at(model, tr.element, x, v) else {
        return;
    };
    let (k, c, sign) = (tr.stiffness_n_per_m, tr.damping_n_s_per_m, tr.sign);
    let (g0, r0) = (tr.gap_m, tr.rate_m_s);
    let f0 = sign * tr.force_n;
    (tr.gap_m, tr.rate_m_s) = (g1, r1);
    tr.force_n = k * g1 + c * r1;
    let f1 = sign * tr.force_n;
    tr.window_max_n = tr.window_max_n.max(f1);
    tr.window_min_n = tr.window_min_n.min(f1);
    let (qa, qb) = (
        3.0 * (g1 - g0) - h * (2.0 * r0 + r1),
        h * (r0 + r1) - 2.0 * (g1 - g0),
    );
    // sign * T(s) and sign * dT/ds = sign (k G' + (c/h) G'')
    let force = |s: f64| {
        sign * (k * (g0 + s * (h * r0 + s * (qa + s * qb)))
            + c / h * (h * r0 + s * (2.0 * qa + 3.0 * s * qb)))
    };
    let slope = |s: f64| {
        sign * (k * (h * r0 + s * (2.0 * qa + 3.0 * s * qb)) + c / h * (2.0 * qa + 6.0 * s * qb))
    };
    // (the force at contact, c ldot, is the peak where it only falls after)
    let mut best = if ev.peak_force_n.is_none() && f0 > f1 {
        (f0, t0)
    } else {
        (f1, t0 + h)
    };
    // maxima inside the step: the roots of the quadratic slope
    //   sign [3 k B s^2 + (2 k A + 6 c B / h) s + (k h r0 + 2 c A / h)]
    // where it turns from + to -
    let (ca, cb, cc) = (
        3.0 * k * qb,
        2.0 * k * qa + 6.0 * c * qb / h,
        k * h * r0 + 2.0 * c * qa / h,
    );
    for s in quadratic_roots(ca, cb, cc).into_iter().flatten() {
        let turns = sign * (2.0 * ca * s + cb) < 0.0;
        if (0.0..=1.0).contains(&s) && turns && force(s) > best.0 {
            best = (force(s), t0 + s * h);
        }
    }
    let fd1 = slope(1.0);
    let turned = ev.peak_force_n.is_some() || fd1 <= 0.0;
    if turned
        && ev
            .peak_force_n
            .map_or(true, |p| best.0 > p * (1.0 + settle_rel))
    {
        ev.peak_force_n = Some(best.0);
        ev.time_of_peak_s = Some(best.1);
    }
}

/// The real roots of a s^2 + b s + c (one where a vanishes, none where both
/// a and b do).
fn quadratic_roots(a: f64, b: f64, c: f64) -> [Option<f64>; 2] {
    if a.abs() <= 1e-300 {
        return [(b != 0.0).then(|| -c / b), None];
    }
    let disc = b * b - 4.0 * a * c;
    if disc < 0.0 {
        return [None, None];
    }
    // (the root of larger magnitude first, the other from the product
    // c / a: no cancellation)
    let q = -0.5 * (b + b.signum() * disc.sqrt());
    if q == 0.0 {
        return [Some(0.0), None];
    }
    [Some(q / a), Some(c / q)]
}

#[cfg(test)]
mod tests {
    use super::{ElementSprings, StepGains};
    use crate::model::generate::{self, LatchParams, MastParams};

    /// An engaged latch's force derivative against central differences of
    /// its tension along the sleeve, T = k g + c gdot from the element's own
    /// gap and extension rate, at X + (h^2/4) eps dA, V + (h/2) eps dA (the
    /// Newmark move per unit A), from rest (where the terms of the turn of
    /// the axis u that the derivative leaves out vanish): the axial part of
    /// the force on each joint, u . dQ, is dT to first order (the
    /// transverse part T du is orthogonal to u). Its gain against the
    /// closed form (k h^2/4 + c h/2)(1/m_a + 1/m_b).
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
        let latches: Vec<(usize, f64, f64)> = model
            .elements
            .iter()
            .enumerate()
            .filter_map(|(e, el)| el.latch_spring().map(|(k, c)| (e, k, c)))
            .collect();
        assert!(!latches.is_empty(), "the mast has compliant latches");
        let x = model.x0.clone();
        let v = vec![0.0; n];
        let da: Vec<f64> = (0..n).map(|i| ((i * 5 % 13) as f64 - 6.0) / 6.0).collect();
        let h = 1e-3;
        let gains = StepGains::trapezoid(h);
        for &(e, k, c) in &latches {
            // (one latch at a time: the mast's sleeves share joints)
            let mut springs = ElementSprings::new(&model);
            assert!(!springs.has_elements());
            springs.engage_latch(&model, e, k, c);
            let mut q = vec![0.0; n];
            springs.add_forces(&model, &x, &v, &mut q);
            let mut dq = vec![0.0; n];
            springs.add_force_derivative(&model, gains, &da, &mut dq);
            let gain = springs.max_gain(&model, &x, gains);
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
            // and the force itself: T pulls the joints together, -T u on b
            let t = k * el.lock_gap(&x).unwrap();
            let on_b: f64 = (0..3)
                .map(|k3| (x[3 * jb + k3] - x[3 * ja + k3]) / l * q[3 * jb + k3])
                .sum();
            assert!((on_b + t).abs() <= 1e-9 * t.abs(), "{on_b} vs {}", -t);
            springs.release_latches(Some(&[e]));
            let mut q2 = vec![0.0; n];
            springs.add_forces(&model, &x, &v, &mut q2);
            assert!(q2.iter().all(|f| *f == 0.0), "released");
        }
    }

    /// With compliant elements present (the bay-by-bay ring's gears): an
    /// engaged latch adds exactly its own force to theirs, leaves the
    /// elements' energy booking (`book_move`) as it was, and releasing it
    /// leaves the elements' forces to the bit; releasing every latch
    /// (a reset) keeps every element.
    #[test]
    fn latches_join_and_leave_the_compliant_elements() {
        use crate::model::generate::ring::{ring, RingParams};
        let params = RingParams {
            latch: Some(LatchParams {
                stiffness_n_per_m: 1e6,
                damping_n_s_per_m: 1000.0,
            }),
            ..RingParams::bay_by_bay()
        };
        let text = ring(&params).unwrap().to_toml();
        let model = crate::model::parse(&text, "ring.toml").unwrap().model;
        let n = model.n_coords();
        let mut springs = ElementSprings::new(&model);
        assert!(springs.has_elements());
        let elements = springs.work.len();
        let latches: Vec<(usize, f64, f64)> = model
            .elements
            .iter()
            .enumerate()
            .filter_map(|(e, el)| el.latch_spring().map(|(k, c)| (e, k, c)))
            .take(2)
            .collect();
        assert_eq!(latches.len(), 2);
        // a deflected, moving state: every element's spring and damper act
        let x: Vec<f64> = (0..n)
            .map(|i| model.x0[i] + 1e-3 * ((i * 7 % 11) as f64 - 5.0))
            .collect();
        let v: Vec<f64> = (0..n).map(|i| 0.1 * ((i * 3 % 7) as f64 - 3.0)).collect();
        let forces = |sp: &mut ElementSprings| {
            let mut q = vec![0.0; n];
            sp.add_forces(&model, &x, &v, &mut q);
            q
        };
        let q_elements = forces(&mut springs);
        let moved = springs.book_move(&model, (&model.x0, &v), (&x, &v));
        for &(e, k, c) in &latches {
            springs.engage_latch(&model, e, k, c);
        }
        assert_eq!(springs.work.len(), elements + 2);
        let q_all = forces(&mut springs);
        // each latch's own force, -T u on b and T u on a, T = k g + c gdot
        let mut q_latches = vec![0.0; n];
        for &(e, k, c) in &latches {
            let el = &model.elements[e];
            let (ja, jb) = (el.joints()[0], el.joints()[1]);
            let (l, rate) = el.extension(&x, &v).unwrap();
            let t = k * el.lock_gap(&x).unwrap() + c * rate;
            for k3 in 0..3 {
                let u = (x[3 * jb + k3] - x[3 * ja + k3]) / l;
                q_latches[3 * ja + k3] += t * u;
                q_latches[3 * jb + k3] -= t * u;
            }
        }
        let scale = q_all.iter().fold(0.0f64, |m, f| m.max(f.abs()));
        for i in 0..n {
            let want = q_elements[i] + q_latches[i];
            assert!(
                (q_all[i] - want).abs() <= 1e-9 * scale,
                "{i}: {} vs {want}",
                q_all[i]
            );
        }
        assert_eq!(springs.book_move(&model, (&model.x0, &v), (&x, &v)), moved);
        springs.release_latches(Some(&[latches[0].0]));
        assert_eq!(springs.work.len(), elements + 1);
        springs.release_latches(Some(&[latches[1].0]));
        assert_eq!(springs.work.len(), elements);
        assert_eq!(forces(&mut springs), q_elements);
        springs.engage_latch(&model, latches[0].0, latches[0].1, latches[0].2);
        springs.release_latches(None);
        assert_eq!(springs.work.len(), elements);
        assert_eq!(forces(&mut springs), q_elements);
    }
}
