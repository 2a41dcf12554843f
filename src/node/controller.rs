//! `truss-deploy controller`: subscribes /truss/state (and /truss/lock_status for the
//! cable names and limits), sends /truss/cable_force_cmd, easing the drive tension as
//! deploy_fraction nears 1 so the sleeves latch more gently. `--offline MODEL` runs
//! the same law against the Simulator in-process (no DDS) next to constant tension.

use super::msgs::*;
use super::{make_context, normalize_namespace, qos, topic_name};
use crate::solver::{Options, Simulator};
use clap::Args;
use ros2_client::{MessageTypeName, NodeName, NodeOptions};
use std::path::PathBuf;
use std::time::{Duration, Instant};

#[derive(Args, Debug, Clone)]
pub struct ControllerArgs {
    /// Drive tension far from deployment (N). Default: the tension the node
    /// reports for each cable when the controller starts.
    #[arg(long, allow_negative_numbers = true)]
    pub tension_n: Option<f64>,
    /// Deploy fraction where easing starts.
    #[arg(long, default_value_t = 0.5, allow_negative_numbers = true)]
    pub ease_from: f64,
    /// Fraction of the tension kept at deploy_fraction 1 (so it still closes).
    #[arg(long, default_value_t = 0.1, allow_negative_numbers = true)]
    pub floor: f64,
    /// Namespace of the node.
    #[arg(long, default_value = "/")]
    pub namespace: String,
    #[arg(long)]
    pub loopback: bool,
    /// Stop after this many wall seconds (default: when the truss is deployed).
    #[arg(long, allow_negative_numbers = true)]
    pub max_wall_s: Option<f64>,
    /// Run in-process against the Simulator (no DDS): constant vs eased tension.
    #[arg(long)]
    pub offline: Option<PathBuf>,
}

/// The easing law: full tension below `ease_from`, then linear down to
/// `floor * tension` at deploy_fraction 1.
pub fn eased_tension(tension_n: f64, fraction: f64, ease_from: f64, floor: f64) -> f64 {
    if fraction <= ease_from {
        return tension_n;
    }
    let s = ((fraction - ease_from) / (1.0 - ease_from).max(1e-9)).clamp(0.0, 1.0);
    tension_n * (1.0 - s * (1.0 - floor))
}

fn check(a: &ControllerArgs) -> Result<(), String> {
    if !(0.0..1.0).contains(&a.ease_from) {
        return Err(format!("--ease-from {} must be in [0, 1)", a.ease_from));
    }
    if !(0.0..=1.0).contains(&a.floor) {
        return Err(format!("--floor {} must be in [0, 1]", a.floor));
    }
    if let Some(t) = a.tension_n {
        if !(t.is_finite() && t >= 0.0) {
            return Err(format!("--tension-n {t} must be finite and >= 0"));
        }
    }
    Ok(())
}

#[derive(Debug, Clone, serde::Serialize)]
pub struct OfflineRun {
    pub law: String,
    pub deploy_time_s: Option<f64>,
    pub max_impulse_ns: f64,
    pub sum_impulse_ns: f64,
    pub energy_lost_j: f64,
}

/// Constant vs eased tension on the Simulator directly. Bounded by the model's end time.
pub fn offline(path: &std::path::Path, a: &ControllerArgs) -> Result<Vec<OfflineRun>, String> {
    check(a)?;
    let mut out = Vec::new();
    for eased in [false, true] {
        let loaded = crate::model::load(path).map_err(|e| e.to_string())?;
        let checks = loaded.checks;
        let mut sim =
            Simulator::new(loaded.model, Options::default()).map_err(|e| e.to_string())?;
        let base: Vec<f64> = sim
            .model()
            .cables
            .iter()
            .map(|c| a.tension_n.unwrap_or(c.tension_n).min(c.max_tension_n))
            .collect();
        let dt = sim.model().dt_s;
        let steps = (sim.model().end_time_s / dt).ceil() as usize;
        for _ in 0..steps {
            if sim.state().deployed {
                break;
            }
            let f = sim.state().deploy_fraction(sim.model());
            for (c, &t0) in base.iter().enumerate() {
                let t = if eased {
                    eased_tension(t0, f, a.ease_from, a.floor)
                } else {
                    t0
                };
                sim.set_cable_tension(c, t).map_err(|e| e.to_string())?;
            }
            sim.step(dt).map_err(|e| e.to_string())?;
        }
        let s = sim.state();
        // a truss rigid short of its reference jammed: no deploy time
        let deployed =
            s.deployed && crate::solver::checks::jammed(sim.model(), s, &checks).is_none();
        out.push(OfflineRun {
            law: if eased {
                format!("eased from {} to {}x", a.ease_from, a.floor)
            } else {
                "constant".into()
            },
            deploy_time_s: if deployed {
                s.deploy_time_s.or(Some(s.t_s))
            } else {
                None
            },
            max_impulse_ns: s
                .locks
                .iter()
                .map(|l| l.impulse_ns.abs())
                .fold(0.0, f64::max),
            sum_impulse_ns: s.locks.iter().map(|l| l.impulse_ns.abs()).sum(),
            energy_lost_j: s.locks.iter().map(|l| l.energy_lost_j).sum(),
        });
    }
    Ok(out)
}

/// Summary of a DDS controller run.
#[derive(Debug, Default, Clone)]
pub struct ControllerRun {
    pub states: u64,
    pub commands: u64,
    pub deployed: bool,
    pub max_impulse_ns: f64,
    pub impulses_ns: Vec<f64>,
}

pub fn run_blocking(a: ControllerArgs) -> Result<ControllerRun, String> {
    check(&a)?;
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .map_err(|e| e.to_string())?;
    rt.block_on(run(a))
}

pub async fn run(a: ControllerArgs) -> Result<ControllerRun, String> {
    let ns = normalize_namespace(&a.namespace)?;
    let context = make_context(a.loopback)?;
    let mut node = context
        .new_node(
            NodeName::new(&ns, "truss_controller").map_err(|e| format!("{e:?}"))?,
            NodeOptions::new().enable_rosout(false),
        )
        .map_err(|e| format!("node: {e:?}"))?;
    let st_t = node
        .create_topic(
            &topic_name(&ns, "truss", "state")?,
            MessageTypeName::new("truss_deploy", "TrussState"),
            &qos::reliable10(),
        )
        .map_err(|e| format!("{e:?}"))?;
    let st = node
        .create_subscription::<TrussState>(&st_t, None)
        .map_err(|e| format!("{e:?}"))?;
    let lk_t = node
        .create_topic(
            &topic_name(&ns, "truss", "lock_status")?,
            MessageTypeName::new("truss_deploy", "LockStatus"),
            &qos::latched(),
        )
        .map_err(|e| format!("{e:?}"))?;
    let lk = node
        .create_subscription::<LockStatus>(&lk_t, None)
        .map_err(|e| format!("{e:?}"))?;
    let cmd_t = node
        .create_topic(
            &topic_name(&ns, "truss", "cable_force_cmd")?,
            MessageTypeName::new("truss_deploy", "CableForceCommand"),
            &qos::reliable10(),
        )
        .map_err(|e| format!("{e:?}"))?;
    let cmd = node
        .create_publisher::<CableForceCommand>(&cmd_t, None)
        .map_err(|e| format!("{e:?}"))?;
    let spin = tokio::spawn(node.spinner().map_err(|e| format!("{e:?}"))?.spin());

    let start = Instant::now();
    let max_wall = Duration::from_secs_f64(a.max_wall_s.unwrap_or(600.0).clamp(0.1, 86_400.0));
    let mut run = ControllerRun::default();
    let mut cables: Option<(Vec<String>, Vec<f64>)> = None;
    let mut last_sent: Option<Vec<f64>> = None;
    // bounded: one iteration per received sample or 50 ms, until max_wall
    let max_iter = (max_wall.as_secs_f64() / 0.001) as u64 + 1000;
    for _ in 0..max_iter {
        if start.elapsed() >= max_wall {
            break;
        }
        tokio::select! {
            r = lk.async_take() => if let Ok((m, _)) = r {
                if cables.is_none() {
                    let base = a.tension_n.map(|t| vec![t; m.cable_names.len()])
                        .unwrap_or_else(|| m.cable_tensions_n.clone());
                    say!("controller: cables {:?}, base tensions {:?} N", m.cable_names, base);
                    cables = Some((m.cable_names.clone(), base));
                }
                run.impulses_ns = m.impulse_ns.clone();
                run.max_impulse_ns = m.impulse_ns.iter().map(|x| x.abs()).fold(0.0, f64::max);
                if m.deployed && !run.deployed {
                    run.deployed = true;
                    say!("controller: deployed; latch impulses {:?} N s (max {:.6})", m.impulse_ns, run.max_impulse_ns);
                    if a.max_wall_s.is_none() { break; }
                }
            },
            r = st.async_take() => if let Ok((s, _)) = r {
                run.states += 1;
                if let Some((names, base)) = &cables {
                    let t: Vec<f64> = base.iter().map(|&t0| eased_tension(t0, s.deploy_fraction, a.ease_from, a.floor)).collect();
                    // send on change only (keeps the command stream small)
                    if last_sent.as_ref() != Some(&t) {
                        let _ = cmd.publish(CableForceCommand { names: names.clone(), tensions_n: t.clone() });
                        run.commands += 1;
                        last_sent = Some(t);
                    }
                }
            },
            _ = tokio::time::sleep(Duration::from_millis(50)) => {}
        }
    }
    drop(cmd);
    drop(st);
    drop(lk);
    node.stop_spinner();
    let _ = tokio::time::timeout(Duration::from_secs(3), spin).await;
    drop(node);
    drop(context);
    Ok(run)
}
