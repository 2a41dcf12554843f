//! Save and restore (`Simulator::save`, `restore`): a run continued from a
//! snapshot, in a simulator made afresh from the model file, is the run that
//! never stopped, to the bit: its whole snapshot at the end (state, counters,
//! kept factorizations) is equal. Each case stops where the step carries
//! something beyond positions and velocities: a latch transient, elastic
//! members' restart sub-steps and member forces, speed-controlled motors,
//! waiting latches, the predictor's history.

use std::path::Path;
use truss_deploy::model::generate::{self, MastParams};
use truss_deploy::model::{load, parse};
use truss_deploy::solver::state::Snapshot;
use truss_deploy::solver::{Model, Options, RequestError, Simulator, SolverError};

fn bundled(name: &str) -> Model {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("models")
        .join(name);
    load(&path).expect("bundled model loads").model
}

/// Steps `sim` `steps` times by `dt` (or until deployed).
fn advance(sim: &mut Simulator, dt: f64, steps: usize) {
    for _ in 0..steps {
        if sim.state().deployed {
            break;
        }
        sim.step(dt).expect("step");
    }
}

/// Saves `sim` after `before` steps, goes on for `after` steps; a fresh
/// simulator of `model` restored from the snapshot (through JSON, as a file
/// or a pickle carries it) goes on for as many: the two end equal.
fn continues_to_the_bit(
    model: &dyn Fn() -> Model,
    setup: &dyn Fn(&mut Simulator),
    dt: f64,
    before: usize,
    after: usize,
) -> Snapshot {
    let mut sim = Simulator::new(model(), Options::default()).unwrap();
    setup(&mut sim);
    advance(&mut sim, dt, before);
    let snap = sim.save();
    let text = serde_json::to_string(&snap).expect("a snapshot serializes");
    let back: Snapshot = serde_json::from_str(&text).expect("and reads back");
    assert_eq!(back, snap, "the JSON round trip changed the snapshot");
    advance(&mut sim, dt, after);

    let mut fresh = Simulator::new(model(), Options::default()).unwrap();
    fresh.restore(&back).expect("restore");
    assert_eq!(fresh.save(), snap, "restored, before any step");
    advance(&mut fresh, dt, after);
    let (a, b) = (sim.save(), fresh.save());
    assert_eq!(a.state.t_s, b.state.t_s);
    assert_eq!(a.state, b.state, "the states differ after the restore");
    assert_eq!(a.solver_stats, b.solver_stats);
    assert_eq!(a.kept, b.kept);
    snap
}

fn none(_: &mut Simulator) {}

#[test]
fn the_mast_restored_mid_deployment_goes_on_to_the_bit() {
    // (the bundled mast's compliant latches engage at ~20.38 s: 406 steps of 0.05 s)
    let mast = || bundled("pantograph_mast.toml");
    let snap = continues_to_the_bit(&mast, &none, 0.05, 150, 400);
    assert!(snap.state.locks.is_empty());
}

#[test]
fn the_mast_restored_while_its_latches_ring_goes_on_to_the_bit() {
    let model = || bundled("pantograph_mast.toml");
    // find a step with a latch transient running
    let mut sim = Simulator::new(model(), Options::default()).unwrap();
    let mut steps = 0;
    while sim.state().transients.is_empty() {
        sim.step(0.05).unwrap();
        steps += 1;
        assert!(steps < 1000, "the latches never engaged");
    }
    let snap = continues_to_the_bit(&model, &none, 0.05, steps, 40);
    assert!(!snap.state.transients.is_empty());
}

#[test]
fn an_elastic_ring_restored_after_a_command_goes_on_to_the_bit() {
    // the bundled ring (elastic members, compliant gears and latches): saved
    // with a new drive command not yet taken (the next step restarts under
    // it), and again later with the members' forces and the predictor's
    // history of a running deployment
    let ring = || bundled("double_ring.toml");
    let command = |sim: &mut Simulator| {
        advance(sim, 0.05, 60);
        let t = 0.8 * sim.model().cables[0].tension_n;
        sim.set_cable_tension(0, t).unwrap();
    };
    let snap = continues_to_the_bit(&ring, &command, 0.05, 0, 80);
    assert!(snap.state.carry.command_changed);
    let snap = continues_to_the_bit(&ring, &none, 0.05, 120, 80);
    assert!(snap.state.carry.member_force_n.iter().any(|f| *f != 0.0));
}

#[test]
fn a_ring_on_a_free_bus_restored_goes_on_holding_its_momenta_to_the_bit() {
    // (the held momenta and the corrections' books are part of the state;
    // saved as the first bays swing out, before the latches)
    let ring = || bundled("ring_on_bus.toml");
    let snap = continues_to_the_bit(&ring, &none, 0.05, 20, 20);
    let held = snap
        .state
        .momentum
        .expect("a free-floating model's momenta are held");
    assert!(held.corrections > 0, "{held:?}");
}

#[test]
fn a_speed_controlled_mast_restored_goes_on_to_the_bit() {
    let text = generate::mast(&MastParams::default()).unwrap().to_toml();
    let model = || parse(&text, "mast.toml").unwrap().model;
    let speed = |sim: &mut Simulator| sim.set_cable_speed(0, Some(0.05)).unwrap();
    let snap = continues_to_the_bit(&model, &speed, 0.05, 100, 200);
    assert_eq!(snap.state.motors[0].speed_cmd_m_s, Some(0.05));
}

#[test]
fn the_synchronized_ring_restored_goes_on_through_its_latches_to_the_bit() {
    // rigid members, one mechanism, 90 sleeves latching at one instant (~19.6 s)
    let snap = continues_to_the_bit(
        &|| bundled("double_ring_synchronized.toml"),
        &none,
        0.05,
        300,
        200,
    );
    assert!(snap.state.locks.is_empty());
}

#[test]
fn a_snapshot_of_another_model_is_refused_and_changes_nothing() {
    let mast = bundled("pantograph_mast.toml");
    let mut other = Simulator::new(bundled("sail_array.toml"), Options::default()).unwrap();
    let before = other.save();
    let snap = Simulator::new(mast, Options::default()).unwrap().save();
    match other.restore(&snap) {
        Err(SolverError::Request(RequestError::SnapshotOfAnotherModel { .. })) => {}
        r => panic!("expected the snapshot refused, got {r:?}"),
    }
    assert_eq!(other.save(), before);
    // a damaged one (a vector of the wrong size) too
    let mut damaged = before.clone();
    damaged.state.x.pop();
    match other.restore(&damaged) {
        Err(SolverError::Request(RequestError::SnapshotSize { field: "x", .. })) => {}
        r => panic!("expected the damaged snapshot refused, got {r:?}"),
    }
    assert_eq!(other.save(), before);
}

#[test]
fn a_reset_runs_the_first_run_again_to_the_bit() {
    // the mast deploys, is reset and deploys again: the second run is the
    // first (its state, its kept factorizations), only the counters go on
    let mut sim = Simulator::new(bundled("pantograph_mast.toml"), Options::default()).unwrap();
    let initial = sim.save();
    advance(&mut sim, 0.05, 2000);
    let first = sim.save();
    assert!(first.state.deployed);
    sim.reset().unwrap();
    let after_reset = sim.save();
    assert_eq!(after_reset.state, initial.state);
    assert_eq!(after_reset.kept, initial.kept);
    assert_eq!(after_reset.solver_stats, first.solver_stats);
    advance(&mut sim, 0.05, 2000);
    let second = sim.save();
    assert_eq!(second.state, first.state);
    assert_eq!(second.kept, first.kept);
    assert_eq!(
        second.solver_stats.steps,
        2 * first.solver_stats.steps,
        "the counters go on counting"
    );
}
