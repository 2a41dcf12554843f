//! A step gives up at its caller's limits (`Simulator::set_step_limits`)
//! before its next sub-step, however long the step: a deadline already past,
//! and a cancel flag raised by another thread while one long step runs.

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};
use truss_deploy::model::load;
use truss_deploy::solver::{Options, Simulator, SolverError, StepLimits, StopWhy};

fn ring() -> Simulator {
    let mut m = load(Path::new("models/double_ring.toml"))
        .expect("bundled ring loads")
        .model;
    // (sub-steps as short as the motion needs inside a step of any length,
    // and no cap on their number: a long step grinds instead of failing)
    m.solver.min_substep_fraction = 1e-7;
    m.solver.made_energy_min_substep_fraction = 1e-9;
    m.solver.max_substeps = usize::MAX / 8;
    Simulator::new(m, Options::default()).expect("simulator")
}

#[test]
fn a_step_after_its_deadline_stops_before_its_first_sub_step() {
    let mut sim = ring();
    sim.step(0.05).expect("one plain step");
    let (t0, x0) = (sim.state().t_s, sim.state().x.clone());
    sim.set_step_limits(StepLimits {
        deadline: Some(Instant::now()),
        cancel: None,
        ..StepLimits::default()
    });
    match sim.step(0.05) {
        Err(SolverError::Stopped { t_s, why }) => {
            assert_eq!(why, StopWhy::Deadline);
            assert_eq!(t_s, t0);
        }
        other => panic!("expected a stop at the deadline, got {other:?}"),
    }
    assert_eq!(sim.state().t_s, t0);
    assert_eq!(sim.state().x, x0);
    // (limits lifted: the same step goes on)
    sim.set_step_limits(StepLimits::default());
    sim.step(0.05).expect("the step without limits");
    assert!((sim.state().t_s - (t0 + 0.05)).abs() < 1e-12);
}

#[test]
fn a_long_step_stops_soon_after_its_cancel_flag_is_raised() {
    let mut sim = ring();
    let flag = Arc::new(AtomicBool::new(false));
    sim.set_step_limits(StepLimits {
        deadline: None,
        cancel: Some(flag.clone()),
        ..StepLimits::default()
    });
    // One step over the ring's deployment (~620 s): thousands of sub-steps,
    // seconds of work. The flag goes up after 0.3 s.
    let raiser = {
        let flag = flag.clone();
        std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(300));
            let raised = Instant::now();
            flag.store(true, Ordering::SeqCst);
            raised
        })
    };
    let r = sim.step(2000.0);
    let stopped = Instant::now();
    let raised = raiser.join().expect("raiser thread");
    match r {
        Err(SolverError::Stopped { t_s, why }) => {
            assert_eq!(why, StopWhy::Cancelled);
            // (the first sub-steps are halvings from 2000 s down to what
            // converges: the stop may come before any was accepted)
            assert!(
                (0.0..2000.0).contains(&t_s),
                "stopped inside the step: {t_s}"
            );
            assert_eq!(sim.state().t_s, t_s);
        }
        other => panic!("expected a cancelled step, got {other:?}"),
    }
    let late = stopped.duration_since(raised);
    assert!(
        late < Duration::from_secs(1),
        "stopped {late:?} after the flag"
    );
    // (the state it left is a sound one: the run goes on from it)
    flag.store(false, Ordering::SeqCst);
    sim.step(0.05).expect("a step from the stopped state");
}
