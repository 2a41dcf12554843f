//! The stepping loop reuses its buffers: once a model has run a few steps (the
//! symbolic analysis, the redundant-row probe and the work buffers are set up),
//! a plain step (no latch) allocates nothing on the heap, nor does a sub-step
//! through a compliant latch's transient. Counted with a global
//! allocator wrapper, single-threaded (this file holds one test).

use std::alloc::{GlobalAlloc, Layout, System};
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};
use truss_deploy::model::load;
use truss_deploy::solver::{Options, Simulator};

struct Counting;
static ALLOCATIONS: AtomicU64 = AtomicU64::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn plain_and_transient_steps_do_not_allocate() {
    for name in ["double_ring", "pantograph_mast", "sail_array"] {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("models/{name}.toml"));
        let model = load(&path).expect("bundled model loads").model;
        let dt = model.dt_s;
        let mut sim = Simulator::new(model, Options::default()).expect("simulator");
        for _ in 0..5 {
            sim.step(dt).unwrap();
        }
        let before = ALLOCATIONS.load(Ordering::Relaxed);
        let mut latches = 0;
        for _ in 0..20 {
            latches += sim.step(dt).unwrap();
        }
        let allocations = ALLOCATIONS.load(Ordering::Relaxed) - before;
        assert_eq!(latches, 0, "{name}: these steps should not latch");
        assert_eq!(
            allocations, 0,
            "{name}: 20 plain steps made {allocations} heap allocations"
        );
    }
    // The sub-steps that resolve the mast's compliant latches while they
    // engage (tracking the force, its peak and the settle window) reuse
    // their buffers too; engaging and turning rigid are events and may
    // allocate.
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/pantograph_mast.toml");
    let mut sim = Simulator::new(load(&path).unwrap().model, Options::default()).unwrap();
    while sim.state().transients.is_empty() {
        sim.step(0.05).unwrap();
    }
    sim.step(1e-4).unwrap();
    let (substeps, before) = (
        sim.solver_stats().substeps,
        ALLOCATIONS.load(Ordering::Relaxed),
    );
    let mut events = 0;
    for _ in 0..20 {
        events += sim.step(1e-4).unwrap();
    }
    let allocations = ALLOCATIONS.load(Ordering::Relaxed) - before;
    assert_eq!(events, 0, "these sub-steps should not latch");
    assert_eq!(sim.state().transients.len(), 4, "still engaging");
    assert!(sim.solver_stats().substeps - substeps >= 20);
    assert_eq!(
        allocations, 0,
        "20 steps through the latch transient made {allocations} heap allocations"
    );
    // Compliant elements (the bundled ring with compliant gears) reuse their
    // buffers for their forces and their energy.
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/double_ring_synchronized.toml");
    let text = std::fs::read_to_string(path).unwrap().replace(
        "type = \"sync_hinge\"\n",
        "type = \"sync_hinge\"\nstiffness_n_per_m = 100.0\ndamping_n_s_per_m = 5.0\n",
    );
    assert!(text.contains("stiffness_n_per_m = 100.0"));
    let model = truss_deploy::model::parse(&text, "gears.toml")
        .unwrap()
        .model;
    let mut sim = Simulator::new(model, Options::default()).unwrap();
    for _ in 0..5 {
        sim.step(0.05).unwrap();
    }
    let before = ALLOCATIONS.load(Ordering::Relaxed);
    for _ in 0..20 {
        assert_eq!(sim.step(0.05).unwrap(), 0);
    }
    let allocations = ALLOCATIONS.load(Ordering::Relaxed) - before;
    assert!(
        sim.state().energy.element_spring_energy_j != 0.0,
        "the gears work"
    );
    assert_eq!(
        allocations, 0,
        "20 steps with compliant gears made {allocations} heap allocations"
    );
}
