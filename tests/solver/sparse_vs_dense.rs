//! The sparse backend (sparse LDL^T of S = A M^-1 A^T over the rows a
//! pivot-rejecting probe keeps; regularized for minimum-norm solves) against the
//! dense SVD reference: single solves at configurations with redundant rows, the
//! rank the probe finds, and whole deployments of every bundled model, step by
//! step.

use std::path::{Path, PathBuf};
use truss_deploy::model::generate::{self, MastParams};
use truss_deploy::model::{load, parse};
use truss_deploy::solver::jacobian::Jacobian;
use truss_deploy::solver::linsolve::SolveMode;
use truss_deploy::solver::{Model, Options, Simulator, SolverKind};

fn models() -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("models");
    let mut v: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("models/ exists")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    v.sort();
    v
}

fn sim(model: Model, solver: SolverKind) -> Simulator {
    Simulator::new(
        model,
        Options {
            solver,
            ..Default::default()
        },
    )
    .expect("simulator")
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m, x| m.max(x.abs()))
}

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).fold(0.0, |m, (x, y)| m.max((x - y).abs()))
}

/// Steps dense and sparse side by side to full deployment, or for `max_steps`
/// steps when `to_deployment` is false; positions must agree to 1e-9 m at every
/// step, lock times to 1e-9 s.
fn deploy_both(name: &str, model: impl Fn() -> Model, max_steps: usize) {
    compare_runs(name, model, max_steps, true)
}

fn compare_runs(name: &str, model: impl Fn() -> Model, max_steps: usize, to_deployment: bool) {
    let mut d = sim(model(), SolverKind::Dense);
    let mut s = sim(model(), SolverKind::Sparse);
    let dt = d.model().dt_s;
    assert_eq!(d.state().deployed, s.state().deployed);
    let dx0 = max_diff(&d.state().x, &s.state().x);
    assert!(dx0 <= 1e-9, "{name}: initial positions differ by {dx0:e} m");
    let mut worst = dx0;
    let mut steps = 0;
    while !d.state().deployed {
        if !to_deployment && steps == max_steps {
            break;
        }
        assert!(
            steps < max_steps,
            "{name}: not deployed after {max_steps} steps"
        );
        d.step(dt).expect("dense step");
        s.step(dt).expect("sparse step");
        steps += 1;
        let diff = max_diff(&d.state().x, &s.state().x);
        worst = worst.max(diff);
        assert!(
            diff <= 1e-9,
            "{name}: step {steps} (t = {:.3} s): joint positions differ by {diff:e} m",
            d.state().t_s
        );
        assert_eq!(
            d.state().locked,
            s.state().locked,
            "{name}: step {steps}: locked sets differ"
        );
    }
    assert_eq!(
        s.state().deployed,
        d.state().deployed,
        "{name}: sparse and dense runs disagree on deployment"
    );
    let (ld, ls) = (&d.state().locks, &s.state().locks);
    assert_eq!(ld.len(), ls.len(), "{name}: number of lock events");
    let mut worst_impulse = 0.0f64;
    let largest_impulse = ld.iter().fold(0.0f64, |m, l| m.max(l.impulse_ns.abs()));
    for (a, b) in ld.iter().zip(ls) {
        assert_eq!(a.element, b.element, "{name}: lock order");
        assert!(
            (a.time_s - b.time_s).abs() <= 1e-9,
            "{name}: lock of `{}` at {} s (dense) vs {} s (sparse)",
            a.name,
            a.time_s,
            b.time_s
        );
        worst_impulse =
            worst_impulse.max((a.impulse_ns - b.impulse_ns).abs() / largest_impulse.max(1e-300));
    }
    // (the latch impulses follow from the same states and multipliers: as
    // those, to 1e-6 of the largest)
    assert!(
        worst_impulse <= 1e-6,
        "{name}: lock impulses differ by {worst_impulse:e} of the largest"
    );
    // Member forces: the least-work multipliers agree (the sparse state's
    // basic ones put a redundant group's whole share on the rows it keeps).
    let n_locks = ld.len();
    let (lam_d, lam_s) = (
        d.least_work_multipliers().expect("dense multipliers"),
        s.least_work_multipliers().expect("sparse multipliers"),
    );
    // The least-work split carries the state's joint forces A^T lambda
    // (the Jacobian was just filled at the state by the request).
    let jac = d.jacobian();
    let (mut f_lw, mut f_state) = (vec![0.0; jac.ncols], vec![0.0; jac.ncols]);
    jac.mul_t(&lam_d, &mut f_lw);
    jac.mul_t(&d.state().lambda, &mut f_state);
    let f_err = max_diff(&f_lw, &f_state) / max_abs(&f_state).max(1e-300);
    assert!(
        f_err <= 1e-6 || max_abs(&f_state) < 1e-12,
        "{name}: least-work multipliers change the joint forces by {f_err:e}"
    );
    let lam_err = max_diff(&lam_d, &lam_s) / max_abs(&lam_d).max(1e-300);
    assert!(
        lam_err <= 1e-6,
        "{name}: least-work multipliers differ by {lam_err:e} (relative to the largest)"
    );
    eprintln!(
        "{name}: {steps} steps, max position difference {worst:.2e} m, deploy at {:?} s, \
         {n_locks} locks, max lock-impulse difference {worst_impulse:.1e} of the largest, \
         least-work multipliers {lam_err:.1e} (basic: {:.1e}), joint forces {f_err:.1e}",
        d.state().deploy_time_s,
        max_diff(&lam_d, &s.state().lambda) / max_abs(&lam_d).max(1e-300)
    );
}

#[test]
#[ignore = "every bundled model with both backends, ~2 min in the test profile; CI runs it (.ci/run: slow physics runs)"]
fn bundled_models_deploy_identically() {
    let paths = models();
    assert!(!paths.is_empty());
    for p in paths {
        let m = || load(&p).expect("bundled model loads").model;
        // The mast deploys in 408 steps; the ring (393) and sail array (3331) with the
        // dense solver would take minutes in a debug build: their first 100 steps are
        // compared here, and a quickly deploying ring below covers the latches.
        let name = p.display().to_string();
        if name.contains("pantograph_mast") {
            deploy_both(&name, m, 100_000);
        } else if name.ends_with("models/double_ring.toml") {
            // The bay-by-bay ring starts at its symmetric fold, where the
            // rows leave one first-order mechanism more than the hand count
            // (16 = 15 + 1, asserted here): there the first step's direction
            // is not fixed by the rows, and the two solvers' choices differ
            // by 6.7e-8 m after one step and 7.3e-6 m after two (measured,
            // `simulate --solver dense|sparse --until 0.2 --csv`), so no
            // per-step identity holds; the synchronized rings (the file
            // `double_ring_synchronized.toml` and the nearly deployed ring
            // below) carry the comparison for the ring's elements.
            let model = m();
            let (before, _) = truss_deploy::solver::mobility::before_and_after_locks(&model);
            assert_eq!(before.mechanisms, model.locks.len() / 3 - 3 + 1, "{name}");
        } else if name.ends_with("models/ring_on_bus.toml") {
            // The same fold on a free bus: the six rigid motions more.
            let model = m();
            let (before, _) = truss_deploy::solver::mobility::before_and_after_locks(&model);
            assert_eq!(
                before.mechanisms,
                model.locks.len() / 3 - 3 + 1 + 6,
                "{name}"
            );
        } else {
            compare_runs(&name, m, 100, false);
        }
    }
}

#[test]
#[ignore = "an 18-sided ring with the dense backend, ~6-12 min in the test profile; CI runs it (.ci/run: slow physics runs)"]
fn a_nearly_deployed_ring_latches_identically() {
    use truss_deploy::model::generate::ring::{ring, RingParams};
    let text = ring(&RingParams {
        start_deg: 4.0,
        ..RingParams::synchronized()
    })
    .unwrap()
    .to_toml();
    let m = || {
        parse(&text, "ring.toml")
            .expect("generated ring loads")
            .model
    };
    deploy_both("ring(18 sides, from 4 deg)", m, 10_000);
}

#[test]
fn generated_masts_deploy_identically() {
    for units in [1, 2, 7] {
        let text = generate::mast(&MastParams {
            units,
            ..Default::default()
        })
        .expect("valid params")
        .to_toml();
        let m = || {
            parse(&text, "mast.toml")
                .expect("generated model loads")
                .model
        };
        deploy_both(&format!("mast({units} units)"), m, 100_000);
    }
}

/// Deterministic pseudo-random numbers in [-1, 1).
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }
    fn vec(&mut self, n: usize, scale: f64) -> Vec<f64> {
        (0..n).map(|_| scale * self.next()).collect()
    }
}

/// One factor + accelerations + corrections at a configuration with states of
/// self-stress; joint forces A^T lambda (not lambda) and accelerations compared.
fn compare_single(model: &Model, x: &[f64], locked: &[bool], seed: u64) {
    let mut jac = Jacobian::pattern(model, locked);
    jac.fill(model, x);
    let (m, n) = (jac.nrows, jac.ncols);
    let rank = truss_deploy::solver::mobility::rank(&jac);
    assert!(
        rank < m,
        "the configuration should have redundant rows ({rank} of {m})"
    );
    let mut rng = Lcg(seed);
    let q = rng.vec(n, 3.0);
    // consistent convective term: c = A w
    let w = rng.vec(n, 1.0);
    let mut c = vec![0.0; m];
    jac.mul(&w, &mut c);
    // Inconsistent ones (least-squares in both backends; the simulator's are
    // consistent to roundoff, but the backend must not depend on it).
    let c_bad: Vec<f64> = c.iter().map(|v| v + 1e-6 * rng.next()).collect();
    let r_bad = rng.vec(m, 1e-6);

    let mut dense = SolverKind::Dense.make();
    let mut sparse = SolverKind::Sparse.make();
    // Basic solves (the stepping loop): any exact multipliers; the motion, and
    // the joint forces A^T lambda, are the dense ones. A right-hand side far
    // from consistent falls back to the least-squares answer.
    let c_far: Vec<f64> = c.iter().map(|v| v + 1e-2 * rng.next()).collect();
    for _ in 0..2 {
        dense
            .factor(&jac, &model.inv_mass, SolveMode::Basic)
            .unwrap();
        sparse
            .factor(&jac, &model.inv_mass, SolveMode::Basic)
            .unwrap();
    }
    let forces = |l: &[f64]| {
        let mut f = vec![0.0; n];
        jac.mul_t(l, &mut f);
        f
    };
    for (label, cc) in [
        ("basic, consistent c", &c),
        ("basic, far inconsistent c", &c_far),
    ] {
        let (mut ad, mut ld) = (vec![0.0; n], vec![0.0; m]);
        let (mut as_, mut ls) = (vec![0.0; n], vec![0.0; m]);
        dense
            .accelerations(&jac, &model.inv_mass, &q, cc, &mut ad, &mut ld)
            .unwrap();
        sparse
            .accelerations(&jac, &model.inv_mass, &q, cc, &mut as_, &mut ls)
            .unwrap();
        let ea = max_diff(&ad, &as_) / max_abs(&ad);
        let ef = max_diff(&forces(&ld), &forces(&ls)) / max_abs(&forces(&ld));
        eprintln!("{label}: rel. diff accelerations {ea:.1e}, joint forces {ef:.1e}");
        assert!(
            ea <= 1e-9,
            "{label}: accelerations differ by {ea:e} (relative)"
        );
        assert!(
            ef <= 1e-9,
            "{label}: joint forces differ by {ef:e} (relative)"
        );
    }
    // Compliant solves (elastic members): (S + D) lambda = -c - A M^-1 q is
    // nonsingular, so the multipliers are unique: the same in both backends,
    // and both satisfy M a = q + A^T lambda, A a + D lambda = -c. D spans the
    // members' (1e-5) to the rigid rows' (1e-11) scale; twice, the second
    // time from the sparse backend's kept factorization.
    {
        let d: Vec<f64> = (0..m)
            .map(|i| {
                if i % 3 == 0 {
                    1e-11
                } else {
                    1e-5 * (1.5 + rng.next())
                }
            })
            .collect();
        for pass in 0..2 {
            let (mut ad, mut ld) = (vec![0.0; n], vec![0.0; m]);
            let (mut as_, mut ls) = (vec![0.0; n], vec![0.0; m]);
            dense
                .compliant_accelerations(&jac, &model.inv_mass, &d, &q, &c_far, &mut ad, &mut ld)
                .unwrap();
            let report = sparse
                .compliant_accelerations(&jac, &model.inv_mass, &d, &q, &c_far, &mut as_, &mut ls)
                .unwrap();
            assert!(report.converged, "{report:?}");
            let ea = max_diff(&ad, &as_) / max_abs(&ad);
            let el = max_diff(&ld, &ls) / max_abs(&ld);
            // the equations themselves, for the sparse answer
            let f = forces(&ls);
            let dyn_err = (0..n)
                .map(|i| (as_[i] / model.inv_mass[i] - q[i] - f[i]).abs())
                .fold(0.0f64, f64::max)
                / max_abs(&q);
            let mut aa = vec![0.0; m];
            jac.mul(&as_, &mut aa);
            let con_err = (0..m)
                .map(|i| (aa[i] + d[i] * ls[i] + c_far[i]).abs())
                .fold(0.0f64, f64::max)
                / max_abs(&c_far);
            eprintln!(
                "compliant (pass {pass}): rel. diff accelerations {ea:.1e}, multipliers {el:.1e}; \
                 equations {dyn_err:.1e}, {con_err:.1e}"
            );
            assert!(ea <= 1e-8, "compliant accelerations differ by {ea:e}");
            assert!(el <= 1e-8, "compliant multipliers differ by {el:e}");
            assert!(
                dyn_err <= 1e-10 && con_err <= 1e-8,
                "{dyn_err:e} {con_err:e}"
            );
        }
        // The Newton direction's operator: one solve with the kept
        // factorization, no refinement. At the Jacobian it was made at, the
        // answer is the dense one to within the factorization's roundoff
        // (what a direction needs: the line search judges the iterates on
        // the exact residual), and its accelerations are M^-1 (q + A^T
        // lambda) exactly.
        let (mut ad, mut ld) = (vec![0.0; n], vec![0.0; m]);
        let (mut ar, mut lr) = (vec![0.0; n], vec![0.0; m]);
        dense
            .compliant_accelerations(&jac, &model.inv_mass, &d, &q, &c_far, &mut ad, &mut ld)
            .unwrap();
        let report = sparse
            .compliant_response(&jac, &model.inv_mass, &d, &q, &c_far, &mut ar, &mut lr)
            .unwrap();
        assert!(
            report.reused_factorization && report.factorizations == 0 && report.iterations == 0,
            "{report:?}"
        );
        let ea = max_diff(&ad, &ar) / max_abs(&ad);
        let f = forces(&lr);
        let dyn_err = (0..n)
            .map(|i| (ar[i] / model.inv_mass[i] - q[i] - f[i]).abs())
            .fold(0.0f64, f64::max)
            / max_abs(&q);
        eprintln!("compliant response: rel. diff accelerations {ea:.1e}; equations {dyn_err:.1e}");
        assert!(ea <= 1e-8, "compliant response differs by {ea:e}");
        assert!(dyn_err <= 1e-10, "{dyn_err:e}");
    }
    {
        let (mut dd, mut md) = (vec![0.0; n], vec![0.0; m]);
        let (mut ds, mut ms) = (vec![0.0; n], vec![0.0; m]);
        let mut av = vec![0.0; m];
        jac.mul(&w, &mut av);
        dense
            .correction(&jac, &model.inv_mass, &av, 0.0, &mut dd, &mut md)
            .unwrap();
        sparse
            .correction(&jac, &model.inv_mass, &av, 0.0, &mut ds, &mut ms)
            .unwrap();
        let ex = max_diff(&dd, &ds) / max_abs(&dd);
        eprintln!("basic, consistent r: rel. diff dx {ex:.1e}");
        assert!(
            ex <= 1e-9,
            "basic correction dx differs by {ex:e} (relative)"
        );
    }

    // Minimum-norm solves (latch impulses): the multipliers themselves agree.
    // factor twice: the second factor() reuses the symbolic analysis
    for _ in 0..2 {
        dense
            .factor(&jac, &model.inv_mass, SolveMode::MinNorm)
            .unwrap();
        sparse
            .factor(&jac, &model.inv_mass, SolveMode::MinNorm)
            .unwrap();
    }
    assert_eq!(sparse.name(), "sparse");
    for (label, cc, tol) in [("consistent c", &c, 1e-9), ("inconsistent c", &c_bad, 1e-9)] {
        let (mut ad, mut ld) = (vec![0.0; n], vec![0.0; m]);
        let (mut as_, mut ls) = (vec![0.0; n], vec![0.0; m]);
        dense
            .accelerations(&jac, &model.inv_mass, &q, cc, &mut ad, &mut ld)
            .unwrap();
        sparse
            .accelerations(&jac, &model.inv_mass, &q, cc, &mut as_, &mut ls)
            .unwrap();
        let ea = max_diff(&ad, &as_) / max_abs(&ad);
        let (fd, fs) = (forces(&ld), forces(&ls));
        let ef = max_diff(&fd, &fs) / max_abs(&fd);
        let el = max_diff(&ld, &ls) / max_abs(&ld);
        eprintln!("{label}: rel. diff accelerations {ea:.1e}, joint forces {ef:.1e}, multipliers {el:.1e}");
        assert!(
            ea <= tol,
            "{label}: accelerations differ by {ea:e} (relative)"
        );
        assert!(
            ef <= tol,
            "{label}: joint forces A^T lambda differ by {ef:e} (relative)"
        );
        // minimum norm in both: the multipliers themselves agree, more loosely
        assert!(
            el <= 1e-5,
            "{label}: multipliers differ by {el:e} (relative)"
        );
    }
    let mut av = vec![0.0; m];
    jac.mul(&w, &mut av);
    for (label, r, tol) in [
        ("consistent r", &av, 1e-9),
        ("inconsistent r", &r_bad, 1e-9),
    ] {
        let (mut dd, mut md) = (vec![0.0; n], vec![0.0; m]);
        let (mut ds, mut ms) = (vec![0.0; n], vec![0.0; m]);
        dense
            .correction(&jac, &model.inv_mass, r, 0.0, &mut dd, &mut md)
            .unwrap();
        sparse
            .correction(&jac, &model.inv_mass, r, 0.0, &mut ds, &mut ms)
            .unwrap();
        let ex = max_diff(&dd, &ds) / max_abs(&dd);
        let em = max_diff(&md, &ms) / max_abs(&md);
        eprintln!("{label}: rel. diff dx {ex:.1e}, multipliers {em:.1e}");
        assert!(
            ex <= tol,
            "{label}: corrections dx differ by {ex:e} (relative)"
        );
        assert!(
            em <= 1e-5,
            "{label}: multipliers differ by {em:e} (relative)"
        );
    }
}

#[test]
fn single_solves_match_dense_with_redundant_rows() {
    for units in [4, 12] {
        let text = generate::mast(&MastParams {
            units,
            ..Default::default()
        })
        .expect("valid params")
        .to_toml();
        // a configuration on the manifold part-way through deployment
        let mut s = sim(
            parse(&text, "mast.toml").expect("loads").model,
            SolverKind::Dense,
        );
        for _ in 0..7 {
            s.step(s.model().dt_s).unwrap();
        }
        let model = s.model();
        let x = s.state().x.clone();
        let unlocked = vec![false; model.elements.len()];
        compare_single(model, &x, &unlocked, 1 + units as u64);
        // with every sleeve latched as a bar (more states of self-stress)
        let all: Vec<bool> = (0..model.elements.len())
            .map(|e| model.locks.contains(&e))
            .collect();
        compare_single(model, &x, &all, 100 + units as u64);
        // the initial geometry (a flat mast, 5 deg)
        compare_single(model, &model.x0, &unlocked, 7 + units as u64);
    }
}

/// Per-step timings, dense vs sparse (run with
/// `cargo test --release --no-default-features --test solver sparse_vs_dense::timing_dense_vs_sparse -- --ignored --nocapture`).
#[test]
#[ignore]
fn timing_dense_vs_sparse() {
    let mut cases: Vec<(String, String)> = models()
        .into_iter()
        .map(|p| {
            (
                p.display().to_string(),
                std::fs::read_to_string(&p).unwrap(),
            )
        })
        .collect();
    for units in [20, 60, 150] {
        let text = generate::mast(&MastParams {
            units,
            ..Default::default()
        })
        .unwrap()
        .to_toml();
        cases.push((format!("mast({units} units)"), text));
    }
    for (name, text) in cases {
        for kind in [SolverKind::Dense, SolverKind::Sparse] {
            let model = parse(&text, "m.toml").unwrap().model;
            let sparse_only = std::env::var_os("TIMING_SPARSE_ONLY").is_some();
            if kind == SolverKind::Dense && (model.n_coords() > 500 || sparse_only) {
                continue; // seconds per step
            }
            let mut s = sim(model, kind);
            let dt = s.model().dt_s;
            let steps = if s.model().n_coords() > 300 && kind == SolverKind::Dense {
                5
            } else {
                200
            };
            let f0 = s.factorizations();
            let mut times = Vec::new();
            for _ in 0..steps {
                if s.state().deployed {
                    s.reset().unwrap();
                }
                let t0 = std::time::Instant::now();
                s.step(dt).unwrap();
                times.push(t0.elapsed().as_secs_f64());
            }
            times.sort_by(f64::total_cmp);
            eprintln!(
                "{name} ({} coords, {} rows): {:>6}: median {:9.1} us/step, {:.1} factorizations/step",
                s.model().n_coords(),
                s.jacobian().nrows,
                kind.name(),
                times[times.len() / 2] * 1e6,
                (s.factorizations() - f0) as f64 / steps as f64
            );
        }
    }
}

#[test]
fn refinement_converges_in_few_steps() {
    use truss_deploy::solver::linsolve::sparse::SparseSchur;
    use truss_deploy::solver::linsolve::ConstraintSolver;
    for units in [4, 150] {
        let text = generate::mast(&MastParams {
            units,
            ..Default::default()
        })
        .unwrap()
        .to_toml();
        let mut s = sim(parse(&text, "m.toml").unwrap().model, SolverKind::Sparse);
        for _ in 0..5 {
            s.step(s.model().dt_s).unwrap();
        }
        let model = s.model();
        let mut jac = Jacobian::pattern(model, &vec![false; model.elements.len()]);
        jac.fill(model, &s.state().x);
        let (m, n) = (jac.nrows, jac.ncols);
        let mut sp = SparseSchur::default();
        sp.factor(&jac, &model.inv_mass, SolveMode::Basic).unwrap();
        let mut rng = Lcg(3);
        let q = rng.vec(n, 1.0);
        let w = rng.vec(n, 1.0);
        let mut c = vec![0.0; m];
        jac.mul(&w, &mut c);
        let (mut a, mut l) = (vec![0.0; n], vec![0.0; m]);
        sp.accelerations(&jac, &model.inv_mass, &q, &c, &mut a, &mut l)
            .unwrap();
        eprintln!(
            "{units} units: {} refinement steps, {} inconsistent",
            sp.total_iterations, sp.inconsistent_solves
        );
        assert!(
            sp.total_iterations <= 10,
            "{} refinement steps",
            sp.total_iterations
        );
    }
}

/// The rank the sparse solver's redundant-row probe finds (pivot rejection)
/// equals the SVD rank, on every bundled model at its start and with every
/// sleeve latched, and on the ring at its deployed geometry.
#[test]
fn pivot_rank_matches_the_svd_rank() {
    use truss_deploy::model::generate::ring::{ring, ring_positions, RingParams};
    let mut cases: Vec<(String, Model, Vec<f64>)> = models()
        .into_iter()
        .map(|p| {
            let m = load(&p).expect("bundled model loads").model;
            let x = m.x0.clone();
            (p.display().to_string(), m, x)
        })
        .collect();
    let p = RingParams::synchronized();
    let ring_model = parse(&ring(&p).unwrap().to_toml(), "ring.toml")
        .unwrap()
        .model;
    let deployed: Vec<f64> = ring_positions(&p, 0.0).unwrap().concat();
    assert_eq!(deployed.len(), ring_model.x0.len());
    cases.push(("ring, deployed".into(), ring_model, deployed));
    for (name, model, x) in &cases {
        let unlocked = vec![false; model.elements.len()];
        let latched: Vec<bool> = (0..model.elements.len())
            .map(|e| model.locks.contains(&e))
            .collect();
        for locked in [&unlocked, &latched] {
            let mut jac = Jacobian::pattern(model, locked);
            jac.fill(model, x);
            let mut sparse = SolverKind::Sparse.make();
            sparse
                .factor(&jac, &model.inv_mass, SolveMode::Basic)
                .expect("factors");
            let svd = truss_deploy::solver::mobility::rank(&jac);
            assert_eq!(
                sparse.pivot_rank(),
                Some(svd),
                "{name}: pivot rank vs SVD rank ({} rows, {} coordinates)",
                jac.nrows,
                jac.ncols
            );
        }
    }
}

/// The velocity projection keeps A V near roundoff with the sparse solver too,
/// up to and through the latch of a ring closing from 20 deg, where the rows its
/// basic solves drop are only nearly redundant: measured worst |A v| / |v|
/// 5.3e-12 (dense: ~1e-16); a rank change the probe missed would show as far
/// more, and the projection then falls back to least squares.
#[test]
fn velocities_stay_on_the_constraint_manifold_near_the_flat_state() {
    use truss_deploy::model::generate::ring::{ring, RingParams};
    let text = ring(&RingParams {
        start_deg: 20.0,
        ..RingParams::synchronized()
    })
    .unwrap()
    .to_toml();
    let mut s = sim(parse(&text, "ring.toml").unwrap().model, SolverKind::Sparse);
    let dt = s.model().dt_s;
    let mut worst = 0.0f64;
    for _ in 0..2000 {
        if s.state().deployed {
            break;
        }
        s.step(dt).expect("sparse step");
        let mut jac = s.jacobian().clone();
        jac.fill(s.model(), &s.state().x);
        let mut av = vec![0.0; jac.nrows];
        jac.mul(&s.state().v, &mut av);
        // (relative to |v|, or to 1 mm/s once the latched ring is at rest)
        let rel = max_abs(&av) / max_abs(&s.state().v).max(1e-3);
        worst = worst.max(rel);
        assert!(
            rel <= 1e-10,
            "t = {:.3} s: |A v| = {:e} relative to |v|",
            s.state().t_s,
            rel
        );
    }
    assert!(s.state().deployed, "the ring deploys");
    eprintln!("worst |A v| / |v| = {worst:.1e}");
}

/// Asking for the minimum-norm multipliers (the node does at every
/// publication) leaves the trajectory bitwise as it was: a second backend
/// instance does that solve, not the stepping one with its kept
/// factorizations. Every bundled model through its deployment. (Doing the
/// solve on the stepping backend also passes here; a review measured
/// roundoff-level changes, ~2e-14 m, from it in other call patterns: this
/// guards the property, it did not find that.)
#[test]
#[ignore = "ring runs with least-work multipliers every step, ~4-8 min in the test profile; CI runs it (.ci/run: slow physics runs)"]
fn least_work_multipliers_leave_the_trajectory_unchanged() {
    for p in models() {
        let mut plain = sim(load(&p).expect("model").model, SolverKind::Sparse);
        let mut asked = sim(load(&p).expect("model").model, SolverKind::Sparse);
        let dt = plain.model().dt_s;
        let max_steps = (plain.model().end_time_s / dt).ceil() as usize;
        let mut k = 0;
        while !plain.state().deployed {
            assert!(k < max_steps, "{}: not deployed", p.display());
            plain.step(dt).expect("step");
            asked.step(dt).expect("step");
            let lambda = asked.least_work_multipliers().expect("multipliers");
            assert_eq!(lambda.len(), asked.state().lambda.len());
            assert!(
                plain.state().x == asked.state().x && plain.state().lambda == asked.state().lambda,
                "{}: step {k}: the trajectory changed",
                p.display()
            );
            k += 1;
        }
        assert!(asked.state().deployed);
    }
}

/// A 192-unit mast (1,158 coordinates, the oracle mast's rods, masses and
/// 10 N drive) latching from 58 deg: its sleeves' position correction at the
/// latch has a |Phi| near the projection's tolerance. A minimum-norm solve
/// stopped at the caller's target (1 % of `projection_tol_m`) leaves a
/// residual large relative to so small a rhs, which reads as an inconsistent
/// one: least squares, which then did not converge (accepted inexact, and
/// the run stopped at the first). Minimum-norm solves go to their floor.
#[test]
fn a_long_mast_latches_with_no_least_squares_rescue() {
    let text = generate::mast(&MastParams {
        units: 192,
        rod_length_m: 0.5,
        joint_mass_kg: 0.25,
        start_deg: 58.0,
        deploy_deg: 60.0,
        tension_n: 10.0,
        max_tension_n: 20.0,
        friction_mu: 0.0,
        damping_n_s_per_m: 0.0,
        ..Default::default()
    })
    .expect("valid params")
    .to_toml();
    let mut s = sim(
        parse(&text, "mast192.toml").expect("loads").model,
        SolverKind::Sparse,
    );
    for _ in 0..200 {
        if s.state().deployed {
            break;
        }
        s.step(0.05).expect("step");
    }
    assert!(s.state().deployed);
    let f = &s.solver_stats().fallbacks;
    assert_eq!(s.solver_stats().accepting_fallbacks(), 0, "{f:?}");
    assert_eq!(f.solve_least_squares, 0, "{f:?}");
}
