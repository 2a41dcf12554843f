//! Run checks: the self-checks and bounds that decide whether a run can be
//! trusted, apart from the stepping itself. Pure functions of the model and
//! the state (no I/O): the CLI calls them before the run (degenerate models)
//! and after every step (energy balance, stall).
//!
//! Tolerances live in [`RunChecks`]; every field has a default and a doc
//! line. A model file's `[checks]` table sets `energy_balance_rel_tol`,
//! `stall_rel_motion`, `stall_time_s`, `max_steps`, `jam_error_rel`,
//! `held_short_rel_gap` and `held_short_confirm_s`; the others are fixed.

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
    /// A sleeve the latches hold short (`HeldShortWatch`): at least this
    /// fraction of the structure's size from its lock, and its length still
    /// within `stall_rel_motion` of the size after `held_short_confirm_s`.
    /// Default 1e-3.
    pub held_short_rel_gap: f64,
    /// How long (s, simulated) a held sleeve is watched before the run stops
    /// as `stalled`. Default 5 s.
    pub held_short_confirm_s: f64,
    /// How long (s, simulated) every drive cable may stick on its pulleys
    /// (`StickWatch`) without a latch before the run stops as `stalled`.
    /// Default 5 s.
    pub stick_confirm_s: f64,
    /// Results accepted inexact (`SolverStats::accepting_fallbacks`: an
    /// unconverged solve or inertia fixed point, a sub-step accepted making
    /// energy or over its ledger's budget) a run may take; the next stops it
    /// at once (stop `error`), naming how nearly dependent the constraint
    /// rows are there (`mobility::near_dependence`). Default 0.
    pub max_inexact_results: u64,
}

impl Default for RunChecks {
    fn default() -> Self {
        RunChecks {
            energy_balance_rel_tol: 1e-2,
            energy_floor_j: 1e-12,
            stall_rel_motion: 1e-7,
            stall_time_s: 1.0,
            max_steps: 2_000_000,
            max_inexact_results: 0,
            min_dt_fraction: 1e-9,
            jam_error_rel: 1e-6,
            held_short_rel_gap: 1e-3,
            held_short_confirm_s: 5.0,
            stick_confirm_s: 5.0,
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

/// "k of n sleeves unlatched, the nearest `S` g m from its lock length"
/// and, with more than one open, "the farthest `F` f m": the sleeve (the
/// bay) that lags most.
pub fn unlatched_summary(model: &Model, state: &State) -> String {
    let open: Vec<(usize, f64)> = model
        .locks
        .iter()
        .filter(|&&e| !state.locked[e])
        .map(|&e| (e, model.elements[e].lock_gap(&state.x).unwrap_or(f64::NAN)))
        .collect();
    let by_gap = |a: &&(usize, f64), b: &&(usize, f64)| a.1.abs().total_cmp(&b.1.abs());
    let (Some(&(e, g)), Some(&(f, gf))) = (open.iter().min_by(by_gap), open.iter().max_by(by_gap))
    else {
        return "every sleeve latched".into();
    };
    let farthest = if open.len() > 1 {
        format!(", the farthest `{}` {gf:.3e} m", model.elements[f].name())
    } else {
        String::new()
    };
    format!(
        "{} of {} sleeves unlatched, the nearest `{}` {g:.3e} m from its lock length{farthest}",
        open.len(),
        model.locks.len(),
        model.elements[e].name(),
    )
}

/// A truss rigid (no mechanism left) with sleeves unlatched, farther than
/// `jam_error_rel` from its reference geometry: it locked up short of
/// deployment. Without a reference, the same for its unlatched sleeves: one
/// farther from its lock length than `jam_error_rel` of the truss's size
/// (`structure_size_m`) is held short. Returns the stop
/// message; None when it is deployed (every sleeve latched, or within the
/// tolerance).
pub fn jammed(model: &Model, state: &State, checks: &RunChecks) -> Option<String> {
    if !state.deployed || model.locks.iter().all(|&e| state.locked[e]) {
        return None;
    }
    let Some(err) = state.final_error_rel(model) else {
        let size = structure_size_m(model);
        let gap = model
            .locks
            .iter()
            .filter(|&&e| !state.locked[e])
            .filter_map(|&e| model.elements[e].lock_gap(&state.x))
            .fold(0.0f64, |m, g| m.max(g.abs()));
        let rel = gap / size;
        return (rel > checks.jam_error_rel).then(|| {
            format!(
                "jammed at t = {:.6} s: rigid (no mechanism left) with a sleeve {gap:.3e} m ({rel:.3e} of its size) from its lock length (> [checks] jam_error_rel = {:e}); {}",
                state.t_s,
                checks.jam_error_rel,
                unlatched_summary(model, state)
            )
        });
    };
    (err > checks.jam_error_rel).then(|| {
        format!(
            "jammed at t = {:.6} s: rigid (no mechanism left) {err:.3e} of its size from the deployed geometry (> [checks] jam_error_rel = {:e}); {}",
            state.t_s,
            checks.jam_error_rel,
            unlatched_summary(model, state)
        )
    })
}

/// The unlatched sleeves whose length the constraints at `locked` fix at
/// `x` (to first order) at least `min_gap_m` from their lock: the gradient
/// g of the sleeve's length lies in the row space of A (its component off
/// the span of the right singular vectors of A with sigma > RANK_TOL
/// sigma_max is at most the row-sine tolerance of `rank`), so no motion
/// left to the truss moves that sleeve toward its lock. Returns (element,
/// gap m). Dense SVD of A: for the checks after a latch, not every step,
/// and only on models of at most `[solver] rank_check_max_coords`
/// coordinates (the SVD's cost grows as rows x coordinates^2: 0.11 s on the
/// 36-sided ring's 432, 32 s on the 180-sided ring's 2160); larger models
/// get no answer (an empty list).
pub fn held_short(model: &Model, x: &[f64], locked: &[bool], min_gap_m: f64) -> Vec<(usize, f64)> {
    use super::jacobian::Jacobian;
    if model.n_coords() > model.solver.rank_check_max_coords {
        return Vec::new();
    }
    let open: Vec<(usize, f64)> = model
        .locks
        .iter()
        .filter(|&&e| !locked[e])
        .filter_map(|&e| {
            let g = model.elements[e].lock_gap(x)?;
            (g.abs() >= min_gap_m).then_some((e, g))
        })
        .collect();
    if open.is_empty() {
        return Vec::new();
    }
    let mut jac = Jacobian::pattern(model, locked);
    if jac.nrows == 0 {
        return Vec::new();
    }
    jac.fill(model, x);
    let Some((sigma, _, v_t)) = super::rank::thin_svd(&jac.to_dense()) else {
        return Vec::new();
    };
    let smax = sigma.iter().cloned().fold(0.0, f64::max);
    let basis: Vec<usize> = (0..sigma.len())
        .filter(|&i| sigma[i] > super::rank::RANK_TOL * smax)
        .collect();
    let mut row = vec![0.0; 6];
    open.into_iter()
        .filter(|&(e, _)| {
            let el = &model.elements[e];
            let joints = el.joints();
            row.resize(3 * joints.len(), 0.0);
            el.jacobian(x, &mut row);
            // g = dl/dX is nonzero only on the sleeve's joints' columns (a
            // joint named twice adds up, as in the assembled Jacobian).
            let mut g: Vec<(usize, f64)> = Vec::with_capacity(row.len());
            for (col, &a) in row.iter().enumerate() {
                let c = 3 * joints[col / 3] + col % 3;
                match g.iter_mut().find(|(cc, _)| *cc == c) {
                    Some((_, v)) => *v += a,
                    None => g.push((c, a)),
                }
            }
            let norm_sq: f64 = g.iter().map(|(_, a)| a * a).sum();
            // |P g|^2 = sum over the basis of (v_i . g)^2
            let inside: f64 = basis
                .iter()
                .map(|&i| {
                    let p: f64 = g.iter().map(|&(c, a)| v_t[(i, c)] * a).sum();
                    p * p
                })
                .sum();
            norm_sq > 0.0 && super::rank::row_is_redundant((norm_sq - inside).max(0.0) / norm_sq)
        })
        .collect()
}

/// Watches for sleeves the latches hold short of their lock: after every
/// step with a latch, `held_short` names the sleeves no motion left to the
/// truss can move toward their lock (a bay that folded the wrong way, or
/// latched out of turn, so that its neighbours locked around it). A held
/// sleeve whose length then stays put (within `stall_rel_motion` of the
/// structure's size) for `held_short_confirm_s` can never latch: the run
/// has jammed, and the watch says which sleeve, where and since when.
/// (First order: at a singular configuration a sleeve can look held and
/// still move; the confirmation window lets it.)
#[derive(Clone, Debug)]
pub struct HeldShortWatch {
    min_gap_m: f64,
    still_m: f64,
    window_s: f64,
    latches: usize,
    /// (sleeve, gap when found, time found, the latch that held it)
    held: Vec<(usize, f64, f64, String)>,
}

impl HeldShortWatch {
    pub fn new(model: &Model, checks: &RunChecks) -> HeldShortWatch {
        let size = structure_size_m(model);
        HeldShortWatch {
            min_gap_m: checks.held_short_rel_gap * size,
            still_m: checks.stall_rel_motion * size,
            window_s: checks.held_short_confirm_s,
            latches: 0,
            held: Vec::new(),
        }
    }

    /// Call after each step; returns the jam message once a held sleeve has
    /// stayed put for the window.
    pub fn update(&mut self, model: &Model, state: &State) -> Option<String> {
        if state.deployed {
            return None;
        }
        let (x, still) = (&state.x, self.still_m);
        // Held sleeves that latched or moved are free again.
        self.held.retain(|&(e, g, _, _)| {
            !state.locked[e]
                && model.elements[e]
                    .lock_gap(x)
                    .is_some_and(|now| (now - g).abs() <= still)
        });
        // A latch holds once it is rigid: at its event for a rigid latch,
        // when its transient settles for a compliant one (its event came
        // earlier), so the rigid set is what is watched, not the events.
        let rigid = state.locks_engaged(model);
        if rigid != self.latches && state.mechanisms > 0 {
            self.latches = rigid;
            let by = state
                .locks
                .iter()
                .rev()
                .find(|l| state.locked[l.element])
                .map_or(String::new(), |l| {
                    format!("`{}` at t = {:.6} s", l.name, l.time_s)
                });
            for (e, g) in held_short(model, x, &state.locked, self.min_gap_m) {
                if !self.held.iter().any(|h| h.0 == e) {
                    self.held.push((e, g, state.t_s, by.clone()));
                }
            }
        }
        let (e, g, since, by) = self
            .held
            .iter()
            .find(|h| state.t_s - h.2 + 1e-12 >= self.window_s)?;
        Some(format!(
            "jammed: sleeve `{}` is held {g:.4e} m from its lock length since t = {since:.6} s, \
             when the latch of {by} left no motion of the truss that moves it (its length is \
             fixed by the latched structure: a bay folded the wrong way or latched out of turn), \
             and it has not moved since; {}",
            model.elements[*e].name(),
            unlatched_summary(model, state)
        ))
    }
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

/// Watches for drive cables that stick: every pulley with friction of every
/// cable slides slower than its slip speed, and no joint moves faster than
/// the largest slip speed. Below its slip speed a pulley's friction is the
/// regularized stick of Coulomb's law (sigma = s / s_slip, a damper of
/// mu theta T / s_slip): it holds whatever difference of tension the capstan
/// law allows across it, up to a factor e^(mu theta). A cable whose every
/// pulley sticks, with the truss at most creeping (the regularization lets it
/// slide at a fraction of s_slip where Coulomb friction would hold it still),
/// delivers no work: the drive's pull and what resists it (gears, members,
/// damping) are within the friction's holding band. The message gives the
/// friction's share of the pull; a small one means the gears hold the truss
/// (a frictionless drive creeps on there as well). Held so for
/// `stick_confirm_s` without a latch, the run has stalled. The test is on
/// velocities only (the accelerations of a stuck mode alternate from step to
/// step under the trapezoidal rule and say nothing of the motion).
#[derive(Clone, Debug)]
pub struct StickWatch {
    window_s: f64,
    since_s: Option<f64>,
    latches: usize,
}

impl StickWatch {
    pub fn new(checks: &RunChecks) -> StickWatch {
        StickWatch {
            window_s: checks.stick_confirm_s,
            since_s: None,
            latches: 0,
        }
    }

    /// Call after each step; returns the stall message once every cable has
    /// stuck for the window.
    pub fn update(&mut self, model: &Model, state: &State) -> Option<String> {
        let with_friction = || {
            model
                .cables
                .iter()
                .zip(&state.cables)
                .filter(|(c, e)| c.friction_mu > 0.0 && !e.sliding_m_s.is_empty())
        };
        let slip_max = with_friction()
            .map(|(c, _)| c.slip_speed_m_s)
            .fold(0.0f64, f64::max);
        let sliding_max = with_friction()
            .flat_map(|(_, e)| e.sliding_m_s.iter().map(|s| s.abs()))
            .fold(0.0f64, f64::max);
        let stuck =
            with_friction().all(|(c, e)| e.sliding_m_s.iter().all(|s| s.abs() < c.slip_speed_m_s));
        let vmax = state.v.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        if state.deployed
            || slip_max == 0.0
            || model.cables.len() != with_friction().count()
            || !stuck
            || !(vmax < slip_max)
            || state.locks.len() != self.latches
        {
            self.since_s = None;
            self.latches = state.locks.len();
            return None;
        }
        let since = *self.since_s.get_or_insert(state.t_s);
        if state.t_s - since + 1e-12 < self.window_s {
            return None;
        }
        // The friction's share of the pull: the pulleys hold the drop of
        // tension along the cable, (T_max - T_min) / T_max; the rest of the
        // pull the gears, members, compliant latches and damping balance. A small share means
        // the truss would stop there without friction too.
        let (t_min_n, t_max_n) = with_friction()
            .flat_map(|(_, e)| e.segment_tension_n.iter().copied())
            .fold((f64::INFINITY, 0.0f64), |(lo, hi), t| {
                (lo.min(t), hi.max(t))
            });
        let share = if t_max_n > 0.0 {
            100.0 * (t_max_n - t_min_n) / t_max_n
        } else {
            0.0
        };
        Some(format!(
            "the drive sticks: since t = {since:.3} s every pulley has slid slower than its slip \
             speed (now |s| <= {sliding_max:.1e} m/s, slip speed {slip_max:.1e} m/s) and no joint \
             moved faster than {vmax:.1e} m/s: the drive's pull is in balance with what resists \
             it, the pulleys' friction holding {share:.1} % of its tension (segments \
             {t_min_n:.3} to {t_max_n:.3} N) and the gears, members, latches and damping the rest, so the \
             truss only creeps ([checks] stick_confirm_s = {}); {}",
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
    use super::{jammed, RunChecks, StickWatch};
    use crate::model::generate::{self, MastParams};
    use crate::solver::{Options, Simulator};

    /// Rigid with sleeves unlatched is a jam only away from the deployed
    /// geometry: at the start geometry (far from it) a jam naming the open
    /// sleeves; at the deployed geometry, with every sleeve latched, or not
    /// rigid, none. With the mast's reference geometry, and without it (the
    /// unlatched sleeves' gaps then tell: every gap is 0 when deployed).
    #[test]
    fn rigid_short_of_the_deployed_geometry_is_a_jam() {
        for with_reference in [true, false] {
            let text = generate::mast(&MastParams::default()).unwrap().to_toml();
            let mut model = crate::model::parse(&text, "mast.toml").unwrap().model;
            let deployed_x = model.reference.clone().expect("the mast has a reference");
            if !with_reference {
                model.reference = None;
            }
            let sim = Simulator::new(model, Options::default()).unwrap();
            let (m, checks) = (sim.model(), RunChecks::default());
            let mut s = sim.state().clone();
            assert_eq!(jammed(m, &s, &checks), None, "not rigid");
            s.deployed = true;
            s.locked[m.locks[0]] = true;
            let msg = jammed(m, &s, &checks).expect("a jam at the start geometry");
            println!("{msg}");
            assert!(msg.starts_with("jammed at t = 0.000000 s"), "{msg}");
            let open = format!(
                "{} of {} sleeves unlatched",
                m.locks.len() - 1,
                m.locks.len()
            );
            assert!(msg.contains(&open), "{msg}");
            let measure = if with_reference {
                "from the deployed geometry"
            } else {
                "from its lock length (>"
            };
            assert!(msg.contains(measure), "{msg}");
            s.x.clone_from(&deployed_x);
            assert_eq!(jammed(m, &s, &checks), None, "at the deployed geometry");
            s.x.clone_from(&m.x0);
            for &e in &m.locks {
                s.locked[e] = true;
            }
            assert_eq!(jammed(m, &s, &checks), None, "every sleeve latched");
        }
    }

    /// A drive whose every pulley slides slower than its slip speed, with
    /// the truss creeping slower than it, stalls after `stick_confirm_s`;
    /// one pulley above its slip speed, a joint faster than it, or a latch
    /// restarts the watch.
    #[test]
    fn a_drive_stuck_on_its_pulleys_stalls_after_the_window() {
        let text = generate::mast(&MastParams::default()).unwrap().to_toml();
        let mut model = crate::model::parse(&text, "mast.toml").unwrap().model;
        for c in &mut model.cables {
            c.friction_mu = 0.02;
        }
        let sim = Simulator::new(model, Options::default()).unwrap();
        let m = sim.model();
        let checks = RunChecks::default();
        let slip = m.cables[0].slip_speed_m_s;
        assert!(
            !sim.state().cables[0].sliding_m_s.is_empty(),
            "the mast's cable has pulleys"
        );
        let stuck_at = |t_s: f64| {
            let mut s = sim.state().clone();
            s.t_s = t_s;
            for c in &mut s.cables {
                c.sliding_m_s.fill(0.3 * slip);
                // the pulleys take the tension from 10 N down to 9 N
                let last = c.segment_tension_n.len() - 1;
                for (k, t) in c.segment_tension_n.iter_mut().enumerate() {
                    *t = 10.0 - k as f64 / last as f64;
                }
            }
            s.v.fill(0.2 * slip);
            s
        };
        let mut w = StickWatch::new(&checks);
        assert_eq!(w.update(m, &stuck_at(1.0)), None);
        assert_eq!(w.update(m, &stuck_at(5.5)), None, "4.5 s stuck");
        let msg = w.update(m, &stuck_at(6.0)).expect("5 s stuck: stalled");
        assert!(
            msg.starts_with("the drive sticks: since t = 1.000 s"),
            "{msg}"
        );
        assert!(
            msg.contains("friction holding 10.0 % of its tension (segments 9.000 to 10.000 N)"),
            "{msg}"
        );
        // each of these restarts the window
        let mut sliding = stuck_at(7.0);
        sliding.cables[0].sliding_m_s[0] = 1.5 * slip;
        let mut moving = stuck_at(7.0);
        moving.v[4] = 2.0 * slip;
        let mut latched = stuck_at(7.0);
        latched.locks.push(crate::solver::state::LockEvent {
            element: m.locks[0],
            name: "latch".into(),
            time_s: 7.0,
            impulse_ns: 0.0,
            energy_lost_j: 0.0,
            closing_speed_m_s: 0.0,
            peak_force_n: None,
            time_of_peak_s: None,
            rigid_at_s: None,
        });
        for s in [sliding, moving, latched] {
            // (latches are only ever added: the later states keep them)
            let later = |t_s: f64| {
                let mut l = stuck_at(t_s);
                l.locks.clone_from(&s.locks);
                l
            };
            let mut w = StickWatch::new(&checks);
            assert_eq!(w.update(m, &stuck_at(0.0)), None);
            assert_eq!(w.update(m, &s), None);
            assert_eq!(w.update(m, &later(11.0)), None, "restarted at t = 11 s");
            assert!(w.update(m, &later(16.0)).is_some());
        }
    }
}
