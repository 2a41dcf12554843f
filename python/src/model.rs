//! `Model`: a model file as a document (`ModelDoc`), read and changed through
//! named accessors, checked by the library's loader after every change.

use crate::{json_loads, model_error, model_error_msg};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray2};
use pyo3::exceptions::{PyKeyError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use truss_deploy::model::{self, LoadedModel, ModelDoc};
use truss_deploy::solver::elements::{Param, AXIAL_STIFFNESS_KEY, REGISTRY};
use truss_deploy::sweep::spec::glob;

/// A truss model: joints with masses, elements, drive cables, settings.
///
/// Made by `Model.load(path)`, `Model.parse(text)` or `truss_deploy.generate`;
/// written by `to_toml()` / `save(path)`. Parameters are read and changed by
/// name (`set_joint_mass("L0", 0.2)`; a name may be a pattern with `*`), and
/// every change is checked by the same loader as `truss-deploy simulate`
/// (a change the loader refuses raises ModelError and changes nothing).
#[pyclass(module = "truss_deploy._native", name = "Model")]
#[derive(Clone)]
pub struct PyModel {
    pub doc: ModelDoc,
    /// What errors name: the file, or `<string>`, `generate ring`.
    pub source: String,
    /// The text the model builds from: the file's until a change, then the
    /// document's (`to_toml`).
    pub text: String,
    pub edited: bool,
}

impl PyModel {
    pub fn from_text(py: Python<'_>, text: &str, source: &str) -> PyResult<PyModel> {
        let doc = ModelDoc::from_toml(text, source).map_err(|e| model_error(py, &e))?;
        Ok(PyModel {
            doc,
            source: source.to_string(),
            text: text.to_string(),
            edited: false,
        })
    }

    /// The loader's model of the current text (the simulator takes it).
    pub fn loaded(&self, py: Python<'_>) -> PyResult<LoadedModel> {
        model::parse(&self.text, &self.source_name()).map_err(|e| model_error(py, &e))
    }

    pub fn source_name(&self) -> String {
        if self.edited {
            format!("{} (edited)", self.source)
        } else {
            self.source.clone()
        }
    }

    /// Applies `f` to a copy of the document; keeps it if the loader takes
    /// the result (else ModelError, nothing changed). Returns what f returns.
    fn edit<T>(
        &mut self,
        py: Python<'_>,
        f: impl FnOnce(&mut ModelDoc) -> PyResult<T>,
    ) -> PyResult<T> {
        let mut doc = self.doc.clone();
        let out = f(&mut doc)?;
        let text = doc.to_toml();
        let name = format!("{} (edited)", self.source);
        model::parse(&text, &name).map_err(|e| model_error(py, &e))?;
        self.doc = doc;
        self.text = text;
        self.edited = true;
        Ok(out)
    }

    fn element_kind_params(kind: &str) -> &'static [&'static str] {
        REGISTRY.iter().find(|r| r.0 == kind).map_or(&[], |r| r.2)
    }
}

fn no_such(what: &str, name: &str, names: Vec<&str>) -> PyErr {
    let shown: Vec<&str> = names.iter().take(12).copied().collect();
    PyKeyError::new_err(format!(
        "the model has no {what} `{name}` (its {what}s: {}{})",
        shown.join(", "),
        if names.len() > 12 { ", ..." } else { "" }
    ))
}

fn finite(name: &str, v: f64, min: f64, inclusive: bool, unit: &str) -> PyResult<f64> {
    let ok = v.is_finite() && if inclusive { v >= min } else { v > min };
    if ok {
        Ok(v)
    } else {
        Err(PyValueError::new_err(format!(
            "{name} = {v}: give a finite number {} {min} ({unit})",
            if inclusive { ">=" } else { ">" }
        )))
    }
}

fn param_num(params: &[(String, Param)], key: &str) -> Option<f64> {
    params
        .iter()
        .find(|(k, _)| k == key)
        .and_then(|(_, p)| match p {
            Param::Num(v) => Some(*v),
            Param::Text(_) => None,
        })
}

fn set_param(params: &mut Vec<(String, Param)>, key: &str, v: Option<Param>) {
    let at = params.iter().position(|(k, _)| k == key);
    match (at, v) {
        (Some(i), Some(v)) => params[i].1 = v,
        (None, Some(v)) => params.push((key.to_string(), v)),
        (Some(i), None) => {
            params.remove(i);
        }
        (None, None) => {}
    }
}

/// Which of `names` match `pattern` (`*`: any run of characters); KeyError
/// when none does.
fn matching(what: &str, pattern: &str, names: Vec<&str>) -> PyResult<Vec<usize>> {
    let hits: Vec<usize> = (0..names.len())
        .filter(|&i| glob(pattern, names[i]))
        .collect();
    if hits.is_empty() {
        return Err(no_such(what, pattern, names));
    }
    Ok(hits)
}

#[pymethods]
impl PyModel {
    /// Reads and checks a model file (ModelError naming the file, the line
    /// and the key, as `truss-deploy simulate` does).
    #[staticmethod]
    fn load(py: Python<'_>, path: std::path::PathBuf) -> PyResult<PyModel> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(&path).map_err(|e| {
            model_error(
                py,
                &model::ModelFileError {
                    file: file.clone(),
                    line: None,
                    message: format!("cannot read the model file ({e}); check the path, or write one with `truss-deploy generate`"),
                },
            )
        })?;
        PyModel::from_text(py, &text, &file)
    }

    /// Parses and checks model text; `name` stands for the file in errors.
    #[staticmethod]
    #[pyo3(signature = (text, name = "<string>"))]
    fn parse(py: Python<'_>, text: &str, name: &str) -> PyResult<PyModel> {
        PyModel::from_text(py, text, name)
    }

    /// The model file's text (TOML), as `truss-deploy generate` writes it.
    fn to_toml(&self) -> String {
        self.doc.to_toml()
    }

    /// Writes the model file (`to_toml()`) to `path`.
    fn save(&self, path: std::path::PathBuf) -> PyResult<()> {
        truss_deploy::files::write_atomic(&path, self.doc.to_toml().as_bytes())
            .map_err(pyo3::exceptions::PyOSError::new_err)
    }

    /// A copy to change without changing this one.
    fn copy(&self) -> PyModel {
        self.clone()
    }

    fn __copy__(&self) -> PyModel {
        self.clone()
    }

    fn __deepcopy__(&self, _memo: &Bound<'_, PyAny>) -> PyModel {
        self.clone()
    }

    fn __reduce__(&self, py: Python<'_>) -> PyResult<(Py<PyAny>, (String, String, bool))> {
        let f = py
            .import("truss_deploy._native")?
            .getattr("_model_from_pickle")?
            .unbind();
        Ok((f, (self.text.clone(), self.source.clone(), self.edited)))
    }

    fn __repr__(&self) -> String {
        format!(
            "<truss_deploy.Model `{}` from {}: {} joints, {} elements, {} cables>",
            self.doc.name,
            self.source_name(),
            self.doc.joints.len(),
            self.doc.elements.len(),
            self.doc.cables.len()
        )
    }

    /// Where the model came from: its file, `<string>`, or `generate KIND`.
    #[getter]
    fn source(&self) -> String {
        self.source_name()
    }
    #[getter]
    fn name(&self) -> String {
        self.doc.name.clone()
    }
    #[getter]
    fn description(&self) -> String {
        self.doc.description.clone()
    }
    #[getter]
    fn notes(&self) -> Vec<String> {
        self.doc.notes.clone()
    }
    #[getter]
    fn joint_names(&self) -> Vec<String> {
        self.doc.joints.iter().map(|j| j.name.clone()).collect()
    }
    #[getter]
    fn element_names(&self) -> Vec<String> {
        self.doc.elements.iter().map(|e| e.name.clone()).collect()
    }
    #[getter]
    fn cable_names(&self) -> Vec<String> {
        self.doc.cables.iter().map(|c| c.name.clone()).collect()
    }
    /// The sleeves (lockable elements), in the order the simulator's lock
    /// states (`Simulator.locked`) list them.
    #[getter]
    fn sleeve_names(&self) -> Vec<String> {
        self.doc
            .elements
            .iter()
            .filter(|e| e.kind == "sleeve")
            .map(|e| e.name.clone())
            .collect()
    }
    /// An element's type (`bar`, `sleeve`, `scissor`, ...).
    fn element_type(&self, name: &str) -> PyResult<String> {
        self.doc
            .elements
            .iter()
            .find(|e| e.name == name)
            .map(|e| e.kind.clone())
            .ok_or_else(|| {
                no_such(
                    "element",
                    name,
                    self.doc.elements.iter().map(|e| e.name.as_str()).collect(),
                )
            })
    }

    /// Initial joint positions, shape (n_joints, 3), m.
    fn positions<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let v: Vec<f64> = self.doc.joints.iter().flat_map(|j| j.position_m).collect();
        Array2::from_shape_vec((self.doc.joints.len(), 3), v)
            .expect("n x 3")
            .into_pyarray(py)
    }
    /// Reference (deployed) joint positions, shape (n_joints, 3), m; None
    /// when the model has none.
    fn reference_positions<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f64>>> {
        let v: Option<Vec<f64>> = self
            .doc
            .joints
            .iter()
            .map(|j| j.reference_m)
            .collect::<Option<Vec<_>>>()
            .map(|r| r.into_iter().flatten().collect());
        v.map(|v| {
            Array2::from_shape_vec((self.doc.joints.len(), 3), v)
                .expect("n x 3")
                .into_pyarray(py)
        })
    }

    /// Time step (s; `[settings] dt_s`).
    #[getter]
    fn dt_s(&self) -> f64 {
        self.doc.dt_s
    }
    #[setter]
    fn set_dt_s(&mut self, py: Python<'_>, v: f64) -> PyResult<()> {
        let v = finite("dt_s", v, 0.0, false, "s")?;
        self.edit(py, |d| {
            d.dt_s = v;
            Ok(())
        })
    }
    /// End time of a run that does not deploy (s; `[settings] end_time_s`).
    #[getter]
    fn end_time_s(&self) -> f64 {
        self.doc.end_time_s
    }
    #[setter]
    fn set_end_time_s(&mut self, py: Python<'_>, v: f64) -> PyResult<()> {
        let v = finite("end_time_s", v, 0.0, false, "s")?;
        self.edit(py, |d| {
            d.end_time_s = v;
            Ok(())
        })
    }
    /// Viscous damping on each joint's velocity (N s/m).
    #[getter]
    fn damping_n_s_per_m(&self) -> f64 {
        self.doc.damping_n_s_per_m
    }
    #[setter]
    fn set_damping_n_s_per_m(&mut self, py: Python<'_>, v: f64) -> PyResult<()> {
        let v = finite("damping_n_s_per_m", v, 0.0, true, "N s/m")?;
        self.edit(py, |d| {
            d.damping_n_s_per_m = v;
            Ok(())
        })
    }
    /// Gravity (m/s^2), 3 numbers.
    #[getter]
    fn gravity_m_s2(&self) -> (f64, f64, f64) {
        let g = self.doc.gravity_m_s2;
        (g[0], g[1], g[2])
    }
    #[setter]
    fn set_gravity_m_s2(&mut self, py: Python<'_>, g: (f64, f64, f64)) -> PyResult<()> {
        for v in [g.0, g.1, g.2] {
            if !v.is_finite() {
                return Err(PyValueError::new_err(format!(
                    "gravity_m_s2 = {g:?}: give 3 finite numbers (m/s^2)"
                )));
            }
        }
        self.edit(py, |d| {
            d.gravity_m_s2 = [g.0, g.1, g.2];
            Ok(())
        })
    }
    /// Members elastic along their axis in the step (`[solver] elastic_members`).
    #[getter]
    fn elastic_members(&self) -> bool {
        self.doc.elastic_members
    }
    #[setter]
    fn set_elastic_members(&mut self, py: Python<'_>, v: bool) -> PyResult<()> {
        self.edit(py, |d| {
            d.elastic_members = v;
            Ok(())
        })
    }

    /// A joint's lumped mass (kg).
    fn joint_mass(&self, name: &str) -> PyResult<f64> {
        self.doc
            .joints
            .iter()
            .find(|j| j.name == name)
            .map(|j| j.mass_kg)
            .ok_or_else(|| {
                no_such(
                    "joint",
                    name,
                    self.doc.joints.iter().map(|j| j.name.as_str()).collect(),
                )
            })
    }
    /// Sets the lumped mass (kg, > 0) of the joints matching `name` (`*`
    /// any run of characters); returns how many.
    fn set_joint_mass(&mut self, py: Python<'_>, name: &str, mass_kg: f64) -> PyResult<usize> {
        let m = finite("mass_kg", mass_kg, 0.0, false, "kg")?;
        let hits = matching(
            "joint",
            name,
            self.doc.joints.iter().map(|j| j.name.as_str()).collect(),
        )?;
        self.edit(py, |d| {
            for &i in &hits {
                d.joints[i].mass_kg = m;
            }
            Ok(hits.len())
        })
    }

    fn cable_index(&self, name: &str) -> PyResult<usize> {
        self.doc
            .cables
            .iter()
            .position(|c| c.name == name)
            .ok_or_else(|| {
                no_such(
                    "cable",
                    name,
                    self.doc.cables.iter().map(|c| c.name.as_str()).collect(),
                )
            })
    }
    /// A cable's motor tension at the start (N).
    fn cable_tension(&self, name: &str) -> PyResult<f64> {
        Ok(self.doc.cables[self.cable_index(name)?].tension_n)
    }
    /// Sets the motor tension (N, >= 0, at most the cable's max_tension_n)
    /// of the cables matching `name`; returns how many.
    fn set_cable_tension(&mut self, py: Python<'_>, name: &str, tension_n: f64) -> PyResult<usize> {
        let t = finite("tension_n", tension_n, 0.0, true, "N")?;
        let hits = matching(
            "cable",
            name,
            self.doc.cables.iter().map(|c| c.name.as_str()).collect(),
        )?;
        self.edit(py, |d| {
            for &i in &hits {
                d.cables[i].tension_n = t;
            }
            Ok(hits.len())
        })
    }
    /// A cable's motor tension limit (N).
    fn cable_max_tension(&self, name: &str) -> PyResult<f64> {
        Ok(self.doc.cables[self.cable_index(name)?].max_tension_n)
    }
    /// Sets the motor tension limit (N, >= 0) of the cables matching `name`.
    fn set_cable_max_tension(
        &mut self,
        py: Python<'_>,
        name: &str,
        max_tension_n: f64,
    ) -> PyResult<usize> {
        let t = finite("max_tension_n", max_tension_n, 0.0, true, "N")?;
        let hits = matching(
            "cable",
            name,
            self.doc.cables.iter().map(|c| c.name.as_str()).collect(),
        )?;
        self.edit(py, |d| {
            for &i in &hits {
                d.cables[i].max_tension_n = t;
            }
            Ok(hits.len())
        })
    }
    /// A cable's pulley friction coefficient mu.
    fn cable_mu(&self, name: &str) -> PyResult<f64> {
        Ok(self.doc.cables[self.cable_index(name)?].friction_mu)
    }
    /// Sets the pulley friction coefficient (>= 0) of the cables matching `name`.
    fn set_cable_mu(&mut self, py: Python<'_>, name: &str, mu: f64) -> PyResult<usize> {
        let mu = finite("friction_mu", mu, 0.0, true, "a ratio")?;
        let hits = matching(
            "cable",
            name,
            self.doc.cables.iter().map(|c| c.name.as_str()).collect(),
        )?;
        self.edit(py, |d| {
            for &i in &hits {
                d.cables[i].friction_mu = mu;
            }
            Ok(hits.len())
        })
    }

    fn element_index(&self, name: &str) -> PyResult<usize> {
        self.doc
            .elements
            .iter()
            .position(|e| e.name == name)
            .ok_or_else(|| {
                no_such(
                    "element",
                    name,
                    self.doc.elements.iter().map(|e| e.name.as_str()).collect(),
                )
            })
    }

    /// A member's axial stiffness EA (N): the element's `axial_stiffness_n`,
    /// else the model's (`[settings] axial_stiffness_n`), else 6e6 N.
    fn member_stiffness(&self, name: &str) -> PyResult<f64> {
        let e = &self.doc.elements[self.element_index(name)?];
        if !PyModel::element_kind_params(&e.kind).contains(&AXIAL_STIFFNESS_KEY) {
            return Err(PyValueError::new_err(format!(
                "element `{name}` is a {} and has no members of its own (no `{AXIAL_STIFFNESS_KEY}`)",
                e.kind
            )));
        }
        Ok(param_num(&e.params, AXIAL_STIFFNESS_KEY)
            .or(self.doc.axial_stiffness_n)
            .unwrap_or(truss_deploy::solver::model::DEFAULT_AXIAL_STIFFNESS_N))
    }
    /// Sets the axial stiffness EA (N, > 0) of the members of the elements
    /// matching `name` (those with members: bars, sleeves, scissors, plates);
    /// returns how many.
    fn set_member_stiffness(&mut self, py: Python<'_>, name: &str, ea_n: f64) -> PyResult<usize> {
        let ea = finite(AXIAL_STIFFNESS_KEY, ea_n, 0.0, false, "N")?;
        let names: Vec<&str> = self
            .doc
            .elements
            .iter()
            .filter(|e| PyModel::element_kind_params(&e.kind).contains(&AXIAL_STIFFNESS_KEY))
            .map(|e| e.name.as_str())
            .collect();
        let hits: Vec<String> = matching("member", name, names.clone())?
            .into_iter()
            .map(|i| names[i].to_string())
            .collect();
        self.edit(py, |d| {
            for e in d.elements.iter_mut().filter(|e| hits.contains(&e.name)) {
                set_param(&mut e.params, AXIAL_STIFFNESS_KEY, Some(Param::Num(ea)));
            }
            Ok(hits.len())
        })
    }

    /// A sleeve's latch stiffness (N/m); None for a rigid latch.
    fn latch_stiffness(&self, name: &str) -> PyResult<Option<f64>> {
        let e = &self.doc.elements[self.element_index(name)?];
        if e.kind != "sleeve" {
            return Err(PyValueError::new_err(format!(
                "element `{name}` is a {}, not a sleeve: only sleeves latch",
                e.kind
            )));
        }
        Ok(param_num(&e.params, "latch_stiffness_n_per_m"))
    }
    /// A sleeve's latch damping (N s/m; 0 when not given).
    fn latch_damping(&self, name: &str) -> PyResult<f64> {
        self.latch_stiffness(name)?;
        let e = &self.doc.elements[self.element_index(name)?];
        Ok(param_num(&e.params, "latch_damping_n_s_per_m").unwrap_or(0.0))
    }
    /// Makes the latches of the sleeves matching `name` compliant, of
    /// stiffness `stiffness_n_per_m` (N/m, > 0) and, when given, damping
    /// `damping_n_s_per_m` (N s/m, >= 0); None makes them rigid. Returns how many.
    #[pyo3(signature = (name, stiffness_n_per_m, damping_n_s_per_m = None))]
    fn set_latch_stiffness(
        &mut self,
        py: Python<'_>,
        name: &str,
        stiffness_n_per_m: Option<f64>,
        damping_n_s_per_m: Option<f64>,
    ) -> PyResult<usize> {
        let k = stiffness_n_per_m
            .map(|k| finite("latch_stiffness_n_per_m", k, 0.0, false, "N/m"))
            .transpose()?;
        let c = damping_n_s_per_m
            .map(|c| finite("latch_damping_n_s_per_m", c, 0.0, true, "N s/m"))
            .transpose()?;
        if k.is_none() && c.is_some() {
            return Err(PyValueError::new_err(
                "latch damping needs a latch stiffness (a compliant latch); a rigid latch has none",
            ));
        }
        let names: Vec<&str> = self
            .doc
            .elements
            .iter()
            .filter(|e| e.kind == "sleeve")
            .map(|e| e.name.as_str())
            .collect();
        let hits: Vec<String> = matching("sleeve", name, names.clone())?
            .into_iter()
            .map(|i| names[i].to_string())
            .collect();
        self.edit(py, |d| {
            for e in d.elements.iter_mut().filter(|e| hits.contains(&e.name)) {
                set_param(&mut e.params, "latch_stiffness_n_per_m", k.map(Param::Num));
                if k.is_none() {
                    set_param(&mut e.params, "latch_damping_n_s_per_m", None);
                } else if let Some(c) = c {
                    set_param(
                        &mut e.params,
                        "latch_damping_n_s_per_m",
                        Some(Param::Num(c)),
                    );
                }
            }
            Ok(hits.len())
        })
    }

    /// An element's parameter as the model file gives it (a number, a text,
    /// or None when the file leaves it to its default).
    fn element_param(&self, py: Python<'_>, name: &str, key: &str) -> PyResult<Py<PyAny>> {
        let e = &self.doc.elements[self.element_index(name)?];
        let known = PyModel::element_kind_params(&e.kind);
        if !known.contains(&key) {
            return Err(PyKeyError::new_err(format!(
                "a {} element has no parameter `{key}` (its parameters: {})",
                e.kind,
                known.join(", ")
            )));
        }
        Ok(
            match e.params.iter().find(|(k, _)| k == key).map(|p| &p.1) {
                Some(Param::Num(v)) => v.into_pyobject(py)?.into_any().unbind(),
                Some(Param::Text(t)) => t.into_pyobject(py)?.into_any().unbind(),
                None => py.None(),
            },
        )
    }
    /// Sets (or with None removes) parameter `key` of the elements matching
    /// `name`; the element type's own checks apply. Returns how many.
    fn set_element_param(
        &mut self,
        py: Python<'_>,
        name: &str,
        key: &str,
        value: Option<Bound<'_, PyAny>>,
    ) -> PyResult<usize> {
        let v = match value {
            None => None,
            Some(v) => Some(if let Ok(s) = v.extract::<String>() {
                Param::Text(s)
            } else {
                let x: f64 = v.extract().map_err(|_| {
                    pyo3::exceptions::PyTypeError::new_err(format!(
                        "element parameter `{key}`: give a number, a str or None"
                    ))
                })?;
                Param::Num(finite(key, x, f64::NEG_INFINITY, false, "its unit")?)
            }),
        };
        let hits = matching(
            "element",
            name,
            self.doc.elements.iter().map(|e| e.name.as_str()).collect(),
        )?;
        for &i in &hits {
            let e = &self.doc.elements[i];
            if !PyModel::element_kind_params(&e.kind).contains(&key) {
                return Err(PyKeyError::new_err(format!(
                    "element `{}` is a {}, which has no parameter `{key}` (its parameters: {})",
                    e.name,
                    e.kind,
                    PyModel::element_kind_params(&e.kind).join(", ")
                )));
            }
        }
        self.edit(py, |d| {
            for &i in &hits {
                set_param(&mut d.elements[i].params, key, v.clone());
            }
            Ok(hits.len())
        })
    }

    /// `truss-deploy analyze`: rank, mechanisms, states of self-stress,
    /// redundant rows, before and after all locks (the keys of `analyze --json`).
    fn analyze<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let loaded = self.loaded(py)?;
        let file = self.source_name();
        let report = py
            .detach(|| truss_deploy::cli::analysis(loaded, &file))
            .map_err(|f| model_error_msg(py, &file, f.message))?;
        json_loads(py, &serde_json::to_string(&report).expect("serializes"))
    }

    /// `truss-deploy analyze --modes COUNT`: the deployed truss's first
    /// `count` natural modes (the `modes` of `analyze --json`, docs/modes.md).
    fn modes<'py>(&self, py: Python<'py>, count: usize) -> PyResult<Bound<'py, PyAny>> {
        if count == 0 {
            return Err(PyValueError::new_err("modes(0): ask for at least one mode"));
        }
        let loaded = self.loaded(py)?;
        let file = self.source_name();
        let modes = py
            .detach(|| {
                let lin = truss_deploy::solver::modes::Linearization::deployed(&loaded.model);
                truss_deploy::solver::modes::natural_modes(&loaded.model, &lin, count)
            })
            .map_err(|e| PyRuntimeError::new_err(format!("{file}: no modes: {e}")))?;
        json_loads(py, &serde_json::to_string(&modes).expect("serializes"))
    }
}

/// Unpickles a Model (its text, where it came from).
#[pyfunction]
fn _model_from_pickle(py: Python<'_>, text: &str, source: &str, edited: bool) -> PyResult<PyModel> {
    let mut m = PyModel::from_text(py, text, source)?;
    m.edited = edited;
    Ok(m)
}

/// `truss-deploy generate KIND` with options `args` ([(name, value or None
/// for a flag)], a sweep's `[base.args]`): the model, checked as the
/// command checks it before writing.
#[pyfunction]
fn _generate(kind: &str, args: Vec<(String, Option<String>)>) -> PyResult<PyModel> {
    let doc = truss_deploy::cli::generate_from_args(kind, &args).map_err(PyValueError::new_err)?;
    let text = doc.to_toml();
    let source = format!("generate {kind}");
    model::parse(&text, &format!("the model `generate {kind}` would write"))
        .map_err(|e| PyValueError::new_err(format!("{e}; change the options")))?;
    Ok(PyModel {
        doc,
        source,
        text,
        edited: false,
    })
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyModel>()?;
    m.add_function(wrap_pyfunction!(_model_from_pickle, m)?)?;
    m.add_function(wrap_pyfunction!(_generate, m)?)?;
    Ok(())
}
