//! Stage `ledger`: commits an accepted trial step to the state and books its
//! energy. Over a step of length h (trapezoidal in the segment tensions and
//! the damping velocity, exact for the motor whose tension is constant):
//!   motor work  W_m = T_cmd (L_old - L_new)              (cable reeled in)
//!   cable work  W_c = -sum_j 1/2 (T_j,old + T_j,new) (l_j,new - l_j,old)
//!   friction    W_m - W_c                                 (lost at the pulleys)
//!   damping     sum_i c 1/2 (v_i,old + v_i,new) dx_i
//!   gravity     sum_i m_i g_i dx_i
//! so that kinetic = cable + gravity - damping - latch losses (the balance
//! `Energy::balance_rel_error` checks).

use super::Simulator;

impl Simulator {
    /// Commits the trial step of length h to the state, with the energy ledger.
    pub(super) fn accept(&mut self, h: f64) {
        self.core.stats.substeps += 1;
        std::mem::swap(&mut self.core.a_prev, &mut self.core.a_prev2);
        self.core.prev_h2 = self.core.prev_h;
        self.core.a_prev.copy_from_slice(&self.state.a);
        self.core.prev_h = Some(h);
        let (m, s, c) = (&self.model, &mut self.state, &self.core);
        let e = &mut s.energy;
        for (ci, cab) in m.cables.iter().enumerate() {
            let (old, new) = (&s.cables[ci], &c.cables[ci]);
            // motor tension is the command, constant over the step: exact work
            e.motor_work_j += s.cable_tension_cmd_n[ci] * (old.length_m - new.length_m);
            let mut seg_work = 0.0;
            for j in 0..cab.path.len() - 1 {
                seg_work -= 0.5
                    * (old.segment_tension_n[j] + new.segment_tension_n[j])
                    * (new.segment_length_m[j] - old.segment_length_m[j]);
            }
            e.cable_work_j += seg_work;
            e.friction_loss_j +=
                s.cable_tension_cmd_n[ci] * (old.length_m - new.length_m) - seg_work;
        }
        let g = m.gravity_m_s2;
        for i in 0..s.x.len() {
            let dx = c.x[i] - s.x[i];
            e.damping_loss_j += m.damping_n_s_per_m * 0.5 * (s.v[i] + c.v[i]) * dx;
            e.gravity_work_j += m.mass[i] * g[i % 3] * dx;
        }
        s.t_s += h;
        s.x.copy_from_slice(&c.x);
        s.v.copy_from_slice(&c.v);
        s.a.copy_from_slice(&c.a);
        s.lambda.clone_from(&c.lambda);
        for (o, n) in s.cables.iter_mut().zip(&c.cables) {
            o.clone_from(n);
        }
        s.max_violation_m = s.max_violation_m.max(c.violation_m);
    }
}
