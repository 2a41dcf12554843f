//! The simulator core: pure Rust, no ROS, no async runtime, no I/O.
//!
//! - [`Model`]: the immutable truss (joints, masses, elements, cables, reference).
//! - [`State`]: what a step changes.
//! - [`Simulator::step`]: the one stepping function the CLI, the node and the benches use.

pub mod cable;
pub mod checks;
pub mod elements;
mod error;
pub mod jacobian;
pub mod least_work;
pub mod linsolve;
pub mod mobility;
pub mod model;
pub mod modes;
pub mod rank;
pub mod settings;
pub mod simulator;
pub mod springs;
pub mod state;
pub mod stats;
pub mod vec3;
pub mod wide;

pub use error::{BackendError, MotorConflict, RequestError, SolverError};
pub use linsolve::SolverKind;
pub use model::{Cable, Joint, Model, ModelParts};
pub use settings::Options;
pub use settings::SolverSettings;
pub use simulator::Simulator;
pub use state::{Energy, LockEvent, State};
pub use stats::SolverStats;

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Instant;

/// When a step gives up before its end (`SolverError::Stopped`), checked
/// before every sub-step: a caller's wall limit or signal does not wait for
/// the thousands of sub-steps a step near a singular state can take.
#[derive(Clone, Debug, Default)]
pub struct StepLimits {
    /// The wall-clock instant past which no sub-step starts.
    pub deadline: Option<Instant>,
    /// A flag that, once raised, stops the step before its next sub-step.
    pub cancel: Option<Arc<AtomicBool>>,
    /// The count of results accepted inexact (`SolverStats::accepting_fallbacks`)
    /// past which no sub-step starts: a run that takes none ends at the first.
    pub max_accepting_fallbacks: Option<u64>,
}

impl StepLimits {
    /// Which limit holds now, if any, with `accepting` results accepted
    /// inexact so far.
    pub(crate) fn reached(&self, accepting: u64) -> Option<StopWhy> {
        if self.max_accepting_fallbacks.is_some_and(|m| accepting > m) {
            Some(StopWhy::Inexact)
        } else if self
            .cancel
            .as_ref()
            .is_some_and(|c| c.load(Ordering::Relaxed))
        {
            Some(StopWhy::Cancelled)
        } else if self.deadline.is_some_and(|d| Instant::now() >= d) {
            Some(StopWhy::Deadline)
        } else {
            None
        }
    }
}

/// Which of the caller's step limits stopped a step (`SolverError::Stopped`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StopWhy {
    /// The wall-clock deadline passed.
    Deadline,
    /// The cancel flag was raised (a signal, another thread).
    Cancelled,
    /// A result was accepted inexact beyond `max_accepting_fallbacks`.
    Inexact,
}
