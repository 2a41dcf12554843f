//! `simulate --plot/--joints/--snapshots`: the SVG files are written and name
//! the joints; an unknown joint is bad input (exit 2) naming it.

use std::path::PathBuf;
use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_truss-deploy"))
}

fn mast() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("models/pantograph_mast.toml")
}

/// Asserts that a run exited 0, showing its stderr where not.
fn succeeded(out: &std::process::Output) {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

fn temp_dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("truss-deploy-plots-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn plot_and_snapshots_are_svg_with_the_joints() {
    let dir = temp_dir("ok");
    let (plot, snaps) = (dir.join("joints.svg"), dir.join("snapshots.svg"));
    let out = bin()
        .arg("simulate")
        .arg(mast())
        .args(["--joints", "L4,R4", "--plot"])
        .arg(&plot)
        .arg("--snapshots")
        .arg(&snaps)
        .output()
        .unwrap();
    succeeded(&out);
    for p in [&plot, &snaps] {
        let text = std::fs::read_to_string(p).unwrap();
        assert!(
            text.starts_with("<svg"),
            "{}: {}",
            p.display(),
            &text[..80.min(text.len())]
        );
        assert!(
            text.contains("<path") || text.contains("<polyline"),
            "{} has no lines",
            p.display()
        );
    }
    let plot_text = std::fs::read_to_string(&plot).unwrap();
    for name in ["L4", "R4", "latch event", "t (s)"] {
        assert!(plot_text.contains(name), "the plot does not mention {name}");
    }
    let snaps_text = std::fs::read_to_string(&snaps).unwrap();
    assert!(
        snaps_text.contains("t = 0.00 s"),
        "no first-instant caption"
    );
    assert_eq!(snaps_text.matches("t = ").count(), 6, "six instants");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn plot_without_joints_picks_some() {
    let dir = temp_dir("default");
    let plot = dir.join("joints.svg");
    let out = bin()
        .arg("simulate")
        .arg(mast())
        .args(["--until", "1", "--plot"])
        .arg(&plot)
        .output()
        .unwrap();
    succeeded(&out);
    let text = std::fs::read_to_string(&plot).unwrap();
    assert!(
        text.starts_with("<svg") && text.contains("R4"),
        "default joints: the ones that move most"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn unknown_joint_is_bad_input_naming_it() {
    let dir = temp_dir("nope");
    let plot = dir.join("joints.svg");
    let out = bin()
        .arg("simulate")
        .arg(mast())
        .args(["--joints", "L1,NOPE", "--plot"])
        .arg(&plot)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("NOPE"), "{err}");
    assert!(
        err.contains("L0") && err.contains("R4"),
        "lists the valid joints: {err}"
    );
    assert!(!out.stdout.starts_with(b"model"), "fails before running");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `--latch-plot` names the hardest latch and the last one as the run's own lock
/// table has them, and counts the latched sleeves: by peak force where every
/// latch has one (the bundled mast's compliant latches), by impulse where not
/// (the generated mast's rigid ones); an unwritable file is bad input (exit 2)
/// found before the run.
#[test]
fn latch_plot_labels_the_hardest_and_the_last_latch() {
    let dir = temp_dir("latch");
    let rigid = dir.join("rigid_mast.toml");
    let out = bin()
        .args(["generate", "mast", "-o"])
        .arg(&rigid)
        .output()
        .unwrap();
    assert!(out.status.success());
    for (model, key) in [(mast(), "peak_force_n"), (rigid, "impulse_ns")] {
        let (svg, json) = (dir.join("latches.svg"), dir.join("s.json"));
        let out = bin()
            .arg("simulate")
            .arg(&model)
            .arg("--latch-plot")
            .arg(&svg)
            .arg("--json")
            .arg(&json)
            .output()
            .unwrap();
        succeeded(&out);
        let summary: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        let locks = summary["locks"].as_array().unwrap();
        let hardest = locks
            .iter()
            .max_by(|a, b| {
                a[key]
                    .as_f64()
                    .unwrap()
                    .total_cmp(&b[key].as_f64().unwrap())
            })
            .unwrap();
        let last = locks
            .iter()
            .max_by(|a, b| {
                a["time_s"]
                    .as_f64()
                    .unwrap()
                    .total_cmp(&b["time_s"].as_f64().unwrap())
            })
            .unwrap();
        let name = hardest["name"].as_str().unwrap();
        let text = std::fs::read_to_string(&svg).unwrap();
        assert!(text.starts_with("<svg"));
        let by = if key == "peak_force_n" {
            format!(
                "hardest: {name} peak {:.1} N",
                hardest[key].as_f64().unwrap()
            )
        } else {
            assert!(hardest["peak_force_n"].is_null(), "rigid latches");
            format!("hardest: {name} {:.3} N s", hardest[key].as_f64().unwrap())
        };
        let scale = if key == "peak_force_n" {
            "area ~ peak force"
        } else {
            "area ~ impulse"
        };
        for label in [
            by,
            format!("last: {}", last["name"].as_str().unwrap()),
            format!("{} of 4 sleeves latched", locks.len()),
            scale.to_string(),
        ] {
            assert!(text.contains(&label), "the latch plot lacks `{label}`");
        }
    }
    let bad = bin()
        .arg("simulate")
        .arg(mast())
        .args(["--latch-plot", "/nonexistent-dir/latches.svg"])
        .output()
        .unwrap();
    assert_eq!(bad.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("/nonexistent-dir/latches.svg"));
}
