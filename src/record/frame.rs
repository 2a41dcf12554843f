//! One recorded instant of a run ([`Frame`]) and the names and topology it
//! is laid out by ([`FrameLayout`], built once from the model).
//!
//! Members are the two-joint elements whose one row is a member's length:
//! bars (`bar`) and sleeves (`sleeve`). Their axial force T is tension
//! positive. The solver's multiplier of such a row is minus its tension
//! (Phi = |X_b - X_a| - L, joint forces -A^T lambda), so T = -lambda:
//!
//! - elastic members (`[solver] elastic_members`): the state's multipliers,
//!   those the step solved and the ledger books, which hold
//!   Phi + tau Phidot + c lambda = 0 with c = L / EA, i.e.
//!   T = EA (l - L) / L + tau EA ldot / L (Kelvin-Voigt: the stretch and its
//!   relaxation time `member_relaxation_s`);
//! - rigid members: the least-work multipliers
//!   (`Simulator::least_work_multipliers`), the split of the state's joint
//!   forces A^T lambda among redundant rows that minimizes
//!   sum L_i / (EA_i) lambda_i^2, independent of the linear solver (what the
//!   node publishes); where that split fails, the solver's own (`least_work`
//!   false in the frame);
//! - a sleeve whose compliant latch engages (a spring-damper transient): the
//!   latch's force T = k (l - L_lock) + c ldot (`Simulator::latch_spring_force_n`);
//! - a sleeve sliding free: 0 (it carries no axial load).

use crate::solver::model::Model;
use crate::solver::state::{Energy, MotorHold};
use crate::solver::Simulator;

/// What a member is: its element kind (`MemberKind::code` in the ParaView
/// series' `kind` array).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MemberKind {
    /// `bar`: a member of fixed length (rigid, or elastic along its axis).
    Bar,
    /// `sleeve`: a telescoping member that slides until it latches.
    Sleeve,
}

impl MemberKind {
    /// 0 bar, 1 sleeve.
    pub fn code(self) -> i32 {
        match self {
            MemberKind::Bar => 0,
            MemberKind::Sleeve => 1,
        }
    }
    pub fn label(self) -> &'static str {
        match self {
            MemberKind::Bar => "bar",
            MemberKind::Sleeve => "sleeve",
        }
    }
}

/// A latch's state at a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LatchState {
    /// Not reached its lock yet: the sleeve slides.
    Open,
    /// Latched: its row holds the sleeve's length.
    Latched,
    /// A compliant latch engaged, its spring-damper transient not yet settled.
    Engaging,
}

impl LatchState {
    /// 0 open, 1 latched, 2 engaging (in the Parquet `state` columns and the
    /// ParaView series' `latch_state`, where -1 is a member that is no latch).
    pub fn code(self) -> i32 {
        match self {
            LatchState::Open => 0,
            LatchState::Latched => 1,
            LatchState::Engaging => 2,
        }
    }
}

/// A member of the layout.
#[derive(Clone, Debug, PartialEq)]
pub struct MemberInfo {
    pub name: String,
    /// Its element (index in `Model::elements`).
    pub element: usize,
    /// Its end joints (indices in `Model::joints`).
    pub joints: [usize; 2],
    pub kind: MemberKind,
    /// Its latch (index in `FrameLayout::latches`), for a lockable sleeve.
    pub latch: Option<usize>,
}

/// A drive cable of the layout: its name and how many segments it has
/// (motor to first pulley, then after each pulley: path length - 1).
#[derive(Clone, Debug, PartialEq)]
pub struct CableInfo {
    pub name: String,
    pub segments: usize,
}

/// A latch of the layout (a lockable element, `Model::locks`).
#[derive(Clone, Debug, PartialEq)]
pub struct LatchInfo {
    pub name: String,
    pub element: usize,
}

/// The names and topology frames are laid out by, from the model.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameLayout {
    pub joints: Vec<String>,
    /// Lumped mass per joint (kg).
    pub joint_mass_kg: Vec<f64>,
    pub members: Vec<MemberInfo>,
    pub cables: Vec<CableInfo>,
    pub latches: Vec<LatchInfo>,
    /// The rigid bodies (a spacecraft bus) and the centre of mass, at the
    /// model's initial geometry: attitudes and momenta are taken from it.
    pub bodies: super::bodies::Bodies,
}

impl FrameLayout {
    pub fn new(m: &Model) -> FrameLayout {
        let latches: Vec<LatchInfo> = m
            .locks
            .iter()
            .map(|&e| LatchInfo {
                name: m.elements[e].name().to_string(),
                element: e,
            })
            .collect();
        let members = m
            .elements
            .iter()
            .enumerate()
            .filter_map(|(e, el)| {
                let kind = match el.kind() {
                    "bar" => MemberKind::Bar,
                    "sleeve" => MemberKind::Sleeve,
                    _ => return None,
                };
                let js = el.joints();
                (js.len() == 2).then(|| MemberInfo {
                    name: el.name().to_string(),
                    element: e,
                    joints: [js[0], js[1]],
                    kind,
                    latch: latches.iter().position(|l| l.element == e),
                })
            })
            .collect();
        FrameLayout {
            joints: m.joints.iter().map(|j| j.name.clone()).collect(),
            joint_mass_kg: m.joints.iter().map(|j| j.mass_kg).collect(),
            members,
            cables: m
                .cables
                .iter()
                .map(|c| CableInfo {
                    name: c.name.clone(),
                    segments: c.path.len().saturating_sub(1),
                })
                .collect(),
            latches,
            bodies: super::bodies::Bodies::of(m, &m.x0),
        }
    }
}

/// One recorded instant of a run.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    /// Simulated time (s) and steps taken.
    pub t_s: f64,
    pub step: u64,
    /// Joint positions and velocities (m, m/s; x, y, z per joint).
    pub x: Vec<f64>,
    pub v: Vec<f64>,
    /// Per member (layout order): axial force (N, tension positive; see the
    /// module's head for where it comes from) and length |X_b - X_a| (m).
    pub member_force_n: Vec<f64>,
    pub member_length_m: Vec<f64>,
    /// Rigid members' forces are the least-work split (false: that split
    /// failed at this state, they are the solver's own).
    pub least_work: bool,
    /// Per cable, the tension of each segment (N): where it leaves the motor
    /// (`[0]`, the motor's tension), then after each pulley.
    pub cable_tension_n: Vec<Vec<f64>>,
    /// Per cable: its length (m), the cable reeled in since the start (m),
    /// the motor's mode.
    pub cable_length_m: Vec<f64>,
    pub reeled_in_m: Vec<f64>,
    pub motor_mode: Vec<MotorHold>,
    /// Per latch: lock gap g = l - L_lock (m, 0 latched), state, the force
    /// through it (N, tension positive: its member's axial force), and the
    /// peak force of its compliant latch so far with its time, as the solver
    /// located it inside the sub-steps (`LockEvent::peak_force_n`; None
    /// before it engages, and for rigid latches).
    pub latch_gap_m: Vec<f64>,
    pub latch_state: Vec<LatchState>,
    pub latch_force_n: Vec<f64>,
    pub latch_peak_force_n: Vec<Option<f64>>,
    pub latch_time_of_peak_s: Vec<Option<f64>>,
    /// The energy ledger (J), the kinetic energy (J) and the balance's
    /// relative error (`Energy::balance_rel_error`).
    pub energy: Energy,
    pub kinetic_energy_j: f64,
    pub balance_rel_error: f64,
    /// Per rigid body (`FrameLayout::bodies`): its rotation from the
    /// model's initial geometry and its rate; the system's linear and
    /// angular momentum (about the initial centre of mass).
    pub bodies: super::bodies::BodiesNow,
}

/// The axial force through a two-joint element (N, tension positive) given
/// the multipliers `lambda` (the Jacobian's row order): T = -lambda of its
/// first row where it has rows; an engaging compliant latch's force; None
/// where it has neither (a sleeve sliding free).
pub fn axial_force_n(sim: &Simulator, lambda: &[f64], element: usize) -> Option<f64> {
    let locked = sim.state().locked.get(element).copied().unwrap_or(false);
    let is_lockable = sim.model().locks.contains(&element);
    if !is_lockable || locked {
        if let Some(l) = sim
            .jacobian()
            .first_row_of(element)
            .and_then(|r| lambda.get(r))
        {
            return Some(-l);
        }
    }
    sim.latch_spring_force_n(element)
}

/// The multipliers members' forces are read from (see the module's head):
/// the state's with elastic members, else the least-work split (the state's
/// where it fails: then false).
pub fn member_multipliers(sim: &mut Simulator) -> (Vec<f64>, bool) {
    if sim.model().solver.elastic_members {
        return (sim.state().lambda.clone(), true);
    }
    match sim.least_work_multipliers() {
        Ok(l) => (l, true),
        Err(_) => (sim.state().lambda.clone(), false),
    }
}

impl Frame {
    /// The frame of `sim`'s current state. (`&mut`: the least-work split
    /// solves on the simulator's own buffers; the trajectory does not
    /// depend on it.)
    pub fn capture(layout: &FrameLayout, sim: &mut Simulator) -> Frame {
        let (lambda, least_work) = member_multipliers(sim);
        let (m, s) = (sim.model(), sim.state());
        let dist = |[a, b]: [usize; 2]| {
            let d = [0, 1, 2].map(|k| s.x[3 * b + k] - s.x[3 * a + k]);
            (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
        };
        let member_force_n: Vec<f64> = layout
            .members
            .iter()
            .map(|mb| axial_force_n(sim, &lambda, mb.element).unwrap_or(0.0))
            .collect();
        let latch_state = layout
            .latches
            .iter()
            .map(|l| {
                if s.transients.iter().any(|t| t.element == l.element) {
                    LatchState::Engaging
                } else if s.locked[l.element] {
                    LatchState::Latched
                } else {
                    LatchState::Open
                }
            })
            .collect();
        let event = |e: usize| s.locks.iter().find(|ev| ev.element == e);
        let ke = s.kinetic_energy_j(m);
        let bodies = layout.bodies.now(m, &s.x, &s.v);
        Frame {
            t_s: s.t_s,
            step: s.steps,
            x: s.x.clone(),
            v: s.v.clone(),
            member_length_m: layout.members.iter().map(|mb| dist(mb.joints)).collect(),
            member_force_n,
            least_work,
            cable_tension_n: s
                .cables
                .iter()
                .map(|c| c.segment_tension_n.clone())
                .collect(),
            cable_length_m: s.cables.iter().map(|c| c.length_m).collect(),
            reeled_in_m: (0..m.cables.len()).map(|ci| s.reeled_in_m(m, ci)).collect(),
            motor_mode: s.motors.iter().map(|mo| mo.hold).collect(),
            latch_gap_m: layout
                .latches
                .iter()
                .map(|l| {
                    if s.locked[l.element] {
                        0.0
                    } else {
                        m.lock_gap_m(l.element, &s.x)
                    }
                })
                .collect(),
            latch_state,
            latch_force_n: layout
                .latches
                .iter()
                .map(|l| axial_force_n(sim, &lambda, l.element).unwrap_or(0.0))
                .collect(),
            latch_peak_force_n: layout
                .latches
                .iter()
                .map(|l| event(l.element).and_then(|ev| ev.peak_force_n))
                .collect(),
            latch_time_of_peak_s: layout
                .latches
                .iter()
                .map(|l| event(l.element).and_then(|ev| ev.time_of_peak_s))
                .collect(),
            energy: s.energy.clone(),
            kinetic_energy_j: ke,
            balance_rel_error: s.energy.balance_rel_error(ke),
            bodies,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::Options;

    fn bundled(name: &str) -> Simulator {
        let path = format!("{}/../../models/{name}", env!("CARGO_MANIFEST_DIR"));
        let model = crate::model::load(std::path::Path::new(&path))
            .expect("bundled model")
            .model;
        Simulator::new(model, Options::default()).expect("simulator")
    }

    /// The ring's layout: every bar and sleeve a member with its two joints,
    /// every sleeve a latch, each cable's segments one fewer than its path.
    #[test]
    fn ring_layout_counts_members_latches_and_segments() {
        let sim = bundled("double_ring.toml");
        let m = sim.model();
        let layout = FrameLayout::new(m);
        let count = |k: &str| m.elements.iter().filter(|e| e.kind() == k).count();
        assert_eq!(layout.members.len(), count("bar") + count("sleeve"));
        assert_eq!(layout.latches.len(), m.locks.len());
        for mb in &layout.members {
            let el = &m.elements[mb.element];
            assert_eq!(el.name(), mb.name);
            assert_eq!(el.joints(), &mb.joints[..]);
            assert_eq!(mb.latch.is_some(), m.locks.contains(&mb.element));
        }
        for (c, info) in m.cables.iter().zip(&layout.cables) {
            assert_eq!(info.segments + 1, c.path.len());
        }
    }

    /// Elastic members (the ring): a bar's recorded force is its
    /// Kelvin-Voigt law T = ((l - L) + tau ldot) / c, c = L / EA, at the
    /// state, to the accuracy the step holds that law; the frame's lengths
    /// are the joints' distances, its balance error the ledger's.
    #[test]
    fn elastic_member_force_is_its_stretch_law() {
        let mut sim = bundled("double_ring.toml");
        for _ in 0..40 {
            sim.step(0.05).expect("step");
        }
        let layout = FrameLayout::new(sim.model());
        let f = Frame::capture(&layout, &mut sim);
        let (m, s) = (sim.model(), sim.state());
        let tau = m.solver.member_relaxation_s;
        let mut largest = 0.0f64;
        let mut worst = 0.0f64;
        for (k, mb) in layout.members.iter().enumerate() {
            if mb.kind != MemberKind::Bar {
                continue;
            }
            let el = &m.elements[mb.element];
            let mut c = [0.0];
            el.row_compliance_m_per_n(false, m.axial_stiffness_n, &mut c);
            let (mut phi, mut phi_h) = ([0.0], [0.0]);
            el.residual(&s.x, &mut phi);
            let h = 1e-7;
            let xh: Vec<f64> = s.x.iter().zip(&s.v).map(|(x, v)| x + h * v).collect();
            el.residual(&xh, &mut phi_h);
            let law = (phi[0] + tau * (phi_h[0] - phi[0]) / h) / c[0];
            largest = largest.max(law.abs());
            worst = worst.max((f.member_force_n[k] - law).abs());
            let [a, b] = mb.joints;
            let d: f64 = (0..3)
                .map(|i| (s.x[3 * b + i] - s.x[3 * a + i]).powi(2))
                .sum::<f64>()
                .sqrt();
            assert_eq!(f.member_length_m[k], d);
        }
        assert!(largest > 0.0, "the drive loads the bars");
        assert!(
            worst <= 1e-3 * largest,
            "recorded forces off the stretch law by {worst} N (largest {largest} N)"
        );
        assert_eq!(
            f.balance_rel_error,
            s.energy.balance_rel_error(f.kinetic_energy_j)
        );
    }

    /// Rigid members (the deployed mast, its four sleeves latched together):
    /// the sleeves' forces are the least-work split, each sleeve a share,
    /// whichever solver ran; the latches' forces are their members'.
    #[test]
    fn latched_mast_sleeves_share_by_least_work() {
        let mut sim = bundled("pantograph_mast.toml");
        while !sim.state().deployed {
            sim.step(0.05).expect("step");
        }
        let layout = FrameLayout::new(sim.model());
        let f = Frame::capture(&layout, &mut sim);
        assert!(f.least_work);
        assert_eq!(layout.members.len(), 4);
        let total: f64 = f.member_force_n.iter().sum();
        assert!(total.abs() > 0.0);
        for (k, mb) in layout.members.iter().enumerate() {
            assert!(
                f.member_force_n[k].abs() > 0.1 * total.abs(),
                "{:?}",
                f.member_force_n
            );
            let l = mb.latch.expect("every sleeve latches");
            assert_eq!(f.latch_force_n[l], f.member_force_n[k]);
            assert_eq!(f.latch_state[l], LatchState::Latched);
            assert_eq!(f.latch_gap_m[l], 0.0);
            assert!(f.latch_peak_force_n[l].is_some());
        }
    }
}
