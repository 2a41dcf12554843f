//! Stage `impact`: an element latches. Its rows join the constraint set and
//! the velocities jump to the new constraint manifold by the mass-orthogonal
//! projection (an inelastic latch): V+ = V- - M^-1 A^T mu with mu = S^+ A V-,
//! the impulses. The kinetic energy lost is 1/2 mu . (A V-) per latching row.
//! Then the mobility of the new constraint set decides whether the truss is
//! deployed.

use super::core::Core;
use super::events::gap;
use super::Simulator;
use crate::solver::linsolve::SolveMode;
use crate::solver::model::Model;
use crate::solver::settings::SolverSettings;
use crate::solver::state::LockEvent;
use crate::solver::SolverError;

impl Core {
    /// The velocity jump onto the constraint manifold of the current pattern
    /// at the trial (x, v), with every solve in `mode`: positions projected,
    /// velocities projected (A V before in `r`, the impulses in `mu`), and the
    /// accelerations after the jump (from `a_guess`). How the impulses are
    /// shared among redundant rows is the mode's: `MinNorm` splits them by
    /// least squares (simultaneous latches of redundant members are
    /// statically indeterminate otherwise).
    pub fn velocity_jump(
        &mut self,
        model: &Model,
        st: &SolverSettings,
        cmd: &[f64],
        mode: SolveMode,
    ) -> Result<(), SolverError> {
        self.project_positions(model, st, mode)?;
        self.factor(model, mode)?;
        self.project_velocities(model, st, mode)?;
        self.consistent_accelerations(model, cmd, st)
    }
}

impl Simulator {
    /// Latches every lockable element at its lock (within the latch
    /// tolerance), applies the inelastic latch to the velocities and records
    /// the events. Returns how many latched.
    pub(super) fn latch(&mut self) -> Result<usize, SolverError> {
        let (model, st) = (&self.model, &self.settings);
        let newly: Vec<usize> = model
            .locks
            .iter()
            .copied()
            .filter(|&e| {
                !self.state.locked[e] && gap(model, e, &self.state.x).abs() <= st.latch_tol_m()
            })
            .collect();
        if newly.is_empty() {
            return Ok(0);
        }
        for &e in &newly {
            self.state.locked[e] = true;
        }
        let core = &mut self.core;
        core.prev_h = None;
        core.set_pattern(model, &self.state.locked);
        core.x.copy_from_slice(&self.state.x);
        core.v.copy_from_slice(&self.state.v);
        core.a_guess.copy_from_slice(&self.state.a);
        // Least squares through the latch: the minimum-norm split of the
        // impulses, and a truss that latches into its flat deployed state has
        // rows only nearly redundant there, on which basic solves are
        // ill-conditioned.
        core.velocity_jump(
            model,
            st,
            &self.state.cable_tension_cmd_n,
            SolveMode::MinNorm,
        )?;
        // A basic factorization of the new locked set at the latched state (the
        // next step starts from it): its probe counts the rank for large models.
        core.factor(model, SolveMode::Basic)?;
        core.stats.latches += newly.len() as u64;
        let ke_before = self.state.kinetic_energy_j(model);
        let t = self.state.t_s;
        for &e in &newly {
            let b = core
                .jac
                .blocks
                .iter()
                .find(|b| b.element == e)
                .expect("latched element has a row");
            let (mu, rate) = (core.mu[b.row0], core.r[b.row0]);
            self.state.locks.push(LockEvent {
                element: e,
                name: model.elements[e].name().to_string(),
                time_s: t,
                impulse_ns: mu.abs(),
                energy_lost_j: 0.5 * mu * rate,
                closing_speed_m_s: rate,
            });
        }
        let s = &mut self.state;
        s.x.copy_from_slice(&core.x);
        s.v.copy_from_slice(&core.v);
        s.a.copy_from_slice(&core.a);
        s.lambda.clone_from(&core.lambda);
        s.max_violation_m = s.max_violation_m.max(core.violation_m);
        let ke_after = s.kinetic_energy_j(model);
        s.energy.lock_loss_j += ke_before - ke_after;
        self.state.mechanisms = self.mechanisms_now();
        // Rigid before every element latched: trusted from an SVD only (the
        // dense solver's, or one confirming a pivot rank; not past
        // `rank_check_max_coords`). Once every element has latched the truss
        // is deployed whatever the count, and the SVD (~4 % of a ring's whole
        // deployment) is skipped.
        let deployed = self.all_locked()
            || (self.state.mechanisms == 0
                && self.model.n_coords() <= self.settings.rank_check_max_coords
                && (self.core.solver.rank().is_some()
                    || crate::solver::rank::of_jacobian(&self.core.jac) == self.model.n_coords()));
        if deployed {
            self.state.deployed = true;
            self.state.deploy_time_s.get_or_insert(t);
        }
        Ok(newly.len())
    }
}
