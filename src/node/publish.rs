//! Building the published messages from the simulator state.

use super::commands::CommandBook;
use super::msgs::*;
use super::Distro;
use crate::solver::model::Model;
use crate::solver::state::MotorHold;
use crate::solver::Simulator;
use ros2_client::builtin_interfaces::Time;
use ros2_client::{MessageTypeName, Name, Node, Publisher};

#[derive(Clone, Debug)]
enum MJoint {
    /// Scissor hinge: rods (i, j) and (k, l).
    Hinge([usize; 4]),
    /// Sleeve: element.
    Slide(usize),
    /// A drive cable's motor: cable index.
    Motor(usize),
}

/// Static view of the model: which elements become /joint_states entries and
/// which joint pairs are drawn as members.
pub struct View {
    names: Vec<String>,
    joints: Vec<MJoint>,
    joint_names: Vec<String>,
    /// (joint a, joint b, sleeve element if the member is a sleeve)
    members: Vec<(usize, usize, Option<usize>)>,
    /// The members that carry an axial force (bars and sleeves,
    /// `record::FrameLayout::members`): (joint a, joint b, element).
    force_members: Vec<(usize, usize, usize)>,
    lock_names: Vec<String>,
    cable_names: Vec<String>,
    /// Publications whose least-work split failed (the solver's own split
    /// was published instead); the first is reported on stderr.
    pub least_work_failures: std::cell::Cell<u64>,
    /// The run checks: a truss rigid short of its reference is not published
    /// as deployed (`checks::jammed`).
    pub checks: crate::solver::checks::RunChecks,
}

fn angle(x: &[f64], r: &[usize; 4]) -> f64 {
    let p = |j: usize| [x[3 * j], x[3 * j + 1], x[3 * j + 2]];
    let (i, j, k, l) = (p(r[0]), p(r[1]), p(r[2]), p(r[3]));
    let a = [j[0] - i[0], j[1] - i[1], j[2] - i[2]];
    let b = [l[0] - k[0], l[1] - k[1], l[2] - k[2]];
    let c = [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ];
    let cn = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
    let d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    cn.atan2(d)
}

/// A motor's actual tension (N): while it tracks a speed, the tension that
/// holds it (`State::motor_tension_n`, of the last step); otherwise the
/// tension it holds by command, at its limit or slack (0), which is what
/// `State::motor_tension_n` gives after the next step, and is already in
/// force while the simulation is paused.
pub fn motor_tension_n(s: &crate::solver::state::State, ci: usize) -> f64 {
    match s.motors[ci].hold {
        MotorHold::Tracking => s.motor_tension_n(ci),
        _ => s.cable_tension_cmd_n[ci],
    }
}

/// A motor's mode on /truss/state: its hold in snake case.
pub fn motor_mode(h: MotorHold) -> &'static str {
    match h {
        MotorHold::Tension => "tension",
        MotorHold::Tracking => "tracking",
        MotorHold::AtLimit => "at_limit",
        MotorHold::Slack => "slack",
    }
}

impl View {
    pub fn new(m: &Model) -> View {
        let mut names = Vec::new();
        let mut joints = Vec::new();
        let mut members = Vec::new();
        for (e, el) in m.elements.iter().enumerate() {
            let js = el.joints();
            // Mechanism joints: a scissor's pivot (revolute), a lockable
            // element (prismatic); members: what the element contributes.
            let lockable = el.lock_gap(&m.x0).is_some();
            if el.kind() == "scissor" && js.len() == 4 {
                names.push(el.name().to_string());
                joints.push(MJoint::Hinge([js[0], js[1], js[2], js[3]]));
            } else if lockable {
                names.push(el.name().to_string());
                joints.push(MJoint::Slide(e));
            }
            for &[a, b] in el.members() {
                members.push((js[a], js[b], lockable.then_some(e)));
            }
        }
        // Each drive cable's motor: a joint whose position is the cable
        // reeled in (m), velocity the reel-in rate (m/s) and effort the motor
        // tension (N), for topic-based ros2_control bridges.
        for (ci, c) in m.cables.iter().enumerate() {
            names.push(format!("{}_motor", c.name));
            joints.push(MJoint::Motor(ci));
        }
        View {
            names,
            joints,
            joint_names: m.joints.iter().map(|j| j.name.clone()).collect(),
            members,
            force_members: crate::record::FrameLayout::new(m)
                .members
                .iter()
                .map(|mb| (mb.joints[0], mb.joints[1], mb.element))
                .collect(),
            lock_names: m
                .locks
                .iter()
                .map(|&e| m.elements[e].name().to_string())
                .collect(),
            cable_names: m.cables.iter().map(|c| c.name.clone()).collect(),
            least_work_failures: std::cell::Cell::new(0),
            checks: crate::solver::checks::RunChecks::default(),
        }
    }

    /// Names on /joint_states: scissor hinges (revolute) and sleeves
    /// (prismatic), then each drive cable's motor as `<cable>_motor`
    /// (prismatic along the cable: see [`Self::joint_state`]).
    pub fn mechanism_joint_names(&self) -> &[String] {
        &self.names
    }

    /// `lambda`: the state's multipliers with redundant rows sharing by least
    /// work (`Simulator::least_work_multipliers`), so that sleeves that
    /// latched together show their stiffness shares of the load whichever
    /// solver runs; a compliant latch shows its spring-damper force while it
    /// engages.
    pub fn joint_state(
        &self,
        sim: &Simulator,
        lambda: &[f64],
        stamp: Time,
        frame: &str,
    ) -> JointState {
        let (m, s) = (sim.model(), sim.state());
        let n = self.joints.len();
        let (mut pos, mut vel, mut eff) = (
            Vec::with_capacity(n),
            Vec::with_capacity(n),
            Vec::with_capacity(n),
        );
        for j in &self.joints {
            match j {
                MJoint::Hinge(r) => {
                    let th = angle(&s.x, r);
                    // d(theta)/dt by a central difference along v
                    let h = 1e-6;
                    let xp: Vec<f64> = s.x.iter().zip(&s.v).map(|(x, v)| x + h * v).collect();
                    let xm: Vec<f64> = s.x.iter().zip(&s.v).map(|(x, v)| x - h * v).collect();
                    pos.push(th);
                    vel.push((angle(&xp, r) - angle(&xm, r)) / (2.0 * h));
                    eff.push(0.0);
                }
                MJoint::Slide(e) => {
                    let (len, rate) = m.elements[*e]
                        .extension(&s.x, &s.v)
                        .unwrap_or((f64::NAN, 0.0));
                    pos.push(len);
                    vel.push(rate);
                    // latched: -lambda of its row; a compliant latch
                    // engaging: the force through it (as the history records)
                    eff.push(crate::record::frame::axial_force_n(sim, lambda, *e).unwrap_or(0.0));
                }
                MJoint::Motor(ci) => {
                    pos.push(s.reeled_in_m(m, *ci));
                    vel.push(s.reel_in_rate_m_s(m, *ci));
                    eff.push(motor_tension_n(s, *ci));
                }
            }
        }
        JointState {
            header: Header {
                stamp,
                frame_id: frame.to_string(),
            },
            name: self.names.clone(),
            position: pos,
            velocity: vel,
            effort: eff,
        }
    }

    /// /joint_states and /truss/state of the current state, as the node
    /// publishes them and the recorder records them: sleeve efforts from the
    /// minimum-norm multipliers once a sleeve has latched (a least-squares
    /// solve; the efforts of sliding sleeves are 0 and need none).
    pub fn state_messages(
        &self,
        sim: &mut Simulator,
        stamp: Time,
        frame: &str,
    ) -> (JointState, TrussState) {
        let shared = (sim.state().locked.iter().any(|&l| l))
            .then(|| sim.least_work_multipliers())
            .and_then(|r| match r {
                Ok(l) => Some(l),
                Err(e) => {
                    let n = self.least_work_failures.get() + 1;
                    self.least_work_failures.set(n);
                    if n == 1 {
                        super::log::node_log!(
                            Warn,
                            "t = {} s: the least-work split of the member forces failed ({e}); \
                             /joint_states efforts are the solver's own split until it succeeds",
                            sim.state().t_s
                        );
                    }
                    None
                }
            });
        let lambda = shared.as_deref().unwrap_or(&sim.state().lambda);
        (
            self.joint_state(sim, lambda, stamp, frame),
            self.truss_state(sim, stamp, frame),
        )
    }

    pub fn truss_state(&self, sim: &Simulator, stamp: Time, frame: &str) -> TrussState {
        let (m, s) = (sim.model(), sim.state());
        let n = m.n_joints();
        TrussState {
            header: Header {
                stamp,
                frame_id: frame.to_string(),
            },
            joint_names: self.joint_names.clone(),
            positions: (0..n)
                .map(|j| Point {
                    x: s.x[3 * j],
                    y: s.x[3 * j + 1],
                    z: s.x[3 * j + 2],
                })
                .collect(),
            velocities: (0..n)
                .map(|j| Vector3 {
                    x: s.v[3 * j],
                    y: s.v[3 * j + 1],
                    z: s.v[3 * j + 2],
                })
                .collect(),
            deploy_fraction: s.deploy_fraction(m),
            remaining_dof: s.mechanisms as u32,
            cable_names: self.cable_names.clone(),
            motor_tensions_n: (0..m.cables.len())
                .map(|ci| motor_tension_n(s, ci))
                .collect(),
            reeled_in_m: (0..m.cables.len()).map(|ci| s.reeled_in_m(m, ci)).collect(),
            motor_modes: s
                .motors
                .iter()
                .map(|mo| motor_mode(mo.hold).into())
                .collect(),
        }
    }

    pub fn lock_status(
        &self,
        sim: &Simulator,
        book: &CommandBook,
        paused: bool,
        stamp: Time,
        frame: &str,
    ) -> LockStatus {
        let (m, s) = (sim.model(), sim.state());
        let k = m.locks.len();
        let (mut time_s, mut imp, mut en) = (vec![-1.0; k], vec![0.0; k], vec![0.0; k]);
        for ev in &s.locks {
            if let Some(i) = m.locks.iter().position(|&e| e == ev.element) {
                time_s[i] = ev.time_s;
                imp[i] = ev.impulse_ns;
                en[i] = ev.energy_lost_j;
            }
        }
        LockStatus {
            header: Header {
                stamp,
                frame_id: frame.to_string(),
            },
            names: self.lock_names.clone(),
            locked: m.locks.iter().map(|&e| s.locked[e]).collect(),
            time_s,
            impulse_ns: imp,
            energy_lost_j: en,
            deployed: s.deployed && crate::solver::checks::jammed(m, s, &self.checks).is_none(),
            paused,
            cable_names: self.cable_names.clone(),
            cable_tensions_n: (0..m.cables.len())
                .map(|ci| motor_tension_n(s, ci))
                .collect(),
            accepted_commands: book.accepted,
            rejected_commands: book.rejected,
            rejected_unknown_cable: book.unknown_cable,
            rejected_mismatched_lengths: book.mismatched_lengths,
            rejected_bad_tension: book.bad_tension,
            rejected_malformed: book.malformed,
            rejected_bad_speed: book.bad_speed,
        }
    }

    /// Members as two LINE_LIST markers: free members and latched sleeves.
    /// The markers: `members` (grey) and `latched_sleeves` (green), and
    /// `member_forces`, the bars and sleeves coloured by axial force T (as
    /// the history records it, `record::frame`): with c = T / max |T| over
    /// them, tension (c > 0) from white to red (1, 1 - c, 1 - c),
    /// compression to blue (1 + c, 1 + c, 1); white where none is loaded.
    /// (`&mut`: rigid members' forces are the least-work split.)
    pub fn markers(&self, sim: &mut Simulator, stamp: Time, frame: &str) -> Vec<MarkerJazzy> {
        let forces: Vec<f64> = if self.force_members.is_empty() {
            Vec::new()
        } else {
            let (lambda, _) = crate::record::frame::member_multipliers(sim);
            self.force_members
                .iter()
                .map(|&(_, _, e)| {
                    crate::record::frame::axial_force_n(sim, &lambda, e).unwrap_or(0.0)
                })
                .collect()
        };
        let s = sim.state();
        let p = |j: usize| Point {
            x: s.x[3 * j],
            y: s.x[3 * j + 1],
            z: s.x[3 * j + 2],
        };
        let (mut free, mut latched) = (Vec::new(), Vec::new());
        for &(a, b, sleeve) in &self.members {
            let locked = sleeve.is_some_and(|e| s.locked.get(e).copied().unwrap_or(false));
            let v = if locked { &mut latched } else { &mut free };
            v.push(p(a));
            v.push(p(b));
        }
        let largest = forces.iter().fold(0.0f64, |m, f| m.max(f.abs()));
        let (mut loaded, mut shades) = (Vec::new(), Vec::new());
        for (&(a, b, _), &f) in self.force_members.iter().zip(&forces) {
            let c = if largest > 0.0 {
                (f / largest) as f32
            } else {
                0.0
            };
            let shade = if c >= 0.0 {
                ColorRGBA {
                    r: 1.0,
                    g: 1.0 - c,
                    b: 1.0 - c,
                    a: 1.0,
                }
            } else {
                ColorRGBA {
                    r: 1.0 + c,
                    g: 1.0 + c,
                    b: 1.0,
                    a: 1.0,
                }
            };
            loaded.extend([p(a), p(b)]);
            shades.extend([shade, shade]);
        }
        let mk = |id: i32, ns: &str, pts: Vec<Point>, color: ColorRGBA| MarkerJazzy {
            header: Header {
                stamp,
                frame_id: frame.to_string(),
            },
            ns: ns.to_string(),
            id,
            type_: 5,  // LINE_LIST
            action: 0, // ADD
            pose: Pose {
                position: Point::default(),
                orientation: Quaternion {
                    x: 0.0,
                    y: 0.0,
                    z: 0.0,
                    w: 1.0,
                },
            },
            scale: Vector3 {
                x: 0.01,
                y: 0.0,
                z: 0.0,
            },
            color,
            lifetime: RosDuration::default(),
            frame_locked: false,
            points: pts,
            colors: Vec::new(),
            texture_resource: String::new(),
            texture: CompressedImage::default(),
            uv_coordinates: Vec::new(),
            text: String::new(),
            mesh_resource: String::new(),
            mesh_file: MeshFile::default(),
            mesh_use_embedded_materials: false,
        };
        let mut by_force = mk(
            2,
            "member_forces",
            loaded,
            ColorRGBA {
                r: 1.0,
                g: 1.0,
                b: 1.0,
                a: 1.0,
            },
        );
        by_force.colors = shades;
        vec![
            mk(
                0,
                "members",
                free,
                ColorRGBA {
                    r: 0.8,
                    g: 0.8,
                    b: 0.85,
                    a: 1.0,
                },
            ),
            mk(
                1,
                "latched_sleeves",
                latched,
                ColorRGBA {
                    r: 0.1,
                    g: 0.9,
                    b: 0.2,
                    a: 1.0,
                },
            ),
            by_force,
        ]
    }
}

/// A key of everything in LockStatus but the header, to publish on change.
pub fn lock_key(m: &LockStatus) -> Vec<u8> {
    let mut k = m.clone();
    k.header = Header::default();
    format!("{k:?}").into_bytes()
}

pub enum MarkerPub {
    Jazzy(Publisher<MarkerArrayJazzy>),
    Galactic(Publisher<MarkerArrayGalactic>),
}

impl MarkerPub {
    pub fn new(node: &mut Node, name: &Name, distro: Distro) -> Result<MarkerPub, String> {
        let t = node
            .create_topic(
                name,
                MessageTypeName::new("visualization_msgs", "MarkerArray"),
                &super::qos::markers(),
            )
            .map_err(|e| format!("create markers: {e:?}"))?;
        Ok(match distro {
            Distro::Jazzy | Distro::Humble => MarkerPub::Jazzy(
                node.create_publisher(&t, None)
                    .map_err(|e| format!("create markers: {e:?}"))?,
            ),
            Distro::Galactic => MarkerPub::Galactic(
                node.create_publisher(&t, None)
                    .map_err(|e| format!("create markers: {e:?}"))?,
            ),
        })
    }

    pub fn publish(&self, view: &View, sim: &mut Simulator, stamp: Time, frame: &str) {
        self.publish_built(view.markers(sim, stamp, frame));
    }

    /// Publishes markers built by [`View::markers`] in this publisher's layout.
    pub fn publish_built(&self, m: Vec<MarkerJazzy>) {
        let _ = match self {
            MarkerPub::Jazzy(p) => p.publish(MarkerArrayJazzy { markers: m }).map_err(|_| ()),
            MarkerPub::Galactic(p) => p
                .publish(MarkerArrayGalactic {
                    markers: m.into_iter().map(Into::into).collect(),
                })
                .map_err(|_| ()),
        };
    }
}

/// The joints `/tf` carries unless `--tf-frames` names others: every post top
/// (a joint named `*_t`, as the ring generators name them) or, with none, the
/// highest joint (greatest z of the reference geometry, else the initial one;
/// the first of equals): a mast's tip.
pub fn default_tf_joints(model: &Model) -> Vec<String> {
    let tops: Vec<String> = model
        .joints
        .iter()
        .filter(|j| j.name.ends_with("_t"))
        .map(|j| j.name.clone())
        .collect();
    if !tops.is_empty() {
        return tops;
    }
    let x = model.reference.as_ref().unwrap_or(&model.x0);
    let mut best: Option<usize> = None;
    for i in 0..model.joints.len() {
        if best.is_none_or(|b| x[3 * i + 2] > x[3 * b + 2]) {
            best = Some(i);
        }
    }
    best.map(|i| vec![model.joints[i].name.clone()])
        .unwrap_or_default()
}

/// The /tf frame of a truss joint: `FRAME/JOINT` (`truss/L4`).
pub fn joint_frame(frame: &str, joint: &str) -> String {
    format!("{frame}/{joint}")
}

/// The indices of the joints named for /tf, or an error naming the unknown one.
pub fn tf_joint_indices(model: &Model, names: &[String]) -> Result<Vec<usize>, String> {
    names
        .iter()
        .map(|n| {
            model
                .joints
                .iter()
                .position(|j| &j.name == n)
                .ok_or_else(|| {
                    let known: Vec<&str> = model.joints.iter().map(|j| j.name.as_str()).collect();
                    format!(
                        "--tf-frames / tf_frames: no joint `{n}` (joints: {})",
                        known.join(", ")
                    )
                })
        })
        .collect()
}

/// /tf: each of `joints` as a frame, child of `frame` (the model frame), at
/// its position, not rotated.
pub fn tf_joints(sim: &Simulator, joints: &[usize], stamp: Time, frame: &str) -> TFMessage {
    let (m, x) = (sim.model(), &sim.state().x);
    TFMessage {
        transforms: joints
            .iter()
            .map(|&j| TransformStamped {
                header: Header {
                    stamp,
                    frame_id: frame.to_string(),
                },
                child_frame_id: joint_frame(frame, &m.joints[j].name),
                transform: Transform {
                    translation: Vector3 {
                        x: x[3 * j],
                        y: x[3 * j + 1],
                        z: x[3 * j + 2],
                    },
                    rotation: Quaternion {
                        w: 1.0,
                        ..Default::default()
                    },
                },
            })
            .collect(),
    }
}

/// /tf_static: the mount, placing the model frame `frame` in `parent` (identity).
pub fn tf_mount(parent: &str, frame: &str, stamp: Time) -> TFMessage {
    TFMessage {
        transforms: vec![TransformStamped {
            header: Header {
                stamp,
                frame_id: parent.to_string(),
            },
            child_frame_id: frame.to_string(),
            transform: Transform {
                rotation: Quaternion {
                    w: 1.0,
                    ..Default::default()
                },
                ..Default::default()
            },
        }],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::node::msgs::sim_stamp;
    use crate::solver::{Options, SolverKind};

    /// The deployed mast's four sleeves latched together (a redundant group):
    /// their published efforts are the least-work shares, the same with
    /// either solver, not the sparse basic split that gives one sleeve the
    /// whole load (0.173 N on S1, 0 on the others).
    #[test]
    fn latched_sleeve_efforts_do_not_depend_on_the_solver() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/pantograph_mast.toml");
        let efforts = |solver: SolverKind| {
            let model = crate::model::load(std::path::Path::new(path))
                .expect("bundled model")
                .model;
            let view = View::new(&model);
            let opts = Options {
                solver,
                ..Options::default()
            };
            let mut sim = Simulator::new(model, opts).expect("simulator");
            while !sim.state().deployed {
                sim.step(0.05).expect("step");
            }
            let lambda = sim.least_work_multipliers().expect("multipliers");
            let js = view.joint_state(&sim, &lambda, sim_stamp(sim.state().t_s), "world");
            let sleeves: Vec<f64> = js
                .name
                .iter()
                .zip(&js.effort)
                .filter(|(n, _)| n.starts_with('S'))
                .map(|(_, &f)| f)
                .collect();
            sleeves
        };
        let (dense, sparse) = (efforts(SolverKind::Dense), efforts(SolverKind::Sparse));
        assert_eq!(dense.len(), 4, "four sleeves published: {dense:?}");
        let total: f64 = dense.iter().sum();
        for (d, s) in dense.iter().zip(&sparse) {
            assert!(*d > 0.1 * total, "each sleeve carries a share: {dense:?}");
            assert!(
                (d - s).abs() <= 1e-6 * total,
                "dense {dense:?} vs sparse {sparse:?}"
            );
        }
    }

    /// The deployed mast's `member_forces` marker: one line per sleeve, each
    /// coloured by the sign and share of its force in the frame the history
    /// records (tension red, compression blue), the most loaded saturated.
    #[test]
    fn member_force_marker_colours_follow_the_recorded_forces() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/pantograph_mast.toml");
        let model = crate::model::load(std::path::Path::new(path))
            .expect("bundled model")
            .model;
        let view = View::new(&model);
        let mut sim = Simulator::new(model, Options::default()).expect("simulator");
        while !sim.state().deployed {
            sim.step(0.05).expect("step");
        }
        let layout = crate::record::FrameLayout::new(sim.model());
        let frame = crate::record::Frame::capture(&layout, &mut sim);
        let stamp = sim_stamp(sim.state().t_s);
        let ms = view.markers(&mut sim, stamp, "world");
        let m = ms.iter().find(|m| m.ns == "member_forces").expect("marker");
        assert_eq!(m.points.len(), 2 * layout.members.len());
        assert_eq!(m.colors.len(), m.points.len());
        let largest = frame
            .member_force_n
            .iter()
            .fold(0.0f64, |a, f| a.max(f.abs()));
        assert!(largest > 0.0);
        for (k, &f) in frame.member_force_n.iter().enumerate() {
            let c = m.colors[2 * k];
            let share = (f.abs() / largest) as f32;
            if f > 0.0 {
                assert!(
                    c.r == 1.0 && (c.g - (1.0 - share)).abs() < 1e-6,
                    "{k}: {f} N {c:?}"
                );
            } else {
                assert!(
                    c.b == 1.0 && (c.r - (1.0 - share)).abs() < 1e-6,
                    "{k}: {f} N {c:?}"
                );
            }
        }
    }

    /// While the mast's compliant latches engage, /joint_states effort of each
    /// sleeve is the force through its latch (`latch_spring_force_n`, tension
    /// positive), and sampled every 20 us from the engagement on, its largest
    /// magnitude is the peak force the latch reports (to the sampling's reach:
    /// 1e-3 here, never above it).
    #[test]
    fn engaging_latch_efforts_are_the_latch_forces() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/pantograph_mast.toml");
        let new_sim = || {
            let model = crate::model::load(std::path::Path::new(path))
                .expect("bundled model")
                .model;
            Simulator::new(model, Options::default()).expect("simulator")
        };
        // when the latches engage (a first run)
        let mut probe = new_sim();
        while probe.state().locks.is_empty() {
            probe.step(0.05).expect("step");
        }
        let engaged_s = probe.state().locks[0].time_s;
        let mut sim = new_sim();
        let view = View::new(sim.model());
        while sim.state().t_s + 0.05 < engaged_s {
            sim.step(0.05).expect("step");
        }
        while sim.state().transients.is_empty() {
            sim.step(2e-5).expect("step");
        }
        let mut largest = 0.0f64;
        let mut samples = 0;
        while !sim.state().transients.is_empty() && samples < 20_000 {
            let stamp = sim_stamp(sim.state().t_s);
            let (js, _) = view.state_messages(&mut sim, stamp, "world");
            for tr in &sim.state().transients {
                let name = sim.model().elements[tr.element].name();
                let k = js
                    .name
                    .iter()
                    .position(|n| n == name)
                    .expect("sleeve published");
                let f = sim.latch_spring_force_n(tr.element).unwrap();
                assert_eq!(js.effort[k], f, "{name} at t = {}", sim.state().t_s);
                largest = largest.max(f.abs());
            }
            sim.step(2e-5).expect("step");
            samples += 1;
        }
        let peak = sim
            .state()
            .locks
            .iter()
            .filter_map(|l| l.peak_force_n)
            .fold(0.0, f64::max);
        assert!(
            peak > 0.0 && samples > 100,
            "peak {peak} N, {samples} samples"
        );
        assert!(
            largest <= peak * (1.0 + 1e-9) && largest >= (1.0 - 1e-3) * peak,
            "largest published {largest} N vs reported peak {peak} N"
        );
    }
}
