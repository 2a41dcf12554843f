//! What a step changes: time, positions, velocities, accelerations, the locked
//! set, cable commands and readings, member forces, the energy ledger and the
//! lock events so far.

use super::cable::CableEval;
use super::model::Model;
use serde::{Deserialize, Serialize};

/// One sleeve latching: when, how hard, and the kinetic energy the inelastic
/// latch took out of the structure.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LockEvent {
    pub element: usize,
    pub name: String,
    pub time_s: f64,
    /// Magnitude of the impulse carried by the latching member (N s).
    pub impulse_ns: f64,
    /// Kinetic energy lost in this latch (J): 1/2 mu * (closing rate before), mu the impulse.
    pub energy_lost_j: f64,
    /// Sleeve closing (or opening) rate just before the latch (m/s).
    pub closing_speed_m_s: f64,
    /// Compliant latches: the largest force through the latch while it
    /// engaged (N, magnitude) and when; None for a rigid latch (whose force
    /// is an impulse) or while the peak is still to come.
    pub peak_force_n: Option<f64>,
    pub time_of_peak_s: Option<f64>,
    /// Compliant latches: when the transient settled and the latch turned
    /// rigid (s); None for a rigid latch or while the transient lasts.
    pub rigid_at_s: Option<f64>,
}

impl LockEvent {
    /// Element e reaching its lock at t_s with the closing rate `rate`;
    /// its impulse, loss and forces are booked as they become known.
    pub fn new(element: usize, name: &str, time_s: f64, rate: f64) -> LockEvent {
        LockEvent {
            element,
            name: name.to_string(),
            time_s,
            impulse_ns: 0.0,
            energy_lost_j: 0.0,
            closing_speed_m_s: rate,
            peak_force_n: None,
            time_of_peak_s: None,
            rigid_at_s: None,
        }
    }
}

/// A compliant latch while its engagement transient lasts: a spring-damper
/// about the lock length, tension T = k (l - L_lock) + c ldot.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LatchTransient {
    pub element: usize,
    /// Index of its event in `State::locks`.
    pub event: usize,
    pub stiffness_n_per_m: f64,
    pub damping_n_s_per_m: f64,
    /// Inverse effective mass of the structure along the sleeve at
    /// engagement (1/kg), every rigid constraint holding.
    pub inv_mass_eff_per_kg: f64,
    /// +1 when the sleeve engaged extending (the latch pulls: T > 0), -1
    /// when shortening (it pushes).
    pub sign: f64,
    /// The window over which it is checked for settling (s): its own
    /// period 2 pi / sqrt(k w), w = `inv_mass_eff_per_kg`; on a structure
    /// with one mechanism (rigid rows, by an SVD at engagement; no compliant
    /// element), the period of the one mode its
    /// engaged latches make together, 2 pi / sqrt(sum_i k_i w_i) (exact
    /// there: with one mechanism n, w_i = (A_i n)^2 / n^T M n).
    pub period_s: f64,
    pub engaged_at_s: f64,
    /// Latch tension at the state (N), and the sleeve's lock gap and
    /// extension rate there (m, m/s), from which it is interpolated.
    pub force_n: f64,
    pub gap_m: f64,
    pub rate_m_s: f64,
    /// Extremes of sign * T over the current window of one period, its
    /// start, and sign * T there.
    pub window_max_n: f64,
    pub window_min_n: f64,
    pub window_start_s: f64,
    pub window_start_force_n: f64,
    /// Integral of T dt and the damper's dissipation since engagement (N s, J).
    pub impulse_ns: f64,
    pub dissipated_j: f64,
}

/// How a cable's motor holds it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MotorHold {
    /// At the commanded tension (`State::cable_tension_cmd_n`).
    Tension,
    /// At the commanded speed: the tension is what holds it.
    Tracking,
    /// Speed-commanded, held at its tension limit (`max_tension_n`): the
    /// structure resists more than the drive can pull (a stall, or a latch).
    AtLimit,
    /// Speed-commanded, at zero tension: the structure runs ahead of the cable.
    Slack,
}

/// A drive cable's motor: tension control (the default) or speed control
/// (`Simulator::set_cable_speed`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MotorState {
    /// The reel-in speed commanded (m/s; negative pays out), None under
    /// tension control.
    pub speed_cmd_m_s: Option<f64>,
    pub hold: MotorHold,
    /// While tracking: the cable length it holds at the state's time (m).
    pub length_ref_m: f64,
    /// The tension command it returns to when the speed command ends (N).
    pub tension_cmd_n: f64,
}

/// Energy bookkeeping (J). Balance: kinetic + latch_spring_energy +
/// element_spring_energy + member_strain_energy = cable_work +
/// gravity_work + integrator_work - damping_loss - lock_loss -
/// latch_damping_loss - member_damping_loss.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Energy {
    /// Work of the motors: motor tension times the cable length reeled in.
    pub motor_work_j: f64,
    /// Work of the cable segments on the structure (motor work minus pulley friction).
    pub cable_work_j: f64,
    pub friction_loss_j: f64,
    pub damping_loss_j: f64,
    pub lock_loss_j: f64,
    pub gravity_work_j: f64,
    /// Energy the dampers of compliant latches took (J).
    pub latch_damping_loss_j: f64,
    /// Elastic energy held in engaged compliant latches now (J).
    pub latch_spring_energy_j: f64,
    /// Elastic energy compliant elements (`Constraint::spring`) gained since
    /// the start (J); their dampers' loss is in `damping_loss_j`.
    pub element_spring_energy_j: f64,
    /// Elastic energy held in elastic members now, 1/2 sum c_i lambda_i^2
    /// (J; `SolverSettings::elastic_members`).
    pub member_strain_energy_j: f64,
    /// Energy elastic members' dampers took (J; `SolverSettings::elastic_members`).
    pub member_damping_loss_j: f64,
    /// Kinetic energy the backward-Euler steps (`blend_change_rel`) gained
    /// beyond the forces' trapezoid work, (h/2) (A_{n+1} - A_n)^T M Vbar
    /// per such step (J; 0 when every step is the average acceleration's).
    pub integrator_work_j: f64,
}

impl Energy {
    /// |kinetic - (work in - losses)| divided by the largest energy that flowed.
    pub fn balance_rel_error(&self, kinetic_j: f64) -> f64 {
        let net = self.cable_work_j + self.gravity_work_j + self.integrator_work_j
            - self.damping_loss_j
            - self.lock_loss_j
            - self.latch_damping_loss_j
            - self.latch_spring_energy_j
            - self.element_spring_energy_j
            - self.member_strain_energy_j
            - self.member_damping_loss_j;
        (kinetic_j - net).abs() / self.scale_j(kinetic_j)
    }

    /// The energy the balance is measured against (J): the largest of the
    /// motor's and gravity's work, the kinetic energy and the compliant
    /// elements' elastic energy (which flowed too).
    pub fn scale_j(&self, kinetic_j: f64) -> f64 {
        self.motor_work_j
            .abs()
            .max(self.gravity_work_j.abs())
            .max(kinetic_j)
            .max(self.element_spring_energy_j.abs())
            .max(1e-300)
    }
}

/// Everything a step carries to the next, as MuJoCo's mjData: written only
/// by the stages of `Simulator::step` (each field names the one that writes
/// it) and by the caller's commands, read by the next step. With the
/// solver's counters and the backends' kept factorizations it makes a
/// `Snapshot` (`Simulator::save`, `restore`): a run continued from one is
/// the run that never stopped, to the bit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct State {
    /// Time (s). `ledger::accept` (each sub-step), `step` (its end).
    pub t_s: f64,
    /// Joint positions, velocities and accelerations (m, m/s, m/s^2; 3 per
    /// joint). `ledger::accept` (the trial's), the latch's velocity jump
    /// (`impact::lock_rigidly`), a motor's engagement (`v`), a restart (`a`).
    pub x: Vec<f64>,
    pub v: Vec<f64>,
    pub a: Vec<f64>,
    /// Per element; only lockable elements ever become true. `impact`.
    pub locked: Vec<bool>,
    /// Motor-end tension commanded per cable (N); a speed-controlled motor
    /// released to its limit or slack holds that tension here. Commands
    /// (`set_cable_tension`, `set_cable_speed`), `motor` (releases).
    pub cable_tension_cmd_n: Vec<f64>,
    /// Per cable, its motor's mode (tension or speed control). Commands, `motor`.
    pub motors: Vec<MotorState>,
    /// Per cable, the last evaluation: segment lengths and tensions (the
    /// motor's tension is `segment_tension_n[0]`), wraps, sliding speeds.
    /// `ledger::accept`, a restart.
    pub cables: Vec<CableEval>,
    /// Lagrange multipliers of the active rows (row order of the current Jacobian).
    /// With redundant rows the split is statically indeterminate: the dense
    /// solver gives the minimum-norm one, the sparse solver one that leaves the
    /// rows it found redundant at zero (both give the same joint forces A^T lambda).
    /// `Simulator::least_work_multipliers` gives the least-work split with
    /// either (what the node publishes as sleeve forces). `ledger::accept`, a restart.
    pub lambda: Vec<f64>,
    /// The energy ledger. `ledger`, `impact` (latch losses), `motor` (an engagement's jump).
    pub energy: Energy,
    /// Latch events so far, in order. `impact`.
    pub locks: Vec<LockEvent>,
    /// Compliant latches engaged and not yet settled (rigid). `impact`, `ledger::accept`.
    pub transients: Vec<LatchTransient>,
    /// Largest |Phi| seen after any step (m). `ledger::accept`.
    pub max_violation_m: f64,
    /// Mechanisms (3n - rank A) of the current constraint set, at the last check. `impact`.
    pub mechanisms: usize,
    /// Deployed, and when (s). `impact`.
    pub deployed: bool,
    pub deploy_time_s: Option<f64>,
    /// Steps taken. `step`.
    pub steps: u64,
    /// A free-floating model's momenta at the start, held by the stage
    /// `momentum`, and what that stage removed; None where the model is not
    /// free-floating or `momentum_projection` is off. `Simulator::initialize`
    /// (the start), `momentum::hold` (each accepted sub-step).
    #[serde(default)]
    pub momentum: Option<HeldMomentum>,
    /// What the integrator carries from a sub-step to the next.
    pub carry: Carry,
}

/// What the integrator carries from one sub-step to the next beside the
/// physical state (part of `State`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Carry {
    /// The Newmark predictor's history. `ledger::accept` (push), a latch, a
    /// motor's change or a reset (forget), a command's restart (shift).
    pub accel_history: AccelHistory,
    /// The last Newmark trial needed Newton steps: the next starts them at
    /// once. `integrator::newmark_iterate` (every trial, accepted or not).
    pub newton_last: bool,
    /// Elastic members: backward-Euler sub-steps still to take after a
    /// restart (docs/solver.md, Elastic members, Restarts). Set by every
    /// restart (`consistent_accelerations`), counted down by `ledger::accept`.
    pub restart_substeps_left: usize,
    /// Per cable, the pulley sliding speeds a friction-blend entry is judged
    /// from (`friction_blend_entered`): a trial's start, or, while
    /// `blend_start_held`, the restart's, held through the sub-step after the
    /// restart's backward-Euler ones. `integrator::newmark` (not held),
    /// `ledger::accept` (held), a restart (released).
    pub blend_start: Vec<Vec<f64>>,
    pub blend_start_held: bool,
    /// Elastic members: the members' joint forces A^T lambda at the state
    /// (N), whose trapezoid work the ledger books. A restart, `ledger::accept`.
    pub member_force_n: Vec<f64>,
    /// Rigid members: compliant latches reached while others engage, along
    /// which the structure cannot move; they latch rigid once the transients
    /// are over. `impact::latch` (adds), `impact::latch_waiting` (empties).
    pub waiting: Vec<WaitingLatch>,
    /// A cable command changed since the state's accelerations were computed:
    /// the next step restarts from A(t_n+). Commands (set), `step` (cleared).
    pub command_changed: bool,
    /// The last trial that made energy and was halved: the ledger gate's
    /// memory of whether halving helps. The ledger gate (`trial_ledger`).
    pub made_energy_halved: Option<MadeEnergyHalving>,
}

/// A compliant latch waiting for the others' transients (`Carry::waiting`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct WaitingLatch {
    pub element: usize,
    /// When it reached its lock (s).
    pub reached_s: f64,
    /// The sign of its gap before it reached its lock (0 if unknown).
    pub side: f64,
}

/// A free-floating model's total momenta as held (`State::momentum`): the
/// start's, and the corrections made to keep them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct HeldMomentum {
    /// P = sum m v (N s) and L = sum m (x - c) x v about the centre of mass
    /// c (N m s), at the start.
    pub linear_n_s: [f64; 3],
    pub angular_n_m_s: [f64; 3],
    /// Sub-steps corrected, and the sums and largest of the corrections'
    /// sizes |P_0 - P| (N s) and |L_0 - L| (N m s): the integrator's own
    /// drift, which the correction takes out.
    pub corrections: u64,
    pub linear_removed_n_s: f64,
    pub angular_removed_n_m_s: f64,
    pub largest_angular_n_m_s: f64,
    /// The kinetic energy the corrections changed in all (J): second order
    /// in their size, -1/2 (|dP|^2 / M + dL^T I^-1 dL) from a state at
    /// its start's momenta.
    pub kinetic_change_j: f64,
}

/// A trial sub-step that made energy and was halved (`Carry::made_energy_halved`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MadeEnergyHalving {
    pub h_s: f64,
    pub miss_j: f64,
}

/// The accelerations at the starts of the last accepted sub-steps, newest
/// first (A_{n-1} .. A_{n-4}), and those sub-steps' lengths (None: no
/// extrapolation across a velocity jump, a latch or a reset).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct AccelHistory {
    pub a: [Vec<f64>; 4],
    pub h: [Option<f64>; 4],
}

impl AccelHistory {
    pub fn new(n: usize) -> AccelHistory {
        AccelHistory {
            a: std::array::from_fn(|_| vec![0.0; n]),
            h: [None; 4],
        }
    }

    /// After an accepted sub-step of length h that started from `a`.
    pub fn push(&mut self, a: &[f64], h: f64) {
        self.a.rotate_right(1);
        self.h.rotate_right(1);
        self.a[0].copy_from_slice(a);
        self.h[0] = Some(h);
    }

    /// No extrapolation across what just happened.
    pub fn forget(&mut self) {
        self.h[0] = None;
    }

    /// A command's jump of the accelerations from `before` to `after`,
    /// which persists: every entry shifted by it.
    pub fn shift(&mut self, before: &[f64], after: &[f64]) {
        for a in &mut self.a {
            for ((a, b), c) in a.iter_mut().zip(before).zip(after) {
                *a += c - b;
            }
        }
    }
}

impl State {
    /// The model at rest at t = 0, before the simulator settles it: its
    /// initial positions, the cables at their model tensions under tension
    /// control, nothing latched.
    pub fn at_rest(model: &Model) -> State {
        let n = model.n_coords();
        State {
            t_s: 0.0,
            x: model.x0.clone(),
            v: vec![0.0; n],
            a: vec![0.0; n],
            locked: vec![false; model.elements.len()],
            cable_tension_cmd_n: model.cables.iter().map(|c| c.tension_n).collect(),
            motors: model
                .cables
                .iter()
                .map(|c| MotorState {
                    speed_cmd_m_s: None,
                    hold: MotorHold::Tension,
                    length_ref_m: c.length_m(&model.x0),
                    tension_cmd_n: c.tension_n,
                })
                .collect(),
            cables: model.cables.iter().map(CableEval::for_cable).collect(),
            lambda: Vec::new(),
            energy: Energy::default(),
            locks: Vec::new(),
            transients: Vec::new(),
            max_violation_m: 0.0,
            mechanisms: 0,
            deployed: false,
            deploy_time_s: None,
            steps: 0,
            momentum: None,
            carry: Carry {
                accel_history: AccelHistory::new(n),
                blend_start: model
                    .cables
                    .iter()
                    .map(|c| vec![0.0; c.path.len().saturating_sub(2)])
                    .collect(),
                member_force_n: vec![0.0; n],
                ..Carry::default()
            },
        }
    }

    /// Whether every vector has the model's size (a snapshot to restore):
    /// else the first that does not, as an error.
    pub fn check_sizes(&self, model: &Model) -> Result<(), super::SolverError> {
        let n = model.n_coords();
        let (ne, nc) = (model.elements.len(), model.cables.len());
        let rows = |locked: &[bool]| -> usize {
            (model.elements.iter().zip(locked))
                .map(|(el, &l)| el.rows(l))
                .sum()
        };
        let mut sizes = vec![
            ("x", self.x.len(), n),
            ("v", self.v.len(), n),
            ("a", self.a.len(), n),
            ("locked", self.locked.len(), ne),
            ("cable_tension_cmd_n", self.cable_tension_cmd_n.len(), nc),
            ("motors", self.motors.len(), nc),
            ("cables", self.cables.len(), nc),
            ("carry.member_force_n", self.carry.member_force_n.len(), n),
            ("carry.blend_start", self.carry.blend_start.len(), nc),
        ];
        if self.locked.len() == ne {
            sizes.push(("lambda", self.lambda.len(), rows(&self.locked)));
        }
        for (k, a) in self.carry.accel_history.a.iter().enumerate() {
            let field = [
                "accel_history.a[0]",
                "accel_history.a[1]",
                "accel_history.a[2]",
                "accel_history.a[3]",
            ][k];
            sizes.push((field, a.len(), n));
        }
        let elements = self.transients.iter().map(|t| t.element);
        let bad_element = elements
            .chain(self.locks.iter().map(|l| l.element))
            .chain(self.carry.waiting.iter().map(|w| w.element))
            .find(|&e| e >= ne);
        let bad_event = self.transients.iter().any(|t| t.event >= self.locks.len());
        if bad_element.is_some() || bad_event {
            return Err(super::SolverError::Request(
                super::RequestError::SnapshotIndex {
                    element: bad_element,
                    elements: ne,
                },
            ));
        }
        match sizes.into_iter().find(|(_, len, expected)| len != expected) {
            Some((field, len, expected)) => Err(super::SolverError::Request(
                super::RequestError::SnapshotSize {
                    field,
                    len,
                    expected,
                },
            )),
            None => Ok(()),
        }
    }

    pub fn kinetic_energy_j(&self, model: &Model) -> f64 {
        kinetic_energy_j(model, &self.v)
    }
    /// Max distance of any joint from the reference, over the largest reference dimension.
    pub fn final_error_rel(&self, model: &Model) -> Option<f64> {
        let r = model.reference.as_ref()?;
        let size = model.reference_size_m()?;
        let worst = (0..model.n_joints())
            .map(|j| {
                ((0..3)
                    .map(|k| (self.x[3 * j + k] - r[3 * j + k]).powi(2))
                    .sum::<f64>())
                .sqrt()
            })
            .fold(0.0, f64::max);
        Some(worst / size)
    }
    /// Progress of the deployment in [0, 1]: 1 - d(t)/d(0), with d the RMS distance of
    /// the joints from the reference deployed geometry; without a reference, the
    /// fraction of latches engaged.
    pub fn deploy_fraction(&self, model: &Model) -> f64 {
        let Some(r) = model.reference.as_ref() else {
            return if model.locks.is_empty() {
                0.0
            } else {
                self.locks_engaged(model) as f64 / model.locks.len() as f64
            };
        };
        let rms = |x: &[f64]| {
            (x.iter().zip(r).map(|(a, b)| (a - b).powi(2)).sum::<f64>() / x.len().max(1) as f64)
                .sqrt()
        };
        let d0 = rms(&model.x0);
        if d0 == 0.0 {
            return 1.0;
        }
        (1.0 - rms(&self.x) / d0).clamp(0.0, 1.0)
    }

    /// The motor's tension on cable `ci` (N): the commanded one, or under
    /// speed control the one that holds the speed.
    pub fn motor_tension_n(&self, ci: usize) -> f64 {
        self.cables[ci].segment_tension_n[0]
    }

    /// The cable length cable `ci`'s motor reeled in since the start (m;
    /// negative where it paid out): L(X0) - L(X).
    pub fn reeled_in_m(&self, model: &Model, ci: usize) -> f64 {
        let c = &model.cables[ci];
        c.length_m(&model.x0) - c.length_m(&self.x)
    }

    /// The cable's reel-in rate -Ldot (m/s).
    pub fn reel_in_rate_m_s(&self, model: &Model, ci: usize) -> f64 {
        -model.cables[ci].length_rate(&self.x, &self.v)
    }

    pub fn locks_engaged(&self, model: &Model) -> usize {
        model.locks.iter().filter(|&&e| self.locked[e]).count()
    }
}

/// Kinetic energy 1/2 sum m_i v_i^2 of the velocities `v` (J).
pub fn kinetic_energy_j(model: &Model, v: &[f64]) -> f64 {
    0.5 * v
        .iter()
        .zip(&model.mass)
        .map(|(v, m)| m * v * v)
        .sum::<f64>()
}

/// A simulation's complete state (`Simulator::save`): restored into a
/// simulator of the same model (`Simulator::restore`), the run goes on as the
/// one that never stopped, to the bit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Snapshot {
    /// The model it belongs to, checked by `restore`.
    pub model: ModelKey,
    pub state: State,
    /// The solver's counters so far.
    pub solver_stats: super::stats::SolverStats,
    /// The stepping backend's kept factorizations, as the inputs they were
    /// made from (`restore` makes them again).
    pub kept: super::linsolve::Kept,
}

/// What identifies a model to a snapshot: its name and sizes.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ModelKey {
    pub name: String,
    pub coordinates: usize,
    pub elements: usize,
    pub cables: usize,
}

impl ModelKey {
    pub fn of(model: &Model) -> ModelKey {
        ModelKey {
            name: model.name.clone(),
            coordinates: model.n_coords(),
            elements: model.elements.len(),
            cables: model.cables.len(),
        }
    }
}
