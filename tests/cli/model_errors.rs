//! Malformed model files: every error names the fault and, where the fault is at
//! a place in the file, the 1-based line of that place.

use truss_deploy::model::{load, parse, ModelFileError};

/// A valid 1-unit planar scissor with supports, a latching sleeve and a drive
/// cable. Every line the table below mutates is unique in this text.
const VALID: &str = r#"[model]
name = "one_unit"
description = "1-unit scissor for error tests"

[settings]
dt_s = 0.05
end_time_s = 10.0

[[joint]]
name = "L0"
position_m = [0.0, 0.0, 0.0]
mass_kg = 0.11

[[joint]]
name = "R0"
position_m = [0.4, 0.0, 0.0]
mass_kg = 0.12

[[joint]]
name = "L1"
position_m = [0.0, 0.0, 0.3]
mass_kg = 0.13

[[joint]]
name = "R1"
position_m = [0.4, 0.0, 0.3]
mass_kg = 0.14

[[element]]
type = "support"
name = "fix_L0"
joints = ["L0"]
fix = "xyz"

[[element]]
type = "support"
name = "slide_R0"
joints = ["R0"]
fix = "yz"

[[element]]
type = "support"
name = "plane_L1"
joints = ["L1"]
fix = "y"

[[element]]
type = "support"
name = "plane_R1"
joints = ["R1"]
fix = "y"

[[element]]
type = "scissor"
name = "U1"
joints = ["L0", "R1", "R0", "L1"]
ratio = 1.0

[[element]]
type = "sleeve"
name = "S1"
joints = ["L0", "L1"]
lock_length_m = 0.45

[[cable]]
name = "drive"
path = ["L0", "R0", "L1", "R1"]
tension_n = 0.5
max_tension_n = 2.0
friction_mu = 0.005
"#;

/// The shipped mast model, as written by `truss-deploy generate mast`.
const MAST: &str = include_str!("../../models/pantograph_mast.toml");

/// Applies (old, new) replacements; each `old` must occur exactly once.
fn mutate(edits: &[(&str, &str)]) -> String {
    let mut t = VALID.to_string();
    for (old, new) in edits {
        assert_eq!(
            t.matches(old).count(),
            1,
            "test bug: `{old}` must occur exactly once"
        );
        t = t.replacen(old, new, 1);
    }
    t
}

/// The error from parsing `text`, which must not parse.
fn err_of(text: &str) -> ModelFileError {
    match parse(text, "bad.toml") {
        Ok(_) => panic!("parsed OK, expected an error:\n{text}"),
        Err(e) => e,
    }
}

/// 1-based line of the single line holding `needle`.
fn line_with(text: &str, needle: &str) -> usize {
    let hits: Vec<usize> = text
        .lines()
        .enumerate()
        .filter(|(_, l)| l.contains(needle))
        .map(|(i, _)| i + 1)
        .collect();
    assert_eq!(hits.len(), 1, "test bug: `{needle}` must be on one line");
    hits[0]
}

/// 1-based line of the `[...]` / `[[...]]` header of the table holding `needle`.
fn table_of(text: &str, needle: &str) -> usize {
    let at = line_with(text, needle);
    let lines: Vec<&str> = text.lines().collect();
    (1..=at)
        .rev()
        .find(|&n| lines[n - 1].trim_start().starts_with('['))
        .expect("a table header above the needle")
}

/// Where the error must point.
#[derive(Clone, Copy, Debug)]
enum Loc {
    /// The line holding this text.
    Line(&'static str),
    /// The header line of the table holding this text.
    Table(&'static str),
    /// A literal line number.
    Nth(usize),
    /// The fault is not at one place: no line.
    Nowhere,
}

struct Case {
    what: &'static str,
    edits: Vec<(&'static str, &'static str)>,
    /// Replace the whole text instead of editing VALID.
    whole: Option<&'static str>,
    loc: Loc,
    phrases: &'static [&'static str],
}

fn case(
    what: &'static str,
    edits: Vec<(&'static str, &'static str)>,
    loc: Loc,
    phrases: &'static [&'static str],
) -> Case {
    Case {
        what,
        edits,
        whole: None,
        loc,
        phrases,
    }
}

const EXTRA_JOINT_R1B: &str =
    "mass_kg = 0.14\n\n[[joint]]\nname = \"R1b\"\nposition_m = [0.4, 0.0, 0.3]\nmass_kg = 0.1\n";

fn cases() -> Vec<Case> {
    vec![
        case(
            "TOML syntax error (doubled `=`)",
            vec![("mass_kg = 0.12", "mass_kg = = 0.12")],
            Loc::Line("mass_kg = = 0.12"),
            &["expected"],
        ),
        case(
            "unknown top-level key",
            vec![("[model]\n", "colour = \"red\"\n\n[model]\n")],
            Loc::Line("colour"),
            &["unknown field `colour`"],
        ),
        case(
            "unknown top-level table",
            vec![("friction_mu = 0.005\n", "friction_mu = 0.005\n\n[extras]\nx = 1\n")],
            Loc::Line("[extras]"),
            &["unknown field `extras`"],
        ),
        case(
            "missing joint mass",
            vec![("mass_kg = 0.12\n", "")],
            Loc::Table("name = \"R0\""),
            &["missing field `mass_kg`"],
        ),
        case(
            "unknown field in a joint",
            vec![("mass_kg = 0.12\n", "mass_kg = 0.12\ncolour = \"red\"\n")],
            Loc::Line("colour"),
            &["unknown field `colour`"],
        ),
        case(
            "a cable whose motor joint an element already names",
            vec![("name = \"S1\"", "name = \"drive_motor\"")],
            Loc::Line("name = \"drive\""),
            &["`drive_motor`", "rename the cable or the element"],
        ),
        case(
            "duplicate joint name",
            vec![("name = \"R1\"", "name = \"R0\"")],
            // the second `R0`: the one declared 4th
            Loc::Nth(25),
            &["duplicate joint name `R0`"],
        ),
        case(
            "empty joint name",
            vec![("name = \"L1\"", "name = \"\"")],
            Loc::Line("name = \"\""),
            &["empty name"],
        ),
        case(
            "element refers to an unknown joint",
            vec![(
                "joints = [\"L0\", \"R1\", \"R0\", \"L1\"]",
                "joints = [\"L0\", \"R9\", \"R0\", \"L1\"]",
            )],
            Loc::Line("\"R9\""),
            &["`U1`", "`R9`", "does not exist"],
        ),
        case(
            "cable path with an unknown joint",
            vec![(
                "path = [\"L0\", \"R0\", \"L1\", \"R1\"]",
                "path = [\"L0\", \"R0\", \"X1\", \"R1\"]",
            )],
            Loc::Line("\"X1\""),
            &["`drive`", "`X1`", "does not exist"],
        ),
        case(
            "zero-length bar (two joints at the same place)",
            vec![
                ("mass_kg = 0.14\n", EXTRA_JOINT_R1B),
                (
                    "[[cable]]",
                    "[[element]]\ntype = \"bar\"\nname = \"B0\"\njoints = [\"R1\", \"R1b\"]\n\n[[cable]]",
                ),
            ],
            Loc::Table("name = \"B0\""),
            &["`B0`", "zero-length"],
        ),
        case(
            "NaN coordinate",
            vec![("position_m = [0.0, 0.0, 0.3]", "position_m = [nan, 0.0, 0.3]")],
            Loc::Table("nan"),
            &["`L1`", "NaN"],
        ),
        case(
            "infinite mass",
            vec![("mass_kg = 0.13", "mass_kg = inf")],
            Loc::Table("mass_kg = inf"),
            &["`L1`", "infinite"],
        ),
        case(
            "negative mass",
            vec![("mass_kg = 0.13", "mass_kg = -0.13")],
            Loc::Table("mass_kg = -0.13"),
            &["`L1`", "mass_kg = -0.13", "positive"],
        ),
        case(
            "zero mass",
            vec![("mass_kg = 0.13", "mass_kg = 0.0")],
            Loc::Table("mass_kg = 0.0"),
            &["`L1`", "positive"],
        ),
        case(
            "cable path of one joint",
            vec![("path = [\"L0\", \"R0\", \"L1\", \"R1\"]", "path = [\"L0\"]")],
            Loc::Line("path = [\"L0\"]"),
            &["`drive`", "1 joint"],
        ),
        case(
            "unknown element type",
            vec![("type = \"sleeve\"", "type = \"rope\"")],
            // element errors point at the element's [[element]] header
            Loc::Table("type = \"rope\""),
            &["`S1`", "unknown element type `rope`"],
        ),
        case(
            "unknown element parameter (typo lenght_m)",
            vec![(
                "[[cable]]",
                "[[element]]\ntype = \"bar\"\nname = \"B1\"\njoints = [\"L0\", \"R0\"]\nlenght_m = 0.4\n\n[[cable]]",
            )],
            Loc::Table("lenght_m"),
            &["`B1`", "unknown parameter `lenght_m`", "length_m"],
        ),
        case(
            "sleeve without lock_length_m",
            vec![("lock_length_m = 0.45\n", "")],
            Loc::Table("name = \"S1\""),
            &["`S1`", "lock_length_m"],
        ),
        case(
            "support with fix = \"w\"",
            vec![("fix = \"yz\"", "fix = \"w\"")],
            Loc::Table("fix = \"w\""),
            &["`slide_R0`", "\"w\""],
        ),
        case(
            "support with fix = \"\"",
            vec![("fix = \"yz\"", "fix = \"\"")],
            Loc::Table("fix = \"\""),
            &["`slide_R0`", "fix"],
        ),
        case(
            "scissor rods do not cross at the pivot",
            vec![("position_m = [0.4, 0.0, 0.3]", "position_m = [0.4, 0.0, 0.35]")],
            Loc::Table("name = \"U1\""),
            // pivot row z: (L0 - R0)/2 + (R1 - L1)/2 = 0.05/2
            &["`U1`", "initial geometry", "2.500e-2"],
        ),
        case(
            "bar with explicit length_m different from the joint distance",
            vec![(
                "[[cable]]",
                "[[element]]\ntype = \"bar\"\nname = \"B2\"\njoints = [\"L0\", \"R0\"]\nlength_m = 0.5\n\n[[cable]]",
            )],
            Loc::Table("name = \"B2\""),
            &["`B2`", "initial geometry", "-1.000e-1"],
        ),
        case(
            "duplicate element name",
            vec![("name = \"S1\"", "name = \"U1\"")],
            Loc::Nth(61),
            &["duplicate element name `U1`"],
        ),
        case(
            "reference_m for only some joints",
            vec![(
                "mass_kg = 0.12\n",
                "mass_kg = 0.12\nreference_m = [0.2, 0.0, 0.0]\n",
            )],
            Loc::Nowhere,
            &["1 of 4 joints", "reference_m"],
        ),
        case(
            "cable tension above max_tension_n",
            vec![("tension_n = 0.5", "tension_n = 5.0")],
            Loc::Table("tension_n = 5.0"),
            &["`drive`", "max_tension_n"],
        ),
        case(
            "scissor ratio = 0",
            vec![("ratio = 1.0", "ratio = 0.0")],
            Loc::Table("ratio = 0.0"),
            &["`U1`", "ratio", "positive"],
        ),
        case(
            "scissor ratio < 0",
            vec![("ratio = 1.0", "ratio = -1")],
            Loc::Table("ratio = -1"),
            &["`U1`", "ratio", "positive"],
        ),
        case(
            "scissor ratio as text",
            vec![("ratio = 1.0", "ratio = \"one\"")],
            Loc::Table("ratio = \"one\""),
            &["`U1`", "ratio", "number"],
        ),
        case(
            "scissor ratio NaN",
            vec![("ratio = 1.0", "ratio = nan")],
            Loc::Table("ratio = nan"),
            &["`U1`", "ratio", "finite"],
        ),
        case(
            "element parameter that is an array",
            vec![("ratio = 1.0", "ratio = [1.0]")],
            Loc::Table("ratio = [1.0]"),
            &["`U1`", "ratio"],
        ),
        case(
            "element naming a joint twice",
            vec![("joints = [\"L0\", \"L1\"]", "joints = [\"L0\", \"L0\"]")],
            Loc::Table("joints = [\"L0\", \"L0\"]"),
            &["`S1`", "`L0` twice"],
        ),
        case(
            "scissor with 3 joints",
            vec![(
                "joints = [\"L0\", \"R1\", \"R0\", \"L1\"]",
                "joints = [\"L0\", \"R1\", \"R0\"]",
            )],
            Loc::Table("name = \"U1\""),
            &["`U1`", "4 joints", "3 are given"],
        ),
        case(
            "negative cable friction",
            vec![("friction_mu = 0.005", "friction_mu = -0.1")],
            Loc::Table("friction_mu = -0.1"),
            &["`drive`", "friction"],
        ),
        case(
            "cable path repeating a joint",
            vec![(
                "path = [\"L0\", \"R0\", \"L1\", \"R1\"]",
                "path = [\"L0\", \"R0\", \"R0\", \"R1\"]",
            )],
            Loc::Table("path = [\"L0\", \"R0\", \"R0\", \"R1\"]"),
            &["`drive`", "distinct"],
        ),
        case(
            "element joints as a string, not a list",
            vec![("joints = [\"L0\", \"L1\"]", "joints = \"L0\"")],
            Loc::Line("joints = \"L0\""),
            &["invalid type", "sequence"],
        ),
        case(
            "NaN in [settings]",
            vec![("dt_s = 0.05", "dt_s = nan")],
            Loc::Line("[settings]"),
            &["[settings]", "`dt_s`", "NaN"],
        ),
        case(
            "negative dt_s",
            vec![("dt_s = 0.05", "dt_s = -0.05")],
            Loc::Line("[settings]"),
            &["`dt_s` = -0.05", "> 0"],
        ),
        case(
            "[solver] with an unknown key (typo newmark_max_iteration)",
            vec![(
                "friction_mu = 0.005\n",
                "friction_mu = 0.005\n\n[solver]\nlock_tol_m = 1e-9\nnewmark_max_iteration = 5\n",
            )],
            Loc::Line("newmark_max_iteration"),
            &["unknown field `newmark_max_iteration`", "newmark_max_iterations"],
        ),
        case(
            "[solver] with an iteration limit of 0",
            vec![(
                "friction_mu = 0.005\n",
                "friction_mu = 0.005\n\n[solver]\nroot_max_iterations = 0\n",
            )],
            Loc::Table("root_max_iterations"),
            &["[solver] root_max_iterations = 0", "at least 1"],
        ),
        case(
            "[solver] with a NaN tolerance",
            vec![(
                "friction_mu = 0.005\n",
                "friction_mu = 0.005\n\n[solver]\nlock_tol_m = nan\n",
            )],
            Loc::Table("lock_tol_m"),
            &["[solver] lock_tol_m = NaN", "finite number > 0"],
        ),
        Case {
            what: "empty file",
            edits: vec![],
            whole: Some(""),
            loc: Loc::Nth(1),
            phrases: &["missing field `model`"],
        },
        Case {
            what: "only a [model] header: no joints",
            edits: vec![],
            whole: Some("[model]\nname = \"empty\"\n"),
            loc: Loc::Nowhere,
            phrases: &["no [[joint]] entries"],
        },
    ]
}

#[test]
fn malformed_models_report_line_and_cause() {
    let mut failures = Vec::new();
    let all = cases();
    for c in &all {
        let text = match c.whole {
            Some(t) => t.to_string(),
            None => mutate(&c.edits),
        };
        let expected = match c.loc {
            Loc::Line(n) => Some(line_with(&text, n)),
            Loc::Table(n) => Some(table_of(&text, n)),
            Loc::Nth(n) => Some(n),
            Loc::Nowhere => None,
        };
        match parse(&text, "bad.toml") {
            Ok(_) => failures.push(format!("{}: parsed OK, expected an error", c.what)),
            Err(e) => {
                if e.file != "bad.toml" {
                    failures.push(format!("{}: file is `{}`", c.what, e.file));
                }
                if e.line != expected {
                    failures.push(format!(
                        "{}: line {:?}, expected {:?} ({})",
                        c.what, e.line, expected, e.message
                    ));
                }
                for p in c.phrases {
                    if !e.message.contains(p) {
                        failures.push(format!("{}: message lacks `{p}`: {}", c.what, e.message));
                    }
                }
            }
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} cases failed:\n{}",
        failures.len(),
        all.len(),
        failures.join("\n")
    );
}

#[test]
fn valid_models_parse() {
    let m = parse(VALID, "ok.toml").expect("the test's base model is valid");
    assert_eq!(m.model.n_joints(), 4);
    assert_eq!(m.model.elements.len(), 6);
    assert_eq!(m.model.cables.len(), 1);
    assert_eq!(m.model.locks.len(), 1, "the sleeve latches");
    assert!(m.model.reference.is_none());

    let mast = parse(MAST, "pantograph_mast.toml").expect("shipped mast is valid");
    assert_eq!(mast.model.n_joints(), 10);
    assert_eq!(mast.model.locks.len(), 4);
    assert!(mast.model.reference.is_some());
    assert!(!mast.notes.is_empty());
}

#[test]
fn error_display_is_file_colon_line() {
    let text = mutate(&[("mass_kg = 0.13", "mass_kg = -0.13")]);
    let e = err_of(&text);
    let shown = e.to_string();
    assert!(
        shown.starts_with("bad.toml:19: "),
        "Display should start with file:line: {shown}"
    );
    let e = err_of("[model]\nname = \"x\"\n");
    assert!(e.to_string().starts_with("bad.toml: "), "{e}");
}

#[test]
fn unclosed_array_points_at_or_just_after_the_fault() {
    // The TOML parser notices a missing `]` only at the next token, which is on
    // the following line; accept the faulty line or the one after it.
    let text = mutate(&[(
        "position_m = [0.4, 0.0, 0.0]",
        "position_m = [0.4, 0.0, 0.0",
    )]);
    let fault = line_with(&text, "position_m = [0.4, 0.0, 0.0");
    let e = err_of(&text);
    let line = e.line.expect("a syntax error has a line");
    assert!(
        line == fault || line == fault + 1,
        "line {line}, fault on {fault}: {}",
        e.message
    );
    assert!(e.message.contains("]"), "{}", e.message);
}

#[test]
fn case_sensitive_names_and_reference_on_all_joints() {
    // A joint name that is valid but collides only in case is accepted (names are case-sensitive).
    let text = mutate(&[(
        "mass_kg = 0.14\n",
        "mass_kg = 0.14\n\n[[joint]]\nname = \"r1\"\nposition_m = [1.0, 0.0, 0.3]\nmass_kg = 0.1\n",
    )]);
    assert!(parse(&text, "ok.toml").is_ok());
    // reference_m on every joint is accepted (the deployed geometry: the
    // sleeve L0-L1 at its lock length 0.45 m, the 0.5 m rods crossing at
    // their middles); one of them NaN is not.
    let w = (0.25f64 - 0.45 * 0.45).sqrt();
    let all_ref = mutate(&[
        (
            "mass_kg = 0.11",
            "reference_m = [0.0, 0.0, 0.0]\nmass_kg = 0.11",
        ),
        (
            "mass_kg = 0.12",
            &format!("reference_m = [{w:?}, 0.0, 0.0]\nmass_kg = 0.12"),
        ),
        (
            "mass_kg = 0.13",
            "reference_m = [0.0, 0.0, 0.45]\nmass_kg = 0.13",
        ),
        (
            "mass_kg = 0.14",
            &format!("reference_m = [{w:?}, 0.0, 0.45]\nmass_kg = 0.14"),
        ),
    ]);
    if let Err(e) = parse(&all_ref, "ok.toml") {
        panic!("{e}");
    }
    let one_nan = all_ref.replacen(
        "reference_m = [0.0, 0.0, 0.45]\nmass_kg = 0.13",
        "reference_m = [nan, 0.0, 0.0]\nmass_kg = 0.13",
        1,
    );
    let e = err_of(&one_nan);
    assert_eq!(e.line, Some(table_of(&one_nan, "reference_m = [nan")));
    assert!(e.message.contains("`L1`"), "{}", e.message);
}

#[test]
fn load_of_a_missing_file_has_no_line() {
    let path = std::env::temp_dir().join(format!(
        "truss_deploy_missing_{}/nope.toml",
        std::process::id()
    ));
    let e = match load(&path) {
        Ok(_) => panic!("loading a missing file succeeded"),
        Err(e) => e,
    };
    assert_eq!(e.line, None);
    assert!(e.message.contains("cannot read"), "{}", e.message);
    assert!(e.file.ends_with("nope.toml"));
}

/// Parses every variant; a panic inside `parse` fails the test with the variant named.
fn parse_never_panics(what: &str, variants: impl Iterator<Item = (String, String)>) {
    let mut n = 0;
    for (label, text) in variants {
        let r = std::panic::catch_unwind(|| parse(&text, "cut.toml").map(|_| ()));
        assert!(r.is_ok(), "{what}: parse panicked on {label}:\n{text}");
        if let Ok(Err(e)) = r {
            assert!(
                !e.message.trim().is_empty(),
                "{what}: empty message on {label}"
            );
            if let Some(l) = e.line {
                assert!(
                    l >= 1 && l <= text.matches('\n').count() + 1,
                    "{what}: line {l} outside the file on {label}"
                );
            }
        }
        n += 1;
    }
    assert!(n > 0);
}

fn without_line(text: &str, i: usize) -> String {
    text.split_inclusive('\n')
        .enumerate()
        .filter(|(k, _)| *k != i)
        .map(|(_, l)| l)
        .collect()
}

#[test]
fn deleting_any_single_line_never_panics() {
    for (name, base) in [("one_unit", VALID), ("mast", MAST)] {
        let n = base.lines().count();
        parse_never_panics(
            name,
            (0..n).map(|i| (format!("line {} deleted", i + 1), without_line(base, i))),
        );
    }
}

#[test]
fn truncating_anywhere_never_panics() {
    for (name, base) in [("one_unit", VALID), ("mast", MAST)] {
        // At the start of every line, and in the middle of every line.
        let mut cuts = vec![];
        let mut off = 0;
        for l in base.split_inclusive('\n') {
            cuts.push(off);
            cuts.push(off + l.len() / 2);
            off += l.len();
        }
        cuts.push(base.len());
        parse_never_panics(
            name,
            cuts.into_iter()
                .map(|c| (format!("cut at byte {c}"), base[..c].to_string())),
        );
    }
}
