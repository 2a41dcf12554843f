//! ROS 2 MCAP recordings (`simulate --mcap`, `node --record`) read back by two
//! independent readers, Python `mcap` + `mcap-ros2-support` and `rosbags`
//! (tests/python/check_mcap.py): every message decodes with the schemas in the
//! file, and counts, stamps and the final lock state agree with the run's JSON
//! summary. Interpreter: env TRUSS_PYTHON (.ci/run sets it to its venv, where it
//! installs the readers). Skipped, with a message, only when TRUSS_PYTHON is unset.
#![cfg(feature = "ros")]

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

const MAST: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/models/pantograph_mast.toml");
const CHECK: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/python/check_mcap.py");
const BIN: &str = env!("CARGO_BIN_EXE_truss-deploy");

fn python() -> Option<String> {
    match std::env::var("TRUSS_PYTHON") {
        Ok(p) if !p.is_empty() => Some(p),
        _ => {
            eprintln!(
                "\n!!!!!!!! SKIPPED record_mcap: TRUSS_PYTHON is not set. It must name a Python with \
                 rosbags, mcap and mcap-ros2-support (.ci/run installs them into .ci/venv and sets it). !!!!!!!!\n"
            );
            None
        }
    }
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("truss_record_{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

/// Runs check_mcap.py on `file` and returns its SUMMARY object.
fn check(py: &str, file: &Path, partial: bool) -> Value {
    let mut cmd = Command::new(py);
    cmd.arg(CHECK).arg(file);
    if partial {
        cmd.arg("--partial");
    }
    let out = cmd.output().expect("run check_mcap.py");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "check_mcap.py failed on {}:\n{stdout}\n{}",
        file.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    let line = stdout
        .lines()
        .find_map(|l| l.strip_prefix("SUMMARY "))
        .expect("SUMMARY line");
    serde_json::from_str(line).unwrap()
}

/// `simulate` on the bundled mast with `args`; it must succeed.
fn simulate_mast(args: &[&std::ffi::OsStr]) {
    let out = Command::new(BIN)
        .args(["simulate", MAST])
        .args(args)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "simulate {args:?}: {err}");
}

const TOPICS: [(&str, &str); 7] = [
    ("/joint_states", "sensor_msgs/msg/JointState"),
    ("/truss/state", "truss_deploy/msg/TrussState"),
    ("/truss/lock_status", "truss_deploy/msg/LockStatus"),
    ("/truss/markers", "visualization_msgs/msg/MarkerArray"),
    ("/clock", "rosgraph_msgs/msg/Clock"),
    ("/tf", "tf2_msgs/msg/TFMessage"),
    ("/tf_static", "tf2_msgs/msg/TFMessage"),
];

fn count(v: &Value, reader: &str, topic: &str) -> u64 {
    v[reader]["topics"][topic]["count"].as_u64().unwrap_or(0)
}

/// What both readers must agree on for any finished recording: the five
/// topics with their types, the ros2 profile and encodings, the QoS of
/// DESIGN.md, every message decoded by both with stamp = log time = publish
/// time, the same counts as the summary's statistics, the same final messages.
/// Every recorded MarkerArray decodes with the official definitions of the
/// distributions in `ok` (rosbags' type stores, independent of the schema the
/// file carries) and with none of those in `fail`.
fn markers_decode_as(v: &Value, ok: &[&str], fail: &[&str]) {
    let n = count(v, "rosbags", "/truss/markers");
    assert!(n >= 1);
    let o = &v["rosbags"]["official_markers"];
    for d in ok {
        assert_eq!(o[d]["ok"].as_u64(), Some(n), "{d}: {o}");
    }
    for d in fail {
        assert_eq!(o[d]["fail"].as_u64(), Some(n), "{d}: {o}");
    }
}

fn check_whole(v: &Value) {
    let (m, r) = (&v["mcap"], &v["rosbags"]);
    assert_eq!(m["profile"], "ros2");
    assert!(m["chunks"].as_u64().unwrap() >= 1);
    assert_eq!(m["compression"], serde_json::json!(["lz4"]));
    for (topic, ty) in TOPICS {
        let ch = &m["channels"][topic];
        assert_eq!(ch["type"], ty, "{topic}: {ch}");
        assert_eq!(ch["schema_encoding"], "ros2msg");
        assert_eq!(ch["message_encoding"], "cdr");
        assert_eq!(r["channels"][topic]["type"], ty, "rosbags {topic}");
        assert_eq!(r["channels"][topic]["serialization_format"], "cdr");
        let n = count(v, "mcap", topic);
        assert!(n >= 1, "{topic}: no message");
        assert_eq!(n, count(v, "rosbags", topic), "{topic}: readers disagree");
        assert_eq!(m["statistics_channel_counts"][topic].as_u64(), Some(n));
        assert_eq!(r["channels"][topic]["msgcount"].as_u64(), Some(n));
        for reader in ["mcap", "rosbags"] {
            let t = &v[reader]["topics"][topic];
            assert_eq!(t["stamp_mismatches"], 0, "{reader} {topic}: {t}");
            assert_eq!(t["backwards"], 0, "{reader} {topic}: {t}");
        }
    }
    let total: u64 = TOPICS.iter().map(|(t, _)| count(v, "mcap", t)).sum();
    assert_eq!(m["statistics_message_count"].as_u64(), Some(total));
    assert_eq!(r["message_count"].as_u64(), Some(total));
    // QoS as offered (DESIGN.md "ROS 2 interface"), parsed by rosbags from the YAML
    let qos = |t: &str| &r["channels"][t]["qos"];
    for t in ["/joint_states", "/truss/state"] {
        assert_eq!(qos(t)["reliability"], "RELIABLE");
        assert_eq!(qos(t)["durability"], "VOLATILE");
        assert_eq!(qos(t)["history"], "KEEP_LAST");
        assert_eq!(qos(t)["depth"], 10);
    }
    assert_eq!(qos("/truss/lock_status")["durability"], "TRANSIENT_LOCAL");
    assert_eq!(qos("/truss/lock_status")["depth"], 1);
    assert_eq!(qos("/clock")["reliability"], "BEST_EFFORT");
    assert_eq!(qos("/truss/markers")["reliability"], "RELIABLE");
    // (as tf2's broadcasters offer them)
    assert_eq!(qos("/tf")["reliability"], "RELIABLE");
    assert_eq!(qos("/tf")["durability"], "VOLATILE");
    assert_eq!(qos("/tf")["depth"], 100);
    assert_eq!(qos("/tf_static")["durability"], "TRANSIENT_LOCAL");
    assert_eq!(qos("/tf_static")["depth"], 1);
    for t in ["/tf", "/tf_static"] {
        let last = &m["topics"][t]["last_transforms"];
        assert!(!last.as_array().unwrap().is_empty(), "{t}");
        assert_eq!(
            last, &r["topics"][t]["last_transforms"],
            "{t}: readers disagree"
        );
    }
    assert_eq!(m["final_lock"], r["final_lock"]);
    assert_eq!(m["final_state"], r["final_state"]);
}

/// The bundled mast recorded every step: as many /joint_states, /truss/state
/// and /clock as states (steps + the initial one), from t = 0 to the JSON's end
/// time; /truss/markers at the node's 5 Hz of simulated time (the first state
/// at or after each multiple of 0.2 s) and at the end; the last
/// /truss/lock_status says what the JSON says.
/// With --mcap-rate 4 the periodic topics come at t = 0, every 0.25 s and at
/// the end.
#[test]
fn simulate_mast_recording_decodes_whole_with_both_readers() {
    let Some(py) = python() else { return };
    let (file, json) = (tmp("mast.mcap"), tmp("mast.json"));
    simulate_mast(&[
        "--mcap".as_ref(),
        file.as_os_str(),
        "--json".as_ref(),
        json.as_os_str(),
    ]);
    let s: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(s["deployed"], true);
    let v = check(&py, &file, false);
    check_whole(&v);
    markers_decode_as(&v, &["humble", "jazzy"], &["galactic"]);

    let steps = s["steps"].as_u64().unwrap();
    let end_ns = (s["time_s"].as_f64().unwrap() * 1e9).round() as u64;
    for topic in [
        "/joint_states",
        "/truss/state",
        "/clock",
        "/tf",
        "/truss/markers",
    ] {
        let t = &v["mcap"]["topics"][topic];
        assert_eq!(t["first_ns"], 0, "{topic}");
        assert_eq!(t["last_ns"].as_u64(), Some(end_ns), "{topic}");
        if topic != "/truss/markers" {
            assert_eq!(count(&v, "mcap", topic), steps + 1, "{topic}");
        }
    }
    // /tf_static: the mount, once; /tf: the mast's tip, the highest joint of
    // the deployed geometry, in the model frame at the last state
    assert_eq!(count(&v, "mcap", "/tf_static"), 1);
    let mount = &v["mcap"]["topics"]["/tf_static"]["last_transforms"][0];
    assert_eq!(mount["parent"], "world");
    assert_eq!(mount["child"], "truss");
    assert_eq!(mount["rotation"], serde_json::json!([0.0, 0.0, 0.0, 1.0]));
    let tip = &v["mcap"]["topics"]["/tf"]["last_transforms"];
    assert_eq!(tip.as_array().unwrap().len(), 1, "{tip}");
    assert_eq!(tip[0]["parent"], "truss");
    assert_eq!(tip[0]["child"], "truss/L4", "{tip}");
    let stamps = |topic: &str| -> Vec<u64> {
        v["mcap"]["topics"][topic]["stamps_ns"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_u64().unwrap())
            .collect()
    };
    let states = stamps("/joint_states");
    let mut due_ns = 0u64;
    let mut want_markers = vec![];
    for &t in &states {
        if t >= due_ns {
            want_markers.push(t);
            while due_ns <= t {
                due_ns += 200_000_000;
            }
        }
    }
    if want_markers.last() != states.last() {
        want_markers.push(*states.last().unwrap());
    }
    assert!(want_markers.len() > 10, "{want_markers:?}");
    assert_eq!(stamps("/truss/markers"), want_markers);
    // lock status: the initial one, then one per change (sleeves latching in
    // one step change it once), the last at the end
    let locks = s["locks"].as_array().unwrap();
    let n_lock = count(&v, "mcap", "/truss/lock_status");
    assert!(n_lock >= 2 && n_lock <= locks.len() as u64 + 2, "{n_lock}");
    let fl = &v["mcap"]["final_lock"];
    assert_eq!(fl["deployed"], true);
    assert_eq!(fl["names"].as_array().unwrap().len(), locks.len());
    for l in locks {
        let k = fl["names"]
            .as_array()
            .unwrap()
            .iter()
            .position(|n| *n == l["name"])
            .expect("lock in the recording");
        assert_eq!(fl["locked"][k], true);
        // the same f64 through JSON and CDR
        assert_eq!(fl["time_s"][k].as_f64(), l["time_s"].as_f64(), "{l}");
        assert_eq!(
            fl["impulse_ns"][k].as_f64(),
            l["impulse_ns"].as_f64(),
            "{l}"
        );
    }
    let fs = &v["mcap"]["final_state"];
    assert_eq!(fs["remaining_dof"], s["dof_final"]);
    // the drive motor under tension control: its tension, the cable it reeled in
    assert_eq!(fs["cable_names"], serde_json::json!(["drive"]));
    assert_eq!(fs["motor_modes"], serde_json::json!(["tension"]));
    assert_eq!(fs["motor_tensions_n"], serde_json::json!([0.02]));
    assert!(fs["reeled_in_m"][0].as_f64().unwrap() > 0.1, "{fs}");
    assert_eq!(fl["cable_tensions_n"], serde_json::json!([0.02]));
    assert_eq!(fl["rejected_bad_speed"], 0);
    assert_eq!(
        v["mcap"]["joint_names"],
        serde_json::json!(super::MAST_JOINTS)
    );

    // --mcap-rate 4: t = 0, every 0.25 s of simulated time, and the end
    let rated = tmp("mast_rate.mcap");
    simulate_mast(&[
        "--mcap-rate".as_ref(),
        "4".as_ref(),
        "--mcap".as_ref(),
        rated.as_os_str(),
    ]);
    let w = check(&py, &rated, false);
    check_whole(&w);
    let end_s = s["time_s"].as_f64().unwrap();
    let periods = (end_s / 0.25 + 1e-9).floor() as u64;
    let on_grid = (end_s / 0.25 - (end_s / 0.25).round()).abs() < 1e-6;
    let want = 1 + periods + u64::from(!on_grid);
    assert_eq!(count(&w, "mcap", "/joint_states"), want, "end {end_s} s");
    assert_eq!(
        w["mcap"]["topics"]["/joint_states"]["last_ns"].as_u64(),
        Some(end_ns)
    );
    assert_eq!(w["mcap"]["final_lock"], v["mcap"]["final_lock"]);
    let _ = std::fs::remove_file(&file);
    let _ = std::fs::remove_file(&rated);
}

/// Bad --mcap arguments are input errors (exit 2) naming the flag or the file.
#[test]
fn simulate_mcap_bad_input_exits_2() {
    for (args, needle) in [
        (
            vec!["--mcap", "/nonexistent_dir_truss/x.mcap"],
            "nonexistent_dir_truss",
        ),
        (
            vec!["--mcap", "/tmp/truss_x.mcap", "--mcap-rate", "0"],
            "--mcap-rate",
        ),
        (
            vec!["--mcap", "/tmp/truss_x.mcap", "--mcap-rate", "nan"],
            "--mcap-rate",
        ),
    ] {
        let out = Command::new(BIN)
            .args(["simulate", MAST])
            .args(&args)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
    }
}

/// Recording outputs are checked like the other outputs: never the model
/// (left byte for byte), never another output's path; the node's too, and its
/// time arguments are bounded (exit 2, no panic). A finished recording leaves
/// no temporary file beside it.
#[test]
fn recordings_never_overwrite_the_model_or_another_output() {
    let dir = tmp("outputs_dir");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let model = dir.join("mast.toml");
    std::fs::copy(MAST, &model).unwrap();
    let before = std::fs::read(&model).unwrap();
    let m = model.to_str().unwrap();
    let out = dir.join("run.mcap");
    let o = out.to_str().unwrap();
    for (args, needle) in [
        (vec!["simulate", m, "--mcap", m], "is the model file"),
        (
            vec!["simulate", m, "--mcap", o, "--json", o],
            "each output needs its own file",
        ),
        (vec!["node", m, "--record", m], "is the model file"),
        (vec!["node", m, "--timing", m], "is the model file"),
        (vec!["node", m, "--max-wall-s", "1e20"], "--max-wall-s"),
        (
            vec!["node", m, "--lock-period-s", "1e20"],
            "--lock-period-s",
        ),
    ] {
        let r = Command::new(BIN).args(&args).output().unwrap();
        let err = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
        assert_eq!(
            std::fs::read(&model).unwrap(),
            before,
            "{args:?} touched the model"
        );
    }
    let r = Command::new(BIN)
        .args(["simulate", m, "--mcap", o])
        .output()
        .unwrap();
    assert_eq!(
        r.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&r.stderr)
    );
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["mast.toml", "run.mcap"]);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A node whose stdout and stderr are full (Linux /dev/full) runs to its
/// --max-wall-s and exits 0: a failed log line is not a panic (was exit 101).
#[test]
fn node_with_full_stdout_and_stderr_does_not_panic() {
    let Ok(full) = std::fs::OpenOptions::new().write(true).open("/dev/full") else {
        eprintln!("skipped: no /dev/full");
        return;
    };
    let mut child = Command::new(BIN)
        .args(["node", MAST, "--loopback", "--max-wall-s", "1.5"])
        .env("ROS_DOMAIN_ID", domain(3).to_string())
        .stdout(full.try_clone().unwrap())
        .stderr(full)
        .spawn()
        .expect("spawn node");
    let t0 = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if t0.elapsed() > Duration::from_secs(30) {
            let _ = child.kill();
            panic!("the node did not stop by --max-wall-s");
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    assert_eq!(status.code(), Some(0), "{status:?}");
}

struct NodeProc(Child);
impl Drop for NodeProc {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn domain(k: u16) -> u16 {
    crate::domain(6 + k)
}

fn spawn_node(dom: u16, file: &Path, extra: &[&str]) -> NodeProc {
    let child = Command::new(BIN)
        .args(["node", MAST, "--loopback", "--record"])
        .arg(file)
        .args(extra)
        .env("ROS_DOMAIN_ID", dom.to_string())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .expect("spawn node");
    NodeProc(child)
}

/// Waits (at most 20 s) for the node to exit; its exit code and stdout.
fn wait_exit(p: &mut NodeProc) -> (Option<i32>, String) {
    let t0 = Instant::now();
    loop {
        if let Some(st) = p.0.try_wait().unwrap() {
            let mut s = String::new();
            if let Some(mut o) = p.0.stdout.take() {
                let _ = std::io::Read::read_to_string(&mut o, &mut s);
            }
            return (st.code(), s);
        }
        assert!(t0.elapsed() < Duration::from_secs(20), "node did not exit");
        std::thread::sleep(Duration::from_millis(50));
    }
}

fn signal(p: &NodeProc, sig: &str) {
    let ok = Command::new("kill")
        .args([sig, &p.0.id().to_string()])
        .status()
        .unwrap();
    assert!(ok.success());
}

/// The node recording, stopped by SIGINT: the file is finished (summary,
/// footer) and decodes whole with both readers; the node says how many
/// messages it recorded and the readers find that many.
#[test]
fn node_recording_stopped_by_sigint_decodes_whole() {
    let Some(py) = python() else { return };
    let file = tmp("node_sigint.mcap");
    let mut node = spawn_node(
        domain(0),
        &file,
        &[
            "--rtf",
            "2",
            "--max-wall-s",
            "30",
            "--markers-for",
            "humble",
        ],
    );
    std::thread::sleep(Duration::from_secs(4));
    signal(&node, "-INT");
    let (code, stdout) = wait_exit(&mut node);
    assert!(
        matches!(code, Some(0) | Some(130)),
        "exit {code:?}\n{stdout}"
    );
    assert!(stdout.contains("stopped (SIGINT)"), "{stdout}");
    let v = check(&py, &file, false);
    check_whole(&v);
    markers_decode_as(&v, &["humble", "jazzy"], &["galactic"]);
    let said: u64 = stdout
        .lines()
        .find_map(|l| l.split("recorded ").nth(1))
        .and_then(|r| r.split(' ').next())
        .and_then(|n| n.parse().ok())
        .expect("`recorded N messages` in the node's output");
    assert_eq!(v["mcap"]["statistics_message_count"].as_u64(), Some(said));
    // ~4 s of wall time at rtf 2: several simulated seconds
    let last = v["mcap"]["topics"]["/joint_states"]["last_ns"]
        .as_u64()
        .unwrap();
    assert!(last > 2_000_000_000, "last stamp {last} ns");
    let _ = std::fs::remove_file(&file);
}

/// Stopped by --max-wall-s, with Foxy's and Galactic's marker layout: finished,
/// both readers decode the markers with the schema in the file, and the raw
/// markers are Galactic's Marker, not Humble's.
#[test]
fn node_recording_ended_by_max_wall_decodes_whole() {
    let Some(py) = python() else { return };
    let file = tmp("node_maxwall.mcap");
    let mut node = spawn_node(
        domain(1),
        &file,
        &["--max-wall-s", "2.5", "--markers-for", "galactic"],
    );
    let (code, stdout) = wait_exit(&mut node);
    assert_eq!(code, Some(0), "{stdout}");
    let v = check(&py, &file, false);
    check_whole(&v);
    markers_decode_as(&v, &["galactic"], &["humble", "jazzy"]);
    let _ = std::fs::remove_file(&file);
}

/// A node killed with SIGKILL (no chance to finish the file) leaves the chunks
/// it closed (one a second): a linear reader decodes them, up to the cut.
#[test]
fn killed_node_leaves_a_file_readable_to_its_last_chunk() {
    let Some(py) = python() else { return };
    let file = tmp("node_killed.mcap");
    let mut node = spawn_node(domain(2), &file, &["--max-wall-s", "30"]);
    std::thread::sleep(Duration::from_millis(3500));
    signal(&node, "-KILL");
    let _ = wait_exit(&mut node);
    let v = check(&py, &file, true);
    let p = &v["partial"];
    assert!(!p["end"].is_null(), "a killed file has no footer: {p}");
    let js = &p["topics"]["/joint_states"];
    // chunks closed at 1, 2 and 3 s of wall time (rtf 1; start-up takes some)
    assert!(js["count"].as_u64().unwrap() >= 20, "{p}");
    assert!(js["last_ns"].as_u64().unwrap() >= 1_000_000_000, "{p}");
    for (topic, _) in TOPICS {
        let t = &p["topics"][topic];
        assert!(t["count"].as_u64().unwrap_or(0) >= 1, "{topic}: {p}");
        assert_eq!(t["stamp_mismatches"], 0, "{topic}");
    }
    let _ = std::fs::remove_file(&file);
}

/// docs/foxglove_layout.json plots fields that exist on recorded topics, and
/// its 3D panel shows /truss/markers in the frame the recordings use.
#[test]
fn foxglove_layout_refers_to_recorded_topics_and_fields() {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/docs/foxglove_layout.json"
    ))
    .unwrap();
    let v: Value = serde_json::from_str(&text).unwrap();
    let cfg = v["configById"].as_object().unwrap();
    let three_d = &cfg["3D!truss"];
    assert_eq!(
        three_d["followTf"],
        truss_deploy::node::record::FRAME,
        "fixed frame"
    );
    assert_eq!(three_d["topics"]["/truss/markers"]["visible"], true);
    // fields of the recorded types (custom ones from msg/, the rest from JointState)
    let msg = |f: &str| {
        std::fs::read_to_string(format!("{}/msg/{f}", env!("CARGO_MANIFEST_DIR"))).unwrap()
    };
    let fields = |topic: &str| -> String {
        match topic {
            "/truss/state" => msg("TrussState.msg"),
            "/truss/lock_status" => msg("LockStatus.msg"),
            "/joint_states" => "float64[] position\nfloat64[] velocity\nfloat64[] effort\n".into(),
            t => panic!("layout plots {t}, which is not a recorded topic with a plot field"),
        }
    };
    let mut n = 0;
    for (id, panel) in cfg.iter().filter(|(k, _)| k.starts_with("Plot!")) {
        for p in panel["paths"].as_array().unwrap() {
            let path = p["value"].as_str().unwrap();
            let (topic, field) = path.split_once('.').expect("topic.field");
            let field = field.split('[').next().unwrap();
            let defs = fields(topic);
            assert!(
                defs.lines()
                    .any(|l| l.split_whitespace().nth(1) == Some(field)),
                "{id}: {path}: no field `{field}`"
            );
            assert!(TOPICS.iter().any(|(t, _)| *t == topic));
            n += 1;
        }
    }
    assert!(n >= 4, "{n} plotted paths");
}
