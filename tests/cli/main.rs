//! The command line as a user runs it: the built binary on model files,
//! its outputs, plots, exit statuses and error messages.

mod bus;
mod cli;
mod cli_plots;
mod docs;
mod history;
mod malformed_corpus;
mod model_errors;
mod modes;
mod motor_speed;
mod report;
mod run_outcomes;
mod sweep;

use std::path::PathBuf;
use std::process::{Command, Output};
use std::sync::atomic::{AtomicUsize, Ordering};

/// The binary under test.
pub const BIN: &str = env!("CARGO_BIN_EXE_truss-deploy");

/// A fresh, empty directory for one test (`test` names it).
pub fn temp_dir(test: &str) -> PathBuf {
    static N: AtomicUsize = AtomicUsize::new(0);
    let d = std::env::temp_dir().join(format!(
        "truss_deploy_cli_{}_{}_{test}",
        std::process::id(),
        N.fetch_add(1, Ordering::SeqCst)
    ));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("create temp dir");
    d
}

/// Runs the binary with `args` to its end (no backtraces in its output).
pub fn run<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> Output {
    Command::new(BIN)
        .args(args)
        .env("RUST_BACKTRACE", "0")
        .output()
        .expect("run truss-deploy")
}

/// A finished run's exit status, stdout and stderr, for assertion messages
/// and for what a test looks for in the output.
pub fn text(o: &Output) -> String {
    format!(
        "exit {:?}\nstdout:\n{}\nstderr:\n{}",
        o.status.code(),
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// TRUSS_PYTHON if it imports `modules` (and `missing` is None: a
/// non-Python prerequisite found); None, skipped with the reason, unless
/// the environment variable `require` is "1", when it fails instead.
/// `install` says what to install.
pub fn python_with(
    modules: &str,
    missing: Option<String>,
    require: &str,
    install: &str,
) -> Option<String> {
    let required = std::env::var(require).as_deref() == Ok("1");
    let why = match std::env::var("TRUSS_PYTHON") {
        Err(_) => "TRUSS_PYTHON is not set".to_string(),
        Ok(_) if missing.is_some() => missing.unwrap_or_default(),
        Ok(py) => match Command::new(&py)
            .args(["-c", &format!("import {modules}")])
            .output()
        {
            Ok(o) if o.status.success() => return Some(py),
            Ok(o) => format!(
                "{py} cannot import {modules}: {}",
                String::from_utf8_lossy(&o.stderr)
            ),
            Err(e) => format!("cannot run {py}: {e}"),
        },
    };
    assert!(!required, "{require}=1 but {why}");
    eprintln!("\n!!!!!!!! SKIPPED: {why}; install {install} and set TRUSS_PYTHON (.ci/run does) !!!!!!!!\n");
    None
}
