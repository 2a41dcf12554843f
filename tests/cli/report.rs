//! `simulate --report FILE.html`: the report of the bundled ring and mast is
//! one self-contained file under 5 MB that headless Chromium opens with no
//! network, draws, plays and lists every latch in
//! (`tests/python/check_report.py`, run with `TRUSS_PYTHON` where it has
//! Playwright; skipped without it or without Chromium unless
//! `TRUSS_REQUIRE_CHROMIUM=1`); a report path that cannot be written is bad
//! input named by its flag.

use super::{run, temp_dir};
use crate::text;
use std::path::{Path, PathBuf};
use std::process::Command;

fn model(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("models")
        .join(name)
}

/// `simulate MODEL --report DIR/NAME.html --json DIR/NAME.json`: the two
/// paths, after checking the run deployed and the report's size.
fn report_of(dir: &Path, name: &str, file: &str) -> (PathBuf, PathBuf) {
    let (html, json) = (
        dir.join(format!("{name}.html")),
        dir.join(format!("{name}.json")),
    );
    let o = run(&[
        "simulate".as_ref(),
        model(file).as_os_str(),
        "--report".as_ref(),
        html.as_os_str(),
        "--json".as_ref(),
        json.as_os_str(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let bytes = std::fs::metadata(&html)
        .expect("the report is written")
        .len();
    assert!(
        text(&o).contains(&format!("bytes: {}", html.display())),
        "the size is printed: {}",
        text(&o)
    );
    assert!(
        bytes < 5_000_000,
        "{name}: the report is {bytes} bytes, more than 5 MB"
    );
    let page = std::fs::read_to_string(&html).unwrap();
    // self-contained: no script or style from elsewhere
    for bad in ["src=\"http", "href=\"http", "src=\"//", "@import"] {
        assert!(!page.contains(bad), "{name}: the report holds `{bad}`");
    }
    (html, json)
}

/// TRUSS_PYTHON with Playwright, and Chromium; None (skipped, said why)
/// unless TRUSS_REQUIRE_CHROMIUM=1.
fn python_with_playwright() -> Option<String> {
    let chromium = std::env::var("TRUSS_CHROMIUM").unwrap_or_else(|_| "/usr/bin/chromium".into());
    let missing = (!Path::new(&chromium).exists()).then(|| format!("no Chromium at {chromium}"));
    crate::python_with(
        "playwright.sync_api",
        missing,
        "TRUSS_REQUIRE_CHROMIUM",
        "chromium and playwright (pip, no `playwright install`)",
    )
}

#[test]
fn ring_and_mast_reports_draw_play_and_list_every_latch_in_chromium() {
    let dir = temp_dir("report");
    let (ring, ring_json) = report_of(&dir, "double_ring", "double_ring.toml");
    let (mast, mast_json) = report_of(&dir, "pantograph_mast", "pantograph_mast.toml");
    let Some(py) = python_with_playwright() else {
        return;
    };
    let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/python/check_report.py");
    let o = Command::new(&py)
        .arg(&script)
        .args([&ring, &ring_json, &mast, &mast_json])
        .output()
        .expect("run check_report.py");
    assert!(o.status.success(), "check_report.py: {}", text(&o));
    let _ = std::fs::remove_dir_all(&dir);
}

/// The checks fail on a report that does not draw: the ring's report with
/// its 3D view's script broken must fail check_report.py.
#[test]
fn the_browser_check_fails_on_a_broken_report() {
    let Some(py) = python_with_playwright() else {
        return;
    };
    let dir = temp_dir("report_broken");
    let (mast, json) = report_of(&dir, "pantograph_mast", "pantograph_mast.toml");
    let page = std::fs::read_to_string(&mast).unwrap();
    let broken = dir.join("broken.html");
    std::fs::write(
        &broken,
        page.replacen(
            "const renderer = new THREE.WebGLRenderer",
            "const renderer = new THREE.NoSuchRenderer",
            1,
        ),
    )
    .unwrap();
    let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/python/check_report.py");
    let o = Command::new(&py)
        .arg(&script)
        .args([&broken, &json])
        .output()
        .expect("run check_report.py");
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(text(&o).contains("FAIL: broken.html"), "{}", text(&o));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_unwritable_report_path_is_bad_input_naming_the_flag() {
    let dir = temp_dir("report_bad");
    let missing = dir.join("no_such_dir/r.html");
    let o = run(&[
        "simulate".as_ref(),
        model("pantograph_mast.toml").as_os_str(),
        "--report".as_ref(),
        missing.as_os_str(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains(&format!("--report {}", missing.display())),
        "{}",
        text(&o)
    );
    // the model file itself
    let o = run(&[
        "simulate".as_ref(),
        model("pantograph_mast.toml").as_os_str(),
        "--report".as_ref(),
        model("pantograph_mast.toml").as_os_str(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("--report"), "{}", text(&o));
    assert!(!text(&o).contains("panicked"), "{}", text(&o));
    let _ = std::fs::remove_dir_all(&dir);
}

/// A run stopped before it deployed still writes its report, with the stop
/// reason and the frames computed until then.
#[test]
fn a_run_stopped_early_writes_its_report_with_the_stop_reason() {
    let dir = temp_dir("report_until");
    let html = dir.join("until.html");
    let o = run(&[
        "simulate".as_ref(),
        model("pantograph_mast.toml").as_os_str(),
        "--until".as_ref(),
        "5".as_ref(),
        "--report".as_ref(),
        html.as_os_str(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let page = std::fs::read_to_string(&html).expect("the report is written");
    assert!(page.contains(r#""stop_reason":"until""#));
    assert!(page.contains("reached --until 5 s, not deployed"));
    let _ = std::fs::remove_dir_all(&dir);
}
