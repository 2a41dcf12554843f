//! Stage `ledger`: commits an accepted trial step to the state and books its energy
//! (docs/solver.md, Energy ledger). Over a step of length h, by the trapezoid:
//!   motor work  W_m = 1/2 (T_old + T_new) (L_old - L_new)  (cable reeled in)
//!   cable work  W_c = -sum_j 1/2 (T_j,old + T_j,new) (l_j,new - l_j,old)
//!   friction    W_m - W_c                                 (lost at the pulleys)
//!   damping     sum_i c 1/2 (v_i,old + v_i,new) dx_i
//!   gravity     sum_i m_i g_i dx_i
//!   latch damper  sum_latches c 1/2 (ldot_old + ldot_new) dl,  spring 1/2 k g^2
//!   compliant elements  damper c 1/2 (rate_old + rate_new) . dPhi, spring 1/2 k |Phi|^2
//!   backward-Euler steps  (h/2) (A_new - A_old)^T M Vbar  (`integrator_work_j`)
//! so that kinetic + latch spring = cable + gravity + backward-Euler term - damping - latch losses
//! (checked by `Energy::balance_rel_error`). The trapezoid is exactly what the average-acceleration
//! rule does to the kinetic energy: Vbar^T M dV = Abar^T M dX (Abar, Vbar the step's means).

use super::core::{Core, StepRule};
use super::sim::Simulator;
use crate::solver::cable::CableEval;
use crate::solver::model::Model;
use crate::solver::springs::track_transient;
use crate::solver::state::{kinetic_energy_j, Energy, State};

impl Simulator {
    /// Commits the trial step of length h to the state, with the energy ledger.
    pub(super) fn accept(&mut self, h: f64, rule: StepRule) {
        self.core.stats.substeps += 1;
        // the sub-step after a restart's backward-Euler ones judges a blend entry from the
        // restart's sliding (`friction_blend_entered`): the state's before the first of them
        let (core, carry) = (&mut self.core, &mut self.state.carry);
        let restart_be = rule == StepRule::BackwardEuler && carry.restart_substeps_left > 0;
        if restart_be {
            carry.restart_substeps_left -= 1;
            core.stats.restart_backward_euler += 1;
            if !carry.blend_start_held {
                for (dst, src) in carry.blend_start.iter_mut().zip(&self.state.cables) {
                    dst.copy_from_slice(&src.sliding_m_s);
                }
            }
        }
        carry.blend_start_held = restart_be;
        carry.accel_history.push(&self.state.a, h);
        let (elastic_j, damper_j) = core.element_springs.book_move(
            &self.model,
            (&self.state.x, &self.state.v),
            (&core.x, &core.v),
        );
        let integrator_j = integrator_work_j(&self.model, &self.state, &self.core, (h, rule));
        let (m, s, c) = (&self.model, &mut self.state, &self.core);
        let e = &mut s.energy;
        e.integrator_work_j += integrator_j;
        book_drive_work(m, e, &s.cables, &c.cables, &s.x, &c.x);
        e.damping_loss_j += damping_loss_j(m, (&s.x, &s.v), (&c.x, &c.v));
        e.element_spring_energy_j += elastic_j;
        e.damping_loss_j += damper_j;
        if self.settings.elastic_members {
            // members' trapezoid work on the joints less their strain energy's gain: dampers' loss
            let work_j = member_work_j(&s.x, &c.x, &s.carry.member_force_n, &c.member_force_trial);
            e.member_damping_loss_j += -work_j - (c.strain_trial_j - e.member_strain_energy_j);
            e.member_strain_energy_j = c.strain_trial_j;
        }
        // Compliant latches: damper work c ldot dl by the trapezoid, spring energy 1/2 k g^2
        // exact; per latch, its force impulse (trapezoid of T) and dissipation.
        e.latch_spring_energy_j = 0.0;
        for tr in &mut s.transients {
            let Some(mv) = transient_move(m, tr, (&s.x, &s.v), (&c.x, &c.v)) else {
                continue;
            };
            let (k, cd) = (tr.stiffness_n_per_m, tr.damping_n_s_per_m);
            e.latch_damping_loss_j += mv.dissipated_j;
            tr.dissipated_j += mv.dissipated_j;
            tr.impulse_ns += 0.5 * h * (tr.force_n + k * mv.gap_m.1 + cd * mv.rate_m_s);
            e.latch_spring_energy_j += 0.5 * k * mv.gap_m.1 * mv.gap_m.1;
        }
        // Tracking motors: the length they hold moves on with the sub-step.
        for (mo, speed) in s.motors.iter_mut().zip(&c.motor.speed_m_s) {
            if let Some(speed) = speed {
                mo.length_ref_m -= speed * h;
            }
        }
        let t0 = s.t_s;
        s.t_s += h;
        c.commit_trial(s);
        if self.settings.elastic_members {
            std::mem::swap(
                &mut s.carry.member_force_n,
                &mut self.core.member_force_trial,
            );
        }
        let settle_rel = self.settings.latch_settle_rel;
        for tr in &mut s.transients {
            let ev = &mut s.locks[tr.event];
            track_transient(m, tr, ev, t0, h, (&s.x, &s.v), settle_rel);
        }
        self.track_latch_rows();
    }

    /// The ledger of the trial step in the core before acceptance (`TrialEnergy`, J). Its net work:
    /// drive and gravity, joint damping, compliant elements' springs and dampers, not compliant
    /// latches' transients. A sound step leaves a residual of the trapezoid's error, a small
    /// fraction of the flow; a Newmark solution that made energy (a solve converged to a wrong
    /// motion near a singular configuration) does not.
    pub(super) fn trial_energy_residual_j(&mut self, h: f64, rule: StepRule) -> TrialEnergy {
        let integrator_j = integrator_work_j(&self.model, &self.state, &self.core, (h, rule));
        let (m, s) = (&self.model, &self.state);
        let c = &mut self.core;
        let (elastic_j, damper_j) = c.element_springs.book_move(m, (&s.x, &s.v), (&c.x, &c.v));
        let mut scratch = Energy::default();
        let work_j = book_drive_work(m, &mut scratch, &s.cables, &c.cables, &s.x, &c.x);
        let damping_j = damping_loss_j(m, (&s.x, &s.v), (&c.x, &c.v));
        let (kinetic_before_j, kinetic_trial_j) =
            (kinetic_energy_j(m, &s.v), kinetic_energy_j(m, &c.v));
        let d_kinetic_j = kinetic_trial_j - kinetic_before_j;
        // elastic members: their strain energy's change and what the velocity projection took
        let member_j = if self.settings.elastic_members {
            member_work_j(&s.x, &c.x, &s.carry.member_force_n, &c.member_force_trial)
        } else {
            0.0
        };
        let latch_j = transients_took_j(m, s, (&c.x, &c.v));
        TrialEnergy {
            residual_j: d_kinetic_j
                - (work_j - damping_j - elastic_j - damper_j + member_j + integrator_j - latch_j),
            flow_j: d_kinetic_j.abs()
                + integrator_j.abs()
                + work_j.abs()
                + damping_j.abs()
                + elastic_j.abs()
                + damper_j.abs()
                + member_j.abs()
                + latch_j.abs()
                + scratch.friction_loss_j.abs(),
            kinetic_before_j,
            kinetic_trial_j,
        }
    }
}

/// What the compliant latches' transients took over the move from the state to
/// (x, v), J, as `accept` books it: damper c 1/2 (ldot_0 + ldot_1) dl and the
/// spring's gain 1/2 k (g_1^2 - g_0^2).
fn transients_took_j(m: &Model, s: &State, (x, v): (&[f64], &[f64])) -> f64 {
    s.transients
        .iter()
        .filter_map(|tr| {
            let mv = transient_move(m, tr, (&s.x, &s.v), (x, v))?;
            let (g0, g1) = mv.gap_m;
            Some(mv.dissipated_j + 0.5 * tr.stiffness_n_per_m * (g1 * g1 - g0 * g0))
        })
        .sum()
}

/// A compliant latch over a move from (x0, v0) to (x1, v1).
struct TransientMove {
    /// Its damper's work by the trapezoid, c 1/2 (ldot_0 + ldot_1) dl (J).
    dissipated_j: f64,
    /// Its gap before and after (m), and its rate after (m/s).
    gap_m: (f64, f64),
    rate_m_s: f64,
}

fn transient_move(
    m: &Model,
    tr: &crate::solver::state::LatchTransient,
    (x0, v0): (&[f64], &[f64]),
    (x1, v1): (&[f64], &[f64]),
) -> Option<TransientMove> {
    let elem = &m.elements[tr.element];
    let ((l0, r0), (l1, r1)) = (elem.extension(x0, v0)?, elem.extension(x1, v1)?);
    Some(TransientMove {
        dissipated_j: tr.damping_n_s_per_m * 0.5 * (r0 + r1) * (l1 - l0),
        gap_m: (elem.lock_gap(x0)?, elem.lock_gap(x1)?),
        rate_m_s: r1,
    })
}

/// The kinetic energy (J) a backward-Euler trial step (`Core::backward_euler`; dV = h A_new,
/// dX = h V_old + h^2/2 A_new) gains beyond the forces' trapezoid work: Vbar^T M h A_new =
/// Abar^T M dX + (h/2) (A_new - A_old)^T M Vbar, its last term, booked from this formula and not
/// as what is left of the balance, which stays a check (docs/solver.md, Backward-Euler steps).
/// 0 for the average acceleration's step.
fn integrator_work_j(m: &Model, s: &State, c: &Core, (h, rule): (f64, StepRule)) -> f64 {
    if rule != StepRule::BackwardEuler {
        return 0.0;
    }
    (0..s.v.len())
        .map(|i| 0.25 * h * m.mass[i] * (c.a[i] - s.a[i]) * (s.v[i] + c.v[i]))
        .sum()
}

/// A trial sub-step's ledger (`Simulator::trial_energy_residual_j`), J.
pub(super) struct TrialEnergy {
    /// The change of kinetic energy less the net work booked over the trial.
    pub residual_j: f64,
    /// The sum of the magnitudes of the ledger's terms over it.
    pub flow_j: f64,
    pub kinetic_before_j: f64,
    pub kinetic_trial_j: f64,
}

/// Elastic members' work on the joints over a move (J), by the trapezoid
/// in their joint forces f = A^T lambda: 1/2 (f_old + f_new) . dx.
fn member_work_j(x0: &[f64], x1: &[f64], f0: &[f64], f1: &[f64]) -> f64 {
    (0..x0.len())
        .map(|i| 0.5 * (f0[i] + f1[i]) * (x1[i] - x0[i]))
        .sum()
}

/// The joint damping's work over a move (J), by the trapezoid (module doc).
fn damping_loss_j(m: &Model, (x0, v0): (&[f64], &[f64]), (x1, v1): (&[f64], &[f64])) -> f64 {
    (0..x0.len())
        .map(|i| m.damping_n_s_per_m * 0.5 * (v0[i] + v1[i]) * (x1[i] - x0[i]))
        .sum()
}

/// Books the drive's and gravity's work over a move of the joints from `x_old` to `x_new` (cable
/// readings `old`, `new` at its ends) into the ledger (module doc's terms), and returns it (J).
/// The motor's trapezoid is exact for a commanded tension, constant over a step, not for a
/// speed-controlled motor's.
pub(super) fn book_drive_work(
    m: &Model,
    e: &mut Energy,
    old: &[CableEval],
    new: &[CableEval],
    x_old: &[f64],
    x_new: &[f64],
) -> f64 {
    let mut work_j = 0.0;
    for (ci, cab) in m.cables.iter().enumerate() {
        let (old, new) = (&old[ci], &new[ci]);
        let motor_j = 0.5
            * (old.segment_tension_n[0] + new.segment_tension_n[0])
            * (old.length_m - new.length_m);
        e.motor_work_j += motor_j;
        let mut seg_work = 0.0;
        for j in 0..cab.path.len() - 1 {
            seg_work -= 0.5
                * (old.segment_tension_n[j] + new.segment_tension_n[j])
                * (new.segment_length_m[j] - old.segment_length_m[j]);
        }
        e.cable_work_j += seg_work;
        e.friction_loss_j += motor_j - seg_work;
        work_j += seg_work;
    }
    let g = m.gravity_m_s2;
    for i in 0..x_old.len() {
        let w = m.mass[i] * g[i % 3] * (x_new[i] - x_old[i]);
        e.gravity_work_j += w;
        work_j += w;
    }
    work_j
}
