//! The simulator core: pure Rust, no ROS, no async runtime, no I/O.
//!
//! - [`Model`]: the immutable truss (joints, masses, elements, cables, reference).
//! - [`State`]: what a step changes.
//! - [`Simulator::step`]: the one stepping function the CLI, the node and the benches use.

pub mod cable;
pub mod checks;
pub mod elements;
pub mod jacobian;
pub mod least_work;
pub mod linsolve;
pub mod mobility;
pub mod model;
pub mod rank;
pub mod settings;
pub mod simulator;
pub mod springs;
pub mod state;
pub mod stats;
pub mod vec3;

pub use linsolve::SolverKind;
pub use model::{Cable, Joint, Model, ModelParts};
pub use settings::Options;
pub use settings::SolverSettings;
pub use simulator::Simulator;
pub use state::{Energy, LockEvent, State};
pub use stats::SolverStats;

use std::fmt;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Instant;

#[derive(Clone, Debug, PartialEq)]
pub enum SolverError {
    /// A model or command the solver cannot accept.
    Invalid(String),
    InitialViolation {
        element: String,
        kind: &'static str,
        row: usize,
        residual_m: f64,
        limit_m: f64,
    },
    NonFinite(String),
    /// Non-finite entries in the constraint Jacobian, as a solver backend
    /// finds them; `Simulator::step` reports it as `NonFinite`, naming the
    /// element whose rows hold them.
    NonFiniteJacobian,
    NoConvergence {
        t_s: f64,
    },
    Projection {
        violation_m: f64,
    },
    /// The latch root search ended at its iteration limit with the element's
    /// gap beyond the latch tolerance.
    LatchSearch {
        element: String,
        t_s: f64,
        gap_m: f64,
        iterations: usize,
    },
    /// A lockable element passed its lock without latching.
    MissedLatch {
        element: String,
        t_s: f64,
        gap_m: f64,
    },
    /// The step gave up early at a limit its caller set
    /// (`Simulator::set_step_limits`): the state is the last sub-step it
    /// accepted, at `t_s`, short of the step's end.
    Stopped {
        t_s: f64,
        why: StopWhy,
    },
}

/// When a step gives up before its end (`SolverError::Stopped`), checked
/// before every sub-step: a caller's wall limit or signal does not wait for
/// the thousands of sub-steps a step near a singular state can take.
#[derive(Clone, Debug, Default)]
pub struct StepLimits {
    /// The wall-clock instant past which no sub-step starts.
    pub deadline: Option<Instant>,
    /// A flag that, once raised, stops the step before its next sub-step.
    pub cancel: Option<Arc<AtomicBool>>,
}

impl StepLimits {
    /// Which limit holds now, if any.
    pub(crate) fn reached(&self) -> Option<StopWhy> {
        if self
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
}

impl fmt::Display for SolverError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SolverError::Invalid(s) => write!(f, "{s}"),
            SolverError::InitialViolation { element, kind, row, residual_m, limit_m } => write!(
                f,
                "the initial geometry violates {kind} element `{element}` (row {row} has residual {residual_m:.3e} m, the limit is {limit_m:e} m); \
                 fix the joint positions so that the element's constraints hold, e.g. regenerate the model with `truss-deploy generate`"
            ),
            SolverError::NonFinite(what) => write!(f, "non-finite values in the {what}; check masses, tensions and geometry"),
            SolverError::NonFiniteJacobian => write!(f, "non-finite values in the constraint Jacobian; check masses, tensions and geometry"),
            SolverError::NoConvergence { t_s } => {
                write!(f, "the Newmark iteration did not converge in the step ending at t = {t_s:.6} s; use a smaller --dt")
            }
            SolverError::Projection { violation_m } => write!(
                f,
                "projection onto the constraints failed (|Phi| = {violation_m:.3e} m): the truss reached a singular or locked-up configuration"
            ),
            SolverError::LatchSearch { element, t_s, gap_m, iterations } => write!(
                f,
                "the latch search for `{element}` stopped after {iterations} iterations at t = {t_s:.9} s \
                 with the gap {gap_m:.3e} m, beyond the latch tolerance (its bracket collapsed, or [solver] \
                 root_max_iterations reached); use a smaller --dt"
            ),
            SolverError::MissedLatch { element, t_s, gap_m } => write!(
                f,
                "`{element}` passed its lock without latching (gap {gap_m:.3e} m at t = {t_s:.9} s); \
                 tighten [solver] root_tol_m or use a smaller --dt"
            ),
            SolverError::Stopped { t_s, why } => write!(
                f,
                "the step was stopped at t = {t_s:.6} s, inside it: {}",
                match why {
                    StopWhy::Deadline => "the wall-clock deadline passed",
                    StopWhy::Cancelled => "a stop was requested",
                }
            ),
        }
    }
}

impl std::error::Error for SolverError {}
