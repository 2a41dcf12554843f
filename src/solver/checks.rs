//! Run checks: the self-checks and bounds that decide whether a run can be
//! trusted, apart from the stepping itself. Pure functions of the model and
//! the state (no I/O): the CLI calls them before the run (degenerate models)
//! and after every step (energy balance, stall).
//!
//! Tolerances live in [`RunChecks`]; every field has a default and a doc
//! line. A model file's `[checks]` table sets `energy_balance_rel_tol`,
//! `stall_rel_motion`, `stall_time_s` and `max_steps`; the others are fixed.

use super::cable;
use super::model::Model;
use super::state::State;

/// Tolerances and budgets of a run (defaults in `Default`).
#[derive(Clone, Debug, PartialEq)]
pub struct RunChecks {
    /// Largest relative energy balance error |K - (W_in - losses)| / max(|W_motor|,
    /// |W_gravity|, K) a run may show; past it the run stops with an error
    /// (the motion is not the one of the model's forces). Default 1e-2.
    pub energy_balance_rel_tol: f64,
    /// Energies below this (J) are roundoff: the balance is not checked while
    /// the largest energy that flowed is below it. Default 1e-12 J.
    pub energy_floor_j: f64,
    /// A truss is at rest when no joint would move more than this fraction of
    /// the structure's size within `stall_time_s` at its current velocity and
    /// acceleration. Default 1e-7.
    pub stall_rel_motion: f64,
    /// How long (s, simulated) the truss must stay at rest before the run
    /// stops as `stalled`. Default 1 s.
    pub stall_time_s: f64,
    /// Most steps one run may take (the number of steps of `--until / --dt`
    /// is checked before the run). Default 2,000,000.
    pub max_steps: u64,
    /// Smallest time step as a fraction of the run's length. Default 1e-9.
    pub min_dt_fraction: f64,
    /// A truss that turns rigid with sleeves unlatched has deployed only
    /// within this distance of its reference geometry (`final_error_rel`);
    /// farther, it jammed short of deployment (stop `stalled`). Default 1e-6.
    pub jam_error_rel: f64,
}

impl Default for RunChecks {
    fn default() -> Self {
        RunChecks {
            energy_balance_rel_tol: 1e-2,
            energy_floor_j: 1e-12,
            stall_rel_motion: 1e-7,
            stall_time_s: 1.0,
            max_steps: 2_000_000,
            min_dt_fraction: 1e-9,
            jam_error_rel: 1e-6,
        }
    }
}

/// The size of the structure (m) that motion is measured against: the largest
/// extent of the reference geometry, else of the initial geometry, never 0.
pub fn structure_size_m(model: &Model) -> f64 {
    let extent = |x: &[f64]| {
        (0..3)
            .map(|axis| {
                let (lo, hi) = x
                    .iter()
                    .skip(axis)
                    .step_by(3)
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                        (lo.min(*v), hi.max(*v))
                    });
                hi - lo
            })
            .fold(0.0, f64::max)
    };
    let size = model
        .reference_size_m()
        .unwrap_or(0.0)
        .max(extent(&model.x0));
    if size > 0.0 {
        size
    } else {
        1.0
    }
}

/// The applied forces at rest, Q = cable segment forces + m g (N), at the
/// state's positions and cable readings.
fn applied_at_rest(model: &Model, state: &State, q: &mut [f64]) {
    q.fill(0.0);
    for (c, eval) in model.cables.iter().zip(&state.cables) {
        cable::add_forces(c, eval, &state.x, q);
    }
    for (i, qi) in q.iter_mut().enumerate() {
        *qi += model.mass[i] * model.gravity_m_s2[i % 3];
    }
}

/// Why a model cannot deploy, found at its initial state (the state the
/// simulator starts from: at rest, accelerations consistent with the drive).
/// `None` when nothing is wrong, or the model starts deployed.
///
/// - no sleeve at all: nothing ever latches, so the run never deploys;
/// - no mechanism (3n - rank A = 0) while sleeves are unlatched: the truss is
///   rigid at its initial geometry, nothing moves;
/// - no drive: no cable tension and no gravity;
/// - the drive has no component along the mechanisms: the constrained
///   accelerations A_c = M^-1 (Q + A^T lambda) (the applied forces Q projected on
///   the free motions) are below 1e-9 of the unconstrained ones M^-1 Q (a dead
///   point: collinear scissor rods, a cable along a rigid direction).
pub fn cannot_deploy(model: &Model, state: &State) -> Option<String> {
    if state.deployed {
        return None;
    }
    if model.locks.is_empty() {
        return Some(
            "the model has no sleeve (no lock_length_m), so it never latches and never deploys"
                .into(),
        );
    }
    let unlatched = unlatched_summary(model, state);
    if state.mechanisms == 0 {
        return Some(format!(
            "the truss has no mechanism at its initial geometry (3n - rank A = 0): \
             nothing can move, so no sleeve reaches its lock length ({unlatched})"
        ));
    }
    let mut q = vec![0.0; model.n_coords()];
    applied_at_rest(model, state, &mut q);
    let free = q
        .iter()
        .zip(&model.inv_mass)
        .fold(0.0f64, |m, (f, w)| m.max((f * w).abs()));
    if free == 0.0 {
        return Some(format!(
            "nothing drives the truss: no cable pulls (tension_n = 0 or no [[cable]]) and \
             gravity is zero ({unlatched})"
        ));
    }
    let constrained = state.a.iter().fold(0.0f64, |m, a| m.max(a.abs()));
    if !(constrained > 1e-9 * free) {
        return Some(format!(
            "the drive has no component along the truss's {} mechanism(s) at its initial \
             geometry: the constrained accelerations are {constrained:.3e} m/s^2 against \
             {free:.3e} m/s^2 unconstrained (a dead point, e.g. collinear scissor rods or a \
             cable pulling along a rigid direction), so nothing moves ({unlatched})",
            state.mechanisms
        ));
    }
    None
}

/// "k of n sleeves unlatched, nearest `S` (gap g m)".
pub fn unlatched_summary(model: &Model, state: &State) -> String {
    let open: Vec<(usize, f64)> = model
        .locks
        .iter()
        .filter(|&&e| !state.locked[e])
        .map(|&e| (e, model.elements[e].lock_gap(&state.x).unwrap_or(f64::NAN)))
        .collect();
    match open.iter().min_by(|a, b| a.1.abs().total_cmp(&b.1.abs())) {
        None => "every sleeve latched".into(),
        Some(&(e, g)) => format!(
            "{} of {} sleeves unlatched, the nearest `{}` {:.3e} m from its lock length",
            open.len(),
            model.locks.len(),
            model.elements[e].name(),
            g
        ),
    }
}

/// A truss rigid (no mechanism left) with sleeves unlatched, farther than
/// `jam_error_rel` from its reference geometry: it locked up short of
/// deployment. Returns the stop message; None when it is deployed (every
/// sleeve latched, or within the tolerance) or has no reference to tell.
pub fn jammed(model: &Model, state: &State, checks: &RunChecks) -> Option<String> {
    if !state.deployed || model.locks.iter().all(|&e| state.locked[e]) {
        return None;
    }
    let err = state.final_error_rel(model)?;
    (err > checks.jam_error_rel).then(|| {
        format!(
            "jammed at t = {:.6} s: rigid (no mechanism left) {err:.3e} of its size from the deployed geometry (> [checks] jam_error_rel = {:e}); {}",
            state.t_s,
            checks.jam_error_rel,
            unlatched_summary(model, state)
        )
    })
}

/// Watches for a truss at rest that no drive moves: after every step, the
/// motion a joint would make within `stall_time_s` from the current velocity
/// and acceleration, d = |v|_max T + |a|_max T^2 / 2, is compared with
/// `stall_rel_motion` times the structure's size. The constrained acceleration
/// is the applied force projected on the free mechanisms (mass-weighted), so a
/// truss with d below the limit is at rest and its drive has no component
/// along any motion left to it. Once that has held for `stall_time_s` of
/// simulated time without a latch, the run has stalled.
#[derive(Clone, Debug)]
pub struct StallWatch {
    limit_m: f64,
    window_s: f64,
    rest_since_s: Option<f64>,
    latches: usize,
}

impl StallWatch {
    pub fn new(model: &Model, checks: &RunChecks) -> StallWatch {
        StallWatch {
            limit_m: checks.stall_rel_motion * structure_size_m(model),
            window_s: checks.stall_time_s,
            rest_since_s: None,
            latches: 0,
        }
    }

    /// Call after each step; returns the stall message once the truss has been
    /// at rest for the window.
    pub fn update(&mut self, model: &Model, state: &State) -> Option<String> {
        if state.deployed {
            return None;
        }
        let t = self.window_s;
        let vmax = state.v.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let amax = state.a.iter().fold(0.0f64, |m, a| m.max(a.abs()));
        let reach_m = vmax * t + 0.5 * amax * t * t;
        if reach_m > self.limit_m || state.locks.len() != self.latches || !reach_m.is_finite() {
            self.rest_since_s = None;
            self.latches = state.locks.len();
            return None;
        }
        let since = *self.rest_since_s.get_or_insert(state.t_s);
        if state.t_s - since + 1e-12 < self.window_s {
            return None;
        }
        Some(format!(
            "the truss has been at rest since t = {since:.3} s (no joint would move {:.1e} m \
             in {} s: |v| <= {vmax:.1e} m/s, |a| <= {amax:.1e} m/s^2): the applied forces \
             have no resultant along any motion left to it, so nothing moves it further; {}",
            self.limit_m,
            self.window_s,
            unlatched_summary(model, state)
        ))
    }
}

/// The energy balance check after a step: `Some(message)` when the relative
/// balance error exceeds `energy_balance_rel_tol` (or is not a number) while
/// the energy that flowed exceeds `energy_floor_j`.
pub fn energy_unbalanced(model: &Model, state: &State, checks: &RunChecks) -> Option<String> {
    let ke = state.kinetic_energy_j(model);
    let e = &state.energy;
    let scale = e
        .motor_work_j
        .abs()
        .max(e.gravity_work_j.abs())
        .max(ke)
        .max(e.element_spring_energy_j.abs());
    let err = e.balance_rel_error(ke);
    if err <= checks.energy_balance_rel_tol || (scale <= checks.energy_floor_j && err.is_finite()) {
        return None;
    }
    Some(format!(
        "the energy balance is off by {err:.3e} of the energy that flowed (tolerance \
         {:e}, [checks] energy_balance_rel_tol): kinetic {ke:.6e} J + elastic {:.6e} J \
         against cable work {:.6e} J + gravity work {:.6e} J - damping {:.6e} J - latches \
         {:.6e} J (motor {:.6e} J, friction {:.6e} J); the computed motion is not the one \
         of the model's forces, try a smaller --dt",
        checks.energy_balance_rel_tol,
        e.latch_spring_energy_j + e.element_spring_energy_j,
        e.cable_work_j,
        e.gravity_work_j,
        e.damping_loss_j,
        e.lock_loss_j + e.latch_damping_loss_j,
        e.motor_work_j,
        e.friction_loss_j
    ))
}

#[cfg(test)]
mod tests {
    use super::{jammed, RunChecks};
    use crate::model::generate::{self, MastParams};
    use crate::solver::{Options, Simulator};

    /// Rigid with sleeves unlatched is a jam only away from the reference:
    /// at the start geometry (far from it) a jam naming the nearest open
    /// sleeve; at the reference, with every sleeve latched, or not rigid,
    /// none.
    #[test]
    fn rigid_short_of_the_reference_is_a_jam() {
        let text = generate::mast(&MastParams::default()).unwrap().to_toml();
        let model = crate::model::parse(&text, "mast.toml").unwrap().model;
        let sim = Simulator::new(model, Options::default()).unwrap();
        let (m, checks) = (sim.model(), RunChecks::default());
        let mut s = sim.state().clone();
        assert_eq!(jammed(m, &s, &checks), None, "not rigid");
        s.deployed = true;
        s.locked[m.locks[0]] = true;
        let msg = jammed(m, &s, &checks).expect("a jam at the start geometry");
        println!("{msg}");
        assert!(msg.starts_with("jammed at t = 0.000000 s"), "{msg}");
        assert!(
            msg.contains(&format!(
                "{} of {} sleeves unlatched",
                m.locks.len() - 1,
                m.locks.len()
            )),
            "{msg}"
        );
        s.x.clone_from(m.reference.as_ref().unwrap());
        assert_eq!(jammed(m, &s, &checks), None, "at the reference");
        s.x.clone_from(&m.x0);
        for &e in &m.locks {
            s.locked[e] = true;
        }
        assert_eq!(jammed(m, &s, &checks), None, "every sleeve latched");
    }
}
