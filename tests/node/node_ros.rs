//! The node as ROS 2 tools see it, through an independent Cyclone DDS peer
//! (tests/python/graph_peer.py reading the DCPSPublication/DCPSSubscription
//! builtin topics, /rosout, /tf, and calling the parameter services as
//! rmw_cyclonedds does) and a Fast DDS one (tests/fastdds/param_peer.cpp, the
//! parameter services as rmw_fastrtps calls them): one type per announced
//! topic; `--ros-args` renaming the node and a topic and setting a parameter;
//! /rosout carrying the start line; the mast tip's /tf frame; `ros2 param`
//! list/get/describe/set, a set rtf taking effect at once. Bad `--ros-args`
//! fail with exit status 2 before any DDS.
//! Interpreter: env TRUSS_PYTHON (default `python3`); the Cyclone tests SKIP
//! loudly when `import cyclonedds` fails, the Fast DDS one without Fast DDS
//! unless TRUSS_REQUIRE_FASTDDS=1 (.ci/run installs both).
#![cfg(feature = "ros")]

use serde_json::Value;
use std::collections::{BTreeMap, BTreeSet};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

const MODEL: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/models/pantograph_mast.toml");
const BIN: &str = env!("CARGO_BIN_EXE_truss-deploy");
const PY_DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/python");

/// The k-th domain of this module's tests (k < 12; see crate::domain).
fn domain(k: u16) -> u16 {
    assert!(k < 12);
    crate::domain(10 + k)
}

struct NodeProc(Child);
impl Drop for NodeProc {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn python() -> Option<String> {
    let py = std::env::var("TRUSS_PYTHON").unwrap_or_else(|_| "python3".into());
    let ok = Command::new(&py)
        .args(["-c", "import cyclonedds"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !ok {
        eprintln!(
            "\n!!!!!!!! SKIPPED node_ros: `{py} -c 'import cyclonedds'` failed. \
             Install it (pip install cyclonedds==11.0.1) and set TRUSS_PYTHON; .ci/run does. !!!!!!!!\n"
        );
        return None;
    }
    Some(py)
}

/// The node (the mast) on loopback (ROS_LOCALHOST_ONLY=1, as a ROS 2 user sets it).
fn spawn_node(dom: u16, extra: &[&str]) -> NodeProc {
    spawn_node_of(MODEL, dom, extra)
}

fn spawn_node_of(model: &str, dom: u16, extra: &[&str]) -> NodeProc {
    let mut args = vec!["node", model, "--max-wall-s", "40"];
    args.extend_from_slice(extra);
    NodeProc(
        Command::new(BIN)
            .args(&args)
            .env("ROS_DOMAIN_ID", dom.to_string())
            .env("ROS_LOCALHOST_ONLY", "1")
            .env_remove("TRUSS_DDS_LOOPBACK")
            .spawn()
            .expect("spawn node"),
    )
}

/// Runs graph_peer.py on `dom` with `env`; its SUMMARY.
fn graph_peer(py: &str, dom: u16, env: &[(&str, &str)]) -> Value {
    let t0 = Instant::now();
    let out = Command::new(py)
        .arg(format!("{PY_DIR}/graph_peer.py"))
        .env("ROS_DOMAIN_ID", dom.to_string())
        .env("CYCLONEDDS_URI", format!("file://{PY_DIR}/cyclone-lo.xml"))
        .envs(env.iter().copied())
        .output()
        .expect("run graph_peer.py");
    assert!(t0.elapsed() < Duration::from_secs(60));
    let stdout = String::from_utf8_lossy(&out.stdout);
    eprintln!("{}", String::from_utf8_lossy(&out.stderr));
    let line = stdout
        .lines()
        .find_map(|l| l.strip_prefix("SUMMARY "))
        .unwrap_or_else(|| panic!("peer summary in {stdout}"));
    serde_json::from_str(line).unwrap()
}

/// topic -> the set of types announced for it (writers and readers).
fn types_by_topic(v: &Value) -> BTreeMap<String, BTreeSet<String>> {
    let mut m: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for e in v["endpoints"].as_array().unwrap() {
        m.entry(e["topic"].as_str().unwrap().into())
            .or_default()
            .insert(e["type"].as_str().unwrap().into());
    }
    m
}

fn endpoint<'a>(v: &'a Value, kind: &str, topic: &str) -> Option<&'a Value> {
    v["endpoints"]
        .as_array()
        .unwrap()
        .iter()
        .find(|e| e["kind"] == kind && e["topic"] == topic)
}

#[test]
fn every_announced_topic_has_one_type_and_rosout_has_the_start_line() {
    let Some(py) = python() else { return };
    let dom = domain(0);
    let _node = spawn_node(dom, &[]);
    let v = graph_peer(
        &py,
        dom,
        &[
            ("PEER_SECS", "25"),
            ("PEER_WAIT_TOPIC", "rt/truss/cable_force_cmd"),
            ("PEER_WAIT_LOG", "on ROS domain"),
        ],
    );
    let types = types_by_topic(&v);
    eprintln!("announced: {types:#?}");
    for (topic, t) in &types {
        assert_eq!(t.len(), 1, "{topic} announced with {t:?}");
    }
    for (topic, ty) in [
        ("rt/clock", "rosgraph_msgs::msg::dds_::Clock_"),
        ("rt/joint_states", "sensor_msgs::msg::dds_::JointState_"),
        ("rt/truss/state", "truss_deploy::msg::dds_::TrussState_"),
        (
            "rt/truss/lock_status",
            "truss_deploy::msg::dds_::LockStatus_",
        ),
        (
            "rt/truss/cable_force_cmd",
            "truss_deploy::msg::dds_::CableForceCommand_",
        ),
        (
            "rt/truss/markers",
            "visualization_msgs::msg::dds_::MarkerArray_",
        ),
        ("rt/rosout", "rcl_interfaces::msg::dds_::Log_"),
    ] {
        assert_eq!(
            types.get(topic).map(|t| t.iter().next().unwrap().as_str()),
            Some(ty),
            "{topic}"
        );
    }
    // the node writes /clock and does not read it (ros2-client's own reader is gone)
    assert!(endpoint(&v, "pub", "rt/clock").is_some());
    assert!(endpoint(&v, "sub", "rt/clock").is_none());
    // /rosout with rclcpp's reliability and durability (RustDDS does not
    // announce History: its depth of 1000 is checked in the lib's tests), and
    // the start line in it, from before the peer joined
    let r = endpoint(&v, "pub", "rt/rosout").expect("rosout writer");
    assert_eq!(
        (&r["reliability"], &r["durability"]),
        (&Value::from("Reliable"), &Value::from("TransientLocal")),
        "{r}"
    );
    let start = v["rosout"]
        .as_array()
        .unwrap()
        .iter()
        .find(|l| l["msg"].as_str().unwrap().contains("on ROS domain"))
        .expect("the start line on /rosout");
    assert_eq!(start["name"], "truss_deploy");
    assert_eq!(start["level"], 20, "INFO");
    assert!(start["msg"]
        .as_str()
        .unwrap()
        .starts_with(&format!("node /truss_deploy on ROS domain {dom}")));
}

#[test]
fn ros_args_rename_the_node_and_a_topic_and_set_rtf() {
    let Some(py) = python() else { return };
    let dom = domain(1);
    let _node = spawn_node(
        dom,
        &[
            "--ros-args",
            "-r",
            "/joint_states:=/truss/js",
            "-r",
            "__node:=t2",
            "-p",
            "rtf:=2.0",
        ],
    );
    let v = graph_peer(
        &py,
        dom,
        &[
            ("PEER_SECS", "25"),
            ("PEER_WAIT_TOPIC", "rt/truss/js"),
            ("PEER_WAIT_LOG", "on ROS domain"),
            ("PEER_JS_TOPIC", "rt/truss/js"),
        ],
    );
    let types = types_by_topic(&v);
    assert_eq!(
        types
            .get("rt/truss/js")
            .map(|t| t.iter().next().unwrap().as_str()),
        Some("sensor_msgs::msg::dds_::JointState_")
    );
    assert!(!types.contains_key("rt/joint_states"), "{types:?}");
    let start = v["rosout"]
        .as_array()
        .unwrap()
        .iter()
        .find(|l| l["msg"].as_str().unwrap().contains("on ROS domain"))
        .expect("the start line on /rosout");
    assert_eq!(start["name"], "t2");
    let msg = start["msg"].as_str().unwrap();
    assert!(
        msg.starts_with(&format!("node /t2 on ROS domain {dom} (loopback only)")),
        "{msg}"
    );
    assert!(msg.contains(", rtf 2, publishing at 40.000 Hz"), "{msg}");
    // simulated time runs at twice the wall clock on the renamed topic
    let s = v["js_samples"].as_array().unwrap();
    let (first, last) = (&s[0], &s[s.len() - 1]);
    let wall = last[0].as_f64().unwrap() - first[0].as_f64().unwrap();
    let sim = last[1].as_f64().unwrap() - first[1].as_f64().unwrap();
    assert!(wall > 3.0, "{wall} s of samples");
    let rtf = sim / wall;
    eprintln!("simulated {sim:.3} s in {wall:.3} s of wall time: rtf {rtf:.3}");
    assert!((1.6..=2.4).contains(&rtf), "rtf {rtf}");
}

#[test]
fn bad_ros_args_and_environment_fail_with_status_2() {
    for (args, env, says) in [
        (
            &["--ros-args", "-p", "rft:=2"][..],
            None,
            "no parameter `rft`",
        ),
        (&["--ros-args", "-p", "rtf:=0"], None, "outside its range"),
        (&["--ros-args", "-p", "rtf:=fast"], None, "is a double"),
        (
            &["--ros-args", "--frobnicate"],
            None,
            "unknown argument `--frobnicate`",
        ),
        (
            &["--ros-args", "-r", "__node:=9lives"],
            None,
            "__node:=9lives",
        ),
        (&["--ros-args", "-r", "__ns:=/a b"], None, "namespace"),
        (
            &["--ros-args", "--params-file", "/nonexistent/p.yaml"],
            None,
            "/nonexistent/p.yaml",
        ),
        (&["--rtf", "0"], None, "--rtf"),
        (&["--tf-frames", "L4,nope"], None, "no joint `nope`"),
        (
            &["--ros-args", "-p", "tf_frames:=[L4, 7]"],
            None,
            "one type",
        ),
        (
            &["--ros-args", "-p", "rate_hz:=.inf"],
            None,
            "outside its range",
        ),
        (
            &[],
            Some(("ROS_LOCALHOST_ONLY", "yes")),
            "ROS_LOCALHOST_ONLY",
        ),
        (
            &[],
            Some(("ROS_AUTOMATIC_DISCOVERY_RANGE", "WIDE")),
            "ROS_AUTOMATIC_DISCOVERY_RANGE",
        ),
    ] {
        let mut c = Command::new(BIN);
        c.args(["node", MODEL, "--max-wall-s", "5"])
            .args(args)
            .env("ROS_DOMAIN_ID", domain(2).to_string())
            .env("TRUSS_DDS_LOOPBACK", "1");
        if let Some((k, val)) = env {
            c.env(k, val);
        }
        let t0 = Instant::now();
        let r = c.output().unwrap();
        let err = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(2), "{args:?} {env:?}: {err}");
        assert!(err.contains(says), "{args:?} {env:?}: {err}");
        assert!(
            t0.elapsed() < Duration::from_secs(5),
            "fails before any DDS"
        );
    }
    // --ros-args belongs to the node
    let r = Command::new(BIN)
        .args(["analyze", MODEL, "--ros-args", "-p", "rtf:=2"])
        .output()
        .unwrap();
    assert_eq!(r.status.code(), Some(2));
}

#[test]
fn tf_frame_of_the_mast_tip_is_the_tip_joint_position() {
    let Some(py) = python() else { return };
    let dom = domain(3);
    let _node = spawn_node(dom, &[]);
    let v = graph_peer(
        &py,
        dom,
        &[
            ("PEER_SECS", "25"),
            ("PEER_WAIT_TOPIC", "rt/tf"),
            ("PEER_TF", "1"),
        ],
    );
    let types = types_by_topic(&v);
    for t in ["rt/tf", "rt/tf_static"] {
        assert_eq!(
            types.get(t).map(|t| t.iter().next().unwrap().as_str()),
            Some("tf2_msgs::msg::dds_::TFMessage_"),
            "{t}"
        );
    }
    // (History depths are not announced by RustDDS: see the lib's tests)
    let q = |t: &str| {
        let e = endpoint(&v, "pub", t).unwrap();
        (
            e["reliability"].as_str().unwrap().to_string(),
            e["durability"].as_str().unwrap().to_string(),
        )
    };
    assert_eq!(q("rt/tf"), ("Reliable".into(), "Volatile".into()));
    assert_eq!(
        q("rt/tf_static"),
        ("Reliable".into(), "TransientLocal".into())
    );
    let st = v["tf_static"].as_array().unwrap();
    assert_eq!(st.len(), 1, "the mount, once: {st:?}");
    assert_eq!(
        (&st[0]["parent"], &st[0]["child"]),
        (&Value::from("world"), &Value::from("truss"))
    );
    let pairs = v["tf_pairs"].as_array().unwrap();
    assert!(
        pairs.len() >= 20,
        "{} frames paired with /truss/state",
        pairs.len()
    );
    let mut moved = false;
    for p in pairs {
        // the default frame of a mast: its tip (the highest joint when deployed), L4
        assert_eq!(p["child"], "truss/L4");
        assert_eq!(p["parent"], "truss");
        let tf: Vec<f64> = p["tf"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        let joint: Vec<f64> = p["state"]["L4"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        for k in 0..3 {
            assert!(
                (tf[k] - joint[k]).abs() <= 1e-12,
                "{tf:?} vs {joint:?} at {}",
                p["stamp_s"]
            );
        }
        moved |= (tf[2] - pairs[0]["tf"][2].as_f64().unwrap()).abs() > 1e-6;
    }
    assert!(moved, "the tip frame follows the deploying mast");
}

#[test]
fn parameters_listed_got_described_and_set_live_from_a_cyclone_client() {
    let Some(py) = python() else { return };
    let dom = domain(4);
    let _node = spawn_node(dom, &[]);
    let v = graph_peer(
        &py,
        dom,
        &[("PEER_PARAMS", "/truss_deploy"), ("PEER_SET_RTF", "2.0")],
    );
    eprintln!("{v:#}");
    let names: Vec<&str> = v["list"]
        .as_array()
        .expect("list answered")
        .iter()
        .map(|x| x.as_str().unwrap())
        .collect();
    for n in [
        "rtf",
        "rate_hz",
        "marker_rate_hz",
        "lock_period_s",
        "model",
        "tf_frames",
    ] {
        assert!(names.contains(&n), "{n} in {names:?}");
    }
    let g = v["get"].as_array().expect("get answered");
    assert_eq!(
        (g[0][0].as_u64(), g[0][1].as_f64()),
        (Some(3), Some(1.0)),
        "rtf: double 1"
    );
    assert_eq!(g[1][0], 4, "model: a string");
    assert!(g[1][2].as_str().unwrap().ends_with("pantograph_mast.toml"));
    assert_eq!(g[2][0], 0, "an unknown name: NOT_SET");
    let d = &v["describe_rtf"];
    assert_eq!(d["read_only"], false);
    assert_eq!(d["range"], serde_json::json!([0.001, 1000.0]));
    let set = v["set"].as_array().expect("set answered");
    assert_eq!(set[0][0], true);
    assert_eq!(set[1][0], false);
    assert!(
        set[1][1].as_str().unwrap().contains("outside its range"),
        "{}",
        set[1][1]
    );
    assert_eq!(set[2][0], false);
    assert!(
        set[2][1].as_str().unwrap().contains("read-only"),
        "{}",
        set[2][1]
    );
    assert_eq!(v["rtf_get_after"], 2.0);
    assert!(
        v["events"]
            .as_array()
            .unwrap()
            .iter()
            .any(|e| e == &serde_json::json!(["/truss_deploy", [["rtf", 2.0]]])),
        "/parameter_events announces the change: {}",
        v["events"]
    );
    let (before, after) = (
        v["rtf_before"].as_f64().expect("rtf measured before"),
        v["rtf_after"].as_f64().expect("rtf measured after"),
    );
    eprintln!("simulated seconds per wall second: {before:.3} at rtf 1, {after:.3} at rtf 2");
    assert!((0.8..=1.2).contains(&before), "{before}");
    // the wall time per simulated second halves
    assert!(
        (1.6..=2.4).contains(&(after / before)),
        "{after} / {before}"
    );
}

#[test]
fn parameters_listed_got_and_set_from_a_fastdds_client() {
    let Some(peer) = super::node_fastdds::peer_or_skip("param_peer") else {
        return;
    };
    let dom = domain(5);
    let _node = spawn_node(dom, &["--ros-args", "-r", "__node:=mast"]);
    let t0 = Instant::now();
    let out = Command::new(&peer)
        .env("ROS_DOMAIN_ID", dom.to_string())
        .env("PEER_NODE", "/mast")
        .env("PEER_SET_RTF", "3.0")
        .output()
        .expect("run the Fast DDS parameter peer");
    assert!(t0.elapsed() < Duration::from_secs(60));
    let stdout = String::from_utf8_lossy(&out.stdout);
    eprintln!("{stdout}\n{}", String::from_utf8_lossy(&out.stderr));
    let line = stdout
        .lines()
        .find_map(|l| l.strip_prefix("SUMMARY "))
        .expect("peer summary");
    let v: Value = serde_json::from_str(line).unwrap();
    let names: Vec<&str> = v["list"]
        .as_array()
        .expect("list answered")
        .iter()
        .map(|x| x.as_str().unwrap())
        .collect();
    assert!(
        names.contains(&"rtf") && names.contains(&"tf_frames"),
        "{names:?}"
    );
    assert_eq!(
        (v["get"][0][0].as_u64(), v["get"][0][1].as_f64()),
        (Some(3), Some(1.0)),
        "rtf: double 1"
    );
    assert!(v["get"][1][1]
        .as_str()
        .unwrap()
        .ends_with("pantograph_mast.toml"));
    assert_eq!(v["set"][0][0], true, "{v}");
    assert_eq!(v["set"][1][0], false, "{v}");
    assert!(v["set"][1][1].as_str().unwrap().contains("read-only"));
    assert_eq!(v["rtf_after"].as_f64(), Some(3.0));
}

/// The sail's two cables, commanded by two partial commands written back to
/// back (taken in one tick when they arrive together): both in force, neither
/// lost (before, a tick kept only its last valid command). The merge itself is
/// tested deterministically in the lib (commands::tests).
#[test]
fn two_partial_commands_written_together_both_apply() {
    let Some(py) = python() else { return };
    let dom = domain(6);
    let sail = concat!(env!("CARGO_MANIFEST_DIR"), "/models/sail_array.toml");
    let _node = spawn_node_of(sail, dom, &["--paused"]);
    let v = graph_peer(&py, dom, &[("PEER_SAIL_CMDS", "1"), ("PEER_SECS", "20")]);
    eprintln!("{v}");
    assert_eq!(v["accepted"], 2, "{v}");
    assert_eq!(v["tensions"], v["want"], "both partial commands in force");
}

/// SimulateSteps from a Cyclone client: 200 steps with feedback every 10 and
/// the stamps 200 steps further; a second goal canceled after its first
/// feedback ends CANCELED, short of 200.
#[test]
fn simulate_steps_action_runs_200_steps_with_feedback_and_cancels() {
    let Some(py) = python() else { return };
    let dom = domain(7);
    // paused, so that only the action steps; rtf 10: 200 steps of 0.05 s in 1 s
    let _node = spawn_node(dom, &["--paused", "--rtf", "10"]);
    let v = graph_peer(
        &py,
        dom,
        &[("PEER_ACTION", "1"), ("PEER_ACTION_STEPS", "200")],
    );
    eprintln!("{v:#}");
    assert_eq!(v["accepted"], true);
    let fb: Vec<(u64, u64)> = v["feedback"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| (f[0].as_u64().unwrap(), f[1].as_u64().unwrap()))
        .collect();
    let want: Vec<(u64, u64)> = (1..=20).map(|k| (10 * k, 200 - 10 * k)).collect();
    assert_eq!(fb, want, "feedback every 10 steps");
    assert_eq!(v["status"], 4, "STATUS_SUCCEEDED");
    assert_eq!(v["result"][0], 1, "RESULT_OK");
    let (t0, t1) = (
        v["stamp_before"].as_f64().unwrap(),
        v["stamp_after"].as_f64().unwrap(),
    );
    assert!((t1 - t0 - 200.0 * 0.05).abs() < 1e-6, "{t0} -> {t1}");
    // cancel
    assert_eq!(v["accepted2"], true);
    assert!(v["first_feedback2"][0].as_u64().unwrap() >= 10);
    assert_eq!(v["cancel_code"], 0, "ERROR_NONE");
    assert_eq!(v["canceling"], 1);
    assert_eq!(v["status2"], 5, "STATUS_CANCELED: {v}");
    let msg = v["result2"][1].as_str().unwrap();
    let done: u64 = msg
        .strip_prefix("canceled after ")
        .and_then(|m| m.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{msg}"));
    assert!((10..200).contains(&done), "{msg}");
}

/// `--params-file` in ROS 2's layout sets parameters (the `/**` section, then
/// the node's own, -p after both), and `--log-level warn` keeps info lines
/// (the start line) off stdout. Short runs on loopback.
#[test]
fn params_file_and_log_level_take_effect() {
    let dir = std::env::temp_dir().join(format!("truss_ros_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let yaml = dir.join("p.yaml");
    std::fs::write(
        &yaml,
        "/**:\n  ros__parameters:\n    rtf: 3.0\n    lock_period_s: 2.0\n\
         other:\n  ros__parameters:\n    rtf: 9.0\n\
         mast:\n  ros__parameters:\n    rate_hz: 12.5\n    tf_frames:\n    - R4\n    - L4\n",
    )
    .unwrap();
    let run = |extra: &[&str]| {
        let r = Command::new(BIN)
            .args(["node", MODEL, "--max-wall-s", "1"])
            .args(extra)
            .env("ROS_DOMAIN_ID", domain(8).to_string())
            .env("TRUSS_DDS_LOOPBACK", "1")
            .output()
            .unwrap();
        assert_eq!(
            r.status.code(),
            Some(0),
            "{}",
            String::from_utf8_lossy(&r.stderr)
        );
        String::from_utf8_lossy(&r.stdout).to_string()
    };
    let y = yaml.to_str().unwrap();
    let out = run(&["--ros-args", "-r", "__node:=mast", "--params-file", y]);
    let start = out
        .lines()
        .find(|l| l.contains("on ROS domain"))
        .unwrap_or_else(|| panic!("{out}"));
    assert!(start.starts_with("mast: node /mast"), "{start}");
    assert!(
        start.contains(", rtf 3, publishing at 12.500 Hz"),
        "{start}"
    );
    // -p after the file wins
    let out = run(&["--ros-args", "--params-file", y, "-p", "rtf:=4.0"]);
    assert!(out.contains(", rtf 4, publishing at 80.000 Hz"), "{out}");
    // the read-only `model` set at start is the model the node runs
    let sail = concat!(env!("CARGO_MANIFEST_DIR"), "/models/sail_array.toml");
    let out = run(&["--ros-args", "-p", &format!("model:={sail}")]);
    assert!(out.contains("; model sail_array ("), "{out}");
    let quiet = run(&["--ros-args", "--log-level", "warn"]);
    assert!(!quiet.contains("on ROS domain"), "{quiet}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// SimulateSteps from a Fast DDS client as rmw_fastrtps calls it: 200 steps,
/// feedback every 10, STATUS_SUCCEEDED with RESULT_OK.
#[test]
fn simulate_steps_action_from_a_fastdds_client() {
    let Some(peer) = super::node_fastdds::peer_or_skip("param_peer") else {
        return;
    };
    let dom = domain(9);
    let _node = spawn_node(dom, &["--paused", "--rtf", "10"]);
    let t0 = Instant::now();
    let out = Command::new(&peer)
        .env("ROS_DOMAIN_ID", dom.to_string())
        .env("PEER_ACTION", "1")
        .output()
        .expect("run the Fast DDS peer");
    assert!(t0.elapsed() < Duration::from_secs(60));
    let stdout = String::from_utf8_lossy(&out.stdout);
    eprintln!("{stdout}\n{}", String::from_utf8_lossy(&out.stderr));
    let line = stdout
        .lines()
        .find_map(|l| l.strip_prefix("SUMMARY "))
        .expect("peer summary");
    let v: Value = serde_json::from_str(line).unwrap();
    assert_eq!(v["accepted"], true, "{v}");
    let fb: Vec<(u64, u64)> = v["feedback"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| (f[0].as_u64().unwrap(), f[1].as_u64().unwrap()))
        .collect();
    let want: Vec<(u64, u64)> = (1..=20).map(|k| (10 * k, 200 - 10 * k)).collect();
    assert_eq!(fb, want, "feedback every 10 steps");
    assert_eq!(
        (&v["status"], &v["result"]),
        (&Value::from(4), &Value::from(1)),
        "{v}"
    );
}
