//! `truss-deploy sweep` (docs/sweeps.md) on the bundled mast: rows and
//! summary, grids, bad input, `rerun`, SIGKILL and resume, shards and merge,
//! pyarrow, and a Slurm array job.

use serde_json::Value;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use super::{run, temp_dir, BIN};
use crate::text;

/// A sweep file in `dir` on the bundled mast, with these `[[param]]` tables.
fn mast_sweep(dir: &Path, name: &str, seed: u64, samples: Option<u64>, params: &str) -> PathBuf {
    let mast = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/pantograph_mast.toml");
    let samples = samples.map_or(String::new(), |n| format!("samples = {n}\n"));
    let p = dir.join(format!("{name}.toml"));
    std::fs::write(
        &p,
        format!(
            "[sweep]\nname = \"{name}\"\nseed = {seed}\n{samples}\n[base]\nmodel = \"{}\"\n\n{params}",
            mast.display()
        ),
    )
    .expect("write sweep file");
    p
}

const SCATTER: &str = r#"
[[param]]
key = "cable.drive.friction_mu"
dist = "uniform"
min = 0.002
max = 0.03

[[param]]
key = "cable.drive.tension_n"
dist = "lognormal"
median = 0.02
sigma = 0.15

[[param]]
key = "joint.*.mass_kg"
dist = "normal"
mean = 1.0
std = 0.05
min = 0.85
max = 1.15
relative = true
each = true
"#;

/// The rows in DIR/samples by index.
fn rows(dir: &Path) -> BTreeMap<u64, Value> {
    let mut out = BTreeMap::new();
    for e in std::fs::read_dir(dir.join("samples")).expect("samples dir") {
        let p = e.expect("entry").path();
        if p.extension().is_some_and(|x| x == "json") {
            let v: Value = serde_json::from_str(&std::fs::read_to_string(&p).expect("read row"))
                .expect("row is JSON");
            let i = v["index"].as_u64().expect("index");
            assert!(out.insert(i, v).is_none(), "two rows of sample {i}");
        }
    }
    out
}

fn without_wall(mut v: Value) -> Value {
    v.as_object_mut().expect("row").remove("wall_time_s");
    v
}

fn read_json(p: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(p).expect("read json")).expect("json")
}

#[test]
fn mast_rows_summary_and_rerun_bit_for_bit() {
    let d = temp_dir("rows");
    let s = mast_sweep(&d, "mast", 11, Some(8), SCATTER);
    let out = d.join("out");
    let o = run(&[
        "sweep".as_ref(),
        s.as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
        "--jobs".as_ref(),
        "2".as_ref(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    // (no terminal: progress as plain lines, the last one at the last sample)
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("8/8 samples have rows"),
        "{}",
        text(&o)
    );
    let r = rows(&out);
    assert_eq!(
        r.keys().copied().collect::<Vec<_>>(),
        (0..8).collect::<Vec<_>>()
    );
    let sum = read_json(&out.join("summary.json"));
    let deployed = r.values().filter(|v| v["deployed"] == true).count() as u64;
    assert_eq!(sum["samples"], 8);
    assert_eq!(sum["deployed"].as_u64(), Some(deployed));
    let (lo, p, hi) = (
        sum["p_deploy_low"].as_f64().unwrap(),
        sum["p_deploy"].as_f64().unwrap(),
        sum["p_deploy_high"].as_f64().unwrap(),
    );
    assert!(lo <= p && p <= hi && lo < hi, "{sum:#}");
    // the parameters vary from sample to sample, within their ranges
    let mus: Vec<f64> = r
        .values()
        .map(|v| v["params"][0].as_f64().unwrap())
        .collect();
    assert!(mus.iter().all(|m| (0.002..0.03).contains(m)), "{mus:?}");
    assert!(mus.windows(2).all(|w| w[0] != w[1]), "{mus:?}");
    let masses: Vec<f64> = r
        .values()
        .map(|v| v["params"][2].as_f64().unwrap())
        .collect();
    assert!(
        masses.iter().all(|m| (0.85..=1.15).contains(m)),
        "{masses:?}"
    );
    for f in [
        "results.parquet",
        "plots/deploy_time.svg",
        "plots/deploy_time_vs_params.svg",
        "plots/latch_load_per_sleeve.svg",
    ] {
        assert!(
            out.join(f)
                .metadata()
                .map(|m| m.len() > 500)
                .unwrap_or(false),
            "{f}"
        );
    }
    // rerun reproduces sample 5's row bit for bit (apart from wall time)
    let o = run(&[
        "sweep".as_ref(),
        "rerun".as_ref(),
        out.as_os_str(),
        "5".as_ref(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        String::from_utf8_lossy(&o.stdout).contains("identical"),
        "{}",
        text(&o)
    );
    let again = read_json(&out.join("rerun/sample-5.json"));
    assert_eq!(without_wall(again), without_wall(r[&5].clone()));
    // ... and its model file, run by `simulate`, deploys at the same instant
    let j = d.join("s5.json");
    let o = run(&[
        "simulate".as_ref(),
        out.join("rerun/sample-5.toml").as_os_str(),
        "--json".as_ref(),
        j.as_os_str(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(read_json(&j)["deploy_time_s"], r[&5]["deploy_time_s"]);
    // a tampered row is found out by rerun (exit 1, the field named)
    let p = out.join("samples/000000005.json");
    let mut v = r[&5].clone();
    v["steps"] = Value::from(v["steps"].as_u64().unwrap() + 1);
    std::fs::write(&p, serde_json::to_string(&v).unwrap()).unwrap();
    let o = run(&[
        "sweep".as_ref(),
        "rerun".as_ref(),
        out.as_os_str(),
        "5".as_ref(),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("steps"),
        "{}",
        text(&o)
    );
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn grid_and_list_make_their_product() {
    let d = temp_dir("grid");
    let s = mast_sweep(
        &d,
        "grid",
        3,
        Some(2),
        r#"
[[param]]
key = "settings.damping_n_s_per_m"
dist = "grid"
min = 0.0
max = 0.002
n = 3

[[param]]
key = "cable.drive.tension_n"
dist = "list"
values = [0.02, 0.03]

[[param]]
key = "cable.drive.friction_mu"
dist = "uniform"
min = 0.002
max = 0.01
"#,
    );
    let out = d.join("out");
    let o = run(&[
        "sweep".as_ref(),
        s.as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let r = rows(&out);
    assert_eq!(r.len(), 12, "3 x 2 grid points x 2 samples");
    let mut points: BTreeMap<(u64, u64), usize> = BTreeMap::new();
    for v in r.values() {
        let p = &v["params"];
        let key = (
            p[0].as_f64().unwrap().to_bits(),
            p[1].as_f64().unwrap().to_bits(),
        );
        *points.entry(key).or_insert(0) += 1;
    }
    let mut expected = BTreeMap::new();
    for c in [0.0, 0.001, 0.002f64] {
        for t in [0.02, 0.03f64] {
            expected.insert((c.to_bits(), t.to_bits()), 2);
        }
    }
    assert_eq!(points, expected);
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn bad_input_exits_2_naming_key_and_line_before_any_sample() {
    let d = temp_dir("bad");
    // (params start on line 9 of the sweep file: the `key =` line is 10)
    let cases: &[(&str, &[&str])] = &[
        ("[[param]]\nkey = \"foo.bar\"\ndist = \"uniform\"\nmin = 0\nmax = 1\n", &["`foo.bar`", ":10:", "unknown parameter"]),
        ("[[param]]\nkey = \"settings.no_such_key\"\ndist = \"uniform\"\nmin = 0\nmax = 1\n", &["`settings.no_such_key`", ":10:", "no_such_key"]),
        ("[[param]]\nkey = \"cable.drive.tension_n\"\ndist = \"uniform\"\nmin = 2\nmax = 1\n", &["`cable.drive.tension_n`", ":10:", "inverted"]),
        ("[[param]]\nkey = \"cable.drive.tension_n\"\ndist = \"grid\"\nmin = 1\nmax = 1\nn = 3\n", &["`cable.drive.tension_n`", ":10:", "empty"]),
        ("[[param]]\nkey = \"cable.drive.tension_n\"\ndist = \"normal\"\nmean = 1\nstd = -0.1\n", &["`cable.drive.tension_n`", ":10:", "std"]),
        ("[[param]]\nkey = \"sync_hinge.*.stiffness_n_per_m\"\ndist = \"uniform\"\nmin = 1\nmax = 2\n", &["`sync_hinge.*.stiffness_n_per_m`", ":10:", "lacks"]),
        ("[[param]]\nkey = \"joint.*.mass\"\ndist = \"uniform\"\nmin = 1\nmax = 2\n", &["`joint.*.mass`", ":10:", "lacks"]),
        ("[[param]]\nkey = \"cable.drive.tension_n\"\ndist = \"list\"\nvalues = []\n", &["`cable.drive.tension_n`", ":10:", "empty"]),
        ("[[param]]\nkey = \"cable.drive.tension_n\"\ndist = \"uniform\"\nmin = 1\nmax = = 2\n", &[":13:"]),
    ];
    for (k, (params, want)) in cases.iter().enumerate() {
        let s = mast_sweep(&d, &format!("bad{k}"), 1, Some(3), params);
        let out = d.join(format!("out{k}"));
        let o = run(&[
            "sweep".as_ref(),
            s.as_os_str(),
            "-o".as_ref(),
            out.as_os_str(),
        ]);
        assert_eq!(o.status.code(), Some(2), "case {k}: {}", text(&o));
        let err = String::from_utf8_lossy(&o.stderr);
        for w in *want {
            assert!(err.contains(w), "case {k}: `{w}` not in {err}");
        }
        assert!(!err.contains("panicked"), "{err}");
        assert!(
            !out.exists(),
            "case {k}: the output directory was made before the input was checked"
        );
    }
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn invalid_samples_are_rows_and_the_sweep_exits_1() {
    let d = temp_dir("invalid");
    // an untruncated normal around a small mass: some draws are negative
    let s = mast_sweep(
        &d,
        "invalid",
        5,
        Some(12),
        "[[param]]\nkey = \"joint.L1.mass_kg\"\ndist = \"normal\"\nmean = 0.05\nstd = 0.1\n",
    );
    let out = d.join("out");
    let o = run(&[
        "sweep".as_ref(),
        s.as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
    ]);
    let r = rows(&out);
    assert_eq!(r.len(), 12);
    let invalid: Vec<&Value> = r
        .values()
        .filter(|v| v["stop_reason"] == "invalid")
        .collect();
    let negative = r
        .values()
        .filter(|v| v["params"][0].as_f64().unwrap() <= 0.0)
        .count();
    assert!(
        negative > 0 && negative < 12,
        "{negative} of 12 draws negative"
    );
    assert_eq!(invalid.len(), negative);
    assert!(invalid
        .iter()
        .all(|v| v["stop_message"].as_str().unwrap().contains("mass_kg")));
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert_eq!(
        read_json(&out.join("summary.json"))["failed"].as_u64(),
        Some(negative as u64)
    );
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn sigkill_halfway_then_restart_gives_one_row_per_sample() {
    let d = temp_dir("kill");
    let n = 300;
    let s = mast_sweep(&d, "kill", 7, Some(n), SCATTER);
    let out = d.join("out");
    let mut child = Command::new(BIN)
        .args([
            "sweep".as_ref(),
            s.as_os_str(),
            "-o".as_ref(),
            out.as_os_str(),
            "--jobs".as_ref(),
            "1".as_ref(),
        ])
        .stdout(std::process::Stdio::null())
        .spawn()
        .expect("spawn");
    let t0 = Instant::now();
    let count = |out: &Path| {
        std::fs::read_dir(out.join("samples"))
            .map(|d| {
                d.filter(|e| {
                    e.as_ref()
                        .is_ok_and(|e| e.path().extension().is_some_and(|x| x == "json"))
                })
                .count()
            })
            .unwrap_or(0)
    };
    while count(&out) < 40 {
        assert!(
            child.try_wait().expect("wait").is_none(),
            "the sweep ended before it was killed"
        );
        assert!(
            t0.elapsed() < Duration::from_secs(120),
            "no 40 rows in 120 s"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    child.kill().expect("SIGKILL"); // (Child::kill sends SIGKILL on Unix)
    child.wait().expect("reap");
    let before = rows(&out);
    assert!(
        before.len() >= 40 && (before.len() as u64) < n,
        "{} rows at the kill",
        before.len()
    );
    let o = run(&[
        "sweep".as_ref(),
        s.as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
        "--jobs".as_ref(),
        "2".as_ref(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        String::from_utf8_lossy(&o.stdout).contains(&format!("{} had rows already", before.len())),
        "{}",
        text(&o)
    );
    let after = rows(&out);
    assert_eq!(
        after.keys().copied().collect::<Vec<_>>(),
        (0..n).collect::<Vec<_>>()
    );
    for (i, v) in &before {
        assert_eq!(&after[i], v, "sample {i} was run again");
    }
    // no temporary files left behind in the rows' directory apart from the
    // killed run's in-flight one (at most one, with --jobs 1)
    let stray = std::fs::read_dir(out.join("samples"))
        .unwrap()
        .filter(|e| {
            !e.as_ref()
                .unwrap()
                .path()
                .extension()
                .is_some_and(|x| x == "json")
        })
        .count();
    assert!(stray <= 1, "{stray} temporary files");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn shards_merge_to_the_one_machine_rows_and_refuse_another_sweep() {
    let d = temp_dir("shards");
    let s = mast_sweep(&d, "shards", 21, Some(10), SCATTER);
    let one = d.join("one");
    let o = run(&[
        "sweep".as_ref(),
        s.as_os_str(),
        "-o".as_ref(),
        one.as_os_str(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let sharded = d.join("sharded");
    for i in 0..3 {
        let o = run(&[
            "sweep".as_ref(),
            s.as_os_str(),
            "-o".as_ref(),
            sharded.as_os_str(),
            "--shard".as_ref(),
            format!("{i}/3").as_ref(),
            "--jobs".as_ref(),
            "1".as_ref(),
        ]);
        assert!(o.status.success(), "shard {i}: {}", text(&o));
        assert!(
            !sharded.join("results.parquet").exists(),
            "a shard wrote the results"
        );
    }
    let o = run(&["sweep".as_ref(), "merge".as_ref(), sharded.as_os_str()]);
    assert!(o.status.success(), "{}", text(&o));
    let (a, b) = (rows(&one), rows(&sharded));
    assert_eq!(a.len(), 10);
    for (i, v) in &a {
        assert_eq!(
            without_wall(v.clone()),
            without_wall(b[i].clone()),
            "sample {i}"
        );
    }
    assert_eq!(
        read_json(&one.join("summary.json")),
        read_json(&sharded.join("summary.json"))
    );
    // a part of another sweep (another seed) is refused
    let s2 = mast_sweep(&d, "other", 22, Some(10), SCATTER);
    let other = d.join("other");
    let o = run(&[
        "sweep".as_ref(),
        s2.as_os_str(),
        "-o".as_ref(),
        other.as_os_str(),
        "--shard".as_ref(),
        "1/3".as_ref(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    std::fs::copy(
        other.join("parts/part-1-of-3.jsonl"),
        sharded.join("parts/part-1-of-3.jsonl"),
    )
    .unwrap();
    let o = run(&["sweep".as_ref(), "merge".as_ref(), sharded.as_os_str()]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("another sweep"),
        "{}",
        text(&o)
    );
    // a missing shard is refused
    std::fs::remove_file(sharded.join("parts/part-1-of-3.jsonl")).unwrap();
    let o = run(&["sweep".as_ref(), "merge".as_ref(), sharded.as_os_str()]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("[1]"),
        "{}",
        text(&o)
    );
    // and a directory of another sweep is not resumed into
    let o = run(&[
        "sweep".as_ref(),
        s2.as_os_str(),
        "-o".as_ref(),
        one.as_os_str(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    let _ = std::fs::remove_dir_all(&d);
}

/// TRUSS_PYTHON with pyarrow and pandas; None (skipped, said why) unless
/// TRUSS_REQUIRE_PYARROW=1.
fn python_with_pyarrow() -> Option<String> {
    crate::python_with(
        "pyarrow, pandas",
        None,
        "TRUSS_REQUIRE_PYARROW",
        "pyarrow and pandas",
    )
}

#[test]
fn pyarrow_and_pandas_read_one_row_per_sample() {
    let Some(py) = python_with_pyarrow() else {
        return;
    };
    let d = temp_dir("pyarrow");
    let s = mast_sweep(&d, "py", 4, Some(6), SCATTER);
    let out = d.join("out");
    let o = run(&[
        "sweep".as_ref(),
        s.as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let script = r#"
import json, sys
import pyarrow.parquet as pq, pandas as pd
t = pq.read_table(sys.argv[1])
df = pd.read_parquet(sys.argv[1])
lat = df[["index", "latch_name", "latch_peak_force_n"]].explode(["latch_name", "latch_peak_force_n"])
print(json.dumps({"rows": t.num_rows, "index": df["index"].tolist(), "deploy": df["deploy_time_s"].tolist(),
  "mu": df["p_cable_drive_friction_mu"].tolist(), "latches": int(lat.shape[0]),
  "accepting": [int(x) for x in df["accepting_fallbacks"]],
  "seed": [int(x) for x in df["seed"]], "meta": t.schema.metadata[b"truss_deploy.sweep"].decode()}))
"#;
    let o = Command::new(&py)
        .args(["-c", script])
        .arg(out.join("results.parquet"))
        .output()
        .expect("python");
    assert!(o.status.success(), "{}", text(&o));
    let v: Value = serde_json::from_slice(&o.stdout).expect("python's JSON");
    let r = rows(&out);
    assert_eq!(v["rows"], 6);
    assert_eq!(v["meta"], "py");
    assert_eq!(v["index"], serde_json::json!([0, 1, 2, 3, 4, 5]));
    for (i, row) in &r {
        let i = *i as usize;
        assert_eq!(v["deploy"][i], row["deploy_time_s"], "sample {i}");
        assert_eq!(v["mu"][i], row["params"][0], "sample {i}");
        assert_eq!(v["seed"][i], row["seed"], "sample {i}");
        assert_eq!(v["accepting"][i], row["accepting_fallbacks"], "sample {i}");
    }
    let latches: usize = r
        .values()
        .map(|row| row["latches"].as_array().unwrap().len())
        .sum();
    assert_eq!(v["latches"].as_u64(), Some(latches as u64));
    let _ = std::fs::remove_dir_all(&d);
}

/// `sbatch` of a running Slurm; None (skipped, said why) unless TRUSS_REQUIRE_SLURM=1.
fn slurm() -> bool {
    let required = std::env::var("TRUSS_REQUIRE_SLURM").as_deref() == Ok("1");
    let why = match Command::new("sinfo").args(["-h", "-o", "%a"]).output() {
        Ok(o) if o.status.success() && String::from_utf8_lossy(&o.stdout).contains("up") => {
            return true
        }
        Ok(o) => format!("sinfo finds no partition up: {}", text(&o)),
        Err(e) => format!("no Slurm here (sinfo: {e})"),
    };
    assert!(
        !required,
        "TRUSS_REQUIRE_SLURM=1 but {why}; .ci/slurm.sh starts one"
    );
    eprintln!("\n!!!!!!!! SKIPPED: {why}; .ci/slurm.sh starts a single-node Slurm !!!!!!!!\n");
    false
}

fn wait_for_job(id: &str, t0: Instant, limit: Duration) {
    loop {
        let o = Command::new("squeue")
            .args(["-h", "-j", id, "-o", "%i %T"])
            .output()
            .expect("squeue");
        if String::from_utf8_lossy(&o.stdout).trim().is_empty() {
            return;
        }
        assert!(
            t0.elapsed() < limit,
            "job {id} still queued or running after {limit:?}: {}",
            text(&o)
        );
        std::thread::sleep(Duration::from_millis(500));
    }
}

#[test]
fn slurm_array_matches_one_machine() {
    if !slurm() {
        return;
    }
    let d = temp_dir("slurm");
    let s = mast_sweep(&d, "slurm", 31, Some(12), SCATTER);
    let one = d.join("one");
    let o = run(&[
        "sweep".as_ref(),
        s.as_os_str(),
        "-o".as_ref(),
        one.as_os_str(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let out = d.join("array");
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/slurm/sweep.sbatch");
    let sbatch = |args: &[String]| {
        let o = Command::new("sbatch").args(args).output().expect("sbatch");
        assert!(o.status.success(), "{}", text(&o));
        String::from_utf8_lossy(&o.stdout)
            .trim()
            .split(';')
            .next()
            .unwrap()
            .to_string()
    };
    let array = sbatch(&[
        "--parsable".into(),
        format!("--chdir={}", d.display()),
        format!("--output={}/slurm-%A_%a.out", d.display()),
        format!(
            "--export=ALL,SWEEP={},OUT={},TRUSS_DEPLOY={BIN}",
            s.display(),
            out.display()
        ),
        script.display().to_string(),
    ]);
    let merge = sbatch(&[
        "--parsable".into(),
        format!("--dependency=afterok:{array}"),
        format!("--chdir={}", d.display()),
        format!("--output={}/slurm-merge.out", d.display()),
        format!("--wrap={BIN} sweep merge {}", out.display()),
    ]);
    let t0 = Instant::now();
    wait_for_job(&array, t0, Duration::from_secs(300));
    wait_for_job(&merge, t0, Duration::from_secs(300));
    let logs: String = std::fs::read_dir(&d)
        .unwrap()
        .filter_map(|e| {
            let p = e.ok()?.path();
            p.file_name()?.to_str()?.starts_with("slurm-").then(|| {
                format!(
                    "{}:\n{}",
                    p.display(),
                    std::fs::read_to_string(&p).unwrap_or_default()
                )
            })
        })
        .collect();
    for i in 0..4 {
        assert!(
            out.join(format!("parts/part-{i}-of-4.jsonl")).exists(),
            "no part {i} of 4:\n{logs}"
        );
    }
    assert!(
        out.join("results.parquet").exists(),
        "the merge job wrote no results:\n{logs}"
    );
    let (a, b) = (rows(&one), rows(&out));
    assert_eq!(a.len(), 12);
    assert_eq!(b.len(), 12);
    for (i, v) in &a {
        assert_eq!(
            without_wall(v.clone()),
            without_wall(b[i].clone()),
            "sample {i}"
        );
    }
    assert_eq!(
        read_json(&one.join("summary.json")),
        read_json(&out.join("summary.json"))
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// `[sweep] history = true`: each sample writes its history (every step)
/// under `DIR/history/INDEX/`, one row per step and the initial state, its
/// last row at the row's end time (read back by pyarrow where TRUSS_PYTHON
/// has it; the Parquet framing checked either way).
#[test]
fn sweep_history_writes_each_samples_tables() {
    let d = temp_dir("sweep_history");
    let s = mast_sweep(&d, "hist", 5, Some(2), SCATTER);
    let spec = std::fs::read_to_string(&s).unwrap();
    std::fs::write(&s, spec.replacen("[base]", "history = true\n\n[base]", 1)).unwrap();
    let out = d.join("out");
    let o = run(&[
        "sweep".as_ref(),
        s.as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let rows = rows(&out);
    assert_eq!(rows.len(), 2);
    let py = std::env::var("TRUSS_PYTHON").ok().filter(|py| {
        Command::new(py)
            .args(["-c", "import pyarrow"])
            .output()
            .is_ok_and(|o| o.status.success())
    });
    for (i, row) in &rows {
        let h = out.join("history").join(format!("{i:09}"));
        for t in ["joints", "members", "cables", "latches", "energy"] {
            let bytes = std::fs::read(h.join(format!("{t}.parquet")))
                .unwrap_or_else(|e| panic!("sample {i} {t}: {e}"));
            assert!(
                bytes.starts_with(b"PAR1") && bytes.ends_with(b"PAR1"),
                "{t}"
            );
        }
        if let Some(py) = &py {
            let o = Command::new(py)
                .args([
                    "-c",
                    "import sys, json, pyarrow.parquet as pq\nt = pq.read_table(sys.argv[1]).to_pydict()\nprint(json.dumps({'rows': len(t['t_s']), 't': t['t_s'][-1]}))",
                ])
                .arg(h.join("energy.parquet"))
                .output()
                .expect("run python");
            assert!(o.status.success(), "{}", text(&o));
            let r: Value = serde_json::from_slice(&o.stdout).unwrap();
            assert_eq!(r["rows"].as_u64(), Some(row["steps"].as_u64().unwrap() + 1));
            assert_eq!(r["t"].as_f64(), row["time_s"].as_f64());
        }
    }
    let _ = std::fs::remove_dir_all(&d);
}
