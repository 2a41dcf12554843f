//! truss-deploy: deployment dynamics of space deployable truss structures.
//!
//! [`solver`] is the pure simulator core (Xu Yan et al.'s macroelement method with
//! exact latch events and drift-free projection); [`model`] reads, validates and
//! generates model files.

pub mod cli;
pub mod model;
#[cfg(feature = "ros")]
pub mod node;
pub mod solver;
