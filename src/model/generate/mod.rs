//! Parametric model generators. Each writes the folded initial geometry and the
//! reference deployed geometry from closed-form geometry, never from the
//! simulator, and lists its modelling choices in the file's notes.

use super::file::{CableDoc, ElementDoc, JointDoc, ModelDoc};
use crate::solver::elements::Param;

/// Pantograph mast of `units` linear scissor-link units stacked along z, in the
/// x-z plane.
#[derive(Clone, Debug)]
pub struct MastParams {
    pub units: usize,
    pub rod_length_m: f64,
    pub joint_mass_kg: f64,
    /// Rod angle from the horizontal when folded and when deployed (deg).
    pub start_deg: f64,
    pub deploy_deg: f64,
    pub tension_n: f64,
    pub max_tension_n: f64,
    pub friction_mu: f64,
    pub damping_n_s_per_m: f64,
    pub dt_s: f64,
    /// Compliant latches on the sleeves: stiffness (N/m) and damping (N s/m);
    /// rigid latches when None.
    pub latch: Option<LatchParams>,
}

/// A compliant latch as the generators write it on every sleeve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LatchParams {
    pub stiffness_n_per_m: f64,
    pub damping_n_s_per_m: f64,
}

/// The parameters of a sleeve latching at `lock_length_m`, with the checked
/// compliant-latch parameters `spring` (`LatchParams::sleeve_params`, or none).
pub fn sleeve_lock(spring: &[(String, Param)], lock_length_m: f64) -> Vec<(String, Param)> {
    let mut params = vec![("lock_length_m".to_string(), Param::Num(lock_length_m))];
    params.extend_from_slice(spring);
    params
}

/// The sleeves' latch parameters (checked): the compliant latch of a
/// generator's `latch`, none for rigid latches.
pub fn latch_params(latch: Option<&LatchParams>) -> Result<Vec<(String, Param)>, GenerateError> {
    latch.map_or(Ok(Vec::new()), LatchParams::sleeve_params)
}

/// The model note of compliant latches.
pub fn latch_note(l: &LatchParams) -> String {
    format!(
        "Latches are compliant: {} N/m and {} N s/m each (a spring-loaded latch pin in a 20 mm telescoping tube: an assumption, not a measured value); the peak latch force depends on it.",
        l.stiffness_n_per_m, l.damping_n_s_per_m
    )
}

impl LatchParams {
    /// The sleeve parameters, after checking them.
    pub fn sleeve_params(&self) -> Result<Vec<(String, Param)>, GenerateError> {
        let (k, c) = (self.stiffness_n_per_m, self.damping_n_s_per_m);
        if !(k.is_finite() && k > 0.0 && c.is_finite() && c >= 0.0) {
            return Err(GenerateError(format!(
                "latch stiffness {k} N/m must be > 0 and latch damping {c} N s/m >= 0"
            )));
        }
        Ok(vec![
            ("latch_stiffness_n_per_m".into(), Param::Num(k)),
            ("latch_damping_n_s_per_m".into(), Param::Num(c)),
        ])
    }
}

impl Default for MastParams {
    fn default() -> Self {
        MastParams {
            units: 4,
            rod_length_m: 0.5,
            joint_mass_kg: 0.15,
            start_deg: 5.0,
            deploy_deg: 60.0,
            tension_n: 0.02,
            max_tension_n: 1.0,
            friction_mu: 0.005,
            damping_n_s_per_m: 0.0,
            dt_s: 0.05,
            latch: None,
        }
    }
}

/// Checks a generator's drive and dissipation options (also NaN: every test fails).
pub(crate) fn check_drive(
    tension_n: f64,
    max_tension_n: f64,
    mu: f64,
    damping: f64,
) -> Result<(), GenerateError> {
    if !(tension_n >= 0.0 && tension_n <= max_tension_n && mu >= 0.0 && damping >= 0.0) {
        return Err(GenerateError(format!(
            "drive tension {tension_n:?} N must be within 0..{max_tension_n:?} N, friction {mu:?} and damping {damping:?} N s/m must be >= 0"
        )));
    }
    Ok(())
}

pub fn mast_joint_names(units: usize) -> Vec<String> {
    (0..=units)
        .flat_map(|u| [format!("L{u}"), format!("R{u}")])
        .collect()
}

/// Closed-form mast geometry at rod angle phi (rad): level u has its left joint at
/// (0, 0, u L sin phi) and its right joint at (L cos phi, 0, u L sin phi). Every unit
/// is a rectangle whose diagonals are the two rods, crossing at their midpoints.
pub fn mast_positions(units: usize, rod_length_m: f64, phi: f64) -> Vec<[f64; 3]> {
    let (w, h) = (rod_length_m * phi.cos(), rod_length_m * phi.sin());
    (0..=units)
        .flat_map(|u| [[0.0, 0.0, u as f64 * h], [w, 0.0, u as f64 * h]])
        .collect()
}

/// d/dphi of the closed-form positions, for the one-DOF energy oracle.
pub fn mast_velocity_coefficients(units: usize, rod_length_m: f64, phi: f64) -> Vec<[f64; 3]> {
    let l = rod_length_m;
    (0..=units)
        .flat_map(|u| {
            [
                [0.0, 0.0, u as f64 * l * phi.cos()],
                [-l * phi.sin(), 0.0, u as f64 * l * phi.cos()],
            ]
        })
        .collect()
}

/// The drive cable's path: motor at L0, then L0 -> R0 -> L1 -> R1 -> ... -> R_N.
/// Its horizontal runs L_u -> R_u shorten as the mast rises; the runs R_u -> L_{u+1}
/// lie along scissor rods and keep their length, so the cable length is
/// (N+1) L cos phi + N L.
pub fn mast_cable_path(units: usize) -> Vec<String> {
    mast_joint_names(units)
}

pub fn mast_cable_length(units: usize, rod_length_m: f64, phi: f64) -> f64 {
    (units as f64 + 1.0) * rod_length_m * phi.cos() + units as f64 * rod_length_m
}

pub fn mast(p: &MastParams) -> Result<ModelDoc, GenerateError> {
    if !(1..=500).contains(&p.units) {
        return Err(GenerateError(format!(
            "--units {} is out of range; a mast has 1 to 500 units",
            p.units
        )));
    }
    let spring = latch_params(p.latch.as_ref())?;
    let positive = [p.rod_length_m, p.joint_mass_kg, p.dt_s];
    if positive.iter().any(|v| !(v.is_finite() && *v > 0.0)) {
        return Err(GenerateError(
            "rod length, joint mass and dt must be positive and finite".into(),
        ));
    }
    if !(p.start_deg > 0.5 && p.start_deg < p.deploy_deg && p.deploy_deg < 89.0) {
        return Err(GenerateError(format!(
            "start angle {} deg and deploy angle {} deg must satisfy 0.5 < start < deploy < 89",
            p.start_deg, p.deploy_deg
        )));
    }
    check_drive(
        p.tension_n,
        p.max_tension_n,
        p.friction_mu,
        p.damping_n_s_per_m,
    )?;
    let (phi0, phid) = (p.start_deg.to_radians(), p.deploy_deg.to_radians());
    let names = mast_joint_names(p.units);
    let x0 = mast_positions(p.units, p.rod_length_m, phi0);
    let xd = mast_positions(p.units, p.rod_length_m, phid);
    let joints = names
        .iter()
        .zip(x0.iter().zip(&xd))
        .map(|(n, (a, b))| JointDoc {
            name: n.clone(),
            position_m: *a,
            mass_kg: p.joint_mass_kg,
            reference_m: Some(*b),
        })
        .collect();
    let mut elements = Vec::new();
    let lock_len = p.rod_length_m * phid.sin();
    let support = |name: &str, joint: &str, fix: &str| ElementDoc {
        kind: "support".into(),
        name: name.into(),
        joints: vec![joint.into()],
        params: vec![("fix".into(), Param::Text(fix.into()))],
    };
    elements.push(support("base_L0", "L0", "xyz"));
    elements.push(support("base_R0", "R0", "yz"));
    for u in 1..=p.units {
        elements.push(support(&format!("plane_L{u}"), &format!("L{u}"), "y"));
        elements.push(support(&format!("plane_R{u}"), &format!("R{u}"), "y"));
    }
    for u in 0..p.units {
        elements.push(ElementDoc {
            kind: "scissor".into(),
            name: format!("U{}", u + 1),
            joints: vec![
                format!("L{u}"),
                format!("R{}", u + 1),
                format!("R{u}"),
                format!("L{}", u + 1),
            ],
            params: vec![("ratio".into(), Param::Num(1.0))],
        });
        elements.push(ElementDoc {
            kind: "sleeve".into(),
            name: format!("S{}", u + 1),
            joints: vec![format!("L{u}"), format!("L{}", u + 1)],
            params: sleeve_lock(&spring, lock_len),
        });
    }
    Ok(ModelDoc {
        name: "pantograph_mast".into(),
        description: format!(
            "Planar pantograph mast of {} linear scissor-link units, rods {} m, deploying from {} deg to {} deg",
            p.units, p.rod_length_m, p.start_deg, p.deploy_deg
        ),
        notes: vec![
            "Units stack along z in the x-z plane; level u has joints L_u (left) and R_u (right).".into(),
            "Each unit is a scissor (SLE) with rods L_u-R_{u+1} and R_u-L_{u+1} pinned at their midpoints (ratio 1).".into(),
            "Supports: L0 fixed; R0 slides along x; every joint is held in the plane y = 0 (a planar mast): one mechanism remains.".into(),
            "Sleeves L_u-L_{u+1} latch at the design unit height L sin(deploy angle); all latch together since the units move as one.".into(),
            "Drive cable from a motor at L0 over pulleys L0-R0-L1-R1-...-R_N (anchored at R_N): its horizontal runs shorten as the mast rises.".into(),
            "The drive tension is small on purpose: with no damping the mast accelerates freely, and this tension gives a deployment of tens of seconds.".into(),
            "Reference geometry is the closed-form rectangle stack at the deploy angle.".into(),
        ]
        .into_iter()
        .chain(p.latch.as_ref().map(latch_note))
        .collect(),
        dt_s: p.dt_s,
        end_time_s: 600.0,
        damping_n_s_per_m: p.damping_n_s_per_m,
        elastic_members: false,
        joints,
        elements,
        cables: vec![CableDoc {
            name: "drive".into(),
            path: mast_cable_path(p.units),
            tension_n: p.tension_n,
            max_tension_n: p.max_tension_n,
            friction_mu: p.friction_mu,
            pulley_radius_m: 0.01,
            ..CableDoc::default()
        }],
        ..Default::default()
    })
}

pub mod ring;
pub mod ring_stowing;
pub mod sail;

/// A generator's options that make no model (`mast`, `ring`, `sail`): the
/// message names the option (as the command line spells it) and its range.
#[derive(Clone, Debug, PartialEq)]
pub struct GenerateError(pub String);

impl std::fmt::Display for GenerateError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for GenerateError {}

/// (the command line prints the message as it is)
impl From<GenerateError> for String {
    fn from(e: GenerateError) -> String {
        e.0
    }
}
