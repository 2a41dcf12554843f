//! Latch loads engineers size hardware by (issue 11), against closed forms:
//! least-work sharing of redundant forces and impulses by member stiffness.

use truss_deploy::model::file::parse;
use truss_deploy::solver::{Options, Simulator, SolverKind};

fn opts(kind: SolverKind) -> Options {
    Options {
        solver: kind,
        ..Options::default()
    }
}

/// A held at the origin; B (mass m, held in y and z) on the x axis at
/// `start` m, pulled towards A by a frictionless cable of tension F. Two
/// sleeves join the same two joints and latch together at `lock` m; their
/// EA are `ea1` and `ea2` (N).
fn parallel_sleeves_model(m: f64, f: f64, start: f64, lock: f64, ea1: f64, ea2: f64) -> String {
    format!(
        r#"
[model]
name = "parallel_sleeves"
[[joint]]
name = "A"
position_m = [0.0, 0.0, 0.0]
mass_kg = 1.0
[[joint]]
name = "B"
position_m = [{start}, 0.0, 0.0]
mass_kg = {m}
[[element]]
type = "support"
name = "A_held"
joints = ["A"]
fix = "xyz"
[[element]]
type = "support"
name = "B_yz"
joints = ["B"]
fix = "yz"
[[element]]
type = "sleeve"
name = "S1"
joints = ["A", "B"]
lock_length_m = {lock}
axial_stiffness_n = {ea1}
[[element]]
type = "sleeve"
name = "S2"
joints = ["A", "B"]
lock_length_m = {lock}
axial_stiffness_n = {ea2}
[[cable]]
name = "pull"
path = ["A", "B"]
tension_n = {f}
max_tension_n = {f}
"#
    )
}

/// Two sleeves on the same joints latching together share the impulse m v
/// in proportion to their stiffness EA/L (least work), not equally (the
/// minimum-norm split gave 0.5 m v each whatever the stiffness).
#[test]
fn parallel_sleeves_share_the_latch_impulse_by_stiffness() {
    let (m, f, start, lock): (f64, f64, f64, f64) = (0.4, 3.0, 1.0, 0.6);
    let v = (2.0 * f * (start - lock) / m).sqrt(); // closing speed at the latch
    for kind in [SolverKind::Dense, SolverKind::Sparse] {
        let model = parse(
            &parallel_sleeves_model(m, f, start, lock, 3.0e6, 1.0e6),
            "parallel.toml",
        )
        .unwrap()
        .model;
        let mut sim = Simulator::new(model, opts(kind)).unwrap();
        for _ in 0..200 {
            if sim.state().locks.len() == 2 {
                break;
            }
            sim.step(0.05).unwrap();
        }
        let locks = &sim.state().locks;
        assert_eq!(locks.len(), 2, "{kind:?}: both sleeves latch");
        assert!((locks[0].time_s - locks[1].time_s).abs() < 1e-12);
        let p = |name: &str| locks.iter().find(|l| l.name == name).unwrap().impulse_ns;
        let (p1, p2) = (p("S1"), p("S2"));
        let total = m * v;
        assert!(
            (p1 - 0.75 * total).abs() <= 1e-6 * total && (p2 - 0.25 * total).abs() <= 1e-6 * total,
            "{kind:?}: impulses {p1} and {p2}, expected {} and {} (3:1 of m v = {total})",
            0.75 * total,
            0.25 * total
        );
        // and the energy lost, 1/2 m v^2, is split alike (1/2 P_i v)
        let lost: f64 = locks.iter().map(|l| l.energy_lost_j).sum();
        assert!((lost - 0.5 * m * v * v).abs() <= 1e-6 * 0.5 * m * v * v);
        println!(
            "{kind:?}: impulses {p1:.9} / {p2:.9} N s (ratio {:.9})",
            p1 / p2
        );
    }
}

/// A statically indeterminate plane truss: three bars from held joints
/// P1..P3 to one joint Q (held in y) carrying its weight under gravity
/// (gx, 0, gz). The bar forces are the stiffness method's, N_i = k_i e_i.u
/// with K u = f, K = sum k_i e_i e_i^T, k_i = EA_i / L_i.
#[test]
fn three_bar_truss_forces_are_the_stiffness_method_ones() {
    let p: [[f64; 3]; 3] = [[-1.0, 0.0, 0.0], [0.2, 0.0, 0.0], [1.5, 0.0, 0.0]];
    let q: [f64; 3] = [0.3, 0.0, -1.1];
    let ea = [2.0e6, 5.0e6, 3.0e6];
    let (m, g) = (2.5, [1.7, 0.0, -9.81]);
    let mut text = format!(
        "[model]\nname = \"three_bar\"\n[settings]\ngravity_m_s2 = [{}, 0.0, {}]\n\
         [[joint]]\nname = \"Q\"\nposition_m = [{}, 0.0, {}]\nmass_kg = {m}\n\
         [[element]]\ntype = \"support\"\nname = \"Q_y\"\njoints = [\"Q\"]\nfix = \"y\"\n",
        g[0], g[2], q[0], q[2]
    );
    for i in 0..3 {
        text += &format!(
            "[[joint]]\nname = \"P{i}\"\nposition_m = [{}, 0.0, {}]\nmass_kg = 1.0\n\
             [[element]]\ntype = \"support\"\nname = \"P{i}_held\"\njoints = [\"P{i}\"]\nfix = \"xyz\"\n\
             [[element]]\ntype = \"bar\"\nname = \"B{i}\"\njoints = [\"P{i}\", \"Q\"]\naxial_stiffness_n = {}\n",
            p[i][0], p[i][2], ea[i]
        );
    }
    // stiffness method in the x-z plane
    let mut e = [[0.0; 2]; 3];
    let mut k = [0.0; 3];
    let mut kk = [[0.0; 2]; 2];
    for i in 0..3 {
        let d = [q[0] - p[i][0], q[2] - p[i][2]];
        let l = (d[0] * d[0] + d[1] * d[1]).sqrt();
        e[i] = [d[0] / l, d[1] / l];
        k[i] = ea[i] / l;
        for a in 0..2 {
            for b in 0..2 {
                kk[a][b] += k[i] * e[i][a] * e[i][b];
            }
        }
    }
    let f = [m * g[0], m * g[2]];
    let det = kk[0][0] * kk[1][1] - kk[0][1] * kk[1][0];
    let u = [
        (kk[1][1] * f[0] - kk[0][1] * f[1]) / det,
        (kk[0][0] * f[1] - kk[1][0] * f[0]) / det,
    ];
    let n: Vec<f64> = (0..3)
        .map(|i| k[i] * (e[i][0] * u[0] + e[i][1] * u[1]))
        .collect();
    let scale = n.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    for kind in [SolverKind::Dense, SolverKind::Sparse] {
        let model = parse(&text, "three_bar.toml").unwrap().model;
        let bar_row = |name: &str| {
            let e = model
                .elements
                .iter()
                .position(|el| el.name() == name)
                .unwrap();
            e
        };
        let rows: Vec<usize> = (0..3).map(|i| bar_row(&format!("B{i}"))).collect();
        let mut sim = Simulator::new(model, opts(kind)).unwrap();
        // at rest: no joint can move, so the multipliers are the static forces
        let amax = sim.state().a.iter().fold(0.0f64, |a, b| a.max(b.abs()));
        assert!(
            amax < 1e-12,
            "{kind:?}: the truss is rigid (|a| = {amax:e})"
        );
        let lambda = sim.least_work_multipliers().unwrap();
        let jac = sim.jacobian();
        let mut worst = 0.0f64;
        for i in 0..3 {
            let b = jac.blocks.iter().find(|b| b.element == rows[i]).unwrap();
            // Phi = |Q - P| - L: the force on Q is e lambda, so tension is -lambda
            let tension = -lambda[b.row0];
            worst = worst.max((tension - n[i]).abs() / scale);
        }
        println!("{kind:?}: stiffness method {n:?}, worst relative error {worst:.2e}");
        assert!(
            worst <= 1e-9,
            "{kind:?}: bar forces off by {worst:e} of the largest"
        );
    }
}
