//! `analyze --modes`: the natural modes as a user asks for them, and the
//! frequencies of a bars-only ring truss against OpenSees (openseespy from
//! PyPI in TRUSS_PYTHON; skipped without it unless TRUSS_REQUIRE_OPENSEES=1,
//! as `.ci/run` sets).

use serde_json::Value;
use std::path::Path;

use crate::{run, temp_dir, text, BIN};

/// The bundled ring's first ten modes: printed, in the JSON (ascending,
/// positive, elastic, one shape per joint with its largest joint
/// displacement 1), and drawn.
#[test]
fn analyze_gives_the_bundled_rings_first_modes() {
    let d = temp_dir("modes_ring");
    let (json, svg) = (d.join("ring.json"), d.join("modes.svg"));
    let o = run(&[
        "analyze".as_ref(),
        Path::new("models/double_ring.toml").as_os_str(),
        "--modes".as_ref(),
        "10".as_ref(),
        "--json".as_ref(),
        json.as_os_str(),
        "--modes-svg".as_ref(),
        svg.as_os_str(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let out = text(&o);
    assert!(out.contains("natural modes (reference geometry"), "{out}");
    let v: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let modes = v["modes"]["modes"].as_array().expect("modes in the JSON");
    assert_eq!(modes.len(), 10);
    let f: Vec<f64> = modes
        .iter()
        .map(|m| m["frequency_hz"].as_f64().unwrap())
        .collect();
    assert!(f[0] > 0.0 && f.windows(2).all(|w| w[0] <= w[1]), "{f:?}");
    assert_eq!(v["modes"]["mechanisms"].as_u64(), Some(0));
    for m in modes {
        assert_eq!(m["kind"], "elastic");
        let shape = m["shape"].as_array().unwrap();
        assert_eq!(shape.len(), 72);
        let biggest = shape
            .iter()
            .map(|u| {
                u.as_array()
                    .unwrap()
                    .iter()
                    .map(|c| c.as_f64().unwrap().powi(2))
                    .sum::<f64>()
                    .sqrt()
            })
            .fold(0.0, f64::max);
        assert!((biggest - 1.0).abs() < 1e-12, "{biggest}");
    }
    // The first frequency printed as in the JSON (7 significant digits).
    assert!(out.contains(&format!("{:.6e}", f[0])), "{out}");
    let drawn = std::fs::read_to_string(&svg).unwrap();
    assert!(drawn.starts_with("<svg") && drawn.contains("mode 1:") && drawn.contains("mode 6:"));
}

/// Bad requests are refused with what is wrong (exit 2), nothing written.
#[test]
fn bad_mode_requests_are_refused() {
    let d = temp_dir("modes_bad");
    let o = run(&["analyze", "models/pantograph_mast.toml", "--modes", "0"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("--modes 0"), "{}", text(&o));
    let svg = d.join("m.svg");
    let o = run(&[
        "analyze".as_ref(),
        "models/pantograph_mast.toml".as_ref(),
        "--modes-svg".as_ref(),
        svg.as_os_str(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("--modes"), "{}", text(&o));
    assert!(!svg.exists());
    let o = run(&["analyze", "models/pantograph_mast.toml", "--modes", "many"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
}

/// A bars-only ring truss (12 bays, 48 joints, 156 bars, masses and EA
/// scattered) built alike here and in OpenSees (tests/python/opensees_modes.py):
/// the first ten frequencies agree to 1e-6.
#[test]
fn a_bar_ring_has_the_frequencies_opensees_finds() {
    let Some(py) = crate::python_with(
        "openseespy.opensees",
        None,
        "TRUSS_REQUIRE_OPENSEES",
        "openseespy==3.7.1.2 (with Debian's libblas3 and liblapack3)",
    ) else {
        return;
    };
    let d = temp_dir("modes_opensees");
    let o = std::process::Command::new(&py)
        .arg("tests/python/opensees_modes.py")
        .arg(BIN)
        .arg(&d)
        .args(["12", "10"])
        .output()
        .expect("run python");
    assert!(o.status.success(), "{}", text(&o));
    let line = String::from_utf8_lossy(&o.stdout)
        .lines()
        .find(|l| l.starts_with('{'))
        .map(str::to_string)
        .unwrap_or_else(|| panic!("no JSON line: {}", text(&o)));
    let v: Value = serde_json::from_str(&line).unwrap();
    let (ours, theirs) = (
        v["ours"].as_array().unwrap(),
        v["opensees"].as_array().unwrap(),
    );
    assert_eq!(ours.len(), 10);
    assert_eq!(theirs.len(), 10);
    assert_eq!(v["mechanisms"].as_u64(), Some(0));
    for (i, (a, b)) in ours.iter().zip(theirs).enumerate() {
        let (a, b) = (a.as_f64().unwrap(), b.as_f64().unwrap());
        assert!(
            (a - b).abs() <= 1e-6 * b,
            "mode {}: {a} Hz against OpenSees {b} Hz",
            i + 1
        );
    }
}

/// `--modes-vtk`: VTK's own XML reader gets the truss (a point per joint,
/// a line per member), each mode's shape as point data equal to the JSON's
/// to the last digit, and the frequencies as field data.
#[test]
fn mode_shapes_read_back_with_vtk() {
    let Some(py) = crate::python_with("vtk", None, "TRUSS_REQUIRE_PYARROW", "vtk") else {
        return;
    };
    let d = temp_dir("modes_vtk");
    let (json, vtp) = (d.join("m.json"), d.join("modes.vtp"));
    let o = run(&[
        "analyze".as_ref(),
        Path::new("models/pantograph_mast.toml").as_os_str(),
        "--modes".as_ref(),
        "4".as_ref(),
        "--json".as_ref(),
        json.as_os_str(),
        "--modes-vtk".as_ref(),
        vtp.as_os_str(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let script = r#"
import json, sys
import vtk
from vtk.util.numpy_support import vtk_to_numpy
r = vtk.vtkXMLPolyDataReader()
r.SetFileName(sys.argv[1])
r.Update()
p = r.GetOutput()
modes = json.load(open(sys.argv[2]))["modes"]["modes"]
shape_diff = max(
    abs(float(vtk_to_numpy(p.GetPointData().GetArray(f"mode_{k + 1:02d}"))[j][c]) - m["shape"][j][c])
    for k, m in enumerate(modes) for j in range(len(m["shape"])) for c in range(3))
f = vtk_to_numpy(p.GetFieldData().GetArray("frequency_hz"))
print(json.dumps({
    "points": int(p.GetNumberOfPoints()), "lines": int(p.GetNumberOfLines()),
    "shape_diff": shape_diff,
    "freq_diff": max(abs(float(f[k]) - m["frequency_hz"]) for k, m in enumerate(modes)),
    "modes": len(modes), "frequencies": int(len(f)),
}))
"#;
    let o = std::process::Command::new(&py)
        .arg("-c")
        .arg(script)
        .arg(&vtp)
        .arg(&json)
        .output()
        .expect("run python");
    assert!(o.status.success(), "{}", text(&o));
    let v: Value =
        serde_json::from_slice(&o.stdout).unwrap_or_else(|e| panic!("{e}: {}", text(&o)));
    assert_eq!(v["points"].as_u64(), Some(10), "{v}");
    assert_eq!(v["lines"].as_u64(), Some(4), "the mast's four sleeves: {v}");
    assert_eq!(v["modes"], v["frequencies"]);
    assert_eq!(v["shape_diff"].as_f64(), Some(0.0), "{v}");
    assert_eq!(v["freq_diff"].as_f64(), Some(0.0), "{v}");
}
