//! `truss-deploy simulate`: offline run to full deployment.
//!
//! Every run ends with a stop reason (`StopReason`), in the summary on stdout
//! and in the JSON, and an exit status: 0 when it did what was asked
//! (deployed, or reached `--until`), 1 when it stopped otherwise (the model's
//! end time, a stall, a failed step or self-check, the wall-clock limit),
//! 2 on bad input (before the run), 130 when interrupted by SIGINT/SIGTERM.
//! Whatever ends the run, the CSV (whole rows), the plots and the summary of
//! what was computed are written.

use super::output::{check_outputs, write_atomic, AtomicFile};
use super::{interrupt, make_simulator_from, plot, Failure, SolverArg};
use crate::solver::checks::{self, HeldShortWatch, RunChecks, StallWatch};
use crate::solver::{Energy, LockEvent, Simulator, SolverError, SolverStats, StepLimits, StopWhy};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;
use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

#[derive(Args, Debug)]
pub struct SimulateArgs {
    /// Model file (TOML).
    model: PathBuf,
    /// Time step (s); default: the model's `dt_s`. At least 1e-9 of the run, at most all of it.
    #[arg(long, allow_negative_numbers = true)]
    dt: Option<f64>,
    /// Stop at this simulation time (s) even if not deployed (exit 0); default: the model's
    /// `end_time_s` (reaching it undeployed is exit 1).
    #[arg(long, allow_negative_numbers = true)]
    until: Option<f64>,
    /// Stop the run (exit 1, outputs written) after this much wall-clock time (s).
    #[arg(long, allow_negative_numbers = true)]
    max_wall_s: Option<f64>,
    /// Write every joint coordinate against time.
    #[arg(long)]
    csv: Option<PathBuf>,
    /// Write the summary as JSON.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Draw the x, y, z histories of the --joints, latch events marked (SVG).
    #[arg(long, value_name = "FILE.svg")]
    plot: Option<PathBuf>,
    /// Joints for --plot, comma-separated; default: the 3 that move the most.
    #[arg(long, value_delimiter = ',', value_name = "A,B,C")]
    joints: Vec<String>,
    /// Draw the truss at 6 instants of the deployment in a 3-D projection (SVG).
    #[arg(long, value_name = "FILE.svg")]
    snapshots: Option<PathBuf>,
    /// Draw each sleeve's latch time against its place around the ring, marker area
    /// by impulse, the hardest and the last latch labelled (SVG).
    #[arg(long, value_name = "FILE.svg")]
    latch_plot: Option<PathBuf>,
    /// Linear solver: sparse (range-space LDL^T and conjugate gradients) or dense (SVD, the
    /// paper's null-space method); the same motion.
    #[arg(long, value_enum, default_value_t = SolverArg::Sparse)]
    solver: SolverArg,
    /// Record the run as a ROS 2 MCAP file: the node's topics, log time = simulation time.
    #[cfg(feature = "ros")]
    #[arg(long, value_name = "FILE.mcap")]
    mcap: Option<PathBuf>,
    /// --mcap: publications per simulated second (default: every step; /truss/markers at
    /// most 5 per simulated second, as the node publishes them).
    #[cfg(feature = "ros")]
    #[arg(
        long,
        value_name = "HZ",
        allow_negative_numbers = true,
        requires = "mcap"
    )]
    mcap_rate: Option<f64>,
}

/// Why a run stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
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
    fn label(self) -> &'static str {
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

#[derive(Serialize)]
pub struct SimulateJson {
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
}

fn check_positive(name: &str, v: Option<f64>) -> Result<(), Failure> {
    match v {
        Some(x) if !(x.is_finite() && x > 0.0) => Err(Failure::input(format!(
            "{name} {x} must be a positive number of seconds"
        ))),
        _ => Ok(()),
    }
}

/// The step and the run length must make a bounded, meaningful run: dt at
/// most the whole run, at least `min_dt_fraction` of it, and no more steps
/// than `max_steps`.
fn check_step_count(dt: f64, until: f64, dt_from: &str, checks: &RunChecks) -> Result<(), Failure> {
    if dt > until {
        return Err(Failure::input(format!(
            "{dt_from} {dt:?} s is longer than the run ({until:?} s); give a step shorter than the run"
        )));
    }
    if dt < checks.min_dt_fraction * until {
        return Err(Failure::input(format!(
            "{dt_from} {dt:?} s is below {:e} of the run ({until:?} s); give a larger step or a shorter --until",
            checks.min_dt_fraction
        )));
    }
    let steps = (until / dt).ceil();
    if steps > checks.max_steps as f64 {
        return Err(Failure::input(format!(
            "{dt_from} {dt:?} s over {until:?} s makes {steps:.0} steps, more than the budget of {} ([checks] max_steps); give a larger step or a shorter --until",
            checks.max_steps
        )));
    }
    Ok(())
}

fn csv_header(sim: &Simulator) -> String {
    let mut h = String::from("t_s");
    for j in &sim.model().joints {
        for c in ["x", "y", "z"] {
            h += &format!(",{}_{c}_m", j.name);
        }
    }
    h
}

fn csv_row(out: &mut impl Write, sim: &Simulator) -> std::io::Result<()> {
    let s = sim.state();
    write!(out, "{}", s.t_s)?;
    for v in &s.x {
        write!(out, ",{v}")?;
    }
    writeln!(out)
}

pub fn run(a: SimulateArgs) -> Result<(), Failure> {
    check_positive("--dt", a.dt)?;
    check_positive("--until", a.until)?;
    check_positive("--max-wall-s", a.max_wall_s)?;
    let (mut sim, checks) = make_simulator_from(&a.model, a.solver.into())?;
    #[cfg(feature = "ros")]
    let mcap_path = &a.mcap;
    #[cfg(not(feature = "ros"))]
    let mcap_path: &Option<std::path::PathBuf> = &None;
    let outputs: Vec<(&str, &std::path::Path)> = [
        ("--csv", &a.csv),
        ("--json", &a.json),
        ("--plot", &a.plot),
        ("--snapshots", &a.snapshots),
        ("--latch-plot", &a.latch_plot),
        ("--mcap", mcap_path),
    ]
    .into_iter()
    .filter_map(|(o, p)| p.as_deref().map(|p| (o, p)))
    .collect();
    check_outputs(&[a.model.as_path()], &outputs)?;
    let dt = a.dt.unwrap_or(sim.model().dt_s);
    let until = a.until.unwrap_or(sim.model().end_time_s);
    let dt_from = if a.dt.is_some() { "--dt" } else { "dt_s" };
    check_step_count(dt, until, dt_from, &checks)
        .map_err(|f| Failure::input(format!("{}: {}", a.model.display(), f.message)))?;
    // A model that cannot deploy is refused when the run is to deploy it;
    // with --until (a run for a time) it is a warning.
    if let Some(why) = checks::cannot_deploy(sim.model(), sim.state()) {
        if a.until.is_none() {
            return Err(Failure::input(format!(
                "{}: the model cannot deploy: {why}; fix the model (`truss-deploy analyze` \
                 shows its mechanisms), or give --until to run it for a time anyway",
                a.model.display()
            )));
        }
        super::warn(&format!(
            "{}: the model cannot deploy: {why}",
            a.model.display()
        ));
    }
    let mut rec = plot::Recorder::new(
        sim.model(),
        a.plot.as_deref(),
        &a.joints,
        a.snapshots.as_deref(),
    )
    .map_err(Failure::input)?;
    rec.record(sim.state().t_s, &sim.state().x);
    let mut csv = match &a.csv {
        Some(p) => {
            let mut f = AtomicFile::create(p).map_err(Failure::input)?;
            writeln!(f.writer(), "{}", csv_header(&sim))
                .and_then(|_| csv_row(f.writer(), &sim))
                .map_err(|e| Failure::run(format!("cannot write {}: {e}", p.display())))?;
            Some(f)
        }
        None => None,
    };
    let dof_initial = sim.state().mechanisms;
    // --mcap (issue 15): the node's topics recorded offline, one code path with the node.
    #[cfg(feature = "ros")]
    // (written to a temporary sibling, renamed onto the target once finished)
    let mut mcap = match &a.mcap {
        Some(p) => {
            let temp = super::output::temp_path(p, "part");
            match crate::node::record::OfflineRecording::start(&temp, &mut sim, a.mcap_rate) {
                Ok(r) => Some((r, temp, p.clone())),
                Err(e) => {
                    let _ = std::fs::remove_file(&temp);
                    return Err(Failure::input(
                        e.replace(&temp.display().to_string(), &p.display().to_string()),
                    ));
                }
            }
        }
        None => None,
    };
    let bar = ProgressBar::new((until / dt).ceil() as u64);
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} t = {msg} [{bar:30}] {pos}/{len} steps, {elapsed} elapsed",
        )
        .expect("valid template")
        .progress_chars("=> "),
    );
    interrupt::install();
    let start = Instant::now();
    // (checked inside a step too: one step near a singular state can run
    // for minutes)
    sim.set_step_limits(StepLimits {
        deadline: a
            .max_wall_s
            .map(|limit| start + std::time::Duration::from_secs_f64(limit)),
        cancel: Some(interrupt::flag()),
    });
    let mut stall = StallWatch::new(sim.model(), &checks);
    let mut held = HeldShortWatch::new(sim.model(), &checks);
    let stop: (StopReason, String) = loop {
        let (m, s) = (sim.model(), sim.state());
        if let Some(msg) = checks::jammed(m, s, &checks) {
            break (StopReason::Stalled, msg);
        }
        if s.deployed {
            let t = s.deploy_time_s.unwrap_or(0.0);
            break (
                StopReason::Deployed,
                if s.locks.is_empty() {
                    "deployed: every sleeve was latched at the start".into()
                } else {
                    {
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
                },
            );
        }
        if s.t_s >= until - 1e-9 * dt {
            break match a.until {
                Some(u) => (
                    StopReason::Until,
                    format!("reached --until {u} s, not deployed"),
                ),
                None => (
                    StopReason::EndTime,
                    format!(
                        "reached the model's end_time_s = {until} s without deploying; {}",
                        checks::unlatched_summary(m, s)
                    ),
                ),
            };
        }
        if interrupt::requested() {
            break interrupted_stop(s.t_s);
        }
        if let Some(limit) = a.max_wall_s {
            if start.elapsed().as_secs_f64() > limit {
                break wall_limit_stop(limit, s.t_s);
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
            if let SolverError::Stopped { t_s, why } = e {
                break match why {
                    StopWhy::Cancelled => interrupted_stop(t_s),
                    StopWhy::Deadline => wall_limit_stop(a.max_wall_s.unwrap_or(0.0), t_s),
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
        let (m, s) = (sim.model(), sim.state());
        if let Some(f) = csv.as_mut() {
            if let Err(e) = csv_row(f.writer(), &sim) {
                break (
                    StopReason::Error,
                    format!(
                        "cannot write {}: {e}",
                        a.csv.as_ref().expect("csv path").display()
                    ),
                );
            }
        }
        rec.record(s.t_s, &s.x);
        if let Some(why) = checks::energy_unbalanced(m, s, &checks) {
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
        // (recording after the checks: the mutable borrow ends the state's)
        #[cfg(feature = "ros")]
        if let Some((mc, temp, target)) = mcap.as_mut() {
            if let Err(e) = mc.after_step(&mut sim) {
                let e = e.replace(&temp.display().to_string(), &target.display().to_string());
                break (StopReason::Error, format!("cannot record --mcap: {e}"));
            }
        }
        let (m, s) = (sim.model(), sim.state());
        bar.inc(1);
        if s.steps % 20 == 0 {
            bar.set_message(format!(
                "{:.2} s, {}/{} locks",
                s.t_s,
                s.locks_engaged(m),
                m.locks.len()
            ));
        }
    };
    bar.finish_and_clear();
    let wall = start.elapsed().as_secs_f64();
    let (mut reason, mut message) = stop;
    // Outputs: what was computed, whatever stopped the run. A failed write
    // turns a run that did what was asked into an error (exit 1).
    let mut write_errors: Vec<String> = Vec::new();
    if let Some(f) = csv {
        if let Err(e) = f.commit() {
            write_errors.push(e);
        }
    }
    #[cfg(feature = "ros")]
    if let Some((m, temp, target)) = mcap {
        let shown =
            |e: String| e.replace(&temp.display().to_string(), &target.display().to_string());
        match m.finish(&mut sim).map_err(shown).and_then(|st| {
            std::fs::rename(&temp, &target)
                .map(|_| st)
                .map_err(|e| format!("cannot write {}: {e}", target.display()))
        }) {
            Ok(st) => say!(
                "mcap             {} messages, {} bytes: {}",
                st.messages,
                st.bytes,
                target.display()
            ),
            Err(e) => {
                let _ = std::fs::remove_file(&temp);
                write_errors.push(e);
            }
        }
    }
    let (m, s) = (sim.model(), sim.state());
    let locks: Vec<(String, f64)> = s.locks.iter().map(|l| (l.name.clone(), l.time_s)).collect();
    if let Err(e) = rec.finish(m, &locks) {
        write_errors.push(e);
    }
    if let Some(p) = &a.latch_plot {
        let sleeves: Vec<String> = m
            .locks
            .iter()
            .map(|&e| m.elements[e].name().to_string())
            .collect();
        if let Err(e) = plot::latch_plot(p, &format!("{}: latches", m.name), &sleeves, &s.locks) {
            write_errors.push(e);
        }
    }
    if !write_errors.is_empty() && reason.exit_code() == 0 {
        reason = StopReason::Error;
        message = write_errors.join("; ");
    }
    let ke = s.kinetic_energy_j(m);
    let jam = checks::jammed(m, s, &checks).is_some();
    let summary = SimulateJson {
        model: m.name.clone(),
        solver: format!("{:?}", a.solver).to_lowercase(),
        dt_s: dt,
        deployed: s.deployed && !jam,
        deploy_time_s: if jam {
            None
        } else {
            s.deploy_time_s.or(s.deployed.then_some(0.0))
        },
        time_s: s.t_s,
        steps: s.steps,
        wall_time_s: wall,
        final_error_rel: s.final_error_rel(m),
        max_constraint_violation_m: s.max_violation_m,
        energy_balance_rel_error: s.energy.balance_rel_error(ke),
        dof_initial,
        dof_final: s.mechanisms,
        kinetic_energy_j: ke,
        energy: s.energy.clone(),
        locks: s.locks.clone(),
        stop_reason: reason,
        stop_message: message.clone(),
        solver_stats: sim.solver_stats().clone(),
        error: (reason == StopReason::Error).then(|| message.clone()),
    };
    print_summary(&summary);
    if let Some(j) = &a.json {
        let text = serde_json::to_string_pretty(&summary).expect("summary serializes") + "\n";
        if let Err(e) = write_atomic(j, text.as_bytes()) {
            write_errors.push(e.clone());
            if reason.exit_code() == 0 {
                reason = StopReason::Error;
                message = e;
            }
        }
    }
    for e in write_errors.iter().filter(|e| **e != message) {
        super::warn(e);
    }
    match reason.exit_code() {
        0 => Ok(()),
        code => Err(Failure { code, message }),
    }
}

/// The latch with the largest load: the largest peak force among compliant
/// latches, else the largest impulse among rigid ones.
fn largest_latch_load(locks: &[LockEvent]) -> Option<&LockEvent> {
    let by = |f: fn(&LockEvent) -> Option<f64>| {
        locks
            .iter()
            .filter_map(|l| f(l).map(|v| (v, l)))
            .max_by(|a, b| a.0.total_cmp(&b.0))
            .map(|(_, l)| l)
    };
    by(|l| l.peak_force_n).or_else(|| by(|l| Some(l.impulse_ns)))
}

fn print_summary(s: &SimulateJson) {
    say!("model            {}", s.model);
    match s.deploy_time_s {
        Some(t) if s.deployed => say!("deployed         yes, at t = {t:.6} s"),
        _ => say!("deployed         no (stopped at t = {:.3} s)", s.time_s),
    }
    // (a message that starts with its reason is not prefixed with it again)
    let label = s.stop_reason.label();
    if s.stop_message.starts_with(label) {
        say!("stop             {}", s.stop_message);
    } else {
        say!("stop             {label}: {}", s.stop_message);
    }
    say!(
        "steps            {} at dt = {} s, wall time {:.3} s",
        s.steps,
        s.dt_s,
        s.wall_time_s
    );
    if let Some(e) = s.final_error_rel {
        say!("final error      {e:.3e} of the largest reference dimension");
    }
    say!("max |Phi|        {:.3e} m", s.max_constraint_violation_m);
    say!(
        "energy           motor {:.6e} J, friction {:.3e} J, damping {:.3e} J, latches {:.6e} J, kinetic {:.6e} J, elastic {:.3e} J; balance error {:.2e}",
        s.energy.motor_work_j, s.energy.friction_loss_j, s.energy.damping_loss_j, s.energy.lock_loss_j + s.energy.latch_damping_loss_j, s.kinetic_energy_j, s.energy.latch_spring_energy_j + s.energy.element_spring_energy_j, s.energy_balance_rel_error
    );
    say!(
        "mechanisms       {} at start, {} at end",
        s.dof_initial,
        s.dof_final
    );
    let st = &s.solver_stats;
    say!(
        "solver           {} sub-steps ({} halvings), {} constraint solves ({} unconverged)",
        st.substeps,
        st.fallbacks.substep_halvings,
        st.solves,
        st.fallbacks.solve_unconverged
    );
    if st.fallbacks.solve_unconverged * 10 > st.solves {
        // (the run's checks still hold: balance, |Phi|; what suffers is the time)
        say!(
            "                 more than a tenth of the solves did not converge: the constraints \
             are nearly redundant here (a configuration close to singular, such as a ring's \
             last bays near flat; `cargo run --release --example near_singular` on a restart, \
             docs/double_ring_stowing.md, \"The 36-sided ring's endgame\"), which is what makes such a run slow"
        );
    }
    if !s.locks.is_empty() {
        say!(
            "\n{:<16} {:>14} {:>14} {:>16} {:>14} {:>14} {:>14}",
            "lock",
            "time_s",
            "impulse_ns",
            "energy_lost_j",
            "speed_m_s",
            "peak_force_n",
            "time_of_peak_s"
        );
        let opt = |v: Option<f64>, prec: usize| v.map_or("-".into(), |v| format!("{v:.prec$e}"));
        for l in &s.locks {
            say!(
                "{:<16} {:>14.6} {:>14.6e} {:>16.6e} {:>14.6e} {:>14} {:>14}",
                l.name,
                l.time_s,
                l.impulse_ns,
                l.energy_lost_j,
                l.closing_speed_m_s,
                opt(l.peak_force_n, 6),
                opt(l.time_of_peak_s, 6)
            );
        }
        if let Some(l) = largest_latch_load(&s.locks) {
            match l.peak_force_n {
                Some(f) => say!(
                    "largest latch load: `{}`, peak force {f:.6e} N at t = {:.6} s",
                    l.name,
                    l.time_of_peak_s.unwrap_or(l.time_s)
                ),
                None => say!(
                    "largest latch load: `{}`, impulse {:.6e} N s at t = {:.6} s (rigid latch)",
                    l.name,
                    l.impulse_ns,
                    l.time_s
                ),
            }
        }
    }
}

/// The stop of a run a signal interrupted at t_s.
fn interrupted_stop(t_s: f64) -> (StopReason, String) {
    (
        StopReason::Interrupted,
        format!("interrupted by a signal at t = {t_s:.6} s"),
    )
}

/// The stop of a run that reached its `--max-wall-s` limit at t_s.
fn wall_limit_stop(limit_s: f64, t_s: f64) -> (StopReason, String) {
    (
        StopReason::Error,
        format!("the wall-clock limit --max-wall-s {limit_s} s was reached at t = {t_s:.6} s"),
    )
}
