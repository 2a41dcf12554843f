//! truss-deploy-core: the simulator of truss-deploy with its model files and
//! runs, built as its own crate so that it compiles while the DDS stack does.
//! Its modules are re-exported by the `truss_deploy` library, whose paths
//! (`truss_deploy::solver::...`) are the ones to use.
//!
//! [`solver`] is the pure simulator core (Xu Yan et al.'s macroelement method with
//! exact latch events and drift-free projection); [`model`] reads, validates and
//! generates model files; [`run`] runs one model to deployment (for `simulate` and
//! every sweep sample); [`record`] holds what a run records as it steps
//! (frames, CSV, ParaView series); [`files`] writes files atomically. Sweeps are the crate
//! `truss-deploy-sweep` (src/sweep/).

pub mod files;
pub mod model;
pub mod record;
pub mod run;
pub mod solver;
