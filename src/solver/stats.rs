//! Counters of what the solver did: steps, sub-steps, Newmark iterations,
//! factorizations and solves, every fallback by kind, and the latch searches.
//! `simulate --json` writes them as `solver_stats`, `bench` prints them, the
//! node logs them at shutdown. A fallback is a give-up that the solver
//! survives on purpose (the step goes on by another route); a give-up that
//! would leave a wrong result is a [`crate::solver::SolverError`] instead.

use serde::Serialize;

#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, serde::Deserialize)]
pub struct SolverStats {
    /// `Simulator::step` calls completed.
    pub steps: u64,
    /// Newmark trials accepted into the state (sub-steps and the parts of a
    /// step before and after each latch).
    pub substeps: u64,
    /// Newmark steps computed (accepted or not: root-search and dip-check
    /// trials, halved sub-steps).
    pub newmark_steps: u64,
    /// Fixed-point iterations over all Newmark steps (each one constrained
    /// solve), Newton iterations included.
    pub newmark_iterations: u64,
    /// Newmark iterations that went on with Newton steps where the plain
    /// iteration stopped contracting (the friction blend, stiff springs):
    /// the method's own route, not a fallback (its failures are).
    pub newton_switches: u64,
    /// Modified Newton iterations (elastic members) that contracted slower
    /// than `newmark_refresh_rho`: their kept factorization made afresh.
    pub newmark_refreshes: u64,
    /// Newton steps (directions) of Newmark iterations switched to Newton,
    /// the GMRES iterations computing them (one constrained solve each), and
    /// the halvings of their line search.
    pub newton_steps: u64,
    pub newton_krylov_iterations: u64,
    pub newton_backtracks: u64,
    /// Numeric factorizations made, and factor requests served by a kept one.
    pub factorizations: u64,
    pub factorizations_reused: u64,
    /// Probes for redundant rows (sparse backend: a rejecting factorization of every row).
    pub probes: u64,
    /// Constrained solves (accelerations and corrections) and their iterations
    /// (conjugate gradients / Richardson; 0 for the dense backend).
    pub solves: u64,
    pub solve_iterations: u64,
    /// Numeric factorizations made inside solves (the compliant solves of
    /// elastic members factor S + D there), and solves served by a kept one.
    pub solve_factorizations: u64,
    pub solve_factorizations_reused: u64,
    pub fallbacks: Fallbacks,
    /// Latch root searches started, and the trial steps they computed.
    pub latch_searches: u64,
    pub latch_search_steps: u64,
    /// Sleeves latched (rigid, or compliant latches engaging; with elastic
    /// members also compliant latches the structure cannot move along,
    /// which latch at once as their row, L/EA + 1/k).
    pub latches: u64,
    /// Elastic members: sub-steps taken under the backward-Euler rule
    /// because they follow accelerations solved at acceleration level (a
    /// start or reset, a latch, a command change, a motor's release or
    /// engagement: `restart_substeps`).
    pub restart_backward_euler: u64,
    /// Trial sub-steps cut at a unilateral spring's contact onset or
    /// release (`contact_cut_rel`: an end stop's kink located).
    pub contact_cuts: u64,
    /// Trial sub-steps halved because their ledger missed by more than its
    /// budget (`ledger_budget_rel_per_s`: step-size control on the
    /// trapezoid's error in fast motion).
    pub ledger_halvings: u64,
    /// Compliant latches that engaged, and the sub-steps spent resolving
    /// their transients.
    pub compliant_latches: u64,
    pub transient_substeps: u64,
    /// Elastic members: compliant latches whose transient ended because
    /// the structure could no longer move along them (other latches turned
    /// rigid or latched as rows): they turned rigid as their rows at once.
    pub transients_immobile: u64,
    /// Speed-controlled motors released from their speed (tension beyond
    /// its limit or below zero, or a rigid latch), and engaged at it.
    pub motor_releases: u64,
    pub motor_engagements: u64,
    /// Engagements of a released motor refused because the tracking motors' system could not
    /// take its speed (two speeds on one motion); one is tried again at the next step, or
    /// after a motor releases or engages.
    pub motor_conflicts: u64,
}

/// Fallbacks by kind (see each field).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, serde::Deserialize)]
pub struct Fallbacks {
    /// A Newmark iteration did not converge and the sub-step was halved.
    pub substep_halvings: u64,
    /// A sub-step that needed Newton steps went through the friction's fast
    /// transient in the blend and was taken again as a backward-Euler step,
    /// which the transient leaves at rest instead of ringing
    /// (`blend_change_rel`; elastic members).
    pub blend_entry_backward_euler: u64,
    /// ... and was halved to resolve it (rigid members).
    pub blend_entry_halvings: u64,
    /// A trial sub-step made or lost energy no force accounts for
    /// (`substep_energy_rel`) and was halved.
    pub substep_energy_halvings: u64,
    /// ... at its shortest (`made_energy_min_substep_fraction`): accepted
    /// with the energy it made, which the run's balance error then shows.
    pub substep_energy_accepted: u64,
    /// A trial sub-step at the shortest length (`min_substep_fraction`)
    /// missed its ledger's budget (`ledger_budget_rel_per_s`) and was
    /// accepted: the step-size control stops there.
    pub ledger_budget_exceeded: u64,
    /// Newton steps of a Newmark iteration (`newton_switches`) whose line
    /// search gave up (`newmark_newton_line_search_max`,
    /// `newmark_newton_min_step`): the plain iteration went on from the best
    /// iterate, with its own fallbacks.
    pub newmark_newton_failed: u64,
    /// ... and were retried from the best iterate with the friction's secant
    /// slopes back to the step start (once per Newmark step).
    pub newmark_newton_secant: u64,
    /// A stalled Newmark iteration restarted with least-squares solves.
    pub newmark_min_norm: u64,
    /// A stalled Newmark iteration restarted with the friction direction of the step start.
    pub newmark_lagged_friction: u64,
    /// A stalled position projection switched to least-squares corrections.
    pub projection_min_norm: u64,
    /// A velocity projection was redone in least squares (the dropped rows' residual stood out).
    pub velocity_min_norm: u64,
    /// A least-work split (latch impulses, member forces) that the sparse
    /// backend's minimum-norm solve did not give exactly was made again by
    /// the dense SVD (`crate::solver::least_work`).
    pub least_work_dense: u64,
    /// ... and was kept inexact: the model is beyond `rank_check_max_coords`.
    pub least_work_inexact: u64,
    /// A kept factorization gave a slow or inaccurate solve and was refactored.
    pub solve_refactored: u64,
    /// A basic solve was inaccurate with a fresh factorization: redundant rows probed again.
    pub solve_reprobed: u64,
    /// A solve whose right-hand side was inconsistent was answered in least squares.
    pub solve_least_squares: u64,
    /// A solve ended at its iteration limit without meeting its tolerance
    /// (the result is used: the Newmark convergence test and the projection's
    /// |Phi| check judge what it leads to).
    pub solve_unconverged: u64,
    /// An interpolated touch of a sleeve's lock length that the step map did not confirm.
    pub dips_rejected: u64,
    /// A latch root search reached its iteration limit with the gap within
    /// the latch tolerance (beyond it, the search is an error).
    pub root_search_limit: u64,
    /// The accelerations' fixed point with cable inertia stopped at its iteration limit.
    pub consistent_unconverged: u64,
    /// A compliant latch turned rigid at `latch_max_periods` without having
    /// settled (the rigid latch took the oscillation left).
    pub latch_unsettled: u64,
    /// A compliant latch latched rigid: nothing of the structure could move
    /// along it (inverse effective mass below `latch_immobile_rel` of its
    /// free value, e.g. a sleeve redundant with members already latched, or
    /// at its shortest as the ring's radial members at the flat state), so
    /// its spring could never deflect. At once, or after the transients of
    /// latches engaging with it.
    pub latch_without_compliance: u64,
}

impl SolverStats {
    /// The fallbacks that accept a result known to be inexact, by name:
    /// solves stopped at their iteration limit, the cable inertia's fixed
    /// point stopped at its limit, sub-steps accepted although they made
    /// energy or missed their ledger's budget at the shortest length. The
    /// others
    /// (halvings, restarts, Newton switches, refactorizations, ...) change
    /// the route to a result that meets its tolerance.
    pub fn accepting_fallbacks_by_kind(&self) -> [(&'static str, u64); 5] {
        let f = &self.fallbacks;
        [
            ("unconverged solves", f.solve_unconverged),
            ("inexact least-work splits", f.least_work_inexact),
            ("unconverged inertia fixed points", f.consistent_unconverged),
            ("sub-steps making energy", f.substep_energy_accepted),
            (
                "sub-steps over their ledger's budget",
                f.ledger_budget_exceeded,
            ),
        ]
    }

    /// How many results were accepted by a fallback that knows them inexact
    /// (the sum of `accepting_fallbacks_by_kind`): 0 for a run that needed
    /// no rescue.
    pub fn accepting_fallbacks(&self) -> u64 {
        self.accepting_fallbacks_by_kind()
            .iter()
            .map(|(_, n)| n)
            .sum()
    }

    /// The counters as one line (for `bench` and the node's shutdown log).
    pub fn line(&self) -> String {
        let f = &self.fallbacks;
        format!(
            "{} steps, {} sub-steps, {} Newmark steps ({:.2} iterations each), \
             {} Newton switches, {} Newton steps ({} GMRES iterations, {} backtracks), \
             {} factorizations ({} reused, {} probes), {} solves ({:.2} iterations each; {} factored inside, {} with a kept one), \
             {} latch searches ({} trial steps), {} latches, {} restart sub-steps taken backward-Euler, {} sub-steps cut at contacts, {} halved on their ledger's budget; fallbacks: {} halvings ({} at blend entries, {} for energy, {} accepted making energy, {} over their ledger's budget at the shortest), \
             {} blend entries taken again backward-Euler, {} Newton switches failed ({} retried with secant slopes), {} Newmark min-norm, {} lagged friction, {} projection min-norm, {} velocity min-norm, \
             {} refactored, {} re-probed, {} least-squares, {} unconverged solves, \
             {} least-work splits made dense ({} inexact), \
             {} dips rejected, {} root searches at their limit, \
             {} inertia fixed points unconverged, {} latches unsettled at their limit, \
             {} compliant latches with no compliance",
            self.steps,
            self.substeps,
            self.newmark_steps,
            self.newmark_iterations as f64 / self.newmark_steps.max(1) as f64,
            self.newton_switches,
            self.newton_steps,
            self.newton_krylov_iterations,
            self.newton_backtracks,
            self.factorizations,
            self.factorizations_reused,
            self.probes,
            self.solves,
            self.solve_iterations as f64 / self.solves.max(1) as f64,
            self.solve_factorizations,
            self.solve_factorizations_reused,
            self.latch_searches,
            self.latch_search_steps,
            self.latches,
            self.restart_backward_euler,
            self.contact_cuts,
            self.ledger_halvings,
            f.substep_halvings,
            f.blend_entry_halvings,
            f.substep_energy_halvings,
            f.substep_energy_accepted,
            f.ledger_budget_exceeded,
            f.blend_entry_backward_euler,
            f.newmark_newton_failed,
            f.newmark_newton_secant,
            f.newmark_min_norm,
            f.newmark_lagged_friction,
            f.projection_min_norm,
            f.velocity_min_norm,
            f.solve_refactored,
            f.solve_reprobed,
            f.solve_least_squares,
            f.solve_unconverged,
            f.least_work_dense,
            f.least_work_inexact,
            f.dips_rejected,
            f.root_search_limit,
            f.consistent_unconverged,
            f.latch_unsettled,
            f.latch_without_compliance,
        )
    }
}
