//! The ROS 2 node (feature `ros`): steps the [`Simulator`] in real time and
//! publishes over DDS with ros2-client on a tokio current_thread runtime. Its
//! settings are ROS parameters ([`params`], served by [`param_services`]),
//! set from flags and `--ros-args` ([`rosargs`]); its log goes to /rosout
//! ([`log`]).
//! Topics, types and QoS follow ../shared/DESIGN.md "ROS 2 interface"; see
//! launch_notes.md for running it next to a ROS 2 installation.

pub mod commands;
pub mod controller;
pub mod log;
pub mod msgs;
pub mod param_services;
pub mod params;
pub mod publish;
pub mod record;
pub mod rosargs;
pub mod services;
pub mod sim_action;

#[cfg(all(feature = "humble", feature = "jazzy"))]
compile_error!(
    "features `humble` and `jazzy` exclude each other; for Humble build with \
     `--no-default-features --features humble`"
);
#[cfg(not(any(feature = "humble", feature = "jazzy")))]
compile_error!(
    "the node needs a ROS 2 distribution: feature `jazzy` (the default) or \
     `--no-default-features --features humble` (feature `ros` alone is not enough)"
);

use crate::solver::{Options, Simulator};
use clap::{Args, ValueEnum};
use commands::{CmdTopic, CommandBook};
use log::node_log;
use msgs::*;
use params::Params;
use ros2_client::dds::rustdds::DomainParticipantBuilder;
use ros2_client::qos::{Durability, History, WhenFull};
use ros2_client::{
    Context, MessageTypeName, Name, Node, NodeName, NodeOptions, Publisher, QosProfile,
    ServiceMapping, Subscription,
};
use rosargs::{LogLevel, ParamValue, RosArgs};
use services::{Control, Services};
use std::ffi::OsString;
use std::net::Ipv4Addr;
use std::path::PathBuf;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};
use tokio::time::Instant as TokioInstant;

/// The ROS 2 distribution this build is for (cargo feature `jazzy` or `humble`).
#[cfg(feature = "humble")]
pub const BUILT_FOR: Distro = Distro::Humble;
#[cfg(not(feature = "humble"))]
pub const BUILT_FOR: Distro = Distro::Jazzy;

#[derive(Clone, Copy, Debug, ValueEnum, PartialEq, Eq)]
pub enum Distro {
    /// ROS 2 Jazzy (and Iron, later): Marker with the texture/uv/mesh_file fields.
    Jazzy,
    /// ROS 2 Humble: the same Marker layout as Jazzy (the fields came in
    /// common_interfaces 3.0.0, before Humble's release).
    Humble,
    /// ROS 2 Foxy and Galactic (end of life): Marker without the texture, uv and
    /// mesh_file fields.
    #[value(alias = "foxy")]
    Galactic,
}

#[derive(Clone, Copy, Debug, ValueEnum, PartialEq, Eq)]
pub enum Mapping {
    /// Request id in the payload, as rmw_cyclonedds_cpp does.
    Cyclone,
    /// Request id in RTPS inline QoS, as rmw_fastrtps_cpp / Connext do.
    Enhanced,
}

#[derive(Args, Debug, Clone)]
pub struct NodeArgs {
    /// Model file (TOML).
    pub model: PathBuf,
    /// Publish rate of /joint_states, /truss/state, /clock and /tf (Hz);
    /// parameter `rate_hz`. Default: one publication per simulation step at
    /// the chosen real-time factor, at most 100 Hz.
    #[arg(long, allow_negative_numbers = true)]
    pub rate: Option<f64>,
    /// Real-time factor: simulated seconds per wall-clock second (parameter `rtf`).
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    pub rtf: f64,
    /// Node namespace; topics and services are resolved in it (/clock stays
    /// global). `--ros-args -r __ns:=/NS` overrides it.
    #[arg(long, default_value = "/")]
    pub namespace: String,
    /// Restrict RustDDS to 127.0.0.1 (also: ROS_LOCALHOST_ONLY=1,
    /// ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST or OFF, TRUSS_DDS_LOOPBACK=1).
    #[arg(long)]
    pub loopback: bool,
    /// Stop by itself after this many wall-clock seconds.
    #[arg(long, allow_negative_numbers = true)]
    pub max_wall_s: Option<f64>,
    /// Frame of headers and markers.
    #[arg(long, default_value = "truss")]
    pub frame_id: String,
    /// Layout of visualization_msgs/Marker on /truss/markers. Default: the
    /// distribution of this build (cargo feature `jazzy` or `humble`).
    #[arg(long, value_enum, default_value_t = BUILT_FOR)]
    pub markers_for: Distro,
    /// Answer every service request in this mapping. Default: each request in
    /// its own client's mapping (rmw_cyclonedds and rmw_fastrtps alike).
    #[arg(long, value_enum)]
    pub service_mapping: Option<Mapping>,
    /// Do not publish /clock (several simulators on one domain).
    #[arg(long)]
    pub no_clock: bool,
    /// Start paused (services resume/step drive it).
    #[arg(long)]
    pub paused: bool,
    /// Period of the unconditional /truss/lock_status republication (s); it is
    /// also published on every change.
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    pub lock_period_s: f64,
    /// Write publish-period and command-latency statistics (JSON) here at exit.
    #[arg(long)]
    pub timing: Option<PathBuf>,
    /// Record what the node publishes as a ROS 2 MCAP file (log time =
    /// simulation time); finished on SIGINT, SIGTERM and --max-wall-s, and a
    /// chunk is closed every second so that a killed node leaves a readable file.
    #[arg(long, value_name = "FILE.mcap")]
    pub record: Option<PathBuf>,
    /// Truss joints published as /tf frames (comma-separated joint names;
    /// parameter `tf_frames`). Default: every post top (joints named `*_t`,
    /// as the ring generators name them) or, with none, the highest joint of
    /// the deployed geometry (a mast's tip).
    #[arg(long, value_delimiter = ',', value_name = "JOINT,...")]
    pub tf_frames: Option<Vec<String>>,
    /// The contents of the command line's `--ros-args` sections (rcl's syntax;
    /// see [`rosargs`]), set by the command-line front end.
    #[arg(skip)]
    pub ros_args: Vec<OsString>,
}

/// What a run did, for the exit message and tests.
#[derive(Debug, Default, Clone, serde::Serialize)]
pub struct RunSummary {
    pub steps: u64,
    pub sim_time_s: f64,
    pub deployed: bool,
    pub publications: u64,
    pub accepted_commands: u32,
    pub rejected_commands: u32,
    pub overruns: u64,
    pub stop_reason: String,
}

/// Domain id from ROS_DOMAIN_ID (ros2-client itself ignores it).
pub fn domain_id_from_env() -> Result<u16, String> {
    match std::env::var("ROS_DOMAIN_ID") {
        Err(_) => Ok(0),
        Ok(s) if s.trim().is_empty() => Ok(0),
        Ok(s) => match s.trim().parse::<u16>() {
            Ok(d) if d <= 232 => Ok(d),
            _ => Err(format!("ROS_DOMAIN_ID `{s}` must be an integer 0..=232")),
        },
    }
}

/// Whether the environment keeps DDS on 127.0.0.1: ROS_LOCALHOST_ONLY=1
/// (Humble), ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST (Jazzy; OFF, "no
/// discovery beyond the process", is kept to the host, the nearest RustDDS
/// offers), or this program's TRUSS_DDS_LOOPBACK=1.
pub fn loopback_from_env() -> Result<bool, String> {
    let var = |n: &str| std::env::var(n).ok().map(|v| v.trim().to_string());
    let truss = matches!(var("TRUSS_DDS_LOOPBACK").as_deref(), Some("1" | "true"));
    let localhost_only = match var("ROS_LOCALHOST_ONLY").as_deref() {
        None | Some("" | "0") => false,
        Some("1") => true,
        Some(v) => return Err(format!("ROS_LOCALHOST_ONLY `{v}` must be 0 or 1")),
    };
    let range = match var("ROS_AUTOMATIC_DISCOVERY_RANGE").as_deref() {
        None | Some("" | "SUBNET" | "SYSTEM_DEFAULT") => false,
        Some("LOCALHOST" | "OFF") => true,
        Some(v) => {
            return Err(format!(
            "ROS_AUTOMATIC_DISCOVERY_RANGE `{v}` must be SUBNET, LOCALHOST, OFF or SYSTEM_DEFAULT"
        ))
        }
    };
    Ok(truss || localhost_only || range)
}

/// A ros2-client context on ROS_DOMAIN_ID, optionally on 127.0.0.1 only.
pub fn make_context(loopback: bool) -> Result<Context, String> {
    let domain = domain_id_from_env()?;
    let mut b = DomainParticipantBuilder::new(domain);
    if loopback || loopback_from_env()? {
        b = b.with_only_networks([Ipv4Addr::LOCALHOST]);
    }
    let dp = b
        .build()
        .map_err(|e| format!("DDS participant on domain {domain}: {e:?}"))?;
    Context::from_domain_participant(dp).map_err(|e| format!("ROS context: {e:?}"))
}

/// Normalized absolute namespace: "/" or "/a/b".
pub fn normalize_namespace(ns: &str) -> Result<String, String> {
    let parts: Vec<&str> = ns.split('/').filter(|p| !p.is_empty()).collect();
    for p in &parts {
        let ok = p.starts_with(|c: char| c.is_ascii_alphabetic() || c == '_')
            && p.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
            && !p.contains("__");
        if !ok {
            return Err(format!("namespace `{ns}`: bad token `{p}`"));
        }
    }
    Ok(format!("/{}", parts.join("/")))
}

/// Topic and service names of a node: resolved in its namespace, then
/// remapped by the `-r FROM:=TO` rules that apply to it (the first that
/// matches, as rcl).
#[derive(Clone, Debug)]
pub struct Naming {
    pub ns: String,
    pub node: String,
    remaps: Vec<(String, String)>,
}

impl Naming {
    pub fn new(ns: &str, node: &str, remaps: Vec<(String, String)>) -> Naming {
        Naming {
            ns: ns.to_string(),
            node: node.to_string(),
            remaps,
        }
    }

    /// Names in namespace `ns`, no remapping.
    pub fn plain(ns: &str) -> Naming {
        Naming::new(ns, "", Vec::new())
    }

    /// The absolute name of `name` (relative to the namespace, or absolute), remapped.
    pub fn full(&self, name: &str) -> Result<String, String> {
        let r = rosargs::resolve(name, &self.ns, &self.node)?;
        Ok(match self.remaps.iter().find(|(from, _)| *from == r) {
            Some((_, to)) => to.clone(),
            None => r,
        })
    }

    /// [`Self::full`] as a ros2-client [`Name`].
    pub fn name(&self, name: &str) -> Result<Name, String> {
        let full = self.full(name)?;
        let (ns, base) = full.rsplit_once('/').unwrap_or(("", &full));
        Name::new(if ns.is_empty() { "/" } else { ns }, base)
            .map_err(|e| format!("name {full}: {e:?}"))
    }
}

/// `sub/base` resolved in `ns` (no remapping).
pub fn topic_name(ns: &str, sub: &str, base: &str) -> Result<Name, String> {
    let rel = if sub.is_empty() {
        base.to_string()
    } else {
        format!("{sub}/{base}")
    };
    Naming::plain(ns).name(&rel)
}

/// QoS profiles of DESIGN.md "ROS 2 interface".
pub mod qos {
    use super::*;
    /// reliable, volatile, keep last 10 (/joint_states, /truss/state, commands).
    pub fn reliable10() -> QosProfile {
        QosProfile::publisher_default()
            .reliability_reliable(WhenFull::DEFAULT)
            .durability(Durability::Volatile)
            .history(History::KeepLast { depth: 10 })
    }
    /// reliable, transient local, keep last 1 (/truss/lock_status).
    pub fn latched() -> QosProfile {
        QosProfile::publisher_default()
            .reliability_reliable(WhenFull::DEFAULT)
            .durability(Durability::TransientLocal)
            .history(History::KeepLast { depth: 1 })
    }
    /// best effort, keep last 1 (/clock).
    pub fn clock() -> QosProfile {
        QosProfile::publisher_default()
            .reliability_best_effort()
            .durability(Durability::Volatile)
            .history(History::KeepLast { depth: 1 })
    }
    /// reliable, volatile, keep last 100 (/tf, as tf2's TransformBroadcaster).
    pub fn tf() -> QosProfile {
        QosProfile::publisher_default()
            .reliability_reliable(WhenFull::DEFAULT)
            .durability(Durability::Volatile)
            .history(History::KeepLast { depth: 100 })
    }
    /// reliable, transient local, keep last 1 (/tf_static, as tf2's
    /// StaticTransformBroadcaster).
    pub fn tf_static() -> QosProfile {
        latched()
    }
    /// reliable, volatile (/truss/markers); keep last 1 since only the newest matters.
    pub fn markers() -> QosProfile {
        QosProfile::publisher_default()
            .reliability_reliable(WhenFull::DEFAULT)
            .durability(Durability::Volatile)
            .history(History::KeepLast { depth: 1 })
    }
}

fn forced_mapping(m: Option<Mapping>) -> Option<ServiceMapping> {
    m.map(|m| match m {
        Mapping::Cyclone => ServiceMapping::Cyclone,
        Mapping::Enhanced => ServiceMapping::Enhanced,
    })
}

/// Entry point of `truss-deploy node`: a current_thread runtime around [`run`].
pub fn run_blocking(args: NodeArgs) -> Result<RunSummary, NodeError> {
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .map_err(|e| NodeError::Run(format!("tokio runtime: {e}")))?;
    rt.block_on(run(args))
}

#[derive(Debug)]
pub enum NodeError {
    /// Bad arguments or model (exit status 2).
    Input(String),
    /// DDS or runtime failure (exit status 1).
    Run(String),
}

impl std::fmt::Display for NodeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            NodeError::Input(s) | NodeError::Run(s) => f.write_str(s),
        }
    }
}

struct Endpoints {
    js: Publisher<JointState>,
    state: Publisher<TrussState>,
    lock: Publisher<LockStatus>,
    /// None with --no-clock.
    clock: Option<Publisher<Clock>>,
    markers: publish::MarkerPub,
    tf: Publisher<TFMessage>,
    tf_static: Publisher<TFMessage>,
    cmd: Subscription<CableForceCommand>,
    speed_cmd: Subscription<CableSpeedCommand>,
    srv: Services,
    params_srv: param_services::ParamServices,
    action: sim_action::SimulateSteps,
}

fn create_endpoints(
    node: &mut Node,
    names: &Naming,
    a: &NodeArgs,
    p: &Params,
    events_topic: &ros2_client::dds::rustdds::Topic,
) -> Result<Endpoints, String> {
    let e = |what: &str, err: &dyn std::fmt::Debug| format!("create {what}: {err:?}");
    let clock = if !p.boolean(params::PUBLISH_CLOCK) {
        None
    } else {
        let clock_t = node
            .create_topic(
                &names.name("/clock")?,
                MessageTypeName::new("rosgraph_msgs", "Clock"),
                &qos::clock(),
            )
            .map_err(|x| e("clock", &x))?;
        Some(
            node.create_publisher::<Clock>(&clock_t, None)
                .map_err(|x| e("clock", &x))?,
        )
    };
    let js_t = node
        .create_topic(
            &names.name("joint_states")?,
            MessageTypeName::new("sensor_msgs", "JointState"),
            &qos::reliable10(),
        )
        .map_err(|x| e("joint_states", &x))?;
    let js = node
        .create_publisher::<JointState>(&js_t, None)
        .map_err(|x| e("joint_states", &x))?;
    let st_t = node
        .create_topic(
            &names.name("truss/state")?,
            MessageTypeName::new("truss_deploy", "TrussState"),
            &qos::reliable10(),
        )
        .map_err(|x| e("state", &x))?;
    let state = node
        .create_publisher::<TrussState>(&st_t, None)
        .map_err(|x| e("state", &x))?;
    let lock_t = node
        .create_topic(
            &names.name("truss/lock_status")?,
            MessageTypeName::new("truss_deploy", "LockStatus"),
            &qos::latched(),
        )
        .map_err(|x| e("lock_status", &x))?;
    let lock = node
        .create_publisher::<LockStatus>(&lock_t, None)
        .map_err(|x| e("lock_status", &x))?;
    let markers = publish::MarkerPub::new(node, &names.name("truss/markers")?, a.markers_for)?;
    let tf_t = node
        .create_topic(
            &names.name("/tf")?,
            MessageTypeName::new("tf2_msgs", "TFMessage"),
            &qos::tf(),
        )
        .map_err(|x| e("tf", &x))?;
    let tf = node
        .create_publisher::<TFMessage>(&tf_t, None)
        .map_err(|x| e("tf", &x))?;
    let tf_static_t = node
        .create_topic(
            &names.name("/tf_static")?,
            MessageTypeName::new("tf2_msgs", "TFMessage"),
            &qos::tf_static(),
        )
        .map_err(|x| e("tf_static", &x))?;
    let tf_static = node
        .create_publisher::<TFMessage>(&tf_static_t, None)
        .map_err(|x| e("tf_static", &x))?;
    let cmd_t = node
        .create_topic(
            &names.name("truss/cable_force_cmd")?,
            MessageTypeName::new("truss_deploy", "CableForceCommand"),
            &qos::reliable10(),
        )
        .map_err(|x| e("cable_force_cmd", &x))?;
    let cmd = node
        .create_subscription::<CableForceCommand>(&cmd_t, None)
        .map_err(|x| e("cable_force_cmd", &x))?;
    let speed_t = node
        .create_topic(
            &names.name("truss/cable_speed_cmd")?,
            MessageTypeName::new("truss_deploy", "CableSpeedCommand"),
            &qos::reliable10(),
        )
        .map_err(|x| e("cable_speed_cmd", &x))?;
    let speed_cmd = node
        .create_subscription::<CableSpeedCommand>(&speed_t, None)
        .map_err(|x| e("cable_speed_cmd", &x))?;
    let srv = Services::new(node, names, forced_mapping(a.service_mapping))?;
    let params_srv = param_services::ParamServices::new(
        node,
        names,
        forced_mapping(a.service_mapping),
        events_topic,
    )?;
    let action = sim_action::SimulateSteps::new(node, names, forced_mapping(a.service_mapping))?;
    Ok(Endpoints {
        js,
        state,
        lock,
        clock,
        markers,
        tf,
        tf_static,
        cmd,
        speed_cmd,
        srv,
        params_srv,
        action,
    })
}

/// Timing records for `--timing`.
#[derive(Default)]
struct Timing {
    publish_at: Vec<Instant>,
    /// (source timestamp -> start of the step that used it, s), (take -> step, s)
    cmd_latency_s: Vec<(f64, f64)>,
}

const MAX_TIMING_RECORDS: usize = 2_000_000;
/// Longest `--max-wall-s`: a year.
const MAX_WALL_S: f64 = 3.2e7;
const MAX_CMDS_PER_WAKE: usize = 100_000;
const MAX_CATCHUP_STEPS: usize = 50;

fn unix_now_ns() -> i64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_nanos() as i64)
        .unwrap_or(0)
}

/// The node's parameters at start: the flags' values, then the `--ros-args`
/// overrides; `ignored` lists params-file entries for names it does not have.
/// The model comes from the `model` parameter, and [`Self::complete`] gives
/// the defaults that depend on it (rate, /tf joints) unless they were given.
struct StartParams {
    params: Params,
    ignored: Vec<String>,
    rate_given: bool,
    tf_frames_given: bool,
}

/// Start value of `rate_hz` until the model gives the default.
const RATE_HZ_UNTIL_MODEL: f64 = 20.0;

fn start_params(a: &NodeArgs, ros: &RosArgs, fqn: &str) -> Result<StartParams, String> {
    use params::*;
    let start = vec![
        (RTF, ParamValue::Double(a.rtf)),
        (
            RATE_HZ,
            ParamValue::Double(a.rate.unwrap_or(RATE_HZ_UNTIL_MODEL)),
        ),
        (MARKER_RATE_HZ, ParamValue::Double(5.0)),
        (LOCK_PERIOD_S, ParamValue::Double(a.lock_period_s)),
        (MAX_SPEED_M_S, ParamValue::Double(1.0)),
        (MODEL, ParamValue::Str(a.model.display().to_string())),
        (FRAME_ID, ParamValue::Str(a.frame_id.clone())),
        (PARENT_FRAME_ID, ParamValue::Str("world".into())),
        (PUBLISH_CLOCK, ParamValue::Bool(!a.no_clock)),
        (USE_SIM_TIME, ParamValue::Bool(false)),
        (
            TF_FRAMES,
            ParamValue::StrArray(a.tf_frames.clone().unwrap_or_default()),
        ),
    ];
    let mut params = Params::new(start)?;
    let ignored = params.apply_overrides(ros, fqn)?;
    let given = |name: &str| ros.params_for(fqn).any(|p| p.name == name);
    Ok(StartParams {
        params,
        ignored,
        rate_given: a.rate.is_some() || given(RATE_HZ),
        tf_frames_given: a.tf_frames.is_some() || given(TF_FRAMES),
    })
}

impl StartParams {
    /// The defaults that depend on the model: one publication per step at the
    /// real-time factor (at most 100 Hz), and the /tf joints.
    fn complete(&mut self, dt_s: f64, tf_default: Vec<String>) -> Result<(), String> {
        use params::*;
        if !self.rate_given {
            let r = (self.params.f64(RTF) / dt_s).clamp(1e-2, 100.0);
            self.params.set_start(RATE_HZ, ParamValue::Double(r))?;
        }
        if !self.tf_frames_given {
            self.params
                .set_start(TF_FRAMES, ParamValue::StrArray(tf_default))?;
        }
        Ok(())
    }
}

/// The settings the main loop reads, from the parameters (again after each set).
struct Live {
    rtf: f64,
    rate_hz: f64,
    pub_period: Duration,
    lock_period: Duration,
    marker_period: Duration,
    /// Largest |speed| a speed command may give (m/s).
    max_speed_m_s: f64,
}

impl Live {
    fn from(p: &Params) -> Live {
        let rate_hz = p.f64(params::RATE_HZ);
        Live {
            rtf: p.f64(params::RTF),
            rate_hz,
            pub_period: Duration::from_secs_f64(1.0 / rate_hz),
            lock_period: Duration::from_secs_f64(p.f64(params::LOCK_PERIOD_S)),
            marker_period: Duration::from_secs_f64(1.0 / p.f64(params::MARKER_RATE_HZ)),
            max_speed_m_s: p.f64(params::MAX_SPEED_M_S),
        }
    }
}

/// Runs the node until SIGINT/SIGTERM or --max-wall-s.
pub async fn run(a: NodeArgs) -> Result<RunSummary, NodeError> {
    let input = NodeError::Input;
    // (bounded so that Duration and Instant arithmetic cannot overflow)
    if let Some(m) = a.max_wall_s {
        if !(m.is_finite() && m > 0.0 && m <= MAX_WALL_S) {
            return Err(input(format!(
                "--max-wall-s {m} must be in (0, {MAX_WALL_S:e}] s"
            )));
        }
    }
    let ros = rosargs::parse(&a.ros_args).map_err(input)?;
    let node_name = ros.node_name("truss_deploy").map_err(input)?;
    let ns = normalize_namespace(&ros.namespace(&node_name).unwrap_or(a.namespace.clone()))
        .map_err(input)?;
    let names = Naming::new(
        &ns,
        &node_name,
        ros.name_remaps(&node_name, &ns).map_err(input)?,
    );
    let fqn = names.full("~").map_err(input)?;
    log::init(
        &log::logger_name(&fqn),
        ros.log_level.unwrap_or(LogLevel::Info),
    );
    let mut par = start_params(&a, &ros, &fqn).map_err(input)?;
    // (the model argument, or the `model` parameter set by --ros-args)
    let model_path = PathBuf::from(par.params.string(params::MODEL));
    let loaded = crate::model::load(&model_path).map_err(|e| input(e.to_string()))?;
    let checks = loaded.checks.clone();
    let mut sim = Simulator::new(loaded.model, Options::default())
        .map_err(|e| input(format!("{}: {e}", model_path.display())))?;
    let dt = sim.model().dt_s;
    par.complete(dt, publish::default_tf_joints(sim.model()))
        .map_err(input)?;
    let tf_joints = publish::tf_joint_indices(sim.model(), par.params.strings(params::TF_FRAMES))
        .map_err(input)?;
    for p in &par.ignored {
        node_log!(Warn, "{p}: no such parameter here; ignored");
    }
    let mut view = publish::View::new(sim.model());
    view.checks = checks.clone();
    let mut rec = match &a.record {
        Some(p) => Some(record::Recorder::create(p, &names, a.markers_for).map_err(input)?),
        None => None,
    };
    let mut rec_error: Option<String> = None;
    let mut next_flush = Instant::now() + Duration::from_secs(1);

    let loopback = a.loopback || loopback_from_env().map_err(input)?;
    let context = make_context(loopback).map_err(NodeError::Run)?;
    let mut node = context
        .new_node(
            NodeName::new(&ns, &node_name).map_err(|e| input(format!("node name: {e:?}")))?,
            // the parameter services are the node's own (param_services.rs):
            // ros2-client's answer in one service mapping only
            NodeOptions::new()
                .enable_rosout(true)
                .start_parameter_services(false),
        )
        .map_err(|e| NodeError::Run(format!("node: {e:?}")))?;
    log::attach(node.logging_handle());
    let mut ep = create_endpoints(
        &mut node,
        &names,
        &a,
        &par.params,
        &context.get_parameter_events_topic(),
    )
    .map_err(NodeError::Run)?;
    let spinner = node
        .spinner()
        .map_err(|e| NodeError::Run(format!("spinner: {e:?}")))?;
    let spin = tokio::spawn(spinner.spin());
    let mut live = Live::from(&par.params);
    let frame_id = par.params.string(params::FRAME_ID).to_string();
    let mount = publish::tf_mount(
        par.params.string(params::PARENT_FRAME_ID),
        &frame_id,
        sim_stamp(0.0),
    );
    if let Some(r) = rec.as_mut() {
        let w = r.write(record::Topic::TfStatic, &mount, 0);
        record_failed(&mut rec, &mut rec_error, w);
    }
    let _ = ep.tf_static.publish(mount);
    node_log!(Info,
        "node {} on ROS domain {}{}; model {} ({} joints, {} cables), dt {} s, rtf {}, publishing at {:.3} Hz",
        node.fully_qualified_name(),
        node.domain_id(),
        if loopback { " (loopback only)" } else { "" },
        sim.model().name,
        sim.model().n_joints(),
        sim.model().cables.len(),
        dt,
        live.rtf,
        live.rate_hz
    );

    let mut sigterm = tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate())
        .map_err(|e| NodeError::Run(format!("SIGTERM handler: {e}")))?;
    let mut sigint = tokio::signal::unix::signal(tokio::signal::unix::SignalKind::interrupt())
        .map_err(|e| NodeError::Run(format!("SIGINT handler: {e}")))?;

    let start = Instant::now();
    let deadline = a.max_wall_s.map(|s| start + Duration::from_secs_f64(s));
    let mut book = CommandBook::default();
    let mut ctl = Control::new(a.paused, &sim, dt);
    let mut next_pub = start;
    let mut next_lock = start;
    let mut next_marker = start;
    let mut pending = commands::Pending::default();
    let mut awaiting_step: Option<(i64, Instant)> = None;
    let mut lock_dirty = true;
    let mut summary = RunSummary::default();
    let mut timing = a.timing.as_ref().map(|_| Timing::default());
    let mut last_lock_key: Option<Vec<u8>> = None;

    let stop_reason: String = loop {
        let now = Instant::now();
        if deadline.is_some_and(|d| now >= d) {
            break "max wall time".into();
        }
        // 0. Periodic publications first, so that stepping does not delay them.
        if now >= next_pub {
            let stamp = sim_stamp(sim.state().t_s);
            let (js, st) = view.state_messages(&mut sim, stamp, &frame_id);
            let tf = publish::tf_joints(&sim, &tf_joints, stamp, &frame_id);
            if let Some(r) = rec.as_mut() {
                let ns = record::stamp_ns(sim.state().t_s);
                let w = r
                    .write(record::Topic::Clock, &Clock { clock: stamp }, ns)
                    .and_then(|_| r.write(record::Topic::JointStates, &js, ns))
                    .and_then(|_| r.write(record::Topic::State, &st, ns))
                    .and_then(|_| r.write(record::Topic::Tf, &tf, ns));
                record_failed(&mut rec, &mut rec_error, w);
            }
            if let Some(clock) = &ep.clock {
                let _ = clock.publish(Clock { clock: stamp });
            }
            let _ = ep.js.publish(js);
            let _ = ep.state.publish(st);
            let _ = ep.tf.publish(tf);
            summary.publications += 1;
            if let Some(tm) = timing.as_mut() {
                if tm.publish_at.len() < MAX_TIMING_RECORDS {
                    tm.publish_at.push(now);
                }
            }
            next_pub += live.pub_period;
            if next_pub + live.pub_period < now {
                next_pub = now + live.pub_period; // fell behind: skip, do not burst
            }
        }
        // 1. Commands: drain everything pending (the reader keeps at most its
        //    QoS depth), validate each, merge the valid ones in order.
        //    Force commands first, then speed commands: within one tick the
        //    order between the two topics is the order they are read in.
        for _ in 0..MAX_CMDS_PER_WAKE {
            let r = match ep.cmd.take() {
                Ok(None) => break,
                Ok(Some(x)) => Ok(x),
                Err(e) => Err(e),
            };
            if let Some((v, src, taken)) = book_command(r, &mut book, CmdTopic::Force, |b, c| {
                b.check(c, sim.model())
            }) {
                pending.add(v, src, taken);
            }
            lock_dirty = true;
        }
        for _ in 0..MAX_CMDS_PER_WAKE {
            let r = match ep.speed_cmd.take() {
                Ok(None) => break,
                Ok(Some(x)) => Ok(x),
                Err(e) => Err(e),
            };
            if let Some((v, src, taken)) = book_command(r, &mut book, CmdTopic::Speed, |b, c| {
                b.check_speed(c, sim.model(), live.max_speed_m_s)
            }) {
                pending.add_speeds(v, src, taken);
            }
            lock_dirty = true;
        }
        // The tick's valid commands are in force from the next step on.
        if let Some((cmd, src_ns, taken)) = pending.take() {
            for (c, x) in cmd {
                // validated against the same model; a speed's engagement
                // solves at the state, which can fail
                if let Err(e) = commands::apply(&mut sim, c, x) {
                    node_log!(
                        Warn,
                        "command {x:?} for cable `{}` not applied: {e}",
                        sim.model().cables[c].name
                    );
                }
            }
            lock_dirty = true;
            if timing.is_some() {
                awaiting_step = Some((src_ns, taken));
            }
        }
        // 2. Services (each request in its client's mapping; see services.rs).
        let before = ctl.steps;
        if ep.srv.serve(&node, &mut ctl, &mut sim, Instant::now()) > 0 {
            lock_dirty = true;
        }
        summary.steps += ctl.steps - before;
        let changed = ep.params_srv.serve(&node, &mut par.params, Instant::now());
        if !changed.is_empty() {
            // From now on at the new settings: simulated time continues from
            // here at the new real-time factor.
            let now = Instant::now();
            ctl.anchor_wall = now;
            ctl.anchor_sim = sim.state().t_s;
            live = Live::from(&par.params);
            next_pub = next_pub.min(now + live.pub_period);
            next_lock = next_lock.min(now + live.lock_period);
            next_marker = next_marker.min(now + live.marker_period);
            let set: Vec<String> = changed
                .iter()
                .filter_map(|n| par.params.get(n).map(|v| format!("{n} = {v}")))
                .collect();
            node_log!(Info, "parameters set: {}", set.join(", "));
        }
        if ep.action.serve(&node, &mut ctl, &sim, Instant::now()) > 0 {
            lock_dirty = true;
        }
        // 3. Stepping in real time.
        let now = Instant::now();
        let target = ctl.anchor_sim + live.rtf * now.duration_since(ctl.anchor_wall).as_secs_f64();
        if ep.action.executing() {
            // a SimulateSteps goal steps the paused simulation at the same pace
            let due = ((target - sim.state().t_s) / dt + 0.5).floor().max(0.0) as u64;
            let taken = ep
                .action
                .advance(&mut ctl, &mut sim, due.min(MAX_CATCHUP_STEPS as u64));
            summary.steps += taken;
            if taken > 0 {
                lock_dirty = true;
            }
        }
        ep.action.finish(&node, now);
        let mut n = 0;
        while !sim.state().deployed
            && ctl.step_failure.is_none()
            && !ctl.paused()
            && sim.state().t_s + 0.5 * dt <= target
            && n < MAX_CATCHUP_STEPS
        {
            if let Some((src_ns, taken)) = awaiting_step.take() {
                if let Some(tm) = timing.as_mut() {
                    if tm.cmd_latency_s.len() < MAX_TIMING_RECORDS {
                        let lat = if src_ns > 0 {
                            (unix_now_ns() - src_ns) as f64 * 1e-9
                        } else {
                            f64::NAN
                        };
                        tm.cmd_latency_s.push((lat, taken.elapsed().as_secs_f64()));
                    }
                }
            }
            match sim.step(dt) {
                Ok(ev) => {
                    if ev > 0 {
                        lock_dirty = true;
                    }
                }
                Err(e) => {
                    let why = format!("step failed at t = {:.4} s: {e}", sim.state().t_s);
                    node_log!(Error, "{why}; holding the last state (reset to continue)");
                    ctl.step_failure = Some(why);
                    lock_dirty = true;
                }
            }
            n += 1;
            summary.steps += 1;
            if sim.state().deployed {
                match crate::solver::checks::jammed(sim.model(), sim.state(), &checks) {
                    Some(jam) => node_log!(Warn, "{jam}; holding the final state"),
                    None => node_log!(
                        Info,
                        "fully deployed at t = {:.3} s; holding the final state",
                        sim.state().t_s
                    ),
                }
                lock_dirty = true;
            }
        }
        if n == MAX_CATCHUP_STEPS {
            // Too far behind: drop the debt instead of spiralling.
            summary.overruns += 1;
            ctl.anchor_wall = Instant::now();
            ctl.anchor_sim = sim.state().t_s;
        }
        // 4. Publications.
        let now = Instant::now();
        let stamp = sim_stamp(sim.state().t_s);
        if lock_dirty || now >= next_lock {
            let msg = view.lock_status(&sim, &book, ctl.paused(), stamp, &frame_id);
            // Publish on change (anything but the stamp) and at 1 Hz.
            let key = publish::lock_key(&msg);
            if now >= next_lock || last_lock_key.as_ref() != Some(&key) {
                if let Some(r) = rec.as_mut() {
                    let w = r.write(
                        record::Topic::LockStatus,
                        &msg,
                        record::stamp_ns(sim.state().t_s),
                    );
                    record_failed(&mut rec, &mut rec_error, w);
                }
                if let Err(e) = ep.lock.publish(msg) {
                    node_log!(Warn, "lock_status publish: {e:?}");
                }
                last_lock_key = Some(key);
                next_lock = now + live.lock_period;
            }
            lock_dirty = false;
        }
        if now >= next_marker {
            let m = view.markers(&mut sim, stamp, &frame_id);
            if let Some(r) = rec.as_mut() {
                let w = r.write_markers(&m, record::stamp_ns(sim.state().t_s));
                record_failed(&mut rec, &mut rec_error, w);
            }
            ep.markers.publish_built(m);
            next_marker = now + live.marker_period;
        }
        // Close the recording's chunk every second: a kill loses at most that.
        if now >= next_flush {
            if let Some(r) = rec.as_mut() {
                let w = r.flush();
                record_failed(&mut rec, &mut rec_error, w);
            }
            next_flush = now + Duration::from_secs(1);
        }
        // 5. Sleep until the next thing to do.
        let mut wake = next_pub.min(next_lock).min(next_marker);
        if (!ctl.paused() || ep.action.executing())
            && !sim.state().deployed
            && ctl.step_failure.is_none()
        {
            let due = ctl.anchor_wall
                + Duration::from_secs_f64(
                    ((sim.state().t_s + dt - ctl.anchor_sim) / live.rtf).max(0.0),
                );
            wake = wake.min(due);
        }
        if let Some(d) = deadline {
            wake = wake.min(d);
        }
        // Services are polled at least every 20 ms.
        wake = wake.min(Instant::now() + Duration::from_millis(20));
        let sleep = tokio::time::sleep_until(TokioInstant::from_std(wake));
        tokio::select! {
            _ = sleep => {}
            // A command wakes the loop at once: read at the rate they come (a
            // keep-last-10 reader polled every 20 ms lost valid commands among
            // a flood), and in force sooner.
            r = ep.cmd.async_take() => {
                if let Some((v, src, taken)) = book_command(r, &mut book, CmdTopic::Force, |b, c| {
                    b.check(c, sim.model())
                }) {
                    pending.add(v, src, taken);
                }
                lock_dirty = true;
                continue;
            }
            r = ep.speed_cmd.async_take() => {
                if let Some((v, src, taken)) = book_command(r, &mut book, CmdTopic::Speed, |b, c| {
                    b.check_speed(c, sim.model(), live.max_speed_m_s)
                }) {
                    pending.add_speeds(v, src, taken);
                }
                lock_dirty = true;
                continue;
            }
            _ = sigint.recv() => break "SIGINT".into(),
            _ = sigterm.recv() => break "SIGTERM".into(),
        }
        // Tokio timers have 1 ms granularity: finish the last stretch precisely.
        if let Some(left) = wake.checked_duration_since(Instant::now()) {
            if left < Duration::from_millis(2) {
                while Instant::now() < wake {
                    std::hint::spin_loop();
                }
            }
        }
    };

    summary.sim_time_s = sim.state().t_s;
    summary.deployed = sim.state().deployed
        && crate::solver::checks::jammed(sim.model(), sim.state(), &checks).is_none();
    summary.accepted_commands = book.accepted;
    summary.rejected_commands = book.rejected;
    summary.stop_reason = stop_reason;
    // Final lock status so late joiners see the end state.
    let last = view.lock_status(
        &sim,
        &book,
        ctl.paused(),
        sim_stamp(sim.state().t_s),
        &frame_id,
    );
    if let Some(mut r) = rec.take() {
        let w = r
            .write(
                record::Topic::LockStatus,
                &last,
                record::stamp_ns(sim.state().t_s),
            )
            .and_then(|_| r.finish());
        match w {
            Ok(st) => node_log!(
                Info,
                "recorded {} messages to {} ({} bytes)",
                st.messages,
                st.path.display(),
                st.bytes
            ),
            Err(e) => rec_error = Some(e),
        }
    }
    let _ = ep.lock.publish(last);
    if let (Some(path), Some(tm)) = (a.timing.as_ref(), timing.as_ref()) {
        let report = timing_report(tm, &live, dt);
        if let Err(e) = std::fs::write(path, serde_json::to_string_pretty(&report).unwrap() + "\n")
        {
            node_log!(Warn, "cannot write {}: {e}", path.display());
        }
    }
    node_log!(Info,
        "stopped ({}) after {} steps, t = {:.3} s, deployed {}, commands accepted {} rejected {}, {} publications, {} overruns",
        summary.stop_reason,
        summary.steps,
        summary.sim_time_s,
        summary.deployed,
        summary.accepted_commands,
        summary.rejected_commands,
        summary.publications,
        summary.overruns
    );
    node_log!(Info, "solver stats: {}", sim.solver_stats().line());
    // Clean shutdown: endpoints, spinner, node, participant (peers see us leave).
    log::detach();
    drop(ep);
    node.stop_spinner();
    let _ = tokio::time::timeout(Duration::from_secs(3), spin).await;
    drop(node);
    drop(context);
    match rec_error {
        Some(e) => Err(NodeError::Run(e)),
        None => Ok(summary),
    }
}

/// After a recording error: say it once, stop recording (the run goes on and
/// ends with exit status 1).
fn record_failed(
    rec: &mut Option<record::Recorder>,
    err: &mut Option<String>,
    w: Result<(), String>,
) {
    if let Err(e) = w {
        node_log!(Warn, "{e}; recording stopped");
        *rec = None;
        *err = Some(e);
    }
}

/// Books one read of the command topic: a command is validated (counted,
/// logged once per kind of fault); a sample that could not be decoded is
/// counted as malformed (the reader has moved past it, so reading goes on).
/// Returns the valid command's (cable, tension or speed) list with its source
/// stamp (ns since the Unix epoch, 0 if none) and the time it was taken.
#[allow(clippy::type_complexity)]
fn book_command<M>(
    r: ros2_client::ReadResult<(M, ros2_client::MessageInfo)>,
    book: &mut CommandBook,
    topic: CmdTopic,
    check: impl FnOnce(&mut CommandBook, &M) -> (Option<Vec<(usize, f64)>>, Option<String>),
) -> Option<(Vec<(usize, f64)>, i64, Instant)> {
    match r {
        Ok((cmd, info)) => {
            let (ok, log) = check(book, &cmd);
            if let Some(l) = log {
                node_log!(Warn, "{l}");
            }
            let src = info.source_timestamp().map(|t| t.to_nanos()).unwrap_or(0);
            ok.map(|v| (v, src, Instant::now()))
        }
        Err(e) => {
            let why = match &e {
                ros2_client::ReadError::Deserialization { reason } => reason.clone(),
                other => format!("{other:?}"),
            };
            if let Some(l) = book.malformed(topic, &why, Instant::now()) {
                node_log!(Warn, "{l}");
            }
            None
        }
    }
}

fn percentile(v: &mut [f64], p: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let i = ((p / 100.0) * (v.len() - 1) as f64).round() as usize;
    v[i.min(v.len() - 1)]
}

fn timing_report(tm: &Timing, live: &Live, dt: f64) -> serde_json::Value {
    let (period, rate) = (live.pub_period.as_secs_f64(), live.rate_hz);
    let mut jitter: Vec<f64> = tm
        .publish_at
        .windows(2)
        .map(|w| (w[1].duration_since(w[0]).as_secs_f64() - period).abs())
        .collect();
    let mut e2e: Vec<f64> = tm
        .cmd_latency_s
        .iter()
        .map(|c| c.0)
        .filter(|x| x.is_finite())
        .collect();
    let mut take: Vec<f64> = tm.cmd_latency_s.iter().map(|c| c.1).collect();
    serde_json::json!({
        "rate_hz": rate,
        "rtf": live.rtf,
        "dt_s": dt,
        "step_period_wall_s": dt / live.rtf,
        "publications": tm.publish_at.len(),
        "publish_period_jitter_s": {
            "p50": percentile(&mut jitter.clone(), 50.0),
            "p99": percentile(&mut jitter.clone(), 99.0),
            "max": percentile(&mut jitter, 100.0),
        },
        "commands_applied": tm.cmd_latency_s.len(),
        "command_to_step_latency_s": {
            "definition": "sender's DDS source timestamp -> start of the first step using the command",
            "first": tm.cmd_latency_s.first().map(|c| c.0),
            "p50": percentile(&mut e2e.clone(), 50.0),
            "p99": percentile(&mut e2e.clone(), 99.0),
            "max": percentile(&mut e2e, 100.0),
        },
        "take_to_step_latency_s": {
            "p50": percentile(&mut take.clone(), 50.0),
            "p99": percentile(&mut take.clone(), 99.0),
            "max": percentile(&mut take, 100.0),
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        node: NodeArgs,
    }

    /// The distribution feature decides the Gid in ros_discovery_info (Humble
    /// 24 bytes, Iron and later 16: rmw_dds_common/msg/Gid.msg) and the
    /// default --markers-for (which, for Humble as for Jazzy, is the Marker
    /// with texture, uv_coordinates and mesh_file). CI runs this under both
    /// features.
    #[test]
    fn distribution_feature_selects_gid_and_marker_layout() {
        let a = Cli::parse_from(["x", "model.toml"]).node;
        assert_eq!(a.markers_for, BUILT_FOR);
        #[cfg(feature = "humble")]
        {
            assert_eq!(ros2_client::gid::GID_LENGTH, 24);
            assert_eq!(BUILT_FOR, Distro::Humble);
            assert_eq!(
                ros2_client::COMPILED_ROS_DISTRO,
                ros2_client::RosDistro::Humble
            );
        }
        #[cfg(feature = "jazzy")]
        {
            assert_eq!(ros2_client::gid::GID_LENGTH, 16);
            assert_eq!(BUILT_FOR, Distro::Jazzy);
            assert_eq!(
                ros2_client::COMPILED_ROS_DISTRO,
                ros2_client::RosDistro::Jazzy
            );
        }
        // QoS as tf2 and rcl make them (RustDDS does not announce History
        // in discovery, so the wire tests cannot see the depths)
        use ros2_client::ros2::policy;
        assert_eq!(qos::tf().history, History::KeepLast { depth: 100 });
        assert_eq!(qos::tf_static().history, History::KeepLast { depth: 1 });
        let depth = match ros2_client::builtin_topics::rosout::QOS.history() {
            Some(policy::History::KeepLast { depth }) => depth,
            _ => -1,
        };
        assert_eq!(
            depth, 1000,
            "rcl_qos_profile_rosout_default (vendor/PATCHES.md, P5)"
        );
        // --no-clock parses; the service mapping is detected unless forced
        let b = Cli::parse_from(["x", "m.toml", "--no-clock"]).node;
        assert!(b.no_clock && b.service_mapping.is_none());
    }
}
