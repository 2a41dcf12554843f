//! Every numeric policy of the stepping loop: tolerances, iteration limits and
//! the thresholds of its fallbacks, each with its default and what it means.
//! A model file may override any of them in a `[solver]` table (keys as the
//! field names below; an unknown key is rejected by name). The simulator takes
//! them from [`crate::solver::Model::solver`] and passes them explicitly to
//! each stage.

use super::linsolve::SolverKind;
use serde::{Deserialize, Serialize};

/// How to run a model: the backend (sparse by default). Every numeric
/// setting is the model's ([`crate::solver::Model::solver`], the model
/// file's `[solver]`).
#[derive(Clone, Debug, Default)]
pub struct Options {
    pub solver: SolverKind,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SolverSettings {
    // --- projection onto the constraint manifold (stage `projection`) ---
    /// Positions are projected until max |Phi| is at most this (m).
    pub projection_tol_m: f64,
    /// Newton iterations of the position projection before it gives up.
    pub projection_max_iterations: usize,
    /// A projection that ends within this multiple of `projection_tol_m` is
    /// accepted (the roundoff floor of |Phi| grows with the structure's size).
    pub projection_accept_factor: f64,
    /// A basic (redundant rows dropped) Newton iteration whose |Phi| shrinks by
    /// less than this factor switches to least-squares corrections.
    pub projection_min_contraction: f64,
    /// A position correction's linear solve may stop once its residual, the
    /// |Phi| it leaves to first order, is this fraction of `projection_tol_m`
    /// (an inexact Newton step: the projection checks every row after it).
    pub projection_solve_fraction: f64,
    /// A velocity projection's linear solve may stop once max |A V| is at
    /// most this fraction of max|A| max|V| (three orders below
    /// `velocity_redo_floor_rel`, the residual accepted on dropped rows).
    pub velocity_solve_rel: f64,
    /// Velocity projection: the residual A V on the dropped rows may exceed
    /// this multiple of that on the kept rows before the projection is redone
    /// in least squares (a rank change the probe has not seen).
    pub velocity_redo_ratio: f64,
    /// ... and only when it also exceeds this fraction of max|A| max|V|.
    pub velocity_redo_floor_rel: f64,
    /// An initial geometry whose residual exceeds this is rejected (m).
    pub initial_tol_m: f64,

    // --- Newmark integration (stage `integrator`) ---
    /// Members are elastic in the Newmark step: each member row holds
    /// Phi + c lambda = 0 (c = L / EA, the element's `axial_stiffness_n`),
    /// rows that are not members hold it with c = `rigid_row_compliance_rel`
    /// of the stiffest member's, and the step solves positions and multipliers together
    /// (index 3) instead of projecting onto the rigid constraints.
    pub elastic_members: bool,
    /// Elastic members' relaxation time tau (s): each row holds
    /// Phi + tau Phidot + c lambda = 0, a Kelvin-Voigt member whose axial
    /// vibration (far above any step's resolution) is overdamped instead of
    /// ringing undamped under the trapezoidal rule.
    pub member_relaxation_s: f64,
    /// Elastic members: the compliance of the rows that are not members
    /// (supports, hinges, coplanarity, gears' rigid parts), relative to the
    /// stiffest member's: rigid next to every
    /// member, yet S + D stays positive definite however redundant the rows.
    pub rigid_row_compliance_rel: f64,
    /// Fixed-point iterations of one Newmark step before it counts as not converged.
    pub newmark_max_iterations: usize,
    /// Elastic members: a plain Newmark iterate corrects the multipliers
    /// once from the last iterate's with the factorization of S + D made at
    /// the trial's first iterate (modified Newton, as Exudyn's), instead of
    /// solving S + D to roundoff by conjugate gradients (false). The
    /// iteration converges to the same tolerance either way.
    pub newmark_modified_newton: bool,
    /// Modified Newton: an iterate that contracts slower than this (ratio of
    /// successive changes) makes the factorization afresh for the next.
    pub newmark_refresh_rho: f64,
    /// The iteration has converged when the estimated error of the
    /// accelerations is at most this, relative to the largest acceleration ...
    pub newmark_tol_rel: f64,
    /// ... or when the position error it causes, h^2/4 |da|, is at most this (m).
    pub newmark_tol_position_m: f64,
    /// Safety factor on the contraction rate rho estimated from one ratio of
    /// successive changes: error <= safety rho / (1 - rho) |change|.
    pub newmark_rho_safety: f64,
    /// The rate estimate is used only below this rho (else error = change).
    pub newmark_rho_max: f64,
    /// A change at least this fraction of the previous (or of the best so
    /// far) counts as a stall ...
    pub newmark_stall_ratio: f64,
    /// ... and this many in a row switch to least-squares solves, then to the
    /// friction direction of the step start.
    pub newmark_stall_count: usize,
    /// A ratio of successive changes of at least this switches the iteration
    /// to Newton steps on the residual A - G(A), where G is the map of the
    /// fixed-point iteration and its derivative is taken as that of the
    /// pulley friction's blend (the one stiff term the iteration treats
    /// explicitly: below its slip speed a pulley's friction acts as a damper
    /// of mu theta T / slip_speed, ~1e3 N s/m on the double ring, against
    /// joint masses of 0.25 kg). Set it above any ratio (e.g. 1e300) to keep
    /// the plain iteration.
    pub newmark_newton_trigger: f64,
    /// Newton steps solve (I - G') d = G(A) - A by GMRES (each iteration one
    /// constrained solve; G' has the rank of the structure's free motions at
    /// most, so few are needed) until the residual is at most this fraction
    /// of the right-hand side (an inexact Newton step: G' itself leaves out
    /// the geometric terms, so the steps converge linearly, at a rate a
    /// tighter solve of (I - G') d does not improve) ...
    pub newmark_newton_krylov_tol_rel: f64,
    /// ... or for at most this many iterations.
    pub newmark_newton_krylov_max: usize,
    /// A Newton step is taken if it shrinks the kinetic norm of the residual
    /// by at least this fraction of the step taken (alpha), else ...
    pub newmark_newton_decrease: f64,
    /// ... its length along the Newton direction searched (halved, or by
    /// regula falsi on the residual's component along it once that changed
    /// sign) for at most `newmark_newton_line_search_max` trials and down to
    /// this fraction of it; beyond either the Newton steps give up and the
    /// plain iteration goes on with its fallbacks.
    pub newmark_newton_min_step: f64,
    pub newmark_newton_line_search_max: usize,
    /// Once a trial has crossed the sign change of the residual's component
    /// along the direction, a trial is accepted only where that component is
    /// at most this fraction of its value at the accepted iterate (near the
    /// crossing: a trial left on a saturated side would overshoot again).
    pub newmark_newton_curvature: f64,
    /// A sub-step that needed Newton steps and in which a pulley in the
    /// friction blend at its start or end (or on the other side at its end)
    /// changed its sliding by more than this fraction of its slip speed
    /// stepped over the friction's fast transient inside the blend (time
    /// constant m / (mu theta T / slip speed), ~1e-3 s on the double ring).
    /// The average-acceleration rule leaves such a transient ringing (the
    /// velocity along it alternates, decaying by (1 - x) / (1 + x) per step,
    /// x = h/2 times its rate, x ~ 86 for the capstan-hold test), which
    /// biases a creep (rerouted ring: motor work 2.1x its dt -> 0 value), so
    /// with elastic members the sub-step is taken again as a backward-Euler
    /// step (amplification 1 / (1 + 2x): the transient is at rest at its
    /// end), with rigid members it is halved down to `min_substep_fraction`
    /// (the transient resolved). A steady creep changes its sliding little
    /// per step and is not repeated.
    pub blend_change_rel: f64,
    /// Elastic members: this many sub-steps after accelerations were solved
    /// at acceleration level (a start or reset, a latch, a command change,
    /// a motor's release or engagement) are backward-Euler steps, the first
    /// `restart_substep_fraction` of the step long, each doubling the next:
    /// the average acceleration leaves the members' overdamped vibration
    /// (rates up to tau EA / (L m)) ringing, undamped, from such a start
    /// (docs/solver.md, Elastic members, Restarts). 0: none.
    pub restart_substeps: usize,
    /// ... the first of them this fraction of the step long.
    pub restart_substep_fraction: f64,
    /// Smallest sub-step, as a fraction of the requested step, tried before a
    /// non-converging Newmark iteration is reported.
    pub min_substep_fraction: f64,
    /// Sub-steps and latch events one step may take before it is reported.
    pub max_substeps: usize,
    /// A trial sub-step whose energy ledger misses (kinetic energy change
    /// against the work booked over it) by more than this fraction of the
    /// energy that flowed in it is halved (a counted fallback): a Newmark
    /// solution that made energy no force accounts for, as a solve that
    /// converged to a wrong motion near a singular configuration does. The
    /// trapezoid's own error is a small fraction of the flow.
    pub substep_energy_rel: f64,
    /// ... and by more than this fraction of the run's energy scale
    /// (`Energy::scale_j`), below which a miss is roundoff.
    pub substep_energy_floor_rel: f64,
    /// A trial that made energy (`substep_energy_rel`) at the shortest
    /// sub-step (`min_substep_fraction`) is halved on, down to this fraction
    /// of the requested step, while each halving at least halves its miss
    /// per second (its miss falls to a quarter);
    /// then it is accepted and counted (`substep_energy_accepted`). Near a
    /// singular configuration a Newmark solution can make energy at any
    /// length: a shorter one often does not (measured: one trial of dt/1024
    /// of a 36-sided ring made
    /// 6.3e-2 J, 3.3e-4 of its run's energy scale and nearly all of the
    /// run's balance error).
    pub made_energy_min_substep_fraction: f64,
    /// Step-size control on the trapezoid's error: a trial sub-step whose
    /// ledger misses by more than this fraction of the run's energy scale
    /// per second of its length is halved (counted as `ledger_halvings`;
    /// a sub-step that used more than a quarter of its budget is not
    /// doubled after). The scale is the larger of `Energy::scale_j` and the
    /// drive's work to the reference geometry (the motor's work of a whole
    /// deployment, known at the start). The miss of a sub-step of length h
    /// grows as h^3 and its budget as h, so each halving divides the
    /// miss per second by 4; t seconds of fast motion (a ring's final snap)
    /// add at most about this times t to the run's balance error. At the
    /// shortest sub-step (`min_substep_fraction`) a trial over its budget is
    /// accepted and counted (`ledger_budget_exceeded`). 0 turns the control
    /// off (1/s).
    pub ledger_budget_rel_per_s: f64,
    /// A trial sub-step across the contact onset or release of a unilateral
    /// spring (an end stop: `Constraint::contact_distance_m` changes sign) is
    /// cut to end this fraction of its length past the crossing (the
    /// distance interpolated linearly), so that no sub-step integrates the
    /// trapezoid across the force's kink; a crossing within this fraction
    /// of the trial's end, or a cut below the shortest sub-step, is not cut.
    pub contact_cut_rel: f64,
    /// A step is complete when less than this fraction of it remains (or
    /// less than 8 units of roundoff of its end time: late in a run its
    /// sub-steps may add up to an ulp or two short of it).
    pub step_end_rel: f64,
    /// Fixed-point iterations of the accelerations with cable inertia where a
    /// step starts from scratch (the start, a latch, a command change) ...
    pub consistent_max_iterations: usize,
    /// ... until they change by at most this, relative to the largest.
    pub consistent_tol_rel: f64,

    // --- latch events (stage `events`) ---
    /// Sleeves within this distance of their design length latch (m).
    pub lock_tol_m: f64,
    /// The latch time is refined until |gap| is at most this (m).
    pub root_tol_m: f64,
    /// Illinois iterations of the latch root search; a search that ends
    /// without |gap| <= the latch tolerance (`latch_tol_m()`) is an error.
    pub root_max_iterations: usize,
    /// The root search also stops when its bracket is this short, relative
    /// to the step.
    pub root_bracket_rel: f64,
    /// Golden-section and bisection iterations on the step's interpolant
    /// (each shrinks the interval by 0.618 or 0.5).
    pub dip_search_iterations: usize,

    // --- compliant latches (stages `impact` and `ledger`) ---
    /// Steps per latch period until an engaged compliant latch's force has
    /// peaked (the step is cut to period / this; the period is
    /// 2 pi / sqrt(sum k_i w_i) over the engaged latches, w_i the inverse
    /// effective mass along latch i). The damped peak force converges as
    /// h^2: 5.8e-4 off at 40, 1.5e-4 at 80, 5e-5 at 128 (closed-form test).
    pub latch_steps_per_period: f64,
    /// Steps per latch period after every engaged latch has peaked, while
    /// the transients settle (the energy ledger's error over the transient
    /// falls as h^2: the bundled mast's balance 1.13e-5 at 20, 8.1e-6 at 40,
    /// 7.3e-6 at 80, against 7.15e-6 with rigid latches).
    pub latch_settle_steps_per_period: f64,
    /// A compliant latch has settled, and turns rigid, once its force swung
    /// by at most this fraction of its peak over one of its periods beyond
    /// its net change there (max - min - |end - start|: its vibration has
    /// died out; a load the drive keeps raising is carried on by the rigid
    /// latch, or with elastic members by its row).
    pub latch_settle_rel: f64,
    /// A compliant latch turns rigid after at most this many of its periods,
    /// settled or not (the rigid latch takes the oscillation left).
    pub latch_max_periods: f64,
    /// A compliant latch the structure can hardly move along (its inverse
    /// effective mass w at most this fraction of its free two-joint value
    /// 1/m_a + 1/m_b, e.g. a sleeve at its shortest, such as the ring's
    /// radial sleeves at the flat state, where w is roundoff: ~1e-15) has
    /// no transient: it latches rigid, after the others' transients.
    pub latch_immobile_rel: f64,

    // --- speed-controlled motors (stage `motor`) ---
    /// The motors' k x k system is singular where a motor's mobility
    /// grad L . d falls below this fraction of its free value grad L . W q
    /// (the structure cannot move along its cable), or a pivot below this
    /// fraction of the largest diagonal (two motors move it alike): a
    /// speed command that makes it so is refused with an error naming the
    /// cables, a released motor whose engagement would stays released, and
    /// within a step the error names them.
    pub motor_pivot_rel: f64,

    // --- mobility (the rank decision itself is `crate::solver::rank`) ---
    /// Largest model (coordinates) whose mobility is counted by a dense SVD
    /// when the backend reveals no rank.
    pub rank_check_max_coords: usize,

    // --- least-work split of redundant forces (`crate::solver::least_work`) ---
    /// Compliance of the rows that are not members (supports, hinges,
    /// coplanarity), relative to the stiffest member's, in the first of the
    /// two solves whose Richardson extrapolation (eps, eps / 2) gives their
    /// rigid limit.
    pub least_work_rigid_row_eps: f64,
    /// A split on the sparse backend is exact when its joint forces A^T
    /// lambda are the given f to this (or, where f has a part off the range
    /// of A^T, those of the basic solve), relative to |A^T lambda_p| +
    /// max|A| max|lambda|; else the dense SVD redoes it.
    pub least_work_feasible_rel: f64,

    // --- natural modes (`crate::solver::modes`, `analyze --modes`) ---
    /// A mode whose omega^2 is at most this fraction of the largest
    /// eigenvalue's magnitude is a mechanism (zero frequency).
    pub modes_mechanism_rel: f64,
    /// The preload's least-work split must carry the joint forces to this
    /// (|A^T lambda - f| / |f|); beyond it the state is not an equilibrium
    /// of the locked truss and no modes are given.
    pub modes_equilibrium_rel: f64,
    // --- momentum of a free-floating model (stage `momentum`) ---
    /// A free-floating model (no support, gravity or joint damping: its
    /// linear and angular momentum are constant) has its velocities given
    /// the least change, a rigid motion, that restores both after every
    /// accepted sub-step (docs/solver.md, Momentum); false leaves the
    /// angular momentum to the integrator's truncation.
    pub momentum_projection: bool,
    /// A model is free-floating where no constraint row, every lock's
    /// included, moves under a rigid motion by more than this fraction of
    /// max|A| max|motion| at the initial positions.
    pub momentum_free_rel: f64,
}

impl Default for SolverSettings {
    fn default() -> Self {
        SolverSettings {
            projection_tol_m: 1e-12,
            projection_max_iterations: 25,
            projection_accept_factor: 1e3,
            projection_min_contraction: 0.25,
            projection_solve_fraction: 0.01,
            velocity_solve_rel: 1e-13,
            velocity_redo_ratio: 100.0,
            velocity_redo_floor_rel: 1e-10,
            initial_tol_m: 1e-6,
            elastic_members: false,
            member_relaxation_s: 0.1,
            rigid_row_compliance_rel: 1e-6,
            newmark_max_iterations: 60,
            newmark_modified_newton: true,
            newmark_refresh_rho: 0.2,
            newmark_tol_rel: 1e-12,
            newmark_tol_position_m: 1e-14,
            newmark_rho_safety: 20.0,
            newmark_rho_max: 0.1,
            newmark_stall_ratio: 0.9,
            newmark_stall_count: 4,
            newmark_newton_trigger: 0.5,
            newmark_newton_krylov_tol_rel: 1e-3,
            newmark_newton_krylov_max: 10,
            newmark_newton_decrease: 1e-4,
            newmark_newton_min_step: 1e-6,
            newmark_newton_line_search_max: 20,
            newmark_newton_curvature: 0.25,
            blend_change_rel: 0.25,
            restart_substeps: 3,
            restart_substep_fraction: 0.01,
            min_substep_fraction: 1.0 / 1024.0,
            max_substeps: 10_000,
            substep_energy_rel: 0.5,
            substep_energy_floor_rel: 1e-9,
            made_energy_min_substep_fraction: 1.0 / 65536.0,
            contact_cut_rel: 1e-3,
            ledger_budget_rel_per_s: 1e-6,
            step_end_rel: 1e-12,
            consistent_max_iterations: 20,
            consistent_tol_rel: 1e-13,
            lock_tol_m: 1e-9,
            root_tol_m: 1e-13,
            root_max_iterations: 100,
            root_bracket_rel: 1e-15,
            dip_search_iterations: 60,
            latch_steps_per_period: 128.0,
            latch_settle_steps_per_period: 40.0,
            latch_settle_rel: 1e-3,
            latch_max_periods: 50.0,
            latch_immobile_rel: 1e-9,
            motor_pivot_rel: 1e-12,
            rank_check_max_coords: 1500,
            least_work_rigid_row_eps: 1e-6,
            least_work_feasible_rel: 1e-10,
            modes_mechanism_rel: 1e-10,
            modes_equilibrium_rel: 1e-8,
            momentum_projection: true,
            momentum_free_rel: 1e-9,
        }
    }
}

impl SolverSettings {
    /// Elements within this distance of their lock at a latch event latch
    /// together (m): the latch tolerance, or ten root tolerances where the
    /// root search is asked for less accuracy than that.
    pub fn latch_tol_m(&self) -> f64 {
        self.lock_tol_m.max(10.0 * self.root_tol_m)
    }

    /// Checks that every number is usable: finite and positive tolerances,
    /// iteration limits of at least 1, fractions below 1. The message names
    /// the key.
    pub fn validate(&self) -> Result<(), SettingsError> {
        let positive = [
            ("projection_tol_m", self.projection_tol_m),
            ("member_relaxation_s", self.member_relaxation_s),
            ("projection_accept_factor", self.projection_accept_factor),
            (
                "projection_min_contraction",
                self.projection_min_contraction,
            ),
            ("projection_solve_fraction", self.projection_solve_fraction),
            ("velocity_solve_rel", self.velocity_solve_rel),
            ("velocity_redo_ratio", self.velocity_redo_ratio),
            ("velocity_redo_floor_rel", self.velocity_redo_floor_rel),
            ("initial_tol_m", self.initial_tol_m),
            ("newmark_tol_rel", self.newmark_tol_rel),
            ("newmark_tol_position_m", self.newmark_tol_position_m),
            ("newmark_rho_safety", self.newmark_rho_safety),
            ("newmark_rho_max", self.newmark_rho_max),
            ("newmark_refresh_rho", self.newmark_refresh_rho),
            ("newmark_stall_ratio", self.newmark_stall_ratio),
            ("newmark_newton_trigger", self.newmark_newton_trigger),
            (
                "newmark_newton_krylov_tol_rel",
                self.newmark_newton_krylov_tol_rel,
            ),
            ("newmark_newton_decrease", self.newmark_newton_decrease),
            ("newmark_newton_min_step", self.newmark_newton_min_step),
            ("newmark_newton_curvature", self.newmark_newton_curvature),
            ("blend_change_rel", self.blend_change_rel),
            ("restart_substep_fraction", self.restart_substep_fraction),
            ("min_substep_fraction", self.min_substep_fraction),
            ("substep_energy_rel", self.substep_energy_rel),
            ("substep_energy_floor_rel", self.substep_energy_floor_rel),
            (
                "made_energy_min_substep_fraction",
                self.made_energy_min_substep_fraction,
            ),
            ("contact_cut_rel", self.contact_cut_rel),
            ("step_end_rel", self.step_end_rel),
            ("consistent_tol_rel", self.consistent_tol_rel),
            ("lock_tol_m", self.lock_tol_m),
            ("root_tol_m", self.root_tol_m),
            ("root_bracket_rel", self.root_bracket_rel),
            ("latch_steps_per_period", self.latch_steps_per_period),
            (
                "latch_settle_steps_per_period",
                self.latch_settle_steps_per_period,
            ),
            ("latch_settle_rel", self.latch_settle_rel),
            ("latch_max_periods", self.latch_max_periods),
            ("latch_immobile_rel", self.latch_immobile_rel),
            ("rigid_row_compliance_rel", self.rigid_row_compliance_rel),
            ("motor_pivot_rel", self.motor_pivot_rel),
            ("least_work_rigid_row_eps", self.least_work_rigid_row_eps),
            ("least_work_feasible_rel", self.least_work_feasible_rel),
            ("modes_mechanism_rel", self.modes_mechanism_rel),
            ("modes_equilibrium_rel", self.modes_equilibrium_rel),
            ("momentum_free_rel", self.momentum_free_rel),
        ];
        let bad = |key, value, rule| Err(SettingsError { key, value, rule });
        for (key, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return bad(key, v, SettingsRule::Positive);
            }
        }
        if !(self.ledger_budget_rel_per_s.is_finite() && self.ledger_budget_rel_per_s >= 0.0) {
            let v = self.ledger_budget_rel_per_s;
            return bad("ledger_budget_rel_per_s", v, SettingsRule::NonNegative);
        }
        for (key, v) in [
            (
                "projection_min_contraction",
                self.projection_min_contraction,
            ),
            ("projection_solve_fraction", self.projection_solve_fraction),
            ("newmark_rho_max", self.newmark_rho_max),
            ("newmark_stall_ratio", self.newmark_stall_ratio),
            (
                "newmark_newton_krylov_tol_rel",
                self.newmark_newton_krylov_tol_rel,
            ),
            ("newmark_newton_decrease", self.newmark_newton_decrease),
            ("newmark_newton_min_step", self.newmark_newton_min_step),
            ("newmark_newton_curvature", self.newmark_newton_curvature),
            ("restart_substep_fraction", self.restart_substep_fraction),
            ("min_substep_fraction", self.min_substep_fraction),
            (
                "made_energy_min_substep_fraction",
                self.made_energy_min_substep_fraction,
            ),
            ("step_end_rel", self.step_end_rel),
            ("rigid_row_compliance_rel", self.rigid_row_compliance_rel),
            ("motor_pivot_rel", self.motor_pivot_rel),
            ("least_work_rigid_row_eps", self.least_work_rigid_row_eps),
            ("least_work_feasible_rel", self.least_work_feasible_rel),
            ("modes_mechanism_rel", self.modes_mechanism_rel),
            ("modes_equilibrium_rel", self.modes_equilibrium_rel),
            ("momentum_free_rel", self.momentum_free_rel),
        ] {
            if v >= 1.0 {
                return bad(key, v, SettingsRule::BelowOne);
            }
        }
        let counts = [
            ("projection_max_iterations", self.projection_max_iterations),
            ("newmark_max_iterations", self.newmark_max_iterations),
            ("newmark_stall_count", self.newmark_stall_count),
            ("newmark_newton_krylov_max", self.newmark_newton_krylov_max),
            (
                "newmark_newton_line_search_max",
                self.newmark_newton_line_search_max,
            ),
            ("max_substeps", self.max_substeps),
            ("consistent_max_iterations", self.consistent_max_iterations),
            ("root_max_iterations", self.root_max_iterations),
            ("dip_search_iterations", self.dip_search_iterations),
        ];
        for (key, v) in counts {
            if v == 0 {
                return bad(key, 0.0, SettingsRule::AtLeastOne);
            }
        }
        Ok(())
    }
}

/// A `[solver]` setting that breaks its rule (`SolverSettings::validate`).
#[derive(Clone, Debug, PartialEq)]
pub struct SettingsError {
    pub key: &'static str,
    pub value: f64,
    pub rule: SettingsRule,
}

/// What a `[solver]` number must be.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SettingsRule {
    Positive,
    NonNegative,
    BelowOne,
    AtLeastOne,
}

impl std::fmt::Display for SettingsError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (key, v) = (self.key, self.value);
        match self.rule {
            SettingsRule::Positive => {
                write!(f, "[solver] {key} = {v}: it must be a finite number > 0")
            }
            SettingsRule::NonNegative => write!(
                f,
                "[solver] {key} = {v}: it must be a finite number >= 0 (0: no control)"
            ),
            SettingsRule::BelowOne => write!(f, "[solver] {key} = {v}: it must be below 1"),
            SettingsRule::AtLeastOne => write!(f, "[solver] {key} = 0: it must be at least 1"),
        }
    }
}

impl std::error::Error for SettingsError {}
