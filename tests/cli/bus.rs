//! A free-floating spacecraft bus (`rigid_body`, `generate ring --mount
//! bus`): its mass and inertia as written, momentum over a deployment, and
//! the bus's turn against a two-body answer derived by hand.

use serde_json::Value;
use std::f64::consts::PI;
use std::fmt::Write;

use crate::{run, temp_dir, text};

fn simulate_json(model: &std::path::Path, dir: &std::path::Path) -> Value {
    let json = dir.join("s.json");
    let o = run(&[
        "simulate".as_ref(),
        model.as_os_str(),
        "--json".as_ref(),
        json.as_os_str(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap()
}

/// `generate ring --mount bus`: no support; the six bus joints carry the
/// stated mass and, about their centre, the stated principal inertias
/// (sum m (|r|^2 1 - r r^T)) to roundoff; other bus options need the mount.
#[test]
fn the_generated_bus_has_the_stated_mass_and_inertia() {
    let d = temp_dir("bus_generate");
    let f = d.join("bus.toml");
    let o = run(&[
        "generate".as_ref(),
        "ring".as_ref(),
        "--sides".as_ref(),
        "12".as_ref(),
        "--mount".as_ref(),
        "bus".as_ref(),
        "--bus-mass-kg".as_ref(),
        "250".as_ref(),
        "--bus-inertia".as_ref(),
        "40,55,70".as_ref(),
        "-o".as_ref(),
        f.as_os_str(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let doc: toml::Value = toml::from_str(&std::fs::read_to_string(&f).unwrap()).unwrap();
    let elements = doc["element"].as_array().unwrap();
    assert!(elements
        .iter()
        .all(|e| e["type"].as_str() != Some("support")));
    assert_eq!(
        elements
            .iter()
            .filter(|e| e["type"].as_str() == Some("rigid_body"))
            .count(),
        1
    );
    assert_eq!(doc["settings"]["damping_n_s_per_m"].as_float(), Some(0.0));
    let bus: Vec<([f64; 3], f64)> = doc["joint"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|j| j["name"].as_str().unwrap().starts_with("BUS_"))
        .map(|j| {
            let p: Vec<f64> = j["position_m"]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_float().unwrap())
                .collect();
            ([p[0], p[1], p[2]], j["mass_kg"].as_float().unwrap())
        })
        .collect();
    assert_eq!(bus.len(), 6);
    let m: f64 = bus.iter().map(|b| b.1).sum();
    assert!((m - 250.0).abs() < 1e-12 * 250.0, "{m}");
    let c: Vec<f64> = (0..3)
        .map(|k| bus.iter().map(|b| b.1 * b.0[k]).sum::<f64>() / m)
        .collect();
    let mut j = [[0.0; 3]; 3];
    for (p, mass) in &bus {
        let r = [p[0] - c[0], p[1] - c[1], p[2] - c[2]];
        let rr = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
        for a in 0..3 {
            for b in 0..3 {
                j[a][b] += mass * ((a == b) as u8 as f64 * rr - r[a] * r[b]);
            }
        }
    }
    for (a, want) in [40.0, 55.0, 70.0].iter().enumerate() {
        assert!(
            (j[a][a] - want).abs() < 1e-12 * want,
            "J_{a}{a} = {}",
            j[a][a]
        );
        for b in 0..3 {
            if a != b {
                assert!(j[a][b].abs() < 1e-12 * want);
            }
        }
    }
    // a body no real inertia makes, and bus options without the bus
    let o = run(&[
        "generate",
        "ring",
        "--mount",
        "bus",
        "--bus-inertia",
        "1,1,5",
        "-o",
        "-",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains("less than the sum of the other two"),
        "{}",
        text(&o)
    );
    let o = run(&["generate", "ring", "--bus-mass-kg", "50", "-o", "-"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("--mount bus"), "{}", text(&o));
}

/// A 12-sided ring deploying on a free bus (no external force: no support,
/// no joint damping, the cable between the ring's joints): both momenta stay
/// at their start to 1e-9 of their scales (the step holds them: the
/// trapezoid alone conserves the angular one only to its truncation, whose
/// sum the summary reports, 1.7e-6 measured); the bus turns as the ring
/// opens on its one side.
#[test]
fn a_ring_deploying_on_a_free_bus_keeps_its_momentum() {
    let d = temp_dir("bus_ring");
    let f = d.join("bus12.toml");
    let o = run(&[
        "generate".as_ref(),
        "ring".as_ref(),
        "--sides".as_ref(),
        "12".as_ref(),
        "--mount".as_ref(),
        "bus".as_ref(),
        "-o".as_ref(),
        f.as_os_str(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let s = simulate_json(&f, &d);
    assert_eq!(s["stop_reason"], "deployed");
    assert_eq!(s["accepting_fallbacks"].as_u64(), Some(0));
    let p = &s["momentum"];
    assert!(p["linear_drift_rel"].as_f64().unwrap() < 1e-12, "{p}");
    assert!(p["angular_drift_rel"].as_f64().unwrap() < 1e-9, "{p}");
    assert_eq!(p["held"], true, "{p}");
    let removed = p["angular_removed_rel"].as_f64().unwrap();
    assert!(removed > 0.0 && removed < 1e-5, "{p}");
    let bus = &s["bodies"][0];
    assert_eq!(bus["name"], "bus");
    assert!(
        bus["final_attitude_change_deg"].as_f64().unwrap() > 1.0,
        "{bus}"
    );
    assert!(bus["peak_rate_rad_s"].as_f64().unwrap() > bus["final_rate_rad_s"].as_f64().unwrap());
}

/// The two-body answer. A bus (six joints carrying M and J, plus four
/// light anchor joints A, A_up, A_dn, A_x rigid with it, placed so that
/// the plane z = 0 holds the centre of mass and z stays a principal axis) and a point mass m held
/// on the bus-fixed line through A along x at height y = e above the bus's
/// centre of mass (two `coplanar` rows), pulled toward A by a cable and
/// latched by a sleeve. Planar, at rest at the start: the total angular
/// momentum about the system's centre of mass is 0,
///     J w + mu (r x rdot) = 0,   r = R(theta) (s, e),   mu = M m / (M + m),
/// with J and M the bus's (anchors included) about its centre of mass and s
/// the mass's coordinate along the line from there; r x rdot = -e sdot + w
/// (s^2 + e^2), so dtheta/ds = mu e / (J + mu (s^2 + e^2)) and
///     Delta theta = (e / k) (atan(s1 / k) - atan(s0 / k)),  k^2 = (J + mu e^2) / mu,
/// whatever the cable does; after the latch the two turn as one at w = 0.
/// With e = 0 (the line through the centre of mass) the bus does not turn.
/// `mirrored`: a second arm, the first's mirror image in the plane y = 0
/// (A2 at y = -e, P2 at P's mirror point): the model is symmetric under the
/// reflection, which reverses L_z, so the two arms' turns of the bus cancel
/// (the two-body answer is then not the model's; `exact` is the one arm's).
/// (A half turn about z would not do: it keeps L_z, and the turns add.)
fn two_body(e: f64, mirrored: bool, dir: &std::path::Path) -> (f64, f64, Value) {
    let (mbus, j, m): (f64, [f64; 3], f64) = (100.0, [10.0, 12.0, 14.0], 5.0);
    let (anchor_m, a_x, u0, u1) = (0.01, 0.6, -1.1, -0.3);
    let tr = j[0] + j[1] + j[2];
    let a = (0.5 * tr / mbus).sqrt();
    let mu_k = |k: usize| mbus * (0.5 * tr - j[k]) / tr;
    let mut joints: Vec<(String, [f64; 3], f64)> = vec![
        ("BUS_px".into(), [a, 0.0, 0.0], mu_k(0)),
        ("BUS_mx".into(), [-a, 0.0, 0.0], mu_k(0)),
        ("BUS_py".into(), [0.0, a, 0.0], mu_k(1)),
        ("BUS_pz".into(), [0.0, 0.0, a], mu_k(2)),
        ("BUS_my".into(), [0.0, -a, 0.0], mu_k(1)),
        ("BUS_mz".into(), [0.0, 0.0, -a], mu_k(2)),
        ("A".into(), [a_x, e, 0.0], anchor_m),
        ("A_up".into(), [a_x, e, 0.4], anchor_m),
        ("A_dn".into(), [a_x, e, -0.4], anchor_m),
        ("A_x".into(), [a_x + 0.5, e, 0.0], anchor_m),
    ];
    // the bus's centre of mass and J_z with the anchors
    let mb: f64 = joints.iter().map(|j| j.2).sum();
    let cx = joints.iter().map(|j| j.2 * j.1[0]).sum::<f64>() / mb;
    let cy = joints.iter().map(|j| j.2 * j.1[1]).sum::<f64>() / mb;
    let jz: f64 = joints
        .iter()
        .map(|j| j.2 * ((j.1[0] - cx).powi(2) + (j.1[1] - cy).powi(2)))
        .sum();
    if mirrored {
        for (n, p) in [
            ("A2", [a_x, -e, 0.0]),
            ("A2_up", [a_x, -e, 0.4]),
            ("A2_dn", [a_x, -e, -0.4]),
            ("A2_x", [a_x + 0.5, -e, 0.0]),
        ] {
            joints.push((n.into(), p, anchor_m));
        }
    }
    let bus_joints = joints.len();
    joints.push(("P".into(), [a_x + u0, e, 0.0], m));
    if mirrored {
        joints.push(("P2".into(), [a_x + u0, -e, 0.0], m));
    }
    let mut t = String::from(
        "[model]\nname = \"two_body\"\n[settings]\ndt_s = 0.01\nend_time_s = 60.0\ngravity_m_s2 = [0.0, 0.0, 0.0]\ndamping_n_s_per_m = 0.0\n",
    );
    for (n, p, mass) in &joints {
        writeln!(
            t,
            "[[joint]]\nname = \"{n}\"\nposition_m = [{:?}, {:?}, {:?}]\nmass_kg = {mass:?}",
            p[0], p[1], p[2]
        )
        .unwrap();
    }
    let names: Vec<String> = joints[..bus_joints]
        .iter()
        .map(|j| format!("\"{}\"", j.0))
        .collect();
    writeln!(
        t,
        "[[element]]\ntype = \"rigid_body\"\nname = \"bus\"\njoints = [{}]",
        names.join(", ")
    )
    .unwrap();
    t += "[[element]]\ntype = \"coplanar\"\nname = \"line_y\"\njoints = [\"A\", \"A_up\", \"A_x\", \"P\"]\n";
    t += "[[element]]\ntype = \"coplanar\"\nname = \"line_z\"\njoints = [\"A\", \"A_x\", \"BUS_py\", \"P\"]\n";
    writeln!(t, "[[element]]\ntype = \"sleeve\"\nname = \"S\"\njoints = [\"A\", \"P\"]\nlock_length_m = {:?}", -u1).unwrap();
    t += "[[cable]]\nname = \"pull\"\npath = [\"A\", \"P\"]\ntension_n = 2.0\nmax_tension_n = 4.0\nfriction_mu = 0.0\npulley_radius_m = 0.01\n";
    if mirrored {
        t += "[[element]]\ntype = \"coplanar\"\nname = \"line2_y\"\njoints = [\"A2\", \"A2_up\", \"A2_x\", \"P2\"]\n";
        t += "[[element]]\ntype = \"coplanar\"\nname = \"line2_z\"\njoints = [\"A2\", \"A2_x\", \"BUS_my\", \"P2\"]\n";
        writeln!(t, "[[element]]\ntype = \"sleeve\"\nname = \"S2\"\njoints = [\"A2\", \"P2\"]\nlock_length_m = {:?}", -u1).unwrap();
        t += "[[cable]]\nname = \"pull2\"\npath = [\"A2\", \"P2\"]\ntension_n = 2.0\nmax_tension_n = 4.0\nfriction_mu = 0.0\npulley_radius_m = 0.01\n";
    }
    let f = dir.join(format!("two_body_{e}_{mirrored}.toml"));
    std::fs::write(&f, t).unwrap();
    let s = simulate_json(&f, dir);
    assert_eq!(s["stop_reason"], "deployed", "{}", s["stop_message"]);
    let mu = mb * m / (mb + m);
    // (the line's offset from the bus's centre of mass, which the anchors move)
    let ec = e - cy;
    let k = ((jz + mu * ec * ec) / mu).sqrt();
    let (s0, s1) = (a_x + u0 - cx, a_x + u1 - cx);
    let exact = (ec / k) * ((s1 / k).atan() - (s0 / k).atan());
    let turned = s["bodies"][0]["final_attitude_change_deg"]
        .as_f64()
        .unwrap()
        * PI
        / 180.0;
    (turned, exact, s)
}

#[test]
fn an_offset_pull_turns_the_bus_by_the_two_body_angle() {
    let d = temp_dir("bus_two_body");
    let (turned, exact, s) = two_body(0.8, false, &d);
    assert!(exact.abs() > 1e-3, "{exact}");
    // (the angle's sign is not reported: the axis is, along -z for e > 0;
    // 1.1e-7 measured at dt 0.01, 4.9e-7 with the angular momentum not held)
    assert!(
        (turned - exact.abs()).abs() <= 2.5e-7 * exact.abs(),
        "turned {turned:.12e} rad, two-body answer {exact:.12e} rad"
    );
    let axis = &s["bodies"][0]["final_rotation_axis"];
    assert!(
        (axis[2].as_f64().unwrap().abs() - 1.0).abs() < 1e-9,
        "{axis}"
    );
    // latched, the two turn as one body with L = 0: at rest
    let (last, peak) = (
        s["bodies"][0]["final_rate_rad_s"].as_f64().unwrap(),
        s["bodies"][0]["peak_rate_rad_s"].as_f64().unwrap(),
    );
    assert!(
        last < 1e-5 * peak,
        "final rate {last:e} rad/s, peak {peak:e} rad/s"
    );
    assert!(s["momentum"]["linear_drift_rel"].as_f64().unwrap() < 1e-12);
}

#[test]
fn a_pull_through_the_centre_of_mass_leaves_the_attitude_unchanged() {
    let d = temp_dir("bus_symmetric");
    let (turned, _, s) = two_body(0.0, false, &d);
    assert!(turned < 1e-12, "turned {turned:e} rad");
    assert!(
        s["momentum"]["angular_drift_rel"].as_f64().unwrap() < 1e-12,
        "{}",
        s["momentum"]
    );
}

/// Two arms, each of which alone turns the bus by the two-body angle (10.04
/// deg), drawn in at once, mirror images on a bus symmetric in that mirror:
/// their turns cancel, the bus keeps its attitude to roundoff while the
/// system's angular momentum stays 0.
#[test]
fn a_symmetric_deployment_on_a_symmetric_bus_leaves_the_attitude_unchanged() {
    let d = temp_dir("bus_mirrored");
    let (turned, one_arm, s) = two_body(0.8, true, &d);
    assert!(one_arm.abs() > 0.1, "{one_arm}");
    assert!(
        turned < 1e-12,
        "turned {turned:e} rad (one arm alone: {one_arm:e} rad)"
    );
    assert_eq!(s["locks"].as_array().unwrap().len(), 2);
    assert!(
        s["momentum"]["angular_drift_rel"].as_f64().unwrap() < 1e-12,
        "{}",
        s["momentum"]
    );
}

/// `--history`: `bodies.parquet` holds the bus's attitude and rate at every
/// step, its last row the summary's final attitude, its largest rate the
/// summary's peak, and the linear momentum 0 to roundoff all along.
#[test]
fn the_history_has_the_bus_over_time() {
    let Some(py) = crate::python_with(
        "pandas, pyarrow",
        None,
        "TRUSS_REQUIRE_PYARROW",
        "pandas, pyarrow",
    ) else {
        return;
    };
    let d = temp_dir("bus_history");
    let (json, hist) = (d.join("s.json"), d.join("hist"));
    let o = run(&[
        "simulate".as_ref(),
        std::path::Path::new("models/ring_on_bus.toml").as_os_str(),
        "--json".as_ref(),
        json.as_os_str(),
        "--history".as_ref(),
        hist.as_os_str(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let s: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let script = r#"
import json, sys
import pandas as pd
b = pd.read_parquet(sys.argv[1] + "/bodies.parquet")
j = pd.read_parquet(sys.argv[1] + "/joints.parquet")
lin = max(abs(b[f"linear_momentum_{c}_n_s"]).max() for c in "xyz")
print(json.dumps({
    "rows": len(b), "joint_rows": len(j),
    "last_attitude_deg": float(b["bus.attitude_change_deg"].iloc[-1]),
    "peak_rate": float(b["bus.rate_rad_s"].max()),
    "peak_t": float(b["t_s"][b["bus.rate_rad_s"].idxmax()]),
    "linear": float(lin),
}))
"#;
    let o = std::process::Command::new(&py)
        .arg("-c")
        .arg(script)
        .arg(&hist)
        .output()
        .expect("python");
    assert!(o.status.success(), "{}", text(&o));
    let v: Value =
        serde_json::from_slice(&o.stdout).unwrap_or_else(|e| panic!("{e}: {}", text(&o)));
    assert_eq!(v["rows"], v["joint_rows"]);
    let bus = &s["bodies"][0];
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * b.abs().max(1e-12);
    let (att, want) = (
        v["last_attitude_deg"].as_f64().unwrap(),
        bus["final_attitude_change_deg"].as_f64().unwrap(),
    );
    assert!(close(att, want), "history {att} deg, summary {want} deg");
    let (peak, want) = (
        v["peak_rate"].as_f64().unwrap(),
        bus["peak_rate_rad_s"].as_f64().unwrap(),
    );
    assert!(
        close(peak, want),
        "history {peak} rad/s, summary {want} rad/s"
    );
    assert_eq!(v["peak_t"], bus["peak_rate_time_s"]);
    let scale = s["momentum"]["linear_scale_n_s"].as_f64().unwrap();
    assert!(v["linear"].as_f64().unwrap() <= 1e-12 * scale, "{v}");
}
