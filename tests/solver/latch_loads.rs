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

/// The parallel-sleeve model with the sleeves' latches compliant: stiffness
/// and damping per sleeve (one sleeve when `k2` is 0).
fn compliant_model(
    m: f64,
    f: f64,
    start: f64,
    lock: f64,
    k1: f64,
    c1: f64,
    k2: f64,
    c2: f64,
) -> String {
    let mut text = parallel_sleeves_model(m, f, start, lock, 6e6, 6e6);
    text = text.replacen(
        "axial_stiffness_n = 6000000\n",
        &format!("axial_stiffness_n = 6000000\nlatch_stiffness_n_per_m = {k1}\nlatch_damping_n_s_per_m = {c1}\n"),
        1,
    );
    if k2 > 0.0 {
        text = text.replacen(
            "axial_stiffness_n = 6000000\n[[cable]]",
            &format!("axial_stiffness_n = 6000000\nlatch_stiffness_n_per_m = {k2}\nlatch_damping_n_s_per_m = {c2}\n[[cable]]"),
            1,
        );
    } else {
        // drop the second sleeve
        let at = text
            .find("[[element]]\ntype = \"sleeve\"\nname = \"S2\"")
            .unwrap();
        let end = text[at..].find("[[cable]]").unwrap() + at;
        text.replace_range(at..end, "");
    }
    assert!(text.contains("latch_stiffness_n_per_m"), "{text}");
    text
}

/// Closed form of a mass m arriving at speed v on a spring-damper (k, c)
/// under a steady pull F: m d'' + c d' + k d = F, d(0) = 0, d'(0) = v. The
/// force through the latch f = k d + c d' peaks where f' = 0; f' is a damped
/// sinusoid e^(-s t) (D1 cos wd t + D2 sin wd t), so the first peak is at
/// wd t = the first positive angle with tan = -D1/D2. Returns (t_peak, f_peak).
fn damped_latch_peak(m: f64, k: f64, c: f64, f: f64, v: f64) -> (f64, f64) {
    let w0 = (k / m).sqrt();
    let zeta = c / (2.0 * (k * m).sqrt());
    let (s, wd) = (zeta * w0, w0 * (1.0 - zeta * zeta).sqrt());
    let c1 = -f / k;
    let c2 = (v + s * c1) / wd;
    // d' = e^(-s t) (P cos + Q sin), d'' = e^(-s t) (R cos + U sin)
    let (p, q) = (-s * c1 + wd * c2, -s * c2 - wd * c1);
    let (r, u) = (-s * p + wd * q, -s * q - wd * p);
    let (d1, d2) = (k * p + c * r, k * q + c * u);
    let mut th = (-d1 / d2).atan();
    if th <= 0.0 {
        th += std::f64::consts::PI;
    }
    let t = th / wd;
    let e = (-s * t).exp();
    let d = f / k + e * (c1 * (wd * t).cos() + c2 * (wd * t).sin());
    let dd = e * (p * (wd * t).cos() + q * (wd * t).sin());
    (t, k * d + c * dd)
}

/// The largest force through the latch over its first three periods, from
/// the closed-form motion (underdamped): d = F/k + e^(-s t) (c1 cos wd t +
/// c2 sin wd t), f = k d + c d', sampled on 2e5 points and refined on the
/// parabola through the best three. Unlike [`damped_latch_peak`] it also
/// finds a peak at contact (f = c v at t = 0, where f only falls after:
/// damping ratios above 1/2).
fn sampled_latch_peak(m: f64, k: f64, c: f64, f: f64, v: f64) -> (f64, f64) {
    sampled_member_peak(m, k, c, f, v, k, c)
}

/// As [`sampled_latch_peak`], the force k_i d + c_i d' of one of several
/// latches in parallel (on the same joints: the same deflection d), the
/// motion that of their sums (k, c).
fn sampled_member_peak(m: f64, k: f64, c: f64, f: f64, v: f64, ki: f64, ci: f64) -> (f64, f64) {
    let w0 = (k / m).sqrt();
    let zeta = c / (2.0 * (k * m).sqrt());
    assert!(zeta < 1.0);
    let (s, wd) = (zeta * w0, w0 * (1.0 - zeta * zeta).sqrt());
    let (c1, c2) = (-f / k, (v - s * f / k) / wd);
    let force = |t: f64| {
        let (e, (sn, cs)) = ((-s * t).exp(), (wd * t).sin_cos());
        let d = f / k + e * (c1 * cs + c2 * sn);
        let dd = e * ((-s * c1 + wd * c2) * cs + (-s * c2 - wd * c1) * sn);
        ki * d + ci * dd
    };
    let n = 200_000;
    let dt = 3.0 * 2.0 * std::f64::consts::PI / wd / n as f64;
    let i = (0..=n)
        .max_by(|&i, &j| force(i as f64 * dt).total_cmp(&force(j as f64 * dt)))
        .unwrap();
    if i == 0 {
        return (0.0, force(0.0));
    }
    let (fm, f0, fp) = (
        force((i - 1) as f64 * dt),
        force(i as f64 * dt),
        force((i + 1) as f64 * dt),
    );
    let off = 0.5 * (fm - fp) / (fm - 2.0 * f0 + fp);
    let t = (i as f64 + off) * dt;
    (t, force(t))
}

fn run_until_settled(sim: &mut Simulator, dt: f64, max_steps: usize) {
    for _ in 0..max_steps {
        if sim.state().deployed {
            return;
        }
        sim.step(dt).unwrap();
    }
    panic!("not deployed (settled) after {max_steps} steps");
}

/// A mass m at speed v into a latch of stiffness k under a constant cable
/// pull F peaks at F + sqrt(F^2 + k m v^2) (undamped) or at the damped
/// oscillator's closed-form peak (at contact, c v, above damping ratio 1/2),
/// at dt = 0.05 s, 25x the latch's period.
#[test]
fn a_compliant_latch_peaks_at_the_closed_form_force() {
    let (m, f, start, lock): (f64, f64, f64, f64) = (0.4, 3.0, 1.0, 0.6);
    let v = (2.0 * f * (start - lock) / m).sqrt();
    let t_engage = (2.0 * (start - lock) * m / f).sqrt();
    let k = 4.0e6;
    for (c, what) in [
        (0.0, "undamped"),
        (0.2 * 2.0 * (k * m).sqrt(), "damped, zeta 0.2"),
        // the peak at contact, c v: the force only falls after
        (0.9 * 2.0 * (k * m).sqrt(), "damped, zeta 0.9"),
    ] {
        let (t_peak, f_peak) = sampled_latch_peak(m, k, c, f, v);
        if c < (k * m).sqrt() {
            // the first stationary point is the peak below damping ratio 1/2
            let (t1, f1) = damped_latch_peak(m, k, c, f, v);
            assert!((f1 - f_peak).abs() <= 1e-9 * f_peak, "{f1} vs {f_peak}");
            assert!((t1 - t_peak).abs() <= 1e-6 * t1, "{t1} vs {t_peak}");
        } else {
            assert_eq!(t_peak, 0.0, "{what}: peak at contact");
            assert!((f_peak - c * v).abs() <= 1e-12 * f_peak, "{f_peak} vs c v");
        }
        if c == 0.0 {
            let plain = f + (f * f + k * m * v * v).sqrt();
            assert!(
                (f_peak - plain).abs() <= 1e-12 * plain,
                "closed forms agree"
            );
        }
        let model = parse(
            &compliant_model(m, f, start, lock, k, c, 0.0, 0.0),
            "latch.toml",
        )
        .unwrap()
        .model;
        let mut sim = Simulator::new(model, Options::default()).unwrap();
        // Through the engagement in short outer steps, to check the ledger
        // while the latch holds elastic energy: kinetic + spring = work in -
        // losses, with the latch damper's loss.
        while sim.state().t_s + 0.05 < t_engage {
            sim.step(0.05).unwrap();
        }
        while sim.state().t_s < t_engage + 1.5 * t_peak {
            sim.step(1e-4).unwrap();
        }
        let s = sim.state();
        assert_eq!(s.transients.len(), 1, "{what}: the latch is still elastic");
        let bal = s.energy.balance_rel_error(s.kinetic_energy_j(sim.model()));
        println!(
            "{what}: mid-transient energy balance {bal:.1e} (spring {:.6} J, damper {:.6} J, kinetic {:.6} J)",
            s.energy.latch_spring_energy_j,
            s.energy.latch_damping_loss_j,
            s.kinetic_energy_j(sim.model())
        );
        assert!(
            bal <= 1e-6,
            "{what}: energy balance error {bal:e} during the transient"
        );
        run_until_settled(&mut sim, 0.05, 100);
        let ev = &sim.state().locks[0];
        let peak = ev.peak_force_n.expect("a compliant latch reports its peak");
        let t_of_peak = ev.time_of_peak_s.unwrap();
        let err = (peak - f_peak).abs() / f_peak;
        let t_err = (t_of_peak - (t_engage + t_peak)).abs();
        println!(
            "{what}: peak {peak:.6} N vs {f_peak:.6} N (rel {err:.1e}), at {t_of_peak:.7} s vs {:.7} s ({t_err:.1e} s), engaged at {:.9} s; period {:.2e} s; {} steps",
            t_engage + t_peak,
            ev.time_s,
            2.0 * std::f64::consts::PI * (m / k).sqrt(),
            sim.state().steps
        );
        assert!(err <= 1e-4, "{what}: peak force off by {err:e}");
        // The impulse through the latch, a magnitude (the sleeve shortens into
        // it, the force is a push): by momentum, the m v it stopped plus the
        // pull's F tau over the transient tau, engagement to rigid (the mass
        // is at rest after; the pull is the only other force).
        let tau = ev.rigid_at_s.expect("turned rigid") - ev.time_s;
        let want = m * v + f * tau;
        println!(
            "{what}: impulse {:.9} N s vs m v + F tau {want:.9} N s (tau {tau:.6} s)",
            ev.impulse_ns
        );
        assert!(
            (ev.impulse_ns - want).abs() <= 1e-9 * want,
            "{what}: impulse {} N s, m v + F tau = {want} N s",
            ev.impulse_ns
        );
        assert!((ev.time_s - t_engage).abs() <= 1e-9, "engagement time");
        assert!(
            t_err <= 1e-3 * 2.0 * std::f64::consts::PI * (m / k).sqrt(),
            "{what}: time of peak off by {t_err:e} s"
        );
        // after it turned rigid (its spring energy and the drive's work over
        // the deflection it is moved back by go with the latch's loss)
        let s = sim.state();
        let bal = s.energy.balance_rel_error(s.kinetic_energy_j(sim.model()));
        println!(
            "{what}: energy balance {bal:.1e}, latch damping {:.6} J, lock loss {:.6} J",
            s.energy.latch_damping_loss_j, s.energy.lock_loss_j
        );
        assert!(bal <= 1e-6, "{what}: energy balance error {bal:e}");
    }
}

/// A reset in the middle of a compliant latch's transient leaves no spring
/// behind: the reset simulator runs as a new one, bit for bit.
#[test]
fn a_reset_mid_transient_leaves_no_latch_spring() {
    let (m, f, start, lock): (f64, f64, f64, f64) = (0.4, 3.0, 1.0, 0.6);
    let text = compliant_model(m, f, start, lock, 4.0e6, 500.0, 0.0, 0.0);
    let model = || parse(&text, "latch.toml").unwrap().model;
    let mut sim = Simulator::new(model(), Options::default()).unwrap();
    while sim.state().transients.is_empty() {
        sim.step(0.01).unwrap();
    }
    sim.step(1e-5).unwrap();
    assert_eq!(sim.state().transients.len(), 1, "in the transient");
    sim.reset().unwrap();
    let mut fresh = Simulator::new(model(), Options::default()).unwrap();
    for _ in 0..20 {
        assert_eq!(sim.state().a, fresh.state().a, "t = {}", sim.state().t_s);
        assert_eq!(sim.state().x, fresh.state().x);
        sim.step(0.05).unwrap();
        fresh.step(0.05).unwrap();
    }
}

/// Two compliant latches in parallel share the load by stiffness: peaks
/// 3:1 for k 3:1 with dampers in the same ratio, the total the closed form of
/// their sum; with equal dampers each peak is its own k_i d + c_i d' of the
/// pair's closed-form motion (peaking at a different instant).
#[test]
fn parallel_compliant_latches_share_by_stiffness() {
    let (m, f, start, lock): (f64, f64, f64, f64) = (0.4, 3.0, 1.0, 0.6);
    let v = (2.0 * f * (start - lock) / m).sqrt();
    let (k1, k2) = (3.0e6, 1.0e6);
    let zeta = 0.1;
    let c_total = zeta * 2.0 * ((k1 + k2) * m).sqrt();
    // two sleeves on the same joints, deployed to rigid
    let settled_pair = |c1: f64, c2: f64| {
        let text = compliant_model(m, f, start, lock, k1, c1, k2, c2);
        let model = parse(&text, "pair.toml").unwrap().model;
        let mut sim = Simulator::new(model, Options::default()).unwrap();
        run_until_settled(&mut sim, 0.05, 100);
        sim
    };
    let sim = settled_pair(0.75 * c_total, 0.25 * c_total);
    let locks = &sim.state().locks;
    let p = |n: &str| {
        locks
            .iter()
            .find(|l| l.name == n)
            .unwrap()
            .peak_force_n
            .unwrap()
    };
    let (p1, p2) = (p("S1"), p("S2"));
    let (_, total) = damped_latch_peak(m, k1 + k2, c_total, f, v);
    println!(
        "peaks {p1:.6} / {p2:.6} N (ratio {:.9}), sum {:.6} vs {total:.6}",
        p1 / p2,
        p1 + p2
    );
    assert!((p1 / p2 - 3.0).abs() <= 1e-6, "ratio {}", p1 / p2);
    assert!(((p1 + p2) - total).abs() <= 1e-4 * total);
    // equal dampers: the ratio is no longer 3 and each peak is its own
    let (c1, c2) = (0.5 * c_total, 0.5 * c_total);
    let sim = settled_pair(c1, c2);
    for (name, ki, ci) in [("S1", k1, c1), ("S2", k2, c2)] {
        let ev = sim.state().locks.iter().find(|l| l.name == name).unwrap();
        let (_, want) = sampled_member_peak(m, k1 + k2, c_total, f, v, ki, ci);
        let got = ev.peak_force_n.unwrap();
        println!("equal dampers, {name}: peak {got:.6} N vs {want:.6} N");
        assert!((got - want).abs() <= 1e-4 * want, "{name}: {got} vs {want}");
    }
}

/// The bundled ring: one mechanism, its 54 diagonals engaging compliant at
/// one instant, its 36 radial members reaching their lock at their shortest
/// (the flat state), where nothing moves along them.
/// - Every sleeve latches; the radial members latch rigid once the
///   transients are over (no peak, no impulse), each a counted fallback.
/// - With one mechanism n every latch's length moves as l_i = (A_i n) q, so
///   its force is T_i(t) = (A_i n) (k q + c q') and its closing speed
///   ldot_i = (A_i n) q'(0): with the same k and c on every latch, the peak
///   over the closing speed is one number for all of them, at least c (the
///   damper's force at contact, c ldot_i). Just after contact
///   T_i'(0+) = (A_i n) (k q'(0) + c q''(0+)), q''(0+) = q''(0-) - w c q'(0)
///   (the damper's force decelerates the mode, w its inverse mass): where
///   c^2 w > k (damping ratio above 1/2) and the drive's slow q''(0-) is
///   small, the force only falls from contact, and the peak is c ldot_i.
///   The one mode's w, from its first sub-step's deceleration w c q'(0):
///   3.3 /kg, c^2 w = 3.0e5 N/m against k = 2e5 N/m. (A peak located on
///   the tension's own Hermite interpolant, with the rate k ldot + c l''
///   from the accelerations, put it 1e-5 s after contact at 1.079 N s/m
///   above c at 128 sub-steps per period and 0.135 at 1024: a first-order
///   artifact that falls to 0.)
#[test]
fn the_rings_compliant_latches_peak_in_proportion_to_their_closing_speeds() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("models/double_ring_synchronized.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let model = parse(&text, "double_ring_synchronized.toml").unwrap().model;
    let mut sim = Simulator::new(model, Options::default()).unwrap();
    run_until_settled(&mut sim, 0.05, 800);
    let s = sim.state();
    assert_eq!(s.locks.len(), 90, "every sleeve latched");
    let (k, c) = (2e5, 300.0);
    let mut ratios = Vec::new();
    let mut radial = 0;
    for ev in &s.locks {
        let el = &sim.model().elements[ev.element];
        assert_eq!(el.latch_spring(), Some((k, c)), "{}", ev.name);
        if ev.name.starts_with('R') {
            radial += 1;
            assert!(ev.peak_force_n.is_none(), "{}: rigid", ev.name);
            assert!(
                ev.impulse_ns <= 1e-12,
                "{}: impulse {}",
                ev.name,
                ev.impulse_ns
            );
            continue;
        }
        let peak = ev.peak_force_n.expect("a compliant latch's peak");
        let v = ev.closing_speed_m_s.abs();
        assert!(v > 0.1, "{}: closing speed {v}", ev.name);
        assert!(ev.rigid_at_s.is_some_and(|t| t > ev.time_s), "{}", ev.name);
        ratios.push((ev.name.clone(), peak / v));
    }
    assert_eq!(radial, 36);
    assert_eq!(sim.solver_stats().fallbacks.latch_without_compliance, 36);
    assert_eq!(ratios.len(), 54);
    // The peak at contact, c ldot_i, for every latch: to roundoff of the
    // closing speed, and at the instant of contact.
    let family = |n: &str| n.replace(|ch: char| ch.is_ascii_digit(), "");
    println!("peak / closing speed {:.9} N s/m (c = {c})", ratios[0].1);
    for (name, r) in &ratios {
        assert!(
            (r - c).abs() <= 1e-9 * c,
            "{name}: peak / closing speed {r}, c {c}"
        );
        let ev = s.locks.iter().find(|l| &l.name == name).unwrap();
        assert_eq!(
            ev.time_of_peak_s,
            Some(ev.time_s),
            "{name}: the peak at contact"
        );
    }
    assert_eq!(
        ratios
            .iter()
            .map(|(n, _)| family(n))
            .collect::<std::collections::BTreeSet<_>>()
            .len(),
        3
    );
}

/// Runs a model (TOML text) to deployment on `kind`.
fn deployed(text: &str, name: &str, kind: SolverKind) -> Simulator {
    let model = parse(text, name).expect("loads").model;
    let dt = model.dt_s;
    let mut sim = Simulator::new(model, opts(kind)).unwrap();
    while !sim.state().deployed {
        assert!(
            sim.state().t_s < sim.model().end_time_s,
            "{name}: not deployed"
        );
        sim.step(dt).unwrap();
    }
    sim
}

/// For rigid latches the latched rows are the only ones whose rate jumps
/// (every other row's A V is 0 before and after), so for any split mu with
/// A^T mu = M (V- - V+) the events' losses 1/2 mu_e (A V-)_e sum to the
/// kinetic energy the latches took. The sparse backend's least-work split
/// must meet that as the dense SVD's does, and give the same impulses.
#[test]
fn latch_impulses_account_for_the_energy_taken_on_either_backend() {
    let sail = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/sail_array.toml");
    let models = [
        ("sail_array.toml", std::fs::read_to_string(sail).unwrap()),
        (
            "generate mast (rigid latches)",
            truss_deploy::model::generate::mast(&Default::default())
                .unwrap()
                .to_toml(),
        ),
    ];
    for (file, text) in &models {
        let mut impulses = Vec::new();
        for kind in [SolverKind::Dense, SolverKind::Sparse] {
            let sim = deployed(text, file, kind);
            let s = sim.state();
            assert!(!s.locks.is_empty(), "{file}");
            assert!(
                s.locks.iter().all(|ev| ev.peak_force_n.is_none()),
                "{file}: rigid latches expected"
            );
            let lost: f64 = s.locks.iter().map(|ev| ev.energy_lost_j).sum();
            let taken = s.energy.lock_loss_j;
            assert!(taken > 0.0, "{file} {kind:?}: {taken}");
            assert!(
                (lost - taken).abs() <= 1e-6 * taken,
                "{file} {kind:?}: the events' losses {lost:e} J against the latches' {taken:e} J"
            );
            // (the sparse splits by its own route, not redone by the dense SVD)
            let f = &sim.solver_stats().fallbacks;
            assert_eq!(
                (f.least_work_dense, f.least_work_inexact),
                (0, 0),
                "{file} {kind:?}: splits redone densely / kept inexact"
            );
            impulses.push(s.locks.iter().map(|ev| ev.impulse_ns).collect::<Vec<_>>());
        }
        for (d, sp) in impulses[0].iter().zip(&impulses[1]) {
            assert!(
                (d - sp).abs() <= 1e-6 * d.abs(),
                "{file}: dense {d} N s, sparse {sp} N s"
            );
        }
    }
}
