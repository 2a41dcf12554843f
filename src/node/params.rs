//! The node's settings as ROS 2 parameters (pure, no DDS): each declared with
//! a descriptor (type, description, range, read-only), its value starting
//! from the command-line flag, then the `--ros-args` overrides (params files
//! and `-p`, in order), then `set` while running. One check serves all three.

use super::rosargs::{ParamValue, RosArgs};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Bool,
    Double,
    Str,
    StrArray,
}

impl Kind {
    fn label(self) -> &'static str {
        match self {
            Kind::Bool => "bool",
            Kind::Double => "double",
            Kind::Str => "string",
            Kind::StrArray => "string array",
        }
    }
}

/// rcl_interfaces/ParameterDescriptor, as far as the node uses it.
#[derive(Clone, Debug)]
pub struct Descriptor {
    pub name: &'static str,
    pub kind: Kind,
    pub description: &'static str,
    /// The command-line flag that gives its start value, if any.
    pub flag: Option<&'static str>,
    pub read_only: bool,
    /// Inclusive range of a double (rcl_interfaces/FloatingPointRange, step 0).
    pub range: Option<(f64, f64)>,
}

/// Names of the live settings the main loop reads.
pub const RTF: &str = "rtf";
pub const RATE_HZ: &str = "rate_hz";
pub const MARKER_RATE_HZ: &str = "marker_rate_hz";
pub const LOCK_PERIOD_S: &str = "lock_period_s";
pub const MAX_SPEED_M_S: &str = "max_speed_m_s";
pub const MODEL: &str = "model";
pub const FRAME_ID: &str = "frame_id";
pub const PARENT_FRAME_ID: &str = "parent_frame_id";
pub const PUBLISH_CLOCK: &str = "publish_clock";
pub const USE_SIM_TIME: &str = "use_sim_time";
pub const TF_FRAMES: &str = "tf_frames";

/// Every parameter the node declares.
pub fn descriptors() -> Vec<Descriptor> {
    let d = |name, kind, description, flag, read_only, range| Descriptor {
        name,
        kind,
        description,
        flag,
        read_only,
        range,
    };
    vec![
        d(
            RTF,
            Kind::Double,
            "real-time factor: simulated seconds per wall-clock second",
            Some("--rtf"),
            false,
            Some((1e-3, 1000.0)),
        ),
        d(
            RATE_HZ,
            Kind::Double,
            "publication rate of /joint_states, /truss/state, /clock and /tf (Hz)",
            Some("--rate"),
            false,
            Some((1e-2, 1000.0)),
        ),
        d(
            MARKER_RATE_HZ,
            Kind::Double,
            "publication rate of /truss/markers (Hz)",
            None,
            false,
            Some((1e-2, 100.0)),
        ),
        d(
            LOCK_PERIOD_S,
            Kind::Double,
            "period of the unconditional /truss/lock_status republication (s)",
            Some("--lock-period-s"),
            false,
            Some((1e-3, 3600.0)),
        ),
        d(
            MAX_SPEED_M_S,
            Kind::Double,
            "largest reel-in speed a /truss/cable_speed_cmd may command, either way (m/s); \
             a command above it is rejected",
            None,
            false,
            Some((1e-6, 100.0)),
        ),
        d(MODEL, Kind::Str, "the model file (TOML)", None, true, None),
        d(
            FRAME_ID,
            Kind::Str,
            "frame of headers and markers; the mount frame on /tf_static",
            Some("--frame-id"),
            true,
            None,
        ),
        d(
            PARENT_FRAME_ID,
            Kind::Str,
            "the frame the truss is mounted in: parent of frame_id on /tf_static",
            None,
            true,
            None,
        ),
        d(
            PUBLISH_CLOCK,
            Kind::Bool,
            "publish /clock (false: --no-clock)",
            Some("--no-clock"),
            true,
            None,
        ),
        d(
            USE_SIM_TIME,
            Kind::Bool,
            "the node is the clock: its stamps are simulation time already",
            None,
            true,
            None,
        ),
        d(
            TF_FRAMES,
            Kind::StrArray,
            "truss joints published as /tf frames (child of frame_id)",
            Some("--tf-frames"),
            true,
            None,
        ),
    ]
}

/// The declared parameters and their values, in declaration order.
#[derive(Clone, Debug)]
pub struct Params {
    entries: Vec<(Descriptor, ParamValue)>,
}

impl Params {
    /// Starts from the flags' values: (name, value) for each declared name.
    pub fn new(start: Vec<(&'static str, ParamValue)>) -> Result<Params, String> {
        let mut entries = Vec::new();
        for d in descriptors() {
            let v = start
                .iter()
                .find(|(n, _)| *n == d.name)
                .map(|(_, v)| v.clone())
                .ok_or_else(|| format!("parameter `{}` has no start value", d.name))?;
            let v = check(&d, v).map_err(|e| with_flag(&d, e))?;
            entries.push((d, v));
        }
        Ok(Params { entries })
    }

    /// Applies the `--ros-args` overrides for the node `fqn`, in order
    /// (read-only parameters too, as ROS 2 does at declaration). An unknown
    /// name given with `-p` is an error; a params file may hold other
    /// nodes' parameters, whose names are returned to be warned about.
    pub fn apply_overrides(&mut self, ros: &RosArgs, fqn: &str) -> Result<Vec<String>, String> {
        let mut ignored = Vec::new();
        for p in ros.params_for(fqn) {
            match self.entries.iter_mut().find(|(d, _)| d.name == p.name) {
                None if p.from_command_line => {
                    return Err(format!(
                        "{}: this node has no parameter `{}` (it has: {})",
                        p.origin,
                        p.name,
                        self.names().join(", ")
                    ))
                }
                None => ignored.push(format!("{}: `{}`", p.origin, p.name)),
                Some((d, v)) => {
                    *v = check(d, p.value.clone()).map_err(|e| format!("{}: {e}", p.origin))?
                }
            }
        }
        Ok(ignored)
    }

    /// Sets a parameter while running: refused (with the reason) if unknown,
    /// read-only, of another type or out of range.
    pub fn set(&mut self, name: &str, value: ParamValue) -> Result<(), String> {
        self.set_checked(name, value, false)
    }

    /// Sets a start value found only later (one that depends on the model),
    /// read-only or not; checked as any other.
    pub fn set_start(&mut self, name: &str, value: ParamValue) -> Result<(), String> {
        self.set_checked(name, value, true)
    }

    fn set_checked(&mut self, name: &str, value: ParamValue, at_start: bool) -> Result<(), String> {
        let Some((d, v)) = self.entries.iter_mut().find(|(d, _)| d.name == name) else {
            return Err(format!("no parameter `{name}`"));
        };
        if d.read_only && !at_start {
            return Err(format!("parameter `{name}` is read-only"));
        }
        *v = check(d, value)?;
        Ok(())
    }

    pub fn names(&self) -> Vec<&'static str> {
        self.entries.iter().map(|(d, _)| d.name).collect()
    }

    pub fn get(&self, name: &str) -> Option<&ParamValue> {
        self.entries
            .iter()
            .find(|(d, _)| d.name == name)
            .map(|(_, v)| v)
    }

    pub fn descriptor(&self, name: &str) -> Option<&Descriptor> {
        self.entries
            .iter()
            .find(|(d, _)| d.name == name)
            .map(|(d, _)| d)
    }

    /// A declared double (0 for another name: a programming error the tests catch).
    pub fn f64(&self, name: &str) -> f64 {
        match self.get(name) {
            Some(ParamValue::Double(x)) => *x,
            _ => 0.0,
        }
    }

    pub fn string(&self, name: &str) -> &str {
        match self.get(name) {
            Some(ParamValue::Str(s)) => s,
            _ => "",
        }
    }

    pub fn boolean(&self, name: &str) -> bool {
        matches!(self.get(name), Some(ParamValue::Bool(true)))
    }

    pub fn strings(&self, name: &str) -> &[String] {
        match self.get(name) {
            Some(ParamValue::StrArray(v)) => v,
            _ => &[],
        }
    }
}

fn with_flag(d: &Descriptor, e: String) -> String {
    match d.flag {
        Some(f) => format!("{f}: {e}"),
        None => e,
    }
}

/// The value in the parameter's type (an integer serves as a double), in range.
fn check(d: &Descriptor, v: ParamValue) -> Result<ParamValue, String> {
    let v = match (d.kind, v) {
        (Kind::Double, ParamValue::Int(i)) => ParamValue::Double(i as f64),
        (Kind::Double, v @ ParamValue::Double(_))
        | (Kind::Bool, v @ ParamValue::Bool(_))
        | (Kind::Str, v @ ParamValue::Str(_))
        | (Kind::StrArray, v @ ParamValue::StrArray(_)) => v,
        (k, v) => {
            return Err(format!(
                "parameter `{}` is a {}, not {v}",
                d.name,
                k.label()
            ))
        }
    };
    if let (Some((lo, hi)), ParamValue::Double(x)) = (d.range, &v) {
        if !(x.is_finite() && *x >= lo && *x <= hi) {
            return Err(format!(
                "parameter `{}` = {x} is outside its range [{lo}, {hi}]",
                d.name
            ));
        }
    }
    if d.name == USE_SIM_TIME && v == ParamValue::Bool(true) {
        return Err("parameter `use_sim_time` must stay false: this node publishes /clock".into());
    }
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::node::rosargs;

    fn start() -> Vec<(&'static str, ParamValue)> {
        vec![
            (RTF, ParamValue::Double(1.0)),
            (RATE_HZ, ParamValue::Double(20.0)),
            (MARKER_RATE_HZ, ParamValue::Double(5.0)),
            (LOCK_PERIOD_S, ParamValue::Double(1.0)),
            (MAX_SPEED_M_S, ParamValue::Double(1.0)),
            (MODEL, ParamValue::Str("m.toml".into())),
            (FRAME_ID, ParamValue::Str("truss".into())),
            (PARENT_FRAME_ID, ParamValue::Str("world".into())),
            (PUBLISH_CLOCK, ParamValue::Bool(true)),
            (USE_SIM_TIME, ParamValue::Bool(false)),
            (TF_FRAMES, ParamValue::StrArray(vec![])),
        ]
    }

    #[test]
    fn overrides_in_order_and_live_sets_checked() {
        let mut p = Params::new(start()).unwrap();
        let ros = rosargs::parse(
            &[
                "-p",
                "rtf:=2",
                "-p",
                "other:rtf:=7.0",
                "-p",
                "model:=x.toml",
                "-p",
                "lock_period_s:=0.5",
            ]
            .map(std::ffi::OsString::from),
        )
        .unwrap();
        assert!(p.apply_overrides(&ros, "/t2").unwrap().is_empty());
        assert_eq!(
            p.f64(RTF),
            2.0,
            "int given for a double; other:rtf not for /t2"
        );
        assert_eq!(p.string(MODEL), "x.toml", "read-only, but set at start");
        assert_eq!(p.f64(LOCK_PERIOD_S), 0.5);
        p.set(RTF, ParamValue::Double(4.0)).unwrap();
        assert_eq!(p.f64(RTF), 4.0);
        for (n, v, says) in [
            (
                RTF,
                ParamValue::Double(0.0),
                "outside its range [0.001, 1000]",
            ),
            (RTF, ParamValue::Double(f64::NAN), "outside its range"),
            (RTF, ParamValue::Str("x".into()), "is a double"),
            (MODEL, ParamValue::Str("y".into()), "read-only"),
            ("rft", ParamValue::Double(1.0), "no parameter `rft`"),
        ] {
            let e = p.set(n, v).unwrap_err();
            assert!(e.contains(says), "{n}: {e}");
        }
        assert_eq!(p.f64(RTF), 4.0, "a refused value leaves the old one");
        let bad = rosargs::parse(&["-p", "rft:=2"].map(std::ffi::OsString::from)).unwrap();
        let e = p.apply_overrides(&bad, "/t2").unwrap_err();
        assert!(e.contains("-p rft:=2") && e.contains("rtf"), "{e}");
        let bad =
            rosargs::parse(&["-p", "use_sim_time:=true"].map(std::ffi::OsString::from)).unwrap();
        assert!(p.apply_overrides(&bad, "/t2").is_err());
    }

    #[test]
    fn a_bad_flag_names_the_flag() {
        let mut s = start();
        s[3].1 = ParamValue::Double(1e20);
        let e = Params::new(s).unwrap_err();
        assert!(
            e.contains("--lock-period-s") && e.contains("lock_period_s"),
            "{e}"
        );
    }
}
