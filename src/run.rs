//! One run of a model to full deployment, as `simulate` and every `sweep`
//! sample make it: the stepping loop with its stop reasons and run checks
//! (`solver::checks`), and the summary of what was computed.
//!
//! The loop knows nothing of output files, progress bars or signals: the
//! caller hooks them in as recorders (`record::Recorder`), which the loop
//! calls at the start, after each step, after its checks and at the end.

use crate::record::{Frame, FrameLayout, RecordError, Recorder};
use crate::solver::checks::{self, HeldShortWatch, RunChecks, StallWatch, StickWatch};
use crate::solver::{Energy, LockEvent, Simulator, SolverError, SolverStats, StepLimits, StopWhy};
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Why a run stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StopReason {
    /// Every sleeve latched (or the truss became rigid): exit 0.
    Deployed,
    /// `--until` reached: exit 0.
    Until,
    /// The model's `end_time_s` reached without deploying: exit 1.
    EndTime,
    /// At rest, and no drive moves it (`checks::StallWatch`): exit 1.
    Stalled,
    /// SIGINT or SIGTERM: exit 130.
    Interrupted,
    /// A step failed, a self-check failed, an output could not be written or
    /// the wall-clock limit was reached: exit 1.
    Error,
}

impl StopReason {
    pub fn exit_code(self) -> i32 {
        match self {
            StopReason::Deployed | StopReason::Until => 0,
            StopReason::Interrupted => 130,
            _ => 1,
        }
    }
    pub fn label(self) -> &'static str {
        match self {
            StopReason::Deployed => "deployed",
            StopReason::Until => "until",
            StopReason::EndTime => "end_time",
            StopReason::Stalled => "stalled",
            StopReason::Interrupted => "interrupted",
            StopReason::Error => "error",
        }
    }
}

/// The summary of a run (`simulate --json`).
#[derive(Serialize)]
pub struct RunSummary {
    pub model: String,
    pub solver: String,
    pub dt_s: f64,
    pub deployed: bool,
    pub deploy_time_s: Option<f64>,
    pub time_s: f64,
    pub steps: u64,
    pub wall_time_s: f64,
    pub final_error_rel: Option<f64>,
    pub max_constraint_violation_m: f64,
    pub energy_balance_rel_error: f64,
    pub dof_initial: usize,
    pub dof_final: usize,
    /// The deployed, latched truss's first natural frequency (Hz): a
    /// property of the model, not of the run (`solver::modes::
    /// deployed_first_frequency_hz`, docs/modes.md); null beyond
    /// `rank_check_max_coords` coordinates.
    pub first_frequency_hz: Option<f64>,
    pub kinetic_energy_j: f64,
    pub energy: Energy,
    pub locks: Vec<LockEvent>,
    /// Why the run stopped, and the sentence that says so.
    pub stop_reason: StopReason,
    pub stop_message: String,
    /// Set when the run stopped on an error (the same as `stop_message`);
    /// everything above is what was computed until then.
    pub error: Option<String>,
    /// What the solver did: steps, sub-steps, iterations, factorizations,
    /// solves, fallbacks by kind, latch searches.
    pub solver_stats: SolverStats,
    /// Results accepted by a fallback that knows them inexact
    /// (`SolverStats::accepting_fallbacks`): 0 when the run needed no rescue.
    pub accepting_fallbacks: u64,
    /// Per drive cable, its motor at the end of the run.
    pub motors: Vec<MotorSummary>,
    /// Per member (bar or sleeve, in model order), its axial force and
    /// length at the end of the run (`record::Frame`).
    pub members: Vec<MemberSummary>,
    /// Per rigid body (a spacecraft bus), its attitude change and rates
    /// (`record::bodies`; in `simulate`'s summary and a sweep's rows).
    pub bodies: Vec<crate::record::bodies::BodySummary>,
    /// With a rigid body: the system's linear and angular momentum and
    /// their drift over the run (null otherwise).
    pub momentum: Option<crate::record::bodies::MomentumSummary>,
}

/// A member at the end of a run.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct MemberSummary {
    pub name: String,
    /// `bar` or `sleeve`.
    pub kind: &'static str,
    /// Axial force (N, tension positive: `record::frame` says from what) and
    /// length (m).
    pub axial_force_n: f64,
    pub length_m: f64,
}

/// A drive cable's motor at the end of a run.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct MotorSummary {
    pub cable: String,
    /// `tension` (commanded tension), `tracking` (at the commanded speed),
    /// `at_limit` (speed-commanded, at its tension limit), `slack`.
    pub mode: crate::solver::state::MotorHold,
    /// The commanded reel-in speed (m/s), null under tension control.
    pub speed_cmd_m_s: Option<f64>,
    /// The motor's tension (N) and the cable it reeled in since the start (m).
    pub tension_n: f64,
    pub reeled_in_m: f64,
}

/// How long a run goes: the step, the end time, whether that end time was
/// asked for (`--until`: reaching it is `Until`, else `EndTime`), the
/// wall-clock limit (s) and a cancel flag (a signal: `Interrupted`), both
/// checked before every sub-step, so also inside one long step.
#[derive(Clone, Debug)]
pub struct RunLimits {
    pub dt_s: f64,
    pub until_s: f64,
    pub until_asked: bool,
    pub max_wall_s: Option<f64>,
    pub cancel: Option<Arc<AtomicBool>>,
}

/// A step and a run length that make no bounded, meaningful run
/// (`check_step_count`); `dt_from` names where dt came from (`--dt`, `dt_s`).
#[derive(Clone, Debug, PartialEq)]
pub enum StepCountError {
    /// dt longer than the whole run.
    LongerThanRun {
        dt_from: String,
        dt_s: f64,
        until_s: f64,
    },
    /// dt below `min_dt_fraction` of the run.
    TooShort {
        dt_from: String,
        dt_s: f64,
        until_s: f64,
        min_dt_fraction: f64,
    },
    /// More steps than `[checks] max_steps`.
    OverBudget {
        dt_from: String,
        dt_s: f64,
        until_s: f64,
        steps: f64,
        max_steps: u64,
    },
}

impl std::fmt::Display for StepCountError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StepCountError::LongerThanRun { dt_from, dt_s: dt, until_s: until } => write!(
                f,
                "{dt_from} {dt:?} s is longer than the run ({until:?} s); give a step shorter than the run"
            ),
            StepCountError::TooShort { dt_from, dt_s: dt, until_s: until, min_dt_fraction } => write!(
                f,
                "{dt_from} {dt:?} s is below {min_dt_fraction:e} of the run ({until:?} s); give a larger step or a shorter --until"
            ),
            StepCountError::OverBudget { dt_from, dt_s: dt, until_s: until, steps, max_steps } => write!(
                f,
                "{dt_from} {dt:?} s over {until:?} s makes {steps:.0} steps, more than the budget of {max_steps} ([checks] max_steps); give a larger step or a shorter --until"
            ),
        }
    }
}

impl std::error::Error for StepCountError {}

/// The step and the run length must make a bounded, meaningful run: dt at
/// most the whole run, at least `min_dt_fraction` of it, and no more steps
/// than `max_steps`. `dt_from` names where dt came from (`--dt`, `dt_s`).
pub fn check_step_count(
    dt: f64,
    until: f64,
    dt_from: &str,
    checks: &RunChecks,
) -> Result<(), StepCountError> {
    let dt_from = dt_from.to_string();
    if dt > until {
        return Err(StepCountError::LongerThanRun {
            dt_from,
            dt_s: dt,
            until_s: until,
        });
    }
    if dt < checks.min_dt_fraction * until {
        return Err(StepCountError::TooShort {
            dt_from,
            dt_s: dt,
            until_s: until,
            min_dt_fraction: checks.min_dt_fraction,
        });
    }
    let steps = (until / dt).ceil();
    if steps > checks.max_steps as f64 {
        return Err(StepCountError::OverBudget {
            dt_from,
            dt_s: dt,
            until_s: until,
            steps,
            max_steps: checks.max_steps,
        });
    }
    Ok(())
}

/// Where the loop stopped: reason, message, wall time of the loop (s), and
/// the recorders' errors at their end (`Recorder::finish`; a run that did
/// what was asked and lost an output stops with `StopReason::Error`).
pub struct Stop {
    pub reason: StopReason,
    pub message: String,
    pub wall_time_s: f64,
    pub record_errors: Vec<RecordError>,
}

fn deployed_message(sim: &Simulator) -> String {
    let (m, s) = (sim.model(), sim.state());
    let t = s.deploy_time_s.unwrap_or(0.0);
    if s.locks.is_empty() {
        return "deployed: every sleeve was latched at the start".into();
    }
    let open = m.locks.iter().filter(|&&e| !s.locked[e]).count();
    if open == 0 {
        format!("deployed at t = {t:.6} s: every sleeve latched")
    } else {
        format!(
            "deployed at t = {t:.6} s: rigid (no mechanism left) with {open} of {} sleeves not latched",
            m.locks.len()
        )
    }
}

/// Why a run stopped at a result accepted inexact beyond
/// `RunChecks::max_inexact_results`: which results (counted since `before`),
/// and how nearly dependent the constraint rows are at the state.
fn inexact(sim: &mut Simulator, before: &SolverStats, t_s: f64) -> String {
    let (now, then) = (
        sim.solver_stats().accepting_fallbacks_by_kind(),
        before.accepting_fallbacks_by_kind(),
    );
    let kinds: Vec<String> = now
        .iter()
        .zip(&then)
        .filter(|(n, b)| n.1 > b.1)
        .map(|(n, b)| format!("{} {}", n.1 - b.1, n.0))
        .collect();
    let rows = match sim.near_dependence() {
        Some(d) => d.to_string(),
        None => {
            "the model is too large for the rows' dense analysis ([solver] rank_check_max_coords)"
                .to_string()
        }
    };
    format!(
        "stopped at t = {t_s:.6} s at the first result accepted inexact (in its sub-step: {}; \
         [checks] max_inexact_results): {rows}",
        kinds.join(", ")
    )
}

/// Steps `sim` until it deploys, reaches the end time, stalls, fails a
/// check or a step, runs out of steps or wall time, or a recorder fails;
/// calls the recorders (in their order) at the start, after each step,
/// after its checks and at the end.
pub fn run_loop(
    sim: &mut Simulator,
    checks: &RunChecks,
    limits: RunLimits,
    recorders: &mut [&mut dyn Recorder],
) -> Stop {
    let (dt, until) = (limits.dt_s, limits.until_s);
    let start = Instant::now();
    let inexact_before = sim.solver_stats().clone();
    sim.set_step_limits(StepLimits {
        deadline: limits
            .max_wall_s
            .map(|limit| start + Duration::from_secs_f64(limit)),
        cancel: limits.cancel.clone(),
        max_accepting_fallbacks: Some(
            inexact_before.accepting_fallbacks() + checks.max_inexact_results,
        ),
    });
    let interrupted = |t_s: f64| {
        (
            StopReason::Interrupted,
            format!("interrupted by a signal at t = {t_s:.6} s"),
        )
    };
    let wall_limit = |t_s: f64| {
        (
            StopReason::Error,
            format!(
                "the wall-clock limit --max-wall-s {} s was reached at t = {t_s:.6} s",
                limits.max_wall_s.unwrap_or(0.0)
            ),
        )
    };
    let mut stall = StallWatch::new(sim.model(), checks);
    let mut held = HeldShortWatch::new(sim.model(), checks);
    let mut stick = StickWatch::new(checks);
    let each =
        |recorders: &mut [&mut dyn Recorder],
         sim: &mut Simulator,
         hook: fn(&mut dyn Recorder, &mut Simulator) -> Result<(), RecordError>| {
            recorders.iter_mut().try_for_each(|r| hook(&mut **r, sim))
        };
    let started = each(recorders, sim, |r, sim| r.start(sim));
    let (reason, message) = loop {
        if let Err(e) = &started {
            break (StopReason::Error, e.to_string());
        }
        let (m, s) = (sim.model(), sim.state());
        if let Some(msg) = checks::jammed(m, s, checks) {
            break (StopReason::Stalled, msg);
        }
        if s.deployed {
            break (StopReason::Deployed, deployed_message(sim));
        }
        if s.t_s >= until - 1e-9 * dt {
            break if limits.until_asked {
                (
                    StopReason::Until,
                    format!("reached --until {until} s, not deployed"),
                )
            } else {
                (
                    StopReason::EndTime,
                    format!(
                        "reached the model's end_time_s = {until} s without deploying; {}",
                        checks::unlatched_summary(m, s)
                    ),
                )
            };
        }
        if limits
            .cancel
            .as_ref()
            .is_some_and(|c| c.load(Ordering::SeqCst))
        {
            break interrupted(s.t_s);
        }
        if let Some(limit) = limits.max_wall_s {
            if start.elapsed().as_secs_f64() > limit {
                break wall_limit(s.t_s);
            }
        }
        if s.steps >= checks.max_steps {
            break (
                StopReason::Error,
                format!(
                    "the step budget of {} steps ([checks] max_steps) was used up at t = {:.6} s",
                    checks.max_steps, s.t_s
                ),
            );
        }
        let h = dt.min(until - s.t_s);
        if let Err(e) = sim.step(h) {
            // (a limit reached inside the step)
            if let SolverError::Stopped { t_s, why } = e {
                break match why {
                    StopWhy::Cancelled => interrupted(t_s),
                    StopWhy::Deadline => wall_limit(t_s),
                    StopWhy::Inexact => (StopReason::Error, inexact(sim, &inexact_before, t_s)),
                };
            }
            break (
                StopReason::Error,
                format!(
                    "the step from t = {:.6} s failed: {e} (there: {} mechanism(s) left; {})",
                    sim.state().t_s,
                    sim.state().mechanisms,
                    checks::unlatched_summary(sim.model(), sim.state())
                ),
            );
        }
        if let Err(e) = each(recorders, sim, |r, sim| r.after_step(sim)) {
            break (StopReason::Error, e.to_string());
        }
        let (m, s) = (sim.model(), sim.state());
        if let Some(why) = checks::energy_unbalanced(m, s, checks) {
            break (StopReason::Error, format!("at t = {:.6} s {why}", s.t_s));
        }
        if let Some(why) = stall.update(m, s) {
            break (
                StopReason::Stalled,
                format!("stalled at t = {:.6} s: {why}", s.t_s),
            );
        }
        if let Some(why) = held.update(m, s) {
            break (
                StopReason::Stalled,
                format!("stalled at t = {:.6} s: {why}", s.t_s),
            );
        }
        if let Some(why) = stick.update(m, s) {
            break (
                StopReason::Stalled,
                format!("stalled at t = {:.6} s: {why}", s.t_s),
            );
        }
        if let Err(e) = each(recorders, sim, |r, sim| r.after_checks(sim)) {
            break (StopReason::Error, e.to_string());
        }
    };
    sim.set_step_limits(StepLimits::default());
    let mut stop = Stop {
        reason,
        message,
        wall_time_s: start.elapsed().as_secs_f64(),
        record_errors: Vec::new(),
    };
    for r in recorders.iter_mut() {
        if let Err(e) = r.finish(sim, &stop) {
            stop.record_errors.push(e);
        }
    }
    if !stop.record_errors.is_empty() && stop.reason.exit_code() == 0 {
        stop.reason = StopReason::Error;
        stop.message = stop
            .record_errors
            .iter()
            .map(|e| e.to_string())
            .collect::<Vec<_>>()
            .join("; ");
    }
    stop
}

/// The summary of what `sim` computed, stopped for `reason`.
#[allow(clippy::too_many_arguments)]
pub fn summarize(
    sim: &mut Simulator,
    checks: &RunChecks,
    solver: &str,
    dt_s: f64,
    dof_initial: usize,
    wall_time_s: f64,
    reason: StopReason,
    message: String,
) -> RunSummary {
    let layout = FrameLayout::new(sim.model());
    let frame = Frame::capture(&layout, sim);
    let (m, s) = (sim.model(), sim.state());
    let ke = s.kinetic_energy_j(m);
    let jam = checks::jammed(m, s, checks).is_some();
    RunSummary {
        model: m.name.clone(),
        solver: solver.to_string(),
        dt_s,
        deployed: s.deployed && !jam,
        deploy_time_s: if jam {
            None
        } else {
            s.deploy_time_s.or(s.deployed.then_some(0.0))
        },
        time_s: s.t_s,
        steps: s.steps,
        wall_time_s,
        final_error_rel: s.final_error_rel(m),
        max_constraint_violation_m: s.max_violation_m,
        energy_balance_rel_error: s.energy.balance_rel_error(ke),
        dof_initial,
        dof_final: s.mechanisms,
        first_frequency_hz: crate::solver::modes::deployed_first_frequency_hz(m),
        kinetic_energy_j: ke,
        energy: s.energy.clone(),
        locks: s.locks.clone(),
        stop_reason: reason,
        error: (reason == StopReason::Error).then(|| message.clone()),
        stop_message: message,
        solver_stats: sim.solver_stats().clone(),
        accepting_fallbacks: sim.solver_stats().accepting_fallbacks(),
        motors: m
            .cables
            .iter()
            .enumerate()
            .map(|(ci, c)| MotorSummary {
                cable: c.name.clone(),
                mode: s.motors[ci].hold,
                speed_cmd_m_s: s.motors[ci].speed_cmd_m_s,
                tension_n: s.motor_tension_n(ci),
                reeled_in_m: s.reeled_in_m(m, ci),
            })
            .collect(),
        members: layout
            .members
            .iter()
            .enumerate()
            .map(|(k, mb)| MemberSummary {
                name: mb.name.clone(),
                kind: mb.kind.label(),
                axial_force_n: frame.member_force_n[k],
                length_m: frame.member_length_m[k],
            })
            .collect(),
        bodies: Vec::new(),
        momentum: None,
    }
}
