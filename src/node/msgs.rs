//! Wire types: plain serde structs whose field order is the .msg order (CDR is
//! positional). The custom types mirror `msg/*.msg`; `tests/node_msgs.rs` parses
//! those files and checks them against [`CUSTOM_FIELDS`] and the structs' own
//! serde field lists, field by field.

use ros2_client::builtin_interfaces::Time;
use ros2_client::Message;
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Header {
    pub stamp: Time,
    pub frame_id: String,
}

#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize, PartialEq)]
pub struct Point {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize, PartialEq)]
pub struct Vector3 {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize, PartialEq)]
pub struct Quaternion {
    pub x: f64,
    pub y: f64,
    pub z: f64,
    pub w: f64,
}

#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize, PartialEq)]
pub struct Pose {
    pub position: Point,
    pub orientation: Quaternion,
}

#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize, PartialEq)]
pub struct ColorRGBA {
    pub r: f32,
    pub g: f32,
    pub b: f32,
    pub a: f32,
}

/// builtin_interfaces/Duration.
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize, PartialEq)]
pub struct RosDuration {
    pub sec: i32,
    pub nanosec: u32,
}

/// sensor_msgs/msg/JointState.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct JointState {
    pub header: Header,
    pub name: Vec<String>,
    pub position: Vec<f64>,
    pub velocity: Vec<f64>,
    pub effort: Vec<f64>,
}
impl Message for JointState {}

/// rosgraph_msgs/msg/Clock.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Clock {
    pub clock: Time,
}
impl Message for Clock {}

/// truss_deploy/msg/TrussState (msg/TrussState.msg).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct TrussState {
    pub header: Header,
    pub joint_names: Vec<String>,
    pub positions: Vec<Point>,
    pub velocities: Vec<Vector3>,
    pub deploy_fraction: f64,
    pub remaining_dof: u32,
}
impl Message for TrussState {}

/// truss_deploy/msg/LockStatus (msg/LockStatus.msg).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct LockStatus {
    pub header: Header,
    pub names: Vec<String>,
    pub locked: Vec<bool>,
    pub time_s: Vec<f64>,
    pub impulse_ns: Vec<f64>,
    pub energy_lost_j: Vec<f64>,
    pub deployed: bool,
    pub paused: bool,
    pub cable_names: Vec<String>,
    pub cable_tensions_n: Vec<f64>,
    pub accepted_commands: u32,
    pub rejected_commands: u32,
    pub rejected_unknown_cable: u32,
    pub rejected_mismatched_lengths: u32,
    pub rejected_bad_tension: u32,
}
impl Message for LockStatus {}

/// truss_deploy/msg/CableForceCommand (msg/CableForceCommand.msg).
#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
pub struct CableForceCommand {
    pub names: Vec<String>,
    pub tensions_n: Vec<f64>,
}
impl Message for CableForceCommand {}

/// The custom types as the Rust side declares them: (type, [(field, .msg type)]),
/// in struct order. Kept by hand next to the structs; the test compares it both
/// with the .msg files and with the structs' serde field names.
pub const CUSTOM_FIELDS: &[(&str, &[(&str, &str)])] = &[
    (
        "CableForceCommand",
        &[("names", "string[]"), ("tensions_n", "float64[]")],
    ),
    (
        "LockStatus",
        &[
            ("header", "std_msgs/Header"),
            ("names", "string[]"),
            ("locked", "bool[]"),
            ("time_s", "float64[]"),
            ("impulse_ns", "float64[]"),
            ("energy_lost_j", "float64[]"),
            ("deployed", "bool"),
            ("paused", "bool"),
            ("cable_names", "string[]"),
            ("cable_tensions_n", "float64[]"),
            ("accepted_commands", "uint32"),
            ("rejected_commands", "uint32"),
            ("rejected_unknown_cable", "uint32"),
            ("rejected_mismatched_lengths", "uint32"),
            ("rejected_bad_tension", "uint32"),
        ],
    ),
    (
        "TrussState",
        &[
            ("header", "std_msgs/Header"),
            ("joint_names", "string[]"),
            ("positions", "geometry_msgs/Point[]"),
            ("velocities", "geometry_msgs/Vector3[]"),
            ("deploy_fraction", "float64"),
            ("remaining_dof", "uint32"),
        ],
    ),
];

/// std_srvs/srv/Trigger request (an empty ROS struct carries one dummy byte).
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct TriggerRequest {
    pub structure_needs_at_least_one_member: u8,
}
impl Message for TriggerRequest {}

/// std_srvs/srv/Trigger response.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct TriggerResponse {
    pub success: bool,
    pub message: String,
}
impl Message for TriggerResponse {}

/// visualization_msgs/msg/Marker as of ROS 2 Iron/Jazzy (with texture, uv and
/// mesh_file fields). Humble's layout is [`MarkerHumble`].
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct MarkerJazzy {
    pub header: Header,
    pub ns: String,
    pub id: i32,
    pub type_: i32,
    pub action: i32,
    pub pose: Pose,
    pub scale: Vector3,
    pub color: ColorRGBA,
    pub lifetime: RosDuration,
    pub frame_locked: bool,
    pub points: Vec<Point>,
    pub colors: Vec<ColorRGBA>,
    pub texture_resource: String,
    pub texture: CompressedImage,
    pub uv_coordinates: Vec<UvCoordinate>,
    pub text: String,
    pub mesh_resource: String,
    pub mesh_file: MeshFile,
    pub mesh_use_embedded_materials: bool,
}

/// visualization_msgs/msg/Marker as of ROS 2 Humble.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct MarkerHumble {
    pub header: Header,
    pub ns: String,
    pub id: i32,
    pub type_: i32,
    pub action: i32,
    pub pose: Pose,
    pub scale: Vector3,
    pub color: ColorRGBA,
    pub lifetime: RosDuration,
    pub frame_locked: bool,
    pub points: Vec<Point>,
    pub colors: Vec<ColorRGBA>,
    pub text: String,
    pub mesh_resource: String,
    pub mesh_use_embedded_materials: bool,
}

#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct CompressedImage {
    pub header: Header,
    pub format: String,
    pub data: Vec<u8>,
}

#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize)]
pub struct UvCoordinate {
    pub u: f32,
    pub v: f32,
}

#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct MeshFile {
    pub filename: String,
    pub data: Vec<u8>,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct MarkerArrayJazzy {
    pub markers: Vec<MarkerJazzy>,
}
impl Message for MarkerArrayJazzy {}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct MarkerArrayHumble {
    pub markers: Vec<MarkerHumble>,
}
impl Message for MarkerArrayHumble {}

impl Default for Header {
    fn default() -> Self {
        Header {
            stamp: Time::ZERO,
            frame_id: String::new(),
        }
    }
}

impl From<MarkerJazzy> for MarkerHumble {
    fn from(m: MarkerJazzy) -> Self {
        MarkerHumble {
            header: m.header,
            ns: m.ns,
            id: m.id,
            type_: m.type_,
            action: m.action,
            pose: m.pose,
            scale: m.scale,
            color: m.color,
            lifetime: m.lifetime,
            frame_locked: m.frame_locked,
            points: m.points,
            colors: m.colors,
            text: m.text,
            mesh_resource: m.mesh_resource,
            mesh_use_embedded_materials: m.mesh_use_embedded_materials,
        }
    }
}

/// Simulation time (s) as a ROS time stamp.
pub fn sim_stamp(t_s: f64) -> Time {
    let ns = (t_s.max(0.0) * 1e9).round() as i64;
    Time::new((ns / 1_000_000_000) as i32, (ns % 1_000_000_000) as u32)
}

/// Seconds of a ROS time stamp.
pub fn stamp_s(t: &Time) -> f64 {
    t.to_nanos() as f64 * 1e-9
}
