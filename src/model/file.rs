//! The TOML model file: reading with serde, validation with file and line in
//! every error, conversion to the solver's [`Model`], and writing.
//!
//! ```toml
//! [model]
//! name = "pantograph_mast"
//! description = "..."
//! notes = ["each modelling choice, one line each"]
//!
//! [settings]                 # all optional
//! dt_s = 0.05
//! end_time_s = 120.0
//! gravity_m_s2 = [0.0, 0.0, 0.0]
//! damping_n_s_per_m = 0.0    # viscous, on each joint's velocity
//! axial_stiffness_n = 6.0e6  # EA of members that name none (N): shares redundant forces
//!
//! [checks]                   # all optional: solver::checks::RunChecks
//! energy_balance_rel_tol = 1e-2   # a run whose energy balance is off by more stops (exit 1)
//! stall_rel_motion = 1e-7    # at rest: no joint moves this fraction of the size ...
//! stall_time_s = 1.0         # ... within this time; so long at rest: `stalled`
//! max_steps = 2000000        # step budget of one run
//! max_inexact_results = 0    # results accepted inexact before the run stops
//! jam_error_rel = 1e-6       # rigid with sleeves unlatched, farther from the reference: `stalled`
//! held_short_rel_gap = 1e-3  # a latch leaves a sleeve this fraction of the size short, fixed ...
//! held_short_confirm_s = 5.0 # ... and it has not moved so long after: `stalled` (1e300: never)
//! stick_confirm_s = 5.0      # every drive cable sticks on its pulleys so long: `stalled` (1e300: never)
//! [solver]                   # all optional: tolerances and iteration limits,
//! newmark_max_iterations = 60  # keys and defaults in solver::settings
//!
//! [[joint]]
//! name = "L0"
//! position_m = [0.0, 0.0, 0.0]
//! mass_kg = 0.15
//! reference_m = [0.0, 0.0, 0.0]   # deployed position (optional, all joints or none;
//!                                 # must satisfy every element, sleeves latched)
//!
//! [[element]]
//! type = "scissor"           # see `truss-deploy analyze --help` / elements::REGISTRY
//! name = "U1"
//! joints = ["L0", "R1", "R0", "L1"]
//! ratio = 1.0                # element parameters
//!
//! [[cable]]
//! name = "drive"
//! path = ["L0", "R0", "L1"]  # motor end first, anchored end last, pulleys between
//! tension_n = 1.0
//! max_tension_n = 20.0
//! friction_mu = 0.005
//! line_density_kg_per_m = 0.0
//! pulley_radius_m = 0.01
//! slip_speed_m_s = 1e-4
//! ```

use crate::solver::checks::RunChecks;
use crate::solver::elements::{ElementSpec, Param};
use crate::solver::model::ModelPart;
use crate::solver::{Cable, Joint, Model, ModelParts, SolverError, SolverSettings};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::fmt;
use std::path::Path;
use toml::Spanned;

/// A problem with a model file: where, what, and how to fix it.
#[derive(Clone, Debug, PartialEq)]
pub struct ModelFileError {
    pub file: String,
    pub line: Option<usize>,
    pub message: String,
}

impl fmt::Display for ModelFileError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(l) => write!(f, "{}:{}: {}", self.file, l, self.message),
            None => write!(f, "{}: {}", self.file, self.message),
        }
    }
}
impl std::error::Error for ModelFileError {}

#[derive(Deserialize, Debug, Default)]
#[serde(deny_unknown_fields)]
struct Header {
    name: String,
    #[serde(default)]
    description: String,
    #[serde(default)]
    notes: Vec<String>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct Settings {
    #[serde(default = "default_dt")]
    dt_s: f64,
    #[serde(default = "default_end")]
    end_time_s: f64,
    #[serde(default, deserialize_with = "xyz")]
    gravity_m_s2: [f64; 3],
    #[serde(default)]
    damping_n_s_per_m: f64,
    /// Model-wide EA of members (N); the solver's default when absent.
    #[serde(default)]
    axial_stiffness_n: Option<f64>,
}

/// Run checks (`[checks]`, all optional): see `solver::checks::RunChecks`.
#[derive(Deserialize, Debug, Default)]
#[serde(deny_unknown_fields)]
struct ChecksSpec {
    energy_balance_rel_tol: Option<f64>,
    stall_rel_motion: Option<f64>,
    stall_time_s: Option<f64>,
    max_steps: Option<u64>,
    jam_error_rel: Option<f64>,
    held_short_rel_gap: Option<f64>,
    held_short_confirm_s: Option<f64>,
    stick_confirm_s: Option<f64>,
    max_inexact_results: Option<u64>,
}

/// Exactly three numbers [x, y, z]: serde's fixed-size arrays would take the
/// first three of a longer list and drop the rest silently.
fn xyz<'de, D: serde::Deserializer<'de>>(d: D) -> Result<[f64; 3], D::Error> {
    let v: Vec<f64> = Vec::deserialize(d)?;
    <[f64; 3]>::try_from(v.as_slice()).map_err(|_| {
        serde::de::Error::custom(format!(
            "expected exactly 3 numbers [x, y, z], found {}",
            v.len()
        ))
    })
}

fn xyz_opt<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<[f64; 3]>, D::Error> {
    xyz(d).map(Some)
}
fn default_dt() -> f64 {
    0.05
}
fn default_end() -> f64 {
    600.0
}
impl Default for Settings {
    fn default() -> Self {
        Settings {
            dt_s: default_dt(),
            end_time_s: default_end(),
            gravity_m_s2: [0.0; 3],
            damping_n_s_per_m: 0.0,
            axial_stiffness_n: None,
        }
    }
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct JointSpec {
    name: Spanned<String>,
    #[serde(deserialize_with = "xyz")]
    position_m: [f64; 3],
    mass_kg: f64,
    #[serde(default, deserialize_with = "xyz_opt")]
    reference_m: Option<[f64; 3]>,
}

#[derive(Deserialize, Debug)]
struct ElementEntry {
    #[serde(rename = "type")]
    kind: Spanned<String>,
    name: Spanned<String>,
    joints: Vec<Spanned<String>>,
    #[serde(flatten)]
    params: BTreeMap<String, toml::Value>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct CableSpec {
    name: Spanned<String>,
    path: Spanned<Vec<Spanned<String>>>,
    tension_n: f64,
    max_tension_n: Option<f64>,
    #[serde(default)]
    friction_mu: f64,
    #[serde(default)]
    line_density_kg_per_m: f64,
    #[serde(default = "default_radius")]
    pulley_radius_m: f64,
    #[serde(default = "default_slip")]
    slip_speed_m_s: f64,
}
fn default_radius() -> f64 {
    0.01
}
fn default_slip() -> f64 {
    1e-4
}
/// A cable's `max_tension_n` when the file gives none: four times its tension.
fn default_max_tension(tension_n: f64) -> f64 {
    tension_n.max(0.0) * 4.0
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct FileSpec {
    model: Header,
    #[serde(default)]
    settings: Settings,
    #[serde(default)]
    checks: ChecksSpec,
    solver: Option<Spanned<SolverSettings>>,
    #[serde(default, rename = "joint")]
    joints: Vec<Spanned<JointSpec>>,
    #[serde(default, rename = "element")]
    elements: Vec<Spanned<ElementEntry>>,
    #[serde(default, rename = "cable")]
    cables: Vec<Spanned<CableSpec>>,
}

/// The keys of a `[[element]]` entry besides its type's parameters
/// (`ElementEntry`'s fields; its flattened parameter map hides them from
/// [`struct_keys`]). The parameters of each type are `elements::REGISTRY`'s.
pub const ELEMENT_KEYS: &[&str] = &["type", "name", "joints"];

/// Every table of the model file and the keys it takes, read from the
/// loader's own serde structs (so the list cannot drift from what `parse`
/// accepts): `""` is the top level (the table names), then `model`,
/// `settings`, `checks`, `solver`, `joint`, `element` (without the
/// per-type parameters) and `cable`. docs/model-format.md documents each
/// (tests/cli/docs.rs).
pub fn file_keys() -> Vec<(&'static str, &'static [&'static str])> {
    vec![
        ("", struct_keys::<FileSpec>()),
        ("model", struct_keys::<Header>()),
        ("settings", struct_keys::<Settings>()),
        ("checks", struct_keys::<ChecksSpec>()),
        ("solver", struct_keys::<SolverSettings>()),
        ("joint", struct_keys::<JointSpec>()),
        ("element", ELEMENT_KEYS),
        ("cable", struct_keys::<CableSpec>()),
    ]
}

/// The field names serde's derive passes to `deserialize_struct`: a probe
/// deserializer records them and stops.
fn struct_keys<T: serde::de::DeserializeOwned>() -> &'static [&'static str] {
    use serde::de::Visitor;
    #[derive(Debug)]
    struct Stop;
    impl fmt::Display for Stop {
        fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            f.write_str("probe")
        }
    }
    impl std::error::Error for Stop {}
    impl serde::de::Error for Stop {
        fn custom<M: fmt::Display>(_: M) -> Self {
            Stop
        }
    }
    struct Probe<'a>(&'a mut &'static [&'static str]);
    impl<'de> serde::Deserializer<'de> for Probe<'_> {
        type Error = Stop;
        fn deserialize_any<V: Visitor<'de>>(self, _: V) -> Result<V::Value, Stop> {
            Err(Stop)
        }
        fn deserialize_struct<V: Visitor<'de>>(
            self,
            _: &'static str,
            fields: &'static [&'static str],
            _: V,
        ) -> Result<V::Value, Stop> {
            *self.0 = fields;
            Err(Stop)
        }
        serde::forward_to_deserialize_any! {
            bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string
            bytes byte_buf option unit unit_struct newtype_struct seq tuple
            tuple_struct map enum identifier ignored_any
        }
    }
    let mut keys: &'static [&'static str] = &[];
    let _ = T::deserialize(Probe(&mut keys));
    keys
}

/// Loaded model plus the descriptive parts of the file.
pub struct LoadedModel {
    pub model: Model,
    /// The run checks, the file's `[checks]` over the defaults.
    pub checks: RunChecks,
    pub description: String,
    pub notes: Vec<String>,
}

fn line_of(text: &str, offset: usize) -> usize {
    text[..offset.min(text.len())]
        .bytes()
        .filter(|b| *b == b'\n')
        .count()
        + 1
}

/// Reads and validates a model file.
pub fn load(path: &Path) -> Result<LoadedModel, ModelFileError> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| ModelFileError {
        file: file.clone(),
        line: None,
        message: format!("cannot read the model file ({e}); check the path, or write one with `truss-deploy generate`"),
    })?;
    parse(&text, &file)
}

/// Parses and validates model text; `file` names it in errors.
pub fn parse(text: &str, file: &str) -> Result<LoadedModel, ModelFileError> {
    let err = |span: Option<std::ops::Range<usize>>, message: String| ModelFileError {
        file: file.to_string(),
        line: span.map(|s| line_of(text, s.start)),
        message,
    };
    let spec: FileSpec = toml::from_str(text).map_err(|e| {
        let msg = e.message().trim().to_string();
        // Name the key whose value is wrong (serde's messages say only what was
        // expected): the `key =` of the line the error points at.
        let key = e
            .span()
            .and_then(|s| key_on_line(text, s.start))
            .filter(|k| !msg.contains(&format!("`{k}`")))
            .map_or(String::new(), |k| format!("`{k}`: "));
        err(
            e.span(),
            format!("{key}{msg}; see the format in docs/model-format.md"),
        )
    })?;
    let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
    if let Some(solver) = &spec.solver {
        solver.get_ref().validate().map_err(|m| {
            err(
                Some(solver.span()),
                format!("{m}; see `[solver]` in docs/model-format.md"),
            )
        })?;
    }
    let s = &spec.settings;
    let settings_span = settings_line(text);
    for (key, v, min_exclusive) in [
        ("dt_s", s.dt_s, Some(0.0)),
        ("end_time_s", s.end_time_s, Some(0.0)),
        ("damping_n_s_per_m", s.damping_n_s_per_m, None),
    ] {
        let bad = match min_exclusive {
            Some(m) => !(v.is_finite() && v > m),
            None => !(v.is_finite() && v >= 0.0),
        };
        if bad {
            return Err(err(
                settings_span.clone(),
                format!(
                    "[settings] `{key}` = {v}: give a finite number {}",
                    if min_exclusive.is_some() {
                        "> 0"
                    } else {
                        ">= 0"
                    }
                ),
            ));
        }
    }
    if !finite(&s.gravity_m_s2) {
        return Err(err(
            settings_span,
            "[settings] `gravity_m_s2` holds a NaN or infinite number; give 3 finite numbers (m/s^2)".into(),
        ));
    }
    if s.axial_stiffness_n
        .is_some_and(|ea| !(ea.is_finite() && ea > 0.0))
    {
        return Err(err(
            settings_span.clone(),
            format!(
                "[settings] axial_stiffness_n = {} must be a positive, finite EA in N",
                s.axial_stiffness_n.unwrap_or(f64::NAN)
            ),
        ));
    }
    let checks = run_checks(&spec.checks).map_err(|e| err(None, e.to_string()))?;

    // Joints: unique names, finite numbers, positive masses.
    let mut index: BTreeMap<&str, usize> = BTreeMap::new();
    let mut joints = Vec::new();
    let mut x0 = Vec::new();
    let mut reference = Vec::new();
    let mut with_reference = 0;
    if spec.joints.is_empty() {
        return Err(err(
            None,
            "the model has no [[joint]] entries; a truss needs joints".into(),
        ));
    }
    for js in &spec.joints {
        let j = js.get_ref();
        let name = j.name.get_ref().as_str();
        if name.is_empty() {
            return Err(err(
                Some(j.name.span()),
                "a joint has an empty name; give every joint a unique name".into(),
            ));
        }
        if index.insert(name, joints.len()).is_some() {
            return Err(err(
                Some(j.name.span()),
                format!("duplicate joint name `{name}`; joint names must be unique"),
            ));
        }
        if !finite(&j.position_m)
            || !j.mass_kg.is_finite()
            || j.reference_m.is_some_and(|r| !finite(&r))
        {
            return Err(err(
                Some(js.span()),
                format!(
                    "joint `{name}` has a NaN or infinite number; give finite coordinates and mass"
                ),
            ));
        }
        if j.mass_kg <= 0.0 {
            return Err(err(
                Some(js.span()),
                format!(
                    "joint `{name}` has mass_kg = {}; every joint needs a positive lumped mass",
                    j.mass_kg
                ),
            ));
        }
        joints.push(Joint {
            name: name.to_string(),
            mass_kg: j.mass_kg,
        });
        x0.extend(j.position_m);
        if let Some(r) = j.reference_m {
            with_reference += 1;
            reference.extend(r);
        }
    }
    if with_reference != 0 && with_reference != joints.len() {
        return Err(err(None, format!("{with_reference} of {} joints have reference_m; give it for every joint or for none", joints.len())));
    }
    let lookup = |n: &Spanned<String>, whose: &str| -> Result<usize, ModelFileError> {
        index.get(n.get_ref().as_str()).copied().ok_or_else(|| {
            err(Some(n.span()), format!("{whose} refers to joint `{}`, which does not exist; declare it in a [[joint]] entry or fix the name", n.get_ref()))
        })
    };

    // Elements.
    let mut elements = Vec::new();
    let mut element_spans = Vec::new();
    let mut element_names: BTreeMap<String, ()> = BTreeMap::new();
    for es in &spec.elements {
        let e = es.get_ref();
        let whose = format!("element `{}`", e.name.get_ref());
        if e.name.get_ref().is_empty() {
            return Err(err(
                Some(e.name.span()),
                "an element has an empty name; give every element a unique name".into(),
            ));
        }
        if element_names.insert(e.name.get_ref().clone(), ()).is_some() {
            return Err(err(
                Some(e.name.span()),
                format!(
                    "duplicate element name `{}`; element names must be unique",
                    e.name.get_ref()
                ),
            ));
        }
        let mut params = BTreeMap::new();
        for (k, v) in &e.params {
            let p = match v {
                toml::Value::Float(f) if f.is_finite() => Param::Num(*f),
                toml::Value::Float(f) => {
                    return Err(err(
                        Some(es.span()),
                        format!("{whose}: parameter `{k}` is {f}; give a finite number"),
                    ));
                }
                toml::Value::Integer(i) => Param::Num(*i as f64),
                toml::Value::String(s) => Param::Text(s.clone()),
                other => {
                    return Err(err(
                        Some(es.span()),
                        format!("{whose}: parameter `{k}` = {other} must be a number or a string"),
                    ));
                }
            };
            params.insert(k.clone(), p);
        }
        let idx = e
            .joints
            .iter()
            .map(|j| lookup(j, &whose))
            .collect::<Result<Vec<_>, _>>()?;
        elements.push(ElementSpec {
            kind: e.kind.get_ref().clone(),
            name: e.name.get_ref().clone(),
            joints: idx,
            params,
        });
        element_spans.push(es.span());
    }

    // Cables.
    let mut cables = Vec::new();
    let mut cable_spans = Vec::new();
    for cs in &spec.cables {
        let c = cs.get_ref();
        let whose = format!("cable `{}`", c.name.get_ref());
        if c.name.get_ref().is_empty() || cables.iter().any(|k: &Cable| &k.name == c.name.get_ref())
        {
            return Err(err(
                Some(c.name.span()),
                format!(
                    "cable name `{}` is empty or used twice; give every cable a unique name",
                    c.name.get_ref()
                ),
            ));
        }
        // (its motor is the joint `<cable>_motor` in /joint_states, beside
        // the elements' joints)
        let motor = format!("{}_motor", c.name.get_ref());
        if element_names.contains_key(&motor) {
            return Err(err(
                Some(c.name.span()),
                format!(
                    "{whose}'s motor is published as the joint `{motor}`, which an element is \
                     already named; rename the cable or the element"
                ),
            ));
        }
        if c.path.get_ref().len() < 2 {
            return Err(err(
                Some(c.path.span()),
                format!("{whose} has a path of {} joint(s); list at least the motor-end joint and the anchored end", c.path.get_ref().len()),
            ));
        }
        let nums = [
            ("tension_n", c.tension_n),
            ("max_tension_n", c.max_tension_n.unwrap_or(c.tension_n)),
            ("friction_mu", c.friction_mu),
            ("line_density_kg_per_m", c.line_density_kg_per_m),
            ("pulley_radius_m", c.pulley_radius_m),
        ];
        for (key, v) in nums {
            if !(v.is_finite() && v >= 0.0) {
                return Err(err(
                    Some(cs.span()),
                    format!("{whose}: `{key}` = {v}; give a finite number >= 0"),
                ));
            }
        }
        if !(c.slip_speed_m_s.is_finite() && c.slip_speed_m_s > 0.0) {
            return Err(err(
                Some(cs.span()),
                format!(
                    "{whose}: `slip_speed_m_s` = {}; give a finite speed > 0 (m/s)",
                    c.slip_speed_m_s
                ),
            ));
        }
        if let Some(max) = c.max_tension_n {
            if c.tension_n > max {
                return Err(err(
                    Some(cs.span()),
                    format!(
                        "{whose}: `tension_n` = {} N exceeds `max_tension_n` = {max} N; raise max_tension_n or lower the tension",
                        c.tension_n
                    ),
                ));
            }
        }
        let path = c
            .path
            .get_ref()
            .iter()
            .map(|j| lookup(j, &whose))
            .collect::<Result<Vec<_>, _>>()?;
        cables.push(Cable {
            name: c.name.get_ref().clone(),
            path,
            tension_n: c.tension_n,
            max_tension_n: c.max_tension_n.unwrap_or(default_max_tension(c.tension_n)),
            friction_mu: c.friction_mu,
            line_density_kg_per_m: c.line_density_kg_per_m,
            pulley_radius_m: c.pulley_radius_m,
            slip_speed_m_s: c.slip_speed_m_s,
        });
        cable_spans.push(cs.span());
    }

    let n_elements = elements.len();
    let parts = ModelParts {
        name: spec.model.name.clone(),
        joints,
        x0,
        reference: (with_reference > 0).then_some(reference),
        elements,
        cables,
        gravity_m_s2: s.gravity_m_s2,
        damping_n_s_per_m: s.damping_n_s_per_m,
        dt_s: s.dt_s,
        end_time_s: s.end_time_s,
        axial_stiffness_n: s.axial_stiffness_n,
    };
    let mut model = Model::build(parts).map_err(|e| {
        let span = match e.at {
            ModelPart::Element(i) => element_spans.get(i).cloned(),
            ModelPart::Cable(i) => cable_spans.get(i).cloned(),
            ModelPart::Joints | ModelPart::Settings => None,
        };
        err(span, e.what)
    })?;
    model.solver = spec.solver.map(Spanned::into_inner).unwrap_or_default();
    let limit_m = model.solver.initial_tol_m;
    if let Some((e, row, residual)) = model.initial_violation(limit_m) {
        let el = &model.elements[e];
        let span = element_spans.get(e).cloned();
        let e = SolverError::InitialViolation {
            element: el.name().to_string(),
            kind: el.kind(),
            row,
            residual_m: residual,
            limit_m,
        };
        return Err(err(span, e.to_string()));
    }
    debug_assert_eq!(n_elements, model.elements.len());
    check_reference(&model, &spec.joints, &element_spans, &err)?;
    Ok(LoadedModel {
        model,
        checks,
        description: spec.model.description,
        notes: spec.model.notes,
    })
}

/// The key of the `key = value` line holding byte `offset`, if any.
fn key_on_line(text: &str, offset: usize) -> Option<String> {
    let offset = offset.min(text.len());
    let start = text[..offset].rfind('\n').map_or(0, |i| i + 1);
    let line = text[start..].lines().next()?;
    let (key, _) = line.split_once('=')?;
    let key = key.trim().trim_matches('"');
    (!key.is_empty()
        && key
            .chars()
            .all(|c| c.is_alphanumeric() || "_-.".contains(c)))
    .then(|| key.to_string())
}

/// The span of the `[settings]` header, for errors in that table.
fn settings_line(text: &str) -> Option<std::ops::Range<usize>> {
    text.find("[settings]").map(|i| i..i + 10)
}

/// `[checks]` over the defaults, each value checked and named.
/// A `[checks]` number out of its range (`run_checks`): positive and
/// finite, at least 1 for a count.
#[derive(Debug)]
struct ChecksError {
    key: &'static str,
    value: f64,
}

impl fmt::Display for ChecksError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.key {
            "max_steps" => write!(f, "[checks] `max_steps` = 0: give at least 1"),
            key => write!(
                f,
                "[checks] `{key}` = {}: give a finite number > 0",
                self.value
            ),
        }
    }
}

fn run_checks(c: &ChecksSpec) -> Result<RunChecks, ChecksError> {
    let mut r = RunChecks::default();
    let positive = |key: &'static str, v: Option<f64>| match v {
        Some(x) if !(x.is_finite() && x > 0.0) => Err(ChecksError { key, value: x }),
        _ => Ok(v),
    };
    if let Some(v) = positive("energy_balance_rel_tol", c.energy_balance_rel_tol)? {
        r.energy_balance_rel_tol = v;
    }
    if let Some(v) = positive("stall_rel_motion", c.stall_rel_motion)? {
        r.stall_rel_motion = v;
    }
    if let Some(v) = positive("stall_time_s", c.stall_time_s)? {
        r.stall_time_s = v;
    }
    if let Some(v) = positive("jam_error_rel", c.jam_error_rel)? {
        r.jam_error_rel = v;
    }
    if let Some(v) = positive("held_short_rel_gap", c.held_short_rel_gap)? {
        r.held_short_rel_gap = v;
    }
    if let Some(v) = positive("held_short_confirm_s", c.held_short_confirm_s)? {
        r.held_short_confirm_s = v;
    }
    if let Some(v) = positive("stick_confirm_s", c.stick_confirm_s)? {
        r.stick_confirm_s = v;
    }
    if let Some(v) = c.max_inexact_results {
        r.max_inexact_results = v;
    }
    if let Some(v) = c.max_steps {
        if v == 0 {
            return Err(ChecksError {
                key: "max_steps",
                value: 0.0,
            });
        }
        r.max_steps = v;
    }
    Ok(r)
}

/// Largest residual (m) of any element at the reference (deployed) geometry,
/// sleeves taken latched there.
pub const REFERENCE_TOL_M: f64 = 1e-6;

/// The reference geometry is the deployed truss: it must span a size and
/// satisfy every element with every sleeve latched (a sleeve's length there
/// is its lock length). Checked here so that `final_error_rel` is measured
/// against a geometry the truss can reach, and `analyze` (which ranks the
/// Jacobian there) never works on a degenerate one.
fn check_reference(
    model: &Model,
    joints: &[Spanned<JointSpec>],
    element_spans: &[std::ops::Range<usize>],
    err: &dyn Fn(Option<std::ops::Range<usize>>, String) -> ModelFileError,
) -> Result<(), ModelFileError> {
    let Some(r) = &model.reference else {
        return Ok(());
    };
    let size = model.reference_size_m().unwrap_or(0.0);
    if !(size.is_finite() && size > 0.0) {
        return Err(err(
            joints.first().map(|j| j.span()),
            format!("every joint's `reference_m` is the same point (the reference spans {size} m); give the deployed position of each joint"),
        ));
    }
    let mut buf = Vec::new();
    for (e, el) in model.elements.iter().enumerate() {
        // (compliant elements: their springs' rows, at rest when deployed)
        let rows = el.rows(true).max(el.spring().map_or(0, |sp| sp.rows));
        if rows == 0 {
            continue;
        }
        buf.resize(rows, 0.0);
        el.residual(r, &mut buf);
        if let Some(row) = buf.iter().position(|v| !(v.abs() <= REFERENCE_TOL_M)) {
            let names: Vec<&str> = el
                .joints()
                .iter()
                .map(|&j| model.joints[j].name.as_str())
                .collect();
            return Err(err(
                element_spans.get(e).cloned(),
                format!(
                    "the reference geometry (`reference_m`) violates {} element `{}` on joints {}: row {row} has residual {:.3e} m there (limit {REFERENCE_TOL_M:e} m, sleeves taken latched); the reference is the deployed truss and must satisfy every element: fix `reference_m` of these joints{}",
                    el.kind(),
                    el.name(),
                    names.join(", "),
                    buf[row],
                    if el.lock_gap(r).is_some() { " or the sleeve's `lock_length_m`" } else { "" }
                ),
            ));
        }
    }
    Ok(())
}

/// A model file as a document: what the generators write ([`ModelDoc::to_toml`])
/// and what [`ModelDoc::from_toml`] reads back from any model file, every key
/// the loader takes, so that a model can be edited by name (a joint's mass, a
/// cable's tension) and built again (`parse(&doc.to_toml(), ..)`).
#[derive(Clone, Debug, Default)]
pub struct ModelDoc {
    pub name: String,
    pub description: String,
    pub notes: Vec<String>,
    pub dt_s: f64,
    pub end_time_s: f64,
    pub damping_n_s_per_m: f64,
    /// `[settings] gravity_m_s2` (m/s^2).
    pub gravity_m_s2: [f64; 3],
    /// `[settings] axial_stiffness_n`: the EA of members that name none (N);
    /// the solver's default when None.
    pub axial_stiffness_n: Option<f64>,
    /// Writes `[solver] elastic_members = true` (rigid members when false).
    pub elastic_members: bool,
    /// The other `[solver]` keys, as the file gives them (`SolverSettings`).
    pub solver: toml::Table,
    /// `[checks]` keys, as the file gives them (`RunChecks`).
    pub checks: toml::Table,
    pub joints: Vec<JointDoc>,
    pub elements: Vec<ElementDoc>,
    pub cables: Vec<CableDoc>,
}

#[derive(Clone, Debug)]
pub struct JointDoc {
    pub name: String,
    pub position_m: [f64; 3],
    pub mass_kg: f64,
    pub reference_m: Option<[f64; 3]>,
}

#[derive(Clone, Debug)]
pub struct ElementDoc {
    pub kind: String,
    pub name: String,
    pub joints: Vec<String>,
    pub params: Vec<(String, Param)>,
}

#[derive(Clone, Debug)]
pub struct CableDoc {
    pub name: String,
    pub path: Vec<String>,
    pub tension_n: f64,
    pub max_tension_n: f64,
    pub friction_mu: f64,
    pub pulley_radius_m: f64,
    /// Written only when not the loader's defaults (0 kg/m, 1e-4 m/s).
    pub line_density_kg_per_m: f64,
    pub slip_speed_m_s: f64,
}

impl Default for CableDoc {
    /// The loader's defaults of the optional keys; no name, no path.
    fn default() -> Self {
        CableDoc {
            name: String::new(),
            path: Vec::new(),
            tension_n: 0.0,
            max_tension_n: 0.0,
            friction_mu: 0.0,
            pulley_radius_m: default_radius(),
            line_density_kg_per_m: 0.0,
            slip_speed_m_s: default_slip(),
        }
    }
}

fn q(s: &str) -> String {
    toml::Value::String(s.to_string()).to_string()
}
fn num(v: f64) -> String {
    // Rust's shortest round-trip form, always with a decimal point or exponent
    let s = format!("{v:?}");
    s
}
fn arr3(v: [f64; 3]) -> String {
    format!("[{}, {}, {}]", num(v[0]), num(v[1]), num(v[2]))
}
fn names(v: &[String]) -> String {
    format!(
        "[{}]",
        v.iter().map(|s| q(s)).collect::<Vec<_>>().join(", ")
    )
}

impl ModelDoc {
    pub fn to_toml(&self) -> String {
        let mut o = String::new();
        o += "# Written by `truss-deploy generate`; every modelling choice is listed in `notes`.\n";
        o += &format!(
            "[model]\nname = {}\ndescription = {}\nnotes = [\n",
            q(&self.name),
            q(&self.description)
        );
        for n in &self.notes {
            o += &format!("  {},\n", q(n));
        }
        o += "]\n\n[settings]\n";
        o += &format!(
            "dt_s = {}\nend_time_s = {}\ngravity_m_s2 = {}\ndamping_n_s_per_m = {}\n",
            num(self.dt_s),
            num(self.end_time_s),
            arr3(self.gravity_m_s2),
            num(self.damping_n_s_per_m)
        );
        if let Some(ea) = self.axial_stiffness_n {
            o += &format!("axial_stiffness_n = {}\n", num(ea));
        }
        if self.elastic_members || !self.solver.is_empty() {
            o += "\n[solver]\n";
            if self.elastic_members {
                o += "elastic_members = true\n";
            }
            o += &table_keys(&self.solver);
        }
        if !self.checks.is_empty() {
            o += "\n[checks]\n";
            o += &table_keys(&self.checks);
        }
        for j in &self.joints {
            o += &format!(
                "\n[[joint]]\nname = {}\nposition_m = {}\nmass_kg = {}\n",
                q(&j.name),
                arr3(j.position_m),
                num(j.mass_kg)
            );
            if let Some(r) = j.reference_m {
                o += &format!("reference_m = {}\n", arr3(r));
            }
        }
        for e in &self.elements {
            o += &format!(
                "\n[[element]]\ntype = {}\nname = {}\njoints = {}\n",
                q(&e.kind),
                q(&e.name),
                names(&e.joints)
            );
            for (k, p) in &e.params {
                match p {
                    Param::Num(v) => o += &format!("{k} = {}\n", num(*v)),
                    Param::Text(s) => o += &format!("{k} = {}\n", q(s)),
                }
            }
        }
        for c in &self.cables {
            o += &format!(
                "\n[[cable]]\nname = {}\npath = {}\ntension_n = {}\nmax_tension_n = {}\nfriction_mu = {}\npulley_radius_m = {}\n",
                q(&c.name),
                names(&c.path),
                num(c.tension_n),
                num(c.max_tension_n),
                num(c.friction_mu),
                num(c.pulley_radius_m)
            );
            if c.line_density_kg_per_m != 0.0 {
                o += &format!("line_density_kg_per_m = {}\n", num(c.line_density_kg_per_m));
            }
            if c.slip_speed_m_s != default_slip() {
                o += &format!("slip_speed_m_s = {}\n", num(c.slip_speed_m_s));
            }
        }
        o
    }

    /// The document of a model file's text (every key the loader takes,
    /// defaults filled in as the loader fills them), checked as [`parse`]
    /// checks it: a text that does not load is refused with the same error,
    /// naming `file`, the line and the key. `parse(&doc.to_toml(), ..)`
    /// builds the same model as `parse(text, ..)`.
    pub fn from_toml(text: &str, file: &str) -> Result<ModelDoc, ModelFileError> {
        parse(text, file)?;
        let spec: FileSpec = toml::from_str(text).map_err(|e| ModelFileError {
            file: file.to_string(),
            line: None,
            message: e.message().trim().to_string(),
        })?;
        let raw: toml::Table = toml::from_str(text).unwrap_or_default();
        let table = |name: &str| match raw.get(name) {
            Some(toml::Value::Table(t)) => t.clone(),
            _ => toml::Table::new(),
        };
        let mut solver = table("solver");
        let elastic_members = matches!(
            solver.remove("elastic_members"),
            Some(toml::Value::Boolean(true))
        );
        let s = &spec.settings;
        let num_param = |v: &toml::Value| match v {
            toml::Value::Float(f) => Param::Num(*f),
            toml::Value::Integer(i) => Param::Num(*i as f64),
            toml::Value::String(t) => Param::Text(t.clone()),
            // (parse refused any other)
            other => Param::Text(other.to_string()),
        };
        Ok(ModelDoc {
            name: spec.model.name,
            description: spec.model.description,
            notes: spec.model.notes,
            dt_s: s.dt_s,
            end_time_s: s.end_time_s,
            damping_n_s_per_m: s.damping_n_s_per_m,
            gravity_m_s2: s.gravity_m_s2,
            axial_stiffness_n: s.axial_stiffness_n,
            elastic_members,
            solver,
            checks: table("checks"),
            joints: spec
                .joints
                .into_iter()
                .map(|j| {
                    let j = j.into_inner();
                    JointDoc {
                        name: j.name.into_inner(),
                        position_m: j.position_m,
                        mass_kg: j.mass_kg,
                        reference_m: j.reference_m,
                    }
                })
                .collect(),
            elements: spec
                .elements
                .into_iter()
                .map(|e| {
                    // (the parameters in the file's order: the entry's text
                    // names each once, as `key = value` on a line)
                    let entry = text.get(e.span()).unwrap_or("");
                    let at = |k: &str| {
                        entry
                            .lines()
                            .position(|l| l.split('=').next().map(str::trim) == Some(k))
                    };
                    let e = e.into_inner();
                    let mut params: Vec<(String, Param)> = e
                        .params
                        .iter()
                        .map(|(k, v)| (k.clone(), num_param(v)))
                        .collect();
                    params.sort_by_key(|(k, _)| at(k).unwrap_or(usize::MAX));
                    ElementDoc {
                        kind: e.kind.into_inner(),
                        name: e.name.into_inner(),
                        joints: e.joints.into_iter().map(Spanned::into_inner).collect(),
                        params,
                    }
                })
                .collect(),
            cables: spec
                .cables
                .into_iter()
                .map(|c| {
                    let c = c.into_inner();
                    CableDoc {
                        name: c.name.into_inner(),
                        path: c
                            .path
                            .into_inner()
                            .into_iter()
                            .map(Spanned::into_inner)
                            .collect(),
                        tension_n: c.tension_n,
                        max_tension_n: c.max_tension_n.unwrap_or(default_max_tension(c.tension_n)),
                        friction_mu: c.friction_mu,
                        pulley_radius_m: c.pulley_radius_m,
                        line_density_kg_per_m: c.line_density_kg_per_m,
                        slip_speed_m_s: c.slip_speed_m_s,
                    }
                })
                .collect(),
        })
    }
}

/// `key = value` lines of a table's keys, in its order.
fn table_keys(t: &toml::Table) -> String {
    t.iter().map(|(k, v)| format!("{k} = {v}\n")).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A file read as a document and written again builds the same model,
    /// with every optional key of the format (gravity, EA, `[solver]`,
    /// `[checks]`, a cable's density and slip speed); the bundled models,
    /// which the generators wrote, come back as the same text.
    #[test]
    fn a_document_writes_back_the_model_it_was_read_from() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models");
        for name in [
            "pantograph_mast",
            "double_ring",
            "double_ring_synchronized",
            "sail_array",
        ] {
            let text = std::fs::read_to_string(dir.join(format!("{name}.toml"))).unwrap();
            let doc = ModelDoc::from_toml(&text, name).expect("loads");
            assert_eq!(doc.to_toml(), text, "{name}");
        }
        let mast = std::fs::read_to_string(dir.join("pantograph_mast.toml")).unwrap();
        let text = mast
            .replace(
                "gravity_m_s2 = [0.0, 0.0, 0.0]\ndamping_n_s_per_m = 0.0",
                "gravity_m_s2 = [0.0, 0.0, -0.5]\ndamping_n_s_per_m = 0.1\naxial_stiffness_n = 2e6\n\n[checks]\nmax_steps = 5000\nstall_time_s = 2.5\n\n[solver]\nnewmark_max_iterations = 70\nlock_tol_m = 2e-9",
            )
            .replace(
                "pulley_radius_m = 0.01\n",
                "pulley_radius_m = 0.01\nline_density_kg_per_m = 0.001\nslip_speed_m_s = 2e-4\n",
            );
        let direct = parse(&text, "m").expect("loads");
        let doc = ModelDoc::from_toml(&text, "m").expect("loads");
        let again = parse(&doc.to_toml(), "m").expect("loads");
        assert_eq!(format!("{:?}", direct.model), format!("{:?}", again.model));
        assert_eq!(
            format!("{:?}", direct.checks),
            format!("{:?}", again.checks)
        );
        assert_eq!(again.model.solver.newmark_max_iterations, 70);
        assert_eq!(again.model.cables[0].slip_speed_m_s, 2e-4);
        let e = ModelDoc::from_toml(
            &text.replace("mass_kg = 0.15", "mass_kg = -1.0"),
            "bad.toml",
        )
        .expect_err("refused");
        assert_eq!(e.file, "bad.toml");
        assert!(e.line.is_some() && e.message.contains("mass_kg"), "{e}");
    }
}
