//! Stage `ledger`: commits an accepted trial step to the state and books its
//! energy. Over a step of length h (trapezoidal in the segment tensions and
//! the damping velocity, exact for the motor whose tension is constant):
//!   motor work  W_m = T_cmd (L_old - L_new)              (cable reeled in)
//!   cable work  W_c = -sum_j 1/2 (T_j,old + T_j,new) (l_j,new - l_j,old)
//!   friction    W_m - W_c                                 (lost at the pulleys)
//!   damping     sum_i c 1/2 (v_i,old + v_i,new) dx_i
//!   gravity     sum_i m_i g_i dx_i
//!   latch damper  sum_latches c 1/2 (ldot_old + ldot_new) dl,  spring 1/2 k g^2
//!   compliant elements  damper c 1/2 (rate_old + rate_new) . dPhi, spring 1/2 k |Phi|^2
//! so that kinetic + latch spring = cable + gravity - damping - latch losses
//! (the balance `Energy::balance_rel_error` checks).

use super::impact::track_transient;
use super::Simulator;
use crate::solver::cable::CableEval;
use crate::solver::model::Model;
use crate::solver::state::Energy;

impl Simulator {
    /// Commits the trial step of length h to the state, with the energy ledger.
    pub(super) fn accept(&mut self, h: f64) {
        self.core.stats.substeps += 1;
        std::mem::swap(&mut self.core.a_prev, &mut self.core.a_prev2);
        self.core.prev_h2 = self.core.prev_h;
        self.core.a_prev.copy_from_slice(&self.state.a);
        self.core.prev_h = Some(h);
        let core = &mut self.core;
        let (elastic_j, damper_j) = core.element_springs.book_move(
            &self.model,
            (&self.state.x, &self.state.v),
            (&core.x, &core.v),
        );
        let (m, s, c) = (&self.model, &mut self.state, &self.core);
        let e = &mut s.energy;
        book_drive_work(
            m,
            e,
            &s.cable_tension_cmd_n,
            &s.cables,
            &c.cables,
            &s.x,
            &c.x,
        );
        for i in 0..s.x.len() {
            let dx = c.x[i] - s.x[i];
            e.damping_loss_j += m.damping_n_s_per_m * 0.5 * (s.v[i] + c.v[i]) * dx;
        }
        e.element_spring_energy_j += elastic_j;
        e.damping_loss_j += damper_j;
        // Compliant latches: the damper's work c ldot dl by the trapezoid, as
        // the joint damping above; the spring's energy 1/2 k g^2 is exact.
        // Per latch, its force impulse (trapezoid of T) and dissipation.
        e.latch_spring_energy_j = 0.0;
        for tr in &mut s.transients {
            let elem = &m.elements[tr.element];
            let (Some((l0, r0)), Some((l1, r1)), Some(g1)) = (
                elem.extension(&s.x, &s.v),
                elem.extension(&c.x, &c.v),
                elem.lock_gap(&c.x),
            ) else {
                continue;
            };
            let (k, cd) = (tr.stiffness_n_per_m, tr.damping_n_s_per_m);
            let dissipated = cd * 0.5 * (r0 + r1) * (l1 - l0);
            e.latch_damping_loss_j += dissipated;
            tr.dissipated_j += dissipated;
            tr.impulse_ns += 0.5 * h * (tr.force_n + k * g1 + cd * r1);
            e.latch_spring_energy_j += 0.5 * k * g1 * g1;
        }
        let t0 = s.t_s;
        s.t_s += h;
        c.commit_trial(s);
        let settle_rel = self.settings.latch_settle_rel;
        for tr in &mut s.transients {
            let ev = &mut s.locks[tr.event];
            track_transient(m, tr, ev, t0, h, (&s.x, &s.v, &s.a), settle_rel);
        }
    }
}

/// Books the work of the drive and of gravity over a move of the joints from
/// `x_old` to `x_new` (cable readings `old` and `new` at its ends) into the
/// ledger, and returns it (J): motor work (the command is constant over a
/// step: exact), the segments' work on the structure by the trapezoid, the
/// pulley friction as their difference, and gravity's work.
pub(super) fn book_drive_work(
    m: &Model,
    e: &mut Energy,
    cmd: &[f64],
    old: &[CableEval],
    new: &[CableEval],
    x_old: &[f64],
    x_new: &[f64],
) -> f64 {
    let mut work_j = 0.0;
    for (ci, cab) in m.cables.iter().enumerate() {
        let (old, new) = (&old[ci], &new[ci]);
        let motor_j = cmd[ci] * (old.length_m - new.length_m);
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
