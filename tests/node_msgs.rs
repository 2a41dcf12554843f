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
    };
    let _ = TrussState {
        header: h,
        joint_names: Vec::<String>::new(),
        positions: Vec::<Point>::new(),
        velocities: Vec::<Vector3>::new(),
        deploy_fraction: 0f64,
        remaining_dof: 0u32,
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
