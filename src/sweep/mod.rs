//! Deployment sweeps (docs/sweeps.md): many samples of a model with scattered
//! parameters, run on a pool of workers, one row per sample whatever
//! happened, written as each sample finishes so that a killed sweep resumes
//! where it was; shards for a cluster, merged into one result.
//!
//! Layout of a sweep's directory:
//! - `sweep.json`: what the sweep is (its file, its base model, its id);
//! - `samples/NNNNNNNNN.json`: each finished sample's row (written atomically);
//! - `parts/part-I-of-N.jsonl`: a shard's rows (`--shard I/N`);
//! - `results.parquet`, `summary.json`: all rows, and their statistics.
//!
//! Built as the crate `truss-deploy-sweep` (`crates/sweep/Cargo.toml`); the
//! `truss_deploy` library re-exports it as `truss_deploy::sweep`.

// the core's modules under the paths the sweep's files use (`crate::model`, ...)
use truss_deploy_core::{files, model, run, solver};

pub mod history;
pub mod parquet_out;
pub mod rng;
pub mod row;
pub mod spec;
pub mod stats;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use rayon::prelude::*;
use row::Row;
use serde::{Deserialize, Serialize};
use spec::{Base, Generator, Sweep};
use std::path::{Path, PathBuf};

/// A failure with its exit status (2 bad input, 1 a failed run).
#[derive(Debug)]
pub struct SweepFailure {
    pub code: i32,
    pub message: String,
}

fn input(m: impl Into<String>) -> SweepFailure {
    SweepFailure {
        code: 2,
        message: m.into(),
    }
}
fn failed(m: impl Into<String>) -> SweepFailure {
    SweepFailure {
        code: 1,
        message: m.into(),
    }
}

/// `sweep.json`: what a sweep directory holds.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Meta {
    /// A hash of the sweep file and its base model (and this program's version).
    pub sweep_id: String,
    pub name: String,
    pub samples: u64,
    pub keys: Vec<String>,
    pub columns: Vec<String>,
    /// The sweep file as given, its directory (the base model's path is
    /// relative to it), and its text.
    pub sweep_file: String,
    pub sweep_dir: String,
    pub sweep_text: String,
}

/// The first line of a part file.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct PartHeader {
    pub meta: Meta,
    pub shard: u64,
    pub of: u64,
}

fn fnv(bytes: &[u8], mut h: u64) -> u64 {
    for b in bytes {
        h ^= *b as u64;
        h = h.wrapping_mul(0x0100_0000_01B3);
    }
    h
}

/// The id of a sweep: its file's text, its base (model text or generator
/// and arguments) and the program's version, hashed.
pub fn sweep_id(s: &Sweep) -> String {
    let mut h = fnv(s.text.as_bytes(), 0xCBF2_9CE4_8422_2325);
    h = fnv(b"\0", h);
    match &s.base {
        Base::Model { text, .. } => h = fnv(text.as_bytes(), h),
        Base::Generator { kind, args } => h = fnv(format!("{kind}{args:?}").as_bytes(), h),
    }
    h = fnv(env!("CARGO_PKG_VERSION").as_bytes(), h);
    format!("{:016x}", rng::mix(h))
}

pub fn meta(s: &Sweep, file: &Path) -> Meta {
    let dir = file.parent().unwrap_or(Path::new("."));
    let dir = dir.canonicalize().unwrap_or(dir.to_path_buf());
    Meta {
        sweep_id: sweep_id(s),
        name: s.name.clone(),
        samples: s.len(),
        keys: s.params.iter().map(|p| p.key.clone()).collect(),
        columns: s.params.iter().map(|p| p.column.clone()).collect(),
        sweep_file: file.display().to_string(),
        sweep_dir: dir.display().to_string(),
        sweep_text: s.text.clone(),
    }
}

fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), SweepFailure> {
    crate::files::write_atomic(path, bytes).map_err(failed)
}

/// A sample's row: atomic (a temporary file renamed), not synced, so that a
/// killed sweep keeps every finished row without paying an fsync per sample.
fn write_row(path: &Path, bytes: &[u8]) -> Result<(), SweepFailure> {
    crate::files::write_atomic_with(path, bytes, false).map_err(failed)
}

pub fn sample_path(dir: &Path, index: u64) -> PathBuf {
    dir.join("samples").join(format!("{index:09}.json"))
}

/// Reads `sweep.json` of a sweep directory.
pub fn read_meta(dir: &Path) -> Result<Meta, SweepFailure> {
    let p = dir.join("sweep.json");
    let text = std::fs::read_to_string(&p).map_err(|e| {
        input(format!(
            "cannot read {} ({e}): is {} a sweep's directory?",
            p.display(),
            dir.display()
        ))
    })?;
    serde_json::from_str(&text).map_err(|e| input(format!("{}: {e}", p.display())))
}

/// Makes `dir` the sweep's directory: creates it, or checks that it holds
/// the same sweep (a restart), and writes `sweep.json`.
pub fn prepare_dir(dir: &Path, m: &Meta) -> Result<(), SweepFailure> {
    std::fs::create_dir_all(dir.join("samples"))
        .map_err(|e| input(format!("cannot create {}: {e}", dir.display())))?;
    if dir.join("sweep.json").exists() {
        let old = read_meta(dir)?;
        if old.sweep_id != m.sweep_id {
            return Err(input(format!(
                "{} holds another sweep (`{}`, id {}; this one is `{}`, id {}): give another -o, or remove it",
                dir.display(),
                old.name,
                old.sweep_id,
                m.name,
                m.sweep_id
            )));
        }
        return Ok(());
    }
    let text = serde_json::to_string_pretty(m).expect("meta serializes") + "\n";
    write_atomic(&dir.join("sweep.json"), text.as_bytes())
}

/// The row of sample `index` if it finished (None when absent or unreadable,
/// as a file a foreign hand damaged: the sample is then run again).
pub fn read_row(dir: &Path, index: u64) -> Option<Row> {
    let text = std::fs::read_to_string(sample_path(dir, index)).ok()?;
    serde_json::from_str(&text).ok()
}

/// Where sample `index` of the sweep in `dir` writes its history
/// (`[sweep] history`): `DIR/history/INDEX/`, INDEX of nine digits.
pub fn history_dir(dir: &Path, index: u64) -> PathBuf {
    dir.join("history").join(format!("{index:09}"))
}

/// Runs one sample to its row; a panic in it becomes a row too.
pub fn run_sample(sweep: &Sweep, index: u64, gen: &Generator, max_wall_s: Option<f64>) -> Row {
    run_sample_recorded(sweep, index, gen, max_wall_s, None)
}

/// As [`run_sample`], writing the sample's history into `history` when given.
pub fn run_sample_recorded(
    sweep: &Sweep,
    index: u64,
    gen: &Generator,
    max_wall_s: Option<f64>,
    history: Option<&Path>,
) -> Row {
    let sample = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        let s = sweep.sample(index, gen);
        let seed = s.seed;
        let values = s.values.clone();
        let row = match &s.model {
            Ok(text) => {
                row::run_model_recorded(index, seed, values.clone(), text, max_wall_s, history)
            }
            Err(m) => Row::failed(index, seed, values.clone(), "invalid", m.clone()),
        };
        (row, seed, values)
    }));
    match sample {
        Ok((row, _, _)) => row,
        Err(p) => {
            let what = p
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| p.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "a panic".into());
            let seed = rng::sample_seed(sweep.seed, index);
            Row::failed(
                index,
                seed,
                vec![f64::NAN; sweep.params.len()],
                "panic",
                format!("sample {index} panicked: {what}"),
            )
        }
    }
}

/// Without a terminal, the shortest interval between progress lines (s).
const LOG_EVERY_S: f64 = 10.0;

/// How to run a sweep.
#[derive(Clone, Copy, Debug)]
pub struct RunOptions {
    pub jobs: usize,
    /// `--shard I/N`: the samples whose index is I modulo N.
    pub shard: Option<(u64, u64)>,
    /// Per-sample wall limit (s), over the sweep file's.
    pub max_wall_s: Option<f64>,
    pub progress: bool,
}

/// Runs the samples of the sweep (or of its shard) that have no row yet in
/// `dir`; returns (run now, already there).
pub fn run_samples(
    dir: &Path,
    sweep: &Sweep,
    gen: &Generator,
    opts: RunOptions,
) -> Result<(u64, u64), SweepFailure> {
    let mine: Vec<u64> = (0..sweep.len())
        .filter(|i| opts.shard.is_none_or(|(k, n)| i % n == k))
        .collect();
    let todo: Vec<u64> = mine
        .iter()
        .copied()
        .filter(|&i| read_row(dir, i).is_none())
        .collect();
    let done = mine.len() as u64 - todo.len() as u64;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.jobs)
        .build()
        .map_err(|e| failed(format!("cannot start {} workers: {e}", opts.jobs)))?;
    let bar = ProgressBar::with_draw_target(
        Some(todo.len() as u64),
        if opts.progress {
            ProgressDrawTarget::stderr()
        } else {
            ProgressDrawTarget::hidden()
        },
    );
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} [{bar:30}] {pos}/{len} samples, {per_sec}, {elapsed} elapsed, ETA {eta} {msg}",
        )
        .expect("valid template")
        .progress_chars("=> "),
    );
    if done > 0 {
        bar.println(format!(
            "{done} samples already have rows in {}: skipped",
            dir.display()
        ));
    }
    let max_wall_s = opts.max_wall_s.or(sweep.max_wall_s);
    // (without a terminal, as in a log file or a cluster job: a plain line at most every
    // `LOG_EVERY_S`, and at the last sample)
    let log = std::sync::Mutex::new((0u64, std::time::Instant::now()));
    let started = std::time::Instant::now();
    let (total, of) = (todo.len() as u64, mine.len());
    let errors: Vec<String> = pool.install(|| {
        todo.par_iter()
            .with_max_len(1)
            .filter_map(|&i| {
                let hist = sweep.history.then(|| history_dir(dir, i));
                let row = run_sample_recorded(sweep, i, gen, max_wall_s, hist.as_deref());
                let text = serde_json::to_string(&row).expect("row serializes") + "\n";
                bar.inc(1);
                if !opts.progress {
                    let mut l = log.lock().unwrap_or_else(|e| e.into_inner());
                    l.0 += 1;
                    if l.0 == total || l.1.elapsed().as_secs_f64() >= LOG_EVERY_S {
                        l.1 = std::time::Instant::now();
                        eprintln!(
                            "{}/{of} samples have rows, {:.0} s elapsed (sample {i}: {})",
                            done + l.0,
                            started.elapsed().as_secs_f64(),
                            row.stop_reason
                        );
                    }
                }
                write_row(&sample_path(dir, i), text.as_bytes())
                    .err()
                    .map(|f| f.message)
            })
            .collect()
    });
    bar.finish_and_clear();
    if let Some(e) = errors.first() {
        return Err(failed(format!(
            "{} sample rows could not be written (first: {e})",
            errors.len()
        )));
    }
    Ok((todo.len() as u64, done))
}

/// The rows of `indices`, all of which must have finished.
pub fn collect_rows(
    dir: &Path,
    indices: impl Iterator<Item = u64>,
) -> Result<Vec<Row>, SweepFailure> {
    let mut rows = Vec::new();
    for i in indices {
        rows.push(read_row(dir, i).ok_or_else(|| {
            failed(format!(
                "sample {i} has no row in {}",
                sample_path(dir, i).display()
            ))
        })?);
    }
    Ok(rows)
}

pub fn part_path(dir: &Path, shard: u64, of: u64) -> PathBuf {
    dir.join("parts")
        .join(format!("part-{shard}-of-{of}.jsonl"))
}

/// Writes a shard's part file: its header, then its rows, one JSON a line.
pub fn write_part(
    dir: &Path,
    m: &Meta,
    shard: u64,
    of: u64,
    rows: &[Row],
) -> Result<PathBuf, SweepFailure> {
    std::fs::create_dir_all(dir.join("parts"))
        .map_err(|e| failed(format!("cannot create {}/parts: {e}", dir.display())))?;
    let mut text = serde_json::to_string(&PartHeader {
        meta: m.clone(),
        shard,
        of,
    })
    .expect("header serializes")
        + "\n";
    for r in rows {
        text += &(serde_json::to_string(r).expect("row serializes") + "\n");
    }
    let p = part_path(dir, shard, of);
    write_atomic(&p, text.as_bytes())?;
    Ok(p)
}

/// Reads every part file in `dir/parts`: the sweep's meta and all its rows
/// in index order. Refuses parts of different sweeps or shard counts, a
/// missing shard, and rows that do not cover every sample exactly once.
pub fn read_parts(dir: &Path) -> Result<(Meta, Vec<Row>), SweepFailure> {
    let pdir = dir.join("parts");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&pdir)
        .map_err(|e| {
            input(format!(
                "cannot read {} ({e}): no part files to merge",
                pdir.display()
            ))
        })?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "jsonl"))
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(input(format!(
            "{} holds no part files (part-I-of-N.jsonl)",
            pdir.display()
        )));
    }
    let mut first: Option<(PartHeader, PathBuf)> = None;
    let mut shards = std::collections::BTreeSet::new();
    let mut rows: Vec<Row> = Vec::new();
    for f in &files {
        let text = std::fs::read_to_string(f)
            .map_err(|e| input(format!("cannot read {}: {e}", f.display())))?;
        let mut lines = text.lines();
        let header: PartHeader = lines
            .next()
            .and_then(|l| serde_json::from_str(l).ok())
            .ok_or_else(|| input(format!("{}:1: not a part file's header", f.display())))?;
        if let Some((h0, f0)) = &first {
            if h0.meta.sweep_id != header.meta.sweep_id || h0.of != header.of {
                return Err(input(format!(
                    "{} is part of another sweep (`{}`, id {}, {} shards) than {} (`{}`, id {}, {} shards): parts of different sweeps do not merge",
                    f.display(), header.meta.name, header.meta.sweep_id, header.of,
                    f0.display(), h0.meta.name, h0.meta.sweep_id, h0.of
                )));
            }
        } else {
            first = Some((header.clone(), f.clone()));
        }
        if !shards.insert(header.shard) {
            return Err(input(format!(
                "shard {} appears twice ({})",
                header.shard,
                f.display()
            )));
        }
        for (n, l) in lines.enumerate() {
            let r: Row = serde_json::from_str(l)
                .map_err(|e| input(format!("{}:{}: not a row: {e}", f.display(), n + 2)))?;
            if r.index % header.of != header.shard {
                return Err(input(format!(
                    "{}:{}: sample {} does not belong to shard {}/{}",
                    f.display(),
                    n + 2,
                    r.index,
                    header.shard,
                    header.of
                )));
            }
            rows.push(r);
        }
    }
    let (h, _) = first.expect("at least one part");
    let missing: Vec<u64> = (0..h.of).filter(|s| !shards.contains(s)).collect();
    if !missing.is_empty() {
        return Err(failed(format!(
            "shards {missing:?} of {} have no part file in {}: run them first",
            h.of,
            pdir.display()
        )));
    }
    rows.sort_by_key(|r| r.index);
    let covered = rows.len() as u64 == h.meta.samples
        && rows.iter().enumerate().all(|(i, r)| r.index == i as u64);
    if !covered {
        return Err(failed(format!(
            "the parts hold {} rows for {} samples, not one per sample",
            rows.len(),
            h.meta.samples
        )));
    }
    Ok((h.meta, rows))
}

/// Writes `results.parquet` and `summary.json` of all rows; the summary.
pub fn write_results(dir: &Path, m: &Meta, rows: &[Row]) -> Result<stats::Summary, SweepFailure> {
    let summary = stats::summarize(&m.name, &m.sweep_id, &m.keys, &m.columns, rows);
    let bytes = results_parquet(m, rows)?;
    write_atomic(&dir.join("results.parquet"), &bytes)?;
    let text = serde_json::to_string_pretty(&summary).expect("summary serializes") + "\n";
    write_atomic(&dir.join("summary.json"), text.as_bytes())?;
    Ok(summary)
}

/// `results.parquet` of all rows, as bytes: one row per sample, the sweep's
/// name, id and parameters in its key-value metadata (also the Python
/// package's sweep table).
pub fn results_parquet(m: &Meta, rows: &[Row]) -> Result<Vec<u8>, SweepFailure> {
    let metadata = vec![
        ("truss_deploy.sweep".to_string(), m.name.clone()),
        ("truss_deploy.sweep_id".to_string(), m.sweep_id.clone()),
        (
            "truss_deploy.params".to_string(),
            serde_json::to_string(&m.keys.iter().zip(&m.columns).collect::<Vec<_>>())
                .expect("keys serialize"),
        ),
    ];
    parquet_out::to_parquet(rows, &m.columns, &metadata).map_err(failed)
}

/// Rebuilds a sweep from its directory's `sweep.json` (for `rerun`), and
/// checks that its base is still the one the rows were computed from.
pub fn sweep_of_dir(dir: &Path, gen: &Generator) -> Result<(Meta, Sweep), SweepFailure> {
    let m = read_meta(dir)?;
    let s = Sweep::parse(&m.sweep_text, &m.sweep_file, Path::new(&m.sweep_dir), gen)
        .map_err(|e| input(e.to_string()))?;
    if sweep_id(&s) != m.sweep_id {
        return Err(input(format!(
            "the base of sweep `{}` changed since its rows were computed (id {} now, {} then): `rerun` would not reproduce them",
            m.name,
            sweep_id(&s),
            m.sweep_id
        )));
    }
    Ok((m, s))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A generator that writes the bundled mast, and panics when asked for
    /// a tension of 2 N (a worker's panic, injected).
    fn mast_or_panic(_kind: &str, args: &[(String, Option<String>)]) -> Result<String, String> {
        if args
            .iter()
            .any(|(k, v)| k == "tension_n" && v.as_deref() == Some("2"))
        {
            panic!("injected failure at tension 2 N");
        }
        Ok(include_str!("../../models/pantograph_mast.toml").to_string())
    }

    #[test]
    fn a_panic_in_a_sample_is_its_row() {
        let text = "[sweep]\nname = \"p\"\nseed = 1\n[base]\ngenerator = \"mast\"\n\
                    [[param]]\nkey = \"generator.tension_n\"\ndist = \"list\"\nvalues = [1, 2]\n";
        let s = Sweep::parse(text, "p.toml", Path::new("."), &mast_or_panic).expect("valid sweep");
        assert_eq!(s.len(), 2);
        let ok = run_sample(&s, 0, &mast_or_panic, None);
        assert_eq!(ok.stop_reason, "deployed", "{}", ok.stop_message);
        let bad = run_sample(&s, 1, &mast_or_panic, None);
        assert_eq!(bad.stop_reason, "panic");
        assert!(
            bad.stop_message.contains("injected failure at tension 2 N"),
            "{}",
            bad.stop_message
        );
        assert_eq!(bad.index, 1);
        assert_eq!(bad.seed, rng::sample_seed(1, 1));
        assert!(!bad.deployed && bad.deploy_time_s.is_none());
    }
}
