//! truss-deploy: deployment dynamics of space deployable truss structures.
//!
//! [`solver`] is the pure simulator core (Xu Yan et al.'s macroelement method with
//! exact latch events and drift-free projection); [`model`] reads, validates and
//! generates model files; [`run`] runs one model to deployment (for `simulate` and
//! every sweep sample); [`sweep`] runs many samples of a model with scattered parameters;
//! [`record`] holds what a run records as it steps (frames, CSV, ParaView series);
//! [`cli`] is the command line and [`node`] the ROS 2 node. `solver`, `model`,
//! `run`, `record` and `files` are the crate `truss-deploy-core` (`src/core.rs`), `sweep`
//! the crate `truss-deploy-sweep` (`src/sweep/mod.rs`), re-exported here.

/// println! that ignores a failed write (a closed pipe, a full disk) instead
/// of panicking: the exit status and the files written still tell.
macro_rules! say {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout(), $($t)*);
    }};
}

/// eprintln! that ignores a failed write, as [`say!`].
#[allow(unused_macros)]
macro_rules! tell {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($t)*);
    }};
}

pub use truss_deploy_core::{files, model, record, run, solver};
pub use truss_deploy_sweep as sweep;

pub mod cli;
#[cfg(feature = "ros")]
pub mod node;
