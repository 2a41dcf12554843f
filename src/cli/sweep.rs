//! `truss-deploy sweep`: Monte-Carlo and grid studies of a model
//! (docs/sweeps.md). `sweep SWEEP.toml -o DIR [--jobs N] [--shard I/N]`,
//! `sweep merge DIR`, `sweep rerun DIR INDEX`.
//!
//! Exit status: 0 when every sample ran to a row as asked (deployed or not:
//! deployed, end_time, stalled); 1 when some sample's row is an error, an
//! invalid model or a panic (every row and the summary are still written), or
//! a result could not be written; 2 on bad input, before any sample runs.

use super::{sweep_plot, Failure};
use crate::sweep::row::{ran_as_asked, Row};
use crate::sweep::spec::Sweep;
use crate::sweep::{self, stats::Summary, Meta, RunOptions, SweepFailure};
use clap::{Args, Subcommand};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};

#[derive(Args, Debug)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct SweepArgs {
    #[command(subcommand)]
    cmd: Option<SweepCmd>,
    /// The sweep file (format: docs/sweeps.md).
    #[arg(required = true, value_name = "SWEEP.toml")]
    sweep: Option<PathBuf>,
    /// The sweep's directory: sample rows, results.parquet, summary.json, plots/.
    #[arg(short = 'o', long = "output", required = true, value_name = "DIR")]
    output: Option<PathBuf>,
    /// Workers (default: every core).
    #[arg(long)]
    jobs: Option<usize>,
    /// Run shard I of N (I from 0 to N-1: the samples whose index is I modulo N) and
    /// write its part file; `sweep merge DIR` combines the parts.
    #[arg(long, value_name = "I/N")]
    shard: Option<String>,
    /// Wall-clock limit of each sample (s; over the sweep file's `max_wall_s`): a
    /// sample that reaches it is a row with stop_reason `error`.
    #[arg(long, allow_negative_numbers = true)]
    max_wall_s: Option<f64>,
}

#[derive(Subcommand, Debug)]
enum SweepCmd {
    /// Combine the part files of a sharded sweep (DIR/parts) into results.parquet,
    /// summary.json and plots.
    Merge { dir: PathBuf },
    /// Write sample INDEX's model file (DIR/rerun/sample-INDEX.toml), run it, and
    /// compare its row with the sweep's (exit 1 if they differ apart from wall time).
    Rerun { dir: PathBuf, index: u64 },
}

fn from(f: SweepFailure) -> Failure {
    Failure {
        code: f.code,
        message: f.message,
    }
}

/// The generator of a sweep's base: `generate KIND --ARG=VALUE ...` as the
/// `generate` command makes it (`super::generate_from_args`); public for the
/// sweeps of the Python package, whose rows are the command's.
pub fn generator(kind: &str, args: &[(String, Option<String>)]) -> Result<String, String> {
    super::generate_from_args(kind, args).map(|doc| doc.to_toml())
}

fn shard_of(s: &str) -> Result<(u64, u64), Failure> {
    let bad = || {
        Failure::input(format!(
            "--shard {s}: give I/N with 0 <= I < N (I the shard, from 0; N the number of shards)"
        ))
    };
    let (i, n) = s.split_once('/').ok_or_else(bad)?;
    let (i, n): (u64, u64) = (
        i.trim().parse().map_err(|_| bad())?,
        n.trim().parse().map_err(|_| bad())?,
    );
    if n == 0 || i >= n {
        return Err(bad());
    }
    Ok((i, n))
}

pub fn run(a: SweepArgs) -> Result<(), Failure> {
    match a.cmd {
        Some(SweepCmd::Merge { dir }) => merge(&dir),
        Some(SweepCmd::Rerun { dir, index }) => rerun(&dir, index),
        None => {
            let file = a.sweep.expect("clap requires SWEEP.toml");
            let dir = a.output.expect("clap requires -o");
            run_sweep(&file, &dir, a.jobs, a.shard.as_deref(), a.max_wall_s)
        }
    }
}

fn run_sweep(
    file: &Path,
    dir: &Path,
    jobs: Option<usize>,
    shard: Option<&str>,
    max_wall_s: Option<f64>,
) -> Result<(), Failure> {
    let shard = shard.map(shard_of).transpose()?;
    if let Some(w) = max_wall_s {
        if !(w.is_finite() && w > 0.0) {
            return Err(Failure::input(format!(
                "--max-wall-s {w}: give a positive number of seconds"
            )));
        }
    }
    let jobs = match jobs {
        Some(0) => return Err(Failure::input("--jobs 0: give at least 1 worker")),
        Some(j) => j,
        None => std::thread::available_parallelism().map_or(1, |n| n.get()),
    };
    let s = Sweep::load(file, &generator).map_err(|e| Failure::input(e.to_string()))?;
    let m = sweep::meta(&s, file);
    sweep::prepare_dir(dir, &m).map_err(from)?;
    say!(
        "sweep `{}`: {} samples{}, {} parameters, {jobs} workers, id {}",
        m.name,
        m.samples,
        shard.map_or(String::new(), |(i, n)| format!(" (shard {i}/{n})")),
        m.keys.len(),
        m.sweep_id
    );
    let opts = RunOptions {
        jobs,
        shard,
        max_wall_s,
        progress: std::io::stderr().is_terminal(),
    };
    let t0 = std::time::Instant::now();
    let (ran, skipped) = sweep::run_samples(dir, &s, &generator, opts).map_err(from)?;
    say!(
        "ran {ran} samples in {:.1} s ({skipped} had rows already)",
        t0.elapsed().as_secs_f64()
    );
    match shard {
        Some((i, n)) => {
            let rows =
                sweep::collect_rows(dir, (0..s.len()).filter(|k| k % n == i)).map_err(from)?;
            let p = sweep::write_part(dir, &m, i, n, &rows).map_err(from)?;
            say!("wrote {} ({} rows)", p.display(), rows.len());
            status(&rows)
        }
        None => {
            let rows = sweep::collect_rows(dir, 0..s.len()).map_err(from)?;
            finish(dir, &m, &rows)
        }
    }
}

/// The exit status of a sweep's rows.
fn status(rows: &[Row]) -> Result<(), Failure> {
    let bad: Vec<&Row> = rows
        .iter()
        .filter(|r| !ran_as_asked(&r.stop_reason))
        .collect();
    match bad.first() {
        None => Ok(()),
        Some(r) => Err(Failure::run(format!(
            "{} of {} samples did not run as asked (stop_reason error, invalid or panic); first, sample {}: {}",
            bad.len(),
            rows.len(),
            r.index,
            r.stop_message
        ))),
    }
}

/// Results, summary and plots of all rows; the exit status.
fn finish(dir: &Path, m: &Meta, rows: &[Row]) -> Result<(), Failure> {
    let summary = sweep::write_results(dir, m, rows).map_err(from)?;
    print_summary(&summary);
    let plots = dir.join("plots");
    std::fs::create_dir_all(&plots)
        .map_err(|e| Failure::run(format!("cannot create {}: {e}", plots.display())))?;
    sweep_plot::all(&plots, m, rows).map_err(Failure::run)?;
    say!(
        "wrote {0}/results.parquet, {0}/summary.json, {0}/plots/",
        dir.display()
    );
    status(rows)
}

fn merge(dir: &Path) -> Result<(), Failure> {
    let (m, rows) = sweep::read_parts(dir).map_err(from)?;
    say!(
        "merged {} rows of sweep `{}` (id {})",
        rows.len(),
        m.name,
        m.sweep_id
    );
    finish(dir, &m, &rows)
}

fn rerun(dir: &Path, index: u64) -> Result<(), Failure> {
    let (m, s) = sweep::sweep_of_dir(dir, &generator).map_err(from)?;
    if index >= s.len() {
        return Err(Failure::input(format!(
            "sample {index}: the sweep has samples 0 to {}",
            s.len().saturating_sub(1)
        )));
    }
    let sample = s.sample(index, &generator);
    let rdir = dir.join("rerun");
    std::fs::create_dir_all(&rdir)
        .map_err(|e| Failure::run(format!("cannot create {}: {e}", rdir.display())))?;
    if let Ok(text) = &sample.model {
        let p = rdir.join(format!("sample-{index}.toml"));
        super::output::write_atomic(&p, text.as_bytes()).map_err(Failure::run)?;
        say!(
            "wrote {} (sample {index} of `{}`; `truss-deploy simulate` runs it alone)",
            p.display(),
            m.name
        );
    }
    let row = sweep::run_sample(&s, index, &generator, s.max_wall_s);
    let text = serde_json::to_string_pretty(&row).expect("row serializes") + "\n";
    let p = rdir.join(format!("sample-{index}.json"));
    super::output::write_atomic(&p, text.as_bytes()).map_err(Failure::run)?;
    say!(
        "sample {index}: {} ({}), row in {}",
        row.stop_reason,
        row.stop_message,
        p.display()
    );
    match sweep::read_row(dir, index) {
        None => {
            say!("(the sweep has no row of sample {index} yet to compare with)");
            Ok(())
        }
        Some(old) if old.without_wall_time() == row.without_wall_time() => {
            say!("identical to the sweep's row apart from wall time");
            Ok(())
        }
        Some(old) => {
            let a = serde_json::to_value(old.without_wall_time()).expect("row");
            let b = serde_json::to_value(row.without_wall_time()).expect("row");
            let differ: Vec<String> = a
                .as_object()
                .expect("object")
                .iter()
                .filter(|(k, v)| b.get(k.as_str()) != Some(v))
                .map(|(k, _)| k.clone())
                .collect();
            Err(Failure::run(format!(
                "sample {index} gave another row than the sweep's: {} differ",
                differ.join(", ")
            )))
        }
    }
}

fn print_summary(s: &Summary) {
    say!(
        "\n{} samples: {} deployed, p_deploy = {:.3} (95 % Wilson {:.3} .. {:.3})",
        s.samples,
        s.deployed,
        s.p_deploy,
        s.p_deploy_low,
        s.p_deploy_high
    );
    let reasons: Vec<String> = s
        .stop_reasons
        .iter()
        .map(|(k, v)| format!("{k} {v}"))
        .collect();
    say!("stop reasons: {}", reasons.join(", "));
    if s.rescued > 0 {
        say!(
            "rescued: {} of {} samples accepted results their solver knows inexact \
             (column accepting_fallbacks; docs/solver.md): their figures rest on rescue",
            s.rescued,
            s.samples
        );
    }
    let q = |name: &str, unit: &str, q: &Option<crate::sweep::stats::Quantiles>| {
        match q {
        Some(q) => say!(
            "{name:<22} min {:.4} | 5 % {:.4} | 25 % {:.4} | median {:.4} | 75 % {:.4} | 95 % {:.4} | max {:.4} {unit} ({} samples)",
            q.min, q.q05, q.q25, q.median, q.q75, q.q95, q.max, q.count
        ),
        None => say!("{name:<22} none"),
    }
    };
    q("deploy time", "s", &s.deploy_time_s);
    q("largest latch load", &s.latch_load_unit, &s.latch_load);
    if s.first_frequency_hz.is_some() {
        q("first frequency", "Hz", &s.first_frequency_hz);
    }
    if !s.last_latch.is_empty() {
        let l: Vec<String> = s
            .last_latch
            .iter()
            .take(6)
            .map(|(n, c)| format!("{n} {c}"))
            .collect();
        say!("latched last: {}", l.join(", "));
    }
    say!(
        "{:<34} {:>18} {:>18}",
        "Spearman rank correlation",
        "with deploy time",
        "with latch load"
    );
    let f = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:+.3}"));
    for c in &s.correlations {
        say!(
            "  {:<32} {:>18} {:>18}",
            c.key,
            f(c.spearman_deploy_time),
            f(c.spearman_latch_load)
        );
    }
    if let Some(d) = &s.drives_deploy_time {
        say!("drives the deploy-time scatter most: {d}");
    }
}
