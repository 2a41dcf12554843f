//! The rigid bodies' attitude and rate over a run (a spacecraft bus:
//! `rigid_body` elements) and the whole system's linear and angular
//! momentum, sampled after every step.
//!
//! - Attitude: the rotation R that best maps the body's initial joint
//!   positions about its centre of mass, p_i, onto its current ones, q_i
//!   (Kabsch: R = U diag(1, 1, det U V^T) V^T of the SVD of H = sum m_i q_i
//!   p_i^T, exact for a rigid body); its angle acos((tr R - 1) / 2).
//! - Rate: omega = I^-1 sum m_i q_i x (v_i - v_c), I = sum m_i (|q_i|^2 1 -
//!   q_i q_i^T): exact for a rigid motion.
//! - Momentum: P = sum m v, L = sum m (x - c_0) x v about the initial centre
//!   of mass c_0. Internal forces (members, latches, cables between joints)
//!   leave both unchanged; supports and joint damping (on absolute
//!   velocities) do not. The drift is the largest |P - P_0| (|L - L_0|) over
//!   the run relative to the largest sum m |v| (sum m |x - c_0| |v|), the
//!   size of the momenta that cancel in the sum. A free-floating model's
//!   step holds both (stage `momentum`); what it took out is reported too.

use super::{RecordError, Recorder};
use crate::run::Stop;
use crate::solver::Simulator;
use nalgebra::{Matrix3, Vector3};
use serde::Serialize;

/// A rigid body at the end of a run.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BodySummary {
    pub name: String,
    /// Largest |omega| over the steps (rad/s) and when (s).
    pub peak_rate_rad_s: f64,
    pub peak_rate_time_s: f64,
    /// |omega| at the end (rad/s).
    pub final_rate_rad_s: f64,
    /// The rotation from the start to the end: angle (deg) and unit axis.
    pub final_attitude_change_deg: f64,
    pub final_rotation_axis: [f64; 3],
}

/// The system's momenta over a run.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MomentumSummary {
    /// At the end: P (N s) and L about the initial centre of mass (N m s).
    pub final_linear_n_s: [f64; 3],
    pub final_angular_n_m_s: [f64; 3],
    /// Largest change from the start relative to the momentum scale.
    pub linear_drift_rel: f64,
    pub angular_drift_rel: f64,
    /// The scales: largest sum m |v| (N s) and sum m |x - c_0| |v| (N m s).
    pub linear_scale_n_s: f64,
    pub angular_scale_n_m_s: f64,
    /// Whether the step held both momenta (a free-floating model with
    /// `momentum_projection`: docs/solver.md, Momentum), in how many
    /// sub-steps it corrected them, the sums of those corrections' sizes
    /// relative to the scales (the integrator's own drift, taken out), and
    /// the kinetic energy they changed in all (J).
    pub held: bool,
    pub corrections: u64,
    pub linear_removed_rel: f64,
    pub angular_removed_rel: f64,
    pub kinetic_change_j: f64,
}

#[derive(Clone, Debug, PartialEq)]
struct Body {
    name: String,
    joints: Vec<usize>,
    mass: Vec<f64>,
    /// Initial positions about the initial centre of mass.
    p: Vec<Vector3<f64>>,
}

/// A model's rigid bodies and the system's centre of mass at an initial
/// geometry, against which attitudes and momenta are taken.
#[derive(Clone, Debug, PartialEq)]
pub struct Bodies {
    bodies: Vec<Body>,
    c0: Vector3<f64>,
}

/// One instant: per body (|omega| rad/s, rotation angle rad, unit axis),
/// and the system's P (N s) and L about the initial centre of mass (N m s)
/// with their scales, sum m |v| and sum m |x - c_0| |v|.
#[derive(Clone, Debug, PartialEq)]
pub struct BodiesNow {
    pub bodies: Vec<(f64, f64, [f64; 3])>,
    pub linear_n_s: [f64; 3],
    pub angular_n_m_s: [f64; 3],
    pub linear_scale_n_s: f64,
    pub angular_scale_n_m_s: f64,
}

impl Bodies {
    /// The `rigid_body` elements of `model`, at positions `x0`.
    pub fn of(model: &crate::solver::Model, x0: &[f64]) -> Bodies {
        let bodies = model
            .elements
            .iter()
            .filter(|e| e.kind() == "rigid_body")
            .map(|e| {
                let joints = e.joints().to_vec();
                let mass: Vec<f64> = joints.iter().map(|&j| model.joints[j].mass_kg).collect();
                let c = centre(&joints, &mass, x0);
                Body {
                    name: e.name().to_string(),
                    p: joints.iter().map(|&j| joint(x0, j) - c).collect(),
                    joints,
                    mass,
                }
            })
            .collect();
        let all: Vec<usize> = (0..model.n_joints()).collect();
        let masses: Vec<f64> = model.joints.iter().map(|j| j.mass_kg).collect();
        Bodies {
            bodies,
            c0: centre(&all, &masses, x0),
        }
    }

    pub fn names(&self) -> Vec<String> {
        self.bodies.iter().map(|b| b.name.clone()).collect()
    }

    pub fn is_empty(&self) -> bool {
        self.bodies.is_empty()
    }

    /// The bodies and the momenta at positions `x`, velocities `v`.
    pub fn now(&self, model: &crate::solver::Model, x: &[f64], v: &[f64]) -> BodiesNow {
        let (mut p, mut l) = (Vector3::zeros(), Vector3::zeros());
        let (mut ps, mut ls) = (0.0, 0.0);
        for (j, jt) in model.joints.iter().enumerate() {
            let (r, vj) = (joint(x, j) - self.c0, joint(v, j));
            p += jt.mass_kg * vj;
            l += jt.mass_kg * r.cross(&vj);
            ps += jt.mass_kg * vj.norm();
            ls += jt.mass_kg * r.norm() * vj.norm();
        }
        BodiesNow {
            bodies: self.bodies.iter().map(|b| attitude(b, x, v)).collect(),
            linear_n_s: p.into(),
            angular_n_m_s: l.into(),
            linear_scale_n_s: ps,
            angular_scale_n_m_s: ls,
        }
    }
}

/// Samples the bodies and the momenta after every step (`simulate`, a
/// sweep's samples): peaks, drifts and the last values.
pub struct BodyRecorder {
    bodies: Bodies,
    /// Per body: peak rate and its time; the last (rate, angle, axis).
    peak: Vec<(f64, f64)>,
    last: Vec<(f64, f64, [f64; 3])>,
    p0: Vector3<f64>,
    l0: Vector3<f64>,
    p_drift: f64,
    l_drift: f64,
    p_scale: f64,
    l_scale: f64,
    p_last: Vector3<f64>,
    l_last: Vector3<f64>,
    /// The state's held momenta at the last sample.
    held: Option<crate::solver::state::HeldMomentum>,
}

fn joint(x: &[f64], j: usize) -> Vector3<f64> {
    Vector3::new(x[3 * j], x[3 * j + 1], x[3 * j + 2])
}

impl BodyRecorder {
    pub fn new(sim: &Simulator) -> BodyRecorder {
        let (m, s) = (sim.model(), sim.state());
        let bodies = Bodies::of(m, &s.x);
        let start = bodies.now(m, &s.x, &s.v);
        let n = bodies.bodies.len();
        let mut r = BodyRecorder {
            bodies,
            peak: vec![(0.0, s.t_s); n],
            last: vec![(0.0, 0.0, [0.0; 3]); n],
            p0: start.linear_n_s.into(),
            l0: start.angular_n_m_s.into(),
            p_drift: 0.0,
            l_drift: 0.0,
            p_scale: 0.0,
            l_scale: 0.0,
            p_last: Vector3::zeros(),
            l_last: Vector3::zeros(),
            held: None,
        };
        r.sample(sim);
        r
    }

    /// Whether the model has a rigid body to follow.
    pub fn has_bodies(&self) -> bool {
        !self.bodies.is_empty()
    }

    fn sample(&mut self, sim: &Simulator) {
        let s = sim.state();
        let now = self.bodies.now(sim.model(), &s.x, &s.v);
        let (p, l): (Vector3<f64>, Vector3<f64>) =
            (now.linear_n_s.into(), now.angular_n_m_s.into());
        self.p_scale = self.p_scale.max(now.linear_scale_n_s);
        self.l_scale = self.l_scale.max(now.angular_scale_n_m_s);
        self.p_drift = self.p_drift.max((p - self.p0).norm());
        self.l_drift = self.l_drift.max((l - self.l0).norm());
        (self.p_last, self.l_last) = (p, l);
        self.held = s.momentum;
        for (k, b) in now.bodies.into_iter().enumerate() {
            if b.0 > self.peak[k].0 {
                self.peak[k] = (b.0, s.t_s);
            }
            self.last[k] = b;
        }
    }

    pub fn bodies(&self) -> Vec<BodySummary> {
        self.bodies
            .names()
            .into_iter()
            .enumerate()
            .map(|(k, name)| BodySummary {
                name,
                peak_rate_rad_s: self.peak[k].0,
                peak_rate_time_s: self.peak[k].1,
                final_rate_rad_s: self.last[k].0,
                final_attitude_change_deg: self.last[k].1.to_degrees(),
                final_rotation_axis: self.last[k].2,
            })
            .collect()
    }

    /// `summary` with this recorder's bodies and momentum (when the model
    /// has a rigid body; unchanged otherwise).
    pub fn complete(&self, summary: crate::run::RunSummary) -> crate::run::RunSummary {
        if !self.has_bodies() {
            return summary;
        }
        crate::run::RunSummary {
            bodies: self.bodies(),
            momentum: Some(self.momentum()),
            ..summary
        }
    }

    pub fn momentum(&self) -> MomentumSummary {
        let rel = |d: f64, s: f64| if s > 0.0 { d / s } else { 0.0 };
        MomentumSummary {
            final_linear_n_s: self.p_last.into(),
            final_angular_n_m_s: self.l_last.into(),
            linear_drift_rel: rel(self.p_drift, self.p_scale),
            angular_drift_rel: rel(self.l_drift, self.l_scale),
            linear_scale_n_s: self.p_scale,
            angular_scale_n_m_s: self.l_scale,
            held: self.held.is_some(),
            corrections: self.held.map_or(0, |h| h.corrections),
            linear_removed_rel: rel(
                self.held.map_or(0.0, |h| h.linear_removed_n_s),
                self.p_scale,
            ),
            angular_removed_rel: rel(
                self.held.map_or(0.0, |h| h.angular_removed_n_m_s),
                self.l_scale,
            ),
            kinetic_change_j: self.held.map_or(0.0, |h| h.kinetic_change_j),
        }
    }
}

fn centre(joints: &[usize], mass: &[f64], x: &[f64]) -> Vector3<f64> {
    let total: f64 = mass.iter().sum();
    joints
        .iter()
        .zip(mass)
        .map(|(&j, &m)| m * joint(x, j))
        .sum::<Vector3<f64>>()
        / total
}

/// |omega| (rad/s), the rotation angle (rad) and its unit axis.
fn attitude(b: &Body, x: &[f64], v: &[f64]) -> (f64, f64, [f64; 3]) {
    let c = centre(&b.joints, &b.mass, x);
    let vc = centre(&b.joints, &b.mass, v);
    let (mut h, mut inertia, mut lb) = (Matrix3::zeros(), Matrix3::zeros(), Vector3::zeros());
    for ((&j, &m), p) in b.joints.iter().zip(&b.mass).zip(&b.p) {
        let q = joint(x, j) - c;
        h += m * q * p.transpose();
        inertia += m * (q.norm_squared() * Matrix3::identity() - q * q.transpose());
        lb += m * q.cross(&(joint(v, j) - vc));
    }
    let omega = inertia.try_inverse().map_or(Vector3::zeros(), |i| i * lb);
    let svd = h.svd(true, true);
    let (u, vt) = (svd.u.expect("u"), svd.v_t.expect("v_t"));
    let d = (u * vt).determinant().signum();
    let r = u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * vt;
    let angle = ((r.trace() - 1.0) / 2.0).clamp(-1.0, 1.0).acos();
    // axis from the skew part (R - R^T) / 2 = sin(angle) [axis]x
    let w = Vector3::new(
        r[(2, 1)] - r[(1, 2)],
        r[(0, 2)] - r[(2, 0)],
        r[(1, 0)] - r[(0, 1)],
    );
    let axis = if w.norm() > 0.0 {
        w / w.norm()
    } else {
        Vector3::zeros()
    };
    (omega.norm(), angle, [axis.x, axis.y, axis.z])
}

impl Recorder for BodyRecorder {
    fn after_step(&mut self, sim: &mut Simulator) -> Result<(), RecordError> {
        self.sample(sim);
        Ok(())
    }
    fn finish(&mut self, sim: &mut Simulator, _stop: &Stop) -> Result<(), RecordError> {
        self.sample(sim);
        Ok(())
    }
}
