//! The corpus of malformed and degenerate models in `tests/data/`, one table:
//! each file says in its first comment lines what it exercises, the exit
//! status the binary must give (`# expect-exit:`), a fragment its message
//! must hold (`# expect-error:`, searched in stderr and stdout), and
//! optionally the command (`# command:`, default `simulate`) and extra
//! arguments (`# args:`). No case may panic or take more than a few seconds.

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_truss-deploy");

struct Case {
    file: String,
    command: String,
    args: Vec<String>,
    exit: i32,
    fragment: String,
}

fn header(text: &str, key: &str) -> Option<String> {
    text.lines()
        .take_while(|l| l.starts_with('#'))
        .find_map(|l| l.strip_prefix(&format!("# {key}:")))
        .map(|v| v.trim().to_string())
}

fn cases() -> Vec<Case> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .expect("tests/data exists")
        .map(|e| e.expect("dir entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    files
        .iter()
        .map(|p| {
            let text = std::fs::read_to_string(p).expect("read corpus file");
            let name = p.display().to_string();
            Case {
                file: name.clone(),
                command: header(&text, "command").unwrap_or_else(|| "simulate".into()),
                args: header(&text, "args")
                    .map(|a| a.split_whitespace().map(String::from).collect())
                    .unwrap_or_default(),
                exit: header(&text, "expect-exit")
                    .unwrap_or_else(|| panic!("{name}: no `# expect-exit:` line"))
                    .parse()
                    .unwrap_or_else(|e| panic!("{name}: bad expect-exit: {e}")),
                fragment: header(&text, "expect-error").unwrap_or_default(),
            }
        })
        .collect()
}

#[test]
fn every_corpus_model_gives_its_exit_status_and_message() {
    let cases = cases();
    assert!(cases.len() >= 30, "the corpus has {} files", cases.len());
    let mut failures = Vec::new();
    for c in &cases {
        let out_dir = std::env::temp_dir().join(format!("truss_corpus_{}", std::process::id()));
        std::fs::create_dir_all(&out_dir).expect("temp dir");
        let t0 = Instant::now();
        let o = Command::new(BIN)
            .arg(&c.command)
            .arg(&c.file)
            .args(&c.args)
            .env("RUST_BACKTRACE", "0")
            .current_dir(&out_dir)
            .output()
            .expect("run truss-deploy");
        let took = t0.elapsed();
        let (stdout, stderr) = (
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr),
        );
        let mut why = Vec::new();
        if o.status.code() != Some(c.exit) {
            why.push(format!("exit {:?}, expected {}", o.status.code(), c.exit));
        }
        if stderr.contains("panicked") {
            why.push("panicked".into());
        }
        if !stderr.contains(&c.fragment) && !stdout.contains(&c.fragment) {
            why.push(format!("no `{}` in the output", c.fragment));
        }
        if c.exit != 0 && !stderr.trim_start().starts_with("error:") {
            why.push("stderr does not start with `error:`".into());
        }
        if took > Duration::from_secs(20) {
            why.push(format!("took {took:?}"));
        }
        if !why.is_empty() {
            failures.push(format!(
                "{} {}: {}\nstdout:\n{stdout}\nstderr:\n{stderr}",
                c.command,
                c.file,
                why.join("; ")
            ));
        }
        let _ = std::fs::remove_dir_all(&out_dir);
    }
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}
