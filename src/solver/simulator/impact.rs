//! Stage `impact`: an element latches (docs/solver.md, Latches). Its rows join the constraint set
//! and the velocities jump onto the new manifold by the mass-orthogonal projection (an inelastic
//! latch): V+ = V- - M^-1 A^T mu, mu = S^+ A V- the impulses, shared among redundant rows by least
//! work; the kinetic energy lost is 1/2 mu . (A V-) per row. The mobility of the new set decides
//! whether the truss is deployed.
//!
//! A compliant latch engages instead as a spring-damper about its lock length,
//! T = k (l - L) + c ldot (`crate::solver::springs`), with steps that resolve its period
//! (`transient_step_s`); once settled it turns rigid (`turn_rigid`). With elastic members the
//! sleeve's row, of compliance c = L/EA + 1/k, then holds its deflection.

use super::core::{Core, Pose};
use super::events::held;
use super::sim::Simulator;
use crate::solver::linsolve::SolveMode;
use crate::solver::model::Model;
use crate::solver::settings::SolverSettings;
use crate::solver::springs::sleeve_motion_at;
use crate::solver::state::{Carry, LatchTransient, LockEvent, WaitingLatch};
use crate::solver::SolverError;

impl Core {
    /// The velocity jump onto the constraint manifold of the current pattern at the trial (x, v),
    /// every solve in `mode`: positions and velocities projected (A V before in `r`, the impulses
    /// in `mu`), then the accelerations (from `a_guess`). `MinNorm` shares the impulses among
    /// redundant rows by least squares (simultaneous latches of redundant members are otherwise
    /// statically indeterminate).
    pub fn velocity_jump(
        &mut self,
        model: &Model,
        st: &SolverSettings,
        (cmd, carry): (&[f64], &mut Carry),
        mode: SolveMode,
    ) -> Result<(), SolverError> {
        if st.elastic_members {
            // (elastic members keep their stretch: the latch is at its lock)
            self.factor(model, mode, Pose::PLAIN)?;
            self.elastic_velocity_jump(model)?;
            return self.consistent_accelerations(model, cmd, st, carry);
        }
        self.project_positions(model, st, mode)?;
        self.factor(model, mode, Pose::PLAIN)?;
        self.project_velocities(model, st, mode)?;
        self.consistent_accelerations(model, cmd, st, carry)
    }

    /// The velocity jump of elastic members: V <- V + dV, dV = M^-1 A^T lambda with
    /// A (V + dV) + D lambda = 0, D = c / beta at the model's step: the rigid impulse to within
    /// D / S ~ 1e-5, and well posed at the flat state (docs/solver.md, Elastic members).
    /// Impulses mu = -lambda (N s) in `mu`, A V before in `r`.
    fn elastic_velocity_jump(&mut self, model: &Model) -> Result<(), SolverError> {
        self.jac.mul(&self.v, &mut self.r);
        self.q.fill(0.0);
        let k = 1.0 / self.relaxation_beta(model.dt_s);
        for (d, c) in self.row_d.iter_mut().zip(&self.row_compliance) {
            *d = k * c;
        }
        let report = self.solver.compliant_accelerations(
            &self.jac,
            &model.inv_mass,
            &self.row_d,
            &self.q,
            &self.r,
            &mut self.dx,
            &mut self.mu,
        )?;
        self.book_solve(report);
        for (v, d) in self.v.iter_mut().zip(&self.dx) {
            *v += d;
        }
        for m in &mut self.mu {
            *m = -*m;
        }
        Ok(())
    }
}

impl Simulator {
    /// Latches every lockable element within the latch tolerance of its lock: rigid latches by the
    /// inelastic velocity jump, recorded as events; compliant ones engage as spring-dampers (their
    /// transient runs in the following sub-steps). Returns how many latched or engaged.
    pub(super) fn latch(&mut self) -> Result<usize, SolverError> {
        let (model, st) = (&self.model, &self.settings);
        let newly: Vec<usize> = model
            .locks
            .iter()
            .copied()
            .filter(|&e| {
                !held(&self.state, e)
                    && model.lock_gap_m(e, &self.state.x).abs() <= st.latch_tol_m()
            })
            .collect();
        if newly.is_empty() {
            return Ok(0);
        }
        let t = self.state.t_s;
        let (springy, rigid): (Vec<usize>, Vec<usize>) = newly
            .iter()
            .partition(|&&e| model.elements[e].latch_spring().is_some());
        // rigid latches first: the springs engage on the structure they make
        if !rigid.is_empty() {
            self.latch_rigid(&rigid, &|_| t)?;
        }
        if springy.is_empty() {
            return Ok(newly.len());
        }
        let mut immobile = Vec::new();
        for &e in &springy {
            if !self.engage(e)? {
                immobile.push(e);
            }
        }
        self.share_one_mode_period();
        // A compliant latch the structure cannot move along has no transient of its own. With
        // elastic members it latches now as its row (c = L/EA + 1/k, `Model::latched_sleeve_compliance_m_per_n`),
        // which holds the sleeve at its lock with the latch's stiffness whatever the others'
        // transients do. Rigid members: it waits for the others' transients (its rigid row would
        // be redundant to first order with theirs meanwhile); with none engaging it latches rigid.
        if self.settings.elastic_members && !immobile.is_empty() {
            self.latch_rigid(&immobile, &|_| t)?;
            self.core.stats.latches += immobile.len() as u64;
            self.retire_immobile_transients()?;
            // (the transients it retires may be the last open sleeves)
            self.stamp_deploy_time();
            if !self.state.transients.is_empty() {
                self.state.carry.accel_history.forget();
                self.restart_accelerations()?;
            }
            self.track_latch_rows();
        } else if self.state.transients.is_empty() {
            self.core.stats.fallbacks.latch_without_compliance += immobile.len() as u64;
            self.latch_rigid(&immobile, &|_| t)?;
        } else {
            // the side it came from: its gap at the sub-step's start (0 if already at its lock)
            let tol = self.settings.latch_tol_m();
            for &e in &immobile {
                let g0 = self.model.lock_gap_m(e, &self.x_start);
                let side = if g0.abs() > tol { g0.signum() } else { 0.0 };
                self.state.carry.waiting.push(WaitingLatch {
                    element: e,
                    reached_s: t,
                    side,
                });
            }
            // the dampers' force jumps in: accelerations from there
            self.state.carry.accel_history.forget();
            self.restart_accelerations()?;
        }
        Ok(newly.len())
    }

    /// Latches `elements` rigid at the state and records their events, each
    /// at the instant `reached_s` gives it (when it reached its lock).
    fn latch_rigid(
        &mut self,
        elements: &[usize],
        reached_s: &dyn Fn(usize) -> f64,
    ) -> Result<(), SolverError> {
        let jumps = self.lock_rigidly(elements)?;
        for (&e, (impulse_ns, energy_lost_j, rate)) in elements.iter().zip(jumps) {
            let name = self.model.elements[e].name();
            let mut ev = LockEvent::new(e, name, reached_s(e), rate);
            (ev.impulse_ns, ev.energy_lost_j) = (impulse_ns.abs(), energy_lost_j);
            self.state.locks.push(ev);
        }
        self.stamp_deploy_time();
        Ok(())
    }

    /// Once no transient is left, the waiting compliant latches still at their lock latch rigid (at
    /// the instant they reached it); the others are free again. Returns how many latched.
    fn latch_waiting(&mut self) -> Result<usize, SolverError> {
        if !self.state.transients.is_empty() || self.state.carry.waiting.is_empty() {
            return Ok(0);
        }
        let waiting = std::mem::take(&mut self.state.carry.waiting);
        let tol = self.settings.latch_tol_m();
        let mut at_lock = Vec::new();
        for &WaitingLatch {
            element: e, side, ..
        } in &waiting
        {
            let g = self.model.lock_gap_m(e, &self.state.x);
            if g.abs() <= tol {
                at_lock.push(e);
            } else if g * side < 0.0 {
                // it went past its lock while it waited
                return Err(SolverError::MissedLatch {
                    element: self.model.elements[e].name().to_string(),
                    t_s: self.state.t_s,
                    gap_m: g,
                });
            }
        }
        if at_lock.is_empty() {
            return Ok(0);
        }
        self.core.stats.fallbacks.latch_without_compliance += at_lock.len() as u64;
        let reached = |e: usize| {
            let w = waiting.iter().find(|w| w.element == e);
            w.map_or(f64::NAN, |w| w.reached_s)
        };
        self.latch_rigid(&at_lock, &reached)?;
        Ok(at_lock.len())
    }

    /// Once deployed: the deploy time is the instant the last latch engaged or reached its lock
    /// (compliant latches turn rigid later), also for a latch after the truss turned rigid (near
    /// a singular configuration the rank test finds it rigid while the last sleeves still close
    /// on their locks by second-order motion).
    fn stamp_deploy_time(&mut self) {
        let s = &mut self.state;
        if s.deployed {
            let last = s
                .locks
                .iter()
                .map(|l| l.time_s)
                .fold(f64::NEG_INFINITY, f64::max);
            s.deploy_time_s = Some(s.deploy_time_s.map_or(last, |t| t.max(last)));
        }
    }

    /// Elastic members: a latched compliant latch (as its row at once, or after its transient)
    /// carries its row's force T = -lambda, Phi + tau Phidot + c lambda = 0, c = L/EA + 1/k. Its
    /// event's peak force is the largest |T| through it over its transient and every state since
    /// (called after every accepted sub-step and at its latch).
    pub(super) fn track_latch_rows(&mut self) {
        if !self.settings.elastic_members {
            return;
        }
        let (model, jac, s) = (&self.model, &self.core.jac, &mut self.state);
        for ev in &mut s.locks {
            let e = ev.element;
            if !s.locked[e] || model.elements[e].latch_spring().is_none() {
                continue;
            }
            let Some(f) = jac
                .first_row_of(e)
                .and_then(|r| s.lambda.get(r))
                .map(|l| l.abs())
            else {
                continue;
            };
            if ev.peak_force_n.map_or(true, |p| f > p) {
                ev.peak_force_n = Some(f);
                ev.time_of_peak_s = Some(s.t_s);
            }
        }
    }

    /// The mode a compliant latch of stiffness k across sleeve `e` makes with the structure at the
    /// state: the inverse effective mass w along the sleeve (`Core::inverse_effective_mass`, every
    /// rigid constraint holding; with elastic members on S + D, D = c_r / beta(dt_s)) and the
    /// period 2 pi / sqrt(k w). None where the structure cannot move along the sleeve: w below
    /// `latch_immobile_rel` of its free two-joint value 1/m_a + 1/m_b (the spring would never
    /// deflect nor settle).
    fn latch_mode(&mut self, e: usize, k: f64) -> Result<Option<(f64, f64)>, SolverError> {
        let model = &self.model;
        self.core.x.copy_from_slice(&self.state.x);
        let step_s = self.settings.elastic_members.then_some(model.dt_s);
        let w = self.core.inverse_effective_mass(model, e, step_s)?;
        let period_s = 2.0 * std::f64::consts::PI / (k * w).sqrt();
        let [ja, jb] = [model.elements[e].joints()[0], model.elements[e].joints()[1]];
        let w_free = model.inv_mass[3 * ja] + model.inv_mass[3 * jb];
        let mobile = w > self.settings.latch_immobile_rel * w_free && period_s.is_finite();
        Ok(mobile.then_some((w, period_s)))
    }

    /// A compliant latch engages at the state: its event (peak to come) and transient, of period
    /// 2 pi / sqrt(k w) (`latch_mode`). Returns false, engaging nothing, where the structure
    /// cannot move along the sleeve (w below `latch_immobile_rel` of its free value); the caller
    /// latches it rigid (a counted fallback), after the transients of the others engaging with it.
    fn engage(&mut self, e: usize) -> Result<bool, SolverError> {
        let (model, x, v) = (&self.model, &self.state.x, &self.state.v);
        let (k, c) = model.elements[e].latch_spring().unwrap_or_default();
        let Some((gap_m, rate)) = sleeve_motion_at(model, e, x, v) else {
            return Ok(false);
        };
        let Some((w, period_s)) = self.latch_mode(e, k)? else {
            return Ok(false);
        };
        let t = self.state.t_s;
        let name = self.model.elements[e].name();
        self.state.locks.push(LockEvent::new(e, name, t, rate));
        // (the gap is zero to `latch_tol_m` at engagement: the force is the damper's, c ldot)
        let force_n = c * rate;
        let sign = if rate >= 0.0 { 1.0 } else { -1.0 };
        self.state.transients.push(LatchTransient {
            element: e,
            event: self.state.locks.len() - 1,
            stiffness_n_per_m: k,
            damping_n_s_per_m: c,
            inv_mass_eff_per_kg: w,
            sign,
            period_s,
            engaged_at_s: t,
            force_n,
            gap_m,
            rate_m_s: rate,
            window_max_n: sign * force_n,
            window_min_n: sign * force_n,
            window_start_s: t,
            window_start_force_n: sign * force_n,
            impulse_ns: 0.0,
            dissipated_j: 0.0,
        });
        self.core.element_springs.engage_latch(&self.model, e, k, c);
        self.core.stats.latches += 1;
        self.core.stats.compliant_latches += 1;
        Ok(true)
    }

    /// Longest step that resolves the engaged compliant latches: their period
    /// (`spring_mode_period_s`) over `latch_steps_per_period`, or over
    /// `latch_settle_steps_per_period` once every one has peaked.
    pub(super) fn transient_step_s(&self) -> f64 {
        let tr = &self.state.transients;
        if tr.is_empty() {
            return f64::INFINITY;
        }
        let peaked = tr
            .iter()
            .all(|t| self.state.locks[t.event].peak_force_n.is_some());
        let per_period = if peaked {
            self.settings.latch_settle_steps_per_period
        } else {
            self.settings.latch_steps_per_period
        };
        self.spring_mode_period_s() / per_period
    }

    /// Whether the engaged latches make one mode: the rigid rows leave exactly one mechanism n (an
    /// SVD at the state, up to `rank_check_max_coords`; the state's count may be a bound) and no
    /// compliant element adds stiffness along n.
    fn one_spring_mode(&mut self) -> bool {
        let n = self.model.n_coords();
        if self.core.element_springs.has_elements() || n > self.settings.rank_check_max_coords {
            return false;
        }
        self.core.jac.fill(&self.model, &self.state.x);
        crate::solver::rank::of_jacobian(&self.core.jac) + 1 == n
    }

    /// Where the engaged latches make one mode (`one_spring_mode`), it is every transient's period.
    fn share_one_mode_period(&mut self) {
        if !self.state.transients.is_empty() && self.one_spring_mode() {
            let one_mode_s = self.spring_mode_period_s();
            for tr in &mut self.state.transients {
                tr.period_s = one_mode_s;
            }
        }
    }

    /// 2 pi / sqrt(sum_i k_i w_i) over the engaged latches (s), w_i the inverse effective mass
    /// along latch i: the bound on the period of the fastest mode they make together (Rayleigh:
    /// omega^2 = max_u sum_i k_i (J_i u)^2 / u^T M u <= sum_i k_i w_i), a single latch's own
    /// period, and that of their one mode on a structure with one mechanism.
    fn spring_mode_period_s(&self) -> f64 {
        let omega2: f64 = self
            .state
            .transients
            .iter()
            .map(|t| t.stiffness_n_per_m * t.inv_mass_eff_per_kg)
            .sum();
        2.0 * std::f64::consts::PI / omega2.sqrt()
    }

    /// Turns rigid the compliant latches whose transient is over: over the last period the force
    /// swung by at most `latch_settle_rel` of its peak beyond its net change, or
    /// `latch_max_periods` have passed (`fallbacks.latch_unsettled`). With elastic members a latch
    /// whose force has not turned (no peak yet: it reached its lock nearly at rest and the drive
    /// loads it steadily) settles on the same test against its largest force in the window; its
    /// row then carries the load and reports its force (`track_latch_rows`). Returns how many
    /// turned rigid.
    pub(super) fn settle_transients(&mut self) -> Result<usize, SolverError> {
        if self.state.transients.is_empty() {
            return Ok(0);
        }
        self.core.stats.transient_substeps += 1;
        let (t, st) = (self.state.t_s, &self.settings);
        let mut due: Vec<usize> = Vec::new();
        for tr in &self.state.transients {
            let window_done = window_over(tr, t);
            // the spread beyond the net change: a vibration swings, a steadily rising load does not
            let swing = tr.window_max_n
                - tr.window_min_n
                - (tr.sign * tr.force_n - tr.window_start_force_n).abs();
            // (no peak: a force that has not turned, see above)
            let calm = match self.state.locks[tr.event].peak_force_n {
                Some(p) => swing <= st.latch_settle_rel * p,
                None => st.elastic_members && swing <= st.latch_settle_rel * tr.window_max_n.abs(),
            };
            let overdue = t - tr.engaged_at_s >= st.latch_max_periods * tr.period_s;
            if (window_done && calm) || overdue {
                due.push(tr.element);
                if !(window_done && calm) {
                    self.core.stats.fallbacks.latch_unsettled += 1;
                }
            }
        }
        // a new window for those whose window ended
        for tr in &mut self.state.transients {
            if window_over(tr, t) {
                let f = tr.sign * tr.force_n;
                (tr.window_max_n, tr.window_min_n) = (f, f);
                tr.window_start_s = t;
                tr.window_start_force_n = f;
            }
        }
        if due.is_empty() {
            return Ok(0);
        }
        self.turn_rigid(&due, t)?;
        let mut turned = due.len();
        // Elastic members: those may leave others immobile (`retire_immobile_transients`).
        turned += self.retire_immobile_transients()?;
        // (the waiting latches before the stamp: they may have reached their lock last)
        let waited = self.latch_waiting()?;
        self.stamp_deploy_time();
        Ok(turned + waited)
    }

    /// Turns the engaged compliant latches `due` rigid at the state (time t): each one's force
    /// impulse and dissipation, and the elastic energy 1/2 k g^2 its spring releases, go with its
    /// event; the velocities jump onto the new constraint set (`lock_rigidly`).
    fn turn_rigid(&mut self, due: &[usize], t: f64) -> Result<(), SolverError> {
        // per latch: event, sign, force impulse, dissipation plus released spring energy
        let mut settled: Vec<(usize, f64, f64, f64)> = Vec::with_capacity(due.len());
        for tr in self
            .state
            .transients
            .iter()
            .filter(|tr| due.contains(&tr.element))
        {
            let g = self.model.lock_gap_m(tr.element, &self.state.x);
            let k = tr.stiffness_n_per_m;
            let spring_j = 0.5 * k * g * g;
            self.state.energy.latch_spring_energy_j -= spring_j;
            // Elastic members: the sleeve's row holds its deflection g at c = L/EA + 1/k
            // (`Core::set_compliance`), strain 1/2 g^2/c; the rest of the spring's energy is the
            // latch's loss. Rigid: all of it.
            let held_j = if self.settings.elastic_members {
                0.5 * g * g / self.model.latched_sleeve_compliance_m_per_n(tr.element)
            } else {
                0.0
            };
            self.state.energy.member_strain_energy_j += held_j;
            let spring_j = spring_j - held_j;
            self.state.energy.lock_loss_j += spring_j;
            settled.push((tr.event, tr.sign, tr.impulse_ns, tr.dissipated_j + spring_j));
        }
        self.state
            .transients
            .retain(|tr| !due.contains(&tr.element));
        self.core.element_springs.release_latches(Some(due));
        let jumps = self.lock_rigidly(due)?;
        for ((event, sign, impulse_ns, lost_j), (impulse, lost, _)) in
            settled.into_iter().zip(jumps)
        {
            let ev = &mut self.state.locks[event];
            // both signed tension positive; reported as a magnitude (times the engaging sign)
            ev.impulse_ns = sign * (impulse_ns + impulse);
            ev.energy_lost_j = lost_j + lost;
            ev.rigid_at_s = Some(t);
        }
        Ok(())
    }

    /// Elastic members, with compliant latches engaged: those the structure can no longer move
    /// along since other latches turned rigid or latched as rows (w below `latch_immobile_rel` of
    /// its free value, as at `engage`) have no mode left to settle in: they turn rigid now as
    /// their rows, c = L/EA + 1/k. The others take the structure's new w and period. Repeated
    /// until none turns (each row may immobilize others). Returns how many turned.
    pub(super) fn retire_immobile_transients(&mut self) -> Result<usize, SolverError> {
        if !self.settings.elastic_members {
            return Ok(0);
        }
        let mut turned = 0;
        while !self.state.transients.is_empty() {
            // (elastic members only: w solved on S + D factored at the state)
            let mut immobile = Vec::new();
            for i in 0..self.state.transients.len() {
                let (e, k) = {
                    let tr = &self.state.transients[i];
                    (tr.element, tr.stiffness_n_per_m)
                };
                match self.latch_mode(e, k)? {
                    None => immobile.push(e),
                    Some((w, period_s)) => {
                        let tr = &mut self.state.transients[i];
                        tr.inv_mass_eff_per_kg = w;
                        tr.period_s = period_s;
                    }
                }
            }
            // (the solves above used the core's `a` and `lambda` as scratch: the state's again)
            self.core.a.copy_from_slice(&self.state.a);
            self.core.lambda.clone_from(&self.state.lambda);
            if immobile.is_empty() {
                break;
            }
            self.core.stats.transients_immobile += immobile.len() as u64;
            self.turn_rigid(&immobile, self.state.t_s)?;
            turned += immobile.len();
        }
        self.share_one_mode_period();
        Ok(turned)
    }

    /// Makes `elements` rigid members (locked) at the current state: the velocity jump onto the
    /// new constraint set, impulses split by least work, the kinetic energy taken and the drive's
    /// work over the projection's move booked as latch loss, and the deployed state decided.
    /// Returns per element its impulse (N s, the multiplier's sign: positive where the element
    /// pulls its joints together), the energy it took (J) and its closing rate before (m/s).
    fn lock_rigidly(&mut self, elements: &[usize]) -> Result<Vec<(f64, f64, f64)>, SolverError> {
        self.motors_release_for_impact();
        let (model, st) = (&self.model, &self.settings);
        for &e in elements {
            self.state.locked[e] = true;
        }
        let core = &mut self.core;
        self.state.carry.accel_history.forget();
        core.set_pattern(model, &self.state.locked);
        core.x.copy_from_slice(&self.state.x);
        core.v.copy_from_slice(&self.state.v);
        core.a_guess.copy_from_slice(&self.state.a);
        // Least squares through the latch: latching into the flat deployed state leaves rows only
        // nearly redundant, on which basic solves are ill-conditioned.
        let s = &mut self.state;
        core.velocity_jump(
            model,
            st,
            (&s.cable_tension_cmd_n, &mut s.carry),
            SolveMode::MinNorm,
        )?;
        // A basic factorization of the new locked set at the latched state (the
        // next step starts from it): its probe counts the rank for large models.
        core.factor(model, SolveMode::Basic, Pose::PLAIN)?;
        core.stats.latches += elements
            .iter()
            .filter(|&&e| model.elements[e].latch_spring().is_none())
            .count() as u64;
        // Impulses: the jump's joint impulses M (V- - V+) = A^T P, split among rows by least work.
        for i in 0..core.dx.len() {
            core.dx[i] = model.mass[i] * (self.state.v[i] - core.v[i]);
        }
        core.least_work_split(model, self.opts.solver)?;
        let ke_before = self.state.kinetic_energy_j(model);
        let jumps = elements
            .iter()
            .map(|&e| {
                let row = core.jac.first_row_of(e).expect("latched element has a row");
                let (mu, rate) = (core.mu[row], core.r[row]);
                (mu, 0.5 * mu * rate, rate)
            })
            .collect();
        let s = &mut self.state;
        // The projection moves the joints onto the lock length (by roundoff after the root search,
        // by the deflection T/k for a compliant latch turning rigid) in no time: the drive's and
        // gravity's work over that move goes with the latch's loss.
        let moved_j = super::ledger::book_drive_work(
            model,
            &mut s.energy,
            &s.cables,
            &core.cables,
            &s.x,
            &core.x,
        );
        // (and the compliant elements' elastic energy changes over it)
        let (elastic_j, _) =
            core.element_springs
                .book_move(model, (&s.x, &s.v), (&core.x, &core.v));
        s.energy.element_spring_energy_j += elastic_j;
        core.commit_trial(s);
        let ke_after = s.kinetic_energy_j(model);
        s.energy.lock_loss_j += ke_before - ke_after + moved_j - elastic_j;
        self.state.mechanisms = self.mechanisms_now();
        // Rigid before every element latched: trusted from an SVD only (the dense solver's, or one
        // confirming a pivot rank; not past `rank_check_max_coords`). Once every element has
        // latched the truss is deployed whatever the count, and the SVD (~4 % of a ring's
        // deployment) is skipped. Elastic members move on where the rigid truss has no mechanism.
        let deployed = self.all_locked()
            || (self.state.mechanisms == 0
                && !self.settings.elastic_members
                && self.state.transients.is_empty()
                && self.model.n_coords() <= self.settings.rank_check_max_coords
                && (self.core.solver.rank().is_some()
                    || crate::solver::rank::of_jacobian(&self.core.jac) == self.model.n_coords()));
        if deployed {
            self.state.deployed = true;
        }
        Ok(jumps)
    }
}

/// Whether a transient's current window of one period has ended at `t` (to
/// roundoff of the period: sub-steps land on the window's end).
fn window_over(tr: &LatchTransient, t: f64) -> bool {
    t >= tr.window_start_s + tr.period_s * (1.0 - 1e-12)
}
