//! What can go wrong in the simulator, as types: a caller's request refused
//! (nothing changed), the motors' commands in conflict, a step that gives up
//! (what and where), a backend that cannot take the system. Each message
//! says what happened and what to change.

use super::settings::SettingsError;
use super::state::ModelKey;
use super::StopWhy;
use std::fmt;

#[derive(Clone, Debug, PartialEq)]
pub enum SolverError {
    /// A request the simulator refuses; it changed nothing.
    Request(RequestError),
    /// The model's `[solver]` settings are unusable.
    Settings(SettingsError),
    /// The speed-controlled motors cannot take a command together; nothing changed.
    MotorConflict(MotorConflict),
    /// More sub-steps (or latch events) in one step than `max_substeps`
    /// allows (four more per lockable element).
    SubstepBudget {
        max_substeps: usize,
        t_end_s: f64,
    },
    /// The sparse backend cannot take the constraint system.
    Backend(BackendError),
    InitialViolation {
        element: String,
        kind: &'static str,
        row: usize,
        residual_m: f64,
        limit_m: f64,
    },
    /// Non-finite values in what is named (accelerations, a solve, the
    /// Jacobian's rows of an element).
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

/// A caller's request the simulator refuses (`SolverError::Request`).
#[derive(Clone, Debug, PartialEq)]
pub enum RequestError {
    NoSuchCable {
        index: usize,
        cables: usize,
    },
    Tension {
        cable: String,
        tension_n: f64,
        max_tension_n: f64,
    },
    /// A speed command that is not a finite number.
    Speed {
        cable: String,
        speed_m_s: f64,
    },
    /// Speed control of a cable with a line density.
    SpeedOfMassiveCable {
        cable: String,
    },
    TimeStep {
        dt_s: f64,
    },
    SnapshotOfAnotherModel {
        snapshot: ModelKey,
        model: ModelKey,
    },
    /// A snapshot that names an element the model does not have (or a
    /// latch transient without its event).
    SnapshotIndex {
        element: Option<usize>,
        elements: usize,
    },
    /// A snapshot whose `field` has `len` entries where the model takes `expected`.
    SnapshotSize {
        field: &'static str,
        len: usize,
        expected: usize,
    },
}

/// The tracking motors' system is singular (`SolverError::MotorConflict`).
#[derive(Clone, Debug, PartialEq)]
pub enum MotorConflict {
    /// The structure cannot move along the cable (locked up, or singular).
    Immobile { cable: String },
    /// The cable drives the same motion as the others named.
    SameMotion { cable: String, others: Vec<String> },
}

/// What the sparse backend cannot take (`SolverError::Backend`).
#[derive(Clone, Debug, PartialEq)]
pub enum BackendError {
    /// More entries than its 32-bit index map holds.
    TooLarge { entries: usize },
    /// The symbolic factorization failed (faer's message).
    Symbolic { detail: String },
}

impl fmt::Display for SolverError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SolverError::Request(e) => write!(f, "{e}"),
            SolverError::Settings(e) => write!(f, "{e}"),
            SolverError::MotorConflict(e) => write!(f, "{e}"),
            SolverError::SubstepBudget { max_substeps, t_end_s } => write!(
                f,
                "more than {max_substeps} sub-steps or latch events inside the step ending at t = {t_end_s:.6} s \
                 (raise [solver] max_substeps, or use a smaller --dt)"
            ),
            SolverError::Backend(e) => write!(f, "{e}"),
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
                    StopWhy::Inexact => "a result was accepted inexact",
                }
            ),
        }
    }
}

impl fmt::Display for RequestError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RequestError::NoSuchCable { index, cables } => {
                write!(f, "no cable with index {index} (the model has {cables})")
            }
            RequestError::Tension { cable, tension_n, max_tension_n } => write!(
                f,
                "tension {tension_n} N for cable `{cable}` must be finite, >= 0 and <= {max_tension_n} N"
            ),
            RequestError::Speed { cable, speed_m_s } => {
                write!(f, "speed {speed_m_s} m/s for cable `{cable}` must be finite")
            }
            RequestError::SpeedOfMassiveCable { cable } => write!(
                f,
                "cable `{cable}` has a line density: speed control takes massless cables"
            ),
            RequestError::TimeStep { dt_s } => {
                write!(f, "time step {dt_s} s must be positive and finite")
            }
            RequestError::SnapshotOfAnotherModel { snapshot, model } => write!(
                f,
                "the snapshot is of model `{}` ({} coordinates, {} elements, {} cables), not of `{}` \
                 ({} coordinates, {} elements, {} cables); restore it into a simulator of its own model",
                snapshot.name, snapshot.coordinates, snapshot.elements, snapshot.cables,
                model.name, model.coordinates, model.elements, model.cables
            ),
            RequestError::SnapshotIndex { element, elements } => match element {
                Some(e) => write!(
                    f,
                    "the snapshot names element {e}, but the model has {elements}: it is damaged or of another model"
                ),
                None => write!(f, "the snapshot has a latch transient without its latch event: it is damaged"),
            },
            RequestError::SnapshotSize { field, len, expected } => write!(
                f,
                "the snapshot's `{field}` has {len} entries where the model takes {expected}: \
                 it is damaged or of another model"
            ),
        }
    }
}

impl fmt::Display for MotorConflict {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MotorConflict::Immobile { cable } => write!(
                f,
                "the structure cannot move along the cable `{cable}` of a speed-controlled motor \
                 (it is locked up or at a singular configuration)"
            ),
            MotorConflict::SameMotion { cable, others } => {
                let others: Vec<String> = others.iter().map(|o| format!("`{o}`")).collect();
                write!(
                    f,
                    "the speed-controlled cable `{cable}` drives the same motion as {}: the \
                     structure cannot follow two speeds along one motion (control one of \
                     them by its speed, the other by its tension)",
                    others.join(", ")
                )
            }
        }
    }
}

impl fmt::Display for BackendError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BackendError::TooLarge { entries } => write!(
                f,
                "constraint system too large for the sparse solver ({entries} entries; use --solver dense \
                 or a smaller model)"
            ),
            BackendError::Symbolic { detail } => {
                write!(f, "sparse symbolic factorization: {detail}")
            }
        }
    }
}

impl std::error::Error for SolverError {}
impl std::error::Error for RequestError {}
