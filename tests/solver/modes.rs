//! Natural modes (`truss_deploy::solver::modes`) against closed forms: a
//! two-bar truss, a spring-mass chain, and beaded strings whose transverse
//! stiffness is the preload's geometric stiffness alone (a bar chain pulled
//! by a cable, a cable over pulleys, the same chain pushed into compression).
//! Every expected value is derived here by hand, never from a run.

use std::f64::consts::PI;
use std::fmt::Write;

use truss_deploy::solver::modes::{natural_modes, Linearization, ModeKind, Modes};

/// A model file: joints (name, position, mass), then elements and cables
/// as TOML text.
fn model_text(name: &str, joints: &[(&str, [f64; 3], f64)], rest: &str) -> String {
    let mut t = format!(
        "[model]\nname = \"{name}\"\n[settings]\ndt_s = 0.01\nend_time_s = 1.0\ngravity_m_s2 = [0.0, 0.0, 0.0]\n"
    );
    for (n, p, m) in joints {
        writeln!(
            t,
            "[[joint]]\nname = \"{n}\"\nposition_m = [{:?}, {:?}, {:?}]\nmass_kg = {m:?}",
            p[0], p[1], p[2]
        )
        .unwrap();
    }
    t + rest
}

fn element(kind: &str, name: &str, joints: &[&str], extra: &str) -> String {
    let j: Vec<String> = joints.iter().map(|j| format!("\"{j}\"")).collect();
    format!(
        "[[element]]\ntype = \"{kind}\"\nname = \"{name}\"\njoints = [{}]\n{extra}\n",
        j.join(", ")
    )
}

fn modes_of(text: &str, count: usize) -> Modes {
    let m = truss_deploy::model::parse(text, "test.toml")
        .expect("model parses")
        .model;
    let lin = Linearization::deployed(&m);
    natural_modes(&m, &lin, count).expect("modes")
}

fn omega(m: &Modes, i: usize) -> f64 {
    2.0 * PI * m.modes[i].frequency_hz
}

fn close(a: f64, b: f64, tol: f64, what: &str) {
    let rel = (a - b).abs() / b.abs();
    assert!(
        rel <= tol,
        "{what}: {a:.15e} against {b:.15e} (rel {rel:.2e} > {tol:.0e})"
    );
}

/// Joint C (mass m) hangs from supports A, B on two bars of different EA,
/// held in the plane y = 0: K = sum_i (EA_i / L_i) e_i e_i^T (2 x 2), and
/// omega^2 the eigenvalues of K / m: tr/2 +- sqrt(tr^2/4 - det).
#[test]
fn a_two_bar_truss_has_the_closed_form_frequencies() {
    let (a, h, m) = (0.3, 0.4, 0.7);
    let (ea1, ea2) = (1.0e3, 2.0e3);
    let mut rest = element("support", "sA", &["A"], "fix = \"xyz\"");
    rest += &element("support", "sB", &["B"], "fix = \"xyz\"");
    rest += &element("support", "sC", &["C"], "fix = \"y\"");
    rest += &element(
        "bar",
        "b1",
        &["A", "C"],
        &format!("axial_stiffness_n = {ea1:?}"),
    );
    rest += &element(
        "bar",
        "b2",
        &["B", "C"],
        &format!("axial_stiffness_n = {ea2:?}"),
    );
    let text = model_text(
        "two_bar",
        &[
            ("A", [-a, 0.0, 0.0], 1.0),
            ("B", [a, 0.0, 0.0], 1.0),
            ("C", [0.0, 0.0, h], m),
        ],
        &rest,
    );
    let modes = modes_of(&text, 5);
    assert_eq!(modes.degrees_of_freedom, 2);
    assert_eq!(modes.modes.len(), 2);
    let l = (a * a + h * h).sqrt();
    let (k1, k2) = (ea1 / l, ea2 / l);
    let (cx, cz) = (a / l, h / l);
    // e1 = (cx, cz) from A to C, e2 = (-cx, cz) from B to C.
    let kxx = (k1 + k2) * cx * cx;
    let kzz = (k1 + k2) * cz * cz;
    let kxz = (k1 - k2) * cx * cz;
    let (tr, det) = (kxx + kzz, kxx * kzz - kxz * kxz);
    let disc = (tr * tr / 4.0 - det).sqrt();
    close(
        omega(&modes, 0),
        ((tr / 2.0 - disc) / m).sqrt(),
        1e-10,
        "first",
    );
    close(
        omega(&modes, 1),
        ((tr / 2.0 + disc) / m).sqrt(),
        1e-10,
        "second",
    );
    assert!(modes.modes.iter().all(|md| md.kind == ModeKind::Elastic));
    // Freed from its plane, C swings in y on nothing: a mechanism, named.
    let text = text.replace("fix = \"y\"", "fix = \"\"").replace(
        "[[element]]\ntype = \"support\"\nname = \"sC\"\njoints = [\"C\"]\nfix = \"\"\n",
        "",
    );
    let modes = modes_of(&text, 5);
    assert_eq!(modes.degrees_of_freedom, 3);
    assert_eq!(modes.mechanisms, 1);
    assert_eq!(modes.modes[0].kind, ModeKind::Mechanism);
    assert!(
        modes.modes[0].shape[2][1].abs() > 0.999,
        "the mechanism is C's y motion"
    );
    close(
        omega(&modes, 1),
        ((tr / 2.0 - disc) / m).sqrt(),
        1e-10,
        "first elastic, unchanged",
    );
}

/// N equal masses on a line, joined by equal bars (k = EA / l), the first
/// bar to a clamp, the last mass free (fixed-free chain), moving along x:
/// omega_j = 2 sqrt(k / m) sin((2 j - 1) pi / (2 (2 N + 1))), j = 1..N.
#[test]
fn a_spring_mass_chain_has_the_closed_form_frequencies() {
    let (n, l, m, ea) = (7usize, 0.25, 0.3, 5.0e4);
    let names: Vec<String> = (0..=n).map(|i| format!("J{i}")).collect();
    let joints: Vec<(&str, [f64; 3], f64)> = names
        .iter()
        .enumerate()
        .map(|(i, s)| (s.as_str(), [i as f64 * l, 0.0, 0.0], m))
        .collect();
    let mut rest = element("support", "clamp", &["J0"], "fix = \"xyz\"");
    for i in 1..=n {
        rest += &element("support", &format!("line{i}"), &[&names[i]], "fix = \"yz\"");
        rest += &element(
            "bar",
            &format!("k{i}"),
            &[&names[i - 1], &names[i]],
            &format!("axial_stiffness_n = {ea:?}"),
        );
    }
    let modes = modes_of(&model_text("chain", &joints, &rest), n);
    assert_eq!(modes.degrees_of_freedom, n);
    let k = ea / l;
    for j in 1..=n {
        let exact =
            2.0 * (k / m).sqrt() * ((2 * j - 1) as f64 * PI / (2.0 * (2 * n + 1) as f64)).sin();
        close(omega(&modes, j - 1), exact, 1e-10, &format!("mode {j}"));
        assert_eq!(modes.modes[j - 1].kind, ModeKind::Elastic);
    }
}

/// A beaded string: N interior masses m at spacing l between a clamp A and
/// an end E that slides along x; in the plane y = 0. The chain's members
/// are elastic bars along x, so their elastic stiffness acts along x only;
/// a transverse (z) motion strains nothing to first order and is held by
/// the tension T alone: omega_k = 2 sqrt(T / (m l)) sin(k pi / (2 (N + 1))).
/// `by`: "bars" (a cable from E to an anchor beyond it pulls E, the bars
/// carry T: their rows' geometric stiffness -lambda H), "cable" (a cable
/// over pulleys at every interior joint, anchored at the clamps at both
/// ends; the bars carry nothing: the cable's own geometric stiffness), or
/// "compression" (the anchor on the other side: the bars push with T and
/// the transverse omega^2 are the negatives, unstable).
const STRING: (usize, f64, f64, f64, f64) = (6, 0.2, 0.05, 12.5, 1.0e6);

fn beaded_string(by: &str) -> (Modes, usize, f64) {
    let (n, l, m, t, _) = STRING;
    let modes = modes_of(&beaded_string_text(by), n);
    (modes, n, 2.0 * (t / (m * l)).sqrt())
}

/// The model file of `beaded_string`.
fn beaded_string_text(by: &str) -> String {
    let (n, l, m, t, ea) = STRING;
    let mut names: Vec<String> = vec!["A".into()];
    names.extend((1..=n).map(|i| format!("P{i}")));
    names.push("E".into());
    let mut joints: Vec<(&str, [f64; 3], f64)> = names
        .iter()
        .enumerate()
        .map(|(i, s)| (s.as_str(), [i as f64 * l, 0.0, 0.0], m))
        .collect();
    let end = (n + 1) as f64 * l;
    let anchor_x = match by {
        "compression" => -0.5,
        _ => end + 0.5,
    };
    joints.push(("M", [anchor_x, 0.0, 0.0], 1.0));
    let mut rest = element("support", "clamp", &["A"], "fix = \"xyz\"");
    rest += &element("support", "anchor", &["M"], "fix = \"xyz\"");
    let end_fix = if by == "cable" { "xyz" } else { "yz" };
    rest += &element("support", "slide", &["E"], &format!("fix = \"{end_fix}\""));
    for i in 1..=n {
        rest += &element("support", &format!("plane{i}"), &[&names[i]], "fix = \"y\"");
    }
    for i in 1..names.len() {
        rest += &element(
            "bar",
            &format!("b{i}"),
            &[&names[i - 1], &names[i]],
            &format!("axial_stiffness_n = {ea:?}"),
        );
    }
    let path: Vec<String> = match by {
        "cable" => names.iter().rev().map(|s| format!("\"{s}\"")).collect(),
        "compression" => vec!["\"M\"".into(), "\"E\"".into()],
        _ => vec!["\"M\"".into(), "\"E\"".into()],
    };
    // (the compressing cable runs from M, left of the clamp, through the
    // chain's line to E: it pulls E toward M, pushing the chain against A)
    writeln!(
        rest,
        "[[cable]]\nname = \"pull\"\npath = [{}]\ntension_n = {t:?}\nmax_tension_n = {:?}\nfriction_mu = 0.0\npulley_radius_m = 0.01",
        path.join(", "),
        2.0 * t
    )
    .unwrap();
    model_text("string", &joints, &rest)
}

fn check_string(modes: &Modes, n: usize, scale: f64, kind: ModeKind) {
    assert_eq!(modes.mechanisms, 0);
    for k in 1..=n {
        let exact = scale * (k as f64 * PI / (2.0 * (n + 1) as f64)).sin();
        let md = &modes.modes[k - 1];
        close(
            2.0 * PI * md.frequency_hz,
            exact,
            1e-8,
            &format!("transverse mode {k}"),
        );
        assert_eq!(md.kind, kind, "mode {k}");
        let along_z: f64 = md.shape.iter().map(|u| u[2] * u[2]).sum();
        let all: f64 = md
            .shape
            .iter()
            .map(|u| u.iter().map(|v| v * v).sum::<f64>())
            .sum();
        assert!(along_z > (1.0 - 1e-12) * all, "mode {k} is transverse");
    }
}

#[test]
fn a_string_pulled_through_its_bars_vibrates_on_their_geometric_stiffness() {
    let (modes, n, scale) = beaded_string("bars");
    assert!(
        (modes.max_preload_n - 12.5).abs() < 1e-9 * 12.5,
        "the bars carry T"
    );
    check_string(&modes, n, scale, ModeKind::Elastic);
}

#[test]
fn a_string_of_cable_over_pulleys_vibrates_on_the_cables_geometric_stiffness() {
    let (modes, n, scale) = beaded_string("cable");
    check_string(&modes, n, scale, ModeKind::Elastic);
}

#[test]
fn a_chain_pushed_by_its_cable_is_unstable_by_the_same_amounts() {
    let (modes, n, scale) = beaded_string("compression");
    assert_eq!(modes.unstable, n);
    // Unstable modes come first (most negative omega^2 first): reverse.
    let mut rev = modes.clone();
    rev.modes.truncate(n);
    rev.modes.reverse();
    for md in &rev.modes {
        assert!(md.omega2_rad2_s2 < 0.0);
    }
    check_string(&rev, n, scale, ModeKind::Unstable);
}

/// The same string as a simulator's state at rest (its start: the consistent
/// accelerations are zero, the multipliers the preload): the modes of
/// `Linearization::of_state` are the closed form's, the state's cable
/// segment tensions and multipliers (in its Jacobian's row order) taken as
/// the run has them.
#[test]
fn a_simulators_state_at_rest_has_the_strings_modes() {
    let (deployed, n, scale) = beaded_string("bars");
    let text = beaded_string_text("bars");
    let m = truss_deploy::model::parse(&text, "test.toml")
        .unwrap()
        .model;
    let sim = truss_deploy::solver::Simulator::new(m, truss_deploy::solver::Options::default())
        .expect("simulator");
    let a_max = sim.state().a.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    assert!(
        a_max < 1e-9,
        "the string starts at rest in equilibrium ({a_max:.2e} m/s^2)"
    );
    let lin = Linearization::of_state(sim.model(), sim.state());
    assert_eq!(lin.geometry, "state");
    let modes = natural_modes(sim.model(), &lin, n).expect("modes");
    check_string(&modes, n, scale, ModeKind::Elastic);
    close(
        modes.max_preload_n,
        deployed.max_preload_n,
        1e-9,
        "the preload",
    );
}
