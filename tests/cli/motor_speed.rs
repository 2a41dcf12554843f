//! `simulate --motor-speed`: a speed-controlled drive from the command line,
//! against the mast's kinematics, and its bad values.

use super::{run, temp_dir};

/// The mast from 30 deg (where the damped cable stays taut) reeled in at
/// 0.01 m/s deploys when it has reeled in L(30 deg) - L(60 deg) =
/// 5 l (cos 30 - cos 60): at that length over that speed, and the summary
/// says so (the motor ends at its limit: the latch stalls it).
#[test]
fn a_speed_driven_mast_deploys_when_its_cable_has_run_in_at_that_speed() {
    let d = temp_dir("motor_speed");
    let (model, json) = (d.join("m.toml"), d.join("s.json"));
    let gen = run(&[
        "generate",
        "mast",
        "--start-deg",
        "30",
        "--damping",
        "0.5",
        "-o",
        model.to_str().unwrap(),
    ]);
    assert!(
        gen.status.success(),
        "{}",
        String::from_utf8_lossy(&gen.stderr)
    );
    let out = run(&[
        "simulate",
        model.to_str().unwrap(),
        "--motor-speed",
        "drive=0.01",
        "--json",
        json.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("motor drive"), "{stdout}");
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    let reel = 5.0 * 0.5 * (30f64.to_radians().cos() - 60f64.to_radians().cos());
    let t = v["deploy_time_s"].as_f64().unwrap();
    assert!(
        (t - reel / 0.01).abs() < 1e-6,
        "deployed at {t} s, kinematics {} s",
        reel / 0.01
    );
    let m = &v["motors"][0];
    assert_eq!(m["cable"], "drive");
    assert_eq!(m["mode"], "at_limit");
    assert_eq!(m["speed_cmd_m_s"].as_f64(), Some(0.01));
    assert!(
        (m["reeled_in_m"].as_f64().unwrap() - reel).abs() < 1e-9,
        "{m}"
    );
    assert!(v["energy_balance_rel_error"].as_f64().unwrap() < 1e-6);
}

/// An unknown cable or a speed that is not a number: exit 2, the value and
/// what is wrong with it named.
#[test]
fn bad_motor_speeds_are_refused_with_the_reason() {
    for (arg, says) in [
        ("winch=0.1", "no cable `winch`"),
        ("drive=fast", "not a finite speed"),
        ("nan", "not a finite speed"),
    ] {
        let out = run(&[
            "simulate",
            "models/pantograph_mast.toml",
            "--motor-speed",
            arg,
        ]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{arg}: {err}");
        assert!(err.contains(says) && err.contains(arg), "{arg}: {err}");
    }
}
