//! `simulate --history` (Parquet tables read back by pyarrow and pandas),
//! `--vtk` (the ParaView series read back by VTK's own XML reader), `--csv`
//! with names that need quoting, and their bad input.
//!
//! Interpreter: env TRUSS_PYTHON with pyarrow and pandas (and vtk for the
//! series); the tests that need it are skipped, saying so, when it is
//! missing, and fail instead with TRUSS_REQUIRE_PYARROW=1 (`.ci/run`).

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;

use super::{run, temp_dir};
use crate::text;

fn model(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("models")
        .join(name)
}

fn read_json(p: &Path) -> Value {
    let t = std::fs::read_to_string(p).unwrap_or_else(|e| panic!("read {}: {e}", p.display()));
    serde_json::from_str(&t).unwrap_or_else(|e| panic!("parse {}: {e}\n{t}", p.display()))
}

/// TRUSS_PYTHON if it imports `modules`; None (skipped, said why) unless
/// TRUSS_REQUIRE_PYARROW=1.
fn python_with(modules: &str) -> Option<String> {
    crate::python_with(modules, None, "TRUSS_REQUIRE_PYARROW", modules)
}

/// Runs `script` with `args`; its stdout parsed as JSON.
fn python(py: &str, script: &str, args: &[&Path]) -> Value {
    let o = Command::new(py)
        .arg("-c")
        .arg(script)
        .args(args)
        .output()
        .expect("run python");
    assert!(o.status.success(), "python failed: {}", text(&o));
    serde_json::from_slice(&o.stdout).unwrap_or_else(|e| panic!("{e}: {}", text(&o)))
}

/// Steps recorded of a run of `steps` steps thinned to every `every`-th:
/// step 0, the multiples of `every`, and the last.
fn recorded_steps(steps: u64, every: u64) -> Vec<u64> {
    let mut v: Vec<u64> = (0..=steps).filter(|s| s % every == 0).collect();
    if *v.last().unwrap() != steps {
        v.push(steps);
    }
    v
}

/// The bundled ring's history (its whole deployment, thinned): every table
/// has one row per recorded step (pyarrow's row count, pandas' `step`
/// column), each member's last-row force is the summary's, and at every row
/// the energy terms make the ledger's balance to its stated relative error.
#[test]
fn ring_history_reads_back_with_pyarrow_and_pandas() {
    let Some(py) = python_with("pyarrow, pandas") else {
        return;
    };
    let d = temp_dir("ring_history");
    let (hist, json) = (d.join("hist"), d.join("run.json"));
    let every = 1;
    let o = run(&[
        "simulate".as_ref(),
        model("double_ring.toml").as_os_str(),
        "--history".as_ref(),
        hist.as_os_str(),
        "--history-every".as_ref(),
        every.to_string().as_ref(),
        "--json".as_ref(),
        json.as_os_str(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let summary = read_json(&json);
    assert_eq!(summary["deployed"], true, "{}", text(&o));
    let steps = summary["steps"].as_u64().unwrap();
    let script = r#"
import json, sys
import pyarrow.parquet as pq, pandas as pd
d = sys.argv[1]
out = {}
for t in ["joints", "members", "cables", "latches", "energy"]:
    tab = pq.read_table(f"{d}/{t}.parquet")
    df = pd.read_parquet(f"{d}/{t}.parquet")
    out[t] = {"rows": tab.num_rows, "steps": [int(s) for s in df["step"]], "t_s": df["t_s"].tolist()}
m = pd.read_parquet(f"{d}/members.parquet")
out["last_forces"] = {c[:-len(".force_n")]: float(m[c].iloc[-1]) for c in m.columns if c.endswith(".force_n")}
e = pd.read_parquet(f"{d}/energy.parquet")
net = (e.cable_work_j + e.gravity_work_j + e.integrator_work_j - e.damping_loss_j - e.lock_loss_j
       - e.latch_damping_loss_j - e.latch_spring_energy_j - e.element_spring_energy_j
       - e.member_strain_energy_j - e.member_damping_loss_j)
scale = pd.concat([e.motor_work_j.abs(), e.gravity_work_j.abs(), e.kinetic_energy_j,
                   e.element_spring_energy_j.abs()], axis=1).max(axis=1).clip(lower=1e-300)
out["miss_j"] = (e.kinetic_energy_j - net).abs().tolist()
out["allowed_j"] = (e.balance_rel_error * scale).tolist()
out["last_energy"] = {c: float(e[c].iloc[-1]) for c in e.columns if c.endswith("_j")}
meta = json.loads(pq.read_table(f"{d}/members.parquet").schema.metadata[b"truss_deploy.layout"])
out["layout_members"] = len(meta["members"])
print(json.dumps(out))
"#;
    let r = python(&py, script, &[&hist]);
    let want = recorded_steps(steps, every);
    for t in ["joints", "members", "cables", "latches", "energy"] {
        assert_eq!(r[t]["rows"].as_u64().unwrap() as usize, want.len(), "{t}");
        let got: Vec<u64> = r[t]["steps"]
            .as_array()
            .unwrap()
            .iter()
            .map(|s| s.as_u64().unwrap())
            .collect();
        assert_eq!(got, want, "{t}: one row per recorded step");
        assert_eq!(r[t]["t_s"], r["joints"]["t_s"], "{t}: the same instants");
    }
    let last_t = r["joints"]["t_s"].as_array().unwrap().last().unwrap();
    assert_eq!(last_t.as_f64(), summary["time_s"].as_f64());
    // each member's force at the last row is the summary's
    let members = summary["members"].as_array().unwrap();
    assert!(members.len() > 100, "the ring's bars and sleeves");
    assert_eq!(
        r["layout_members"].as_u64().unwrap() as usize,
        members.len()
    );
    let mut loaded = 0;
    for mb in members {
        let name = mb["name"].as_str().unwrap();
        let f = mb["axial_force_n"].as_f64().unwrap();
        assert_eq!(r["last_forces"][name].as_f64(), Some(f), "member {name}");
        loaded += (f.abs() > 1e-3) as usize;
    }
    assert!(loaded > 0, "the deployed ring carries load in its members");
    // the energy terms at each row make the balance to its stated error
    let (miss, allowed) = (
        r["miss_j"].as_array().unwrap(),
        r["allowed_j"].as_array().unwrap(),
    );
    for (k, (m, a)) in miss.iter().zip(allowed).enumerate() {
        let (m, a) = (m.as_f64().unwrap(), a.as_f64().unwrap());
        assert!(
            m <= a * (1.0 + 1e-9) + 1e-15 && a <= m * (1.0 + 1e-9) + 1e-15,
            "row {k}: |K - (work in - losses)| = {m} J, balance_rel_error x scale = {a} J"
        );
    }
    for (k, v) in r["last_energy"].as_object().unwrap() {
        let want = if k == "kinetic_energy_j" {
            &summary["kinetic_energy_j"]
        } else {
            &summary["energy"][k]
        };
        assert_eq!(v.as_f64(), want.as_f64(), "energy {k} at the last row");
    }
    let _ = std::fs::remove_dir_all(&d);
}

/// The mast's compliant latches (every step recorded): each latch's
/// `peak_force_n` and `time_of_peak_s` columns end at the summary's values,
/// they first take them at the row whose step holds the peak's time, and no
/// recorded force through the latch exceeds the peak; the latch is
/// `engaging` while its force is recorded nonzero before it latches.
#[test]
fn mast_latch_force_history_peaks_at_the_summary() {
    let Some(py) = python_with("pyarrow, pandas") else {
        return;
    };
    let d = temp_dir("mast_latches");
    let (hist, json) = (d.join("hist"), d.join("run.json"));
    let o = run(&[
        "simulate".as_ref(),
        model("pantograph_mast.toml").as_os_str(),
        "--history".as_ref(),
        hist.as_os_str(),
        "--history-every".as_ref(),
        "1".as_ref(),
        "--json".as_ref(),
        json.as_os_str(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let summary = read_json(&json);
    let script = r#"
import json, sys
import pandas as pd
l = pd.read_parquet(f"{sys.argv[1]}/latches.parquet")
names = [c[:-len(".gap_m")] for c in l.columns if c.endswith(".gap_m")]
out = {"rows": len(l), "t_s": l["t_s"].tolist(), "latches": {}}
for n in names:
    out["latches"][n] = {
        "force_n": l[n + ".force_n"].tolist(),
        "state": l[n + ".state"].tolist(),
        "peak": [None if pd.isna(x) else float(x) for x in l[n + ".peak_force_n"]],
        "when": [None if pd.isna(x) else float(x) for x in l[n + ".time_of_peak_s"]],
    }
print(json.dumps(out))
"#;
    let r = python(&py, script, &[&hist]);
    assert_eq!(
        r["rows"].as_u64(),
        Some(summary["steps"].as_u64().unwrap() + 1),
        "every step and the initial state"
    );
    let t: Vec<f64> = r["t_s"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    let locks = summary["locks"].as_array().unwrap();
    assert_eq!(locks.len(), 4);
    for lock in locks {
        let name = lock["name"].as_str().unwrap();
        let peak = lock["peak_force_n"].as_f64().expect("compliant latch");
        let when = lock["time_of_peak_s"].as_f64().unwrap();
        let h = &r["latches"][name];
        let col = |k: &str| h[k].as_array().unwrap().clone();
        let (peaks, whens, forces) = (col("peak"), col("when"), col("force_n"));
        assert_eq!(peaks.last().unwrap().as_f64(), Some(peak), "{name}");
        assert_eq!(whens.last().unwrap().as_f64(), Some(when), "{name}");
        let first = peaks.iter().position(|p| p.as_f64() == Some(peak)).unwrap();
        assert!(
            first > 0 && t[first - 1] < when && when <= t[first],
            "{name}: the peak at {when} s first recorded at row {first} (t = {} s)",
            t[first]
        );
        assert!(peaks[..first].iter().all(|p| p.as_f64() != Some(peak)));
        let largest = forces
            .iter()
            .map(|f| f.as_f64().unwrap().abs())
            .fold(0.0, f64::max);
        assert!(
            largest > 0.0 && largest <= peak * (1.0 + 1e-9),
            "{name}: recorded forces up to {largest} N, the peak {peak} N"
        );
        let states = col("state");
        for (k, f) in forces.iter().enumerate() {
            if states[k] == "open" {
                assert_eq!(f.as_f64(), Some(0.0), "{name} open at row {k}");
            }
        }
        assert!(states.iter().any(|s| s == "engaging"), "{name}");
        assert_eq!(states.last().unwrap(), "latched", "{name}");
    }
    let _ = std::fs::remove_dir_all(&d);
}

/// The ParaView series of the mast (every 7th step) read by VTK's own XML
/// reader: the collection's time steps are the history's rows, each frame
/// has the documented arrays, and at one step its points, velocities and
/// member forces are the history's values.
#[test]
fn vtk_series_reads_back_with_vtk() {
    let Some(py) = python_with("pyarrow, pandas, vtk") else {
        return;
    };
    let d = temp_dir("vtk");
    let (hist, series) = (d.join("hist"), d.join("series"));
    let o = run(&[
        "simulate".as_ref(),
        model("pantograph_mast.toml").as_os_str(),
        "--history".as_ref(),
        hist.as_os_str(),
        "--vtk".as_ref(),
        series.as_os_str(),
        "--history-every".as_ref(),
        "7".as_ref(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let script = r#"
import json, sys
import xml.etree.ElementTree as ET
import pandas as pd, vtk
from vtk.util.numpy_support import vtk_to_numpy
hist, series = sys.argv[1], sys.argv[2]
sets = ET.parse(f"{series}/run.pvd").getroot().find("Collection").findall("DataSet")
j = pd.read_parquet(f"{hist}/joints.parquet")
m = pd.read_parquet(f"{hist}/members.parquet")
l = pd.read_parquet(f"{hist}/latches.parquet")
k = len(sets) // 2
r = vtk.vtkXMLPolyDataReader()
r.SetFileName(f"{series}/" + sets[k].get("file"))
r.Update()
p = r.GetOutput()
pd_names = [p.GetPointData().GetArrayName(i) for i in range(p.GetPointData().GetNumberOfArrays())]
cd_names = [p.GetCellData().GetArrayName(i) for i in range(p.GetCellData().GetNumberOfArrays())]
pts = vtk_to_numpy(p.GetPoints().GetData())
vel = vtk_to_numpy(p.GetPointData().GetArray("velocity_m_s"))
force = vtk_to_numpy(p.GetCellData().GetArray("axial_force_n"))
state = vtk_to_numpy(p.GetCellData().GetArray("latch_state"))
kind = vtk_to_numpy(p.GetCellData().GetArray("kind"))
joints = [c[:-len(".x_m")] for c in j.columns if c.endswith(".x_m")]
members = [c[:-len(".force_n")] for c in m.columns if c.endswith(".force_n")]
codes = {"open": 0, "latched": 1, "engaging": 2}
lines = p.GetLines()
print(json.dumps({
  "sets": len(sets), "rows": len(j),
  "times": [float(s.get("timestep")) for s in sets], "t_s": j["t_s"].tolist(),
  "points": int(p.GetNumberOfPoints()), "lines": int(p.GetNumberOfLines()),
  "point_arrays": pd_names, "cell_arrays": cd_names,
  "pos_diff": max(abs(pts[i][a] - j[f"{n}.{c}_m"].iloc[k]) for i, n in enumerate(joints) for a, c in enumerate("xyz")),
  "vel_diff": max(abs(vel[i][a] - j[f"{n}.v{c}_m_s"].iloc[k]) for i, n in enumerate(joints) for a, c in enumerate("xyz")),
  "force_diff": max(abs(force[i] - m[f"{n}.force_n"].iloc[k]) for i, n in enumerate(members)),
  "largest_force": max(abs(m[f"{n}.force_n"].iloc[k]) for n in members),
  "state_ok": all(int(state[i]) == codes[l[f"{n}.state"].iloc[k]] for i, n in enumerate(members)),
  "kinds": [int(x) for x in kind], "joints": len(joints), "members": len(members),
  "time_value": p.GetFieldData().GetArray("TimeValue").GetValue(0), "k": k,
}))
"#;
    let r = python(&py, script, &[&hist, &series]);
    assert_eq!(r["sets"], r["rows"], "one time step per history row");
    assert!(r["sets"].as_u64().unwrap() > 10);
    assert_eq!(
        r["times"], r["t_s"],
        "the time steps are the history's times"
    );
    let k = r["k"].as_u64().unwrap() as usize;
    assert_eq!(
        r["time_value"], r["times"][k],
        "a frame read alone has its time (field data TimeValue)"
    );
    assert_eq!(r["points"], r["joints"]);
    assert_eq!(r["lines"], r["members"]);
    for a in ["velocity_m_s", "mass_kg"] {
        assert!(
            r["point_arrays"].as_array().unwrap().iter().any(|n| n == a),
            "{a}: {}",
            r["point_arrays"]
        );
    }
    for a in ["axial_force_n", "length_m", "kind", "latch_state"] {
        assert!(
            r["cell_arrays"].as_array().unwrap().iter().any(|n| n == a),
            "{a}: {}",
            r["cell_arrays"]
        );
    }
    for k in ["pos_diff", "vel_diff", "force_diff"] {
        assert_eq!(
            r[k].as_f64(),
            Some(0.0),
            "{k}: the series' values are the history's"
        );
    }
    assert_eq!(r["state_ok"], true);
    // the mast's members are its four sleeves
    assert!(r["kinds"].as_array().unwrap().iter().all(|k| k == 1));
    let _ = std::fs::remove_dir_all(&d);
}

/// Splits one CSV line per RFC 4180 (quoted fields, doubled quotes).
fn csv_fields(line: &str) -> Vec<String> {
    let (mut out, mut cur, mut quoted, mut chars) =
        (Vec::new(), String::new(), false, line.chars().peekable());
    while let Some(c) = chars.next() {
        match (c, quoted) {
            ('"', true) if chars.peek() == Some(&'"') => {
                cur.push('"');
                chars.next();
            }
            ('"', _) => quoted = !quoted,
            (',', false) => out.push(std::mem::take(&mut cur)),
            _ => cur.push(c),
        }
    }
    out.push(cur);
    out
}

/// A joint named `a,"b"` (the mast's L0 renamed) reads back whole from the
/// --csv header, with Python's csv module where TRUSS_PYTHON is set and
/// with an RFC 4180 split here; every row has as many fields as the header.
#[test]
fn csv_header_quotes_a_joint_name_with_a_comma_and_quotes() {
    let d = temp_dir("csv_quote");
    let text_in = std::fs::read_to_string(model("pantograph_mast.toml")).unwrap();
    assert!(text_in.contains("\"L0\""));
    let renamed = text_in.replace("\"L0\"", r#""a,\"b\"""#);
    let m = d.join("mast.toml");
    std::fs::write(&m, renamed).unwrap();
    let csv = d.join("run.csv");
    let o = run(&[
        "simulate".as_ref(),
        m.as_os_str(),
        "--csv".as_ref(),
        csv.as_os_str(),
        "--until".as_ref(),
        "1".as_ref(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let body = std::fs::read_to_string(&csv).unwrap();
    let mut lines = body.lines();
    let header = csv_fields(lines.next().unwrap());
    assert_eq!(
        &header[..4],
        ["t_s", "a,\"b\"_x_m", "a,\"b\"_y_m", "a,\"b\"_z_m"]
    );
    for l in lines {
        assert_eq!(csv_fields(l).len(), header.len(), "{l}");
    }
    if let Ok(py) = std::env::var("TRUSS_PYTHON") {
        let script = "import csv, json, sys\nr = list(csv.reader(open(sys.argv[1], newline='')))\nprint(json.dumps({'header': r[0][:4], 'widths': sorted({len(x) for x in r})}))";
        let r = python(&py, script, &[&csv]);
        assert_eq!(r["header"][1], "a,\"b\"_x_m");
        assert_eq!(
            r["widths"].as_array().unwrap().len(),
            1,
            "every row as wide"
        );
    }
    let _ = std::fs::remove_dir_all(&d);
}

/// `--history-every 0` (and a negative count) is bad input: exit 2 naming
/// the option, before anything runs.
#[test]
fn history_every_zero_is_an_input_error() {
    let d = temp_dir("every0");
    for n in ["0", "-3"] {
        let o = run(&[
            "simulate".as_ref(),
            model("pantograph_mast.toml").as_os_str(),
            "--history".as_ref(),
            d.join("h").as_os_str(),
            "--history-every".as_ref(),
            n.as_ref(),
        ]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{}", text(&o));
        assert!(err.contains(&format!("--history-every {n}")), "{err}");
        assert!(!err.contains("panicked"), "{err}");
    }
    // (without --history or --vtk it thins nothing: an input error, not ignored)
    let o = run(&[
        "simulate".as_ref(),
        model("pantograph_mast.toml").as_os_str(),
        "--history-every".as_ref(),
        "5".as_ref(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        err.contains("--history-every") && err.contains("--history"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// A history directory that cannot be made (its parent is a file), one that
/// is a file, and one whose table would be another output: each a clear
/// error naming the option and the path, exit 2, no panic.
#[test]
fn unwritable_history_dir_names_the_path() {
    let d = temp_dir("unwritable");
    let file = d.join("plain_file");
    std::fs::write(&file, "x").unwrap();
    let under_file = file.join("hist");
    let shown_under = under_file.display().to_string();
    let shown_file = file.display().to_string();
    let taken = d.join("h2");
    std::fs::create_dir(&taken).unwrap();
    let csv_in_it = taken.join("joints.parquet");
    let cases: Vec<(Vec<&std::ffi::OsStr>, &str)> = vec![
        (
            vec!["--history".as_ref(), under_file.as_os_str()],
            shown_under.as_str(),
        ),
        (
            vec!["--vtk".as_ref(), under_file.as_os_str()],
            shown_under.as_str(),
        ),
        (
            vec!["--history".as_ref(), file.as_os_str()],
            shown_file.as_str(),
        ),
        (
            vec![
                "--history".as_ref(),
                taken.as_os_str(),
                "--csv".as_ref(),
                csv_in_it.as_os_str(),
            ],
            "joints.parquet",
        ),
    ];
    let mast = model("pantograph_mast.toml");
    for (extra, shown) in cases {
        let mut args: Vec<&std::ffi::OsStr> = vec!["simulate".as_ref(), mast.as_os_str()];
        args.extend(extra.iter().copied());
        let o = run(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{:?}: {}", extra, text(&o));
        assert!(err.contains(shown), "{:?}: {err}", extra);
        assert!(
            err.contains(extra[0].to_str().unwrap()),
            "names the option: {err}"
        );
        assert!(!err.contains("panicked"), "{err}");
    }
    assert!(!csv_in_it.exists() && !under_file.exists());
    let _ = std::fs::remove_dir_all(&d);
}
