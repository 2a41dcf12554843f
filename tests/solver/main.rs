//! The solver's tests without a process or a network: element oracles,
//! dynamics against closed forms and quadratures, the bundled models.
//! One test binary (one link of the crate) for all of them.

mod bay_by_bay_ring;
mod compliant_elements;
mod double_ring;
mod dynamics;
mod elastic_members;
mod elements_oracles;
mod latch_loads;
mod modes;
mod momentum;
mod sail_array;
mod snapshot;
mod solver_settings;
mod sparse_vs_dense;
mod speed_motor;
mod step_limits;
