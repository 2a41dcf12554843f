//! Recorders: what a run writes while it steps (CSV, Parquet histories,
//! ParaView series, MCAP, plots, a progress bar), each behind one trait,
//! [`Recorder`], whose hooks the run loop (`run::run_loop`) calls.
//!
//! [`Frame`] is one recorded instant of a run (positions, velocities, member
//! forces and lengths, cable segment tensions, latches, motors, the energy
//! ledger), laid out by a [`FrameLayout`] built once from the model; the
//! recorders that write tables or geometry capture frames.

pub mod bodies;
pub mod csv;
pub mod frame;
pub mod report;
pub mod vtk;

pub use frame::{Frame, FrameLayout, LatchState, MemberKind};

use crate::run::Stop;
use crate::solver::Simulator;
use std::fmt;
use std::path::{Path, PathBuf};

/// A recorder that could not write its output: which output (the option
/// that asked for it, e.g. `--csv`), the path, and why.
#[derive(Debug)]
pub struct RecordError {
    /// The option or key that asked for the output (`--csv`, `--history`).
    pub output: &'static str,
    pub path: PathBuf,
    pub source: RecordFault,
}

/// Why an output could not be written.
#[derive(Debug)]
pub enum RecordFault {
    /// The file system refused (a missing or unwritable directory, a full disk).
    Io(std::io::Error),
    /// Anything else, said in words (an encoder's error, an MCAP writer's).
    Other(String),
}

impl RecordError {
    pub fn io(output: &'static str, path: &Path, e: std::io::Error) -> RecordError {
        RecordError {
            output,
            path: path.to_path_buf(),
            source: RecordFault::Io(e),
        }
    }
    pub fn other(output: &'static str, path: &Path, what: impl Into<String>) -> RecordError {
        RecordError {
            output,
            path: path.to_path_buf(),
            source: RecordFault::Other(what.into()),
        }
    }
}

impl fmt::Display for RecordError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "cannot write {} {}: ", self.output, self.path.display())?;
        match &self.source {
            RecordFault::Io(e) => write!(f, "{e}"),
            RecordFault::Other(s) => write!(f, "{s}"),
        }
    }
}

impl std::error::Error for RecordError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match &self.source {
            RecordFault::Io(e) => Some(e),
            RecordFault::Other(_) => None,
        }
    }
}

/// Hooks of an output into the run loop (`run::run_loop`). `start` runs
/// once before the first step (the initial state), `after_step` after each
/// step before the run checks, `after_checks` after they passed, `finish`
/// once when the loop stopped, whatever stopped it (commit the file). An
/// `Err` from the first three stops the run with `StopReason::Error`; one
/// from `finish` turns a run that did what was asked into an error.
pub trait Recorder {
    fn start(&mut self, _sim: &mut Simulator) -> Result<(), RecordError> {
        Ok(())
    }
    fn after_step(&mut self, _sim: &mut Simulator) -> Result<(), RecordError> {
        Ok(())
    }
    fn after_checks(&mut self, _sim: &mut Simulator) -> Result<(), RecordError> {
        Ok(())
    }
    fn finish(&mut self, _sim: &mut Simulator, _stop: &Stop) -> Result<(), RecordError> {
        Ok(())
    }
}

/// A recorder that records nothing (a sweep sample without history).
pub struct NoRecorder;
impl Recorder for NoRecorder {}

/// Which steps a thinned recorder keeps: the first state (step 0), every
/// `every`-th step, and the last step of the run (in `finish`, when it was
/// not kept already).
#[derive(Clone, Copy, Debug)]
pub struct Thinning {
    pub every: u64,
}

impl Thinning {
    /// Whether step `steps` (the state after that many steps) is kept.
    pub fn keeps(&self, steps: u64) -> bool {
        // (a remainder, not `is_multiple_of`: older toolchains build this too)
        #[allow(clippy::manual_is_multiple_of)]
        let kept = steps % self.every.max(1) == 0;
        kept
    }
}
