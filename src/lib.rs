//! truss-deploy: deployment dynamics of space deployable truss structures.
//!
//! [`solver`] is the pure simulator core (Xu Yan et al.'s macroelement method with
//! exact latch events and drift-free projection); [`model`] reads, validates and
//! generates model files; [`run`] runs one model to deployment (for `simulate` and
//! every sweep sample); [`sweep`] runs many samples of a model with scattered parameters;
//! [`cli`] is the command line and [`node`] the ROS 2 node. The first five are
//! the crate `truss-deploy-core` (`src/core.rs`), re-exported here.

#[macro_use]
mod say;

pub use truss_deploy_core::{files, model, run, solver, sweep};

pub mod cli;
#[cfg(feature = "ros")]
pub mod node;
