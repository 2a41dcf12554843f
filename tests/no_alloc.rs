//! The stepping loop reuses its buffers: once a model has run a few steps (the
//! symbolic analysis, the redundant-row probe and the work buffers are set up),
//! a plain step (no latch) allocates nothing on the heap. Counted with a global
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
fn plain_steps_do_not_allocate() {
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
}
