//! Criterion benchmarks of the parts of one simulation step: assembly,
//! factorization, solve, projection, and whole steps with and without a latch
//! (the lock search).
//!
//!     cargo bench --no-default-features --bench step_parts -- --warm-up-time 1 --measurement-time 2
//!
//! Models: the bundled 18-sided double ring (`models/double_ring_synchronized.toml`) and a
//! 90-sided ring generated in-process, both with the dense and the sparse
//! backend except the dense one on the 90-sided ring (too slow). The parts are
//! timed at one state of a deployment from the model's start, reached by a
//! sparse simulation (`MID_STEPS_18` of the 18-sided ring's ~390 steps,
//! `MID_STEPS_90` on the 90-sided one): its x, v, a, lambda and locked set.
//! Both backends see that state.
//!
//! What each benchmark measures (only the routine is timed; setup is not):
//! - `assembly/{fill,residual,adot_xdot}`: `Jacobian::fill` (A), `residual`
//!   (Phi) and `adot_xdot` (the convective term) at x.
//! - `factor/refactor-*`: `ConstraintSolver::factor` doing a numeric
//!   factorization on every call. The sparse backend keeps recent
//!   factorizations and reuses one while the configuration and the mass
//!   matrix match closely enough (the rules change as the backend is tuned),
//!   so the calls rotate through three (A, M^-1) pairs: A at x, one and two
//!   steps earlier, each with its own M^-1 (perturbed by 1e-9 relative, a
//!   different factor per coordinate). No call finds a kept one: checked once
//!   with the backend's counters, and a WARNING is printed if one does. The
//!   pattern and the symbolic analysis are not redone.
//! - `factor/first-sparse`: the first factor() of a new sparse solver: pattern
//!   of S, ordering, symbolic analysis and numeric factorization (redone after
//!   every latch, which changes the pattern).
//! - `solve/*`: `ConstraintSolver::accelerations` (Q = M a - A^T lambda of the
//!   state, c = Adot Xdot), after a factor at x (`fresh`) or, for sparse, with
//!   the factorization kept from the previous step's configuration as the CG
//!   preconditioner (`kept`; skipped if the backend does not keep it).
//! - `projection/correction-*`: the mass-orthogonal correction
//!   `ConstraintSolver::correction` (one Newton iteration of the position
//!   projection, without its factor) with r = Phi(x') at x' = x + 1e-10 m
//!   noise (the size of violation the projection sees inside the stepping
//!   loop), factored at x'. `projection/correction-large-*`: the same with
//!   1e-6 m noise. The setup prints whether the sparse solve found r
//!   inconsistent (its slower fallback path).
//! - `step/plain-*`: `Simulator::step` without a latch, steps `PLAIN_WINDOW`
//!   of a deployment from the model's start (one running simulation per
//!   benchmark, each iteration times its next step; rebuilt untimed at the
//!   window's end).
//! - `step/latch-*` (the lock search): `Simulator::step` over the step in which
//!   the sleeves of a ring generated nearly deployed (`LATCH_START_DEG`) latch:
//!   the root search for the latch time (Newmark steps of trial lengths), the
//!   pattern change, the impulse projection and the mobility count.
//!   `step/before-latch-*` is the plain step before it on the same ring (its
//!   first step, from rest). Each iteration rebuilds and advances the
//!   simulator in its (untimed) setup.

use criterion::measurement::WallTime;
use criterion::{
    criterion_group, criterion_main, BatchSize, BenchmarkGroup, Criterion, SamplingMode,
};
use std::hint::black_box;
use std::path::Path;
use std::time::{Duration, Instant};
use truss_deploy::model::generate::ring::{ring, RingParams};
use truss_deploy::model::parse;
use truss_deploy::solver::jacobian::Jacobian;
use truss_deploy::solver::linsolve::sparse::SparseSchur;
use truss_deploy::solver::linsolve::ConstraintSolver;
use truss_deploy::solver::linsolve::SolveMode;
use truss_deploy::solver::{Model, Options, Simulator, SolverKind};

/// Steps (dt = 0.05 s) from the start to the state the parts are timed at.
const MID_STEPS_18: usize = 150;
const MID_STEPS_90: usize = 100;
/// Start tilt of the nearly deployed ring of the latch-step benchmarks (deg).
const LATCH_START_DEG: f64 = 1.0;
/// Steps [start, end) of a deployment from the model's start whose plain
/// steps are timed.
const PLAIN_WINDOW: (u64, u64) = (10, 300);

fn parse_model(text: &str, name: &str) -> Model {
    parse(text, name)
        .unwrap_or_else(|e| panic!("{name}: {e}"))
        .model
}

fn simulator(text: &str, name: &str, solver: SolverKind) -> Simulator {
    Simulator::new(
        parse_model(text, name),
        Options {
            solver,
            ..Default::default()
        },
    )
    .unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn ring_text(sides: usize, start_deg: f64) -> String {
    ring(&RingParams {
        sides,
        start_deg,
        ..RingParams::synchronized()
    })
    .expect("valid ring parameters")
    .to_toml()
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
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m, x| m.max(x.abs()))
}

/// A mid-deployment state of one model, and what the parts need at it.
struct Fixture {
    label: &'static str,
    kinds: &'static [SolverKind],
    model: Model,
    /// A filled at x (pattern of the state's locked set).
    jac: Jacobian,
    x: Vec<f64>,
    v: Vec<f64>,
    /// Configurations one and two steps earlier (same locked set).
    x_prev: Vec<f64>,
    x_prev2: Vec<f64>,
    /// Applied forces Q = M a - A^T lambda of the state, convective term c.
    q: Vec<f64>,
    c: Vec<f64>,
    /// Three inverse-mass vectors: M^-1, and two perturbed by 1e-9 relative
    /// (a different random factor per coordinate: not proportional to M^-1).
    inv_mass: [Vec<f64>; 3],
}

impl Fixture {
    fn new(
        label: &'static str,
        text: &str,
        mid_steps: usize,
        kinds: &'static [SolverKind],
    ) -> Fixture {
        let mut sim = simulator(text, label, SolverKind::Sparse);
        let dt = sim.model().dt_s;
        let (mut x_prev, mut x_prev2) = (Vec::new(), Vec::new());
        for k in 0..mid_steps {
            if k + 2 == mid_steps {
                x_prev2 = sim.state().x.clone();
            }
            if k + 1 == mid_steps {
                x_prev = sim.state().x.clone();
            }
            sim.step(dt)
                .unwrap_or_else(|e| panic!("{label}: step {}: {e}", k + 1));
        }
        let s = sim.state();
        assert!(!s.deployed, "{label}: deployed before the mid state");
        assert_eq!(
            s.locks.len(),
            0,
            "{label}: a latch before the mid state (x_prev would have another pattern)"
        );
        let model = parse_model(text, label);
        let mut jac = Jacobian::pattern(&model, &s.locked);
        jac.fill(&model, &s.x);
        let n = model.n_coords();
        let mut q = vec![0.0; n];
        jac.mul_t(&s.lambda, &mut q);
        for ((q, m), a) in q.iter_mut().zip(&model.mass).zip(&s.a) {
            *q = m * a - *q;
        }
        let mut c = vec![0.0; jac.nrows];
        jac.adot_xdot(&model, &s.x, &s.v, &mut c);
        let perturbed = |seed: u64| {
            let mut rng = Lcg(seed);
            let w = model.inv_mass.iter();
            w.map(|w| w * (1.0 + 1e-9 * rng.next()))
                .collect::<Vec<f64>>()
        };
        let inv_mass = [model.inv_mass.clone(), perturbed(1), perturbed(2)];
        eprintln!(
            "{label}: {} joints, {} coordinates, {} constraint rows, t = {:.2} s ({} steps)",
            model.joints.len(),
            n,
            jac.nrows,
            s.t_s,
            mid_steps
        );
        Fixture {
            label,
            kinds,
            jac,
            x: s.x.clone(),
            v: s.v.clone(),
            x_prev,
            x_prev2,
            q,
            c,
            inv_mass,
            model,
        }
    }

    /// A filled at x two steps earlier, one step earlier, and at x: the
    /// configurations the factorization benchmark rotates through.
    fn rotation_jacobians(&self) -> [Jacobian; 3] {
        let filled = |x: &[f64]| {
            let mut jac = self.jac.clone();
            jac.fill(&self.model, x);
            jac
        };
        [filled(&self.x_prev2), filled(&self.x_prev), filled(&self.x)]
    }

    fn id(&self, what: &str, kind: SolverKind) -> String {
        format!("{what}-{}/{}", kind.name(), self.label)
    }
}

fn fixtures() -> Vec<Fixture> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/double_ring_synchronized.toml");
    let ring18 = std::fs::read_to_string(&path).expect("models/double_ring_synchronized.toml");
    vec![
        Fixture::new(
            "ring18",
            &ring18,
            MID_STEPS_18,
            &[SolverKind::Dense, SolverKind::Sparse],
        ),
        Fixture::new(
            "ring90",
            &ring_text(90, RingParams::synchronized().start_deg),
            MID_STEPS_90,
            &[SolverKind::Sparse],
        ),
    ]
}

fn assembly(c: &mut Criterion, fx: &[Fixture]) {
    let mut g = c.benchmark_group("assembly");
    for f in fx {
        let mut jac = f.jac.clone();
        g.bench_function(format!("fill/{}", f.label), |b| {
            b.iter(|| jac.fill(&f.model, black_box(&f.x)))
        });
        let mut out = vec![0.0; f.jac.nrows];
        g.bench_function(format!("residual/{}", f.label), |b| {
            b.iter(|| f.jac.residual(&f.model, black_box(&f.x), &mut out))
        });
        g.bench_function(format!("adot_xdot/{}", f.label), |b| {
            b.iter(|| f.jac.adot_xdot(&f.model, black_box(&f.x), &f.v, &mut out))
        });
    }
    g.finish();
}

/// Whether rotating through the three (configuration, inverse masses) pairs
/// makes every sparse factor() a numeric factorization (no kept one reused).
fn rotation_refactors(f: &Fixture, jacs: &[Jacobian; 3]) -> bool {
    let mut s = SparseSchur::default();
    s.factor(&jacs[0], &f.inv_mass[0], SolveMode::Basic)
        .expect("sparse factor");
    let (n0, r0) = (s.numeric_factorizations, s.reused_factorizations);
    for k in 1..=9 {
        s.factor(&jacs[k % 3], &f.inv_mass[k % 3], SolveMode::Basic)
            .expect("sparse factor");
    }
    s.numeric_factorizations - n0 == 9 && s.reused_factorizations == r0
}

fn factor(c: &mut Criterion, fx: &[Fixture]) {
    let mut g = c.benchmark_group("factor");
    g.sample_size(20);
    g.sampling_mode(SamplingMode::Flat);
    for f in fx {
        let jacs = f.rotation_jacobians();
        if f.kinds.contains(&SolverKind::Sparse) && !rotation_refactors(f, &jacs) {
            eprintln!(
                "WARNING {}: the sparse backend reused a kept factorization although the \
                 configuration and the inverse masses changed; factor/refactor-sparse \
                 measures reuse, not only refactoring",
                f.label
            );
        }
        for &kind in f.kinds {
            let mut s = kind.make();
            s.factor(&jacs[0], &f.inv_mass[0], SolveMode::Basic)
                .expect("factor");
            let mut k = 0;
            g.bench_function(f.id("refactor", kind), |b| {
                b.iter(|| {
                    k = (k + 1) % 3;
                    s.factor(black_box(&jacs[k]), &f.inv_mass[k], SolveMode::Basic)
                        .expect("factor")
                })
            });
        }
        if f.kinds.contains(&SolverKind::Sparse) {
            g.bench_function(f.id("first", SolverKind::Sparse), |b| {
                b.iter_batched(
                    || SolverKind::Sparse.make(),
                    |mut s| {
                        s.factor(black_box(&f.jac), &f.inv_mass[0], SolveMode::Basic)
                            .expect("factor");
                        s
                    },
                    BatchSize::SmallInput,
                )
            });
        }
    }
    g.finish();
}

fn solve(c: &mut Criterion, fx: &[Fixture]) {
    let mut g = c.benchmark_group("solve");
    g.sample_size(50);
    for f in fx {
        let (n, m) = (f.jac.ncols, f.jac.nrows);
        let w = &f.inv_mass[0];
        let (mut a, mut lambda) = (vec![0.0; n], vec![0.0; m]);
        for &kind in f.kinds {
            let mut s = kind.make();
            s.factor(&f.jac, w, SolveMode::Basic).expect("factor");
            g.bench_function(f.id("fresh", kind), |b| {
                b.iter(|| s.accelerations(&f.jac, w, black_box(&f.q), &f.c, &mut a, &mut lambda))
            });
        }
        if f.kinds.contains(&SolverKind::Sparse) {
            // Factor at the previous step's configuration, then at x: the second
            // call keeps the first factorization as the CG preconditioner.
            let mut s = SparseSchur::default();
            let mut jac_prev = f.jac.clone();
            jac_prev.fill(&f.model, &f.x_prev);
            s.factor(&jac_prev, w, SolveMode::Basic).expect("factor");
            let reused = s.reused_factorizations;
            s.factor(&f.jac, w, SolveMode::Basic).expect("factor");
            if s.reused_factorizations != reused + 1 {
                eprintln!(
                    "SKIPPED solve/kept-sparse/{}: the backend did not keep the previous \
                     step's factorization",
                    f.label
                );
                continue;
            }
            g.bench_function(f.id("kept", SolverKind::Sparse), |b| {
                b.iter(|| s.accelerations(&f.jac, w, black_box(&f.q), &f.c, &mut a, &mut lambda))
            });
        }
    }
    g.finish();
}

/// The configurations the projection benchmarks correct: x plus noise of
/// 1e-10 m per coordinate (|Phi| ~ 1e-10 m, the violations the position
/// projection starts from inside the stepping loop: 1e-10 to 6e-10 m on the
/// 18-sided ring), and of 1e-6 m (a large violation; its second-order terms
/// make r inconsistent along the states of self-stress beyond roundoff).
fn projection_targets(f: &Fixture) -> [(&'static str, Vec<f64>); 2] {
    let noisy = |eps: f64| {
        let mut rng = Lcg(7);
        f.x.iter().map(|x| x + eps * rng.next()).collect()
    };
    [
        ("correction", noisy(1e-10)),
        ("correction-large", noisy(1e-6)),
    ]
}

fn projection(c: &mut Criterion, fx: &[Fixture]) {
    let mut g = c.benchmark_group("projection");
    g.sample_size(30);
    for f in fx {
        let (n, m) = (f.jac.ncols, f.jac.nrows);
        let w = &f.inv_mass[0];
        for (what, xp) in projection_targets(f) {
            let mut jac = f.jac.clone();
            jac.fill(&f.model, &xp);
            let mut r = vec![0.0; m];
            jac.residual(&f.model, &xp, &mut r);
            let (mut dx, mut mu) = (vec![0.0; n], vec![0.0; m]);
            if f.kinds.contains(&SolverKind::Sparse) {
                let mut s = SparseSchur::default();
                s.factor(&jac, w, SolveMode::Basic).expect("factor");
                s.correction(&jac, w, &r, 0.0, &mut dx, &mut mu)
                    .expect("correction");
                eprintln!(
                    "{} {what}: sparse solve: {} CG iterations, right-hand side {}",
                    f.label,
                    s.cg_iterations,
                    if s.inconsistent_solves > 0 {
                        "inconsistent (fallback path)"
                    } else {
                        "consistent"
                    }
                );
            }
            for &kind in f.kinds {
                let mut s = kind.make();
                s.factor(&jac, w, SolveMode::Basic).expect("factor");
                // Sanity: one correction removes most of the violation.
                s.correction(&jac, w, &r, 0.0, &mut dx, &mut mu)
                    .expect("correction");
                let x1: Vec<f64> = xp.iter().zip(&dx).map(|(x, d)| x - d).collect();
                let mut r1 = vec![0.0; m];
                jac.residual(&f.model, &x1, &mut r1);
                eprintln!(
                    "{} {what} {}: |Phi| {:.1e} m -> {:.1e} m after one correction",
                    f.label,
                    kind.name(),
                    max_abs(&r),
                    max_abs(&r1)
                );
                g.bench_function(f.id(what, kind), |b| {
                    b.iter(|| s.correction(&jac, w, black_box(&r), 0.0, &mut dx, &mut mu))
                });
            }
        }
    }
    g.finish();
}

/// Plain steps inside a window of a deployment: each iteration times the next
/// step of one running simulation, which is rebuilt (untimed) from the model's
/// start and advanced to `PLAIN_WINDOW.0` steps whenever it reaches
/// `PLAIN_WINDOW.1`. The window holds no latch.
fn plain_steps(g: &mut BenchmarkGroup<WallTime>, label: &str, text: &str, kind: SolverKind) {
    let (start, end) = PLAIN_WINDOW;
    let fresh = || {
        let mut sim = simulator(text, label, kind);
        let dt = sim.model().dt_s;
        for k in 0..start {
            sim.step(dt)
                .unwrap_or_else(|e| panic!("{label}: step {}: {e}", k + 1));
        }
        sim
    };
    let mut sim = fresh();
    let dt = sim.model().dt_s;
    // (steps, factor() calls) when the current simulation entered the window.
    let mut base = (sim.state().steps, sim.factorizations());
    g.bench_function(format!("plain-{}/{label}", kind.name()), |b| {
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            for _ in 0..iters {
                if sim.state().steps >= end {
                    sim = fresh();
                    base = (sim.state().steps, sim.factorizations());
                }
                let t0 = Instant::now();
                let events = sim.step(black_box(dt));
                total += t0.elapsed();
                let events = events
                    .unwrap_or_else(|e| panic!("{label}: step {}: {e}", sim.state().steps + 1));
                assert_eq!(
                    events,
                    0,
                    "{label}: a latch in step {} (inside the plain-step window)",
                    sim.state().steps
                );
            }
            total
        })
    });
    let steps = sim.state().steps - base.0;
    if steps > 0 {
        eprintln!(
            "{label} {}: {:.1} factor() calls per plain step; {}",
            kind.name(),
            (sim.factorizations() - base.1) as f64 / steps as f64,
            sim.solver_diagnostics()
        );
    }
}

/// A ring generated nearly deployed (`LATCH_START_DEG`): `latch_step` is the
/// step in which its sleeves latch (found with the sparse backend).
struct LatchCase {
    label: String,
    text: String,
    kinds: &'static [SolverKind],
    latch_step: usize,
}

fn latch_case(sides: usize, kinds: &'static [SolverKind]) -> Option<LatchCase> {
    let label = format!("ring{sides}-from-{LATCH_START_DEG}deg");
    let text = ring_text(sides, LATCH_START_DEG);
    let mut sim = simulator(&text, &label, SolverKind::Sparse);
    let dt = sim.model().dt_s;
    for k in 1..=50 {
        match sim.step(dt) {
            Ok(0) => {}
            Ok(events) => {
                eprintln!("{label}: {events} latches in step {k}");
                return Some(LatchCase {
                    label,
                    text,
                    kinds,
                    latch_step: k,
                });
            }
            Err(e) => {
                eprintln!("SKIPPED step/*/{label}: step {k} failed: {e}");
                return None;
            }
        }
    }
    eprintln!("SKIPPED step/*/{label}: no latch in 50 steps");
    None
}

/// The latch step and the step before it, each on a simulator rebuilt and
/// advanced to it in the iteration's setup.
fn latch_steps(g: &mut BenchmarkGroup<WallTime>, case: &LatchCase) {
    let label = case.label.as_str();
    for &kind in case.kinds {
        for (what, timed) in [
            ("before-latch", case.latch_step - 1),
            ("latch", case.latch_step),
        ] {
            if timed == 0 {
                continue;
            }
            let setup = || {
                let mut sim = simulator(&case.text, label, kind);
                let dt = sim.model().dt_s;
                for _ in 1..timed {
                    sim.step(dt).expect("step");
                }
                sim
            };
            // Check once that this backend gets through the step, and latches
            // in the same one.
            let mut sim = setup();
            let dt = sim.model().dt_s;
            match sim.step(dt) {
                Ok(events) if (events > 0) == (what == "latch") => {}
                other => {
                    eprintln!(
                        "SKIPPED step/{what}-{}/{label}: step {timed} gave {other:?}",
                        kind.name()
                    );
                    continue;
                }
            }
            g.bench_function(format!("{what}-{}/{label}", kind.name()), |b| {
                b.iter_batched(
                    setup,
                    |mut sim| {
                        let events = sim.step(black_box(dt)).expect("step");
                        (sim, events)
                    },
                    BatchSize::PerIteration,
                )
            });
        }
    }
}

fn step(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/double_ring_synchronized.toml");
    let ring18 = std::fs::read_to_string(&path).expect("models/double_ring_synchronized.toml");
    let ring90 = ring_text(90, RingParams::synchronized().start_deg);
    let mut g = c.benchmark_group("step");
    g.sample_size(10);
    g.sampling_mode(SamplingMode::Flat);
    plain_steps(&mut g, "ring18", &ring18, SolverKind::Dense);
    plain_steps(&mut g, "ring18", &ring18, SolverKind::Sparse);
    plain_steps(&mut g, "ring90", &ring90, SolverKind::Sparse);
    // Not the 90-sided ring: its latch step took 2-3 s when this was written,
    // and each iteration's setup (Simulator::new, whose mobility count is a
    // dense SVD up to 1 500 coordinates) about 1 s more.
    if let Some(case) = latch_case(18, &[SolverKind::Dense, SolverKind::Sparse]) {
        latch_steps(&mut g, &case);
    }
    g.finish();
}

fn parts(c: &mut Criterion) {
    let fx = fixtures();
    assembly(c, &fx);
    factor(c, &fx);
    solve(c, &fx);
    projection(c, &fx);
}

criterion_group!(benches, parts, step);
criterion_main!(benches);
