//! What a step changes: time, positions, velocities, accelerations, the locked
//! set, cable commands and readings, member forces, the energy ledger and the
//! lock events so far.

use super::cable::CableEval;
use super::model::Model;

/// One sleeve latching: when, how hard, and the kinetic energy the inelastic
/// latch took out of the structure.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
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
#[derive(Clone, Debug, PartialEq)]
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
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
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
#[derive(Clone, Debug, PartialEq)]
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
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
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

#[derive(Clone, Debug)]
pub struct State {
    pub t_s: f64,
    pub x: Vec<f64>,
    pub v: Vec<f64>,
    pub a: Vec<f64>,
    /// Per element; only lockable elements ever become true.
    pub locked: Vec<bool>,
    /// Motor-end tension commanded per cable (N); a speed-controlled motor
    /// released to its limit or slack holds that tension here.
    pub cable_tension_cmd_n: Vec<f64>,
    /// Per cable, its motor's mode (tension or speed control).
    pub motors: Vec<MotorState>,
    /// Per cable, the last evaluation: segment lengths and tensions (the
    /// motor's tension is `segment_tension_n[0]`), wraps, sliding speeds.
    pub cables: Vec<CableEval>,
    /// Lagrange multipliers of the active rows (row order of the current Jacobian).
    /// With redundant rows the split is statically indeterminate: the dense
    /// solver gives the minimum-norm one, the sparse solver one that leaves the
    /// rows it found redundant at zero (both give the same joint forces A^T lambda).
    /// `Simulator::least_work_multipliers` gives the least-work split with
    /// either (what the node publishes as sleeve forces).
    pub lambda: Vec<f64>,
    pub energy: Energy,
    pub locks: Vec<LockEvent>,
    /// Compliant latches engaged and not yet settled (rigid).
    pub transients: Vec<LatchTransient>,
    /// Largest |Phi| seen after any step (m).
    pub max_violation_m: f64,
    /// Mechanisms (3n - rank A) of the current constraint set, at the last check.
    pub mechanisms: usize,
    pub deployed: bool,
    pub deploy_time_s: Option<f64>,
    pub steps: u64,
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
