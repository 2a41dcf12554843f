//! Active drive cables: tension along the cable from the capstan law with the
//! current wrap angles, and the generalized forces the cable segments apply.
//!
//! Segment j runs from path[j] to path[j+1]; segment 0 leaves the motor drum at
//! path[0]; the pulley at path[k] (0 < k < last) sits between segments k-1 and k.
//!
//! Wrap angle at pulley k: theta_k = pi - 2 beta_k, with 2 beta_k the angle between
//! the two segments meeting there (a straight run wraps nothing).
//!
//! Sliding: the cable passes over pulley k toward the motor at
//! s_k = -d/dt sum_{j >= k} l_j (the far part shortens while the motor reels in).
//!
//! Tension across a pulley, the corrected Eq. 17 with ds = r dtheta and friction
//! opposing the sliding: dT/dtheta = m T + rho (r s'' - m s^2), m = mu * sigma,
//! sigma = clamp(s / s_slip, -1, 1) the friction direction. Integrated over the wrap
//! from the far side (T_k) to the motor side (T_{k-1}):
//!     T_k = T_{k-1} e^{-m theta} - rho (r s'' - m s^2) theta phi(m theta),
//!     phi(z) = (1 - e^{-z}) / z.
//! With rho = 0 this is the capstan law T_{k-1} / T_k = e^{mu theta} while reeling in,
//! inverted when the cable slides the other way, and continuous through s = 0.

use super::elements::at;
use super::model::Cable;
use super::vec3::Vec3;

#[derive(Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CableEval {
    pub segment_length_m: Vec<f64>,
    pub segment_tension_n: Vec<f64>,
    /// Per pulley (path[1..last]).
    pub wrap_rad: Vec<f64>,
    pub sliding_m_s: Vec<f64>,
    /// Sum of segment lengths (m).
    pub length_m: f64,
}

/// `clone_from` reuses the buffers (the stepping loop copies a cable's state
/// every step and must not allocate).
impl Clone for CableEval {
    fn clone(&self) -> Self {
        CableEval {
            segment_length_m: self.segment_length_m.clone(),
            segment_tension_n: self.segment_tension_n.clone(),
            wrap_rad: self.wrap_rad.clone(),
            sliding_m_s: self.sliding_m_s.clone(),
            length_m: self.length_m,
        }
    }

    fn clone_from(&mut self, o: &Self) {
        self.segment_length_m.clone_from(&o.segment_length_m);
        self.segment_tension_n.clone_from(&o.segment_tension_n);
        self.wrap_rad.clone_from(&o.wrap_rad);
        self.sliding_m_s.clone_from(&o.sliding_m_s);
        self.length_m = o.length_m;
    }
}

impl CableEval {
    pub fn for_cable(c: &Cable) -> Self {
        let segs = c.path.len() - 1;
        let pulleys = segs.saturating_sub(1);
        CableEval {
            segment_length_m: vec![0.0; segs],
            segment_tension_n: vec![0.0; segs],
            wrap_rad: vec![0.0; pulleys],
            sliding_m_s: vec![0.0; pulleys],
            length_m: 0.0,
        }
    }
}

/// phi(z) = (1 - e^{-z}) / z, continuous at 0.
fn phi(z: f64) -> f64 {
    if z.abs() < 1e-12 {
        1.0 - z / 2.0
    } else {
        -f64::exp_m1(-z) / z
    }
}

/// Tension on the far side of a pulley from the motor-side tension `t_motor_side`
/// (see the module doc), never negative (a cable cannot push).
pub fn across_pulley(
    c: &Cable,
    t_motor_side: f64,
    wrap: f64,
    sliding: f64,
    sliding_accel: f64,
) -> f64 {
    let sigma = (sliding / c.slip_speed_m_s).clamp(-1.0, 1.0);
    let m = c.friction_mu * sigma;
    let inertia =
        c.line_density_kg_per_m * (c.pulley_radius_m * sliding_accel - m * sliding * sliding);
    (t_motor_side * (-m * wrap).exp() - inertia * wrap * phi(m * wrap)).max(0.0)
}

/// Evaluates lengths, wrap angles, sliding speeds and tensions. `a` (joint
/// accelerations) feeds the cable-inertia term; pass `None` when rho = 0 or unknown.
pub fn evaluate(
    c: &Cable,
    motor_tension_n: f64,
    x: &[f64],
    v: &[f64],
    a: Option<&[f64]>,
    out: &mut CableEval,
) {
    evaluate_with_direction(c, motor_tension_n, x, v, a, None, out)
}

/// As [`evaluate`], with the friction direction at each pulley where the cable
/// slides slower than `slip_speed_m_s` taken from the given sliding speeds (e.g.
/// those at the start of a time step) instead of the current ones. Inside a step's implicit iteration this keeps the steep friction
/// switch near zero sliding (width `slip_speed_m_s`) out of the iteration, which
/// would otherwise oscillate between the two directions.
pub fn evaluate_with_direction(
    c: &Cable,
    motor_tension_n: f64,
    x: &[f64],
    v: &[f64],
    a: Option<&[f64]>,
    direction_sliding: Option<&[f64]>,
    out: &mut CableEval,
) {
    let segs = c.path.len() - 1;
    out.length_m = 0.0;
    for j in 0..segs {
        out.segment_length_m[j] = (at(x, c.path[j + 1]) - at(x, c.path[j])).norm();
        out.length_m += out.segment_length_m[j];
    }
    // Sliding speeds, accumulated from the anchored end toward the motor.
    let mut rate_far = 0.0;
    for j in (1..segs).rev() {
        let (p, q) = (c.path[j], c.path[j + 1]);
        let d = at(x, q) - at(x, p);
        rate_far += d.dot(&(at(v, q) - at(v, p))) / d.norm();
        out.sliding_m_s[j - 1] = -rate_far; // the pulley at path[j]
    }
    let mut t = motor_tension_n.max(0.0);
    out.segment_tension_n[0] = t;
    for k in 1..segs {
        let u1: Vec3 = at(x, c.path[k - 1]) - at(x, c.path[k]);
        let u2: Vec3 = at(x, c.path[k + 1]) - at(x, c.path[k]);
        let cos2b = (u1.dot(&u2) / (u1.norm() * u2.norm())).clamp(-1.0, 1.0);
        let wrap = std::f64::consts::PI - cos2b.acos();
        out.wrap_rad[k - 1] = wrap;
        let s_accel = match a {
            Some(a) if c.line_density_kg_per_m > 0.0 => sliding_accel(c, k, x, v, a),
            _ => 0.0,
        };
        // Outside the blend zone the direction is the current one (so friction always
        // dissipates); inside it, the given one.
        let current = out.sliding_m_s[k - 1];
        let sliding = match direction_sliding {
            Some(d) if current.abs() < c.slip_speed_m_s => d[k - 1],
            _ => current,
        };
        t = across_pulley(c, t, wrap, sliding, s_accel);
        out.segment_tension_n[k] = t;
    }
}

/// s''_k = -sum_{j >= k} l''_j, with l'' = e.(a_q - a_p) + (|w|^2 - (e.w)^2)/l.
fn sliding_accel(c: &Cable, k: usize, x: &[f64], v: &[f64], a: &[f64]) -> f64 {
    let mut acc = 0.0;
    for j in k..c.path.len() - 1 {
        let (p, q) = (c.path[j], c.path[j + 1]);
        let d = at(x, q) - at(x, p);
        let l = d.norm();
        let e = d / l;
        let w = at(v, q) - at(v, p);
        acc += e.dot(&(at(a, q) - at(a, p))) + (w.norm_squared() - e.dot(&w).powi(2)) / l;
    }
    -acc
}

/// Adds dQ = (dQ/dV) dv to `dq`: the change of the segment forces under a
/// change dv of the joint velocities through the friction direction's blend,
/// at the evaluation `eval` (of this x and some v). Only pulleys sliding
/// slower than `slip_speed_m_s` contribute (elsewhere sigma = +-1 does not
/// depend on the speed). With g_j the force of a unit tension in segment j
/// (its end joints pulled together), s_k = sum_{j >= k} g_j . v, and T_j
/// carrying the factor e^{-mu sigma_k theta_k} of every pulley k <= j before
/// it: dT_j/ds_k = -mu theta_k T_j / s_slip. (Exact without cable inertia;
/// with it, the inertia term's dependence on sigma is left out: the
/// derivative only steers an iteration whose residual is exact.)
///
/// With `start_sliding` (the sliding speeds at the step start), a pulley
/// outside the blend whose sigma differs from the start's takes the
/// secant slope (sigma(s) - sigma(s0)) / (s - s0) instead of 0: from an
/// iterate saturated on the far side, the blend it crossed since the step
/// start still steers the direction (the generalized derivative there is
/// 0, so the Newton step would repeat the plain one and overshoot back).
pub fn add_friction_derivative(
    c: &Cable,
    eval: &CableEval,
    start_sliding: Option<&[f64]>,
    x: &[f64],
    dv: &[f64],
    dq: &mut [f64],
) {
    let segs = c.path.len() - 1;
    if segs < 2 || c.friction_mu == 0.0 {
        return;
    }
    // g_j . dv for segment j
    let g_dot = |j: usize| -> f64 {
        let (p, q) = (c.path[j], c.path[j + 1]);
        let d = at(x, q) - at(x, p);
        -d.dot(&(at(dv, q) - at(dv, p))) / d.norm()
    };
    let mut ds: f64 = (1..segs).map(g_dot).sum(); // at the pulley at path[1]
    let mut cum = 0.0;
    for j in 1..segs {
        // the pulley at path[j], just before segment j
        let (s, slip) = (eval.sliding_m_s[j - 1], c.slip_speed_m_s);
        // mu theta d sigma / ds: inside the blend mu theta / s_slip; outside
        // it 0, or mu theta times the secant slope back to the step start's
        // sigma (sigma != sigma0 implies s != s0)
        let gain = if s.abs() < slip {
            c.friction_mu * eval.wrap_rad[j - 1] / slip
        } else if let Some(start) = start_sliding {
            let s0 = start[j - 1];
            let (sigma, sigma0) = ((s / slip).clamp(-1.0, 1.0), (s0 / slip).clamp(-1.0, 1.0));
            if sigma != sigma0 {
                c.friction_mu * eval.wrap_rad[j - 1] * (sigma - sigma0) / (s - s0)
            } else {
                0.0
            }
        } else {
            0.0
        };
        cum += gain * ds;
        let gd = g_dot(j);
        ds -= gd;
        let dt = -eval.segment_tension_n[j] * cum;
        if dt == 0.0 {
            continue;
        }
        let (p, r) = (c.path[j], c.path[j + 1]);
        let d = at(x, r) - at(x, p);
        let f = d * (dt / d.norm());
        for k in 0..3 {
            dq[3 * p + k] += f[k];
            dq[3 * r + k] -= f[k];
        }
    }
}

/// Adds the segment forces to Q: segment j pulls its two end joints toward each other.
pub fn add_forces(c: &Cable, eval: &CableEval, x: &[f64], q: &mut [f64]) {
    for j in 0..c.path.len() - 1 {
        let (p, r) = (c.path[j], c.path[j + 1]);
        let d = at(x, r) - at(x, p);
        let f = d * (eval.segment_tension_n[j] / d.norm());
        for k in 0..3 {
            q[3 * p + k] += f[k];
            q[3 * r + k] -= f[k];
        }
    }
}
