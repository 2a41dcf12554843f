//! `Simulator` and `Snapshot`: the library's simulator, stepped with the GIL
//! released; runs as `truss-deploy simulate` makes them (`run::run_loop`,
//! `run::summarize`), interruptible from Python (Ctrl-C) between sub-steps.

use crate::model::PyModel;
use crate::{json_loads, model_error_msg, solver_error};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::exceptions::{PyKeyError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyBytes;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc};
use std::time::Duration;
use truss_deploy::record::{RecordError, Recorder as RunRecorder};
use truss_deploy::run::{self, RunLimits};
use truss_deploy::solver::checks::{self, RunChecks};
use truss_deploy::solver::state::Snapshot;
use truss_deploy::solver::{
    Options, RequestError, Simulator, SolverError as LibSolverError, SolverKind,
};

/// How often a run in progress looks for a signal (Ctrl-C) in Python.
const SIGNAL_POLL: Duration = Duration::from_millis(50);

/// What a history records: groups of columns (docs/python.md, History).
#[derive(Clone, Debug)]
struct Recording {
    groups: Vec<String>,
    columns: Vec<String>,
    /// Row-major, `columns.len()` values per recorded state.
    data: Vec<f64>,
}

const GROUPS: &[&str] = &[
    "positions",
    "velocities",
    "motors",
    "cables",
    "energy",
    "progress",
];
const DEFAULT_GROUPS: &[&str] = &["positions", "motors", "energy", "progress"];

/// The energy ledger's terms, by their JSON names (J).
fn energy_terms(e: &truss_deploy::solver::Energy) -> Vec<(String, f64)> {
    match serde_json::to_value(e).expect("energy serializes") {
        serde_json::Value::Object(m) => m
            .into_iter()
            .map(|(k, v)| (k, v.as_f64().unwrap_or(f64::NAN)))
            .collect(),
        _ => Vec::new(),
    }
}

impl Recording {
    fn new(sim: &Simulator, groups: Vec<String>) -> PyResult<Recording> {
        for g in &groups {
            if !GROUPS.contains(&g.as_str()) {
                return Err(PyValueError::new_err(format!(
                    "record: no group `{g}`; give some of {}",
                    GROUPS.join(", ")
                )));
            }
        }
        let (m, s) = (sim.model(), sim.state());
        let mut columns = vec!["t_s".to_string(), "step".to_string()];
        let has = |g: &str| groups.iter().any(|x| x == g);
        if has("positions") {
            for j in &m.joints {
                for c in ["x", "y", "z"] {
                    columns.push(format!("{}_{c}_m", j.name));
                }
            }
        }
        if has("velocities") {
            for j in &m.joints {
                for c in ["x", "y", "z"] {
                    columns.push(format!("{}_v{c}_m_s", j.name));
                }
            }
        }
        if has("motors") {
            for c in &m.cables {
                columns.push(format!("{}_tension_n", c.name));
                columns.push(format!("{}_reeled_in_m", c.name));
                columns.push(format!("{}_reel_in_rate_m_s", c.name));
            }
        }
        if has("cables") {
            for (ci, c) in m.cables.iter().enumerate() {
                for k in 0..s.cables[ci].segment_tension_n.len() {
                    columns.push(format!("{}_segment{k}_tension_n", c.name));
                }
            }
        }
        if has("energy") {
            columns.extend(energy_terms(&s.energy).into_iter().map(|(k, _)| k));
            columns.push("kinetic_energy_j".into());
            columns.push("energy_balance_rel_error".into());
        }
        if has("progress") {
            for k in [
                "deploy_fraction",
                "locks_engaged",
                "mechanisms",
                "max_constraint_violation_m",
            ] {
                columns.push(k.into());
            }
        }
        let mut r = Recording {
            groups,
            columns,
            data: Vec::new(),
        };
        r.push(sim);
        Ok(r)
    }

    fn push(&mut self, sim: &Simulator) {
        let (m, s) = (sim.model(), sim.state());
        let before = self.data.len();
        let d = &mut self.data;
        d.push(s.t_s);
        d.push(s.steps as f64);
        let has = |g: &str| self.groups.iter().any(|x| x == g);
        if has("positions") {
            d.extend_from_slice(&s.x);
        }
        if has("velocities") {
            d.extend_from_slice(&s.v);
        }
        if has("motors") {
            for ci in 0..m.cables.len() {
                d.push(s.motor_tension_n(ci));
                d.push(s.reeled_in_m(m, ci));
                d.push(s.reel_in_rate_m_s(m, ci));
            }
        }
        if has("cables") {
            for c in &s.cables {
                d.extend_from_slice(&c.segment_tension_n);
            }
        }
        if has("energy") {
            let ke = s.kinetic_energy_j(m);
            d.extend(energy_terms(&s.energy).into_iter().map(|(_, v)| v));
            d.push(ke);
            d.push(s.energy.balance_rel_error(ke));
        }
        if has("progress") {
            d.push(s.deploy_fraction(m));
            d.push(s.locks_engaged(m) as f64);
            d.push(s.mechanisms as f64);
            d.push(s.max_violation_m);
        }
        debug_assert_eq!(d.len() - before, self.columns.len());
    }
}

struct Recorder<'a>(&'a mut Option<Recording>);
impl RunRecorder for Recorder<'_> {
    fn after_step(&mut self, sim: &mut Simulator) -> Result<(), RecordError> {
        if let Some(r) = self.0.as_mut() {
            r.push(sim);
        }
        Ok(())
    }
}

/// What a pickled Simulator is made again from: its model, solver,
/// snapshot (JSON) and mechanisms at the start.
type SimulatorPickle = (PyModel, &'static str, Py<PyBytes>, usize);

/// A cable by name or index.
#[derive(FromPyObject)]
enum CableRef {
    Index(usize),
    Name(String),
}

/// The simulation of a model (truss-deploy's `Simulator`): the state, the
/// step, the cable commands, save and restore.
///
/// Arrays are copies of the state at the time of the call. Units: m, s, N,
/// J; positions and velocities are (n_joints, 3) in the model's joint order.
#[pyclass(module = "truss_deploy._native", name = "Simulator")]
pub struct PySim {
    /// (a Mutex makes the class Sync, as PyO3 asks; steps take `&mut self`
    /// and reach it without locking)
    sim: std::sync::Mutex<Simulator>,
    checks: RunChecks,
    model: PyModel,
    solver: SolverKind,
    dof_initial: usize,
    recording: Option<Recording>,
    last_summary: Option<String>,
}

fn solver_kind(name: &str) -> PyResult<SolverKind> {
    match name {
        "sparse" => Ok(SolverKind::Sparse),
        "dense" => Ok(SolverKind::Dense),
        other => Err(PyValueError::new_err(format!(
            "solver `{other}`: give \"sparse\" (the default) or \"dense\""
        ))),
    }
}

fn solver_name(k: SolverKind) -> &'static str {
    match k {
        SolverKind::Sparse => "sparse",
        SolverKind::Dense => "dense",
    }
}

/// A refused request as the exception a Python caller expects: a bad value
/// is a ValueError, an unknown cable a KeyError, the rest SolverError.
fn request_error(e: LibSolverError) -> PyErr {
    match &e {
        LibSolverError::Request(RequestError::NoSuchCable { .. }) => {
            PyKeyError::new_err(e.to_string())
        }
        LibSolverError::Request(
            RequestError::Tension { .. }
            | RequestError::Speed { .. }
            | RequestError::TimeStep { .. },
        ) => PyValueError::new_err(e.to_string()),
        _ => solver_error(&e),
    }
}

fn positive(name: &str, v: Option<f64>) -> PyResult<()> {
    match v {
        Some(x) if !(x.is_finite() && x > 0.0) => Err(PyValueError::new_err(format!(
            "{name} = {x} must be a positive number of seconds"
        ))),
        _ => Ok(()),
    }
}

fn n_by_3<'py>(py: Python<'py>, v: &[f64]) -> Bound<'py, PyArray2<f64>> {
    Array2::from_shape_vec((v.len() / 3, 3), v.to_vec())
        .expect("3 per joint")
        .into_pyarray(py)
}

impl PySim {
    fn build(py: Python<'_>, model: PyModel, solver: SolverKind) -> PyResult<PySim> {
        let loaded = model.loaded(py)?;
        let checks = loaded.checks;
        let source = model.source_name();
        let sim = py
            .detach(|| Simulator::new(loaded.model, Options { solver }))
            .map_err(|e| model_error_msg(py, &source, format!("{source}: {e}")))?;
        let dof_initial = sim.state().mechanisms;
        Ok(PySim {
            sim: std::sync::Mutex::new(sim),
            checks,
            model,
            solver,
            dof_initial,
            recording: None,
            last_summary: None,
        })
    }

    /// The simulator, for reading.
    fn sim(&self) -> std::sync::MutexGuard<'_, Simulator> {
        self.sim.lock().unwrap_or_else(|e| e.into_inner())
    }
    fn sim_mut(&mut self) -> &mut Simulator {
        self.sim.get_mut().unwrap_or_else(|e| e.into_inner())
    }

    fn cable(&self, c: &CableRef) -> PyResult<usize> {
        let sim = self.sim();
        let cables = &sim.model().cables;
        match c {
            CableRef::Index(i) if *i < cables.len() => Ok(*i),
            CableRef::Index(i) => Err(PyKeyError::new_err(format!(
                "cable index {i}: the model has {} cables",
                cables.len()
            ))),
            CableRef::Name(n) => cables.iter().position(|k| &k.name == n).ok_or_else(|| {
                PyKeyError::new_err(format!(
                    "the model has no cable `{n}` (its cables: {})",
                    cables
                        .iter()
                        .map(|k| k.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ))
            }),
        }
    }
}

#[pymethods]
impl PySim {
    /// The simulator of `model` at t = 0 (settled onto its constraints).
    /// `solver`: "sparse" (the default, as the CLI's) or "dense".
    /// `record`: True (positions, motors, energy, progress) or a list of
    /// those groups and "velocities", "cables": a history of every step
    /// (`history()`); None records nothing.
    #[new]
    #[pyo3(signature = (model, solver = "sparse", record = None))]
    fn new(
        py: Python<'_>,
        model: PyRef<'_, PyModel>,
        solver: &str,
        record: Option<Bound<'_, PyAny>>,
    ) -> PyResult<PySim> {
        let mut s = PySim::build(py, model.clone(), solver_kind(solver)?)?;
        if let Some(r) = record {
            s.record(r)?;
        }
        Ok(s)
    }

    /// Starts (or restarts) the history with the current state: True for
    /// the default groups (positions, motors, energy, progress), a list of
    /// groups, or False / None to stop recording.
    fn record(&mut self, what: Bound<'_, PyAny>) -> PyResult<()> {
        let groups: Option<Vec<String>> = if let Ok(b) = what.extract::<bool>() {
            b.then(|| DEFAULT_GROUPS.iter().map(|s| s.to_string()).collect())
        } else if what.is_none() {
            None
        } else {
            Some(what.extract().map_err(|_| {
                PyTypeError::new_err("record: give True, False, None or a list of group names")
            })?)
        };
        self.recording = match groups {
            Some(g) => Some(Recording::new(
                self.sim.get_mut().unwrap_or_else(|e| e.into_inner()),
                g,
            )?),
            None => None,
        };
        Ok(())
    }

    /// The recorded history as (column names, 2-D float64 array, one row
    /// per recorded state); `truss_deploy.Simulator.history()` makes it a
    /// pandas DataFrame.
    fn _history<'py>(&self, py: Python<'py>) -> PyResult<(Vec<String>, Bound<'py, PyArray2<f64>>)> {
        let r = self.recording.as_ref().ok_or_else(|| {
            PyValueError::new_err(
                "nothing recorded: make the simulator with record=True, or call record(True) before stepping",
            )
        })?;
        let w = r.columns.len();
        let a = Array2::from_shape_vec((r.data.len() / w, w), r.data.clone()).expect("rows");
        Ok((r.columns.clone(), a.into_pyarray(py)))
    }

    /// The recorded history as a pandas DataFrame, one row per recorded
    /// state (the state at `record()`, then every step): `t_s` (s), `step`,
    /// and the columns of the groups recorded (docs/python.md, History):
    /// positions `{joint}_x_m` ..., velocities `{joint}_vx_m_s` ..., motors
    /// `{cable}_tension_n`, `{cable}_reeled_in_m`, `{cable}_reel_in_rate_m_s`,
    /// cables `{cable}_segment{k}_tension_n`, energy (the ledger's terms in
    /// J, `kinetic_energy_j`, `energy_balance_rel_error`), progress
    /// (`deploy_fraction`, `locks_engaged`, `mechanisms`,
    /// `max_constraint_violation_m`).
    fn history<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let r = self.recording.as_ref().ok_or_else(|| {
            PyValueError::new_err(
                "nothing recorded: make the simulator with record=True, or call record(True) before stepping",
            )
        })?;
        let w = r.columns.len();
        let n = r.data.len() / w;
        let cols = pyo3::types::PyDict::new(py);
        for (k, name) in r.columns.iter().enumerate() {
            let v: Vec<f64> = (0..n).map(|i| r.data[i * w + k]).collect();
            if name == "step" || name == "locks_engaged" || name == "mechanisms" {
                let v: Vec<i64> = v.into_iter().map(|x| x as i64).collect();
                cols.set_item(name, PyArray1::from_vec(py, v))?;
            } else {
                cols.set_item(name, PyArray1::from_vec(py, v))?;
            }
        }
        py.import("pandas")?.call_method1("DataFrame", (cols,))
    }

    /// The model the simulator was made from.
    #[getter]
    fn model(&self) -> PyModel {
        self.model.clone()
    }
    /// The linear solver: "sparse" or "dense".
    #[getter]
    fn solver(&self) -> &'static str {
        solver_name(self.solver)
    }

    /// Advances the state by `dt` seconds (default: the model's dt_s),
    /// latching sleeves on the way; returns the number of latch events in
    /// the step. The GIL is released while it steps. A failed step raises
    /// SolverError (the state is the last accepted sub-step's).
    #[pyo3(signature = (dt = None))]
    fn step(&mut self, py: Python<'_>, dt: Option<f64>) -> PyResult<usize> {
        let sim = self.sim.get_mut().unwrap_or_else(|e| e.into_inner());
        let dt = dt.unwrap_or(sim.model().dt_s);
        let r = py.detach(|| sim.step(dt));
        if let Some(rec) = self.recording.as_mut() {
            rec.push(sim);
        }
        let n = r.map_err(request_error)?;
        py.check_signals()?;
        Ok(n)
    }

    /// Runs as `truss-deploy simulate` does: to full deployment, or to
    /// `until` (s, simulation time), at steps of `dt` (s; default the
    /// model's), stopping after `max_wall_s` seconds of wall time; the run
    /// checks (energy balance, stall) of the model's [checks]. Returns the
    /// summary, the dict `simulate --json` writes (stop_reason, deploy_time_s,
    /// locks, motors, solver_stats, ...). The GIL is released while it runs;
    /// Ctrl-C stops it between sub-steps and raises KeyboardInterrupt, the
    /// state, the history and `last_summary` (stop_reason "interrupted")
    /// kept. A model that cannot deploy raises ModelError unless `until` is
    /// given (as the CLI refuses it).
    #[pyo3(signature = (until = None, max_wall_s = None, dt = None))]
    fn run<'py>(
        &mut self,
        py: Python<'py>,
        until: Option<f64>,
        max_wall_s: Option<f64>,
        dt: Option<f64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        positive("dt", dt)?;
        positive("until", until)?;
        positive("max_wall_s", max_wall_s)?;
        let source = self.model.source_name();
        let sim = self.sim.get_mut().unwrap_or_else(|e| e.into_inner());
        let dt_s = dt.unwrap_or(sim.model().dt_s);
        let until_s = until.unwrap_or(sim.model().end_time_s);
        let dt_from = if dt.is_some() { "dt" } else { "dt_s" };
        run::check_step_count(dt_s, until_s, dt_from, &self.checks)
            .map_err(|m| PyValueError::new_err(format!("{source}: {m}")))?;
        let speed_controlled = sim.state().motors.iter().any(|m| m.speed_cmd_m_s.is_some());
        if !speed_controlled && until.is_none() {
            if let Some(why) = checks::cannot_deploy(sim.model(), sim.state()) {
                return Err(model_error_msg(
                    py,
                    &source,
                    format!(
                        "{source}: the model cannot deploy: {why}; fix the model (`truss-deploy analyze` \
                         shows its mechanisms), or give until= to run it for a time anyway"
                    ),
                ));
            }
        }
        let cancel = Arc::new(AtomicBool::new(false));
        let limits = RunLimits {
            dt_s,
            until_s,
            until_asked: until.is_some(),
            max_wall_s,
            cancel: Some(cancel.clone()),
        };
        let (checks, recording) = (&self.checks, &mut self.recording);
        let mut interrupt: Option<PyErr> = None;
        let stop = py.detach(|| {
            std::thread::scope(|scope| {
                let (tx, rx) = mpsc::channel::<()>();
                let worker = scope.spawn(move || {
                    let stop = run::run_loop(sim, checks, limits, &mut [&mut Recorder(recording)]);
                    let _ = tx.send(());
                    stop
                });
                // (this thread waits, and looks for a signal while it does:
                // Python runs its handlers only here, in the main thread)
                while let Err(mpsc::RecvTimeoutError::Timeout) = rx.recv_timeout(SIGNAL_POLL) {
                    if interrupt.is_none() {
                        if let Err(e) = Python::attach(|py| py.check_signals()) {
                            interrupt = Some(e);
                            cancel.store(true, Ordering::SeqCst);
                        }
                    }
                }
                worker
                    .join()
                    .unwrap_or_else(|p| std::panic::resume_unwind(p))
            })
        });
        let summary = run::summarize(
            self.sim.get_mut().unwrap_or_else(|e| e.into_inner()),
            &self.checks,
            solver_name(self.solver),
            dt_s,
            self.dof_initial,
            stop.wall_time_s,
            stop.reason,
            stop.message,
        );
        let text = serde_json::to_string(&summary).expect("summary serializes");
        self.last_summary = Some(text.clone());
        if let Some(e) = interrupt {
            return Err(e);
        }
        json_loads(py, &text)
    }

    /// The summary of the last `run()` (also an interrupted one), or None.
    #[getter]
    fn last_summary<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.last_summary
            .as_deref()
            .map(|t| json_loads(py, t))
            .transpose()
    }

    /// Sets a cable's motor tension (N, 0 to its max_tension_n) from the next
    /// step on; a speed-controlled motor returns to tension control.
    /// `cable`: its name or index.
    fn set_cable_tension(&mut self, cable: CableRef, tension_n: f64) -> PyResult<()> {
        let ci = self.cable(&cable)?;
        self.sim_mut()
            .set_cable_tension(ci, tension_n)
            .map_err(request_error)
    }

    /// Drives a cable's motor at a reel-in speed (m/s; negative pays out),
    /// up to its max_tension_n, from the next step on; None returns it to
    /// its tension command. A command the motors cannot take with the
    /// others (two motors moving one motion) raises SolverError and changes
    /// nothing.
    fn set_cable_speed(&mut self, cable: CableRef, speed_m_s: Option<f64>) -> PyResult<()> {
        let ci = self.cable(&cable)?;
        self.sim_mut()
            .set_cable_speed(ci, speed_m_s)
            .map_err(request_error)
    }

    /// The complete state (a Snapshot): restored, the run goes on as the one
    /// that never stopped, to the bit.
    fn save(&self) -> PySnapshot {
        PySnapshot(self.sim().save())
    }

    /// Continues from a snapshot of a simulator of the same model.
    fn restore(&mut self, snapshot: &PySnapshot) -> PyResult<()> {
        self.sim_mut().restore(&snapshot.0).map_err(request_error)
    }

    /// Back to the state at t = 0 (the model's cable tensions); the history
    /// restarts.
    fn reset(&mut self, py: Python<'_>) -> PyResult<()> {
        let sim = self.sim.get_mut().unwrap_or_else(|e| e.into_inner());
        py.detach(|| sim.reset()).map_err(|e| solver_error(&e))?;
        self.dof_initial = sim.state().mechanisms;
        if let Some(r) = self.recording.take() {
            self.recording = Some(Recording::new(sim, r.groups)?);
        }
        Ok(())
    }

    fn __reduce__(&self, py: Python<'_>) -> PyResult<(Py<PyAny>, SimulatorPickle)> {
        let f = py
            .import("truss_deploy._native")?
            .getattr("_simulator_from_pickle")?
            .unbind();
        let snap = PySnapshot(self.sim().save()).to_json(py)?;
        Ok((
            f,
            (
                self.model.clone(),
                solver_name(self.solver),
                snap.unbind(),
                self.dof_initial,
            ),
        ))
    }

    fn __repr__(&self) -> String {
        let g = self.sim();
        let s = g.state();
        format!(
            "<truss_deploy.Simulator `{}` at t = {} s, {} steps, {}>",
            g.model().name,
            s.t_s,
            s.steps,
            if s.deployed {
                "deployed"
            } else {
                "not deployed"
            }
        )
    }

    /// Simulation time (s).
    #[getter]
    fn t_s(&self) -> f64 {
        self.sim().state().t_s
    }
    /// Steps taken.
    #[getter]
    fn steps(&self) -> u64 {
        self.sim().state().steps
    }
    /// Every sleeve latched (or the truss rigid).
    #[getter]
    fn deployed(&self) -> bool {
        self.sim().state().deployed
    }
    /// When it deployed (s), or None.
    #[getter]
    fn deploy_time_s(&self) -> Option<f64> {
        self.sim().state().deploy_time_s
    }
    /// Deployment progress in [0, 1] (1 - RMS distance to the reference
    /// over its initial value; without a reference, the latched fraction).
    #[getter]
    fn deploy_fraction(&self) -> f64 {
        {
            let g = self.sim();
            g.state().deploy_fraction(g.model())
        }
    }
    /// Mechanisms (3n - rank A) of the current constraint set.
    #[getter]
    fn mechanisms(&self) -> usize {
        self.sim().state().mechanisms
    }
    /// Mechanisms at the start (the summary's dof_initial).
    #[getter]
    fn dof_initial(&self) -> usize {
        self.dof_initial
    }
    /// Joint names, in the order of the arrays' rows.
    #[getter]
    fn joint_names(&self) -> Vec<String> {
        self.sim()
            .model()
            .joints
            .iter()
            .map(|j| j.name.clone())
            .collect()
    }
    /// Cable names, in the order of the per-cable arrays.
    #[getter]
    fn cable_names(&self) -> Vec<String> {
        self.sim()
            .model()
            .cables
            .iter()
            .map(|c| c.name.clone())
            .collect()
    }
    /// The lockable elements (sleeves), in the order of `locked`.
    #[getter]
    fn lock_names(&self) -> Vec<String> {
        let g = self.sim();
        let m = g.model();
        m.locks
            .iter()
            .map(|&e| m.elements[e].name().to_string())
            .collect()
    }
    /// Joint positions, shape (n_joints, 3), m.
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        n_by_3(py, &self.sim().state().x)
    }
    /// Joint velocities, shape (n_joints, 3), m/s.
    #[getter]
    fn velocities<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        n_by_3(py, &self.sim().state().v)
    }
    /// Joint accelerations, shape (n_joints, 3), m/s^2.
    #[getter]
    fn accelerations<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        n_by_3(py, &self.sim().state().a)
    }
    /// Lock states, shape (n_locks,), bool: True where the sleeve latched
    /// (order of `lock_names`).
    #[getter]
    fn locked<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<bool>> {
        let g = self.sim();
        let (m, s) = (g.model(), g.state());
        let v: Vec<bool> = m.locks.iter().map(|&e| s.locked[e]).collect();
        PyArray1::from_vec(py, v)
    }
    /// Per cable, the tension of each segment from the motor end (N), an
    /// array of shape (n_segments,) each; element 0 is the motor's tension.
    #[getter]
    fn cable_tensions<'py>(&self, py: Python<'py>) -> Vec<Bound<'py, PyArray1<f64>>> {
        self.sim()
            .state()
            .cables
            .iter()
            .map(|c| PyArray1::from_slice(py, &c.segment_tension_n))
            .collect()
    }
    /// Motor tension per cable, shape (n_cables,), N.
    #[getter]
    fn motor_tensions<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        let g = self.sim();
        let s = g.state();
        let v: Vec<f64> = (0..s.cables.len())
            .map(|ci| s.motor_tension_n(ci))
            .collect();
        PyArray1::from_vec(py, v)
    }
    /// Cable reeled in by each motor since the start, shape (n_cables,), m
    /// (negative where it paid out).
    #[getter]
    fn reeled_in_m<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        let g = self.sim();
        let (m, s) = (g.model(), g.state());
        let v: Vec<f64> = (0..m.cables.len()).map(|ci| s.reeled_in_m(m, ci)).collect();
        PyArray1::from_vec(py, v)
    }
    /// Reel-in rate of each cable (-dL/dt), shape (n_cables,), m/s.
    #[getter]
    fn reel_in_rate_m_s<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        let g = self.sim();
        let (m, s) = (g.model(), g.state());
        let v: Vec<f64> = (0..m.cables.len())
            .map(|ci| s.reel_in_rate_m_s(m, ci))
            .collect();
        PyArray1::from_vec(py, v)
    }
    /// Motor modes per cable: "tension" (commanded tension), "tracking" (at
    /// its commanded speed), "at_limit" (speed-commanded, at its tension
    /// limit), "slack".
    #[getter]
    fn motor_modes(&self) -> Vec<String> {
        self.sim()
            .state()
            .motors
            .iter()
            .map(|m| {
                serde_json::to_value(m.hold)
                    .ok()
                    .and_then(|v| v.as_str().map(String::from))
                    .unwrap_or_default()
            })
            .collect()
    }
    /// Speed command per cable (m/s), None under tension control.
    #[getter]
    fn motor_speed_commands(&self) -> Vec<Option<f64>> {
        self.sim()
            .state()
            .motors
            .iter()
            .map(|m| m.speed_cmd_m_s)
            .collect()
    }
    /// Tension command per cable (N).
    #[getter]
    fn tension_commands<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.sim().state().cable_tension_cmd_n)
    }
    /// Kinetic energy (J).
    #[getter]
    fn kinetic_energy_j(&self) -> f64 {
        {
            let g = self.sim();
            g.state().kinetic_energy_j(g.model())
        }
    }
    /// The energy ledger (J): motor_work_j, friction_loss_j, lock_loss_j, ...
    #[getter]
    fn energy<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_loads(
            py,
            &serde_json::to_string(&self.sim().state().energy).expect("serializes"),
        )
    }
    /// Largest |Phi| after any step so far (m).
    #[getter]
    fn max_constraint_violation_m(&self) -> f64 {
        self.sim().state().max_violation_m
    }
    /// Latch events so far (dicts as the summary's `locks`).
    #[getter]
    fn locks<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_loads(
            py,
            &serde_json::to_string(&self.sim().state().locks).expect("serializes"),
        )
    }
    /// What the solver did so far (the summary's `solver_stats`).
    #[getter]
    fn solver_stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_loads(
            py,
            &serde_json::to_string(self.sim().solver_stats()).expect("serializes"),
        )
    }
    /// The state's member forces (N, in the constraint Jacobian's row order)
    /// shared among redundant rows by least work; computed on a backend of
    /// its own, it does not change the trajectory.
    fn least_work_multipliers<'py>(
        &mut self,
        py: Python<'py>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let sim = self.sim.get_mut().unwrap_or_else(|e| e.into_inner());
        let v = py
            .detach(|| sim.least_work_multipliers())
            .map_err(|e| solver_error(&e))?;
        Ok(PyArray1::from_vec(py, v))
    }
}

/// A simulation's complete state (`Simulator.save()`): the state, the
/// solver's counters and its kept factorizations. Picklable (its JSON); it
/// restores into a simulator of the same model in any process.
#[pyclass(module = "truss_deploy._native", name = "Snapshot")]
#[derive(Clone)]
pub struct PySnapshot(Snapshot);

#[pymethods]
impl PySnapshot {
    /// The snapshot as JSON (bytes); `Snapshot.from_json` reads it back exactly.
    fn to_json<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyBytes>> {
        let text = serde_json::to_vec(&self.0)
            .map_err(|e| crate::SolverError::new_err(format!("cannot write the snapshot: {e}")))?;
        Ok(PyBytes::new(py, &text))
    }
    /// Reads a snapshot's JSON (bytes or str).
    #[staticmethod]
    fn from_json(data: Bound<'_, PyAny>) -> PyResult<PySnapshot> {
        let bytes: Vec<u8> = if let Ok(s) = data.extract::<String>() {
            s.into_bytes()
        } else {
            data.extract()?
        };
        serde_json::from_slice(&bytes)
            .map(PySnapshot)
            .map_err(|e| PyValueError::new_err(format!("not a snapshot's JSON: {e}")))
    }
    /// Simulation time of the snapshot (s).
    #[getter]
    fn t_s(&self) -> f64 {
        self.0.state.t_s
    }
    #[getter]
    fn steps(&self) -> u64 {
        self.0.state.steps
    }
    /// The name of the model it belongs to.
    #[getter]
    fn model_name(&self) -> String {
        self.0.model.name.clone()
    }
    fn __eq__(&self, other: &PySnapshot) -> bool {
        self.0 == other.0
    }
    fn __reduce__(&self, py: Python<'_>) -> PyResult<(Py<PyAny>, (Py<PyBytes>,))> {
        let f = py
            .import("truss_deploy._native")?
            .getattr("_snapshot_from_pickle")?
            .unbind();
        Ok((f, (self.to_json(py)?.unbind(),)))
    }
    fn __repr__(&self) -> String {
        format!(
            "<truss_deploy.Snapshot of `{}` at t = {} s, {} steps>",
            self.0.model.name, self.0.state.t_s, self.0.state.steps
        )
    }
}

#[pyfunction]
fn _snapshot_from_pickle(data: Bound<'_, PyAny>) -> PyResult<PySnapshot> {
    PySnapshot::from_json(data)
}

#[pyfunction]
fn _simulator_from_pickle(
    py: Python<'_>,
    model: PyRef<'_, PyModel>,
    solver: &str,
    snapshot: Bound<'_, PyAny>,
    dof_initial: usize,
) -> PyResult<PySim> {
    let mut s = PySim::build(py, model.clone(), solver_kind(solver)?)?;
    let snap = PySnapshot::from_json(snapshot)?;
    s.sim_mut().restore(&snap.0).map_err(|e| solver_error(&e))?;
    s.dof_initial = dof_initial;
    Ok(s)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PySim>()?;
    m.add_class::<PySnapshot>()?;
    m.add_function(wrap_pyfunction!(_snapshot_from_pickle, m)?)?;
    m.add_function(wrap_pyfunction!(_simulator_from_pickle, m)?)?;
    Ok(())
}
