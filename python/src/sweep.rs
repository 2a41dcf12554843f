//! Sweeps: the library's sweep spec and samples (`truss_deploy::sweep`) with
//! the CLI's generator, so that a sample's row is the one `truss-deploy
//! sweep` writes. A work item is (sweep text, file, directory, index): each
//! worker parses the sweep once (a per-process cache) and runs its samples.

use crate::{json_loads, SweepError};
use pyo3::prelude::*;
use pyo3::types::PyBytes;
use std::collections::HashMap;
use std::path::Path;
use std::sync::{Arc, Mutex};
use truss_deploy::sweep::row::Row;
use truss_deploy::sweep::spec::Sweep;
use truss_deploy::sweep::{self as lib, rng};

type Key = (String, String, String);
static PARSED: Mutex<Option<HashMap<Key, Arc<Sweep>>>> = Mutex::new(None);

/// The sweep of `text` (read as the file `file`, its base model's path
/// relative to `dir`), parsed once per process.
fn parsed(text: &str, file: &str, dir: &str) -> PyResult<Arc<Sweep>> {
    let key = (text.to_string(), file.to_string(), dir.to_string());
    {
        let cache = PARSED.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(s) = cache.as_ref().and_then(|c| c.get(&key)) {
            return Ok(s.clone());
        }
    }
    let s = Sweep::parse(
        text,
        file,
        Path::new(dir),
        &truss_deploy::cli::sweep_generator,
    )
    .map_err(|e| SweepError::new_err(e.to_string()))?;
    let s = Arc::new(s);
    let mut cache = PARSED.lock().unwrap_or_else(|e| e.into_inner());
    let c = cache.get_or_insert_with(HashMap::new);
    if c.len() > 16 {
        c.clear();
    }
    c.insert(key, s.clone());
    Ok(s)
}

fn row_json(r: &Row) -> String {
    serde_json::to_string(r).expect("row serializes")
}

/// What a sweep is: name, samples, keys, columns, id, seed (SweepError when
/// it does not parse: the file, the line, the key).
#[pyfunction]
fn _sweep_info<'py>(
    py: Python<'py>,
    text: &str,
    file: &str,
    dir: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let s = py.detach(|| parsed(text, file, dir))?;
    let m = lib::meta(&s, Path::new(file));
    let info = serde_json::json!({
        "name": m.name,
        "sweep_id": m.sweep_id,
        "samples": m.samples,
        "keys": m.keys,
        "columns": m.columns,
        "seed": s.seed,
        "max_wall_s": s.max_wall_s,
    });
    json_loads(py, &info.to_string())
}

/// Runs sample `index` to its row (JSON), with the GIL released; an error
/// or a panic in the sample is its row.
#[pyfunction]
#[pyo3(signature = (text, file, dir, index, max_wall_s = None))]
fn _sweep_run_sample(
    py: Python<'_>,
    text: &str,
    file: &str,
    dir: &str,
    index: u64,
    max_wall_s: Option<f64>,
) -> PyResult<String> {
    py.detach(|| {
        let s = parsed(text, file, dir)?;
        if index >= s.len() {
            return Err(pyo3::exceptions::PyIndexError::new_err(format!(
                "sample {index}: the sweep has {} samples",
                s.len()
            )));
        }
        let r = lib::run_sample(
            &s,
            index,
            &truss_deploy::cli::sweep_generator,
            max_wall_s.or(s.max_wall_s),
        );
        Ok(row_json(&r))
    })
}

/// Runs samples `indices` in this process on `jobs` threads (the CLI's
/// pool), with the GIL released; their rows (JSON), in the order given.
#[pyfunction]
#[pyo3(signature = (text, file, dir, indices, jobs, max_wall_s = None))]
fn _sweep_run_local(
    py: Python<'_>,
    text: &str,
    file: &str,
    dir: &str,
    indices: Vec<u64>,
    jobs: usize,
    max_wall_s: Option<f64>,
) -> PyResult<Vec<String>> {
    use rayon::prelude::*;
    py.detach(|| {
        let s = parsed(text, file, dir)?;
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(jobs.max(1))
            .build()
            .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(e.to_string()))?;
        let wall = max_wall_s.or(s.max_wall_s);
        Ok(pool.install(|| {
            indices
                .par_iter()
                .with_max_len(1)
                .map(|&i| {
                    row_json(&lib::run_sample(
                        &s,
                        i,
                        &truss_deploy::cli::sweep_generator,
                        wall,
                    ))
                })
                .collect()
        }))
    })
}

/// The row of a sample whose worker failed outside the library (a lost
/// process, an exception in the executor): stop_reason `reason`.
#[pyfunction]
fn _sweep_failed_row(
    text: &str,
    file: &str,
    dir: &str,
    index: u64,
    reason: &str,
    message: String,
) -> PyResult<String> {
    let s = parsed(text, file, dir)?;
    let seed = rng::sample_seed(s.seed, index);
    Ok(row_json(&Row::failed(
        index,
        seed,
        vec![f64::NAN; s.params.len()],
        reason,
        message,
    )))
}

/// The rows (JSON, any order) as `results.parquet`'s bytes and the
/// sweep's summary (`summary.json`, as JSON text).
#[pyfunction]
fn _sweep_table<'py>(
    py: Python<'py>,
    text: &str,
    file: &str,
    dir: &str,
    rows: Vec<String>,
) -> PyResult<(Bound<'py, PyBytes>, String)> {
    let s = parsed(text, file, dir)?;
    let m = lib::meta(&s, Path::new(file));
    let mut parsed_rows: Vec<Row> = rows
        .iter()
        .map(|r| serde_json::from_str(r))
        .collect::<Result<_, _>>()
        .map_err(|e| pyo3::exceptions::PyValueError::new_err(format!("not a sweep row: {e}")))?;
    parsed_rows.sort_by_key(|r| r.index);
    let bytes =
        lib::results_parquet(&m, &parsed_rows).map_err(|f| SweepError::new_err(f.message))?;
    let summary = lib::stats::summarize(&m.name, &m.sweep_id, &m.keys, &m.columns, &parsed_rows);
    Ok((
        PyBytes::new(py, &bytes),
        serde_json::to_string(&summary).expect("summary serializes"),
    ))
}

/// A sweep described as JSON (the sweep file's tables and keys) as the
/// sweep file's TOML text.
#[pyfunction]
fn _sweep_toml_from_json(json: &str) -> PyResult<String> {
    let v: toml::Value =
        serde_json::from_str(json).map_err(|e| SweepError::new_err(format!("<dict>: {e}")))?;
    toml::to_string(&v).map_err(|e| {
        SweepError::new_err(format!(
            "<dict>: {e}; give the sweep file's tables and keys (docs/sweeps.md)"
        ))
    })
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(_sweep_info, m)?)?;
    m.add_function(wrap_pyfunction!(_sweep_run_sample, m)?)?;
    m.add_function(wrap_pyfunction!(_sweep_run_local, m)?)?;
    m.add_function(wrap_pyfunction!(_sweep_failed_row, m)?)?;
    m.add_function(wrap_pyfunction!(_sweep_table, m)?)?;
    m.add_function(wrap_pyfunction!(_sweep_toml_from_json, m)?)?;
    Ok(())
}
