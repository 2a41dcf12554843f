//! The `[solver]` settings reach the stepping loop, its counters count what it
//! did, and its give-ups are errors that name the element and the time.

use truss_deploy::model::generate::{self, MastParams};
use truss_deploy::model::parse;
use truss_deploy::solver::{Model, Options, Simulator, SolverError, SolverSettings};

fn mast_model() -> Model {
    let text = generate::mast(&MastParams::default())
        .expect("valid params")
        .to_toml();
    parse(&text, "mast.toml")
        .expect("generated model loads")
        .model
}

/// Steps the mast until it deploys or has taken `max_steps` steps (Ok), or a
/// step fails (Err).
fn run(settings: SolverSettings, max_steps: usize) -> (Simulator, Result<(), SolverError>) {
    let mut m = mast_model();
    m.solver = settings;
    let mut sim = Simulator::new(m, Options::default()).expect("simulator");
    let dt = sim.model().dt_s;
    for _ in 0..max_steps {
        if sim.state().deployed {
            return (sim, Ok(()));
        }
        if let Err(e) = sim.step(dt) {
            return (sim, Err(e));
        }
    }
    (sim, Ok(()))
}

#[test]
fn counters_match_the_run() {
    let (sim, r) = run(SolverSettings::default(), 2000);
    r.expect("the mast deploys with the default settings");
    let (st, s) = (sim.solver_stats(), sim.state());
    assert!(s.deployed);
    assert_eq!(st.steps, s.steps);
    assert_eq!(st.latches, s.locks.len() as u64);
    assert_eq!(s.locks.len(), sim.model().locks.len());
    // (a latch inside a step splits it in two sub-steps)
    assert!(st.substeps > st.steps, "{st:?}");
    assert!(st.newmark_steps >= st.substeps, "{st:?}");
    assert!(st.newmark_iterations >= 2 * st.newmark_steps, "{st:?}");
    assert!(st.latch_searches >= 1 && st.latch_search_steps >= st.latch_searches);
    assert_eq!(
        sim.factorizations(),
        st.factorizations + st.factorizations_reused
    );
    assert!(st.solves >= st.newmark_iterations, "{st:?}");
}

#[test]
fn a_latch_search_at_its_iteration_limit_is_an_error_naming_the_sleeve() {
    let settings = SolverSettings {
        root_max_iterations: 1,
        ..SolverSettings::default()
    };
    let (sim, r) = run(settings, 2000);
    let e = r.expect_err("one Illinois iteration cannot locate a latch to 1e-9 m");
    let SolverError::LatchSearch {
        element,
        t_s,
        gap_m,
        iterations,
    } = &e
    else {
        panic!("expected a latch search error, got: {e}");
    };
    assert_eq!(*iterations, 1);
    assert!(gap_m.abs() > 1e-9, "{e}");
    assert!(
        sim.model()
            .locks
            .iter()
            .any(|&k| sim.model().elements[k].name() == element),
        "{e}"
    );
    assert!(*t_s > sim.state().t_s, "{e}");
    let msg = e.to_string();
    assert!(
        msg.contains(element.as_str()) && msg.contains("root_max_iterations"),
        "{msg}"
    );
}

/// The same limit with a latch tolerance wide enough for the search's far
/// bracket end: that end is taken (counted as `root_search_limit`), and the
/// mast deploys with every sleeve latched.
#[test]
fn a_latch_search_at_its_limit_within_the_latch_tolerance_latches_there() {
    let settings = SolverSettings {
        root_max_iterations: 1,
        lock_tol_m: 1e-2,
        ..SolverSettings::default()
    };
    let (sim, r) = run(settings, 2000);
    r.expect("every search ends within the latch tolerance");
    let (s, st) = (sim.state(), sim.solver_stats());
    assert!(s.deployed);
    assert_eq!(s.locks.len(), sim.model().locks.len());
    assert!(st.fallbacks.root_search_limit >= 1, "{st:?}");
    assert!(
        st.fallbacks.root_search_limit <= st.latch_searches,
        "{st:?}"
    );
}

#[test]
fn a_newmark_iteration_limit_halves_sub_steps() {
    // The default run never halves a sub-step; one fixed-point iteration
    // (converged only when its change is already negligible) must.
    let (sim, r) = run(SolverSettings::default(), 20);
    r.expect("default settings step");
    assert_eq!(sim.solver_stats().fallbacks.substep_halvings, 0);
    let settings = SolverSettings {
        newmark_max_iterations: 1,
        ..SolverSettings::default()
    };
    let (sim, r) = run(settings, 20);
    let halvings = sim.solver_stats().fallbacks.substep_halvings;
    assert!(halvings > 0, "no halving with one iteration allowed");
    // and where even the smallest sub-step does not converge, the step fails
    // with the time named (not a silent result)
    if let Err(e) = r {
        assert!(matches!(e, SolverError::NoConvergence { .. }), "{e}");
    }
}

#[test]
fn invalid_settings_are_rejected_by_name() {
    let mut m = mast_model();
    m.solver.projection_tol_m = -1.0;
    let e = Simulator::new(m, Options::default())
        .err()
        .expect("a negative tolerance is rejected");
    assert!(e.to_string().contains("projection_tol_m"), "{e}");
}
