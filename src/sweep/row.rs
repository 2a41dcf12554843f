//! One row of a sweep: a sample's parameters and what its run gave, whatever
//! happened (an invalid model, a panic, a wall limit are rows too).

use crate::run::{self, RunLimits, RunSummary};
use crate::solver::{Options, Simulator};
use serde::{Deserialize, Serialize};

/// JSON has no NaN: serde_json writes it as null; these read null back as
/// NaN (a `panic` row's parameters, a latch of a run that went wrong), so
/// that every row written can be read again.
mod null_is_nan {
    use serde::{Deserialize, Deserializer};
    pub fn one<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
        Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
    }
    pub fn many<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<f64>, D::Error> {
        Ok(Vec::<Option<f64>>::deserialize(d)?
            .into_iter()
            .map(|v| v.unwrap_or(f64::NAN))
            .collect())
    }
}

/// A latch of a sample's run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LatchRow {
    pub name: String,
    #[serde(deserialize_with = "null_is_nan::one")]
    pub time_s: f64,
    #[serde(deserialize_with = "null_is_nan::one")]
    pub impulse_ns: f64,
    #[serde(deserialize_with = "null_is_nan::one")]
    pub energy_lost_j: f64,
    /// Compliant latches: the largest force (N); None for a rigid latch.
    pub peak_force_n: Option<f64>,
    pub time_of_peak_s: Option<f64>,
}

/// A sample's row (the Parquet schema in docs/sweeps.md).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Row {
    pub index: u64,
    pub seed: u64,
    /// The parameter values, in the sweep file's order.
    #[serde(deserialize_with = "null_is_nan::many")]
    pub params: Vec<f64>,
    /// deployed, until, end_time, stalled, error (a failed step or check,
    /// the wall limit), invalid (the model could not be made or run), panic.
    pub stop_reason: String,
    pub stop_message: String,
    pub deployed: bool,
    pub deploy_time_s: Option<f64>,
    pub time_s: Option<f64>,
    pub steps: Option<u64>,
    #[serde(deserialize_with = "null_is_nan::one")]
    pub wall_time_s: f64,
    pub final_error_rel: Option<f64>,
    pub max_constraint_violation_m: Option<f64>,
    pub energy_balance_rel_error: Option<f64>,
    pub kinetic_energy_j: Option<f64>,
    pub motor_work_j: Option<f64>,
    pub friction_loss_j: Option<f64>,
    pub damping_loss_j: Option<f64>,
    pub lock_loss_j: Option<f64>,
    pub latch_damping_loss_j: Option<f64>,
    pub substeps: Option<u64>,
    pub newmark_iterations: Option<u64>,
    pub factorizations: Option<u64>,
    pub solves: Option<u64>,
    pub substep_halvings: Option<u64>,
    pub solve_unconverged: Option<u64>,
    /// Results accepted by a fallback that knows them inexact
    /// (`SolverStats::accepting_fallbacks`).
    pub accepting_fallbacks: Option<u64>,
    /// The latches in the order they happened.
    pub latches: Vec<LatchRow>,
    /// The largest latch impulse (N s) and peak force (N; compliant latches).
    pub max_latch_impulse_ns: Option<f64>,
    pub max_latch_peak_force_n: Option<f64>,
    /// The sleeve that latched last.
    pub last_latch: Option<String>,
    /// The deployed truss's first natural frequency (Hz; `RunSummary::first_frequency_hz`).
    pub first_frequency_hz: Option<f64>,
    /// The first rigid body's (a spacecraft bus) peak angular rate (rad/s)
    /// and final attitude change (deg), and the system's angular momentum
    /// drift (`RunSummary::bodies`, `momentum`); null without a rigid body.
    pub bus_peak_rate_rad_s: Option<f64>,
    pub bus_attitude_change_deg: Option<f64>,
    pub angular_momentum_drift_rel: Option<f64>,
}

/// Stop reasons of rows that ran as asked (the sweep's exit status 0).
pub fn ran_as_asked(stop_reason: &str) -> bool {
    matches!(stop_reason, "deployed" | "until" | "end_time" | "stalled")
}

impl Row {
    /// A row with no run: the model could not be made or run, or it panicked.
    pub fn failed(index: u64, seed: u64, params: Vec<f64>, reason: &str, message: String) -> Row {
        Row {
            index,
            seed,
            params,
            stop_reason: reason.into(),
            stop_message: message,
            deployed: false,
            deploy_time_s: None,
            time_s: None,
            steps: None,
            wall_time_s: 0.0,
            final_error_rel: None,
            max_constraint_violation_m: None,
            energy_balance_rel_error: None,
            kinetic_energy_j: None,
            motor_work_j: None,
            friction_loss_j: None,
            damping_loss_j: None,
            lock_loss_j: None,
            latch_damping_loss_j: None,
            substeps: None,
            newmark_iterations: None,
            factorizations: None,
            solves: None,
            substep_halvings: None,
            solve_unconverged: None,
            accepting_fallbacks: None,
            latches: Vec::new(),
            max_latch_impulse_ns: None,
            max_latch_peak_force_n: None,
            last_latch: None,
            first_frequency_hz: None,
            bus_peak_rate_rad_s: None,
            bus_attitude_change_deg: None,
            angular_momentum_drift_rel: None,
        }
    }

    fn from_summary(index: u64, seed: u64, params: Vec<f64>, s: &RunSummary) -> Row {
        let latches: Vec<LatchRow> = s
            .locks
            .iter()
            .map(|l| LatchRow {
                name: l.name.clone(),
                time_s: l.time_s,
                impulse_ns: l.impulse_ns,
                energy_lost_j: l.energy_lost_j,
                peak_force_n: l.peak_force_n,
                time_of_peak_s: l.time_of_peak_s,
            })
            .collect();
        let max = |f: fn(&LatchRow) -> Option<f64>| {
            latches.iter().filter_map(f).max_by(|a, b| a.total_cmp(b))
        };
        let st = &s.solver_stats;
        Row {
            index,
            seed,
            params,
            stop_reason: s.stop_reason.label().into(),
            stop_message: s.stop_message.clone(),
            deployed: s.deployed,
            deploy_time_s: s.deploy_time_s,
            time_s: Some(s.time_s),
            steps: Some(s.steps),
            wall_time_s: s.wall_time_s,
            final_error_rel: s.final_error_rel,
            max_constraint_violation_m: Some(s.max_constraint_violation_m),
            energy_balance_rel_error: Some(s.energy_balance_rel_error),
            kinetic_energy_j: Some(s.kinetic_energy_j),
            motor_work_j: Some(s.energy.motor_work_j),
            friction_loss_j: Some(s.energy.friction_loss_j),
            damping_loss_j: Some(s.energy.damping_loss_j),
            lock_loss_j: Some(s.energy.lock_loss_j),
            latch_damping_loss_j: Some(s.energy.latch_damping_loss_j),
            substeps: Some(st.substeps),
            newmark_iterations: Some(st.newmark_iterations),
            factorizations: Some(st.factorizations),
            solves: Some(st.solves),
            substep_halvings: Some(st.fallbacks.substep_halvings),
            solve_unconverged: Some(st.fallbacks.solve_unconverged),
            accepting_fallbacks: Some(st.accepting_fallbacks()),
            max_latch_impulse_ns: max(|l| Some(l.impulse_ns)),
            max_latch_peak_force_n: max(|l| l.peak_force_n),
            last_latch: latches
                .iter()
                .max_by(|a, b| a.time_s.total_cmp(&b.time_s))
                .map(|l| l.name.clone()),
            latches,
            first_frequency_hz: s.first_frequency_hz,
            bus_peak_rate_rad_s: s.bodies.first().map(|b| b.peak_rate_rad_s),
            bus_attitude_change_deg: s.bodies.first().map(|b| b.final_attitude_change_deg),
            angular_momentum_drift_rel: s.momentum.as_ref().map(|m| m.angular_drift_rel),
        }
    }

    /// The largest latch load: the peak force of compliant latches (N),
    /// else the impulse of rigid ones (N s).
    pub fn largest_latch_load(&self) -> Option<f64> {
        self.max_latch_peak_force_n.or(self.max_latch_impulse_ns)
    }

    /// The row with its wall time zeroed (rows compare equal apart from it).
    pub fn without_wall_time(&self) -> Row {
        Row {
            wall_time_s: 0.0,
            ..self.clone()
        }
    }
}

/// Runs a model's text as `simulate` runs a model file (its `dt_s` and
/// `end_time_s`, the run checks of its `[checks]`), stopping after
/// `max_wall_s` of wall time; the row of sample `index`.
pub fn run_model(
    index: u64,
    seed: u64,
    params: Vec<f64>,
    text: &str,
    max_wall_s: Option<f64>,
) -> Row {
    run_model_recorded(index, seed, params, text, max_wall_s, None)
}

/// As [`run_model`], writing the run's history (every step) into `history`
/// when given (`[sweep] history`); a history that cannot be written makes
/// the row an error naming its path.
pub fn run_model_recorded(
    index: u64,
    seed: u64,
    params: Vec<f64>,
    text: &str,
    max_wall_s: Option<f64>,
    history: Option<&std::path::Path>,
) -> Row {
    let start = std::time::Instant::now();
    let fail = |reason: &str, m: String, params: Vec<f64>| Row {
        wall_time_s: start.elapsed().as_secs_f64(),
        ..Row::failed(index, seed, params, reason, m)
    };
    let loaded = match crate::model::parse(text, &format!("sample {index}")) {
        Ok(l) => l,
        Err(e) => return fail("invalid", e.to_string(), params),
    };
    let checks = loaded.checks;
    let mut sim = match Simulator::new(loaded.model, Options::default()) {
        Ok(s) => s,
        Err(e) => return fail("invalid", format!("sample {index}: {e}"), params),
    };
    let dt = sim.model().dt_s;
    let until = sim.model().end_time_s;
    if let Err(m) = run::check_step_count(dt, until, "dt_s", &checks) {
        return fail("invalid", format!("sample {index}: {m}"), params);
    }
    if let Some(why) = crate::solver::checks::cannot_deploy(sim.model(), sim.state()) {
        return fail(
            "invalid",
            format!("sample {index}: the model cannot deploy: {why}"),
            params,
        );
    }
    let dof_initial = sim.state().mechanisms;
    let limits = RunLimits {
        dt_s: dt,
        until_s: until,
        until_asked: false,
        max_wall_s,
        cancel: None,
    };
    let mut recorder = match history {
        Some(dir) => {
            if let Err(e) = std::fs::create_dir_all(dir) {
                return fail(
                    "error",
                    format!(
                        "sample {index}: cannot write [sweep] history {}: {e}",
                        dir.display()
                    ),
                    params,
                );
            }
            Some(crate::history::HistoryRecorder::new(
                &sim,
                dir,
                "[sweep] history",
                truss_deploy_core::record::Thinning { every: 1 },
            ))
        }
        None => None,
    };
    let mut bodies = truss_deploy_core::record::bodies::BodyRecorder::new(&sim);
    let mut recorders: Vec<&mut dyn truss_deploy_core::record::Recorder> = Vec::new();
    if let Some(r) = recorder.as_mut() {
        recorders.push(r);
    }
    if bodies.has_bodies() {
        recorders.push(&mut bodies);
    }
    let stop = run::run_loop(&mut sim, &checks, limits, &mut recorders);
    let summary = run::summarize(
        &mut sim,
        &checks,
        "sparse",
        dt,
        dof_initial,
        stop.wall_time_s,
        stop.reason,
        stop.message,
    );
    let summary = bodies.complete(summary);
    Row {
        wall_time_s: start.elapsed().as_secs_f64(),
        ..Row::from_summary(index, seed, params, &summary)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_panic_row_with_nan_parameters_reads_back() {
        let r = Row::failed(3, 9, vec![f64::NAN, 1.5], "panic", "boom".into());
        let back: Row = serde_json::from_str(&serde_json::to_string(&r).unwrap()).unwrap();
        assert!(back.params[0].is_nan());
        assert_eq!(back.params[1], 1.5);
        assert_eq!(
            (back.index, back.seed, back.stop_reason.as_str()),
            (3, 9, "panic")
        );
    }
}
