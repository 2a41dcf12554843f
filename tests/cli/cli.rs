//! The command-line front end, driven as a user would: exit status 0 on
//! success, 2 on bad input with a short `error:` message, JSON/CSV outputs.

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Output;

use super::{run, temp_dir};

fn mast_model() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("models/pantograph_mast.toml")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn assert_success(o: &Output, what: &str) {
    assert!(
        o.status.success(),
        "{what}: exit {:?}\nstdout:\n{}\nstderr:\n{}",
        o.status.code(),
        String::from_utf8_lossy(&o.stdout),
        stderr(o)
    );
}

fn read_json(p: &Path) -> Value {
    let text = std::fs::read_to_string(p).unwrap_or_else(|e| panic!("read {}: {e}", p.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("parse {}: {e}\n{text}", p.display()))
}

fn num(v: &Value, key: &str) -> f64 {
    v[key]
        .as_f64()
        .unwrap_or_else(|| panic!("`{key}` is not a number in {v:#}"))
}

fn int(v: &Value, key: &str) -> i64 {
    v[key]
        .as_i64()
        .unwrap_or_else(|| panic!("`{key}` is not an integer in {v:#}"))
}

/// Bad input: exit status 2, no panic, an `error:` message naming the problem
/// (every phrase in `phrases`). Our own messages are one paragraph; clap's
/// usage errors add a usage block, so only their first paragraph is checked.
fn assert_input_error(o: &Output, what: &str, phrases: &[&str], one_paragraph: bool) {
    let err = stderr(o);
    assert_eq!(
        o.status.code(),
        Some(2),
        "{what}: expected exit status 2\nstderr:\n{err}"
    );
    assert!(!err.contains("panicked"), "{what}: panicked:\n{err}");
    let text = err.trim();
    assert!(text.starts_with("error:"), "{what}: stderr:\n{err}");
    let first = text.split("\n\n").next().unwrap();
    if one_paragraph {
        assert_eq!(first, text, "{what}: more than one paragraph:\n{err}");
    }
    for p in phrases {
        assert!(
            first.contains(p),
            "{what}: first paragraph of stderr lacks `{p}`:\n{err}"
        );
    }
}

/// The Maxwell count `mechanisms - self_stress == coordinates - rows`.
fn assert_maxwell(coordinates: i64, rows: i64, mechanisms: i64, self_stress: i64, when: &str) {
    assert_eq!(
        mechanisms - self_stress,
        coordinates - rows,
        "Maxwell fails {when}: m={mechanisms} s={self_stress} n={coordinates} r={rows}"
    );
}

#[test]
fn generate_mast_then_analyze() {
    let d = temp_dir("gen_analyze");
    let model = d.join("mast.toml");
    let json = d.join("analyze.json");
    let o = run(&[
        "generate".as_ref(),
        "mast".as_ref(),
        "-o".as_ref(),
        model.as_os_str(),
    ]);
    assert_success(&o, "generate mast");
    assert!(model.is_file(), "generate wrote no file");

    let o = run(&[
        "analyze".as_ref(),
        model.as_os_str(),
        "--json".as_ref(),
        json.as_os_str(),
    ]);
    assert_success(&o, "analyze");
    let a = read_json(&json);
    let (n, r, rank) = (int(&a, "coordinates"), int(&a, "rows"), int(&a, "rank"));
    let (m, s) = (int(&a, "mechanisms"), int(&a, "self_stress"));
    assert_eq!(n, 30, "10 joints");
    assert_eq!(m, 1, "the mast deploys with one mechanism: {a:#}");
    assert_eq!(m, n - rank);
    assert_eq!(s, r - rank);
    assert_maxwell(n, r, m, s, "before locks");

    let (rl, rankl) = (int(&a, "rows_locked"), int(&a, "rank_locked"));
    let (ml, sl) = (int(&a, "mechanisms_locked"), int(&a, "self_stress_locked"));
    assert_eq!(ml, 0, "all locks engaged leave no mechanism: {a:#}");
    assert!(rl > r, "locks add rows: {rl} <= {r}");
    assert_eq!(ml, n - rankl);
    assert_eq!(sl, rl - rankl);
    assert_maxwell(n, rl, ml, sl, "after locks");
    assert_eq!(a["locked_geometry"], "reference");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn generated_mast_matches_the_shipped_model() {
    let d = temp_dir("gen_same");
    let model = d.join("mast.toml");
    // the bundled mast states its compliant latches (README, Bundled models)
    let o = run(&[
        "generate".as_ref(),
        "mast".as_ref(),
        "--latch-stiffness".as_ref(),
        "2e5".as_ref(),
        "--latch-damping".as_ref(),
        "300".as_ref(),
        "--output".as_ref(),
        model.as_os_str(),
    ]);
    assert_success(&o, "generate mast");
    let written = std::fs::read_to_string(&model).unwrap();
    let shipped = std::fs::read_to_string(mast_model()).unwrap();
    assert_eq!(written, shipped, "models/pantograph_mast.toml is stale");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn simulate_mast_deploys() {
    let d = temp_dir("simulate");
    let json = d.join("s.json");
    let csv = d.join("s.csv");
    let o = run(&[
        "simulate".as_ref(),
        mast_model().as_os_str(),
        "--json".as_ref(),
        json.as_os_str(),
        "--csv".as_ref(),
        csv.as_os_str(),
    ]);
    assert_success(&o, "simulate mast");
    assert!(!stderr(&o).contains("panicked"));
    let s = read_json(&json);
    assert_eq!(s["deployed"], true, "{s:#}");
    assert!(s["error"].is_null(), "{s:#}");
    assert!(num(&s, "max_constraint_violation_m") <= 1e-9, "{s:#}");
    assert!(num(&s, "final_error_rel") <= 1e-6, "{s:#}");
    assert!(num(&s, "energy_balance_rel_error") <= 1e-5, "{s:#}");
    let steps = s["steps"].as_u64().expect("steps");
    assert!(steps > 0);
    // the summary's solver line carries the JSON's counts
    let st = &s["solver_stats"];
    let line = format!(
        "solver           {} sub-steps ({} halvings), {} constraint solves ({} unconverged)",
        st["substeps"],
        st["fallbacks"]["substep_halvings"],
        st["solves"],
        st["fallbacks"]["solve_unconverged"]
    );
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains(&line), "`{line}` not in:\n{out}");
    // the bundled mast needs no fallback that accepts an inexact result: the
    // JSON's count is the sum of those counters, and no `rescued` line
    let f = &st["fallbacks"];
    let by_hand: u64 = [
        &f["solve_unconverged"],
        &f["consistent_unconverged"],
        &f["substep_energy_accepted"],
        &f["ledger_budget_exceeded"],
    ]
    .iter()
    .map(|v| v.as_u64().expect("counter"))
    .sum();
    assert_eq!(s["accepting_fallbacks"].as_u64(), Some(by_hand), "{s:#}");
    assert_eq!(by_hand, 0, "{st:#}");
    assert!(!out.contains("rescued"), "{out}");
    assert!(!out.contains("did not converge"), "{out}");
    let deploy = num(&s, "deploy_time_s");
    assert!(deploy > 0.0 && deploy <= num(&s, "time_s"), "{s:#}");

    let locks = s["locks"].as_array().expect("locks is a list");
    assert!(!locks.is_empty(), "no lock events: {s:#}");
    for l in locks {
        assert!(l["name"].is_string(), "{l:#}");
        for k in ["time_s", "impulse_ns", "energy_lost_j"] {
            let v = num(l, k);
            assert!(v.is_finite() && v >= 0.0, "lock `{k}` = {v}: {l:#}");
        }
        assert!(num(l, "time_s") <= deploy + 1e-12, "{l:#}");
    }
    // The solver's counters: one per step, one latch per lock event, at least
    // one Newmark iteration per Newmark step and one sub-step per step.
    let st = &s["solver_stats"];
    let count = |k: &str| {
        st[k]
            .as_u64()
            .unwrap_or_else(|| panic!("solver_stats.{k}: {st:#}"))
    };
    assert_eq!(count("steps"), steps, "{st:#}");
    assert_eq!(count("latches"), locks.len() as u64, "{st:#}");
    assert!(count("substeps") >= steps, "{st:#}");
    assert!(
        count("newmark_iterations") >= count("newmark_steps"),
        "{st:#}"
    );
    assert!(
        count("latch_searches") >= 1 && count("factorizations") >= 1,
        "{st:#}"
    );
    assert!(st["fallbacks"]["substep_halvings"].is_u64(), "{st:#}");

    let text = std::fs::read_to_string(&csv).expect("csv written");
    let mut lines = text.lines();
    let header = lines.next().expect("csv header");
    assert!(header.starts_with("t_s,L0_x_m"), "header: {header}");
    let columns = header.split(',').count();
    assert_eq!(columns, 1 + 3 * 10);
    let rows: Vec<&str> = lines.collect();
    assert_eq!(
        rows.len() as u64,
        steps + 1,
        "one row at t = 0 and one per step"
    );
    for r in [rows[0], rows[rows.len() - 1]] {
        let vals: Vec<f64> = r.split(',').map(|v| v.parse().expect("number")).collect();
        assert_eq!(vals.len(), columns);
        assert!(vals.iter().all(|v| v.is_finite()));
    }
    let t_last: f64 = rows[rows.len() - 1]
        .split(',')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!((t_last - num(&s, "time_s")).abs() < 1e-9);
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn simulate_until_stops_early() {
    let d = temp_dir("until");
    let json = d.join("s.json");
    let o = run(&[
        "simulate".as_ref(),
        mast_model().as_os_str(),
        "--until".as_ref(),
        "1.0".as_ref(),
        "--json".as_ref(),
        json.as_os_str(),
    ]);
    assert_success(&o, "simulate --until 1.0");
    let s = read_json(&json);
    assert_eq!(s["deployed"], false, "{s:#}");
    assert!((num(&s, "time_s") - 1.0).abs() < 1e-9, "{s:#}");
    assert!(s["locks"].as_array().unwrap().is_empty(), "{s:#}");
    assert!(s["error"].is_null(), "{s:#}");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn missing_model_file_is_an_input_error() {
    let d = temp_dir("missing");
    let model = d.join("nope.toml");
    let o = run(&["simulate".as_ref(), model.as_os_str()]);
    assert_input_error(&o, "missing model", &["nope.toml", "cannot read"], true);
    let o = run(&["analyze".as_ref(), model.as_os_str()]);
    assert_input_error(
        &o,
        "missing model (analyze)",
        &["nope.toml", "cannot read"],
        true,
    );
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn malformed_model_names_file_and_line() {
    let d = temp_dir("malformed");
    let model = d.join("bad.toml");
    let text = "[model]\nname = \"bad\"\n\n[[joint]]\nname = \"a\"\nposition_m = [0.0, 0.0, 0.0]\nmass_kg = = 1.0\n";
    std::fs::write(&model, text).unwrap();
    let o = run(&["simulate".as_ref(), model.as_os_str()]);
    assert_input_error(&o, "malformed model", &["bad.toml:7:"], true);

    // A semantic error: the line of the faulty joint's table.
    let text = "[model]\nname = \"bad\"\n\n[[joint]]\nname = \"a\"\nposition_m = [0.0, 0.0, 0.0]\nmass_kg = -1.0\n";
    std::fs::write(&model, text).unwrap();
    let o = run(&["analyze".as_ref(), model.as_os_str()]);
    assert_input_error(
        &o,
        "negative mass",
        &["bad.toml:4:", "`a`", "positive"],
        true,
    );
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn negative_dt_is_an_input_error() {
    // `--dt -1`: clap takes `-1` for a flag; it must still be exit 2, no panic.
    let o = run(&[
        "simulate".as_ref(),
        mast_model().as_os_str(),
        "--dt".as_ref(),
        "-1".as_ref(),
    ]);
    assert_input_error(&o, "--dt -1", &["-1"], false);
    // `--dt=-1` reaches the program's own check.
    let o = run(&[
        "simulate".as_ref(),
        mast_model().as_os_str(),
        "--dt=-1".as_ref(),
    ]);
    assert_input_error(&o, "--dt=-1", &["--dt", "-1", "positive"], true);
}

#[test]
fn nan_and_infinite_dt_are_input_errors() {
    for v in ["nan", "inf", "0"] {
        let o = run(&[
            "simulate".as_ref(),
            mast_model().as_os_str(),
            "--dt".as_ref(),
            v.as_ref(),
        ]);
        assert_input_error(&o, &format!("--dt {v}"), &["--dt", "positive"], true);
    }
}

#[test]
fn zero_until_is_an_input_error() {
    let o = run(&[
        "simulate".as_ref(),
        mast_model().as_os_str(),
        "--until".as_ref(),
        "0".as_ref(),
    ]);
    assert_input_error(&o, "--until 0", &["--until", "positive"], true);
}

#[test]
fn unknown_subcommand_is_an_input_error() {
    let o = run(&["frobnicate"]);
    assert_input_error(&o, "unknown subcommand", &["frobnicate"], false);
    let o = run(&["generate", "tower", "-o", "x.toml"]);
    assert_input_error(&o, "unknown generate kind", &["tower"], false);
}

#[test]
fn generate_mast_with_zero_units_is_an_input_error() {
    let d = temp_dir("units0");
    let model = d.join("m.toml");
    let o = run(&[
        "generate".as_ref(),
        "mast".as_ref(),
        "--units".as_ref(),
        "0".as_ref(),
        "-o".as_ref(),
        model.as_os_str(),
    ]);
    assert_input_error(&o, "--units 0", &["--units", "0"], true);
    assert!(!model.exists(), "nothing is written on bad input");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn writing_into_a_missing_directory_is_an_input_error() {
    let d = temp_dir("nodir");
    let json = d.join("no_such_dir").join("s.json");
    let o = run(&[
        "simulate".as_ref(),
        mast_model().as_os_str(),
        "--until".as_ref(),
        "0.1".as_ref(),
        "--json".as_ref(),
        json.as_os_str(),
    ]);
    assert_input_error(
        &o,
        "simulate --json into a missing dir",
        &["cannot write", "s.json"],
        true,
    );
    let o = run(&[
        "analyze".as_ref(),
        mast_model().as_os_str(),
        "--json".as_ref(),
        json.as_os_str(),
    ]);
    assert_input_error(
        &o,
        "analyze --json into a missing dir",
        &["cannot write", "s.json"],
        true,
    );
    let csv = d.join("no_such_dir").join("s.csv");
    let o = run(&[
        "simulate".as_ref(),
        mast_model().as_os_str(),
        "--until".as_ref(),
        "0.1".as_ref(),
        "--csv".as_ref(),
        csv.as_os_str(),
    ]);
    assert_input_error(
        &o,
        "simulate --csv into a missing dir",
        &["cannot write", "s.csv"],
        true,
    );
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn help_and_version_exit_zero() {
    for a in ["--help", "--version"] {
        let o = run(&[a]);
        assert_success(&o, a);
        assert!(!o.stdout.is_empty());
    }
}

/// BUG (src/cli/mod.rs `bench`): `bench --steps 0` indexes `times[0]` of an
/// empty vector and panics (exit 101) instead of rejecting the input with exit 2.
#[test]
fn bench_with_zero_steps_is_an_input_error() {
    let o = run(&[
        "bench".as_ref(),
        mast_model().as_os_str(),
        "--steps".as_ref(),
        "0".as_ref(),
    ]);
    assert_input_error(&o, "bench --steps 0", &["--steps"], true);
}

/// Vague error: `--dt -1` is reported by clap as an unexpected argument `-1`
/// (with a tip to write `-- -1`, which would not help); it should say that
/// --dt must be a positive number of seconds.
#[test]
fn negative_dt_message_names_the_option() {
    let o = run(&[
        "simulate".as_ref(),
        mast_model().as_os_str(),
        "--dt".as_ref(),
        "-1".as_ref(),
    ]);
    assert_input_error(&o, "--dt -1", &["--dt", "positive"], true);
}

/// `generate --start-deg` starts a model part-way: a synchronized ring generated 1 deg from
/// flat deploys in a fraction of a second with all 90 sleeves latching (the
/// quick way to study the latch); angles out of range, and a deploy angle for
/// the ring (which latches flat), are input errors that write nothing.
#[test]
fn generate_start_angle_sets_where_the_deployment_starts() {
    let d = temp_dir("start_deg");
    let (model, json) = (d.join("r1.toml"), d.join("r1.json"));
    let o = run(&[
        "generate".as_ref(),
        "ring".as_ref(),
        "--sync".as_ref(),
        "--start-deg".as_ref(),
        "1".as_ref(),
        "-o".as_ref(),
        model.as_os_str(),
    ]);
    assert_success(&o, "generate ring --start-deg 1");
    // (--until bounds the run should the latch be missed)
    let o = run(&[
        "simulate".as_ref(),
        model.as_os_str(),
        "--until".as_ref(),
        "2".as_ref(),
        "--json".as_ref(),
        json.as_os_str(),
    ]);
    assert_success(&o, "simulate the ring from 1 deg");
    let v = read_json(&json);
    assert_eq!(v["deployed"], Value::Bool(true), "{v:#}");
    let t = num(&v, "deploy_time_s");
    assert!(t > 0.0 && t < 1.0, "deploys from 1 deg in {t} s");
    assert_eq!(v["locks"].as_array().map(|l| l.len()), Some(90), "{v:#}");
    for (args, phrases) in [
        (
            &["ring", "--start-deg", "90"][..],
            &["start angle", "90"][..],
        ),
        (
            &["mast", "--start-deg", "70"][..],
            &["start angle", "70"][..],
        ),
        (
            &["ring", "--deploy-deg", "10"][..],
            &["--deploy-deg", "ring"][..],
        ),
    ] {
        let bad = d.join("bad.toml");
        let mut argv: Vec<&std::ffi::OsStr> = vec![std::ffi::OsStr::new("generate")];
        argv.extend(args.iter().map(std::ffi::OsStr::new));
        argv.extend([std::ffi::OsStr::new("-o"), bad.as_os_str()]);
        assert_input_error(&run(&argv), &args.join(" "), phrases, true);
        assert!(!bad.exists(), "{args:?}: nothing is written on bad input");
    }
    let _ = std::fs::remove_dir_all(&d);
}

/// The bay-by-bay ring's gear and stroke-stop options: written into the
/// model (108 end stops and 300 N/m gears for 36 sides), refused with a
/// clear message on the other rings, for a damping without its stops, and
/// for a stiffness that is not positive.
#[test]
fn generate_ring_gear_and_stroke_stop_options() {
    let d = temp_dir("ring_options");
    let out = d.join("r36.toml");
    let o = run(&[
        "generate",
        "ring",
        "--sides",
        "36",
        "--stroke-stops",
        "1e4",
        "--gear-stiffness",
        "300",
        "-o",
        &out.display().to_string(),
    ]);
    assert_success(&o, "generate ring --stroke-stops");
    let text = std::fs::read_to_string(&out).unwrap();
    assert_eq!(text.matches("type = \"end_stop\"").count(), 108);
    assert_eq!(text.matches("stiffness_n_per_m = 300").count(), 36);
    assert!(text.contains("Stroke stops"), "the notes say so");
    // --inner-chord-m: the rule of the paper's chords (depth = mean chord)
    // at 36 sides; the deployed inner chords have that length, and the
    // depth (c_o - c_i) / (2 sin(pi/n)) is the mean chord
    let s36 = (std::f64::consts::PI / 36.0).sin();
    let ci = 0.8757 * (1.0 - s36) / (1.0 + s36);
    let out = d.join("r36_rule.toml");
    let o = run(&[
        "generate",
        "ring",
        "--sides",
        "36",
        "--inner-chord-m",
        &format!("{ci}"),
        "-o",
        &out.display().to_string(),
    ]);
    assert_success(&o, "generate ring --inner-chord-m");
    let m = truss_deploy::model::load(&out).unwrap().model;
    let xd = m.reference.as_ref().unwrap();
    let (a, b) = (
        m.joint_index("I0_t").unwrap(),
        m.joint_index("I1_t").unwrap(),
    );
    let chord = (0..3)
        .map(|k| (xd[3 * a + k] - xd[3 * b + k]).powi(2))
        .sum::<f64>()
        .sqrt();
    assert!(
        (chord - ci).abs() < 1e-12,
        "inner chord {chord} against {ci}"
    );
    assert!(((0.8757 - ci) / (2.0 * s36) - 0.5 * (0.8757 + ci)).abs() < 1e-12);
    for (args, phrase) in [
        (
            vec!["--sync", "--gear-stiffness", "3"],
            "--gear-stiffness is an option of the bay-by-bay ring",
        ),
        (
            vec!["--stow", "--stroke-stops", "1e4"],
            "--stroke-stops is an option of the bay-by-bay ring",
        ),
        (vec!["--stroke-stop-damping", "5"], "needs stroke stops"),
        (vec!["--gear-stiffness", "0"], "--gear-stiffness 0"),
        (vec!["--stroke-stops", "-1"], "--stroke-stops -1"),
        (vec!["--inner-chord-m", "0.9"], "--inner-chord-m 0.9"),
        (vec!["--inner-chord-m", "-0.5"], "--inner-chord-m -0.5"),
        (
            vec!["--sync", "--inner-chord-m", "NaN"],
            "--inner-chord-m NaN",
        ),
        (
            vec!["mast", "--inner-chord-m", "0.7"],
            "--inner-chord-m is an option of `generate ring`, not of `generate mast`",
        ),
        (
            vec!["sail", "--members", "rigid"],
            "--members is an option of `generate ring`, not of `generate sail`",
        ),
    ] {
        // (a kind first replaces `ring`)
        let kind = ["mast", "sail"].into_iter().find(|k| args[0] == *k);
        let mut all = vec!["generate", kind.unwrap_or("ring"), "-o"];
        let o_path = d.join("bad.toml").display().to_string();
        all.push(&o_path);
        all.extend(args.iter().skip(usize::from(kind.is_some())));
        let o = run(&all);
        assert_input_error(&o, &format!("{args:?}"), &[phrase], true);
        assert!(!d.join("bad.toml").exists());
    }
}

/// The text summary's energy line names gravity's work where it is not 0,
/// as the JSON's `gravity_work_j` to the digits it prints: the mast under
/// gravity along its deploy direction for 2 s; the bundled mast (no
/// gravity, no backward-Euler step) names neither.
#[test]
fn the_energy_line_names_the_balance_terms_that_are_not_zero() {
    let d = temp_dir("energy_line");
    let text = std::fs::read_to_string(mast_model()).unwrap();
    let zero = "gravity_m_s2 = [0.0, 0.0, 0.0]\n";
    assert_eq!(text.matches(zero).count(), 1, "the mast's gravity line");
    let m = d.join("mast_g.toml");
    std::fs::write(&m, text.replace(zero, "gravity_m_s2 = [-9.81, 0.0, 0.0]\n")).unwrap();
    let j = d.join("g.json");
    for (model, json, gravity) in [(&m, &j, true), (&mast_model(), &d.join("m.json"), false)] {
        let o = run(&[
            "simulate",
            &model.display().to_string(),
            "--until",
            "2",
            "--json",
            &json.display().to_string(),
        ]);
        assert_success(&o, "simulate --until 2");
        let out = String::from_utf8_lossy(&o.stdout);
        let line = out
            .lines()
            .find(|l| l.starts_with("energy "))
            .expect("an energy line");
        let g = num(&read_json(json)["energy"], "gravity_work_j");
        assert_eq!(g != 0.0, gravity, "{g}");
        assert_eq!(
            line.contains(&format!(", gravity {g:.3e} J")),
            gravity,
            "{line}"
        );
        assert!(!line.contains("backward-Euler"), "{line}");
    }
}
