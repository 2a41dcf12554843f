//! Sail (solar) array generator: see `sail()`.
//!
//! Two parallel planar pantograph booms (boom A in the plane y = 0, boom B in the
//! plane y = width) of `bays` scissor units each along +x carry an accordion deck
//! of 2 * bays rigid plates between their top sides. The paper's array (Xu Yan et
//! al., the deployable sail array example) is the default: 4 units per boom, so 8
//! SLEs and 8 plates, deploying from alpha = 1 deg to alpha = 55 deg to a deck
//! 4.0 m long and 0.7 m wide at z = 0 (flat but for a 0.1 deg residual fold that
//! keeps full deployment a regular configuration), with the boom bottoms at z = -0.7.
//!
//! Joint numbering (`J1`..`J{4 + 6 bays}`, the paper's anchors for 4 bays):
//! station 0 is J1 = boom A bottom, J2 = boom A top, J3 = boom B top, J4 = boom B
//! bottom; then for each station u = 1..=bays a block of six: the odd deck hinge
//! line between stations u-1 and u (boom A side, then boom B side), then station
//! u's A bottom, A top, B top, B bottom. So J5 deploys to (0.5, 0, 0.0009), J26 (the
//! last boom A top) to (4, 0, 0) and J28 (the last boom B bottom) to (4, 0.7, -0.7).
//! The two motor drums follow as `drum_A` and `drum_B`.

use super::super::file::{CableDoc, ElementDoc, JointDoc, ModelDoc};
use super::GenerateError;
use crate::solver::elements::Param;

#[derive(Clone, Debug)]
pub struct SailParams {
    /// Number of scissor units per boom (1 to 100); the paper's array has 4.
    pub bays: usize,
    pub tension_n: f64,
    pub friction_mu: f64,
    pub damping_n_s_per_m: f64,
    pub dt_s: f64,
    /// Deployed unit pitch along x (m); each plate is half of it long.
    pub pitch_m: f64,
    /// Distance between the two booms = plate width along y (m).
    pub width_m: f64,
    /// Rod angle from the vertical, folded and deployed (deg).
    pub start_deg: f64,
    pub deploy_deg: f64,
    /// Mass of each revolute (boom) joint, and of each plate-only joint (kg).
    pub boom_joint_mass_kg: f64,
    pub plate_joint_mass_kg: f64,
    /// The motor drums sit this far below the base bottom joints (m).
    pub drum_drop_m: f64,
    /// Residual fold angle gamma of each plate when deployed (deg). The plates are
    /// (pitch/2)/cos(gamma_d) long so that the deck is not exactly flat when the
    /// sleeves latch; 0 (flat) makes full deployment a singular configuration.
    pub deck_fold_deg: f64,
}

impl Default for SailParams {
    fn default() -> Self {
        SailParams {
            bays: 4,
            tension_n: 10.0,
            friction_mu: 0.005,
            damping_n_s_per_m: 5.0,
            dt_s: 0.01,
            pitch_m: 1.0,
            width_m: 0.7,
            start_deg: 1.0,
            deploy_deg: 55.0,
            boom_joint_mass_kg: 0.15,
            plate_joint_mass_kg: 0.075,
            drum_drop_m: 0.3,
            deck_fold_deg: 0.1,
        }
    }
}

/// Mass of each motor drum joint (kg); the drums are fixed, so it never moves.
const DRUM_MASS_KG: f64 = 0.05;

/// The two booms: A in the plane y = 0, B in the plane y = width.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Boom {
    A,
    B,
}

/// Joint number (1-based, the `J` number) of the top joint of boom `b` at station u.
pub fn top_joint(u: usize, b: Boom) -> usize {
    match (u, b) {
        (0, Boom::A) => 2,
        (0, Boom::B) => 3,
        (u, Boom::A) => 6 * u + 2,
        (u, Boom::B) => 6 * u + 3,
    }
}

/// Joint number of the bottom joint of boom `b` at station u.
pub fn bottom_joint(u: usize, b: Boom) -> usize {
    match (u, b) {
        (0, Boom::A) => 1,
        (0, Boom::B) => 4,
        (u, Boom::A) => 6 * u + 1,
        (u, Boom::B) => 6 * u + 4,
    }
}

/// Joint number of deck hinge line h (0..=2 bays) on boom `b`'s side: even lines are
/// the boom top joints of station h/2, odd lines are plate-only joints.
pub fn hinge_joint(h: usize, b: Boom) -> usize {
    if h % 2 == 0 {
        top_joint(h / 2, b)
    } else {
        let u = h.div_ceil(2); // the station after the odd line
        match b {
            Boom::A => 6 * (u - 1) + 5,
            Boom::B => 6 * (u - 1) + 6,
        }
    }
}

/// Number of truss joints (the drums excluded): 4 + 6 bays.
pub fn sail_truss_joints(bays: usize) -> usize {
    4 + 6 * bays
}

/// Names of all joints in file order: J1..J{4+6 bays}, then drum_A, drum_B.
pub fn sail_joint_names(bays: usize) -> Vec<String> {
    let mut v: Vec<String> = (1..=sail_truss_joints(bays))
        .map(|i| format!("J{i}"))
        .collect();
    v.push("drum_A".into());
    v.push("drum_B".into());
    v
}

fn jname(n: usize) -> String {
    format!("J{n}")
}

/// Closed-form dimensions: rod length L = pitch / sin(deploy angle) and deployed
/// boom height H_d = L cos(deploy angle).
pub fn sail_rod_length_m(p: &SailParams) -> f64 {
    p.pitch_m / p.deploy_deg.to_radians().sin()
}

pub fn sail_deployed_height_m(p: &SailParams) -> f64 {
    sail_rod_length_m(p) * p.deploy_deg.to_radians().cos()
}

/// Length of each plate along x: c = (pitch/2) / cos(deck fold at deployment).
pub fn sail_plate_length_m(p: &SailParams) -> f64 {
    0.5 * p.pitch_m / p.deck_fold_deg.to_radians().cos()
}

/// Closed-form geometry at rod angle alpha (rad, from the vertical), in file order
/// (J1.., then the drums). Unit pitch P = L sin alpha, boom height H = L cos alpha;
/// bottom joints at z = -H_d (fixed height, the boom tops are at z = 0 when deployed),
/// top joints at z = -H_d + H, station u at x = u P. Each plate (length c) is tilted
/// by gamma, cos gamma = (P/2)/c, folded upward: odd hinge line h sits at
/// x = h P/2, z = z_top + c sin gamma. The drums are at (0, y, -H_d - drop).
pub fn sail_positions(p: &SailParams, alpha: f64) -> Vec<[f64; 3]> {
    let l = sail_rod_length_m(p);
    let hd = sail_deployed_height_m(p);
    let (pitch, h) = (l * alpha.sin(), l * alpha.cos());
    let c = sail_plate_length_m(p);
    let cos_g = (0.5 * pitch / c).min(1.0);
    let sin_g = (1.0 - cos_g * cos_g).max(0.0).sqrt();
    let (zb, zt) = (-hd, -hd + h);
    let n = sail_truss_joints(p.bays);
    let mut x = vec![[0.0; 3]; n + 2];
    for b in [Boom::A, Boom::B] {
        let y = if b == Boom::A { 0.0 } else { p.width_m };
        for u in 0..=p.bays {
            let xu = u as f64 * pitch;
            x[top_joint(u, b) - 1] = [xu, y, zt];
            x[bottom_joint(u, b) - 1] = [xu, y, zb];
        }
        for hl in (1..2 * p.bays).step_by(2) {
            x[hinge_joint(hl, b) - 1] = [hl as f64 * 0.5 * pitch, y, zt + c * sin_g];
        }
        x[n + usize::from(b == Boom::B)] = [0.0, y, -hd - p.drum_drop_m];
    }
    x
}

/// Drive cable of boom `b`, motor end first: drum -> top_0 -> bottom_0 -> top_1 ->
/// bottom_1 -> ... -> top_N -> bottom_N (anchored). For boom A with 4 bays this is
/// drum_A, J2, J1, J8, J7, J14, J13, J20, J19, J26, J25: the paper's cable, fixed at
/// J25, over a pulley at J26, zigzagging down the boom along its rods over a pulley
/// at each kink, and over a pulley at J2 to the drum below the base.
pub fn sail_cable_path(bays: usize, b: Boom) -> Vec<String> {
    let mut v = vec![if b == Boom::A { "drum_A" } else { "drum_B" }.to_string()];
    for u in 0..=bays {
        v.push(jname(top_joint(u, b)));
        v.push(jname(bottom_joint(u, b)));
    }
    v
}

/// Closed-form length of one drive cable at rod angle alpha (rad): the drum run
/// (drop + H), N + 1 vertical runs top_u - bottom_u (H each, shrinking as the array
/// deploys) and N runs along rods bottom_u - top_{u+1} (L each, constant):
/// l = drop + (N + 2) L cos alpha + N L, so dl/dalpha = -(N + 2) L sin alpha < 0.
pub fn sail_cable_length(p: &SailParams, alpha: f64) -> f64 {
    let l = sail_rod_length_m(p);
    let n = p.bays as f64;
    p.drum_drop_m + (n + 2.0) * l * alpha.cos() + n * l
}

pub fn sail(p: &SailParams) -> Result<ModelDoc, GenerateError> {
    if !(1..=100).contains(&p.bays) {
        return Err(GenerateError(format!(
            "--bays {} is out of range; a sail array has 1 to 100 bays (scissor units per boom)",
            p.bays
        )));
    }
    let positive = [
        p.dt_s,
        p.pitch_m,
        p.width_m,
        p.boom_joint_mass_kg,
        p.plate_joint_mass_kg,
        p.drum_drop_m,
    ];
    if !(p.deck_fold_deg >= 0.0 && p.deck_fold_deg < 30.0) {
        return Err(GenerateError(format!(
            "deck fold at deployment {} deg must be in 0 to 30 deg",
            p.deck_fold_deg
        )));
    }
    if positive.iter().any(|v| !(v.is_finite() && *v > 0.0)) {
        return Err(GenerateError(
            "dt, pitch, width, joint masses and drum drop must be positive and finite".into(),
        ));
    }
    if !(p.start_deg >= 0.5 && p.start_deg < p.deploy_deg && p.deploy_deg < 89.0) {
        return Err(GenerateError(format!(
            "start angle {} deg and deploy angle {} deg must satisfy 0.5 <= start < deploy < 89",
            p.start_deg, p.deploy_deg
        )));
    }
    if !(p.tension_n.is_finite()
        && p.tension_n >= 0.0
        && p.friction_mu.is_finite()
        && p.friction_mu >= 0.0
        && p.damping_n_s_per_m.is_finite()
        && p.damping_n_s_per_m >= 0.0)
    {
        return Err(GenerateError(
            "tension, friction and damping must be finite and >= 0".into(),
        ));
    }
    let (a0, ad) = (p.start_deg.to_radians(), p.deploy_deg.to_radians());
    let n = p.bays;
    let names = sail_joint_names(n);
    let x0 = sail_positions(p, a0);
    let xd = sail_positions(p, ad);
    let nt = sail_truss_joints(n);
    let joints = names
        .iter()
        .enumerate()
        .map(|(i, name)| {
            let boom = (0..=n).any(|u| {
                [Boom::A, Boom::B]
                    .iter()
                    .any(|&b| top_joint(u, b) == i + 1 || bottom_joint(u, b) == i + 1)
            });
            JointDoc {
                name: name.clone(),
                position_m: x0[i],
                mass_kg: if i >= nt {
                    DRUM_MASS_KG
                } else if boom {
                    p.boom_joint_mass_kg
                } else {
                    p.plate_joint_mass_kg
                },
                reference_m: Some(xd[i]),
            }
        })
        .collect();

    let hd = sail_deployed_height_m(p);
    let mut elements = Vec::new();
    let support = |name: &str, joint: String, fix: &str| ElementDoc {
        kind: "support".into(),
        name: name.into(),
        joints: vec![joint],
        params: vec![("fix".into(), Param::Text(fix.into()))],
    };
    elements.push(support("base_J1", jname(1), "xyz"));
    elements.push(support("base_J4", jname(4), "xyz"));
    elements.push(support("guide_J2", jname(2), "xy"));
    elements.push(support("guide_J3", jname(3), "x"));
    elements.push(support("drum_A", "drum_A".into(), "xyz"));
    elements.push(support("drum_B", "drum_B".into(), "xyz"));
    for b in [Boom::A, Boom::B] {
        for u in 0..n {
            elements.push(ElementDoc {
                kind: "scissor".into(),
                name: format!("SLE_{b:?}{}", u + 1),
                joints: vec![
                    jname(top_joint(u, b)),
                    jname(bottom_joint(u + 1, b)),
                    jname(bottom_joint(u, b)),
                    jname(top_joint(u + 1, b)),
                ],
                params: vec![("ratio".into(), Param::Num(1.0))],
            });
        }
    }
    for pl in 1..=2 * n {
        elements.push(ElementDoc {
            kind: "plate".into(),
            name: format!("plate{pl}"),
            joints: vec![
                jname(hinge_joint(pl - 1, Boom::A)),
                jname(hinge_joint(pl, Boom::A)),
                jname(hinge_joint(pl, Boom::B)),
                jname(hinge_joint(pl - 1, Boom::B)),
            ],
            params: vec![],
        });
    }
    let sleeve = |name: String, a: usize, b: usize, lock: f64| ElementDoc {
        kind: "sleeve".into(),
        name,
        joints: vec![jname(a), jname(b)],
        params: vec![("lock_length_m".into(), Param::Num(lock))],
    };
    elements.push(sleeve("sleeve_1-2".into(), 1, 2, hd));
    elements.push(sleeve("sleeve_3-4".into(), 3, 4, hd));

    let cables = [Boom::A, Boom::B]
        .iter()
        .map(|&b| CableDoc {
            name: format!("drive_{b:?}"),
            path: sail_cable_path(n, b),
            tension_n: p.tension_n,
            max_tension_n: 4.0 * p.tension_n,
            friction_mu: p.friction_mu,
            pulley_radius_m: 0.01,
            ..CableDoc::default()
        })
        .collect();

    let last = nt;
    let c_plate = sail_plate_length_m(p);
    Ok(ModelDoc {
        name: "sail_array".into(),
        description: format!(
            "Deployable sail (solar) array: two planar pantograph booms of {n} scissor units each \
             carrying an accordion deck of {} rigid plates, deploying from alpha = {} deg to {} deg",
            2 * n,
            p.start_deg,
            p.deploy_deg
        ),
        notes: vec![
            "The paper's figure is missing; this design honours its numbers: 8 SLEs (4 per boom) and 8 plates, deploy angle 1 to 55 deg, deck 4.0 m x 0.7 m at z = 0, boom bottoms at z = -0.7, 2 cables at 10 N, mu 0.005, 0.15 kg per revolute joint, 0.075 kg per plate joint. Departures (dt, damping, a 0.1 deg residual deck fold, one guide support) are explained below.".into(),
            format!("Two planar pantograph booms along +x: boom A in the plane y = 0, boom B in the plane y = {}; stations u = 0..={n}, each with a top and a bottom joint per boom.", p.width_m),
            "Each unit u is a scissor (ratio 1) with rods top_u-bottom_(u+1) and bottom_u-top_(u+1) crossing at their midpoints: a rectangle whose diagonals are the rods.".into(),
            format!("Rod angle alpha is measured from the vertical: pitch P = L sin alpha, boom height H = L cos alpha, with L = pitch / sin(deploy) = {:.6} m and deployed height H_d = L cos(deploy) = {:.6} m (the paper's 0.7).", sail_rod_length_m(p), hd),
            "Bottom joints stay at z = -H_d (J1 and J4 are fixed there); top joints are at z = -H_d + H(alpha), so they slide down as the array deploys and end at z = 0.".into(),
            format!("Deck: {} rigid plates (flat formulation) between the booms' top sides, an accordion with hinge lines h = 0..={}: even lines are the boom top joints of station h/2, odd lines are plate-only joints; plate p has corners A_(p-1), A_p, B_p, B_(p-1) and measures {:.7} m (x) by {} m (y).", 2 * n, 2 * n, c_plate, p.width_m),
            "Folded, each plate is tilted by gamma with cos gamma = (P/2)/c; the accordion folds upward: odd hinge lines sit c sin gamma above the top joints.".into(),
            format!("Residual deck fold: the plates are c = (pitch/2)/cos({} deg) long, so at full deployment (P = pitch) each plate is still tilted by {} deg and the odd hinge lines sit {:.2e} m above z = 0. With c = pitch/2 exactly (deck_fold_deg = 0) the flat deck is a singular end point: P reaches its maximum there, the sleeves' gap only touches zero without changing sign (no latch), the deck would snap through to the downward fold, and the inertia of the plate joints diverges, so the stepping does not converge. The 0.1 deg fold keeps every paper reference point within 1e-3 m.", p.deck_fold_deg, p.deck_fold_deg, c_plate * p.deck_fold_deg.to_radians().sin()),
            format!("Joint numbering (paper anchors): J1 = boom A bottom, J2 = boom A top, J3 = boom B top, J4 = boom B bottom at station 0; then per station u = 1..={n} a block of six: odd hinge joint on boom A's side, on boom B's side, then A bottom, A top, B top, B bottom. Hence J5 deploys to (0.5, 0, ~0), J{} (last A top) to ({}, 0, 0), J{} (last B bottom) to ({}, {}, -H_d).", last - 2, n as f64 * p.pitch_m, last, n as f64 * p.pitch_m, p.width_m),
            "Masses: boom joints (tops, which the deck shares, and bottoms) 0.15 kg; plate-only joints 0.075 kg; the two drums 0.05 kg (fixed, so inert).".into(),
            "Supports (paper): J1 and J4 fixed (xyz); x of J2 and J3 fixed, so they slide vertically as H changes.".into(),
            "Added support: y of J2 is also fixed (a vertical guide rail). Without it the cross-section J1-J2-J3-J4 is a parallelogram and the whole array racks sideways (both booms lean in y, the deck translates): a finite mechanism that no lock removes (analyze: 2 mechanisms before locks, 1 after).".into(),
            "Sleeves (paper): the vertical struts J1-J2 and J3-J4 are sleeves latching at lock_length_m = H_d, i.e. at alpha = deploy angle; the deck keeps both booms in step, so both latch at the same instant.".into(),
            "Drive cables (one per boom, constant motor tension, capstan friction mu at each pulley): motor drum fixed at (0, y, -H_d - 0.3) below the base; path drum -> top_0 -> bottom_0 -> top_1 -> bottom_1 -> ... -> top_N -> bottom_N (anchored). For boom A: drum_A, J2, J1, J8, J7, ..., J26, J25: fixed at J25, over a pulley at J26, zigzag down the boom along its rods with a pulley at each kink, over a pulley at J2 to the drum.".into(),
            "Cable length l = drop + (N+2) L cos alpha + N L: the drum run and the N+1 vertical runs top_u-bottom_u shorten as the array deploys, the runs along rods keep length L. The drum run passes J1 on its way up to J2 (harmless: J1 is fixed).".into(),
            "Damping 5 N s/m per joint (not in the paper): undamped, the 2 x 10 N cables put about 60 J of kinetic energy into the array, and as the deck straightens nearly all of it flows into the plate-only joints (about 11 m/s), which the fixed-point Newmark iteration cannot follow. With 5 N s/m the array deploys in about 33 s; the paper's 140 s implies stronger dissipation (about 20 N s/m) or a speed-controlled motor, neither stated. Use --damping to change it.".into(),
            "Time step 0.01 s instead of the paper's 0.05 s: at alpha = 1 deg the folded plates and rods are nearly parallel, and the Newmark iteration of the first step does not converge for dt >= 0.0125 s. Damping above 2 m/dt = 15 N s/m would need a still smaller dt.".into(),
            "Reference geometry is the closed-form geometry at alpha = deploy angle (gamma = deck fold), not the simulator's.".into(),
        ],
        dt_s: p.dt_s,
        end_time_s: 600.0,
        damping_n_s_per_m: p.damping_n_s_per_m,
        elastic_members: false,
        joints,
        elements,
        cables,
        ..Default::default()
    })
}
