//! The stowing double ring: the default `generate ring` and `models/double_ring.toml`.
//!
//! Every quadrilateral of the truss is a parallelogram that shears (the paper's
//! quadrilateral element with its diagonal sleeve; AstroMesh-type hoop trusses fold
//! the same way: the longerons of each bay turn until they lie along the posts):
//!
//! - Outer bay k (posts Ok, Ok+1, chords c_o): even frames sink by a_o, odd frames
//!   rise by a_o (alternating shear around the closed ring), so the chord tilts by
//!   phi with a_o = c_o sin(phi) / 2.
//! - Inner bay k (chords c_i) shears the other way: a_i < 0 (even inner posts high).
//! - Radial frame k (outer post Ok, inner post Ik, radial battens of fixed length w at
//!   top and bottom) is a parallelogram sheared by psi: the inner post sits
//!   delta = w sin(psi) above (even) or below (odd) the outer one, at a horizontal
//!   distance w cos(psi), so a_i = a_o - w sin(psi).
//! - The symmetric fold is the one-parameter family solving, for given a_o,
//!       r_o(a_o) - r_i(a_i) = w cos(psi),  r = sqrt(c^2 - 4 a^2) / (2 sin(pi/n)),
//!   for psi on the branch with a_i < 0 (`fold_state`, bisection). With the paper's
//!   numbers the ring depth w = (c_o - c_i) / (2 sin(pi/n)) = 0.7458 m is within
//!   0.06 % of the mean chord (c_o + c_i)/2 = 0.7462 m, and then psi = phi and the
//!   inner bays shear by -phi: the family runs from deployed (phi = 0) to a bundle
//!   of parallel posts on the ring's axis (phi = 90 deg). With other side counts the
//!   depth is not the mean chord and the fold stops short (36 sides: ~70 deg).
//!
//! Joints and hinges: the outer chords hang on revolute hinges whose axes are fixed
//! in the outer post's fitting (`frame_hinge`: the post and the normal of its radial
//! frame span the fitting, so the hinge axis does not turn as the frame shears).
//! The inner chords end in ball joints. With revolute hinges on both rings the
//! double ring is a one-mechanism linkage (the radial depth then has to be the same
//! at every frame: every bay shears alike); with the inner ends free each radial
//! frame shears on its own, and the ring has sides - 3 deployment mechanisms.
//!
//! Latches: the diagonal sleeves of the outer and inner bays latch at
//! sqrt(c^2 + h^2). With all of them latched the bays are flat, which forces every
//! radial frame square (the inner chords reach their length only at psi = 0).

use super::super::file::{CableDoc, ElementDoc, JointDoc, ModelDoc};
use super::ring::{
    fix_joint, hub_mount, members_note, ring_joints, RingParams, CHORD_UNIT_NOTE, DAMPING_NOTE,
    NUMBERING_NOTE,
};
use super::GenerateError;
use crate::solver::elements::Param;
use std::f64::consts::PI;

/// The symmetric folded state at outer chord tilt phi (rad).
#[derive(Clone, Copy, Debug)]
pub struct FoldState {
    /// Zig-zag offsets of the outer and inner posts (m); a_i < 0 when folded.
    pub a_outer_m: f64,
    pub a_inner_m: f64,
    /// Shear of the radial frames (rad).
    pub psi_rad: f64,
    /// Radii of the outer and inner posts (m).
    pub r_outer_m: f64,
    pub r_inner_m: f64,
}

/// Ring depth w: the radial battens' length, (c_o - c_i) / (2 sin(pi/n)).
pub fn ring_depth_m(p: &RingParams) -> f64 {
    (p.outer_chord_m - p.inner_chord_m) / (2.0 * (PI / p.sides as f64).sin())
}

/// Solves the symmetric fold at outer chord tilt phi (rad) on the stowing branch
/// (inner bays sheared the other way, a_i <= 0), by bisection on psi of
/// f(psi) = r_o - r_i(a_o - w sin psi) - w cos psi, from psi where a_i = 0 (f <= 0)
/// to where the inner chord is vertical (r_i = 0, f >= 0).
pub fn fold_state(p: &RingParams, phi: f64) -> Result<FoldState, GenerateError> {
    let s = (PI / p.sides as f64).sin();
    let (co, ci) = (p.outer_chord_m, p.inner_chord_m);
    let w = ring_depth_m(p);
    let a_o = 0.5 * co * phi.sin();
    let r_o = (co * co - 4.0 * a_o * a_o).max(0.0).sqrt() / (2.0 * s);
    let r_i = |psi: f64| {
        let a_i = a_o - w * psi.sin();
        (ci * ci - 4.0 * a_i * a_i).max(0.0).sqrt() / (2.0 * s)
    };
    let f = |psi: f64| r_o - r_i(psi) - w * psi.cos();
    if phi == 0.0 {
        return Ok(FoldState {
            a_outer_m: 0.0,
            a_inner_m: 0.0,
            psi_rad: 0.0,
            r_outer_m: r_o,
            r_inner_m: r_o - w,
        });
    }
    let lo0 = (a_o / w).min(1.0).asin();
    let hi0 = ((a_o + 0.5 * ci) / w).min(1.0).asin();
    let (mut lo, mut hi) = (lo0, hi0);
    if !(f(lo) <= 0.0 && f(hi) >= 0.0) {
        return Err(GenerateError(format!(
            "a {}-sided ring with chords {co} m and {ci} m (depth {w:.4} m) does not fold to {:.1} deg: its inner bays reach vertical first; use a smaller --start-deg",
            p.sides,
            phi.to_degrees()
        )));
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if f(mid) <= 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let psi = 0.5 * (lo + hi);
    Ok(FoldState {
        a_outer_m: a_o,
        a_inner_m: a_o - w * psi.sin(),
        psi_rad: psi,
        r_outer_m: r_o,
        r_inner_m: r_i(psi),
    })
}

/// Joint positions of the symmetric fold at outer chord tilt phi (rad), ring axis
/// along z through the origin, in the order of `ring_joint_names`.
pub fn stowing_positions(p: &RingParams, phi: f64) -> Result<Vec<[f64; 3]>, GenerateError> {
    let st = fold_state(p, phi)?;
    let n = p.sides;
    let h = p.height_m;
    let mut out = Vec::with_capacity(4 * n);
    for k in 0..n {
        let th = 2.0 * PI * k as f64 / n as f64;
        let sign = if k % 2 == 0 { -1.0 } else { 1.0 };
        let (c, s) = (th.cos(), th.sin());
        let (zo, zi) = (sign * st.a_outer_m, sign * st.a_inner_m);
        out.push([st.r_outer_m * c, st.r_outer_m * s, zo]);
        out.push([st.r_outer_m * c, st.r_outer_m * s, zo + h]);
        out.push([st.r_inner_m * c, st.r_inner_m * s, zi]);
        out.push([st.r_inner_m * c, st.r_inner_m * s, zi + h]);
    }
    Ok(out)
}

/// Bay-by-bay ring: length of the radial battens, w = w0 / cos(theta_d) with
/// w0 = (c_o - c_i) / (2 sin(pi/n)) the ring depth: each radial frame is
/// deployed as a parallelogram sheared theta_d, its inner post w sin(theta_d)
/// above the outer one at the plan depth w0.
pub fn raised_batten_m(p: &RingParams) -> f64 {
    ring_depth_m(p) / p.frame_shear_deg.to_radians().cos()
}

/// Bay-by-bay ring: length of inner chord k..k+1 minus c_i at outer chord
/// tilt phi, with the even frames sheared te and the odd ones to (rad): the
/// outer posts at r_o = c_o cos(phi) / (2 sin(pi/n)), even ones sunk by
/// a = c_o sin(phi) / 2 and odd ones raised by it, and each inner post at
/// r_o - w cos(t), w sin(t) above its outer post.
fn raised_chord_error(p: &RingParams, phi: f64, te: f64, to: f64) -> f64 {
    let n = p.sides as f64;
    let (co, ci) = (p.outer_chord_m, p.inner_chord_m);
    let w = raised_batten_m(p);
    let a = 0.5 * co * phi.sin();
    let r_o = co * phi.cos() / (2.0 * (PI / n).sin());
    let (r_even, r_odd) = (r_o - w * te.cos(), r_o - w * to.cos());
    let t = 2.0 * PI / n;
    let (px, py) = (r_odd * t.cos() - r_even, r_odd * t.sin());
    let dz = 2.0 * a + w * to.sin() - w * te.sin();
    (px * px + py * py + dz * dz).sqrt() - ci
}

/// The end time a bay-by-bay ring of `sides` sides is written with (s):
/// 2000 (n/18)^2 rounded up to the second, at least 2000. The drive pulls the bays open one after
/// another along a cable whose length and pulley count grow with n, so the
/// deployment takes about n^2 as long: the generated rings deploy at
/// 272, 613, 1117, 2667 and 12,927 s for 12, 18, 24, 36 and 72 sides at
/// mu 0.005 (4464 s for 36 sides at mu 0.02), within 56 % of this bound.
pub fn bay_by_bay_end_time_s(sides: usize) -> f64 {
    let r = sides as f64 / 18.0;
    (2000.0 * (r * r).max(1.0)).ceil()
}

/// Bay-by-bay ring: the 2-periodic fold at outer chord tilt phi (rad), the
/// frame shears (te, to) = (theta_d + x, theta_d - x) that keep every inner
/// chord at c_i, continued from x = 0 at phi = 0 in 200 steps of phi (at
/// each, the first sign change above the last x, then bisection).
pub fn raised_fold(p: &RingParams, phi: f64) -> Result<(f64, f64), GenerateError> {
    let thd = p.frame_shear_deg.to_radians();
    if phi == 0.0 {
        return Ok((thd, thd));
    }
    let mut x = 0.0f64;
    let steps = 200;
    for i in 1..=steps {
        let ph = phi * i as f64 / steps as f64;
        let f = |x: f64| raised_chord_error(p, ph, thd + x, thd - x);
        let (mut lo, f_lo) = (x, f(x));
        // (the fold's root is the first of two that leave x = 0 together,
        // about 0.1 ph apart at 18 sides and 18/n as far on n sides: the scan
        // starts at a step below that spacing, or it steps over both)
        let mut dx = if ph < 1e-3 {
            0.01 * ph
        } else {
            1e-4f64.min(1e-3 * ph)
        };
        let mut hi = lo + dx;
        while (f(hi) > 0.0) == (f_lo > 0.0) {
            dx *= 1.5;
            hi = lo + dx;
            if hi > PI {
                return Err(GenerateError(format!(
                    "the bay-by-bay ring does not fold to {:.1} deg (past {:.1} deg no frame shear keeps the inner chords at their length); use a smaller --start-deg",
                    phi.to_degrees(),
                    ph.to_degrees()
                )));
            }
        }
        for _ in 0..100 {
            let mid = 0.5 * (lo + hi);
            if (f(mid) > 0.0) == (f_lo > 0.0) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        x = 0.5 * (lo + hi);
    }
    Ok((thd + x, thd - x))
}

/// Bay-by-bay ring: joint positions of the 2-periodic fold at outer chord
/// tilt phi (rad), ring axis along z, in the order of `ring_joint_names`.
pub fn raised_positions(p: &RingParams, phi: f64) -> Result<Vec<[f64; 3]>, GenerateError> {
    let (te, to) = raised_fold(p, phi)?;
    let n = p.sides;
    let (h, w) = (p.height_m, raised_batten_m(p));
    let a = 0.5 * p.outer_chord_m * phi.sin();
    let r_o = p.outer_chord_m * phi.cos() / (2.0 * (PI / n as f64).sin());
    let mut out = Vec::with_capacity(4 * n);
    for k in 0..n {
        let th = 2.0 * PI * k as f64 / n as f64;
        let (c, s) = (th.cos(), th.sin());
        let (z_o, t) = if k % 2 == 0 { (-a, te) } else { (a, to) };
        let (r_i, z_i) = (r_o - w * t.cos(), z_o + w * t.sin());
        out.push([r_o * c, r_o * s, z_o]);
        out.push([r_o * c, r_o * s, z_o + h]);
        out.push([r_i * c, r_i * s, z_i]);
        out.push([r_i * c, r_i * s, z_i + h]);
    }
    Ok(out)
}

/// Path of the drive cable of one ring ("O" or "I") through every bay diagonal,
/// from the motor at frame 0 around the ring and back to frame 0, where its end is
/// anchored. The outer diagonals run from the low post's bottom to the high post's
/// top (even frames low); the inner ring is sheared the other way (odd frames low).
pub fn stowing_cable_path(n: usize, ring: &str) -> Vec<String> {
    let low_at_even = ring == "O";
    (0..=n)
        .map(|k| {
            let low = (k % 2 == 0) == low_at_even;
            format!("{ring}{}_{}", k % n, if low { "b" } else { "t" })
        })
        .collect()
}

/// The far end of radial frame k's diagonal from the outer post: the inner top on
/// even frames (inner post high), the inner foot on odd frames.
fn frame_diagonal_inner_end(n: usize, k: usize) -> String {
    format!("I{}_{}", k % n, if k % 2 == 0 { "t" } else { "b" })
}

fn dist(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// Horizontal distance of the farthest joint from the centroid of all joints.
pub fn horizontal_extent_m(x: &[[f64; 3]]) -> f64 {
    let m = x.len() as f64;
    let (cx, cy) = (
        x.iter().map(|p| p[0]).sum::<f64>() / m,
        x.iter().map(|p| p[1]).sum::<f64>() / m,
    );
    x.iter()
        .map(|p| ((p[0] - cx).powi(2) + (p[1] - cy).powi(2)).sqrt())
        .fold(0.0, f64::max)
}

pub fn stowing_ring(p: &RingParams) -> Result<ModelDoc, GenerateError> {
    let n = p.sides;
    let phi0 = p.start_deg.to_radians();
    let (x0, xd) = if p.bay_by_bay {
        (raised_positions(p, phi0)?, raised_positions(p, 0.0)?)
    } else {
        (stowing_positions(p, phi0)?, stowing_positions(p, 0.0)?)
    };
    let post = match p.mount.as_str() {
        "post" | "bus" => true,
        "hub" => false,
        other => {
            return Err(GenerateError(format!(
                "--mount {other}: the stowing ring is held at `post` (post O0 clamped to a boom), `bus` (post O0 clamped to a free-floating spacecraft) or `hub` (at its centre)"
            )))
        }
    };
    let bus = p.mount == "bus";
    // Held at post O0, the deployed ring is placed where that post starts; held at
    // its hub, the ring keeps its axis.
    let mut joints = ring_joints(p, &x0, &xd, post);
    let (h, co, ci) = (p.height_m, p.outer_chord_m, p.inner_chord_m);
    let w = ring_depth_m(p);
    let el =
        |kind: &str, name: String, joints: Vec<String>, params: Vec<(String, Param)>| ElementDoc {
            kind: kind.into(),
            name,
            joints,
            params,
        };
    let j = |ring: &str, k: usize, end: &str| format!("{ring}{}_{end}", k % n);
    let fix = fix_joint;
    let mut elements = Vec::new();
    if bus {
        elements.extend(bus_mount(p, &mut joints)?);
    } else if post {
        // Post O0 clamped to the boom's end fitting: its foot fixed, its top held
        // above it, and the fitting's turn about the post held by keeping frame 0's
        // inner foot in the plane y = 0.
        elements.push(fix(j("O", 0, "b"), "xyz"));
        elements.push(fix(j("O", 0, "t"), "xy"));
        elements.push(fix(j("I", 0, "b"), "y"));
    } else {
        elements.extend(hub_mount(n));
    }
    let spring = super::latch_params(p.latch.as_ref())?;
    let lock = |l: f64| super::sleeve_lock(&spring, l);
    for k in 0..n {
        for ring in ["O", "I"] {
            elements.push(el(
                "bar",
                format!("{ring}{k}_post"),
                vec![j(ring, k, "b"), j(ring, k, "t")],
                vec![],
            ));
        }
        // Radial frame k: battens of fixed length w, hinged at both posts, planar.
        for end in ["b", "t"] {
            elements.push(el(
                "bar",
                format!("R{k}_{end}"),
                vec![j("O", k, end), j("I", k, end)],
                vec![],
            ));
        }
        elements.push(el(
            "coplanar",
            format!("R{k}_plane"),
            vec![
                j("O", k, "b"),
                j("O", k, "t"),
                j("I", k, "t"),
                j("I", k, "b"),
            ],
            vec![],
        ));
        // Its long diagonal, outer foot to the inner top where the inner post is high
        // (even frames), inner foot to the outer top where it is low: length^2 =
        // w^2 + h^2 + 2 w h sin(psi); it latches passively.
        elements.push(el(
            "sleeve",
            format!("R{k}_diag"),
            vec![
                stowing_cable_path(n, "O")[k].clone(),
                frame_diagonal_inner_end(n, k),
            ],
            lock(if p.bay_by_bay {
                // (deployed sheared theta_d: its length there)
                let (a, b) = (
                    (k % n) * 4 + if k % 2 == 0 { 0 } else { 1 },
                    (k % n) * 4 + if k % 2 == 0 { 3 } else { 2 },
                );
                dist(&xd[a], &xd[b])
            } else {
                (w * w + h * h).sqrt()
            }),
        ));
        // Bottom chords on revolute hinges fixed in their post's fitting (the inner
        // ones only with `inner_hinges`; otherwise ball joints).
        let hinged: &[(&str, &str)] = if p.inner_hinges && !p.bay_by_bay {
            &[("O", "I"), ("I", "O")]
        } else {
            &[("O", "I")]
        };
        for (ring, across) in hinged {
            for (side, other) in [("next", k + 1), ("prev", k + n - 1)] {
                elements.push(el(
                    "frame_hinge",
                    format!("{ring}{k}_hinge_{side}"),
                    vec![
                        j(ring, k, "b"),
                        j(ring, k, "t"),
                        j(across, k, "b"),
                        j(ring, other, "b"),
                    ],
                    vec![],
                ));
            }
        }
        for (ring, c) in [("O", co), ("I", ci)] {
            elements.push(el(
                "bar",
                format!("{ring}_bay{k}_top"),
                vec![j(ring, k, "t"), j(ring, k + 1, "t")],
                vec![],
            ));
            elements.push(el(
                "bar",
                format!("{ring}_bay{k}_bottom"),
                vec![j(ring, k, "b"), j(ring, k + 1, "b")],
                vec![],
            ));
            elements.push(el(
                "coplanar",
                format!("{ring}_bay{k}_plane"),
                vec![
                    j(ring, k, "b"),
                    j(ring, k, "t"),
                    j(ring, k + 1, "t"),
                    j(ring, k + 1, "b"),
                ],
                vec![],
            ));
            if ring == "O" {
                // The long diagonal, low post's foot to high post's top: its length^2
                // = c^2 + h^2 + 4 a_o h falls to sqrt(c^2 + h^2) as the bay opens.
                let path = stowing_cable_path(n, ring);
                elements.push(el(
                    "sleeve",
                    format!("{ring}_diag{k}"),
                    vec![path[k].clone(), path[k + 1].clone()],
                    lock((c * c + h * h).sqrt()),
                ));
            }
        }
    }
    if p.bay_by_bay {
        // Inner bay diagonals, from the low inner post's foot (odd frames
        // low when stowed) to the high one's top, latching flat.
        let path = stowing_cable_path(n, "I");
        for k in 0..n {
            elements.push(el(
                "sleeve",
                format!("I_diag{k}"),
                vec![path[k].clone(), path[k + 1].clone()],
                lock((ci * ci + h * h).sqrt()),
            ));
        }
        // Compliant gears at the outer posts: the feet of the two outer bays
        // meeting at post Ok level along it (mirror axial), held by a
        // spring-damper instead of imposed.
        let (gk, gc) = (p.gear.stiffness_n_per_m, p.gear.damping_n_s_per_m);
        if !(gk.is_finite() && gk > 0.0 && gc.is_finite() && gc >= 0.0) {
            return Err(GenerateError(format!(
                "gear stiffness {gk} N/m must be > 0 and gear damping {gc} N s/m >= 0"
            )));
        }
        for k in 0..n {
            let params = vec![
                ("mirror".to_string(), Param::Text("axial".into())),
                ("stiffness_n_per_m".to_string(), Param::Num(gk)),
                ("damping_n_s_per_m".to_string(), Param::Num(gc)),
            ];
            elements.push(el(
                "sync_hinge",
                format!("GO{k}"),
                vec![
                    j("O", k, "b"),
                    j("O", k, "t"),
                    j("I", k, "b"),
                    j("O", k + n - 1, "b"),
                    j("O", k + 1, "b"),
                ],
                params,
            ));
        }
    }
    if let (true, Some(stop)) = (p.bay_by_bay, p.stroke_stop.as_ref()) {
        // Every sleeve's stroke: the lengths it takes along the symmetric fold
        // from stowed to deployed, with `stroke_margin_m` to spare; the stop
        // sits at the end away from the lock.
        let index = |name: &str| joints.iter().position(|j| j.name == name);
        let samples = 400;
        let path: Vec<Vec<[f64; 3]>> = (0..=samples)
            .map(|i| raised_positions(p, phi0 * i as f64 / samples as f64))
            .collect::<Result<_, _>>()?;
        let stops: Vec<ElementDoc> = elements
            .iter()
            .filter(|e| e.kind == "sleeve")
            .filter_map(|e| {
                let (a, b) = (index(&e.joints[0])?, index(&e.joints[1])?);
                let lock = e.params.iter().find_map(|(k, v)| match v {
                    Param::Num(l) if k == "lock_length_m" => Some(*l),
                    _ => None,
                })?;
                let lengths = path.iter().map(|x| dist(&x[a], &x[b]));
                let (lo, hi) = lengths.fold((f64::INFINITY, 0.0f64), |(lo, hi), l| {
                    (lo.min(l), hi.max(l))
                });
                let l0 = dist(&x0[a], &x0[b]);
                let (end, l) = if l0 > lock {
                    ("max_length_m", hi + p.stroke_margin_m)
                } else {
                    ("min_length_m", lo - p.stroke_margin_m)
                };
                Some(el(
                    "end_stop",
                    format!("{}_stop", e.name),
                    e.joints.clone(),
                    vec![
                        (end.to_string(), Param::Num(l)),
                        (
                            "stiffness_n_per_m".to_string(),
                            Param::Num(stop.stiffness_n_per_m),
                        ),
                        (
                            "damping_n_s_per_m".to_string(),
                            Param::Num(stop.damping_n_s_per_m),
                        ),
                    ],
                ))
            })
            .collect();
        elements.extend(stops);
    }
    let cable = CableDoc {
        name: "drive".into(),
        path: stowing_cable_path(n, "O"),
        tension_n: p.tension_n,
        max_tension_n: p.max_tension_n,
        friction_mu: p.friction_mu,
        pulley_radius_m: 0.01,
        ..CableDoc::default()
    };
    let extent = horizontal_extent_m(&x0) / horizontal_extent_m(&xd);
    if p.bay_by_bay {
        let (te, to) = raised_fold(p, phi0)?;
        let notes = bay_by_bay_notes(p, extent, (te, to), post);
        return Ok(ModelDoc {
            name: "double_ring".into(),
            description: format!(
                "{n}-sided double-ring deployable truss deploying bay by bay: outer chord {co} m, inner chord {ci} m, \
                 height {h} m, inner ring raised on radial frames sheared {} deg, stowed with the outer bays sheared {} deg \
                 (start extent {extent:.3} of the deployed)",
                p.frame_shear_deg, p.start_deg
            ),
            notes,
            dt_s: p.dt_s,
            end_time_s: bay_by_bay_end_time_s(n),
            damping_n_s_per_m: p.damping_n_s_per_m,
            elastic_members: p.elastic_members,
            joints,
            elements,
            cables: vec![cable],
            ..Default::default()
        });
    }
    let st = fold_state(p, phi0)?;
    let s = (PI / n as f64).sin();
    let (ro_d, ri_d) = (co / (2.0 * s), ci / (2.0 * s));
    Ok(ModelDoc {
        name: "double_ring".into(),
        description: format!(
            "{n}-sided double-ring deployable truss: outer chord {co} m, inner chord {ci} m, height {h} m, depth {w:.4} m, \
             stowed with the outer bays sheared {} deg (start extent {extent:.3} of the deployed)",
            p.start_deg
        ),
        notes: vec![
            format!("Outer ring circumradius {ro_d:.4} m (diameter {:.4} m, the paper's 5.0 m aperture), inner {ri_d:.4} m, from the chords.", 2.0 * ro_d),
            CHORD_UNIT_NOTE.into(),
            "Every quadrilateral is a parallelogram that shears to fold, as AstroMesh-type hoop trusses fold (bay longerons turn until they lie along the posts): outer bays (posts Ok, chords 0.8757 m), inner bays (chords 0.6167 m) and radial frames (outer post, inner post, radial battens of the ring depth).".into(),
            "Outer bays shear in alternating directions around the ring (even frames sink, odd frames rise), inner bays the other way; each radial frame shears so that its inner post rises (even) or sinks (odd).".into(),
            format!("Fold: with the paper's numbers the ring depth {w:.4} m is within 0.06 % of the mean chord {:.4} m, so every panel shears by nearly the same angle and the ring folds to a bundle of parallel posts on its axis. Start: outer bays sheared {} deg, frames {:.2} deg; the farthest joint is {:.3} of its deployed distance from the axis (r_o {:.4} m, r_i {:.4} m).", 0.5 * (co + ci), p.start_deg, st.psi_rad.to_degrees(), extent, st.r_outer_m, st.r_inner_m),
            "Each outer bay has a diagonal sleeve from its low post's foot to its high post's top; it shortens as the bay opens and latches at sqrt(c^2 + h^2). Each radial frame has a diagonal sleeve (its long diagonal, latching at sqrt(w^2 + h^2)): with the outer bays flat the inner chords hold the frames square only to first order in their common shear, and the frame diagonals make the latched ring rigid. The inner bays carry none (with a latch of their own they flatten ahead of the outer bays).".into(),
            if p.inner_hinges {
                "Hinges (assumed; the paper's figures are missing): every bottom chord on a revolute hinge whose axis is fixed in its post's fitting (frame_hinge: the post and its radial frame's normal span the fitting, so the axis does not turn as the frame shears), battens hinged about their frame's normal. No gears; yet with hinges on both rings every radial frame must keep one depth, so all bays shear alike: `analyze` counts 1 mechanism before the latches and 0 after, and every sleeve latches at one instant.".into()
            } else {
                "Hinges (assumed; the paper's figures are missing): outer bottom chords on revolute hinges fixed in the outer post's fitting (frame_hinge), inner chord ends on ball joints, battens hinged about their frame's normal. No gears: `analyze` counts 16 mechanisms for 18 sides before the latches (n - 3 = 15 by hand, one more first-order one at the symmetric start) and 0 after. This variant does not deploy: the inner ring flattens ahead of the outer one and the ring locks up short.".into()
            },
            "Drive (the paper's active cable through the diagonal sleeves): one cable from a motor at post O0's foot through every outer bay diagonal around the ring and back to O0, where its end is anchored; a pulley at every post joint on the way (radius 0.01 m) with capstan friction mu, so the tension falls along the cable away from the motor. The radial frame diagonals latch passively.".into(),
            if post {
                "Mount `post` (default): post O0 clamped to the end fitting of a boom (foot fixed, top held above it, the fitting's turn held by frame 0's inner foot at y = 0), as hoop-truss reflectors hang off their boom at one post. `--mount hub` holds the ring's centre instead.".into()
            } else {
                "Mount `hub`: the centre of the outer feet fixed, O0_b held at y = 0 against spin and the mean heights of two blocks of frames level. The default `post` mount clamps post O0 to a boom instead.".into()
            },
            DAMPING_NOTE.into(),
            "The synchronized ring (square frames, gears at every post, one mechanism, part-folded start) is `generate ring` (the default; `--sync` names its gears).".into(),
            NUMBERING_NOTE.into(),
        ]
        .into_iter()
        .chain(p.latch.as_ref().map(super::latch_note))
        .chain(members_note(p))
        .collect(),
        dt_s: p.dt_s,
        end_time_s: 600.0,
        damping_n_s_per_m: p.damping_n_s_per_m,
        elastic_members: p.elastic_members,
        joints,
        elements,
        cables: vec![cable],
        ..Default::default()
    })
}

/// The note of `--mount bus`.
fn bus_note(p: &RingParams) -> String {
    let b = &p.bus;
    format!(
        "Mount `bus`: post O0 clamped to a free-floating spacecraft bus in place of the ground (no support anywhere): {} kg, principal inertias {}, {}, {} kg m^2 about its centre along x, y, z, the centre {} m outward of post O0's foot at the post's mid-height; the bus is six joints BUS_px ... BUS_mz whose lumped masses carry that mass and inertia, held with post O0 by the rigid body `bus` (the fitting's turn by the coplanar `bus_fitting`). Joint damping is 0 unless --damping gives it: it acts on absolute velocities, an external force that would not conserve momentum; the gears, latches and members damp the deployment.",
        b.mass_kg, b.inertia_kg_m2[0], b.inertia_kg_m2[1], b.inertia_kg_m2[2], b.offset_m
    )
}

/// `--mount bus`: post O0 clamped to a free-floating spacecraft bus instead
/// of the ground. The bus is six joints (`BusParams::vertices`) whose
/// lumped masses carry its mass and inertia, its centre `offset_m` outward
/// of post O0's foot (away from the ring's centre, horizontally) at the
/// post's mid-height; one `rigid_body` holds the six and post O0's two
/// joints; the fitting's turn about the post (the `post` mount's I0_b
/// y = 0) is frame 0's inner foot kept in the plane of the post and the
/// bus's +z vertex (a `coplanar`). Appends the bus joints to `joints`.
fn bus_mount(p: &RingParams, joints: &mut Vec<JointDoc>) -> Result<Vec<ElementDoc>, GenerateError> {
    let pos = |name: &str, js: &[JointDoc]| -> [f64; 3] {
        js.iter()
            .find(|j| j.name == name)
            .expect("ring joint")
            .position_m
    };
    let refpos = |name: &str, js: &[JointDoc]| -> [f64; 3] {
        js.iter()
            .find(|j| j.name == name)
            .and_then(|j| j.reference_m)
            .expect("reference")
    };
    let (ob, ot) = (pos("O0_b", joints), pos("O0_t", joints));
    // outward: from the deployed ring's centre to O0_b, horizontally
    let n = joints.len() as f64;
    let mut c = [0.0; 3];
    for j in joints.iter() {
        let r = j.reference_m.expect("reference");
        for k in 0..3 {
            c[k] += r[k] / n;
        }
    }
    let rb = refpos("O0_b", joints);
    let (dx, dy) = (rb[0] - c[0], rb[1] - c[1]);
    let d = (dx * dx + dy * dy).sqrt();
    let centre = [
        ob[0] + p.bus.offset_m * dx / d,
        ob[1] + p.bus.offset_m * dy / d,
        0.5 * (ob[2] + ot[2]),
    ];
    let mut body = Vec::new();
    for (suffix, off, mass) in p.bus.vertices()? {
        let x = [centre[0] + off[0], centre[1] + off[1], centre[2] + off[2]];
        let name = format!("BUS_{suffix}");
        joints.push(JointDoc {
            name: name.clone(),
            position_m: x,
            mass_kg: mass,
            reference_m: Some(x),
        });
        body.push(name);
    }
    body.push("O0_b".into());
    body.push("O0_t".into());
    Ok(vec![
        ElementDoc {
            kind: "rigid_body".into(),
            name: "bus".into(),
            joints: body,
            params: vec![],
        },
        ElementDoc {
            kind: "coplanar".into(),
            name: "bus_fitting".into(),
            joints: vec!["O0_b".into(), "O0_t".into(), "BUS_pz".into(), "I0_b".into()],
            params: vec![],
        },
    ])
}

/// The model notes of the bay-by-bay ring: every joint choice with its source.
fn bay_by_bay_notes(p: &RingParams, extent: f64, (te, to): (f64, f64), post: bool) -> Vec<String> {
    let n = p.sides;
    let (co, ci, h) = (p.outer_chord_m, p.inner_chord_m, p.height_m);
    let s = (PI / n as f64).sin();
    let (w0, w) = (ring_depth_m(p), raised_batten_m(p));
    let thd = p.frame_shear_deg.to_radians();
    let mut notes = vec![
        format!("Outer ring circumradius {:.4} m (diameter {:.4} m, the paper's 5.0 m aperture), inner {:.4} m in plan, from the chords.", co / (2.0 * s), co / s, ci / (2.0 * s)),
        CHORD_UNIT_NOTE.into(),
        "Every quadrilateral is a parallelogram that shears to fold, as perimeter (hoop) trusses fold: the bay longerons turn until they lie along the posts (TRW, Folding perimeter truss reflector, EP 0959524 A1; NASA NTRS 19870001490: folded longerons, telescoping latching diagonals, bay-by-bay deployment).".into(),
        format!("Raised inner ring (assumed; docs/double_ring_stowing.md Finding 2): each radial frame (outer post, inner post, battens of {w:.4} m) is deployed as a parallelogram sheared {} deg, its inner post {:.4} m above the outer one at the plan depth {w0:.4} m. A square frame makes every flat bay a cone point (Finding 1); the sheared one does not.", p.frame_shear_deg, w * thd.sin()),
        format!("Fold (docs/double_ring_stowing.md): outer bays sheared in alternating directions by phi (even posts sink, odd rise by c_o sin(phi)/2); even frames sheared theta_d + x, odd theta_d - x, x solving for the inner chord length. Start: phi {} deg, frames {:.2} and {:.2} deg; the farthest joint is {extent:.3} of its deployed distance from the axis.", p.start_deg, te.to_degrees(), to.to_degrees()),
        "Hinges (assumed; the paper's figures are missing): outer bottom chords on revolute hinges with axes fixed in the outer post's fitting (frame_hinge), inner chord ends on ball joints, battens hinged in their frame's plane. The bays are then a multi-DOF mechanism, as Xu Yan et al. describe their double-ring truss (Acta Astronautica 2012: an over-constrained multi-DOF mechanism driven by cables).".into(),
        format!("Compliant gears at every outer post (sync_hinge, mirror axial, {} N/m, {} N s/m; assumed, not a measured value): the feet of the two outer bays meeting there kept level along the post by a spring instead of imposed, so the bays deploy unevenly but none folds the wrong way (docs/double_ring_stowing.md Finding 4).", p.gear.stiffness_n_per_m, p.gear.damping_n_s_per_m),
        format!("Latches (telescoping diagonal sleeves): each outer bay's diagonal (low post's foot to high post's top, at sqrt(c_o^2 + h^2) = {:.4} m), each inner bay's (at sqrt(c_i^2 + h^2) = {:.4} m) and each radial frame's long diagonal (at its deployed sheared length). Mechanisms before the latches, by hand: n - 3 = {} with the ball-jointed inner chords, plus one first-order one at the symmetric start (`analyze`: 16 for 18 sides); 0 after.", (co * co + h * h).sqrt(), (ci * ci + h * h).sqrt(), n - 3),
        "Drive (the paper's active cable through the diagonal sleeves): one cable from a motor at post O0's foot through every outer bay diagonal around the ring and back to O0, where its end is anchored; a pulley at every post joint on the way (radius 0.01 m) with capstan friction mu, so the tension falls along the cable away from the motor.".into(),
        "Latch order: the radial frames latch first and far apart, then the bays in adjacent pairs; the last open bays must surround the ring's axis (docs/double_ring_stowing.md Finding 5), so they flatten together and the order is not strictly motor end first.".into(),
    ];
    notes.push(if post {
        "Mount `post` (default): post O0 clamped to the end fitting of a boom (foot fixed, top held above it, the fitting's turn held by frame 0's inner foot at y = 0), as hoop-truss reflectors hang off their boom at one post (US 10131452 B2). `--mount hub` holds the ring's centre instead.".into()
    } else {
        "Mount `hub`: the centre of the outer feet fixed, O0_b held at y = 0 against spin and the mean heights of two blocks of frames level. The default `post` mount clamps post O0 to a boom instead.".into()
    });
    if p.mount == "bus" {
        notes.push(bus_note(p));
    }
    notes.push(DAMPING_NOTE.into());
    notes.push(NUMBERING_NOTE.into());
    notes.extend(p.latch.as_ref().map(super::latch_note));
    notes.extend(members_note(p));
    notes.extend(p.stroke_stop.as_ref().map(|s| format!(
        "Stroke stops (`--stroke-stops`; assumed, not a measured value): every sleeve's telescoping tube ends its stroke {} m beyond the length it takes along the symmetric fold farthest from its lock (an `end_stop` element, {} N/m, {} N s/m), so no bay folds tighter, and no frame shears further the wrong way, than the symmetric fold takes it (docs/double_ring_stowing.md, \"Why the 36-sided ring jams\").",
        p.stroke_margin_m, s.stiffness_n_per_m, s.damping_n_s_per_m
    )));
    notes
}
