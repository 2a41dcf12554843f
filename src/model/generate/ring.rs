//! Double-ring deployable truss (the paper's first example, Fig. 6-9).
//!
//! The paper's figures are missing; this is the topology chosen, honouring every
//! number the paper gives (18 sides, height 0.5 m, outer chord 0.8757 m, inner
//! chord 0.6167 m, 0.25 kg per joint, 15 N, mu = 0.005, dt 0.05 s):
//!
//! - `n` radial frames k = 0..n at angles 2 pi k / n. Frame k holds a vertical outer
//!   post Ok (joints Ok_b, Ok_t) and an inner post Ik, joined at top and bottom by
//!   telescopic radial members mounted square to the posts (right-angle fittings)
//!   and kept planar: the planar truss element joining the rings. The radial
//!   members latch at the ring depth w = R_o - R_i.
//! - Each ring bay k -> k+1 is a quadrilateral of the two posts and two chords, kept
//!   planar, with a diagonal sleeve: the paper's quadrilateral element.
//! - Folding is the zig-zag shear of the bays: even frames sink by a, odd frames
//!   rise by a, so every chord tilts, both ring radii shrink (the inner faster), and
//!   every bay diagonal lengthens. Deployed, a = 0.
//! - The diagonal of a bay runs from the low post's bottom to the high post's top,
//!   so its length^2 = c^2 + h^2 + 4 a h falls monotonically to its design length
//!   sqrt(c^2 + h^2) as the ring opens. The drive cables run through these
//!   diagonals, one cable per ring, from a motor at frame 0 around the ring and back.
//! - The bottom chords are hinged to the posts by revolute joints whose axes are
//!   fixed in the frame's body (`hinge_axis`: each chord keeps its azimuth about
//!   the post), and synchronizing gears at every post's bottom hinge make the two
//!   chords meeting there fold as mirror images (`sync_hinge`). Together they leave
//!   exactly one mechanism, the deployment, before the latches and none after, and
//!   keep the flat deployed state regular (hinges alone make it a singular point
//!   with 16 extra infinitesimal mechanisms; gears alone leave a star-shaped
//!   polygon mode that friction excites on larger rings).
//! - Symmetric deployment is a one-parameter family in closed form:
//!   r_o = sqrt(c_o^2 - 4 a^2) / (2 sin(pi/n)), r_i likewise with c_i.
//! - Supports remove the 6 rigid-body motions in a way the symmetric motion
//!   respects: O0_b fixed, O{n/2}_b (on the x axis) fixed in y, two more even
//!   frames' O_b fixed in z.

use super::super::file::{CableDoc, ElementDoc, JointDoc, ModelDoc};
use super::GenerateError;
use crate::solver::elements::Param;

#[derive(Clone, Debug)]
pub struct RingParams {
    pub sides: usize,
    pub outer_chord_m: f64,
    pub inner_chord_m: f64,
    pub height_m: f64,
    pub joint_mass_kg: f64,
    /// Tilt of the outer bays' chords at the start (deg); 0 is deployed.
    pub start_deg: f64,
    pub tension_n: f64,
    pub max_tension_n: f64,
    pub friction_mu: f64,
    pub damping_n_s_per_m: f64,
    pub dt_s: f64,
    /// Synchronizing gears at the post hinges: "both", "axial", "radial" or "none".
    pub sync: String,
    /// Passive latching cross-diagonals in the cells between the rings.
    pub cell_diagonals: bool,
    /// Mount. Stowing ring: "post" (post O0 clamped to a boom, the default) or "hub".
    /// Synchronized ring: "hub" (held at its centre) or "frame0" (held at post O0).
    pub mount: String,
    /// Today's synchronized ring (`generate ring --sync`): square radial frames with
    /// telescopic radial members, chord hinges at every post and the gears of `sync`;
    /// one mechanism, every latch at one instant, and it folds only part-way.
    /// `false` is the stowing ring (`ring_stowing::stowing_ring`).
    pub synchronized: bool,
    /// Stowing ring: inner chords on revolute hinges fixed in the inner posts'
    /// fittings (true: one mechanism, it deploys to full lock) or on ball joints
    /// (false: sides - 2 mechanisms, but the inner ring then flattens ahead of the
    /// outer one and the ring locks up short of deployed; see ring_stowing).
    pub inner_hinges: bool,
    /// Compliant latches on every sleeve (rigid when None).
    pub latch: Option<super::LatchParams>,
    /// Stowing ring: the bay-by-bay ring (`generate ring --bay-by-bay`, see
    /// `ring_stowing`): the inner ring raised by radial frames deployed
    /// sheared (`frame_shear_deg`), inner chords on ball joints, every
    /// sleeve latching (outer and inner bays, radial frames), and compliant
    /// gears (`gear`) at the outer posts: many mechanisms before the latches.
    pub bay_by_bay: bool,
    /// Bay-by-bay ring: shear of the radial frames when deployed (deg).
    pub frame_shear_deg: f64,
    /// Bay-by-bay ring: stiffness and damping of the outer posts' gears.
    pub gear: super::LatchParams,
    /// Bay-by-bay ring: end stops on every sleeve at its stroke end (the
    /// length the symmetric fold takes farthest from its lock, plus
    /// `stroke_margin_m`), stiffness and damping; none when None.
    pub stroke_stop: Option<super::LatchParams>,
    /// Bay-by-bay ring: stroke beyond the symmetric fold's extreme lengths (m).
    pub stroke_margin_m: f64,
    /// Members elastic along their axis (`[solver] elastic_members`, EA the
    /// model-wide `axial_stiffness_n`): the bay-by-bay ring's default, whose
    /// last bays flatten together through a near-singular state that rigid
    /// members meet with unconverged solves (docs/solver.md#elastic-members).
    pub elastic_members: bool,
    /// `mount = "bus"`: the spacecraft bus post O0 is clamped to.
    pub bus: BusParams,
}

/// A free-floating spacecraft bus (`generate ring --mount bus`): a rigid
/// body of mass M and principal inertias J (about its centre, along the
/// model's axes), its centre `offset_m` outward of post O0's foot and at
/// the post's mid-height. Defaults: a small spacecraft, 100 kg, (10, 12, 14)
/// kg m^2, 1.5 m.
#[derive(Clone, Debug, PartialEq)]
pub struct BusParams {
    pub mass_kg: f64,
    pub inertia_kg_m2: [f64; 3],
    pub offset_m: f64,
}

impl Default for BusParams {
    fn default() -> Self {
        BusParams {
            mass_kg: 100.0,
            inertia_kg_m2: [10.0, 12.0, 14.0],
            offset_m: 1.5,
        }
    }
}

impl BusParams {
    /// The six joints at +-a along the axes from the centre, pair k of mass
    /// mu_k each: a^2 = tr(J) / (2 M), mu_k = M (tr(J)/2 - J_k) / tr(J)
    /// (`elements::rigid_body`): (name suffix, offset, mass) in the order
    /// +x, -x, +y, +z, -y, -z (the first four span the body).
    pub fn vertices(&self) -> Result<Vec<(&'static str, [f64; 3], f64)>, GenerateError> {
        let j = self.inertia_kg_m2;
        let tr = j[0] + j[1] + j[2];
        if !(self.mass_kg.is_finite() && self.mass_kg > 0.0) {
            return Err(GenerateError(format!(
                "--bus-mass-kg {}: give a positive mass",
                self.mass_kg
            )));
        }
        if !(self.offset_m.is_finite() && self.offset_m > 0.0) {
            return Err(GenerateError(format!(
                "--bus-offset-m {}: give a positive distance",
                self.offset_m
            )));
        }
        for k in 0..3 {
            let others = tr - j[k];
            if !(j[k].is_finite() && j[k] > 0.0 && j[k] < others) {
                return Err(GenerateError(format!(
                    "--bus-inertia {},{},{}: principal inertias must be positive and each less than the sum of the other two (a real body's)",
                    j[0], j[1], j[2]
                )));
            }
        }
        let a = (0.5 * tr / self.mass_kg).sqrt();
        let mu = |k: usize| self.mass_kg * (0.5 * tr - j[k]) / tr;
        Ok(vec![
            ("px", [a, 0.0, 0.0], mu(0)),
            ("mx", [-a, 0.0, 0.0], mu(0)),
            ("py", [0.0, a, 0.0], mu(1)),
            ("pz", [0.0, 0.0, a], mu(2)),
            ("my", [0.0, -a, 0.0], mu(1)),
            ("mz", [0.0, 0.0, -a], mu(2)),
        ])
    }
}

impl Default for RingParams {
    /// Today's synchronized ring (the bundled `models/double_ring.toml`).
    fn default() -> Self {
        RingParams {
            sides: 18,
            outer_chord_m: 0.8757,
            inner_chord_m: 0.6167,
            height_m: 0.5,
            joint_mass_kg: 0.25,
            start_deg: 35.0,
            tension_n: 15.0,
            max_tension_n: 60.0,
            friction_mu: 0.005,
            damping_n_s_per_m: 50.0,
            dt_s: 0.05,
            sync: "both".into(),
            cell_diagonals: true,
            mount: "hub".into(),
            synchronized: true,
            inner_hinges: true,
            latch: None,
            bay_by_bay: false,
            frame_shear_deg: 20.0,
            gear: super::LatchParams {
                stiffness_n_per_m: 1000.0,
                damping_n_s_per_m: 5.0,
            },
            stroke_stop: None,
            stroke_margin_m: 0.005,
            elastic_members: false,
            bus: BusParams::default(),
        }
    }
}

impl RingParams {
    /// The synchronized ring: square frames, gears at both post hinges, passive cell
    /// diagonals, hub mount, 35 deg start (`generate ring --sync`; today the default).
    /// Tests about the synchronized ring use this, so they keep testing it when
    /// the default changes.
    pub fn synchronized() -> Self {
        RingParams::default()
    }
    /// The stowing ring (`generate ring --stow`, see `ring_stowing`): parallelogram
    /// bays and radial frames that shear to a bundle, no gears, held at post O0.
    pub fn stowing() -> Self {
        RingParams {
            start_deg: 75.0,
            sync: "none".into(),
            cell_diagonals: false,
            mount: "post".into(),
            synchronized: false,
            ..RingParams::default()
        }
    }
    /// The bay-by-bay ring (`generate ring --bay-by-bay`, see `ring_stowing`).
    pub fn bay_by_bay() -> Self {
        RingParams {
            bay_by_bay: true,
            inner_hinges: false,
            elastic_members: true,
            ..RingParams::stowing()
        }
    }
    /// The bay-by-bay ring of `sides` sides as `generate ring --sides N`
    /// writes it: the 18-sided ring's parameters up to 18 sides; above, what
    /// a larger ring needs to deploy (docs/double_ring_stowing.md, "Why the
    /// 36-sided ring jams" and after): the inner chord by the bundle rule
    /// c_o (1 - sin(pi/n)) / (1 + sin(pi/n)) (to 0.1 mm, as the paper prints
    /// its chords; the paper's 0.6167 m is the rule at 18 sides), stroke stops
    /// of 1e4 N/m and 50 N s/m at every sleeve's stroke end (no bay folds the
    /// wrong way).
    pub fn bay_by_bay_sized(sides: usize) -> Self {
        let d = RingParams {
            sides,
            ..RingParams::bay_by_bay()
        };
        if sides <= 18 {
            return d;
        }
        let s = (std::f64::consts::PI / sides as f64).sin();
        RingParams {
            inner_chord_m: (d.outer_chord_m * (1.0 - s) / (1.0 + s) * 1e4).round() / 1e4,
            stroke_stop: Some(super::LatchParams {
                stiffness_n_per_m: 1e4,
                damping_n_s_per_m: 50.0,
            }),
            ..d
        }
    }
}

/// The note of elastic members (`RingParams::elastic_members`), if they are.
pub fn members_note(p: &RingParams) -> Option<String> {
    p.elastic_members.then(|| {
        "Members elastic along their axis ([solver] elastic_members; EA the solver's default, 6e6 N, \
         as a 20 mm carbon tube; assumed, not a measured value): the last bays flatten together through \
         a near-singular state (docs/double_ring_stowing.md Finding 5) that rigid members cross only with \
         unconverged solves; elastic ones keep it well posed and stretch about 2.5 um per metre under the \
         15 N drive (docs/solver.md#elastic-members). `--members rigid` writes rigid members."
            .to_string()
    })
}

/// Ring radii (r_o, r_i) of the symmetric configuration with zig-zag offset a (m).
pub fn ring_radii(p: &RingParams, a: f64) -> Result<(f64, f64), GenerateError> {
    let s = (std::f64::consts::PI / p.sides as f64).sin();
    let (co, ci) = (p.outer_chord_m, p.inner_chord_m);
    if !(2.0 * a < ci) {
        return Err(GenerateError(format!(
            "zig-zag offset {a} m exceeds half the inner chord; use a smaller start angle"
        )));
    }
    Ok((
        (co * co - 4.0 * a * a).sqrt() / (2.0 * s),
        (ci * ci - 4.0 * a * a).sqrt() / (2.0 * s),
    ))
}

pub fn ring_joint_names(n: usize) -> Vec<String> {
    (0..n)
        .flat_map(|k| {
            [
                format!("O{k}_b"),
                format!("O{k}_t"),
                format!("I{k}_b"),
                format!("I{k}_t"),
            ]
        })
        .collect()
}

/// Joint positions of the symmetric configuration with zig-zag offset a, ring centre
/// at the origin, in the order of `ring_joint_names`.
pub fn ring_positions(p: &RingParams, a: f64) -> Result<Vec<[f64; 3]>, GenerateError> {
    let (ro, ri) = ring_radii(p, a)?;
    let n = p.sides;
    let h = p.height_m;
    let mut out = Vec::with_capacity(4 * n);
    for k in 0..n {
        let th = 2.0 * std::f64::consts::PI * k as f64 / n as f64;
        let sign = if k % 2 == 0 { -1.0 } else { 1.0 };
        let (c, s) = (th.cos(), th.sin());
        let (zo, zi) = (sign * a, sign * a);
        out.push([ro * c, ro * s, zo]);
        out.push([ro * c, ro * s, zo + h]);
        out.push([ri * c, ri * s, zi]);
        out.push([ri * c, ri * s, zi + h]);
    }
    Ok(out)
}

/// Notes both rings' model files carry.
pub(super) const CHORD_UNIT_NOTE: &str =
    "The paper prints the inner chord as 0.6167 mm; metres are meant.";
pub(super) const DAMPING_NOTE: &str = "Joint damping 50 N s/m (a model choice: the paper's 15 N on 0.25 kg joints would deploy in well under a second undamped; its 102 s implies heavy dissipation it does not state).";
pub(super) const NUMBERING_NOTE: &str = "Joint numbering differs from the paper's Fig. 8, which is missing: joints are named by frame and post.";

/// The joints of a ring: names, start positions `x0`, reference positions `xd`
/// shifted so that joint O0_b keeps its start position when the ring is held at
/// post O0 (`at_post`); a ring held at its hub keeps its axis.
pub(super) fn ring_joints(
    p: &RingParams,
    x0: &[[f64; 3]],
    xd: &[[f64; 3]],
    at_post: bool,
) -> Vec<JointDoc> {
    let shift = if at_post {
        [
            x0[0][0] - xd[0][0],
            x0[0][1] - xd[0][1],
            x0[0][2] - xd[0][2],
        ]
    } else {
        [0.0; 3]
    };
    ring_joint_names(p.sides)
        .into_iter()
        .zip(x0.iter().zip(xd))
        .map(|(name, (a, d))| JointDoc {
            name,
            position_m: *a,
            mass_kg: p.joint_mass_kg,
            reference_m: Some([d[0] + shift[0], d[1] + shift[1], d[2] + shift[2]]),
        })
        .collect()
}

/// A support fixing coordinates `fix` of one joint.
pub(super) fn fix_joint(joint: String, fix: &str) -> ElementDoc {
    ElementDoc {
        kind: "support".into(),
        name: format!("fix_{joint}_{fix}"),
        joints: vec![joint],
        params: vec![("fix".into(), Param::Text(fix.into()))],
    }
}

/// Hub mount: the centre of the outer bottom joints fixed; O0_b (on the x axis)
/// held at y = 0 against spin; the mean heights of two blocks of 2m consecutive
/// frames (equal numbers of low and high frames, so their mean stays 0) against tilt.
pub(super) fn hub_mount(n: usize) -> Vec<ElementDoc> {
    let ob = |k: usize| format!("O{}_b", k % n);
    let m = (n / 4).max(1);
    let centroid = |name: &str, joints: Vec<String>, f: &str| ElementDoc {
        kind: "centroid".into(),
        name: name.into(),
        joints,
        params: vec![("fix".into(), Param::Text(f.into()))],
    };
    let block = |from: usize| (from..from + 2 * m).map(ob).collect::<Vec<_>>();
    vec![
        centroid("hub_centre", (0..n).map(ob).collect(), "xyz"),
        fix_joint(ob(0), "y"),
        centroid("hub_level_a", block(0), "z"),
        centroid("hub_level_b", block(n - m), "z"),
    ]
}

/// Path of the drive cable of one ring ("O" or "I"): from the motor at frame 0
/// through every bay diagonal (low bottom -> high top -> next low bottom ...) and
/// back to frame 0, where its end is anchored.
pub fn ring_cable_path(n: usize, ring: &str) -> Vec<String> {
    (0..=n)
        .map(|k| format!("{ring}{}_{}", k % n, if k % 2 == 0 { "b" } else { "t" }))
        .collect()
}

/// The double ring: the stowing ring, or today's synchronized ring with
/// `synchronized` set.
pub fn ring(p: &RingParams) -> Result<ModelDoc, GenerateError> {
    check_params(p)?;
    if p.synchronized {
        synchronized_ring(p)
    } else {
        super::ring_stowing::stowing_ring(p)
    }
}

/// Checks shared by both rings.
fn check_params(p: &RingParams) -> Result<(), GenerateError> {
    let n = p.sides;
    if !(6..=360).contains(&n) || n % 2 != 0 {
        return Err(GenerateError(format!("--sides {n}: a double ring has an even number of sides from 6 to 360 (the bays fold in a zig-zag)")));
    }
    if !(p.start_deg > 0.0 && p.start_deg < 80.0) {
        return Err(GenerateError(format!(
            "start angle {} deg must be between 0 and 80",
            p.start_deg
        )));
    }
    if !(p.inner_chord_m > 0.0
        && p.inner_chord_m < p.outer_chord_m
        && p.height_m > 0.0
        && p.joint_mass_kg > 0.0)
    {
        return Err(GenerateError(
            "chords, height and mass must be positive, the inner chord shorter than the outer"
                .into(),
        ));
    }
    super::check_drive(
        p.tension_n,
        p.max_tension_n,
        p.friction_mu,
        p.damping_n_s_per_m,
    )?;
    Ok(())
}

fn synchronized_ring(p: &RingParams) -> Result<ModelDoc, GenerateError> {
    let n = p.sides;
    if p.sync != "none" && !["both", "axial", "radial"].contains(&p.sync.as_str()) {
        return Err(GenerateError(format!(
            "--sync {}: use both, axial, radial or none",
            p.sync
        )));
    }
    let a0 = 0.5 * p.outer_chord_m * p.start_deg.to_radians().sin();
    let x0 = ring_positions(p, a0)?;
    let xd = ring_positions(p, 0.0)?;
    // A hub mount holds the ring's centre, which the symmetric deployment keeps at
    // the origin; a frame-0 mount holds O0_b where it starts, and the deployed ring
    // is placed likewise.
    let hub = match p.mount.as_str() {
        "hub" => true,
        "frame0" => false,
        other => {
            return Err(GenerateError(format!(
                "--mount {other}: use `hub` (held at the centre) or `frame0` (held at one post)"
            )))
        }
    };
    let joints = ring_joints(p, &x0, &xd, !hub);
    let (h, co, ci) = (p.height_m, p.outer_chord_m, p.inner_chord_m);
    let s = (std::f64::consts::PI / n as f64).sin();
    let (ro_d, ri_d) = (co / (2.0 * s), ci / (2.0 * s));
    let w = ro_d - ri_d;
    let el =
        |kind: &str, name: String, joints: &[String], params: Vec<(String, Param)>| ElementDoc {
            kind: kind.into(),
            name,
            joints: joints.to_vec(),
            params,
        };
    let j = |ring: &str, k: usize, end: &str| format!("{ring}{}_{end}", k % n);
    let spring = super::latch_params(p.latch.as_ref())?;
    let lock = |l: f64| super::sleeve_lock(&spring, l);
    let mut elements = Vec::new();
    let fix = fix_joint;
    // The inner ring is held concentric with the outer ring (the radial tie system):
    // without it the inner ring could drift sideways, a mechanism that pulley
    // friction excites.
    let concentric: Vec<String> = (0..n)
        .map(|k| j("I", k, "b"))
        .chain((0..n).map(|k| j("O", k, "b")))
        .collect();
    elements.push(el(
        "centroid",
        "rings_concentric".into(),
        &concentric,
        vec![
            ("fix".into(), Param::Text("xy".into())),
            ("first_group".into(), Param::Num(n as f64)),
        ],
    ));
    if hub {
        elements.extend(hub_mount(n));
    } else {
        let z_frame = 2 * (n / 4).max(2);
        elements.push(fix(j("O", 0, "b"), "xyz"));
        elements.push(fix(j("O", n / 2, "b"), "y"));
        elements.push(fix(j("O", 2, "b"), "z"));
        elements.push(fix(j("O", z_frame, "b"), "z"));
    }
    let cell_len = ((ro_d * ro_d + ri_d * ri_d
        - 2.0 * ro_d * ri_d * (2.0 * std::f64::consts::PI / n as f64).cos())
        + h * h)
        .sqrt();
    for k in 0..n {
        for ring in ["O", "I"] {
            elements.push(el(
                "bar",
                format!("{ring}{k}_post"),
                &[j(ring, k, "b"), j(ring, k, "t")],
                vec![],
            ));
        }
        // Radial frame: telescopic members square to both posts, latching at depth w.
        for end in ["b", "t"] {
            elements.push(el(
                "sleeve",
                format!("R{k}_{end}"),
                &[j("O", k, end), j("I", k, end)],
                lock(w),
            ));
        }
        elements.push(el(
            "perpendicular",
            format!("R{k}_square_O"),
            &[j("O", k, "b"), j("O", k, "t"), j("I", k, "b")],
            vec![],
        ));
        elements.push(el(
            "perpendicular",
            format!("R{k}_square_I"),
            &[j("I", k, "b"), j("I", k, "t"), j("O", k, "b")],
            vec![],
        ));
        elements.push(el(
            "coplanar",
            format!("R{k}_plane"),
            &[
                j("O", k, "b"),
                j("O", k, "t"),
                j("I", k, "t"),
                j("I", k, "b"),
            ],
            vec![],
        ));
        // Revolute hinges of the bottom chords, their axes fixed in the frame's
        // body (post + radial member): each chord keeps its azimuth about the post.
        for ring in ["O", "I"] {
            let radial = if ring == "O" { "I" } else { "O" };
            for (side, other) in [("next", k + 1), ("prev", k + n - 1)] {
                elements.push(el(
                    "hinge_axis",
                    format!("{ring}{k}_hinge_{side}"),
                    &[
                        j(ring, k, "b"),
                        j(ring, k, "t"),
                        j(radial, k, "b"),
                        j(ring, other, "b"),
                    ],
                    vec![],
                ));
            }
        }
        // Synchronizing gears at both posts' bottom hinges: the two bottom chords
        // meeting there fold as mirror images about the radial frame's plane.
        for ring in ["O", "I"].iter().filter(|_| p.sync != "none") {
            let radial = if *ring == "O" { "I" } else { "O" };
            elements.push(el(
                "sync_hinge",
                format!("{ring}{k}_sync"),
                &[
                    j(ring, k, "b"),
                    j(ring, k, "t"),
                    j(radial, k, "b"),
                    j(ring, k + n - 1, "b"),
                    j(ring, k + 1, "b"),
                ],
                vec![("mirror".into(), Param::Text(p.sync.clone()))],
            ));
        }
        for (ring, c) in [("O", co), ("I", ci)] {
            elements.push(el(
                "bar",
                format!("{ring}_bay{k}_top"),
                &[j(ring, k, "t"), j(ring, k + 1, "t")],
                vec![],
            ));
            elements.push(el(
                "bar",
                format!("{ring}_bay{k}_bottom"),
                &[j(ring, k, "b"), j(ring, k + 1, "b")],
                vec![],
            ));
            elements.push(el(
                "coplanar",
                format!("{ring}_bay{k}_plane"),
                &[
                    j(ring, k, "b"),
                    j(ring, k, "t"),
                    j(ring, k + 1, "t"),
                    j(ring, k + 1, "b"),
                ],
                vec![],
            ));
            let (from, to) = if k % 2 == 0 {
                (j(ring, k, "b"), j(ring, k + 1, "t"))
            } else {
                (j(ring, k, "t"), j(ring, k + 1, "b"))
            };
            elements.push(el(
                "sleeve",
                format!("{ring}_diag{k}"),
                &[from, to],
                lock((c * c + h * h).sqrt()),
            ));
        }
        if p.cell_diagonals {
            // Cross-diagonal of cell k, low bottom to high top: length^2 =
            // |O_k - I_{k+1}|_xy^2 + (h + 2a)^2, falling monotonically to its design length.
            let (from, to) = if k % 2 == 0 {
                (j("O", k, "b"), j("I", k + 1, "t"))
            } else {
                (j("O", k, "t"), j("I", k + 1, "b"))
            };
            elements.push(el(
                "sleeve",
                format!("C{k}_diag"),
                &[from, to],
                lock(cell_len),
            ));
        }
    }
    let cable = |ring: &str| CableDoc {
        name: format!("{}_drive", if ring == "O" { "outer" } else { "inner" }),
        path: ring_cable_path(n, ring),
        tension_n: p.tension_n,
        max_tension_n: p.max_tension_n,
        friction_mu: p.friction_mu,
        pulley_radius_m: 0.01,
        ..CableDoc::default()
    };
    Ok(ModelDoc {
        name: "double_ring".into(),
        description: format!(
            "{n}-sided double-ring deployable truss: outer chord {co} m, inner chord {ci} m, height {h} m, radial depth {w:.4} m, \
             starting with the outer bays sheared {} deg",
            p.start_deg
        ),
        notes: vec![
            format!("Outer ring circumradius {ro_d:.4} m (diameter {:.4} m, the paper's 5.0 m aperture), inner {ri_d:.4} m, from the chords.", 2.0 * ro_d),
            CHORD_UNIT_NOTE.into(),
            "Frame k: outer post Ok_b-Ok_t and inner post Ik_b-Ik_t (0.5 m) joined at top and bottom by telescopic radial members mounted square to the posts and kept planar: the planar truss element joining the rings; the radial members latch at the ring depth.".into(),
            "Bay k: two posts, a top and a bottom chord, kept planar, and a diagonal sleeve from the low post's bottom to the high post's top; it latches at sqrt(c^2 + h^2).".into(),
            "Folding is the zig-zag shear of the bays (even frames low, odd frames high, both rings alike); the symmetric deployment is a one-parameter family solved in closed form.".into(),
            "The bottom chords hang on revolute hinges whose axes are fixed in the frame (post + radial member), with synchronizing gears at each post: one mechanism, the deployment, so every latch engages at the same instant, with or without friction.".into(),
            "Each cell k carries a passive cross-diagonal sleeve Ok -> I(k+1) that latches at deployment; with the latched radial members it makes the deployed ring rigid.".into(),
            "Two drive cables (outer, inner), each from a motor at frame 0 through every bay diagonal of its ring and back to frame 0, with a pulley at every post joint on the way.".into(),
            "Mount `hub` (default): the centre of the outer bottom joints is fixed, O0_b held at y = 0 against spin, and the mean heights of two blocks of frames against tilt; a symmetric deployment needs no reaction. Mount `frame0`: O0_b fixed, as on a boom.".into(),
            "The inner ring is held concentric with the outer ring (centroid constraint, the radial tie system).".into(),
            DAMPING_NOTE.into(),
            "The start is part-folded (outer bays sheared 35 deg; the inner bays fold flat at 44.8 deg, and the fully stowed bundle is singular for this topology).".into(),
            NUMBERING_NOTE.into(),
        ]
        .into_iter()
        .chain(p.latch.as_ref().map(super::latch_note))
        .chain(members_note(p))
        .chain(p.latch.map(|_| "The radial members reach their lock at their shortest (the flat state), where nothing moves along them: they have no transient and latch rigid once the diagonals' transients are over.".to_string()))
        .collect(),
        dt_s: p.dt_s,
        end_time_s: 600.0,
        damping_n_s_per_m: p.damping_n_s_per_m,
        elastic_members: p.elastic_members,
        joints,
        elements,
        cables: vec![cable("O"), cable("I")],
        ..Default::default()
    })
}
