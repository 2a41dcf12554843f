//! The .msg files are the single source of truth: the Rust wire structs must match
//! them field by field (name, type, order). Parses msg/*.msg, compares with the
//! hand-kept table `node::msgs::CUSTOM_FIELDS`, and compares that table's names with
//! the names the structs' serde derive really uses (captured by a tiny Deserializer).
#![cfg(feature = "ros")]

use serde::de::{self, Deserialize, Visitor};
use std::cell::RefCell;
use truss_deploy::node::msgs::{self, CUSTOM_FIELDS};

fn parse_msg(path: &std::path::Path) -> Vec<(String, String)> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut out = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap().trim();
        if line.is_empty() {
            continue;
        }
        let parts: Vec<&str> = line.split_whitespace().collect();
        assert!(
            parts.len() == 2 && !line.contains('='),
            "{}:{}: expected `type name` (no constants/defaults in these messages): {line}",
            path.display(),
            n + 1
        );
        out.push((parts[1].to_string(), parts[0].to_string()));
    }
    out
}

thread_local! {
    static CAPTURED: RefCell<Option<(&'static str, &'static [&'static str])>> = const { RefCell::new(None) };
}

/// A Deserializer that records the struct name and field list serde asks for.
struct Capture;

#[derive(Debug)]
struct Stop;
impl std::fmt::Display for Stop {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("captured")
    }
}
impl std::error::Error for Stop {}
impl de::Error for Stop {
    fn custom<T: std::fmt::Display>(_: T) -> Self {
        Stop
    }
}

impl<'de> de::Deserializer<'de> for Capture {
    type Error = Stop;
    fn deserialize_any<V: Visitor<'de>>(self, _: V) -> Result<V::Value, Stop> {
        Err(Stop)
    }
    fn deserialize_struct<V: Visitor<'de>>(
        self,
        name: &'static str,
        fields: &'static [&'static str],
        _: V,
    ) -> Result<V::Value, Stop> {
        CAPTURED.with(|c| *c.borrow_mut() = Some((name, fields)));
        Err(Stop)
    }
    serde::forward_to_deserialize_any! {
        bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string
        bytes byte_buf option unit unit_struct newtype_struct seq tuple
        tuple_struct map enum identifier ignored_any
    }
}

fn serde_fields<T: for<'de> Deserialize<'de>>() -> (&'static str, Vec<&'static str>) {
    CAPTURED.with(|c| *c.borrow_mut() = None);
    let _ = T::deserialize(Capture);
    let (n, f) = CAPTURED.with(|c| c.borrow().expect("struct captured"));
    (n, f.to_vec())
}

#[test]
fn msg_files_match_rust_structs_field_by_field() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("msg");
    let mut seen = Vec::new();
    for entry in std::fs::read_dir(&dir).unwrap() {
        let p = entry.unwrap().path();
        if p.extension().and_then(|e| e.to_str()) == Some("msg") {
            seen.push(p.file_stem().unwrap().to_str().unwrap().to_string());
        }
    }
    seen.sort();
    let mut table: Vec<String> = CUSTOM_FIELDS.iter().map(|(n, _)| n.to_string()).collect();
    table.sort();
    assert_eq!(
        seen, table,
        "every msg/*.msg has a Rust struct and vice versa"
    );

    for (name, fields) in CUSTOM_FIELDS {
        let parsed = parse_msg(&dir.join(format!("{name}.msg")));
        let table: Vec<(String, String)> = fields
            .iter()
            .map(|(f, t)| (f.to_string(), t.to_string()))
            .collect();
        assert_eq!(parsed.len(), table.len(), "{name}: number of fields");
        for (i, (p, t)) in parsed.iter().zip(&table).enumerate() {
            assert_eq!(p, t, "{name}: field {i} differs (.msg vs Rust table)");
        }
    }

    let structs = [
        serde_fields::<msgs::CableForceCommand>(),
        serde_fields::<msgs::CableSpeedCommand>(),
        serde_fields::<msgs::LockStatus>(),
        serde_fields::<msgs::TrussState>(),
    ];
    for (sname, sfields) in structs {
        let (_, fields) = CUSTOM_FIELDS
            .iter()
            .find(|(n, _)| *n == sname)
            .unwrap_or_else(|| panic!("struct {sname} not in CUSTOM_FIELDS"));
        let tnames: Vec<&str> = fields.iter().map(|(f, _)| *f).collect();
        assert_eq!(sfields, tnames, "{sname}: serde field names/order vs table");
    }
}

#[test]
fn rust_field_types_are_what_the_table_says() {
    // Type check of the table against the structs: build a value whose fields
    // have the table's types (compile-time: this only compiles if they do).
    use msgs::*;
    let h = Header::default();
    let _ = CableForceCommand {
        names: Vec::<String>::new(),
        tensions_n: Vec::<f64>::new(),
    };
    let _ = LockStatus {
        header: h.clone(),
        names: Vec::<String>::new(),
        locked: Vec::<bool>::new(),
        time_s: Vec::<f64>::new(),
        impulse_ns: Vec::<f64>::new(),
        energy_lost_j: Vec::<f64>::new(),
        deployed: false,
        paused: false,
        cable_names: Vec::<String>::new(),
        cable_tensions_n: Vec::<f64>::new(),
        accepted_commands: 0u32,
        rejected_commands: 0u32,
        rejected_unknown_cable: 0u32,
        rejected_mismatched_lengths: 0u32,
        rejected_bad_tension: 0u32,
        rejected_malformed: 0u32,
        rejected_bad_speed: 0u32,
    };
    let _ = CableSpeedCommand {
        names: Vec::<String>::new(),
        speeds_m_s: Vec::<f64>::new(),
    };
    let _ = TrussState {
        header: h,
        joint_names: Vec::<String>::new(),
        positions: Vec::<Point>::new(),
        velocities: Vec::<Vector3>::new(),
        deploy_fraction: 0f64,
        remaining_dof: 0u32,
        cable_names: Vec::<String>::new(),
        motor_tensions_n: Vec::<f64>::new(),
        reeled_in_m: Vec::<f64>::new(),
        motor_modes: Vec::<String>::new(),
    };
    // and the ROS type mapping the table uses
    for (_, fields) in CUSTOM_FIELDS {
        for (_, t) in *fields {
            let base = t.trim_end_matches("[]");
            assert!(
                [
                    "string",
                    "float64",
                    "bool",
                    "uint32",
                    "std_msgs/Header",
                    "geometry_msgs/Point",
                    "geometry_msgs/Vector3"
                ]
                .contains(&base),
                "type {t} has no Rust mapping here"
            );
        }
    }
}

/// Parses one part of a simulation_interfaces file: "msg", or "request" /
/// "response" of a .srv. Returns the fields (name, type) and the constants
/// (name, value); a field's default value (`uint64 steps 1`) is ignored.
fn parse_part(text: &str, part: &str) -> (Vec<(String, String)>, Vec<(String, i64)>) {
    let sections: Vec<&str> = text.split("\n---").collect();
    let body = match part {
        "msg" => sections[0],
        "request" => sections[0],
        "response" => sections.get(1).expect("a .srv has a response part"),
        _ => unreachable!(),
    };
    let (mut fields, mut consts) = (Vec::new(), Vec::new());
    for line in body.lines() {
        let line = line.split('#').next().unwrap().trim();
        if line.is_empty() || line == "---" {
            continue;
        }
        if let Some((lhs, rhs)) = line.split_once('=') {
            let name = lhs.split_whitespace().nth(1).expect("constant name");
            consts.push((
                name.to_string(),
                rhs.trim().parse().expect("integer constant"),
            ));
            continue;
        }
        let parts: Vec<&str> = line.split_whitespace().collect();
        assert!(parts.len() == 2 || parts.len() == 3, "field line: {line}");
        fields.push((parts[1].to_string(), parts[0].to_string()));
    }
    (fields, consts)
}

/// The simulation_interfaces 2.x structs match the published .msg/.srv text
/// (tests/data/simulation_interfaces-2.1.0) field by field, and the constants
/// the node uses have the published values.
#[test]
fn simulation_interfaces_structs_match_the_published_definitions() {
    use msgs::sim_if;
    use msgs::*;
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/simulation_interfaces-2.1.0");
    let read =
        |f: &str| std::fs::read_to_string(dir.join(f)).unwrap_or_else(|e| panic!("{f}: {e}"));
    for (file, part, fields) in msgs::SIM_IF_FIELDS {
        let (parsed, _) = parse_part(&read(file), part);
        let table: Vec<(String, String)> = fields
            .iter()
            .map(|(f, t)| (f.to_string(), t.to_string()))
            .collect();
        assert_eq!(parsed, table, "{file} {part}: fields (name, type, order)");
    }
    // the table's names are the structs' serde names; empty requests carry
    // ROS's one dummy byte
    let check = |file: &str, part: &str, got: (&str, Vec<&str>)| {
        let (_, _, fields) = msgs::SIM_IF_FIELDS
            .iter()
            .find(|(f, p, _)| *f == file && *p == part)
            .unwrap();
        let names: Vec<&str> = fields.iter().map(|(n, _)| *n).collect();
        if names.is_empty() {
            assert_eq!(
                got.1,
                ["structure_needs_at_least_one_member"],
                "{file} {part}"
            );
        } else {
            assert_eq!(got.1, names, "{file} {part} ({})", got.0);
        }
    };
    check("Result.msg", "msg", serde_fields::<SimResult>());
    check(
        "SimulationState.msg",
        "msg",
        serde_fields::<SimulationState>(),
    );
    check(
        "SimulatorFeatures.msg",
        "msg",
        serde_fields::<SimulatorFeatures>(),
    );
    check(
        "GetSimulatorFeatures.srv",
        "request",
        serde_fields::<EmptyRequest>(),
    );
    check(
        "GetSimulatorFeatures.srv",
        "response",
        serde_fields::<GetSimulatorFeaturesResponse>(),
    );
    check(
        "GetSimulationState.srv",
        "request",
        serde_fields::<EmptyRequest>(),
    );
    check(
        "GetSimulationState.srv",
        "response",
        serde_fields::<GetSimulationStateResponse>(),
    );
    check(
        "SetSimulationState.srv",
        "request",
        serde_fields::<SetSimulationStateRequest>(),
    );
    check(
        "SetSimulationState.srv",
        "response",
        serde_fields::<ResultResponse>(),
    );
    check(
        "ResetSimulation.srv",
        "request",
        serde_fields::<ResetSimulationRequest>(),
    );
    check(
        "ResetSimulation.srv",
        "response",
        serde_fields::<ResultResponse>(),
    );
    check(
        "StepSimulation.srv",
        "request",
        serde_fields::<StepSimulationRequest>(),
    );
    check(
        "StepSimulation.srv",
        "response",
        serde_fields::<ResultResponse>(),
    );
    // Rust types of the table's ROS types (compile-time: only builds if they are)
    let _ = SimResult {
        result: 0u8,
        error_message: String::new(),
    };
    let _ = SimulationState { state: 0u8 };
    let _ = SimulatorFeatures {
        features: Vec::<u16>::new(),
        spawn_formats: Vec::<String>::new(),
        custom_info: String::new(),
    };
    let _ = ResetSimulationRequest { scope: 0u8 };
    let _ = StepSimulationRequest { steps: 0u64 };
    // constants
    for (file, name, value) in sim_if::ALL {
        let text = read(file);
        let consts = ["msg", "response"]
            .iter()
            .flat_map(|p| {
                if *p == "response" && !file.ends_with(".srv") {
                    vec![]
                } else {
                    parse_part(&text, p).1
                }
            })
            .collect::<Vec<_>>();
        let got = consts
            .iter()
            .find(|(n, _)| n == name)
            .unwrap_or_else(|| panic!("{file}: no constant {name}"));
        assert_eq!(got.1, *value, "{file} {name}");
    }
}

/// The SimulateSteps action's wire structs (rcl_action's layout: the goal id
/// before the goal and the feedback, the status before the result) carry the
/// fields of tests/data/simulation_interfaces-2.1.0/SimulateSteps.action.
#[test]
fn simulate_steps_structs_match_the_published_action() {
    use msgs::action::*;
    let text = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/data/simulation_interfaces-2.1.0/SimulateSteps.action"),
    )
    .unwrap();
    let parts: Vec<Vec<(String, String)>> = text
        .split("\n---")
        .map(|p| {
            let (fields, _) = parse_part(p, "msg");
            fields
        })
        .collect();
    assert_eq!(parts.len(), 3, "goal, result, feedback");
    let names = |p: &[(String, String)]| -> Vec<String> { p.iter().map(|f| f.0.clone()).collect() };
    assert_eq!(parts[0], [("steps".to_string(), "uint64".to_string())]);
    assert_eq!(parts[1], [("result".to_string(), "Result".to_string())]);
    let mut goal = vec!["goal_id".to_string()];
    goal.extend(names(&parts[0]));
    assert_eq!(serde_fields::<SendGoalRequest>().1, goal);
    let mut fb = vec!["goal_id".to_string()];
    fb.extend(names(&parts[2]));
    assert_eq!(serde_fields::<FeedbackMessage>().1, fb);
    let mut res = vec!["status".to_string()];
    res.extend(names(&parts[1]));
    assert_eq!(serde_fields::<GetResultResponse>().1, res);
}
