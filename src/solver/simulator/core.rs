//! The work state of a step: buffers reused across steps, the Jacobian and
//! the backend's factorization, the trial state, and the counters. Every
//! factorization and solve of the stepping loop goes through `factor`,
//! `solve_accelerations` and `correction`, which book the backend's reports.

use super::work::{MotorWork, NewtonWork};
use crate::solver::cable::CableEval;
use crate::solver::jacobian::Jacobian;
use crate::solver::least_work::LeastWork;
use crate::solver::linsolve::SolverKind;
use crate::solver::linsolve::{ConstraintSolver, FactorReport, SolveMode, SolveReport};
use crate::solver::model::Model;
use crate::solver::springs::StepGains;
use crate::solver::state::State;
use crate::solver::stats::SolverStats;
use crate::solver::SolverError;

/// D of a member row whose force a solve at acceleration level takes from
/// the state, relative to its step value c / beta (large: S is ~1/c smaller).
pub(super) const MEMBER_PIN: f64 = 1e12;

/// Buffers and the factorization, reused across steps.
pub(super) struct Core {
    pub jac: Jacobian,
    pub solver: Box<dyn ConstraintSolver>,
    pub q: Vec<f64>,
    pub c: Vec<f64>,
    pub r: Vec<f64>,
    pub dx: Vec<f64>,
    pub mu: Vec<f64>,
    // trial state of the step being computed
    pub x: Vec<f64>,
    pub v: Vec<f64>,
    pub a: Vec<f64>,
    pub a_guess: Vec<f64>,
    pub lambda: Vec<f64>,
    pub cables: Vec<CableEval>,
    pub violation_m: f64,
    /// A Newmark trial's inverse masses 1 / (m + gamma h c) (its damping
    /// implicit, `Pose::implicit_damping`) and V* = V_n + (1 - gamma) h A_n.
    pub inv_mass_eff: Vec<f64>,
    pub v_star: Vec<f64>,
    /// Per cable, the pulley sliding speeds at the trial's start (the lagged
    /// friction directions, `Pose::lagged_friction`, and the blend's start).
    pub friction_sliding: Vec<Vec<f64>>,
    /// Buffers of the Newton steps of the Newmark iteration.
    pub newton: NewtonWork,
    /// The trial went through the friction blend's fast transient
    /// (`blend_change_rel`).
    pub blend_entry: bool,
    /// The trial's copy of `Carry::newton_last` (read at its start, written
    /// where the iteration ends; `Simulator::newmark_trial` moves it).
    pub newton_last: bool,
    /// The least-work split of redundant multipliers, with a backend of its
    /// own; made at first use.
    pub least_work: Option<LeastWork>,
    /// The compliant elements' and engaged compliant latches' buffers.
    pub element_springs: crate::solver::springs::ElementSprings,
    /// Speed-controlled motors: which track in the current solve, and their buffers.
    pub motor: MotorWork,
    /// What the stepping loop did (the aux solver's work is not counted).
    pub stats: SolverStats,
    /// Elastic members: per row its compliance c (m/N; `rigid_compliance`
    /// for rows that are not members), whether it is a member, D = c / beta
    /// of the solve in progress, and Phi and A V (scratch).
    pub row_compliance: Vec<f64>,
    pub row_member: Vec<bool>,
    pub row_d: Vec<f64>,
    pub row_phi: Vec<f64>,
    pub row_rate: Vec<f64>,
    /// Elastic members: (tau / b) V - A_g, the one vector whose product
    /// with A the index-3 right-hand side takes (scratch, per coordinate).
    pub coord_rate: Vec<f64>,
    /// The members' relaxation time tau (s, `member_relaxation_s`).
    pub relaxation_s: f64,
    /// Elastic members: strain energy 1/2 sum Phi_i^2 / c_i at the trial's
    /// end (J) and their joint forces A^T lambda there (N), whose trapezoid
    /// work the ledger books (with `Carry::member_force_n`, the state's).
    pub strain_trial_j: f64,
    pub member_force_trial: Vec<f64>,
}

impl Core {
    pub fn new(model: &Model, locked: &[bool], solver: Box<dyn ConstraintSolver>) -> Core {
        let n = model.n_coords();
        let jac = Jacobian::pattern(model, locked);
        let m = jac.nrows;
        let mut core = Core {
            jac,
            solver,
            q: vec![0.0; n],
            c: vec![0.0; m],
            r: vec![0.0; m],
            dx: vec![0.0; n],
            mu: vec![0.0; m],
            x: model.x0.clone(),
            v: vec![0.0; n],
            a: vec![0.0; n],
            a_guess: vec![0.0; n],
            lambda: vec![0.0; m],
            cables: model.cables.iter().map(CableEval::for_cable).collect(),
            violation_m: 0.0,
            inv_mass_eff: model.inv_mass.clone(),
            v_star: vec![0.0; n],
            friction_sliding: model
                .cables
                .iter()
                .map(|c| vec![0.0; c.path.len().saturating_sub(2)])
                .collect(),
            blend_entry: false,
            newton_last: false,
            newton: NewtonWork::new(model.solver.newmark_newton_krylov_max, n, m),
            least_work: None,
            element_springs: crate::solver::springs::ElementSprings::new(model),
            motor: MotorWork::new(model, m),
            stats: SolverStats::default(),
            row_compliance: Vec::new(),
            row_member: Vec::new(),
            row_d: Vec::new(),
            row_phi: Vec::new(),
            row_rate: Vec::new(),
            coord_rate: vec![0.0; n],
            relaxation_s: model.solver.member_relaxation_s,
            strain_trial_j: 0.0,
            member_force_trial: vec![0.0; n],
        };
        core.set_compliance(model);
        core
    }

    /// Per-row compliances of the current pattern (elastic members).
    fn set_compliance(&mut self, model: &Model) {
        LeastWork::row_compliance(model, &self.jac, &mut self.row_compliance);
        // (a latched sleeve with a compliant latch: its tube in series with
        // the latch, c = L/EA + 1/k, so its force carries on when its
        // transient ends)
        for b in &self.jac.blocks {
            if model.elements[b.element].latch_spring().is_some() {
                self.row_compliance[b.row0] = model.latched_sleeve_compliance_m_per_n(b.element);
            }
        }
        let rigid = rigid_compliance(model);
        self.row_member.clear();
        self.row_member
            .extend(self.row_compliance.iter().map(|c| c.is_finite()));
        for c in &mut self.row_compliance {
            if !c.is_finite() {
                *c = rigid;
            }
        }
        for b in [&mut self.row_d, &mut self.row_phi, &mut self.row_rate] {
            b.resize(self.jac.nrows, 0.0);
        }
    }

    /// beta = d(Phi + tau Phidot)_{n+1} / d(A A_{n+1}) = h^2/4 + tau h/2
    /// under the average acceleration (also for velocity jumps).
    pub fn relaxation_beta(&self, h: f64) -> f64 {
        h * (0.25 * h + 0.5 * self.relaxation_s)
    }

    /// The same in a trial step of length h under `rule`: beta h^2 + tau gamma h.
    pub fn step_relaxation_beta(&self, h: f64, rule: StepRule) -> f64 {
        match rule {
            StepRule::BackwardEuler => rule.gains(h).spring(1.0, self.relaxation_s),
            StepRule::AverageAcceleration => self.relaxation_beta(h),
        }
    }

    /// Elastic members at (x, v) with the Jacobian filled there: strain
    /// energy 1/2 sum Phi_i^2 / c_i (J) and the largest residual of
    /// Phi + tau A V + c lambda (m).
    pub fn elastic_readings(&mut self, model: &Model) -> (f64, f64) {
        self.jac.residual(model, &self.x, &mut self.row_phi);
        self.jac.mul(&self.v, &mut self.row_rate);
        let tau = self.relaxation_s;
        let (mut strain, mut worst) = (0.0, 0.0f64);
        for i in 0..self.row_phi.len() {
            let (phi, cmp) = (self.row_phi[i], self.row_compliance[i]);
            strain += 0.5 * phi * phi / cmp;
            worst = worst.max((phi + tau * self.row_rate[i] + cmp * self.lambda[i]).abs());
        }
        (strain, worst)
    }

    /// The state's member forces on the joints A^T lambda into `out`
    /// (Jacobian and multipliers at the state).
    pub fn state_member_forces(&self, out: &mut [f64]) {
        self.jac.mul_t(&self.lambda, out);
    }

    /// The Jacobian pattern (and row-sized buffers) of a new locked set.
    pub fn set_pattern(&mut self, model: &Model, locked: &[bool]) {
        self.jac = Jacobian::pattern(model, locked);
        let m = self.jac.nrows;
        for b in [&mut self.c, &mut self.r, &mut self.mu, &mut self.lambda] {
            b.resize(m, 0.0);
        }
        self.newton.set_rows(m);
        self.motor.set_rows(m);
        self.set_compliance(model);
    }

    /// The solves' inverse masses: M^-1, or (M + gamma h C)^-1 inside a
    /// Newmark trial (`Pose::implicit_damping`).
    pub(super) fn weights<'a>(pose: Pose, eff: &'a [f64], model: &'a Model) -> &'a [f64] {
        if pose.implicit_damping {
            eff
        } else {
            &model.inv_mass
        }
    }

    /// Jacobian at the trial x, and a factorization for solves in `mode`
    /// with the inverse masses of `pose`.
    pub fn factor(
        &mut self,
        model: &Model,
        mode: SolveMode,
        pose: Pose,
    ) -> Result<(), SolverError> {
        self.jac.fill(model, &self.x);
        let w = Self::weights(pose, &self.inv_mass_eff, model);
        let report = self.solver.factor(&self.jac, w, mode)?;
        self.book_factor(report);
        Ok(())
    }

    fn book_factor(&mut self, r: FactorReport) {
        let s = &mut self.stats;
        if r.fresh {
            s.factorizations += 1;
        } else {
            s.factorizations_reused += 1;
        }
        s.probes += u64::from(r.probed);
    }

    pub(super) fn book_solve(&mut self, r: SolveReport) {
        let s = &mut self.stats;
        s.solves += 1;
        s.solve_iterations += r.iterations as u64;
        s.solve_factorizations += u64::from(r.factorizations);
        s.solve_factorizations_reused += u64::from(r.reused_factorization);
        let f = &mut s.fallbacks;
        f.solve_refactored += u64::from(r.refactored);
        f.solve_reprobed += u64::from(r.reprobed);
        f.solve_least_squares += u64::from(r.least_squares);
        f.solve_unconverged += u64::from(!r.converged);
    }

    /// Constrained accelerations `a`, multipliers `lambda` for the applied
    /// forces `q` and the right side `c`, with the current factorization,
    /// the rows held as `pose` says.
    pub fn solve_accelerations(&mut self, model: &Model, pose: Pose) -> Result<(), SolverError> {
        let w = Self::weights(pose, &self.inv_mass_eff, model);
        let report = if let Some(h) = pose.rows.elastic_h() {
            // D = c / beta (the trial's rule in the Newmark iteration, else
            // the average acceleration's)
            let beta = match pose.rows {
                Rows::ElasticStep { h, rule } => self.step_relaxation_beta(h, rule),
                _ => self.relaxation_beta(h),
            };
            let k = 1.0 / beta;
            for (d, c) in self.row_d.iter_mut().zip(&self.row_compliance) {
                *d = k * c;
            }
            if let Rows::ElasticForces { .. } = pose.rows {
                // (at acceleration level a member's force is its state's,
                // lambda = -(Phi + tau A V) / c: D >> S, rhs D lambda in `c`)
                for i in 0..self.row_d.len() {
                    if self.row_member[i] {
                        self.row_d[i] = MEMBER_PIN * k * self.row_compliance[i];
                    }
                }
            }
            match pose.solve {
                Solve::Exact => self.solver.compliant_accelerations(
                    &self.jac,
                    w,
                    &self.row_d,
                    &self.q,
                    &self.c,
                    &mut self.a,
                    &mut self.lambda,
                )?,
                // (from the multipliers in `lambda`: the last iterate's)
                Solve::Correction { refresh } => self.solver.compliant_correction(
                    &self.jac,
                    w,
                    &self.row_d,
                    (&self.q, &self.c),
                    &mut self.a,
                    &mut self.lambda,
                    refresh,
                )?,
            }
        } else {
            self.solver.accelerations(
                &self.jac,
                w,
                &self.q,
                &self.c,
                &mut self.a,
                &mut self.lambda,
            )?
        };
        self.book_solve(report);
        Ok(())
    }

    /// The mass-orthogonal correction dX = M^-1 A^T S^+ r of r in `r`
    /// (multipliers into `mu`), with the current factorization, solved until
    /// max |r - A dX| is at most `residual_target`.
    pub fn correction(&mut self, model: &Model, residual_target: f64) -> Result<(), SolverError> {
        let report = self.solver.correction(
            &self.jac,
            &model.inv_mass,
            &self.r,
            residual_target,
            &mut self.dx,
            &mut self.mu,
        )?;
        self.book_solve(report);
        Ok(())
    }

    /// The least-work split (into `mu`) of the joint forces in `dx` among the
    /// rows of the Jacobian as last filled, on its own backend (`least_work`).
    pub fn least_work_split(&mut self, model: &Model, kind: SolverKind) -> Result<(), SolverError> {
        let lw = self.least_work.get_or_insert_with(|| LeastWork::new(kind));
        let (dense, inexact) = (lw.dense_splits, lw.inexact_splits);
        let result = lw.multipliers(model, &self.jac, &self.dx, &mut self.mu);
        let f = &mut self.stats.fallbacks;
        f.least_work_dense += lw.dense_splits - dense;
        f.least_work_inexact += lw.inexact_splits - inexact;
        result
    }

    /// Inverse effective mass of the structure along sleeve `e` at the trial
    /// x (1/kg): l'' under a unit pair of forces pulling its ends apart, every
    /// constraint holding (one solve with Q = J_e^T, Adot Xdot = 0),
    ///
    ///     w = J_e (M^-1 - M^-1 A^T S^+ A M^-1) J_e^T,   S = A M^-1 A^T,
    ///
    /// so a spring k across it has the frequency sqrt(k w). Rigid members
    /// (`step_s` None): at the current factorization. Elastic members
    /// (`step_s` Some(h)), S nearly singular near the flat state: every row
    /// at the rigid rows' compliance c_r over a step h, D = c_r / beta,
    ///
    ///     w = J_e (M^-1 - M^-1 A^T (S + D)^-1 A M^-1) J_e^T   (Woodbury),
    ///
    /// S + D factored at x (docs/solver.md, Latches). Uses `q`, `c`, `a`,
    /// `lambda`, `row_d` as scratch.
    pub fn inverse_effective_mass(
        &mut self,
        model: &Model,
        e: usize,
        step_s: Option<f64>,
    ) -> Result<f64, SolverError> {
        let el = &model.elements[e];
        let (ja, jb) = (el.joints()[0], el.joints()[1]);
        let d = crate::solver::elements::at(&self.x, jb) - crate::solver::elements::at(&self.x, ja);
        let u = d / d.norm();
        self.q.fill(0.0);
        for k in 0..3 {
            self.q[3 * ja + k] = -u[k];
            self.q[3 * jb + k] = u[k];
        }
        self.c.fill(0.0);
        if let Some(h) = step_s {
            self.jac.fill(model, &self.x);
            let d = rigid_compliance(model) / self.relaxation_beta(h);
            self.row_d.fill(d);
            let report = self.solver.compliant_accelerations(
                &self.jac,
                &model.inv_mass,
                &self.row_d,
                &self.q,
                &self.c,
                &mut self.a,
                &mut self.lambda,
            )?;
            self.book_solve(report);
        } else {
            self.solve_accelerations(model, Pose::PLAIN)?;
        }
        Ok((0..3)
            .map(|k| u[k] * (self.a[3 * jb + k] - self.a[3 * ja + k]))
            .sum::<f64>()
            .max(0.0))
    }

    /// Commits the trial to the state, keeping the largest violation seen.
    pub fn commit_trial(&self, s: &mut State) {
        s.x.copy_from_slice(&self.x);
        s.v.copy_from_slice(&self.v);
        s.a.copy_from_slice(&self.a);
        s.lambda.clone_from(&self.lambda);
        for (o, n) in s.cables.iter_mut().zip(&self.cables) {
            o.clone_from(n);
        }
        s.max_violation_m = s.max_violation_m.max(self.violation_m);
    }

    pub fn save_trial(&self, to: &mut TrialCopy) {
        to.x.clone_from(&self.x);
        to.v.clone_from(&self.v);
        to.a.clone_from(&self.a);
        to.lambda.clone_from(&self.lambda);
        to.cables.clone_from(&self.cables);
        to.violation_m = self.violation_m;
        to.strain_j = self.strain_trial_j;
        to.member_force.clone_from(&self.member_force_trial);
    }

    pub fn restore_trial(&mut self, from: &TrialCopy) {
        self.x.clone_from(&from.x);
        self.v.clone_from(&from.v);
        self.a.clone_from(&from.a);
        self.lambda.clone_from(&from.lambda);
        self.cables.clone_from(&from.cables);
        self.violation_m = from.violation_m;
        self.strain_trial_j = from.strain_j;
        self.member_force_trial.clone_from(&from.member_force);
    }
}

/// The compliance given to the rows that are not members (m/N):
/// `rigid_row_compliance_rel` of the stiffest member's.
fn rigid_compliance(model: &Model) -> f64 {
    model.solver.rigid_row_compliance_rel * model.stiffest_compliance_m_per_n
}

/// A copy of a trial step, to come back to after trials of other lengths.
#[derive(Default)]
pub(super) struct TrialCopy {
    x: Vec<f64>,
    v: Vec<f64>,
    a: Vec<f64>,
    lambda: Vec<f64>,
    cables: Vec<CableEval>,
    violation_m: f64,
    /// Elastic members: the trial's strain energy (J) and member forces.
    strain_j: f64,
    member_force: Vec<f64>,
}

/// The rule of a Newmark trial: X_{n+1} = X_n + h V_n + h^2 ((1/2 - beta) A_n
/// + beta A_{n+1}), V_{n+1} = V_n + h ((1 - gamma) A_n + gamma A_{n+1}).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum StepRule {
    /// beta = 1/4, gamma = 1/2: the trapezoid, which conserves energy.
    #[default]
    AverageAcceleration,
    /// beta = 1/2, gamma = 1 (A_n drops out): damps a fast transient that
    /// the trapezoid leaves ringing (docs/solver.md, Backward-Euler steps).
    BackwardEuler,
}

impl StepRule {
    /// What X_{n+1} and V_{n+1} move per unit of A_{n+1} in a step of length h.
    pub fn gains(self, h: f64) -> StepGains {
        match self {
            StepRule::BackwardEuler => StepGains {
                position_s2: 0.5 * h * h,
                velocity_s: h,
            },
            StepRule::AverageAcceleration => StepGains::trapezoid(h),
        }
    }
}

/// How a solve holds the constraint rows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Rows {
    /// Rigid: A a = -Adot Xdot.
    Rigid,
    /// Elastic members at acceleration level, each member's force the
    /// state's, lambda = -(Phi + tau A V) / c, the other rows' compliance
    /// scaled to a step of length h (a restart: `consistent_accelerations`).
    ElasticForces { h: f64 },
    /// Elastic members in a Newmark step of length h under `rule`:
    /// Phi + tau Phidot + c lambda = 0 at its end (index 3).
    ElasticStep { h: f64, rule: StepRule },
}

impl Rows {
    /// The step the elastic rows are scaled to; None for rigid rows.
    pub fn elastic_h(self) -> Option<f64> {
        match self {
            Rows::Rigid => None,
            Rows::ElasticForces { h } | Rows::ElasticStep { h, .. } => Some(h),
        }
    }
}

/// How the constrained solves of a stage are posed, passed to every solve
/// (nothing of it is set on the workspace).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    pub rows: Rows,
    /// Inside a Newmark trial: damping implicit, the solves on
    /// (M + gamma h C)^-1 (`Core::inv_mass_eff`), the dampers on V*.
    pub implicit_damping: bool,
    /// The pulley friction's direction from the sliding at the trial's start
    /// (`Core::friction_sliding`: the stalled iteration's fallback), not the
    /// iterate's.
    pub lagged_friction: bool,
    /// Elastic rows: solved exactly, or corrected once from the last iterate
    /// (a modified Newton step).
    pub solve: Solve,
}

/// How an elastic system is solved (`Pose::solve`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Solve {
    /// To roundoff (conjugate gradients on the kept factorization).
    Exact,
    /// One correction from the multipliers in `Core::lambda` with the kept
    /// factorization, made afresh where `refresh`
    /// (`ConstraintSolver::compliant_correction`).
    Correction { refresh: bool },
}

impl Pose {
    /// Between steps: rigid rows, plain masses, the friction of the iterate.
    pub const PLAIN: Pose = Pose {
        rows: Rows::Rigid,
        implicit_damping: false,
        lagged_friction: false,
        solve: Solve::Exact,
    };
}
