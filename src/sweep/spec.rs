//! The sweep file (docs/sweeps.md): a base model (a model file or a
//! generator and its arguments), distributions of parameters, a master seed;
//! and each sample's model text, built from them.
//!
//! Every problem with the file is found by [`Sweep::load`] before any sample
//! runs: unknown keys, empty or inverted ranges, negative standard
//! deviations, a distribution on a key the base lacks. Each error names the
//! key and the line.

use super::rng::{sample_seed, Rng};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};
use toml::{Spanned, Table, Value};

/// A problem with a sweep file: where and what.
#[derive(Clone, Debug, PartialEq)]
pub struct SweepError {
    pub file: String,
    pub line: Option<usize>,
    pub message: String,
}

impl fmt::Display for SweepError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(l) => write!(f, "{}:{}: {}", self.file, l, self.message),
            None => write!(f, "{}: {}", self.file, self.message),
        }
    }
}

/// Writes a generator's model text: `(kind, [(argument, value)])` to TOML
/// text, or a message. Arguments are the `generate` command's long options
/// without `--` and with `_` for `-` (`tension_n`, `start_deg`); a value of
/// `None` is a flag (`bay_by_bay = true`).
pub type Generator = dyn Fn(&str, &[(String, Option<String>)]) -> Result<String, String> + Sync;

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct FileSpec {
    sweep: Spanned<Header>,
    base: Spanned<BaseSpec>,
    #[serde(default, rename = "param")]
    params: Vec<Spanned<ParamSpec>>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct Header {
    name: String,
    seed: u64,
    samples: Option<Spanned<u64>>,
    max_wall_s: Option<Spanned<f64>>,
    #[serde(default)]
    history: bool,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct BaseSpec {
    model: Option<Spanned<String>>,
    generator: Option<Spanned<String>>,
    #[serde(default)]
    args: BTreeMap<String, Spanned<Value>>,
    /// Keys set in every sample's `[settings]`, `[solver]`, `[checks]`.
    #[serde(default)]
    settings: Table,
    #[serde(default)]
    solver: Table,
    #[serde(default)]
    checks: Table,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct ParamSpec {
    key: Spanned<String>,
    dist: Spanned<String>,
    min: Option<f64>,
    max: Option<f64>,
    mean: Option<f64>,
    std: Option<f64>,
    median: Option<f64>,
    sigma: Option<f64>,
    n: Option<usize>,
    values: Option<Vec<f64>>,
    #[serde(default)]
    relative: bool,
    #[serde(default)]
    each: bool,
}

/// A distribution of one parameter.
#[derive(Clone, Debug, PartialEq)]
pub enum Dist {
    Uniform {
        min: f64,
        max: f64,
    },
    /// Normal, truncated to [min, max] (infinite bounds when not given).
    Normal {
        mean: f64,
        std: f64,
        min: f64,
        max: f64,
    },
    /// exp(N(ln median, sigma^2)).
    LogNormal {
        median: f64,
        sigma: f64,
    },
    /// n values from min to max, evenly spaced (a grid axis).
    Grid {
        min: f64,
        max: f64,
        n: usize,
    },
    /// The listed values (a grid axis).
    List {
        values: Vec<f64>,
    },
}

impl Dist {
    /// The values of a grid axis (None for a random distribution).
    pub fn axis(&self) -> Option<Vec<f64>> {
        match self {
            Dist::Grid { min, max, n } => Some(
                (0..*n)
                    .map(|i| min + (max - min) * i as f64 / (*n - 1) as f64)
                    .collect(),
            ),
            Dist::List { values } => Some(values.clone()),
            _ => None,
        }
    }
    /// A draw from a random distribution.
    fn draw(&self, rng: &mut Rng) -> f64 {
        match *self {
            Dist::Uniform { min, max } => min + (max - min) * rng.uniform(),
            Dist::Normal {
                mean,
                std,
                min,
                max,
            } => {
                // Rejection; `load` made sure the interval holds at least
                // 1e-4 of the probability, so 1e6 tries all fail with
                // probability below e^-100.
                for _ in 0..1_000_000 {
                    let v = mean + std * rng.normal();
                    if (min..=max).contains(&v) {
                        return v;
                    }
                }
                mean.clamp(min, max)
            }
            Dist::LogNormal { median, sigma } => median * (sigma * rng.normal()).exp(),
            Dist::Grid { .. } | Dist::List { .. } => unreachable!("grid axes are not drawn"),
        }
    }
    /// A central value (for checking that the base takes the key).
    fn nominal(&self) -> f64 {
        match self {
            Dist::Uniform { min, max } => 0.5 * (min + max),
            Dist::Normal { mean, min, max, .. } => mean.clamp(*min, *max),
            Dist::LogNormal { median, .. } => *median,
            Dist::Grid { min, .. } => *min,
            Dist::List { values } => values[0],
        }
    }
}

/// Where a parameter goes.
#[derive(Clone, Debug, PartialEq)]
pub enum Target {
    /// An argument of the generator.
    Generator(String),
    /// A key of `[settings]`, `[solver]` or `[checks]`.
    Table { table: String, key: String },
    /// A key of every `[[joint]]`, `[[cable]]` or `[[element]]` entry whose
    /// name matches `pattern` (`*` any run of characters), of the element
    /// type `kind` when it is neither `joint`, `cable` nor `element`.
    Entries {
        kind: String,
        pattern: String,
        key: String,
    },
}

/// One parameter of the sweep.
#[derive(Clone, Debug, PartialEq)]
pub struct Param {
    /// As written in the file (`cable.drive.friction_mu`).
    pub key: String,
    /// Its Parquet column: `p_` and the key, `.` as `_`, `*` as `all`.
    pub column: String,
    pub target: Target,
    pub dist: Dist,
    /// The value multiplies the base's value.
    pub relative: bool,
    /// One draw per matching entry (a manufacturing tolerance) instead of one for all.
    pub each: bool,
    /// Line of the `[[param]]` in the sweep file.
    pub line: usize,
}

/// The base model.
#[derive(Clone, Debug, PartialEq)]
pub enum Base {
    /// A model file's text (and where it was read from).
    Model { path: PathBuf, text: String },
    /// `generate KIND` with these arguments.
    Generator {
        kind: String,
        args: Vec<(String, Option<String>)>,
    },
}

/// A sweep, checked.
#[derive(Clone, Debug)]
pub struct Sweep {
    pub name: String,
    pub seed: u64,
    /// Random draws per grid point (1 when not given and there is a grid).
    pub replicas: u64,
    pub max_wall_s: Option<f64>,
    /// `[sweep] history = true`: each sample's history (Parquet, every
    /// step) under the sweep directory's `history/INDEX/`.
    pub history: bool,
    pub base: Base,
    /// Keys every sample's model takes as they are (`[base.solver]` and the
    /// like): (table, its keys), over the base model's.
    pub fixed: Vec<(String, Table)>,
    pub params: Vec<Param>,
    /// The grid axes: (parameter index, values), first varying slowest.
    pub axes: Vec<(usize, Vec<f64>)>,
    /// The sweep file's text (kept with the results, for `rerun`).
    pub text: String,
}

/// One sample: its index, seed, the parameter values (column values) and
/// its model text, or why the model could not be made.
pub struct Sample {
    pub index: u64,
    pub seed: u64,
    pub values: Vec<f64>,
    pub model: Result<String, String>,
}

fn line_of(text: &str, offset: usize) -> usize {
    text[..offset.min(text.len())]
        .bytes()
        .filter(|b| *b == b'\n')
        .count()
        + 1
}

/// A glob with `*` for any run of characters.
pub fn glob(pattern: &str, name: &str) -> bool {
    match pattern.split_once('*') {
        None => pattern == name,
        Some((head, rest)) => {
            if !name.starts_with(head) {
                return false;
            }
            let name = &name[head.len()..];
            (0..=name.len())
                .filter(|&i| name.is_char_boundary(i))
                .any(|i| glob(rest, &name[i..]))
        }
    }
}

fn column_of(key: &str) -> String {
    let mut c = String::from("p_");
    for ch in key.chars() {
        match ch {
            '*' => c.push_str("all"),
            c2 if c2.is_ascii_alphanumeric() || c2 == '_' => c.push(c2),
            _ => c.push('_'),
        }
    }
    c
}

/// TOML value of a number: an integer when it is one (keys such as
/// `max_steps` take only integers; every float key takes integers too).
fn number(v: f64) -> Value {
    if v.fract() == 0.0 && v.abs() < 9.0e15 {
        Value::Integer(v as i64)
    } else {
        Value::Float(v)
    }
}

fn as_f64(v: &Value) -> Option<f64> {
    match v {
        Value::Float(f) => Some(*f),
        Value::Integer(i) => Some(*i as f64),
        _ => None,
    }
}

/// `generate` option value as text (Rust's shortest round-trip form).
fn arg_text(v: f64) -> String {
    format!("{v}")
}

impl Sweep {
    /// Reads and checks a sweep file.
    pub fn load(path: &Path, generator: &Generator) -> Result<Sweep, SweepError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| SweepError {
            file: file.clone(),
            line: None,
            message: format!("cannot read the sweep file ({e})"),
        })?;
        let dir = path.parent().unwrap_or(Path::new("."));
        Sweep::parse(&text, &file, dir, generator)
    }

    /// Parses and checks a sweep file's text; `dir` resolves the base model's path.
    pub fn parse(
        text: &str,
        file: &str,
        dir: &Path,
        generator: &Generator,
    ) -> Result<Sweep, SweepError> {
        let err = |line: Option<usize>, message: String| SweepError {
            file: file.to_string(),
            line,
            message,
        };
        let at = |span: std::ops::Range<usize>| Some(line_of(text, span.start));
        let spec: FileSpec = toml::from_str(text).map_err(|e| {
            err(
                e.span().map(|s| line_of(text, s.start)),
                format!(
                    "{}; see the sweep file format in docs/sweeps.md",
                    e.message().trim()
                ),
            )
        })?;
        let header = spec.sweep.get_ref();
        let base_line = at(spec.base.span());
        let b = spec.base.get_ref();
        let base = match (&b.model, &b.generator) {
            (Some(m), None) => {
                if !b.args.is_empty() {
                    return Err(err(
                        base_line,
                        "[base] `args` are the generator's; a base `model` takes none".into(),
                    ));
                }
                let p = dir.join(m.get_ref());
                let model_text = std::fs::read_to_string(&p).map_err(|e| {
                    err(
                        at(m.span()),
                        format!("[base] `model`: cannot read {} ({e})", p.display()),
                    )
                })?;
                Base::Model {
                    path: p,
                    text: model_text,
                }
            }
            (None, Some(g)) => {
                let mut args = Vec::new();
                for (k, v) in &b.args {
                    let value = match v.get_ref() {
                        Value::Boolean(true) => None,
                        Value::String(s) => Some(s.clone()),
                        other => match as_f64(other) {
                            Some(x) => Some(arg_text(x)),
                            None => {
                                return Err(err(
                                    at(v.span()),
                                    format!("[base.args] `{k}` = {other}: give a number, a string or `true` (a flag)"),
                                ))
                            }
                        },
                    };
                    args.push((k.clone(), value));
                }
                Base::Generator {
                    kind: g.get_ref().clone(),
                    args,
                }
            }
            _ => {
                return Err(err(
                    base_line,
                    "[base] needs exactly one of `model` (a model file) or `generator` (mast, ring or sail, with [base.args])".into(),
                ))
            }
        };
        let mut params: Vec<Param> = Vec::new();
        for ps in &spec.params {
            let p = ps.get_ref();
            let line = line_of(text, p.key.span().start);
            let key = p.key.get_ref().clone();
            let bad = |m: String| err(Some(line), format!("[[param]] `{key}`: {m}"));
            if params.iter().any(|q| q.key == key) {
                return Err(bad("given twice; one distribution per key".into()));
            }
            let parts: Vec<&str> = key.split('.').collect();
            let target = match parts.as_slice() {
                ["generator", arg] => {
                    if !matches!(base, Base::Generator { .. }) {
                        return Err(bad("the base is a model file, not a generator: scatter the model's keys instead (`cable.drive.tension_n`, `joint.*.mass_kg`)".into()));
                    }
                    Target::Generator(arg.to_string())
                }
                [t @ ("settings" | "solver" | "checks"), k] => Target::Table {
                    table: t.to_string(),
                    key: k.to_string(),
                },
                [kind, pattern, k] if !pattern.is_empty() && !k.is_empty() => Target::Entries {
                    kind: kind.to_string(),
                    pattern: pattern.to_string(),
                    key: k.to_string(),
                },
                _ => {
                    return Err(bad("unknown parameter: give `generator.ARG`, `settings.KEY`, `solver.KEY`, `checks.KEY`, or `KIND.NAME.KEY` with KIND joint, cable, element or an element type and NAME a name or a pattern with `*` (docs/sweeps.md)".into()))
                }
            };
            let need = |v: Option<f64>, name: &str| -> Result<f64, SweepError> {
                match v {
                    Some(x) if x.is_finite() => Ok(x),
                    Some(x) => Err(bad(format!("`{name}` = {x}: give a finite number"))),
                    None => Err(bad(format!(
                        "distribution `{}` needs `{name}`",
                        p.dist.get_ref()
                    ))),
                }
            };
            let range = |min: f64, max: f64| -> Result<(), SweepError> {
                if min < max {
                    Ok(())
                } else {
                    Err(bad(format!(
                        "the range min = {min} .. max = {max} is {}; give min < max",
                        if min == max { "empty" } else { "inverted" }
                    )))
                }
            };
            let allowed: &[&str] = match p.dist.get_ref().as_str() {
                "uniform" => &["min", "max"],
                "normal" => &["mean", "std", "min", "max"],
                "lognormal" => &["median", "sigma"],
                "grid" => &["min", "max", "n"],
                "list" => &["values"],
                other => {
                    return Err(err(
                        Some(line_of(text, p.dist.span().start)),
                        format!("[[param]] `{key}`: unknown distribution `{other}`; give uniform, normal, lognormal, grid or list"),
                    ))
                }
            };
            for (name, given) in [
                ("min", p.min.is_some()),
                ("max", p.max.is_some()),
                ("mean", p.mean.is_some()),
                ("std", p.std.is_some()),
                ("median", p.median.is_some()),
                ("sigma", p.sigma.is_some()),
                ("n", p.n.is_some()),
                ("values", p.values.is_some()),
            ] {
                if given && !allowed.contains(&name) {
                    return Err(bad(format!(
                        "`{name}` is not a field of distribution `{}` (it takes {})",
                        p.dist.get_ref(),
                        allowed.join(", ")
                    )));
                }
            }
            let dist = match p.dist.get_ref().as_str() {
                "uniform" => {
                    let (min, max) = (need(p.min, "min")?, need(p.max, "max")?);
                    range(min, max)?;
                    Dist::Uniform { min, max }
                }
                "normal" => {
                    let mean = need(p.mean, "mean")?;
                    let std = need(p.std, "std")?;
                    if std <= 0.0 {
                        return Err(bad(format!(
                            "`std` = {std}: a standard deviation must be > 0"
                        )));
                    }
                    let min = p.min.unwrap_or(f64::NEG_INFINITY);
                    let max = p.max.unwrap_or(f64::INFINITY);
                    if min.is_nan() || max.is_nan() {
                        return Err(bad("`min`/`max` is NaN".into()));
                    }
                    range(min, max)?;
                    // (the truncation must keep some of the distribution: within
                    // 3.7 std of the mean holds all but 1e-4)
                    if max < mean - 3.7 * std || min > mean + 3.7 * std {
                        return Err(bad(format!("the truncation min = {min} .. max = {max} lies more than 3.7 std from the mean {mean}: it holds almost none of the distribution")));
                    }
                    Dist::Normal {
                        mean,
                        std,
                        min,
                        max,
                    }
                }
                "lognormal" => {
                    let median = need(p.median, "median")?;
                    let sigma = need(p.sigma, "sigma")?;
                    if median <= 0.0 || sigma <= 0.0 {
                        return Err(bad(format!(
                            "median = {median}, sigma = {sigma}: both must be > 0 (sigma is the standard deviation of the logarithm)"
                        )));
                    }
                    Dist::LogNormal { median, sigma }
                }
                "grid" => {
                    let (min, max) = (need(p.min, "min")?, need(p.max, "max")?);
                    range(min, max)?;
                    let n =
                        p.n.ok_or_else(|| bad("distribution `grid` needs `n`".into()))?;
                    if !(2..=100_000).contains(&n) {
                        return Err(bad(format!("`n` = {n}: a grid has 2 to 100000 points")));
                    }
                    Dist::Grid { min, max, n }
                }
                _ => {
                    let values = p
                        .values
                        .clone()
                        .ok_or_else(|| bad("distribution `list` needs `values`".into()))?;
                    if values.is_empty() {
                        return Err(bad("`values` is empty; give at least one value".into()));
                    }
                    if values.iter().any(|v| !v.is_finite()) {
                        return Err(bad("`values` holds a NaN or infinite number".into()));
                    }
                    Dist::List { values }
                }
            };
            if p.each && !matches!(target, Target::Entries { .. }) {
                return Err(bad("`each` draws one value per matching entry: it applies to `KIND.NAME.KEY` parameters".into()));
            }
            if p.each && dist.axis().is_some() {
                return Err(bad(
                    "`each` needs a random distribution (uniform, normal, lognormal), not a grid axis"
                        .into(),
                ));
            }
            params.push(Param {
                column: column_of(&key),
                key,
                target,
                dist,
                relative: p.relative,
                each: p.each,
                line,
            });
        }
        let mut columns: Vec<&str> = params.iter().map(|p| p.column.as_str()).collect();
        columns.sort();
        if let Some(w) = columns.windows(2).find(|w| w[0] == w[1]) {
            return Err(err(
                None,
                format!("two parameters share the column `{}`; rename one", w[0]),
            ));
        }
        let axes: Vec<(usize, Vec<f64>)> = params
            .iter()
            .enumerate()
            .filter_map(|(i, p)| p.dist.axis().map(|a| (i, a)))
            .collect();
        let replicas =
            match &header.samples {
                Some(s) if *s.get_ref() == 0 || *s.get_ref() > 10_000_000 => {
                    return Err(err(
                        at(s.span()),
                        format!("[sweep] `samples` = {}: give 1 to 10000000", s.get_ref()),
                    ))
                }
                Some(s) => *s.get_ref(),
                None if !axes.is_empty() => 1,
                None => return Err(err(
                    at(spec.sweep.span()),
                    "[sweep] needs `samples` (random draws, per grid point when there is a grid)"
                        .into(),
                )),
            };
        let max_wall_s = match &header.max_wall_s {
            Some(w) if !(w.get_ref().is_finite() && *w.get_ref() > 0.0) => {
                return Err(err(
                    at(w.span()),
                    format!(
                        "[sweep] `max_wall_s` = {}: give a positive number of seconds",
                        w.get_ref()
                    ),
                ))
            }
            w => w.as_ref().map(|w| *w.get_ref()),
        };
        let sweep = Sweep {
            name: header.name.clone(),
            seed: header.seed,
            replicas,
            max_wall_s,
            history: header.history,
            base,
            fixed: [
                ("settings", &b.settings),
                ("solver", &b.solver),
                ("checks", &b.checks),
            ]
            .into_iter()
            .filter(|(_, t)| !t.is_empty())
            .map(|(n, t)| (n.to_string(), t.clone()))
            .collect(),
            params,
            axes,
            text: text.to_string(),
        };
        if sweep.len() > 10_000_000 {
            return Err(err(
                None,
                format!(
                    "the sweep has {} samples (grid points times `samples`); at most 10000000",
                    sweep.len()
                ),
            ));
        }
        sweep
            .check_keys(generator)
            .map_err(|(line, m)| err(line, m))?;
        Ok(sweep)
    }

    /// Number of samples: grid points times random draws per point.
    pub fn len(&self) -> u64 {
        self.axes
            .iter()
            .fold(self.replicas, |n, (_, a)| n.saturating_mul(a.len() as u64))
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The base model with its generator arguments replaced by `gen` and
    /// the fixed keys (`[base.solver]` and the like) set.
    fn base_text(
        &self,
        gen: &[(String, f64)],
        generator: &Generator,
    ) -> Result<String, (Option<String>, String)> {
        let text = self.base_text_unfixed(gen, generator)?;
        if self.fixed.is_empty() {
            return Ok(text);
        }
        let mut table: Table = toml::from_str(&text)
            .map_err(|e| (None, format!("the base model is not valid TOML: {e}")))?;
        for (name, keys) in &self.fixed {
            let section = table
                .entry(name.clone())
                .or_insert_with(|| Value::Table(Table::new()));
            let Value::Table(section) = section else {
                return Err((None, format!("`{name}` is not a table in the base model")));
            };
            for (k, v) in keys {
                section.insert(k.clone(), v.clone());
            }
        }
        toml::to_string(&table).map_err(|e| (None, format!("cannot write the model: {e}")))
    }

    fn base_text_unfixed(
        &self,
        gen: &[(String, f64)],
        generator: &Generator,
    ) -> Result<String, (Option<String>, String)> {
        match &self.base {
            Base::Model { text, .. } => Ok(text.clone()),
            Base::Generator { kind, args } => {
                let mut args = args.clone();
                for (k, v) in gen {
                    match args.iter_mut().find(|a| a.0 == *k) {
                        Some(a) => a.1 = Some(arg_text(*v)),
                        None => args.push((k.clone(), Some(arg_text(*v)))),
                    }
                }
                generator(kind, &args).map_err(|m| (None, m))
            }
        }
    }

    /// Checks, before any sample runs, that the base takes every parameter:
    /// the generator its arguments, the model its keys. Each parameter is
    /// set alone at a central value of its distribution, and the model
    /// written and read.
    fn check_keys(&self, generator: &Generator) -> Result<(), (Option<usize>, String)> {
        let base = self.base_text(&[], generator).map_err(|(_, m)| {
            (
                None,
                format!("the base generator refused its [base.args]: {m}"),
            )
        })?;
        let file = "the base model";
        crate::model::parse(&base, file)
            .map_err(|e| (None, format!("the base model is not valid: {e}")))?;
        let table: Table = toml::from_str(&base)
            .map_err(|e| (None, format!("the base model is not valid TOML: {e}")))?;
        for p in &self.params {
            let v = p.dist.nominal();
            let where_ = Some(p.line);
            let text = match &p.target {
                Target::Generator(arg) => {
                    if p.relative {
                        let has = matches!(&self.base, Base::Generator { args, .. } if args.iter().any(|a| a.0 == *arg && a.1.is_some()));
                        if !has {
                            return Err((where_, format!("[[param]] `{}`: `relative` multiplies the base's value, and [base.args] gives no `{arg}`", p.key)));
                        }
                    }
                    let base_v = self.generator_base_value(arg);
                    self.base_text(
                        &[(arg.clone(), if p.relative { base_v * v } else { v })],
                        generator,
                    )
                    .map_err(|(_, m)| {
                        (
                            where_,
                            format!("[[param]] `{}`: the generator does not take it: {m}", p.key),
                        )
                    })?
                }
                _ => {
                    let mut t = table.clone();
                    let mut rng = Rng::for_param(0, 0);
                    apply(&mut t, p, v, &mut rng)
                        .map_err(|m| (where_, format!("[[param]] `{}`: {m}", p.key)))?;
                    toml::to_string(&t).map_err(|e| (where_, e.to_string()))?
                }
            };
            crate::model::parse(&text, file).map_err(|e| {
                (
                    where_,
                    format!(
                        "[[param]] `{}` at its central value {v}: the model does not take it: {}",
                        p.key, e.message
                    ),
                )
            })?;
        }
        Ok(())
    }

    fn generator_base_value(&self, arg: &str) -> f64 {
        match &self.base {
            Base::Generator { args, .. } => args
                .iter()
                .find(|a| a.0 == arg)
                .and_then(|a| a.1.as_deref())
                .and_then(|s| s.parse().ok())
                .unwrap_or(f64::NAN),
            Base::Model { .. } => f64::NAN,
        }
    }

    /// Sample `index` (< `len()`): its values and model text.
    pub fn sample(&self, index: u64, generator: &Generator) -> Sample {
        let seed = sample_seed(self.seed, index);
        // grid coordinates: the first axis varies slowest
        let mut point = index / self.replicas;
        let mut grid: BTreeMap<usize, f64> = BTreeMap::new();
        for (i, axis) in self.axes.iter().rev() {
            let n = axis.len() as u64;
            grid.insert(*i, axis[(point % n) as usize]);
            point /= n;
        }
        let mut values = vec![f64::NAN; self.params.len()];
        let mut gen = Vec::new();
        // generator arguments first (the model they make takes the rest)
        for (i, p) in self.params.iter().enumerate() {
            if let Target::Generator(arg) = &p.target {
                let mut rng = Rng::for_param(seed, i);
                let v = grid
                    .get(&i)
                    .copied()
                    .unwrap_or_else(|| p.dist.draw(&mut rng));
                values[i] = v;
                let applied = if p.relative {
                    self.generator_base_value(arg) * v
                } else {
                    v
                };
                gen.push((arg.clone(), applied));
            }
        }
        let model = self
            .base_text(&gen, generator)
            .map_err(|(_, m)| format!("the generator refused this sample's arguments: {m}"))
            .and_then(|text| {
                let mut table: Table = toml::from_str(&text)
                    .map_err(|e| format!("the base model is not valid TOML: {e}"))?;
                for (i, p) in self.params.iter().enumerate() {
                    if matches!(p.target, Target::Generator(_)) {
                        continue;
                    }
                    let mut rng = Rng::for_param(seed, i);
                    values[i] = match grid.get(&i) {
                        Some(&v) => apply(&mut table, p, v, &mut rng)?,
                        None => {
                            let v = p.dist.draw(&mut rng);
                            apply(&mut table, p, v, &mut rng)?
                        }
                    };
                }
                toml::to_string(&table).map_err(|e| format!("cannot write the model: {e}"))
            });
        Sample {
            index,
            seed,
            values,
            model,
        }
    }
}

/// Sets parameter `p` to `v` in a model's table (with `each`, `v` is the
/// first entry's draw and `rng` draws the others). Returns the column value:
/// `v`, or with `each` the mean of the draws.
fn apply(table: &mut Table, p: &Param, v: f64, rng: &mut Rng) -> Result<f64, String> {
    match &p.target {
        Target::Generator(_) => unreachable!("generator arguments are applied by the generator"),
        Target::Table { table: t, key } => {
            let section = table
                .entry(t.clone())
                .or_insert_with(|| Value::Table(Table::new()));
            let Value::Table(section) = section else {
                return Err(format!("`{t}` is not a table in the base model"));
            };
            let new = if p.relative {
                let base = section.get(key).and_then(as_f64).ok_or_else(|| {
                    format!("`relative` multiplies the base's value, and the base model's [{t}] gives no number `{key}`")
                })?;
                base * v
            } else {
                v
            };
            section.insert(key.clone(), number(new));
            Ok(v)
        }
        Target::Entries { kind, pattern, key } => {
            let (array, type_filter) = match kind.as_str() {
                "joint" | "cable" | "element" => (kind.as_str(), None),
                other => ("element", Some(other)),
            };
            let entries = table
                .get_mut(array)
                .and_then(|a| a.as_array_mut())
                .ok_or_else(|| format!("the base model has no [[{array}]] entries"))?;
            let mut draws = Vec::new();
            for e in entries.iter_mut() {
                let Some(e) = e.as_table_mut() else { continue };
                let name_ok = e
                    .get("name")
                    .and_then(|n| n.as_str())
                    .is_some_and(|n| glob(pattern, n));
                let type_ok =
                    type_filter.is_none_or(|t| e.get("type").and_then(|x| x.as_str()) == Some(t));
                let Some(base) = e.get(key) else { continue };
                if !(name_ok && type_ok) {
                    continue;
                }
                let base = as_f64(base)
                    .ok_or_else(|| format!("`{key}` of `{}` is not a number", e["name"]))?;
                let d = if p.each && !draws.is_empty() {
                    p.dist.draw(rng)
                } else if p.each || draws.is_empty() {
                    v
                } else {
                    draws[0]
                };
                draws.push(d);
                e.insert(key.clone(), number(if p.relative { base * d } else { d }));
            }
            if draws.is_empty() {
                let what = match type_filter {
                    Some(t) => format!("no `{t}` element"),
                    None => format!("no [[{array}]] entry"),
                };
                return Err(format!(
                    "the base model has {what} named `{pattern}` with a `{key}`: a distribution on a key the base lacks"
                ));
            }
            Ok(if p.each {
                draws.iter().sum::<f64>() / draws.len() as f64
            } else {
                v
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn globs() {
        assert!(glob("*", "L0"));
        assert!(glob("O_diag*", "O_diag12"));
        assert!(!glob("O_diag*", "R0_diag"));
        assert!(glob("*_diag", "R0_diag"));
        assert!(glob("R*_d*g", "R10_diag"));
        assert!(!glob("L0", "L01"));
    }

    #[test]
    fn grid_axis_values() {
        let d = Dist::Grid {
            min: 1.0,
            max: 2.0,
            n: 5,
        };
        assert_eq!(d.axis().unwrap(), vec![1.0, 1.25, 1.5, 1.75, 2.0]);
    }

    /// `[base.solver]` (and `[base.settings]`, `[base.checks]`) keys reach
    /// every sample's model as they are, booleans too; a key the model does
    /// not take is refused before any sample runs, by name.
    #[test]
    fn fixed_base_keys_reach_every_sample() {
        let model = std::fs::read_to_string(
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/pantograph_mast.toml"),
        )
        .unwrap();
        let generator = move |_: &str, _: &[(String, Option<String>)]| Ok(model.clone());
        let generator: &Generator = &generator;
        let sweep_text = |solver: &str| {
            format!(
                "[sweep]\nname = \"s\"\nseed = 1\nsamples = 2\n\n[base]\ngenerator = \"mast\"\n\n\
                 [base.solver]\n{solver}\n\n[[param]]\nkey = \"settings.damping_n_s_per_m\"\n\
                 dist = \"uniform\"\nmin = 0.0\nmax = 1.0\n"
            )
        };
        let text = sweep_text("elastic_members = true\nmember_relaxation_s = 0.2");
        let sweep = Sweep::parse(&text, "s.toml", Path::new("."), generator).expect("parses");
        for i in 0..2 {
            let m = sweep.sample(i, generator).model.expect("a model");
            let parsed = crate::model::parse(&m, "sample").expect("loads").model;
            assert!(parsed.solver.elastic_members);
            assert_eq!(parsed.solver.member_relaxation_s, 0.2);
        }
        let bad = sweep_text("no_such_solver_key = 1.0");
        let e = Sweep::parse(&bad, "s.toml", Path::new("."), generator)
            .err()
            .expect("refused");
        assert!(e.message.contains("no_such_solver_key"), "{}", e.message);
    }

    #[test]
    fn columns() {
        assert_eq!(column_of("joint.*.mass_kg"), "p_joint_all_mass_kg");
        assert_eq!(
            column_of("cable.drive.friction_mu"),
            "p_cable_drive_friction_mu"
        );
    }
}
