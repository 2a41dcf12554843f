//! `truss-deploy simulate`: offline run to full deployment.

use super::{make_simulator, plot, write_json, Failure, SolverArg};
use crate::solver::{Energy, LockEvent, Simulator};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;
use std::io::{BufWriter, Write};
use std::path::PathBuf;
use std::time::Instant;

#[derive(Args, Debug)]
pub struct SimulateArgs {
    model: PathBuf,
    /// Time step (s); default: the model's `dt_s`.
    #[arg(long, allow_negative_numbers = true)]
    dt: Option<f64>,
    /// Stop at this simulation time (s) even if not deployed; default: the model's `end_time_s`.
    #[arg(long, allow_negative_numbers = true)]
    until: Option<f64>,
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
    #[arg(long, value_enum, default_value_t = SolverArg::Sparse)]
    solver: SolverArg,
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
    /// Set when the run stopped on an error; everything above is what was computed until then.
    pub error: Option<String>,
}

fn check_positive(name: &str, v: Option<f64>) -> Result<(), Failure> {
    match v {
        Some(x) if !(x.is_finite() && x > 0.0) => Err(Failure::input(format!(
            "{name} {x} must be a positive number of seconds"
        ))),
        _ => Ok(()),
    }
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
    let mut sim = make_simulator(&a.model, a.solver.into())?;
    let dt = a.dt.unwrap_or(sim.model().dt_s);
    let until = a.until.unwrap_or(sim.model().end_time_s);
    let mut rec = plot::Recorder::new(
        sim.model(),
        a.plot.as_deref(),
        &a.joints,
        a.snapshots.as_deref(),
    )
    .map_err(Failure::input)?;
    if let Some(p) = &a.latch_plot {
        plot::check_writable(p).map_err(Failure::input)?;
    }
    rec.record(sim.state().t_s, &sim.state().x);
    let mut csv = match &a.csv {
        Some(p) => {
            let f = std::fs::File::create(p)
                .map_err(|e| Failure::input(format!("cannot write {}: {e}", p.display())))?;
            let mut w = BufWriter::new(f);
            writeln!(w, "{}", csv_header(&sim)).map_err(|e| Failure::run(e.to_string()))?;
            csv_row(&mut w, &sim).map_err(|e| Failure::run(e.to_string()))?;
            Some(w)
        }
        None => None,
    };
    let dof_initial = sim.state().mechanisms;
    let bar = ProgressBar::new((until / dt).ceil() as u64);
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} t = {msg} [{bar:30}] {pos}/{len} steps, {elapsed} elapsed",
        )
        .expect("valid template")
        .progress_chars("=> "),
    );
    let start = Instant::now();
    let mut error = None;
    while !sim.state().deployed && sim.state().t_s < until - 1e-9 * dt {
        let h = dt.min(until - sim.state().t_s);
        if let Err(e) = sim.step(h) {
            error = Some(format!("at t = {:.6} s: {e}", sim.state().t_s));
            break;
        }
        if let Some(w) = csv.as_mut() {
            csv_row(w, &sim).map_err(|e| Failure::run(e.to_string()))?;
        }
        rec.record(sim.state().t_s, &sim.state().x);
        bar.inc(1);
        if sim.state().steps % 20 == 0 {
            bar.set_message(format!(
                "{:.2} s, {}/{} locks",
                sim.state().t_s,
                sim.state().locks_engaged(sim.model()),
                sim.model().locks.len()
            ));
        }
    }
    bar.finish_and_clear();
    let wall = start.elapsed().as_secs_f64();
    if let Some(mut w) = csv {
        w.flush().map_err(|e| Failure::run(e.to_string()))?;
    }
    let (m, s) = (sim.model(), sim.state());
    let ke = s.kinetic_energy_j(m);
    let summary = SimulateJson {
        model: m.name.clone(),
        solver: format!("{:?}", a.solver).to_lowercase(),
        dt_s: dt,
        deployed: s.deployed,
        deploy_time_s: s.deploy_time_s,
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
        error: error.clone(),
    };
    print_summary(&summary);
    if let Some(j) = &a.json {
        write_json(j, &summary)?;
    }
    let locks: Vec<(String, f64)> = s.locks.iter().map(|l| (l.name.clone(), l.time_s)).collect();
    if let Err(e) = rec.finish(m, &locks) {
        match &error {
            Some(_) => eprintln!("error: {e}"),
            None => return Err(Failure::run(e)),
        }
    }
    if let Some(p) = &a.latch_plot {
        let sleeves: Vec<String> = m
            .locks
            .iter()
            .map(|&e| m.elements[e].name().to_string())
            .collect();
        if let Err(e) = plot::latch_plot(p, &format!("{}: latches", m.name), &sleeves, &s.locks) {
            match &error {
                Some(_) => eprintln!("error: {e}"),
                None => return Err(Failure::run(e)),
            }
        }
    }
    match error {
        Some(e) => Err(Failure::run(e)),
        None => Ok(()),
    }
}

fn print_summary(s: &SimulateJson) {
    say!("model            {}", s.model);
    match s.deploy_time_s {
        Some(t) if s.deployed => say!("deployed         yes, at t = {t:.6} s"),
        _ => say!("deployed         no (stopped at t = {:.3} s)", s.time_s),
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
        "energy           motor {:.6e} J, friction {:.3e} J, damping {:.3e} J, latches {:.6e} J, kinetic {:.6e} J; balance error {:.2e}",
        s.energy.motor_work_j, s.energy.friction_loss_j, s.energy.damping_loss_j, s.energy.lock_loss_j, s.kinetic_energy_j, s.energy_balance_rel_error
    );
    say!(
        "mechanisms       {} at start, {} at end",
        s.dof_initial,
        s.dof_final
    );
    if !s.locks.is_empty() {
        say!(
            "\n{:<16} {:>14} {:>14} {:>16} {:>14}",
            "lock",
            "time_s",
            "impulse_ns",
            "energy_lost_j",
            "speed_m_s"
        );
        for l in &s.locks {
            say!(
                "{:<16} {:>14.6} {:>14.6e} {:>16.6e} {:>14.6e}",
                l.name,
                l.time_s,
                l.impulse_ns,
                l.energy_lost_j,
                l.closing_speed_m_s
            );
        }
    }
}
