//! Recording the node's topics as a ROS 2 MCAP file (rosbag2's storage format
//! since Iron), without ROS on the machine: `simulate --mcap FILE` records an
//! offline run, `node --record FILE` records what the node publishes.
//!
//! What goes into the file, as rosbag2's MCAP storage plugin writes it:
//! - header profile `ros2`;
//! - one schema per type, encoding `ros2msg`: the type's .msg text followed, for
//!   every type it uses (depth-first, each once, dependencies sorted by name), by a
//!   line of 80 `=`, a line `MSG: pkg/Type` and that type's .msg text;
//! - one channel per topic, message encoding `cdr`, metadata
//!   `offered_qos_profiles`: the publisher's QoS as rosbag2's YAML list with enum
//!   numbers (the form every rosbag2 since Humble reads: a file without a
//!   `rosbag2` metadata record is decoded as metadata version 8);
//! - messages whose data is the DDS payload the node's publisher sends (the same
//!   serializer, [`encode_cdr`]), log time = publish time = simulation time;
//! - chunks (lz4), message indexes, chunk indexes and statistics in the summary.
//!
//! A chunk is closed every [`Recorder::flush`] (the node does it every second of
//! wall time): a killed process leaves a file whose complete chunks a linear
//! reader decodes; a finished file (SIGINT, SIGTERM, --max-wall-s, end of run)
//! has the summary and footer and opens in any reader.

use super::commands::CommandBook;
use super::msgs::*;
use super::publish::View;
use super::Distro;
use crate::solver::Simulator;
use ros2_client::dds::rustdds::no_key::SerializerAdapter;
use ros2_client::dds::rustdds::CDRSerializerAdapter;
use serde::Serialize;
use std::collections::{BTreeMap, BTreeSet};
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

/// The payload a ros2-client `Publisher<M>` puts on the wire, which is what a
/// ROS 2 MCAP message holds: the 2-byte representation identifier (CDR little
/// endian), 2 option bytes (0) and the CDR body, serialized by the very adapter
/// the publisher's DataWriter uses (`DataWriterCdr<M>`).
pub fn encode_cdr<M: Serialize>(msg: &M, out: &mut Vec<u8>) -> Result<(), String> {
    let body = <CDRSerializerAdapter<M> as SerializerAdapter<M>>::to_bytes(msg)
        .map_err(|e| format!("CDR serialization: {e}"))?;
    let rep = <CDRSerializerAdapter<M> as SerializerAdapter<M>>::output_encoding();
    out.clear();
    out.extend_from_slice(&rep.to_bytes());
    out.extend_from_slice(&[0, 0]);
    out.extend_from_slice(&body);
    Ok(())
}

/// .msg texts of the standard types the node publishes (ROS 2 Jazzy's
/// common_interfaces and rcl_interfaces, comments left out), keyed by the name
/// rosbag2 gives them after `MSG: `.
const STANDARD_MSGS: &[(&str, &str)] = &[
    ("builtin_interfaces/Time", "int32 sec\nuint32 nanosec\n"),
    ("builtin_interfaces/Duration", "int32 sec\nuint32 nanosec\n"),
    (
        "std_msgs/Header",
        "builtin_interfaces/Time stamp\nstring frame_id\n",
    ),
    (
        "std_msgs/ColorRGBA",
        "float32 r\nfloat32 g\nfloat32 b\nfloat32 a\n",
    ),
    ("geometry_msgs/Point", "float64 x\nfloat64 y\nfloat64 z\n"),
    ("geometry_msgs/Vector3", "float64 x\nfloat64 y\nfloat64 z\n"),
    (
        "geometry_msgs/Quaternion",
        "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n",
    ),
    ("geometry_msgs/Pose", "Point position\nQuaternion orientation\n"),
    (
        "geometry_msgs/Transform",
        "Vector3 translation\nQuaternion rotation\n",
    ),
    (
        "geometry_msgs/TransformStamped",
        "std_msgs/Header header\nstring child_frame_id\nTransform transform\n",
    ),
    (
        "tf2_msgs/TFMessage",
        "geometry_msgs/TransformStamped[] transforms\n",
    ),
    (
        "sensor_msgs/JointState",
        "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\nfloat64[] effort\n",
    ),
    (
        "sensor_msgs/CompressedImage",
        "std_msgs/Header header\nstring format\nuint8[] data\n",
    ),
    ("rosgraph_msgs/Clock", "builtin_interfaces/Time clock\n"),
    ("visualization_msgs/UVCoordinate", "float32 u\nfloat32 v\n"),
    ("visualization_msgs/MeshFile", "string filename\nuint8[] data\n"),
    ("visualization_msgs/MarkerArray", "Marker[] markers\n"),
    ("truss_deploy/TrussState", include_str!("../../msg/TrussState.msg")),
    ("truss_deploy/LockStatus", include_str!("../../msg/LockStatus.msg")),
    (
        "truss_deploy/CableForceCommand",
        include_str!("../../msg/CableForceCommand.msg"),
    ),
    (
        "truss_deploy/CableSpeedCommand",
        include_str!("../../msg/CableSpeedCommand.msg"),
    ),
];

/// visualization_msgs/Marker up to `colors`, the same in both layouts.
const MARKER_HEAD: &str = concat!(
    "int32 ARROW=0\nint32 CUBE=1\nint32 SPHERE=2\nint32 CYLINDER=3\n",
    "int32 LINE_STRIP=4\nint32 LINE_LIST=5\nint32 CUBE_LIST=6\nint32 SPHERE_LIST=7\nint32 POINTS=8\n",
    "int32 TEXT_VIEW_FACING=9\nint32 MESH_RESOURCE=10\nint32 TRIANGLE_LIST=11\nint32 ARROW_STRIP=12\n",
    "int32 ADD=0\nint32 MODIFY=0\nint32 DELETE=2\nint32 DELETEALL=3\n",
    "std_msgs/Header header\nstring ns\nint32 id\nint32 type\nint32 action\n",
    "geometry_msgs/Pose pose\ngeometry_msgs/Vector3 scale\nstd_msgs/ColorRGBA color\n",
    "builtin_interfaces/Duration lifetime\nbool frame_locked\n",
    "geometry_msgs/Point[] points\nstd_msgs/ColorRGBA[] colors\n",
);

/// The rest of visualization_msgs/Marker in the layout in use: with the
/// texture, uv and mesh_file fields ([`MarkerJazzy`], Humble and later) or without
/// ([`MarkerGalactic`], Foxy and Galactic).
fn marker_msg(markers: Distro) -> String {
    let tail = match markers {
        Distro::Jazzy | Distro::Humble => concat!(
            "string texture_resource\nsensor_msgs/CompressedImage texture\n",
            "UVCoordinate[] uv_coordinates\nstring text\nstring mesh_resource\n",
            "MeshFile mesh_file\nbool mesh_use_embedded_materials\n"
        ),
        Distro::Galactic => "string text\nstring mesh_resource\nbool mesh_use_embedded_materials\n",
    };
    format!("{MARKER_HEAD}{tail}")
}

const PRIMITIVES: &[&str] = &[
    "bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16", "int32",
    "uint32", "int64", "uint64", "string", "wstring",
];

/// Field types a .msg text uses, qualified with `package` where they are not:
/// the first word of every line that is not a comment, arrays and bounds cut off.
fn dependencies(text: &str, package: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    for line in text.lines() {
        let line = line.trim_start();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let Some(ty) = line.split_whitespace().next() else {
            continue;
        };
        let base = ty.split(['[', '<']).next().unwrap_or(ty);
        if PRIMITIVES.contains(&base) || base.is_empty() {
            continue;
        }
        out.insert(if base.contains('/') {
            base.to_string()
        } else {
            format!("{package}/{base}")
        });
    }
    out
}

/// The complete `ros2msg` definition of `root` ("pkg/Type") as rosbag2 writes
/// it: root text, then every dependency once (depth-first, sorted), each after
/// 80 `=` and `MSG: pkg/Type`. `lookup` gives a type's .msg text.
pub fn full_definition(
    root: &str,
    lookup: &dyn Fn(&str) -> Option<String>,
) -> Result<String, String> {
    fn rec(
        ty: &str,
        lookup: &dyn Fn(&str) -> Option<String>,
        seen: &mut BTreeSet<String>,
        depth: usize,
    ) -> Result<String, String> {
        if depth > 32 {
            return Err(format!("message definition of {ty} nests too deep"));
        }
        let text = lookup(ty).ok_or_else(|| format!("no message definition for {ty}"))?;
        let package = ty.split('/').next().unwrap_or("");
        let mut out = text.clone();
        for dep in dependencies(&text, package) {
            if seen.insert(dep.clone()) {
                // rosbag2 adds a line break before each delimiter (after the
                // text's own: an empty line between definitions)
                out.push('\n');
                out.push_str(&"=".repeat(80));
                out.push_str("\nMSG: ");
                out.push_str(&dep);
                out.push('\n');
                out.push_str(&rec(&dep, lookup, seen, depth + 1)?);
            }
        }
        Ok(out)
    }
    rec(root, lookup, &mut BTreeSet::new(), 0)
}

/// Definition of a type the node publishes, with the marker layout in use.
fn schema_text(root: &str, markers: Distro) -> Result<String, String> {
    let lookup = |ty: &str| -> Option<String> {
        if ty == "visualization_msgs/Marker" {
            return Some(marker_msg(markers));
        }
        STANDARD_MSGS
            .iter()
            .find(|(n, _)| *n == ty)
            .map(|(_, t)| t.to_string())
    };
    full_definition(root, &lookup)
}

/// One QoS profile in rosbag2's `offered_qos_profiles` YAML (enum numbers of
/// rmw: history 1 keep last; reliability 1 reliable, 2 best effort; durability
/// 1 transient local, 2 volatile; liveliness 1 automatic; unset durations as
/// RMW_DURATION_INFINITE, 9223372036 s 854775807 ns).
fn qos_yaml(depth: u32, reliable: bool, transient_local: bool) -> String {
    let inf = "\n    sec: 9223372036\n    nsec: 854775807";
    format!(
        "- history: 1\n  depth: {depth}\n  reliability: {}\n  durability: {}\n  deadline:{inf}\n  lifespan:{inf}\n  liveliness: 1\n  liveliness_lease_duration:{inf}\n  avoid_ros_namespace_conventions: false",
        if reliable { 1 } else { 2 },
        if transient_local { 1 } else { 2 },
    )
}

/// The recorded topics, in channel order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Topic {
    JointStates = 0,
    State = 1,
    LockStatus = 2,
    Markers = 3,
    Clock = 4,
    Tf = 5,
    TfStatic = 6,
}

/// The number of recorded topics ([`Topic`]).
pub const TOPICS: usize = 7;

/// (type, topic under the node's namespace as (sub-namespace, base), QoS YAML)
/// of every recorded topic under its resolved (and remapped) name, as
/// `create_endpoints` offers them (DESIGN.md).
fn topic_table(names: &super::Naming) -> Result<[(&'static str, String, String); TOPICS], String> {
    let name = |n: &str| names.full(n);
    Ok([
        (
            "sensor_msgs/msg/JointState",
            name("joint_states")?,
            qos_yaml(10, true, false),
        ),
        (
            "truss_deploy/msg/TrussState",
            name("truss/state")?,
            qos_yaml(10, true, false),
        ),
        (
            "truss_deploy/msg/LockStatus",
            name("truss/lock_status")?,
            qos_yaml(1, true, true),
        ),
        (
            "visualization_msgs/msg/MarkerArray",
            name("truss/markers")?,
            qos_yaml(1, true, false),
        ),
        // /clock stays global whatever the namespace
        (
            "rosgraph_msgs/msg/Clock",
            name("/clock")?,
            qos_yaml(1, false, false),
        ),
        // (as tf2's TransformBroadcaster and StaticTransformBroadcaster offer them)
        (
            "tf2_msgs/msg/TFMessage",
            name("/tf")?,
            qos_yaml(100, true, false),
        ),
        (
            "tf2_msgs/msg/TFMessage",
            name("/tf_static")?,
            qos_yaml(1, true, true),
        ),
    ])
}

/// Counts of a finished recording.
#[derive(Debug, Default, Clone, Serialize)]
pub struct RecordStats {
    pub path: PathBuf,
    pub messages: u64,
    /// per topic, in [`Topic`] order
    pub per_topic: [u64; TOPICS],
    pub bytes: u64,
}

/// An open MCAP file receiving the node's topics.
pub struct Recorder {
    writer: mcap::Writer<BufWriter<File>>,
    markers: Distro,
    channels: [u16; TOPICS],
    sequence: [u32; TOPICS],
    buf: Vec<u8>,
    stats: RecordStats,
}

impl Recorder {
    /// Creates `path` with the schemas and channels of the node's topics under
    /// namespace `ns` (normalized: "/" or "/a/b"), markers in layout `markers`.
    pub fn create(path: &Path, names: &super::Naming, markers: Distro) -> Result<Recorder, String> {
        let what = |e: &dyn std::fmt::Display| format!("recording {}: {e}", path.display());
        let file = File::create(path).map_err(|e| what(&e))?;
        let options = mcap::WriteOptions::new()
            .profile("ros2")
            .library(format!(
                "truss-deploy {} (mcap-rs)",
                env!("CARGO_PKG_VERSION")
            ))
            .compression(Some(mcap::Compression::Lz4))
            // Uncompressed bytes per chunk: a chunk closes at this size or at
            // every flush(), whichever comes first.
            .chunk_size(Some(256 * 1024));
        let mut writer = options.create(BufWriter::new(file)).map_err(|e| what(&e))?;
        let mut channels = [0u16; TOPICS];
        for (k, (ty, topic, qos)) in topic_table(names)?.iter().enumerate() {
            // "pkg/msg/Type" names the schema; definitions refer to "pkg/Type"
            let short = ty.replacen("/msg/", "/", 1);
            let text = schema_text(&short, markers)?;
            let schema = writer
                .add_schema(ty, "ros2msg", text.as_bytes())
                .map_err(|e| what(&e))?;
            let meta = BTreeMap::from([("offered_qos_profiles".to_string(), qos.clone())]);
            channels[k] = writer
                .add_channel(schema, topic, "cdr", &meta)
                .map_err(|e| what(&e))?;
        }
        Ok(Recorder {
            writer,
            markers,
            channels,
            sequence: [0; TOPICS],
            buf: Vec::with_capacity(4096),
            stats: RecordStats {
                path: path.to_path_buf(),
                ..RecordStats::default()
            },
        })
    }

    /// Writes `msg` on `topic` with log time = publish time = `stamp` (ns of
    /// simulation time).
    pub fn write<M: Serialize>(
        &mut self,
        topic: Topic,
        msg: &M,
        stamp_ns: u64,
    ) -> Result<(), String> {
        encode_cdr(msg, &mut self.buf)?;
        let k = topic as usize;
        let header = mcap::records::MessageHeader {
            channel_id: self.channels[k],
            sequence: self.sequence[k],
            log_time: stamp_ns,
            publish_time: stamp_ns,
        };
        self.writer
            .write_to_known_channel(&header, &self.buf)
            .map_err(|e| format!("recording {}: {e}", self.stats.path.display()))?;
        self.sequence[k] = self.sequence[k].wrapping_add(1);
        self.stats.per_topic[k] += 1;
        self.stats.messages += 1;
        Ok(())
    }

    /// Writes /truss/markers built by [`View::markers`] in the layout the file
    /// was created with (the node's `--markers-for`).
    pub fn write_markers(&mut self, m: &[MarkerJazzy], stamp_ns: u64) -> Result<(), String> {
        match self.markers {
            Distro::Jazzy | Distro::Humble => self.write(
                Topic::Markers,
                &MarkerArrayJazzy {
                    markers: m.to_vec(),
                },
                stamp_ns,
            ),
            Distro::Galactic => self.write(
                Topic::Markers,
                &MarkerArrayGalactic {
                    markers: m.iter().cloned().map(Into::into).collect(),
                },
                stamp_ns,
            ),
        }
    }

    /// Closes the open chunk (with its message index) and hands it to the OS:
    /// everything written so far survives a kill.
    pub fn flush(&mut self) -> Result<(), String> {
        self.writer
            .flush()
            .map_err(|e| format!("recording {}: {e}", self.stats.path.display()))
    }

    /// Writes the summary (schemas, channels, statistics, chunk indexes) and
    /// the footer.
    pub fn finish(mut self) -> Result<RecordStats, String> {
        let path = self.stats.path.clone();
        let what = |e: &dyn std::fmt::Display| format!("recording {}: {e}", path.display());
        self.writer.finish().map_err(|e| what(&e))?;
        let mut w = self.writer.into_inner();
        std::io::Write::flush(&mut w).map_err(|e| what(&e))?;
        let f = w.into_inner().map_err(|e| what(&e.error()))?;
        f.sync_all().map_err(|e| what(&e))?;
        self.stats.bytes = f.metadata().map(|m| m.len()).unwrap_or(0);
        Ok(self.stats)
    }
}

/// Nanoseconds of simulation time, as in the messages' stamps.
pub fn stamp_ns(t_s: f64) -> u64 {
    sim_stamp(t_s).to_nanos().max(0) as u64
}

/// `simulate --mcap`: the node's publications for an offline run. /tf_static
/// (the mount) once; /joint_states, /truss/state, /tf and /clock at the start, then every `period_s` of simulation
/// time (every step when `None`) and at the last state; /truss/markers as the
/// node publishes them, every [`MARKER_PERIOD_S`] (of simulation time here),
/// or at every publication when those are sparser, and at the last state;
/// /truss/lock_status at the start and on every change.
pub struct OfflineRecording {
    rec: Recorder,
    view: View,
    book: CommandBook,
    frame: String,
    period_s: Option<f64>,
    next_s: f64,
    next_marker_s: f64,
    last_t_s: f64,
    last_marker_t_s: f64,
    /// The joints recorded as /tf frames (the node's default `tf_frames`).
    tf_joints: Vec<usize>,
    /// What /truss/lock_status was last recorded for: (latch events, deployed,
    /// motor tensions). Offline, nothing else in it changes (no commands, no
    /// pause), so comparing these is comparing the message without building it.
    last_lock: Option<(usize, bool, Vec<f64>)>,
}

/// The frame of headers and markers (the node's default `--frame-id`).
pub const FRAME: &str = "truss";

/// The frame /tf_static mounts [`FRAME`] in (the node's default `parent_frame_id`).
pub const PARENT_FRAME: &str = "world";

/// The node's /truss/markers period (5 Hz, `launch_notes.md`). A MarkerArray
/// is 84 % of a ring recording's bytes at every step, and a 3D panel gains
/// nothing from more than a viewer's frame rate of them.
pub const MARKER_PERIOD_S: f64 = 0.2;

impl OfflineRecording {
    /// Opens `path` and records the initial state. `rate_hz`: publications per
    /// simulated second (None: every step).
    pub fn start(path: &Path, sim: &mut Simulator, rate_hz: Option<f64>) -> Result<Self, String> {
        if let Some(r) = rate_hz {
            if !(r.is_finite() && r > 0.0) {
                return Err(format!("--mcap-rate {r} must be a positive number of Hz"));
            }
        }
        let mut me = OfflineRecording {
            rec: Recorder::create(path, &super::Naming::plain("/"), Distro::Jazzy)?,
            view: View::new(sim.model()),
            book: CommandBook::default(),
            frame: FRAME.to_string(),
            period_s: rate_hz.map(|r| 1.0 / r),
            next_s: sim.state().t_s,
            next_marker_s: sim.state().t_s,
            last_t_s: f64::NAN,
            last_marker_t_s: f64::NAN,
            tf_joints: super::publish::tf_joint_indices(
                sim.model(),
                &super::publish::default_tf_joints(sim.model()),
            )?,
            last_lock: None,
        };
        let mount = super::publish::tf_mount(PARENT_FRAME, FRAME, sim_stamp(0.0));
        me.rec.write(Topic::TfStatic, &mount, 0)?;
        me.after_step(sim)?;
        Ok(me)
    }

    /// Records what the node would publish after this step.
    pub fn after_step(&mut self, sim: &mut Simulator) -> Result<(), String> {
        let t = sim.state().t_s;
        // a publication is due once t reaches next_s (to a nanosecond)
        if self.period_s.is_none() || t >= self.next_s - 1e-9 {
            self.publish(sim, false)?;
            if let Some(p) = self.period_s {
                self.next_s = next_multiple(self.next_s, p, t);
            }
        }
        self.lock_status(sim)
    }

    /// Records /clock, /joint_states, /truss/state and (when due, or `last`)
    /// /truss/markers for the current state.
    fn publish(&mut self, sim: &mut Simulator, last: bool) -> Result<(), String> {
        let t = sim.state().t_s;
        let stamp = sim_stamp(t);
        let ns = stamp_ns(t);
        let (js, st) = self.view.state_messages(sim, stamp, &self.frame);
        self.rec.write(Topic::Clock, &Clock { clock: stamp }, ns)?;
        self.rec.write(Topic::JointStates, &js, ns)?;
        self.rec.write(Topic::State, &st, ns)?;
        let tf = super::publish::tf_joints(sim, &self.tf_joints, stamp, &self.frame);
        self.rec.write(Topic::Tf, &tf, ns)?;
        self.last_t_s = t;
        if last || t >= self.next_marker_s - 1e-9 {
            self.markers(sim)?;
        }
        Ok(())
    }

    fn markers(&mut self, sim: &mut Simulator) -> Result<(), String> {
        let t = sim.state().t_s;
        let markers = self.view.markers(sim, sim_stamp(t), &self.frame);
        self.rec.write_markers(&markers, stamp_ns(t))?;
        self.next_marker_s = next_multiple(self.next_marker_s, MARKER_PERIOD_S, t);
        self.last_marker_t_s = t;
        Ok(())
    }

    fn lock_status(&mut self, sim: &Simulator) -> Result<(), String> {
        let s = sim.state();
        let same = self.last_lock.as_ref().is_some_and(|(n, d, c)| {
            *n == s.locks.len() && *d == s.deployed && *c == s.cable_tension_cmd_n
        });
        if !same {
            let t = s.t_s;
            let msg = self
                .view
                .lock_status(sim, &self.book, false, sim_stamp(t), &self.frame);
            self.rec.write(Topic::LockStatus, &msg, stamp_ns(t))?;
            self.last_lock = Some((s.locks.len(), s.deployed, s.cable_tension_cmd_n.clone()));
        }
        Ok(())
    }

    /// Records the last state (if not yet) and finishes the file.
    pub fn finish(mut self, sim: &mut Simulator) -> Result<RecordStats, String> {
        if self.last_t_s != sim.state().t_s {
            self.publish(sim, true)?;
        } else if self.last_marker_t_s != sim.state().t_s {
            self.markers(sim)?;
        }
        self.lock_status(sim)?;
        self.rec.finish()
    }
}

/// The first `next + k period` (k >= 0) after `t` (to a nanosecond): the next
/// due time of a periodic publication (steps need not divide the period).
fn next_multiple(next: f64, period: f64, t: f64) -> f64 {
    if next > t + 1e-9 {
        return next;
    }
    // (a closed form: a loop of `period` increments would spin for an
    // --mcap-rate far above the step rate)
    let k = ((t + 1e-9 - next) / period).floor() + 1.0;
    let n = next + k * period;
    if n > t + 1e-9 {
        n
    } else {
        n + period
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ros2_client::builtin_interfaces::Time;

    /// The recorder's bytes are the DDS payload: representation identifier
    /// CDR_LE (0x00 0x01), options 0, then the CDR body, whose layout is checked
    /// here by hand for a Clock (int32 sec, uint32 nanosec, little endian) and a
    /// JointState (header, then 4-byte aligned sequence lengths and 8-byte
    /// aligned doubles, alignment counted from the body's start).
    #[test]
    fn cdr_bytes_are_the_dds_payload() {
        let mut buf = Vec::new();
        encode_cdr(
            &Clock {
                clock: Time::new(3, 7),
            },
            &mut buf,
        )
        .unwrap();
        assert_eq!(buf, [0, 1, 0, 0, 3, 0, 0, 0, 7, 0, 0, 0]);
        let js = JointState {
            header: Header {
                stamp: Time::new(1, 2),
                frame_id: "ab".into(),
            },
            name: vec!["q".into()],
            position: vec![1.5],
            velocity: vec![],
            effort: vec![],
        };
        encode_cdr(&js, &mut buf).unwrap();
        let mut want = vec![0u8, 1, 0, 0];
        let body: Vec<u8> = [
            &1i32.to_le_bytes()[..],
            &2u32.to_le_bytes(),
            &3u32.to_le_bytes(), // "ab\0"
            b"ab\0",
            &[0],                // pad to 4
            &1u32.to_le_bytes(), // one name
            &2u32.to_le_bytes(),
            b"q\0",
            &[0, 0],             // pad to 4
            &1u32.to_le_bytes(), // one position
            // the double starts at body offset 32: 8-aligned, no padding
            &1.5f64.to_le_bytes(),
            &0u32.to_le_bytes(),
            &0u32.to_le_bytes(),
        ]
        .concat();
        want.extend(body);
        assert_eq!(buf, want);
    }

    /// rosbag2's layout of a complete definition, on the docs' example shape:
    /// root first, then each dependency once, depth-first in sorted order.
    #[test]
    fn full_definition_follows_rosbag2() {
        let lookup = |ty: &str| -> Option<String> {
            match ty {
                "a/Root" => Some("# c\nb/Mid m\nLocal l\nfloat64 x 0\nb/Mid[] ms\n".into()),
                "b/Mid" => Some("c/Leaf f\n".into()),
                "a/Local" => Some("c/Leaf f\nstring s\n".into()),
                "c/Leaf" => Some("uint8 v\n".into()),
                _ => None,
            }
        };
        let d = full_definition("a/Root", &lookup).unwrap();
        let sep = "=".repeat(80);
        let want = format!(
            "# c\nb/Mid m\nLocal l\nfloat64 x 0\nb/Mid[] ms\n\n{sep}\nMSG: a/Local\nc/Leaf f\nstring s\n\
\n{sep}\nMSG: c/Leaf\nuint8 v\n\n{sep}\nMSG: b/Mid\nc/Leaf f\n"
        );
        assert_eq!(d, want);
        assert!(full_definition("a/Missing", &lookup).is_err());
    }

    /// Every recorded type resolves to a complete definition (no type left
    /// without its text) in both marker layouts.
    #[test]
    fn every_schema_is_complete() {
        for distro in [Distro::Jazzy, Distro::Humble, Distro::Galactic] {
            for (ty, _, _) in topic_table(&crate::node::Naming::plain("/")).unwrap() {
                let short = ty.replacen("/msg/", "/", 1);
                let text = schema_text(&short, distro).unwrap();
                assert!(!text.is_empty());
            }
        }
        let m = schema_text("visualization_msgs/MarkerArray", Distro::Jazzy).unwrap();
        for t in [
            "MSG: visualization_msgs/Marker\n",
            "MSG: sensor_msgs/CompressedImage\n",
            "MSG: builtin_interfaces/Duration\n",
            "MSG: geometry_msgs/Quaternion\n",
        ] {
            assert_eq!(m.matches(t).count(), 1, "{t} once in\n{m}");
        }
    }
}
