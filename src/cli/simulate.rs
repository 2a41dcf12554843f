//! `truss-deploy simulate`: offline run to full deployment.
//!
//! Every run ends with a stop reason (`StopReason`), in the summary on stdout
//! and in the JSON, and an exit status: 0 when it did what was asked
//! (deployed, or reached `--until`), 1 when it stopped otherwise (the model's
//! end time, a stall, a failed step or self-check, the wall-clock limit),
//! 2 on bad input (before the run), 130 when interrupted by SIGINT/SIGTERM.
//! Whatever ends the run, the CSV (whole rows), the plots and the summary of
//! what was computed are written.

use super::output::{check_outputs, write_atomic};
use super::{interrupt, make_simulator_from, plot, Failure, SolverArg};
use crate::record::csv::CsvRecorder;
use crate::record::{report, vtk, RecordError, Recorder, Thinning};
use crate::run::{self, RunLimits};
use crate::solver::checks;
use crate::solver::state::MotorHold;
use crate::solver::{LockEvent, Simulator};
use crate::sweep::history;
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;

#[derive(Args, Debug)]
// (the outputs --history-every thins: either or both)
#[command(group(clap::ArgGroup::new("thinned").multiple(true)))]
pub struct SimulateArgs {
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
    /// Write the run's history as Parquet tables into this directory (created if missing):
    /// joints.parquet, members.parquet, cables.parquet, latches.parquet, energy.parquet,
    /// bodies.parquet.
    #[arg(long, value_name = "DIR", group = "thinned")]
    history: Option<PathBuf>,
    /// Write the run as a ParaView series into this directory (created if missing):
    /// run.pvd over frame_00000.vtp, ...
    #[arg(long, value_name = "DIR", group = "thinned")]
    vtk: Option<PathBuf>,
    /// --history, --vtk: record every N-th step (the first and the last always).
    #[arg(
        long,
        value_name = "N",
        default_value_t = 1,
        allow_negative_numbers = true,
        requires = "thinned"
    )]
    history_every: i64,
    /// Write one self-contained HTML report (no network needed): the truss in 3D playing
    /// its deployment, members coloured by axial force, cable tension, latch forces and
    /// energy against time, the latch table and the solver's counters (docs/cli.md).
    #[arg(long, value_name = "FILE.html")]
    report: Option<PathBuf>,
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
    #[arg(long, value_enum, default_value_t = SolverArg::Sparse)]
    solver: SolverArg,
    /// Drive a cable's motor at a reel-in speed (m/s; negative pays out) instead of its
    /// tension, up to its max_tension_n: `CABLE=SPEED`, or `SPEED` for every cable. Repeatable.
    #[arg(long, value_name = "[CABLE=]M_S", allow_negative_numbers = true)]
    motor_speed: Vec<String>,
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

pub use crate::run::{RunSummary as SimulateJson, StopReason};

/// `--history-every N`: a whole number of steps, at least 1.
fn history_every(a: &SimulateArgs) -> Result<u64, Failure> {
    match u64::try_from(a.history_every) {
        Ok(n) if n >= 1 => Ok(n),
        _ => Err(Failure::input(format!(
            "--history-every {} must be a whole number of steps, at least 1 (1 records every step)",
            a.history_every
        ))),
    }
}

/// A directory output (`--history`, `--vtk`): an existing directory, or a
/// new one made in an existing directory.
fn output_dir(option: &str, dir: &std::path::Path) -> Result<(), Failure> {
    let shown = dir.display();
    if dir.exists() && !dir.is_dir() {
        return Err(Failure::input(format!(
            "{option} {shown} is not a directory; give a directory (it is created if missing)"
        )));
    }
    if !dir.exists() {
        std::fs::create_dir(dir).map_err(|e| {
            Failure::input(format!(
                "cannot write {option} {shown}: cannot create the directory: {e}; give a \
                 directory in an existing, writable one"
            ))
        })?;
    }
    Ok(())
}

fn check_positive(name: &str, v: Option<f64>) -> Result<(), Failure> {
    match v {
        Some(x) if !(x.is_finite() && x > 0.0) => Err(Failure::input(format!(
            "{name} {x} must be a positive number of seconds"
        ))),
        _ => Ok(()),
    }
}

/// `--motor-speed [CABLE=]M_S` values: (cable index, speed), every cable
/// for a bare speed.
fn motor_speeds(sim: &Simulator, args: &[String]) -> Result<Vec<(usize, f64)>, String> {
    let cables = &sim.model().cables;
    let mut out = Vec::new();
    for a in args {
        let (name, speed) = match a.split_once('=') {
            Some((n, s)) => (Some(n.trim()), s.trim()),
            None => (None, a.trim()),
        };
        let speed: f64 = speed
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite())
            .ok_or_else(|| format!("--motor-speed {a}: `{speed}` is not a finite speed in m/s"))?;
        match name {
            Some(n) => {
                let ci = cables.iter().position(|c| c.name == n).ok_or_else(|| {
                    format!(
                        "--motor-speed {a}: the model has no cable `{n}` (its cables: {})",
                        cables
                            .iter()
                            .map(|c| c.name.as_str())
                            .collect::<Vec<_>>()
                            .join(", ")
                    )
                })?;
                out.push((ci, speed));
            }
            None if cables.is_empty() => {
                return Err(format!("--motor-speed {a}: the model has no cable"))
            }
            None => out.extend((0..cables.len()).map(|ci| (ci, speed))),
        }
    }
    Ok(out)
}

/// `--plot` and `--snapshots`: the joints' histories, kept in memory and
/// drawn after the run.
struct PlotHook<'a>(&'a mut plot::Recorder);

impl Recorder for PlotHook<'_> {
    fn after_step(&mut self, sim: &mut Simulator) -> Result<(), RecordError> {
        let s = sim.state();
        self.0.record(s.t_s, &s.x);
        Ok(())
    }
}

/// The progress bar on stderr.
struct ProgressHook<'a>(&'a ProgressBar);

impl Recorder for ProgressHook<'_> {
    fn after_checks(&mut self, sim: &mut Simulator) -> Result<(), RecordError> {
        let (m, s) = (sim.model(), sim.state());
        self.0.inc(1);
        if s.steps % 20 == 0 {
            self.0.set_message(format!(
                "{:.2} s, {}/{} locks",
                s.t_s,
                s.locks_engaged(m),
                m.locks.len()
            ));
        }
        Ok(())
    }
}

/// `--mcap` (issue 15): the node's topics recorded offline, one code path
/// with the node, written to a temporary sibling and renamed onto the target
/// once finished.
#[cfg(feature = "ros")]
struct McapRecorder {
    rec: Option<crate::node::record::OfflineRecording>,
    temp: PathBuf,
    target: PathBuf,
    stats: Option<crate::node::record::RecordStats>,
}

#[cfg(feature = "ros")]
impl McapRecorder {
    fn error(&self, e: String) -> RecordError {
        let e = e.replace(
            &self.temp.display().to_string(),
            &self.target.display().to_string(),
        );
        RecordError::other("--mcap", &self.target, e)
    }
}

#[cfg(feature = "ros")]
impl Recorder for McapRecorder {
    fn after_checks(&mut self, sim: &mut Simulator) -> Result<(), RecordError> {
        match self.rec.as_mut() {
            Some(r) => r.after_step(sim).map_err(|e| self.error(e)),
            None => Ok(()),
        }
    }
    fn finish(&mut self, sim: &mut Simulator, _stop: &run::Stop) -> Result<(), RecordError> {
        let Some(r) = self.rec.take() else {
            return Ok(());
        };
        let done = r.finish(sim).map_err(|e| self.error(e)).and_then(|st| {
            std::fs::rename(&self.temp, &self.target)
                .map(|_| st)
                .map_err(|e| RecordError::io("--mcap", &self.target, e))
        });
        match done {
            Ok(st) => {
                self.stats = Some(st);
                Ok(())
            }
            Err(e) => {
                let _ = std::fs::remove_file(&self.temp);
                Err(e)
            }
        }
    }
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
        ("--report", &a.report),
        ("--mcap", mcap_path),
    ]
    .into_iter()
    .filter_map(|(o, p)| p.as_deref().map(|p| (o, p)))
    .collect();
    let every = history_every(&a)?;
    // (a directory output: created when missing, its files checked as outputs)
    let history_files: Vec<PathBuf> = match &a.history {
        Some(d) => {
            output_dir("--history", d)?;
            history::TABLES
                .iter()
                .map(|t| history::table_path(d, t))
                .collect()
        }
        None => Vec::new(),
    };
    let vtk_files: Vec<PathBuf> = match &a.vtk {
        Some(d) => {
            output_dir("--vtk", d)?;
            vec![vtk::pvd_path(d), d.join(vtk::frame_name(0))]
        }
        None => Vec::new(),
    };
    let mut outputs = outputs;
    outputs.extend(history_files.iter().map(|p| ("--history", p.as_path())));
    outputs.extend(vtk_files.iter().map(|p| ("--vtk", p.as_path())));
    check_outputs(&[a.model.as_path()], &outputs)?;
    let dt = a.dt.unwrap_or(sim.model().dt_s);
    let until = a.until.unwrap_or(sim.model().end_time_s);
    let dt_from = if a.dt.is_some() { "--dt" } else { "dt_s" };
    run::check_step_count(dt, until, dt_from, &checks)
        .map_err(|m| Failure::input(format!("{}: {m}", a.model.display())))?;
    let speeds = motor_speeds(&sim, &a.motor_speed)
        .map_err(|m| Failure::input(format!("{}: {m}", a.model.display())))?;
    for &(ci, speed) in &speeds {
        sim.set_cable_speed(ci, Some(speed))
            .map_err(|e| Failure::input(format!("{}: --motor-speed: {e}", a.model.display())))?;
    }
    // A model that cannot deploy is refused when the run is to deploy it;
    // with --until (a run for a time) it is a warning. (Its drive is the
    // cable tension: a speed-controlled motor moves what it can move.)
    let cannot = if speeds.is_empty() {
        checks::cannot_deploy(sim.model(), sim.state())
    } else {
        None
    };
    if let Some(why) = cannot {
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
        Some(p) => Some(CsvRecorder::create(p).map_err(|e| Failure::input(e.to_string()))?),
        None => None,
    };
    let dof_initial = sim.state().mechanisms;
    #[cfg(feature = "ros")]
    let mut mcap = match &a.mcap {
        Some(p) => {
            let temp = super::output::temp_path(p, "part");
            match crate::node::record::OfflineRecording::start(&temp, &mut sim, a.mcap_rate) {
                Ok(r) => Some(McapRecorder {
                    rec: Some(r),
                    temp,
                    target: p.clone(),
                    stats: None,
                }),
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
    let limits = RunLimits {
        dt_s: dt,
        until_s: until,
        until_asked: a.until.is_some(),
        max_wall_s: a.max_wall_s,
        cancel: Some(interrupt::flag()),
    };
    let thin = Thinning { every };
    let mut hist = a
        .history
        .as_deref()
        .map(|d| history::HistoryRecorder::new(&sim, d, "--history", thin));
    let mut series = a
        .vtk
        .as_deref()
        .map(|d| vtk::VtkRecorder::new(&sim, d, thin));
    let mut html = a
        .report
        .as_deref()
        .map(|p| report::ReportRecorder::new(&sim, p, until, report::DEFAULT_FRAME_BUDGET));
    let mut bodies = crate::record::bodies::BodyRecorder::new(&sim);
    let (mut plot_hook, mut progress) = (PlotHook(&mut rec), ProgressHook(&bar));
    // (the order of the hooks: the files after each step, then the plots;
    // the MCAP recording and the progress bar after the checks)
    let mut recorders: Vec<&mut dyn Recorder> = Vec::new();
    if let Some(c) = csv.as_mut() {
        recorders.push(c);
    }
    if let Some(h) = hist.as_mut() {
        recorders.push(h);
    }
    if let Some(v) = series.as_mut() {
        recorders.push(v);
    }
    if let Some(r) = html.as_mut() {
        recorders.push(r);
    }
    if bodies.has_bodies() {
        recorders.push(&mut bodies);
    }
    recorders.push(&mut plot_hook);
    #[cfg(feature = "ros")]
    if let Some(m) = mcap.as_mut() {
        recorders.push(m);
    }
    recorders.push(&mut progress);
    let stop = run::run_loop(&mut sim, &checks, limits, &mut recorders);
    drop(recorders);
    bar.finish_and_clear();
    let wall = stop.wall_time_s;
    let (mut reason, mut message) = (stop.reason, stop.message);
    // Outputs: what was computed, whatever stopped the run. A failed write
    // turns a run that did what was asked into an error (exit 1; the
    // recorders' own are in the stop already).
    let mut write_errors: Vec<String> = stop.record_errors.iter().map(|e| e.to_string()).collect();
    #[cfg(feature = "ros")]
    if let Some(st) = mcap.as_ref().and_then(|m| m.stats.as_ref()) {
        say!(
            "mcap             {} messages, {} bytes: {}",
            st.messages,
            st.bytes,
            a.mcap.as_deref().expect("mcap path").display()
        );
    }
    if let Some((frames, bytes)) = html.as_ref().and_then(|r| r.written) {
        say!(
            "report           {frames} frames, {bytes} bytes: {}",
            a.report.as_deref().expect("report path").display()
        );
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
    let summary = run::summarize(
        &mut sim,
        &checks,
        &format!("{:?}", a.solver).to_lowercase(),
        dt,
        dof_initial,
        wall,
        reason,
        message.clone(),
    );
    let summary = bodies.complete(summary);
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
    // (the balance's other terms where they are not 0: gravity's work, and
    // what the backward-Euler steps gained beyond the forces' work)
    let mut other = String::new();
    for (name, j) in [
        ("gravity", s.energy.gravity_work_j),
        ("backward-Euler steps", s.energy.integrator_work_j),
    ] {
        if j != 0.0 {
            other += &format!(", {name} {j:.3e} J");
        }
    }
    say!(
        "energy           motor {:.6e} J, friction {:.3e} J, damping {:.3e} J, latches {:.6e} J, kinetic {:.6e} J, elastic {:.3e} J{other}; balance error {:.2e}",
        s.energy.motor_work_j, s.energy.friction_loss_j, s.energy.damping_loss_j + s.energy.member_damping_loss_j, s.energy.lock_loss_j + s.energy.latch_damping_loss_j, s.kinetic_energy_j, s.energy.latch_spring_energy_j + s.energy.element_spring_energy_j + s.energy.member_strain_energy_j, s.energy_balance_rel_error
    );
    for mo in &s.motors {
        if let Some(speed) = mo.speed_cmd_m_s {
            say!(
                "motor {:<10} {speed} m/s commanded, {}, tension {:.6e} N, reeled in {:.9} m",
                mo.cable,
                match mo.mode {
                    MotorHold::Tracking => "at that speed",
                    MotorHold::AtLimit => "held at its tension limit",
                    MotorHold::Slack => "slack (the structure ran ahead)",
                    MotorHold::Tension => "under tension control",
                },
                mo.tension_n,
                mo.reeled_in_m
            );
        }
    }
    say!(
        "mechanisms       {} at start, {} at end",
        s.dof_initial,
        s.dof_final
    );
    for b in &s.bodies {
        say!(
            "body `{}`     attitude change {:.6e} deg about [{:.4}, {:.4}, {:.4}], peak rate {:.6e} rad/s at t = {:.6} s, final rate {:.3e} rad/s",
            b.name, b.final_attitude_change_deg, b.final_rotation_axis[0], b.final_rotation_axis[1],
            b.final_rotation_axis[2], b.peak_rate_rad_s, b.peak_rate_time_s, b.final_rate_rad_s
        );
    }
    if let Some(p) = &s.momentum {
        say!(
            "momentum         drift linear {:.2e}, angular {:.2e} (of {:.4e} N s, {:.4e} N m s)",
            p.linear_drift_rel,
            p.angular_drift_rel,
            p.linear_scale_n_s,
            p.angular_scale_n_m_s
        );
        if p.held {
            say!(
                "                 held by the step: {} corrections took out {:.2e} (linear), {:.2e} (angular) of the scales, kinetic energy {:.2e} J",
                p.corrections,
                p.linear_removed_rel,
                p.angular_removed_rel,
                p.kinetic_change_j
            );
        }
    }
    if let Some(f) = s.first_frequency_hz {
        say!("first frequency  {f:.6e} Hz (deployed, latched: analyze --modes)");
    }
    let st = &s.solver_stats;
    say!(
        "solver           {} sub-steps ({} halvings), {} constraint solves ({} unconverged)",
        st.substeps,
        st.fallbacks.substep_halvings,
        st.solves,
        st.fallbacks.solve_unconverged
    );
    let accepted = st.accepting_fallbacks();
    if accepted > 0 {
        let kinds: Vec<String> = st
            .accepting_fallbacks_by_kind()
            .iter()
            .filter(|(_, n)| *n > 0)
            .map(|(kind, n)| format!("{n} {kind}"))
            .collect();
        say!(
            "rescued          {accepted} results accepted inexact: {} (docs/solver.md)",
            kinds.join(", ")
        );
    }
    if st.fallbacks.solve_unconverged * 10 > st.solves {
        // (the run's checks still hold: balance, |Phi|; what suffers is the time)
        say!(
            "                 more than a tenth of the solves did not converge: the constraints \
             are nearly redundant here (a configuration close to singular, such as a ring's \
             last bays near flat; `cargo run --release --example near_singular` on a restart, \
             docs/double_ring_stowing.md, \"The 36-sided ring's endgame is a near-singular \
             configuration\"), which is what makes such a run slow"
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
