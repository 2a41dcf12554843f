//! Interoperability with an independent DDS implementation: a Cyclone DDS Python
//! peer (tests/python/peer.py, types written from msg/*.msg) decodes /joint_states,
//! late-joins /truss/lock_status and sends a command the node obeys; then it drives
//! the simulation_interfaces services as rmw_cyclonedds_cpp calls them (no mapping
//! flag on the node): features, pause, step 5, resume, reset, and joins
//! /truss/lock_status late once more, getting exactly the last sample; last it
//! sends a CableSpeedCommand and sees the `drive_motor` joint move at that speed.
//! Interpreter: env TRUSS_PYTHON (default `python3`). SKIPS loudly when
//! `import cyclonedds` fails; .ci/run installs it so that CI really runs this.
#![cfg(feature = "ros")]

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

#[test]
fn cyclone_python_peer_talks_to_the_node() {
    let py = std::env::var("TRUSS_PYTHON").unwrap_or_else(|_| "python3".into());
    let probe = Command::new(&py)
        .args(["-c", "import cyclonedds"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status();
    if !matches!(probe, Ok(s) if s.success()) {
        eprintln!(
            "\n!!!!!!!! SKIPPED node_cyclone: `{py} -c 'import cyclonedds'` failed. \
             Install it (pip install cyclonedds==11.0.1) and set TRUSS_PYTHON; .ci/run does. !!!!!!!!\n"
        );
        return;
    }
    let dom = crate::domain(5);
    // the bundled mast started at 30 deg and damped: taut under a speed command
    let model = crate::taut_mast();
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/python");
    let mut node = Command::new(env!("CARGO_BIN_EXE_truss-deploy"))
        .args([
            "node",
            &model,
            "--loopback",
            "--lock-period-s",
            "1000",
            "--max-wall-s",
            "40",
        ])
        .env("ROS_DOMAIN_ID", dom.to_string())
        .spawn()
        .expect("spawn node");
    // the peer joins late: LockStatus was published once at start
    std::thread::sleep(Duration::from_secs(3));
    let t0 = Instant::now();
    let out = Command::new(&py)
        .arg(format!("{dir}/peer.py"))
        .env("ROS_DOMAIN_ID", dom.to_string())
        .env("CYCLONEDDS_URI", format!("file://{dir}/cyclone-lo.xml"))
        .env("PEER_SECS", "25")
        // small: the mast must not deploy before the services are driven
        .env("PEER_TENSION", "0.0234")
        .env("PEER_SIM_IF", "1")
        .env("PEER_SPEED", "0.02")
        .output()
        .expect("run peer.py");
    let _ = node.kill();
    let _ = node.wait();
    let stdout = String::from_utf8_lossy(&out.stdout);
    eprintln!("{stdout}\n{}", String::from_utf8_lossy(&out.stderr));
    assert!(t0.elapsed() < Duration::from_secs(60));
    let line = stdout
        .lines()
        .find_map(|l| l.strip_prefix("SUMMARY "))
        .expect("peer summary");
    let v: serde_json::Value = serde_json::from_str(line).unwrap();
    assert_eq!(v["result"], "PASS", "{v}");
    let names: Vec<&str> = v["joint_names"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_str().unwrap())
        .collect();
    assert_eq!(names, super::MAST_JOINTS);
    assert!(
        v["late_lock_stamp_s"].as_f64().unwrap() < 0.5,
        "stored sample"
    );
    assert_eq!(v["lock_names"].as_array().unwrap().len(), 4);
    let rej: Vec<u64> = v["rejected"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_u64().unwrap())
        .collect();
    assert_eq!(
        rej,
        [5, 1, 1, 3],
        "rejected total, unknown, mismatched, bad tension"
    );
    let si = &v["sim_interfaces"];
    let f: Vec<u64> = si["features"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_u64().unwrap())
        .collect();
    for x in [20, 24, 25, 26, 31, 32] {
        assert!(f.contains(&x), "feature {x} advertised: {f:?}");
    }
    assert_eq!(si["pause"], 1, "RESULT_OK");
    assert_eq!(si["state_after_pause"], 2, "STATE_PAUSED");
    assert_eq!(si["step"], 1);
    let (tp, ts) = (
        si["stamp_paused_s"].as_f64().unwrap(),
        si["stamp_after_step_s"].as_f64().unwrap(),
    );
    assert!(
        (ts - (tp + 5.0 * 0.05)).abs() < 1e-6,
        "5 steps of 0.05 s while paused: {tp} -> {ts}"
    );
    assert_eq!(si["resume"], 1);
    assert!(si["stamp_after_resume_s"].as_f64().unwrap() > ts + 0.5);
    assert_eq!(si["reset"], 1);
    assert!(
        si["stamp_after_reset_s"].as_f64().unwrap() < si["stamp_after_resume_s"].as_f64().unwrap()
    );
    assert_eq!(
        si["late_joiner_samples"], 1,
        "a late joiner (keeping up to 100) gets exactly the last LockStatus: the writer keeps last 1"
    );
    // the speed command: drive_motor's velocity is the speed from when the
    // motor engaged, its position grows at it (over 1 s of simulated time)
    let sp = &v["speed"];
    assert_eq!(sp["ok"], true, "{sp}");
    assert!(sp["velocity_max_err"].as_f64().unwrap() <= 1e-9, "{sp}");
    let rate = sp["reel_in_rate"].as_f64().unwrap();
    assert!((rate - 0.02).abs() <= 1e-6, "reel-in rate {rate}: {sp}");
    let lat = si["first_call_latency_s"].as_f64().unwrap();
    eprintln!("Cyclone client: first call answered {lat:.4} s after the service was available");
    assert!(lat < 1.0, "first call within 1 s: {lat} s");
    assert!(out.status.success());
}
