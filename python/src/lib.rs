//! `truss_deploy._native`: the Python package's bindings (docs/python.md),
//! a thin layer over the `truss_deploy` library. Models are model documents
//! (`model::ModelDoc`) edited by name and built by the library's loader;
//! simulations are the library's `Simulator`, stepped with the GIL released;
//! runs are `run::run_loop` and `run::summarize`, as `simulate` makes them;
//! sweep samples are `sweep::run_sample` with the CLI's generator. Nothing
//! here computes physics.

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;

mod model;
mod sim;
mod sweep;

create_exception!(
    truss_deploy,
    TrussDeployError,
    PyException,
    "Base class of every error truss_deploy raises for a model, a simulation or a sweep."
);
create_exception!(
    truss_deploy,
    ModelError,
    TrussDeployError,
    "A model file or text that does not load, or a model the simulator refuses. \
     The message is the CLI's: it names the file, the line and the key, and the fix. \
     Attributes: `file` (str) and `line` (int or None)."
);
create_exception!(
    truss_deploy,
    SolverError,
    TrussDeployError,
    "A step that failed or a command the simulator refused (the CLI's message)."
);
create_exception!(
    truss_deploy,
    SweepError,
    TrussDeployError,
    "A sweep file or description that does not parse (names the file, the line and the key)."
);

/// A ModelError with its `file` and `line` attributes.
pub(crate) fn model_error(py: Python<'_>, e: &truss_deploy::model::ModelFileError) -> PyErr {
    let err = ModelError::new_err(e.to_string());
    let v = err.value(py);
    let _ = v.setattr("file", e.file.clone());
    let _ = v.setattr("line", e.line);
    err
}

/// A ModelError from a message that names its file first (`FILE: ...`).
pub(crate) fn model_error_msg(py: Python<'_>, file: &str, message: String) -> PyErr {
    let err = ModelError::new_err(message);
    let v = err.value(py);
    let _ = v.setattr("file", file.to_string());
    let _ = v.setattr("line", None::<usize>);
    err
}

pub(crate) fn solver_error(e: &truss_deploy::solver::SolverError) -> PyErr {
    SolverError::new_err(e.to_string())
}

/// Parses JSON text into Python objects (json.loads).
pub(crate) fn json_loads<'py>(py: Python<'py>, text: &str) -> PyResult<Bound<'py, PyAny>> {
    py.import("json")?.call_method1("loads", (text,))
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("TrussDeployError", py.get_type::<TrussDeployError>())?;
    m.add("ModelError", py.get_type::<ModelError>())?;
    m.add("SolverError", py.get_type::<SolverError>())?;
    m.add("SweepError", py.get_type::<SweepError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    model::register(m)?;
    sim::register(m)?;
    sweep::register(m)?;
    Ok(())
}
