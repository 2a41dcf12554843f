//! Validation and bookkeeping of `/truss/cable_force_cmd` (pure, no DDS).

use super::msgs::CableForceCommand;
use crate::solver::model::Model;
use std::time::{Duration, Instant};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fault {
    UnknownCable,
    MismatchedLengths,
    BadTension,
}

impl Fault {
    pub fn label(self) -> &'static str {
        match self {
            Fault::UnknownCable => "unknown cable",
            Fault::MismatchedLengths => "mismatched array lengths",
            Fault::BadTension => "bad tension",
        }
    }
}

/// Checks a command whole: every name known, equal array lengths, every tension
/// finite, >= 0 and <= the cable's `max_tension_n`. Returns (cable index, tension).
pub fn validate(
    cmd: &CableForceCommand,
    model: &Model,
) -> Result<Vec<(usize, f64)>, (Fault, String)> {
    if cmd.names.len() != cmd.tensions_n.len() {
        return Err((
            Fault::MismatchedLengths,
            format!(
                "{} names but {} tensions",
                cmd.names.len(),
                cmd.tensions_n.len()
            ),
        ));
    }
    let mut out = Vec::with_capacity(cmd.names.len());
    for (name, &t) in cmd.names.iter().zip(&cmd.tensions_n) {
        let Some(c) = model.cable_index(name) else {
            let known: Vec<&str> = model.cables.iter().map(|c| c.name.as_str()).collect();
            return Err((
                Fault::UnknownCable,
                format!("no cable `{name}` (known: {})", known.join(", ")),
            ));
        };
        let max = model.cables[c].max_tension_n;
        if !(t.is_finite() && t >= 0.0 && t <= max) {
            return Err((
                Fault::BadTension,
                format!("tension {t} N for cable `{name}` must be finite, >= 0 and <= {max} N"),
            ));
        }
        out.push((c, t));
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
    /// Samples that could not be decoded as a CableForceCommand.
    pub malformed: u32,
    logged: [bool; 3],
    malformed_logged_at: Option<Instant>,
    malformed_unlogged: u32,
}

impl CommandBook {
    /// Counts a command sample that could not be decoded (`why`: the decoder's
    /// reason). Returns a log line for the first one and then at most one per
    /// [`MALFORMED_LOG_PERIOD`], giving the number since the last line, so a
    /// flood of them neither goes unnoticed nor floods the log.
    pub fn malformed(&mut self, why: &str, now: Instant) -> Option<String> {
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
                "cable_force_cmd sample not decodable as truss_deploy/msg/CableForceCommand ({why}); \
                 skipped, reading goes on. Counted in lock_status rejected_malformed; logged at most \
                 once per {} s.",
                MALFORMED_LOG_PERIOD.as_secs()
            )
        } else {
            format!(
                "{n} more undecodable cable_force_cmd samples (last: {why}); {} in all",
                self.malformed
            )
        })
    }

    /// Validates; on a fault counts it and returns the log line the first time
    /// this kind of fault is seen (None afterwards).
    pub fn check(
        &mut self,
        cmd: &CableForceCommand,
        model: &Model,
    ) -> (Option<Vec<(usize, f64)>>, Option<String>) {
        match validate(cmd, model) {
            Ok(v) => {
                self.accepted = self.accepted.saturating_add(1);
                (Some(v), None)
            }
            Err((fault, why)) => {
                self.rejected = self.rejected.saturating_add(1);
                let slot = match fault {
                    Fault::UnknownCable => {
                        self.unknown_cable = self.unknown_cable.saturating_add(1);
                        0
                    }
                    Fault::MismatchedLengths => {
                        self.mismatched_lengths = self.mismatched_lengths.saturating_add(1);
                        1
                    }
                    Fault::BadTension => {
                        self.bad_tension = self.bad_tension.saturating_add(1);
                        2
                    }
                };
                let log = if self.logged[slot] {
                    None
                } else {
                    self.logged[slot] = true;
                    Some(format!(
                        "rejected cable_force_cmd ({}): {why}; the last good command stays. \
                         Further {} rejections are counted in lock_status, not logged.",
                        fault.label(),
                        fault.label()
                    ))
                };
                (None, log)
            }
        }
    }
}

/// A tick's merged commands: (cable, tension) in arrival order, the first
/// command's source stamp (ns since the Unix epoch, 0 if none) and take time.
pub type Taken = (Vec<(usize, f64)>, i64, Instant);

/// The valid commands taken in one tick, merged in arrival order: a later
/// command's tension for a cable replaces an earlier one's, and cables no
/// command names keep theirs (two partial commands for different cables both
/// apply). Keeps the source stamp and take time of the first, for `--timing`.
#[derive(Debug, Default)]
pub struct Pending {
    tensions: Vec<(usize, f64)>,
    first: Option<(i64, Instant)>,
}

impl Pending {
    pub fn add(&mut self, tensions: Vec<(usize, f64)>, src_ns: i64, taken: Instant) {
        self.tensions.extend(tensions);
        self.first.get_or_insert((src_ns, taken));
    }

    /// (cable, tension) in arrival order, to be applied in that order, with
    /// the first command's source stamp and take time; None if nothing came.
    pub fn take(&mut self) -> Option<Taken> {
        let (src, taken) = self.first.take()?;
        Some((std::mem::take(&mut self.tensions), src, taken))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two partial commands for the sail's two cables taken in one tick both
    /// apply, with a third one for the first cable overriding the first.
    #[test]
    fn partial_commands_in_one_tick_merge_in_order() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/sail_array.toml");
        let model = crate::model::load(std::path::Path::new(path))
            .unwrap()
            .model;
        let mut sim =
            crate::solver::Simulator::new(model, crate::solver::Options::default()).unwrap();
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
        for (c, t) in merged {
            sim.set_cable_tension(c, t).unwrap();
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

    /// 10,000 undecodable samples in one second give one log line; the next
    /// one after the period gives a second line that counts those in between.
    #[test]
    fn malformed_samples_are_counted_and_their_log_rate_limited() {
        let mut b = CommandBook::default();
        let t0 = Instant::now();
        let mut lines = Vec::new();
        for k in 0..10_000u64 {
            let now = t0 + Duration::from_micros(100 * k);
            lines.extend(b.malformed("eof", now));
        }
        assert_eq!(b.malformed, 10_000);
        assert_eq!(lines.len(), 1, "{lines:?}");
        let later = b.malformed("eof", t0 + MALFORMED_LOG_PERIOD + Duration::from_secs(1));
        let line = later.expect("a line after the period");
        assert!(line.starts_with("10000 more"), "{line}");
        assert_eq!(b.malformed, 10_001);
        assert_eq!(b.rejected, 0, "malformed samples are not rejected commands");
    }
}
