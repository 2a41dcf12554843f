//! Validation and bookkeeping of `/truss/cable_force_cmd` (pure, no DDS).

use super::msgs::CableForceCommand;
use crate::solver::model::Model;

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

/// Counters and the "log once per kind" memory.
#[derive(Clone, Debug, Default)]
pub struct CommandBook {
    pub accepted: u32,
    pub rejected: u32,
    pub unknown_cable: u32,
    pub mismatched_lengths: u32,
    pub bad_tension: u32,
    logged: [bool; 3],
}

impl CommandBook {
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
