//! truss-deploy-core: everything of truss-deploy except its front ends (the
//! command line and the ROS 2 node), built as its own crate so that it
//! compiles while the DDS stack does. Its modules are re-exported by the
//! `truss_deploy` library, whose paths (`truss_deploy::solver::...`) are the
//! ones to use.
//!
//! [`solver`] is the pure simulator core (Xu Yan et al.'s macroelement method with
//! exact latch events and drift-free projection); [`model`] reads, validates and
//! generates model files; [`run`] runs one model to deployment (for `simulate` and
//! every sweep sample); [`sweep`] runs many samples of a model with scattered parameters;
//! [`files`] writes files atomically.

#[macro_use]
mod say;

pub mod files;
pub mod model;
pub mod run;
pub mod solver;
pub mod sweep;
