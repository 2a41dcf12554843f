//! A free-floating model's momenta (stage `momentum`): held only where
//! nothing external acts, and then constant over a deployment, measured here
//! from the state's positions, velocities and masses (not from the stage's
//! own books). The corrections that hold them are the integrator's own
//! drift, which the run with the stage off shows.

use std::path::Path;
use truss_deploy::model::load;
use truss_deploy::solver::state::HeldMomentum;
use truss_deploy::solver::{Model, Options, Simulator};

fn bundled(name: &str) -> Model {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("models")
        .join(name);
    load(&path).expect("bundled model loads").model
}

/// P = sum m v and L = sum m (x - c0) x v about the fixed point c0, with
/// their scales sum m |v| and sum m |x - c0| |v|.
fn momenta(model: &Model, x: &[f64], v: &[f64], c0: [f64; 3]) -> ([f64; 6], f64, f64) {
    let (mut out, mut ps, mut ls) = ([0.0; 6], 0.0, 0.0);
    for (j, jt) in model.joints.iter().enumerate() {
        let m = jt.mass_kg;
        let r: Vec<f64> = (0..3).map(|k| x[3 * j + k] - c0[k]).collect();
        let w = &v[3 * j..3 * j + 3];
        for k in 0..3 {
            out[k] += m * w[k];
        }
        out[3] += m * (r[1] * w[2] - r[2] * w[1]);
        out[4] += m * (r[2] * w[0] - r[0] * w[2]);
        out[5] += m * (r[0] * w[1] - r[1] * w[0]);
        let norm = |a: &[f64]| a.iter().map(|q| q * q).sum::<f64>().sqrt();
        ps += m * norm(w);
        ls += m * norm(&r) * norm(w);
    }
    (out, ps, ls)
}

fn centre(model: &Model) -> [f64; 3] {
    let total: f64 = model.joints.iter().map(|j| j.mass_kg).sum();
    let mut c = [0.0; 3];
    for (j, jt) in model.joints.iter().enumerate() {
        for (k, ck) in c.iter_mut().enumerate() {
            *ck += jt.mass_kg * model.x0[3 * j + k] / total;
        }
    }
    c
}

/// What `deploy` measures.
struct Run {
    /// The largest |P - P0| and |L - L0| over the steps relative to their
    /// scales, and the angular scale (N m s).
    linear_drift_rel: f64,
    angular_drift_rel: f64,
    angular_scale_n_m_s: f64,
    deploy_time_s: f64,
    /// The state's books of the corrections.
    held: Option<HeldMomentum>,
}

/// Runs `model` to its deployment (at most 2000 steps of its dt).
fn deploy(model: Model) -> Run {
    let c0 = centre(&model);
    let dt = model.dt_s;
    let mut sim = Simulator::new(model, Options::default()).unwrap();
    let (m0, _, _) = momenta(sim.model(), &sim.state().x, &sim.state().v, c0);
    let (mut dp, mut dl, mut ps, mut ls) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for _ in 0..2000 {
        if sim.state().deployed {
            break;
        }
        sim.step(dt).expect("step");
        let s = sim.state();
        let (m, p_scale, l_scale) = momenta(sim.model(), &s.x, &s.v, c0);
        let diff = |a: usize| {
            (a..a + 3)
                .map(|k| (m[k] - m0[k]).powi(2))
                .sum::<f64>()
                .sqrt()
        };
        dp = dp.max(diff(0));
        dl = dl.max(diff(3));
        ps = ps.max(p_scale);
        ls = ls.max(l_scale);
    }
    let s = sim.state();
    assert!(s.deployed, "deployed within 2000 steps");
    Run {
        linear_drift_rel: dp / ps,
        angular_drift_rel: dl / ls,
        angular_scale_n_m_s: ls,
        deploy_time_s: s.deploy_time_s.unwrap(),
        held: s.momentum,
    }
}

#[test]
fn the_momenta_are_held_where_nothing_external_acts_only() {
    let held = |m: Model| {
        Simulator::new(m, Options::default())
            .unwrap()
            .state()
            .momentum
            .is_some()
    };
    assert!(held(bundled("ring_on_bus.toml")));
    // clamped to a boom: its supports are external
    assert!(!held(bundled("double_ring.toml")));
    assert!(!held(bundled("pantograph_mast.toml")));
    // joint damping acts on absolute velocities; gravity is an external load
    let mut damped = bundled("ring_on_bus.toml");
    damped.damping_n_s_per_m = 1.0;
    assert!(!held(damped));
    let mut heavy = bundled("ring_on_bus.toml");
    heavy.gravity_m_s2 = [0.0, 0.0, -9.81];
    assert!(!held(heavy));
    let mut off = bundled("ring_on_bus.toml");
    off.solver.momentum_projection = false;
    assert!(!held(off));
}

/// The bundled ring on its bus: both momenta constant to 1e-12 of their
/// scales at every step; with the stage off the angular momentum drifts
/// (the trapezoid's truncation and its backward-Euler restarts: 9.6e-7
/// measured) and the corrections' sum is at least about that drift, which
/// they take out step by step. The deployment itself moves by no more than
/// that drift makes of it, and the kinetic energy by far less.
#[test]
fn a_ring_on_a_free_bus_keeps_its_momenta_at_every_step() {
    let held = deploy(bundled("ring_on_bus.toml"));
    let (dp, dl) = (held.linear_drift_rel, held.angular_drift_rel);
    assert!(
        dp < 1e-12 && dl < 1e-12,
        "drift linear {dp:e}, angular {dl:e}"
    );
    let books = held.held.expect("held");
    assert!(books.corrections > 0);
    assert!(books.largest_angular_n_m_s <= books.angular_removed_n_m_s);
    assert!(books.kinetic_change_j.abs() < 1e-9, "{books:?}");

    let mut m = bundled("ring_on_bus.toml");
    m.solver.momentum_projection = false;
    let free = deploy(m);
    assert!(free.held.is_none());
    assert!(free.linear_drift_rel < 1e-12, "{}", free.linear_drift_rel);
    let drift = free.angular_drift_rel;
    assert!(
        drift > 1e-8 && drift < 1e-5,
        "angular drift, not held: {drift:e}"
    );
    let removed_rel = books.angular_removed_n_m_s / held.angular_scale_n_m_s;
    assert!(
        removed_rel >= 0.5 * drift && removed_rel < 1e-4,
        "corrections {removed_rel:e} of the scale, drift not held {drift:e}"
    );
    let (t, t_free) = (held.deploy_time_s, free.deploy_time_s);
    assert!(
        (t - t_free).abs() <= 1e-6 * t_free,
        "deploy time held {t} s, not held {t_free} s"
    );
}
