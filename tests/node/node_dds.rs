//! The node over real DDS on loopback (no ROS install): the binary runs as a child
//! process with --loopback and --max-wall-s; a ros2-client peer in the test talks
//! to it. Each test uses its own ROS_DOMAIN_ID (derived from the process id) and
//! every loop is bounded in count and time.
#![cfg(feature = "ros")]

use ros2_client::{
    Client, Context, MessageTypeName, Name, Node, NodeName, NodeOptions, Publisher, ServiceMapping,
    ServiceTypeName, Subscription,
};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};
use truss_deploy::node::msgs::*;
use truss_deploy::node::qos;

const MODEL: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/models/pantograph_mast.toml");

fn domain(k: u16) -> u16 {
    crate::domain(k)
}

struct NodeProc(Child);
impl Drop for NodeProc {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn spawn_node(dom: u16, extra: &[&str]) -> NodeProc {
    spawn_node_on(MODEL, dom, extra)
}

fn spawn_node_on(model: &str, dom: u16, extra: &[&str]) -> NodeProc {
    let mut args = vec!["node", model, "--loopback", "--lock-period-s", "1000"];
    args.extend_from_slice(extra);
    let child = Command::new(env!("CARGO_BIN_EXE_truss-deploy"))
        .args(&args)
        .env("ROS_DOMAIN_ID", dom.to_string())
        .stdout(Stdio::inherit())
        .stderr(Stdio::inherit())
        .spawn()
        .expect("spawn truss-deploy node");
    NodeProc(child)
}

struct Peer {
    js: Subscription<JointState>,
    st: Subscription<TrussState>,
    lock: Subscription<LockStatus>,
    cmd: Publisher<CableForceCommand>,
    speed: Publisher<CableSpeedCommand>,
    resume: Client<TriggerRequest, TriggerResponse>,
    node: Node,
    _ctx: Context,
}

fn peer(dom: u16) -> Peer {
    std::env::set_var("TRUSS_DDS_LOOPBACK", "1");
    let dp = ros2_client::dds::rustdds::DomainParticipantBuilder::new(dom)
        .with_only_networks([std::net::Ipv4Addr::LOCALHOST])
        .build()
        .unwrap();
    let ctx = Context::from_domain_participant(dp).unwrap();
    let mut node = ctx
        .new_node(
            NodeName::new("/", "test_peer").unwrap(),
            NodeOptions::new().enable_rosout(false),
        )
        .unwrap();
    let t = |node: &mut Node, ns: &str, b: &str, pkg: &str, ty: &str, q| {
        node.create_topic(
            &Name::new(ns, b).unwrap(),
            MessageTypeName::new(pkg, ty),
            &q,
        )
        .unwrap()
    };
    let js_t = t(
        &mut node,
        "/",
        "joint_states",
        "sensor_msgs",
        "JointState",
        qos::reliable10(),
    );
    let st_t = t(
        &mut node,
        "/truss",
        "state",
        "truss_deploy",
        "TrussState",
        qos::reliable10(),
    );
    let lk_t = t(
        &mut node,
        "/truss",
        "lock_status",
        "truss_deploy",
        "LockStatus",
        qos::latched(),
    );
    let cmd_t = t(
        &mut node,
        "/truss",
        "cable_force_cmd",
        "truss_deploy",
        "CableForceCommand",
        qos::reliable10(),
    );
    let speed_t = t(
        &mut node,
        "/truss",
        "cable_speed_cmd",
        "truss_deploy",
        "CableSpeedCommand",
        qos::reliable10(),
    );
    let js = node.create_subscription(&js_t, None).unwrap();
    let st = node.create_subscription(&st_t, None).unwrap();
    let lock = node.create_subscription(&lk_t, None).unwrap();
    let cmd = node.create_publisher(&cmd_t, None).unwrap();
    let speed = node.create_publisher(&speed_t, None).unwrap();
    let resume = node
        .create_client::<TriggerRequest, TriggerResponse>(
            ServiceMapping::Cyclone,
            &Name::new("/truss", "resume").unwrap(),
            &ServiceTypeName::new("std_srvs", "Trigger"),
            qos::reliable10(),
            qos::reliable10(),
        )
        .unwrap();
    // Its spinner keeps the publishers' match counts (get_subscription_count
    // stays 0 without one), so that `send` waits for the node's reader only as
    // long as it must. (peer() runs inside the tests' runtime.)
    tokio::spawn(node.spinner().expect("peer spinner").spin());
    Peer {
        js,
        st,
        lock,
        cmd,
        speed,
        resume,
        node,
        _ctx: ctx,
    }
}

fn rt() -> tokio::runtime::Runtime {
    tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap()
}

/// Waits (bounded) for a LockStatus satisfying `f`; returns it.
async fn wait_lock(p: &Peer, secs: f64, f: impl Fn(&LockStatus) -> bool) -> Option<LockStatus> {
    let end = Instant::now() + Duration::from_secs_f64(secs);
    for _ in 0..100_000 {
        let left = end.checked_duration_since(Instant::now())?;
        match tokio::time::timeout(left, p.lock.async_take()).await {
            Ok(Ok((m, _))) if f(&m) => return Some(m),
            Ok(_) => {}
            Err(_) => return None,
        }
    }
    None
}

async fn next_state(p: &Peer, secs: f64) -> Option<TrussState> {
    match tokio::time::timeout(Duration::from_secs_f64(secs), p.st.async_take()).await {
        Ok(Ok((m, _))) => Some(m),
        _ => None,
    }
}

/// Publishes a command, retrying (bounded) until the node's reader is matched.
async fn send(p: &Peer, names: &[&str], t: &[f64]) {
    let end = Instant::now() + Duration::from_secs(10);
    while p.cmd.get_subscription_count(&p.node) == 0 && Instant::now() < end {
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    let m = CableForceCommand {
        names: names.iter().map(|s| s.to_string()).collect(),
        tensions_n: t.to_vec(),
    };
    p.cmd.publish(m).expect("publish command");
}

/// Publishes a speed command, retrying (bounded) until the node's reader is matched.
async fn send_speed(p: &Peer, names: &[&str], s: &[f64]) {
    let end = Instant::now() + Duration::from_secs(10);
    while p.speed.get_subscription_count(&p.node) == 0 && Instant::now() < end {
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    let m = CableSpeedCommand {
        names: names.iter().map(|s| s.to_string()).collect(),
        speeds_m_s: s.to_vec(),
    };
    p.speed.publish(m).expect("publish speed command");
}

async fn call_resume(p: &Peer) -> TriggerResponse {
    let end = Instant::now() + Duration::from_secs(15);
    for _ in 0..100 {
        let left = end
            .checked_duration_since(Instant::now())
            .expect("resume service timed out");
        let left = left.min(Duration::from_secs(2));
        if let Ok(Ok(r)) =
            tokio::time::timeout(left, p.resume.async_call_service(TriggerRequest::default())).await
        {
            return r;
        }
    }
    panic!("resume service never answered");
}

#[test]
fn joint_states_and_late_joining_lock_status() {
    let dom = domain(0);
    let _node = spawn_node(dom, &["--max-wall-s", "20", "--rate", "20"]);
    // join late: the only lock_status publication so far is the initial one
    // (--lock-period-s 1000, no latch within the first seconds)
    std::thread::sleep(Duration::from_secs(3));
    let model = truss_deploy::model::load(std::path::Path::new(MODEL))
        .unwrap()
        .model;
    let expect: Vec<String> = model
        .elements
        .iter()
        .filter(|e| matches!(e.kind(), "scissor" | "sleeve"))
        .map(|e| e.name().to_string())
        .chain(["drive_motor".to_string()])
        .collect();
    let locks: Vec<String> = model
        .locks
        .iter()
        .map(|&e| model.elements[e].name().to_string())
        .collect();
    rt().block_on(async {
        let p = peer(dom);
        let mut stamps = Vec::new();
        let end = Instant::now() + Duration::from_secs(12);
        for _ in 0..1000 {
            if stamps.len() >= 30 || Instant::now() > end {
                break;
            }
            if let Ok(Ok((js, _))) =
                tokio::time::timeout(Duration::from_secs(2), p.js.async_take()).await
            {
                assert_eq!(js.name, expect, "joint names");
                assert_eq!(js.position.len(), expect.len());
                assert_eq!(js.velocity.len(), expect.len());
                assert_eq!(js.effort.len(), expect.len());
                assert!(js.position.iter().all(|x| x.is_finite()));
                stamps.push(stamp_s(&js.header.stamp));
            }
        }
        assert!(stamps.len() >= 30, "only {} joint_states", stamps.len());
        assert!(
            stamps.windows(2).all(|w| w[1] >= w[0]),
            "stamps go back: {stamps:?}"
        );
        assert!(
            stamps.last() > stamps.first(),
            "stamps never rise: {stamps:?}"
        );
        assert!(stamps[0] > 1.0, "the node ran before we joined");
        // late joiner: transient local delivers the initial LockStatus
        let ls = wait_lock(&p, 5.0, |_| true)
            .await
            .expect("late-joiner LockStatus");
        assert_eq!(ls.names, locks);
        assert_eq!(ls.locked, vec![false; locks.len()]);
        assert_eq!(ls.cable_names, vec!["drive".to_string()]);
        assert!(
            stamp_s(&ls.header.stamp) < 0.5,
            "got a fresh one, not the stored sample"
        );
    });
}

#[test]
fn zero_tension_holds_still_and_more_tension_deploys_sooner() {
    let dom = domain(1);
    let _n0 = spawn_node(dom, &["--max-wall-s", "25", "--paused", "--rtf", "4"]);
    let dom2 = domain(2);
    let _n1 = spawn_node(dom2, &["--max-wall-s", "25", "--paused", "--rtf", "10"]);
    rt().block_on(async {
        // (1) zero tension from the start: nothing moves
        let p = peer(dom);
        let s0 = next_state(&p, 10.0)
            .await
            .expect("initial state while paused");
        send(&p, &["drive"], &[0.0]).await;
        wait_lock(&p, 10.0, |m| {
            m.cable_tensions_n == vec![0.0] && m.accepted_commands == 1
        })
        .await
        .expect("zero-tension command accepted");
        let r = call_resume(&p).await;
        assert!(r.success, "{}", r.message);
        tokio::time::sleep(Duration::from_secs(2)).await;
        let mut s = None;
        for _ in 0..200 {
            // newest state
            match next_state(&p, 1.0).await {
                Some(x) => s = Some(x),
                None => break,
            }
            if s.as_ref().is_some_and(|x| stamp_s(&x.header.stamp) > 4.0) {
                break;
            }
        }
        let s = s.expect("truss state");
        assert!(
            stamp_s(&s.header.stamp) > 4.0,
            "simulation ran (t = {})",
            stamp_s(&s.header.stamp)
        );
        // (with 0.02 N the mast rises ~0.1 m in 4 s; the cable model leaves a
        // residual drift of ~1e-5 m at zero motor tension)
        for (j, (pt, p0)) in s.positions.iter().zip(&s0.positions).enumerate() {
            let d = ((pt.x - p0.x).powi(2) + (pt.y - p0.y).powi(2) + (pt.z - p0.z).powi(2)).sqrt();
            assert!(
                d < 2e-3,
                "joint {} moved {d} m with zero tension",
                s.joint_names[j]
            );
        }
        assert!(s.deploy_fraction <= s0.deploy_fraction + 1e-3);

        // (2) ten times the model's tension: deploys well before ~20.4 s
        let p2 = peer(dom2);
        send(&p2, &["drive"], &[0.2]).await;
        wait_lock(&p2, 10.0, |m| m.cable_tensions_n == vec![0.2])
            .await
            .expect("0.2 N command accepted");
        assert!(call_resume(&p2).await.success);
        let done = wait_lock(&p2, 15.0, |m| m.deployed)
            .await
            .expect("deployed");
        let t = done.time_s.iter().cloned().fold(0.0, f64::max);
        assert!(
            t > 0.0 && t < 12.0,
            "latched at {t} s with 0.2 N (0.02 N: ~20.4 s)"
        );
        // The four sleeves latched together carry the least-work shares of
        // the load on /joint_states (the sparse solver's own multipliers give
        // one of them all of it).
        let mut sleeves = None;
        for _ in 0..200 {
            let Ok(Ok((js, _))) =
                tokio::time::timeout(Duration::from_secs(2), p2.js.async_take()).await
            else {
                break;
            };
            if stamp_s(&js.header.stamp) > t {
                let e: Vec<f64> = js
                    .name
                    .iter()
                    .zip(&js.effort)
                    .filter(|(n, _)| n.starts_with('S'))
                    .map(|(_, &f)| f)
                    .collect();
                sleeves = Some(e);
                break;
            }
        }
        let e = sleeves.expect("joint_states after the latch");
        let total: f64 = e.iter().sum();
        assert!(
            e.len() == 4 && total > 0.0 && e.iter().all(|&f| f > 0.1 * total),
            "sleeve efforts after the latch: {e:?}"
        );
    });
}

#[test]
fn bad_commands_are_rejected_counted_and_publishing_goes_on() {
    let dom = domain(3);
    let _node = spawn_node(dom, &["--max-wall-s", "25", "--rate", "50"]);
    rt().block_on(async {
        let p = peer(dom);
        send(&p, &["drive"], &[0.01]).await;
        wait_lock(&p, 10.0, |m| m.cable_tensions_n == vec![0.01])
            .await
            .expect("good command");
        // One of each kind of fault, back to back, as the Cyclone peer sends
        // them (tests/node/node_cyclone.rs). (Only the first of them used to be
        // sent here: `send` waited 10 s each time for a match count the peer
        // never updated without a spinner, and the node's --max-wall-s ended
        // before the later ones were written.)
        for (n, t) in [
            (&["nope"][..], &[0.01][..]),
            (&["drive"], &[0.01, 0.02]),
            (&["drive"], &[-0.01]),
            (&["drive"], &[f64::NAN]),
            (&["drive"], &[1e9]),
        ] {
            send(&p, n, t).await;
        }
        let ls = wait_lock(&p, 5.0, |m| m.rejected_commands >= 5)
            .await
            .expect("five bad commands rejected and counted");
        assert_eq!(
            (
                ls.rejected_unknown_cable,
                ls.rejected_mismatched_lengths,
                ls.rejected_bad_tension
            ),
            (1, 1, 3)
        );
        assert_eq!(
            ls.cable_tensions_n,
            vec![0.01],
            "the last good command stays"
        );

        // flood: 10,000 commands as fast as we can write them; latest wins
        let t0 = Instant::now();
        for i in 0..10_000u32 {
            let t = 1e-7 * i as f64; // small: the mast must not deploy during the test
            let _ = p.cmd.publish(CableForceCommand {
                names: vec!["drive".into()],
                tensions_n: vec![t],
            });
            if i % 10 == 9 {
                // 10 per millisecond: a 10,000 commands/s flood
                tokio::time::sleep(Duration::from_millis(1)).await;
            }
            if t0.elapsed() > Duration::from_secs(20) {
                break;
            }
        }
        // and joint_states are still flowing with rising stamps
        let mut stamps = Vec::new();
        for _ in 0..400 {
            match tokio::time::timeout(Duration::from_secs(2), p.js.async_take()).await {
                Ok(Ok((js, _))) => stamps.push(stamp_s(&js.header.stamp)),
                _ => break,
            }
            if stamps.len() >= 20 && stamps.last() > stamps.first() {
                break;
            }
        }
        assert!(
            stamps.len() >= 20,
            "publishing stopped after bad commands / flood"
        );
        assert!(stamps.last() > stamps.first());
    });
}

/// A CableSpeedCommand drives the mast's motor at that speed: on
/// /joint_states the `drive_motor` joint's velocity is the commanded speed
/// (to 1e-9 m/s) and its position (the cable reeled in) grows at it, while
/// /truss/state says the motor is tracking and LockStatus shows the motor's
/// actual tension. A speed above the `max_speed_m_s` parameter is rejected
/// whole and counted, and the good command stays.
#[test]
fn speed_command_drives_the_motor_joint_and_a_bad_one_is_counted() {
    let dom = domain(22);
    let model = crate::taut_mast();
    let _node = spawn_node_on(
        &model,
        dom,
        &[
            "--max-wall-s",
            "20",
            "--rtf",
            "4",
            "--ros-args",
            "-p",
            "max_speed_m_s:=0.05",
        ],
    );
    let speed = 0.02;
    rt().block_on(async {
        let p = peer(dom);
        send_speed(&p, &["drive"], &[speed]).await;
        // /truss/state: the motor tracks the speed
        let end = Instant::now() + Duration::from_secs(10);
        let mut tracking = None;
        for _ in 0..2000 {
            if Instant::now() > end {
                break;
            }
            if let Some(st) = next_state(&p, 2.0).await {
                assert_eq!(st.cable_names, ["drive"]);
                assert_eq!(st.motor_modes.len(), 1);
                if st.motor_modes[0] == "tracking" {
                    tracking = Some(st);
                    break;
                }
            }
        }
        let st = tracking.expect("the motor tracks the commanded speed on /truss/state");
        let t_track = stamp_s(&st.header.stamp);
        assert!(
            st.motor_tensions_n[0] > 0.0 && st.motor_tensions_n[0] <= 1.0,
            "{st:?}"
        );
        // /joint_states after that: the motor joint at the speed
        let mut samples: Vec<(f64, f64, f64, f64)> = Vec::new();
        for _ in 0..2000 {
            if samples.len() >= 40 || Instant::now() > end + Duration::from_secs(5) {
                break;
            }
            let Ok(Ok((js, _))) =
                tokio::time::timeout(Duration::from_secs(2), p.js.async_take()).await
            else {
                break;
            };
            let t = stamp_s(&js.header.stamp);
            if t <= t_track {
                continue;
            }
            let k = js
                .name
                .iter()
                .position(|n| n == "drive_motor")
                .expect("drive_motor on /joint_states");
            samples.push((t, js.position[k], js.velocity[k], js.effort[k]));
        }
        assert!(samples.len() >= 40, "only {} joint_states", samples.len());
        for &(t, _, v, e) in &samples {
            assert!(
                (v - speed).abs() <= 1e-9,
                "t = {t}: drive_motor velocity {v} m/s, commanded {speed}"
            );
            assert!(e > 0.0 && e <= 1.0, "t = {t}: motor tension {e} N");
        }
        let (t0, x0, _, _) = samples[0];
        let (t1, x1, _, _) = *samples.last().unwrap();
        assert!(t1 - t0 > 1.0, "{t0} .. {t1}");
        let rate = (x1 - x0) / (t1 - t0);
        assert!(
            (rate - speed).abs() <= 1e-6,
            "reeled in {} m in {} s: {rate} m/s, commanded {speed}",
            x1 - x0,
            t1 - t0
        );
        // LockStatus: the motor's actual tension, the command counted
        let ls = wait_lock(&p, 5.0, |m| m.accepted_commands == 1)
            .await
            .expect("speed command counted");
        assert!(ls.cable_tensions_n[0] > 0.0 && ls.cable_tensions_n[0] <= 1.0);
        // above max_speed_m_s (0.05): rejected whole, counted as a bad speed
        send_speed(&p, &["drive"], &[-0.5]).await;
        let ls = wait_lock(&p, 5.0, |m| m.rejected_commands >= 1)
            .await
            .expect("bad speed rejected and counted");
        assert_eq!(
            (
                ls.rejected_commands,
                ls.rejected_bad_speed,
                ls.accepted_commands
            ),
            (1, 1, 1),
            "{ls:?}"
        );
        // the good command stays: the motor still reels in at the speed
        let mut after = None;
        for _ in 0..1000 {
            let (js, _) = tokio::time::timeout(Duration::from_secs(2), p.js.async_take())
                .await
                .expect("joint_states go on")
                .unwrap();
            if stamp_s(&js.header.stamp) > stamp_s(&ls.header.stamp) {
                after = Some(js);
                break;
            }
        }
        let js = after.expect("joint_states after the rejection");
        let k = js.name.iter().position(|n| n == "drive_motor").unwrap();
        assert!((js.velocity[k] - speed).abs() <= 1e-9, "{js:?}");
    });
}
