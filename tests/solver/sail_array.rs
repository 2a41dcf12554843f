//! The sail (solar) array generator against the paper's numbers, the closed-form
//! cable length, the mobility analysis, and one full deployment.

use std::path::Path;
use truss_deploy::model::generate::sail::{
    sail, sail_cable_length, sail_cable_path, sail_deployed_height_m, sail_joint_names,
    sail_positions, Boom, SailParams,
};
use truss_deploy::model::parse;
use truss_deploy::solver::mobility;
use truss_deploy::solver::{Model, Options, Simulator};

fn default_model() -> Model {
    let text = sail(&SailParams::default()).unwrap().to_toml();
    parse(&text, "sail_array.toml")
        .expect("generated model loads")
        .model
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt()
}

#[test]
fn bundled_file_is_what_the_generator_writes() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/sail_array.toml");
    let shipped = std::fs::read_to_string(path).expect("models/sail_array.toml exists");
    let written = sail(&SailParams::default()).unwrap().to_toml();
    assert_eq!(
        written, shipped,
        "models/sail_array.toml is stale; run `truss-deploy generate sail -o models/sail_array.toml`"
    );
}

#[test]
fn reference_geometry_matches_the_papers_points() {
    let doc = sail(&SailParams::default()).unwrap();
    let get = |name: &str| {
        doc.joints
            .iter()
            .find(|j| j.name == name)
            .unwrap_or_else(|| panic!("joint {name}"))
            .reference_m
            .unwrap()
    };
    for (name, paper) in [
        ("J5", [0.5, 0.0, 0.0]),
        ("J26", [4.0, 0.0, 0.0]),
        ("J28", [4.0, 0.7, -0.7]),
    ] {
        let r = get(name);
        assert!(
            dist(r, paper) <= 1e-3,
            "{name}: reference {r:?}, paper {paper:?}"
        );
    }
    // the paper's joint count: 8 SLEs, 8 plates, 28 numbered joints
    assert_eq!(doc.joints.len(), 28 + 2);
    assert_eq!(
        doc.elements.iter().filter(|e| e.kind == "scissor").count(),
        8
    );
    assert_eq!(doc.elements.iter().filter(|e| e.kind == "plate").count(), 8);
    assert_eq!(&sail_joint_names(4)[..4], &["J1", "J2", "J3", "J4"]);
    // the rods keep their length between the folded and the deployed geometry
    let p = SailParams::default();
    let (x0, xd) = (
        sail_positions(&p, p.start_deg.to_radians()),
        sail_positions(&p, p.deploy_deg.to_radians()),
    );
    for e in doc.elements.iter().filter(|e| e.kind != "support") {
        if e.kind == "sleeve" {
            continue;
        }
        let idx = |n: &String| doc.joints.iter().position(|j| &j.name == n).unwrap();
        let pairs: Vec<(usize, usize)> = match e.kind.as_str() {
            "scissor" => vec![(0, 1), (2, 3)],
            _ => vec![(0, 1), (1, 2), (2, 3), (3, 0), (0, 2)],
        };
        for (a, b) in pairs {
            let (i, j) = (idx(&e.joints[a]), idx(&e.joints[b]));
            let (l0, ld) = (dist(x0[i], x0[j]), dist(xd[i], xd[j]));
            assert!((l0 - ld).abs() < 1e-12, "{}: {l0} vs {ld}", e.name);
        }
    }
}

#[test]
fn bays_out_of_range_are_rejected() {
    for bays in [0, 101] {
        let e = sail(&SailParams {
            bays,
            ..SailParams::default()
        })
        .unwrap_err();
        assert!(e.0.contains("1 to 100"), "{e}");
    }
    for bays in [1, 2, 7] {
        let text = sail(&SailParams {
            bays,
            ..SailParams::default()
        })
        .unwrap()
        .to_toml();
        parse(&text, "s.toml").expect("loads");
    }
}

#[test]
fn mobility_is_one_before_locks_and_zero_after() {
    let m = default_model();
    let free = vec![false; m.elements.len()];
    let before = mobility::analyze(&m, &m.x0, &free);
    assert_eq!(before.mechanisms, 1, "{before:?}");
    let all: Vec<bool> = m
        .elements
        .iter()
        .map(|e| e.lock_gap(&m.x0).is_some())
        .collect();
    assert_eq!(all.iter().filter(|l| **l).count(), 2, "sleeves 1-2 and 3-4");
    let reference = m.reference.clone().unwrap();
    for (x, name) in [(&m.x0, "folded"), (&reference, "reference")] {
        let after = mobility::analyze(&m, x, &all);
        assert_eq!(after.mechanisms, 0, "{name}: {after:?}");
        // Maxwell / Calladine-Pellegrino: m - s = 3n - rows
        assert_eq!(
            after.mechanisms as i64 - after.self_stress as i64,
            after.coordinates as i64 - after.rows as i64
        );
    }
    assert_eq!(
        before.mechanisms as i64 - before.self_stress as i64,
        before.coordinates as i64 - before.rows as i64
    );
}

#[test]
fn cable_length_shrinks_monotonically_while_deploying() {
    let p = SailParams::default();
    let names = sail_joint_names(p.bays);
    let mut last = f64::INFINITY;
    for i in 0..=540 {
        let alpha = (1.0 + 0.1 * i as f64).to_radians();
        let l = sail_cable_length(&p, alpha);
        assert!(
            l < last,
            "cable length grows at {} deg",
            1.0 + 0.1 * i as f64
        );
        last = l;
        // the closed form equals the sum of the path's segments
        let x = sail_positions(&p, alpha);
        for b in [Boom::A, Boom::B] {
            let path = sail_cable_path(p.bays, b);
            let at = |n: &String| x[names.iter().position(|m| m == n).unwrap()];
            let sum: f64 = path.windows(2).map(|w| dist(at(&w[0]), at(&w[1]))).sum();
            assert!((sum - l).abs() < 1e-12, "{b:?} at {alpha}: {sum} vs {l}");
        }
    }
    // the paper's routing: anchored at J25, pulley at J26, ..., pulley at J2, drum
    let a = sail_cable_path(4, Boom::A);
    assert_eq!(a.first().unwrap(), "drum_A");
    assert_eq!(&a[1], "J2");
    assert_eq!(&a[a.len() - 2..], &["J26", "J25"]);
    assert!((sail_deployed_height_m(&p) - 0.70021).abs() < 1e-5);
}

/// One full deployment at the model's dt (about 3300 steps; several minutes in the
/// debug profile).
#[test]
fn full_deployment_reaches_the_reference() {
    let m = default_model();
    let dt = m.dt_s;
    let mut sim = Simulator::new(m, Options::default()).unwrap();
    while !sim.state().deployed {
        assert!(sim.state().t_s < 200.0, "not deployed by t = 200 s");
        sim.step(dt).expect("step");
    }
    let s = sim.state();
    let err = s.final_error_rel(sim.model()).unwrap();
    assert!(err <= 1e-6, "final error {err}");
    assert!(s.max_violation_m <= 1e-9, "violation {}", s.max_violation_m);
    assert_eq!(s.locks.len(), 2);
    // no result accepted inexact on the way (unconverged solves, sub-steps
    // over their ledger, captures)
    let st = sim.solver_stats();
    assert_eq!(st.accepting_fallbacks(), 0, "{st:?}");
    let t = s.deploy_time_s.unwrap();
    assert!(t > 10.0 && t < 100.0, "deploy time {t}");
}
