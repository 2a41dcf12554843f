//! Validation and bookkeeping of `/truss/cable_force_cmd` and
//! `/truss/cable_speed_cmd` (pure, no DDS).

use super::msgs::{CableForceCommand, CableSpeedCommand};
use crate::solver::model::Model;
use std::time::{Duration, Instant};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fault {
    UnknownCable,
    MismatchedLengths,
    BadTension,
    BadSpeed,
}

impl Fault {
    pub fn label(self) -> &'static str {
        match self {
            Fault::UnknownCable => "unknown cable",
            Fault::MismatchedLengths => "mismatched array lengths",
            Fault::BadTension => "bad tension",
            Fault::BadSpeed => "bad speed",
        }
    }
}

/// The two command topics.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CmdTopic {
    Force,
    Speed,
}

impl CmdTopic {
    pub fn topic(self) -> &'static str {
        match self {
            CmdTopic::Force => "cable_force_cmd",
            CmdTopic::Speed => "cable_speed_cmd",
        }
    }
    pub fn type_name(self) -> &'static str {
        match self {
            CmdTopic::Force => "truss_deploy/msg/CableForceCommand",
            CmdTopic::Speed => "truss_deploy/msg/CableSpeedCommand",
        }
    }
}

/// One cable's command: a motor tension (N; ends speed control) or a
/// reel-in speed (m/s, negative pays out; starts speed control).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CableCmd {
    Tension(f64),
    Speed(f64),
}

/// Every name known and equal array lengths; the cable indices.
fn cables(
    names: &[String],
    n_values: usize,
    what: &str,
    model: &Model,
) -> Result<Vec<usize>, (Fault, String)> {
    if names.len() != n_values {
        return Err((
            Fault::MismatchedLengths,
            format!("{} names but {n_values} {what}", names.len()),
        ));
    }
    names
        .iter()
        .map(|name| {
            model.cable_index(name).ok_or_else(|| {
                let known: Vec<&str> = model.cables.iter().map(|c| c.name.as_str()).collect();
                (
                    Fault::UnknownCable,
                    format!("no cable `{name}` (known: {})", known.join(", ")),
                )
            })
        })
        .collect()
}

/// Checks a command whole: every name known, equal array lengths, every tension
/// finite, >= 0 and <= the cable's `max_tension_n`. Returns (cable index, tension).
pub fn validate(
    cmd: &CableForceCommand,
    model: &Model,
) -> Result<Vec<(usize, f64)>, (Fault, String)> {
    let idx = cables(&cmd.names, cmd.tensions_n.len(), "tensions", model)?;
    let mut out = Vec::with_capacity(idx.len());
    for (c, &t) in idx.into_iter().zip(&cmd.tensions_n) {
        let max = model.cables[c].max_tension_n;
        if !(t.is_finite() && t >= 0.0 && t <= max) {
            return Err((
                Fault::BadTension,
                format!(
                    "tension {t} N for cable `{}` must be finite, >= 0 and <= {max} N",
                    model.cables[c].name
                ),
            ));
        }
        out.push((c, t));
    }
    Ok(out)
}

/// Checks a speed command whole: every name known, equal array lengths,
/// every speed finite with |speed| <= `max_speed_m_s`, every named cable
/// massless (the solver's speed control takes only those). Returns (cable
/// index, speed).
pub fn validate_speed(
    cmd: &CableSpeedCommand,
    model: &Model,
    max_speed_m_s: f64,
) -> Result<Vec<(usize, f64)>, (Fault, String)> {
    let idx = cables(&cmd.names, cmd.speeds_m_s.len(), "speeds", model)?;
    let mut out = Vec::with_capacity(idx.len());
    for (c, &s) in idx.into_iter().zip(&cmd.speeds_m_s) {
        let cable = &model.cables[c];
        if !(s.is_finite() && s.abs() <= max_speed_m_s) {
            return Err((
                Fault::BadSpeed,
                format!(
                    "speed {s} m/s for cable `{}` must be finite and at most {max_speed_m_s} m/s \
                     in magnitude (parameter max_speed_m_s)",
                    cable.name
                ),
            ));
        }
        if cable.line_density_kg_per_m > 0.0 {
            return Err((
                Fault::BadSpeed,
                format!(
                    "cable `{}` has a line density: speed control takes massless cables",
                    cable.name
                ),
            ));
        }
        out.push((c, s));
    }
    Ok(out)
}

/// At most one log line about undecodable command samples per this period.
pub const MALFORMED_LOG_PERIOD: Duration = Duration::from_secs(10);

/// Counters and the "log once per kind" memory.
#[derive(Clone, Debug, Default)]
pub struct CommandBook {
    pub accepted: u32,
    pub rejected: u32,
    pub unknown_cable: u32,
    pub mismatched_lengths: u32,
    pub bad_tension: u32,
    pub bad_speed: u32,
    /// Samples on either topic that could not be decoded as its type.
    pub malformed: u32,
    /// Per topic and kind of fault: logged already.
    logged: [[bool; 4]; 2],
    malformed_logged_at: Option<Instant>,
    malformed_unlogged: u32,
}

impl CommandBook {
    /// Counts a command sample that could not be decoded (`why`: the decoder's
    /// reason). Returns a log line for the first one and then at most one per
    /// [`MALFORMED_LOG_PERIOD`], giving the number since the last line, so a
    /// flood of them neither goes unnoticed nor floods the log.
    pub fn malformed(&mut self, topic: CmdTopic, why: &str, now: Instant) -> Option<String> {
        self.malformed = self.malformed.saturating_add(1);
        self.malformed_unlogged = self.malformed_unlogged.saturating_add(1);
        if self
            .malformed_logged_at
            .is_some_and(|t| now.duration_since(t) < MALFORMED_LOG_PERIOD)
        {
            return None;
        }
        let n = std::mem::take(&mut self.malformed_unlogged);
        let first = self.malformed_logged_at.is_none();
        self.malformed_logged_at = Some(now);
        Some(if first {
            format!(
                "{} sample not decodable as {} ({why}); skipped, reading goes on. Counted in \
                 lock_status rejected_malformed; logged at most once per {} s.",
                topic.topic(),
                topic.type_name(),
                MALFORMED_LOG_PERIOD.as_secs()
            )
        } else {
            format!(
                "{n} more undecodable command samples (last: {} {why}); {} in all",
                topic.topic(),
                self.malformed
            )
        })
    }

    /// Validates a force command; on a fault counts it and returns the log
    /// line the first time this kind of fault is seen on this topic (None
    /// afterwards).
    pub fn check(
        &mut self,
        cmd: &CableForceCommand,
        model: &Model,
    ) -> (Option<Vec<(usize, f64)>>, Option<String>) {
        let r = validate(cmd, model);
        self.book(CmdTopic::Force, r)
    }

    /// [`Self::check`] for a speed command, speeds limited to `max_speed_m_s`.
    pub fn check_speed(
        &mut self,
        cmd: &CableSpeedCommand,
        model: &Model,
        max_speed_m_s: f64,
    ) -> (Option<Vec<(usize, f64)>>, Option<String>) {
        let r = validate_speed(cmd, model, max_speed_m_s);
        self.book(CmdTopic::Speed, r)
    }

    fn book(
        &mut self,
        topic: CmdTopic,
        r: Result<Vec<(usize, f64)>, (Fault, String)>,
    ) -> (Option<Vec<(usize, f64)>>, Option<String>) {
        match r {
            Ok(v) => {
                self.accepted = self.accepted.saturating_add(1);
                (Some(v), None)
            }
            Err((fault, why)) => {
                self.rejected = self.rejected.saturating_add(1);
                let (count, slot) = match fault {
                    Fault::UnknownCable => (&mut self.unknown_cable, 0),
                    Fault::MismatchedLengths => (&mut self.mismatched_lengths, 1),
                    Fault::BadTension => (&mut self.bad_tension, 2),
                    Fault::BadSpeed => (&mut self.bad_speed, 3),
                };
                *count = count.saturating_add(1);
                let logged = &mut self.logged[topic as usize][slot];
                let log = if *logged {
                    None
                } else {
                    *logged = true;
                    Some(format!(
                        "rejected {} ({}): {why}; the last good command stays. \
                         Further {} rejections are counted in lock_status, not logged.",
                        topic.topic(),
                        fault.label(),
                        fault.label()
                    ))
                };
                (None, log)
            }
        }
    }
}

/// A tick's merged commands: (cable, command) in arrival order, the first
/// command's source stamp (ns since the Unix epoch, 0 if none) and take time.
pub type Taken = (Vec<(usize, CableCmd)>, i64, Instant);

/// The valid commands taken in one tick, merged in arrival order: a later
/// command for a cable replaces an earlier one's (a tension ends its speed
/// control, a speed starts it), and cables no command names keep theirs (two
/// partial commands for different cables both apply). Keeps the source stamp
/// and take time of the first, for `--timing`.
#[derive(Debug, Default)]
pub struct Pending {
    cmds: Vec<(usize, CableCmd)>,
    first: Option<(i64, Instant)>,
}

impl Pending {
    /// A force command's (cable, tension) list.
    pub fn add(&mut self, tensions: Vec<(usize, f64)>, src_ns: i64, taken: Instant) {
        self.cmds
            .extend(tensions.into_iter().map(|(c, t)| (c, CableCmd::Tension(t))));
        self.first.get_or_insert((src_ns, taken));
    }

    /// A speed command's (cable, speed) list.
    pub fn add_speeds(&mut self, speeds: Vec<(usize, f64)>, src_ns: i64, taken: Instant) {
        self.cmds
            .extend(speeds.into_iter().map(|(c, s)| (c, CableCmd::Speed(s))));
        self.first.get_or_insert((src_ns, taken));
    }

    /// (cable, command) in arrival order, to be applied in that order, with
    /// the first command's source stamp and take time; None if nothing came.
    pub fn take(&mut self) -> Option<Taken> {
        let (src, taken) = self.first.take()?;
        Some((std::mem::take(&mut self.cmds), src, taken))
    }
}

/// Applies one merged command to the simulator.
pub fn apply(
    sim: &mut crate::solver::Simulator,
    cable: usize,
    cmd: CableCmd,
) -> Result<(), crate::solver::SolverError> {
    match cmd {
        CableCmd::Tension(t) => sim.set_cable_tension(cable, t),
        CableCmd::Speed(s) => sim.set_cable_speed(cable, Some(s)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bundled sail (two drive cables).
    fn sail_sim() -> crate::solver::Simulator {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/sail_array.toml");
        let model = crate::model::load(std::path::Path::new(path))
            .unwrap()
            .model;
        crate::solver::Simulator::new(model, crate::solver::Options::default()).unwrap()
    }

    /// Two partial commands for the sail's two cables taken in one tick both
    /// apply, with a third one for the first cable overriding the first.
    #[test]
    fn partial_commands_in_one_tick_merge_in_order() {
        let mut sim = sail_sim();
        let mut book = CommandBook::default();
        let mut pending = Pending::default();
        let t0 = Instant::now();
        for (k, (name, t)) in [("drive_A", 3.0), ("drive_B", 4.0), ("drive_A", 5.0)]
            .into_iter()
            .enumerate()
        {
            let cmd = CableForceCommand {
                names: vec![name.into()],
                tensions_n: vec![t],
            };
            let (ok, log) = book.check(&cmd, sim.model());
            assert!(log.is_none());
            pending.add(ok.unwrap(), 100 + k as i64, t0);
        }
        let (merged, src, _) = pending.take().unwrap();
        assert_eq!(src, 100, "the first command's stamp");
        for (c, cmd) in merged {
            apply(&mut sim, c, cmd).unwrap();
        }
        let m = sim.model();
        let (a, b) = (
            m.cable_index("drive_A").unwrap(),
            m.cable_index("drive_B").unwrap(),
        );
        let cmd = &sim.state().cable_tension_cmd_n;
        assert_eq!(cmd[a], 5.0, "the later command for drive_A wins");
        assert_eq!(cmd[b], 4.0, "drive_B's partial command applies too");
        assert!(pending.take().is_none(), "taken once");
        assert_eq!(book.accepted, 3);
    }

    /// Force and speed commands for the sail's two cables in one tick apply in
    /// arrival order: a tension after a speed ends that cable's speed control,
    /// a speed after a tension starts it. Bad speed commands are rejected
    /// whole and counted by kind, logged once per kind.
    #[test]
    fn speed_and_force_commands_merge_in_order_and_bad_speeds_are_rejected() {
        use crate::solver::state::MotorHold;
        let mut sim = sail_sim();
        let mut book = CommandBook::default();
        let mut pending = Pending::default();
        let t0 = Instant::now();
        let speed = |n: &str, s: f64| CableSpeedCommand {
            names: vec![n.into()],
            speeds_m_s: vec![s],
        };
        let force = |n: &str, t: f64| CableForceCommand {
            names: vec![n.into()],
            tensions_n: vec![t],
        };
        let (ok, _) = book.check_speed(&speed("drive_A", 0.01), sim.model(), 1.0);
        pending.add_speeds(ok.unwrap(), 1, t0);
        let (ok, _) = book.check(&force("drive_B", 4.0), sim.model());
        pending.add(ok.unwrap(), 2, t0);
        let (ok, _) = book.check(&force("drive_A", 5.0), sim.model());
        pending.add(ok.unwrap(), 3, t0);
        let (ok, _) = book.check_speed(&speed("drive_B", -0.02), sim.model(), 1.0);
        pending.add_speeds(ok.unwrap(), 4, t0);
        let (merged, src, _) = pending.take().unwrap();
        assert_eq!(src, 1);
        assert_eq!(merged.len(), 4);
        for (c, cmd) in merged {
            apply(&mut sim, c, cmd).unwrap();
        }
        let m = sim.model();
        let (a, b) = (
            m.cable_index("drive_A").unwrap(),
            m.cable_index("drive_B").unwrap(),
        );
        let s = sim.state();
        assert_eq!(s.motors[a].speed_cmd_m_s, None, "the later tension wins");
        assert_eq!(s.motors[a].hold, MotorHold::Tension);
        assert_eq!(s.cable_tension_cmd_n[a], 5.0);
        assert_eq!(
            s.motors[b].speed_cmd_m_s,
            Some(-0.02),
            "the later speed wins"
        );
        assert_ne!(s.motors[b].hold, MotorHold::Tension);
        assert_eq!(book.accepted, 4);

        let mut logs = Vec::new();
        for cmd in [
            speed("drive_A", f64::NAN),
            speed("drive_A", 1.5),
            speed("drive_A", -1.5),
            speed("nope", 0.01),
            CableSpeedCommand {
                names: vec!["drive_A".into()],
                speeds_m_s: vec![0.01, 0.02],
            },
        ] {
            let (ok, log) = book.check_speed(&cmd, sim.model(), 1.0);
            assert!(ok.is_none(), "{cmd:?} rejected");
            logs.extend(log);
        }
        assert_eq!(
            (
                book.rejected,
                book.bad_speed,
                book.unknown_cable,
                book.mismatched_lengths
            ),
            (5, 3, 1, 1)
        );
        assert_eq!(logs.len(), 3, "once per kind: {logs:?}");
        assert!(logs[0].contains("cable_speed_cmd") && logs[0].contains("max_speed_m_s"));
        // (the unknown-cable kind on the force topic is logged on its own)
        let (_, log) = book.check(&force("nope", 1.0), sim.model());
        assert!(log.is_some_and(|l| l.contains("cable_force_cmd")));
    }

    /// 10,000 undecodable samples in one second give one log line; the next
    /// one after the period gives a second line that counts those in between.
    #[test]
    fn malformed_samples_are_counted_and_their_log_rate_limited() {
        let mut b = CommandBook::default();
        let t0 = Instant::now();
        let mut lines = Vec::new();
        for k in 0..10_000u64 {
            let now = t0 + Duration::from_micros(100 * k);
            lines.extend(b.malformed(CmdTopic::Force, "eof", now));
        }
        assert_eq!(b.malformed, 10_000);
        assert_eq!(lines.len(), 1, "{lines:?}");
        let later = b.malformed(
            CmdTopic::Force,
            "eof",
            t0 + MALFORMED_LOG_PERIOD + Duration::from_secs(1),
        );
        let line = later.expect("a line after the period");
        assert!(line.starts_with("10000 more"), "{line}");
        assert_eq!(b.malformed, 10_001);
        assert_eq!(b.rejected, 0, "malformed samples are not rejected commands");
    }
}
