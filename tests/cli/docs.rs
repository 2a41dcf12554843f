//! The documentation against the program: docs/model-format.md lists exactly
//! the keys the model loader accepts, the README's commands run as shown, and
//! `--version` names the version and the commit.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicUsize, Ordering};
use truss_deploy::model::file::file_keys;
use truss_deploy::solver::elements::REGISTRY;

const BIN: &str = env!("CARGO_BIN_EXE_truss-deploy");

fn manifest() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn read(rel: &str) -> String {
    std::fs::read_to_string(manifest().join(rel)).unwrap_or_else(|e| panic!("read {rel}: {e}"))
}

/// The keys each section of docs/model-format.md documents: the first
/// backticked word of every table row (`| \`key\` | ...`). A `##` heading
/// naming a table (`[settings]`, `[[joint]]`) opens that table's section;
/// under `[[element]]`, a `###` heading naming an element type (`` `bar` ``)
/// opens `element:bar`; `####` headings stay in their section.
fn documented_keys(doc: &str) -> BTreeMap<String, BTreeSet<String>> {
    let mut sections: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    let mut table: Option<String> = None;
    let mut current: Option<String> = None;
    let backticked = |s: &str| -> Option<String> {
        let start = s.find('`')? + 1;
        let end = start + s[start..].find('`')?;
        Some(s[start..end].to_string())
    };
    for line in doc.lines() {
        if let Some(h) = line.strip_prefix("## ") {
            table = backticked(h)
                .filter(|t| t.starts_with('['))
                .map(|t| t.trim_matches(|c| c == '[' || c == ']').to_string());
            current = table.clone();
            if let Some(t) = &current {
                sections.entry(t.clone()).or_default();
            }
        } else if let Some(h) = line.strip_prefix("### ") {
            current = match (&table, backticked(h)) {
                (Some(t), Some(kind)) if t == "element" => Some(format!("element:{kind}")),
                _ => None,
            };
            if let Some(s) = &current {
                sections.entry(s.clone()).or_default();
            }
        } else if line.starts_with("| `") {
            if let (Some(s), Some(key)) = (&current, backticked(line)) {
                sections.get_mut(s).unwrap().insert(key);
            }
        }
    }
    sections
}

/// The keys the loader accepts, by the same section names.
fn loader_keys() -> BTreeMap<String, BTreeSet<String>> {
    let mut keys: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (table, k) in file_keys() {
        if !table.is_empty() {
            keys.insert(table.to_string(), k.iter().map(|s| s.to_string()).collect());
        }
    }
    for (kind, _, params, _) in REGISTRY {
        keys.insert(
            format!("element:{kind}"),
            params.iter().map(|s| s.to_string()).collect(),
        );
    }
    keys
}

/// Every difference between the loader's keys and the documented ones.
fn differences(doc: &str) -> Vec<String> {
    let (code, docs) = (loader_keys(), documented_keys(doc));
    let mut out = Vec::new();
    for (section, keys) in &code {
        let Some(documented) = docs.get(section) else {
            out.push(format!(
                "section `{section}` is not in docs/model-format.md"
            ));
            continue;
        };
        for k in keys.difference(documented) {
            out.push(format!(
                "`{section}` key `{k}` is accepted by the loader but not documented"
            ));
        }
        for k in documented.difference(keys) {
            out.push(format!(
                "`{section}` key `{k}` is documented but the loader rejects it"
            ));
        }
    }
    for section in docs.keys().filter(|s| !code.contains_key(*s)) {
        out.push(format!(
            "docs/model-format.md documents `{section}`, which the loader has not"
        ));
    }
    out
}

#[test]
fn model_format_page_lists_exactly_the_loaders_keys() {
    let doc = read("docs/model-format.md");
    let diff = differences(&doc);
    assert!(
        diff.is_empty(),
        "docs/model-format.md and the loader disagree:\n{}",
        diff.join("\n")
    );
    // The top level's tables are the sections.
    let top = file_keys()
        .into_iter()
        .find(|(t, _)| t.is_empty())
        .unwrap()
        .1;
    let docs = documented_keys(&doc);
    for table in top {
        assert!(docs.contains_key(*table), "table `{table}` has no section");
    }
}

#[test]
fn model_format_check_sees_a_missing_and_an_extra_key() {
    let doc = read("docs/model-format.md");
    // a key the loader has, its row removed
    let row = doc
        .lines()
        .find(|l| l.starts_with("| `lock_length_m`"))
        .expect("the sleeve's lock_length_m row");
    let without = doc.replacen(&format!("{row}\n"), "", 1);
    assert!(differences(&without)
        .iter()
        .any(|d| d.contains("element:sleeve")
            && d.contains("lock_length_m")
            && d.contains("not documented")));
    // a key the loader rejects, added to [settings]
    let with = doc.replacen(
        "| `dt_s` |",
        "| `no_such_key_s` | s | 0 | none |\n| `dt_s` |",
        1,
    );
    assert!(differences(&with)
        .iter()
        .any(|d| d.contains("no_such_key_s") && d.contains("rejects")));
    // and the loader does reject it, by name
    let model = read("models/pantograph_mast.toml").replacen(
        "[settings]\n",
        "[settings]\nno_such_key_s = 1.0\n",
        1,
    );
    let err = truss_deploy::model::parse(&model, "m.toml")
        .err()
        .expect("unknown key rejected");
    assert!(err.message.contains("no_such_key_s"), "{}", err.message);
}

#[test]
fn solver_page_names_every_setting_and_every_counter() {
    let doc = read("docs/solver.md");
    let named = |k: &str| doc.contains(&format!("`{k}`"));
    let settings = file_keys()
        .into_iter()
        .find(|(t, _)| *t == "solver")
        .unwrap()
        .1;
    assert!(settings.len() > 20, "the [solver] keys: {settings:?}");
    let missing: Vec<_> = settings.iter().filter(|k| !named(k)).collect();
    assert!(
        missing.is_empty(),
        "docs/solver.md does not name the [solver] keys {missing:?}"
    );
    // the counters, as `solver_stats` in `simulate --json` writes them
    let stats = serde_json::to_value(truss_deploy::solver::SolverStats::default()).unwrap();
    let mut counters = Vec::new();
    for (k, v) in stats.as_object().unwrap() {
        match v.as_object() {
            Some(inner) => counters.extend(inner.keys().map(|i| format!("{k}.{i}"))),
            None => counters.push(k.clone()),
        }
    }
    assert!(
        counters.iter().any(|c| c == "fallbacks.substep_halvings"),
        "{counters:?}"
    );
    let missing: Vec<_> = counters.iter().filter(|k| !named(k)).collect();
    assert!(
        missing.is_empty(),
        "docs/solver.md does not name the counters {missing:?}"
    );
}

/// A fresh, empty directory holding links to the bundled models and to
/// docs/ (the example sweep files).
fn readme_dir() -> PathBuf {
    static N: AtomicUsize = AtomicUsize::new(0);
    let d = std::env::temp_dir().join(format!(
        "truss_deploy_readme_{}_{}",
        std::process::id(),
        N.fetch_add(1, Ordering::SeqCst)
    ));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("create temp dir");
    for sub in ["models", "docs"] {
        std::os::unix::fs::symlink(manifest().join(sub), d.join(sub)).expect("link models, docs");
    }
    d
}

/// The README's commands: every line of a fenced code block that starts with
/// `truss-deploy` or `cargo run` (not `cargo test`), with the exit status a
/// trailing `# exit N` states (0 otherwise). `cargo run --release --` runs the
/// built binary.
fn readme_commands(readme: &str) -> Vec<(Vec<String>, i32, String)> {
    let mut out = Vec::new();
    let mut in_block = false;
    for line in readme.lines() {
        if line.trim_start().starts_with("```") {
            in_block = !in_block;
            continue;
        }
        let line = line.trim();
        if !in_block || !(line.starts_with("truss-deploy ") || line.starts_with("cargo run")) {
            continue;
        }
        let (command, comment) = line.split_once(" #").unwrap_or((line, ""));
        let exit = comment
            .split_whitespace()
            .skip_while(|w| *w != "exit")
            .nth(1)
            .map_or(0, |n| n.parse().expect("`# exit N` with a number"));
        let words: Vec<&str> = command.split_whitespace().collect();
        let args = if words[0] == "truss-deploy" {
            &words[1..]
        } else {
            let dashes = words
                .iter()
                .position(|w| *w == "--")
                .unwrap_or_else(|| panic!("`{line}`: cargo run without `--`"));
            &words[dashes + 1..]
        };
        out.push((
            args.iter().map(|s| s.to_string()).collect(),
            exit,
            line.to_string(),
        ));
    }
    out
}

#[test]
fn readme_commands_run_as_shown() {
    let readme = read("README.md");
    let commands = readme_commands(&readme);
    assert!(
        commands
            .iter()
            .any(|(a, _, _)| a.first().is_some_and(|c| c == "simulate")),
        "the README shows no simulate command"
    );
    let dir = readme_dir();
    for (args, exit, line) in &commands {
        let o = Command::new(BIN)
            .args(args)
            .current_dir(&dir)
            .env("RUST_BACKTRACE", "0")
            .output()
            .expect("run truss-deploy");
        assert_eq!(
            o.status.code(),
            Some(*exit),
            "README command `{line}`\nstdout:\n{}\nstderr:\n{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        );
    }
    // the summary the README's `--json run.json` wrote: every key is in docs/cli.md
    let cli = read("docs/cli.md");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("run.json")).expect("run.json"))
            .expect("JSON summary");
    let mut keys: Vec<String> = summary.as_object().unwrap().keys().cloned().collect();
    keys.extend(summary["energy"].as_object().unwrap().keys().cloned());
    keys.extend(summary["locks"][0].as_object().unwrap().keys().cloned());
    let missing: Vec<_> = keys
        .iter()
        .filter(|k| !cli.contains(&format!("`{k}`")))
        .collect();
    assert!(
        missing.is_empty(),
        "docs/cli.md does not name the summary keys {missing:?}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn readme_first_commands_are_the_two_a_newcomer_needs() {
    let readme = read("README.md");
    let first_block: Vec<&str> = readme
        .split("```")
        .nth(1)
        .expect("a code block")
        .lines()
        .skip(1)
        .map(|l| l.split(" #").next().unwrap().trim())
        .filter(|l| !l.is_empty())
        .collect();
    assert_eq!(
        first_block,
        [
            "cargo run --release -- simulate models/pantograph_mast.toml",
            "cargo test"
        ]
    );
    let words = readme.split_whitespace().count();
    assert!(words <= 1200, "README.md has {words} words (at most 1200)");
}

#[test]
fn version_names_the_version_and_the_commit() {
    let o = Command::new(BIN)
        .arg("--version")
        .output()
        .expect("run truss-deploy");
    assert!(o.status.success());
    let text = String::from_utf8_lossy(&o.stdout);
    let version = env!("CARGO_PKG_VERSION");
    assert!(text.contains(version), "`{text}` lacks {version}");
    // the commit: 7 or more hex digits, or "unknown" outside a git checkout
    let commit = text
        .split(|c: char| c.is_whitespace() || c == '(' || c == ')')
        .find(|w| *w == "unknown" || (w.len() >= 7 && w.chars().all(|c| c.is_ascii_hexdigit())));
    assert!(commit.is_some(), "`{text}` names no commit");
    if manifest().join(".git").exists() {
        let head = Command::new("git")
            .args(["rev-parse", "--short", "HEAD"])
            .current_dir(manifest())
            .output();
        if let Some(h) = head.ok().filter(|h| h.status.success()) {
            let head = String::from_utf8_lossy(&h.stdout).trim().to_string();
            assert!(text.contains(&head), "`{text}` is not HEAD's commit {head}");
        }
    }
}
