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

/// geometry_msgs/msg/Transform.
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize, PartialEq)]
pub struct Transform {
    pub translation: Vector3,
    pub rotation: Quaternion,
}

/// geometry_msgs/msg/TransformStamped.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct TransformStamped {
    pub header: Header,
    pub child_frame_id: String,
    pub transform: Transform,
}

/// tf2_msgs/msg/TFMessage (/tf and /tf_static).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct TFMessage {
    pub transforms: Vec<TransformStamped>,
}
impl Message for TFMessage {}

/// truss_deploy/msg/TrussState (msg/TrussState.msg).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct TrussState {
    pub header: Header,
    pub joint_names: Vec<String>,
    pub positions: Vec<Point>,
    pub velocities: Vec<Vector3>,
    pub deploy_fraction: f64,
    pub remaining_dof: u32,
    pub cable_names: Vec<String>,
    pub motor_tensions_n: Vec<f64>,
    pub reeled_in_m: Vec<f64>,
    pub motor_modes: Vec<String>,
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
    pub rejected_malformed: u32,
    pub rejected_bad_speed: u32,
}
impl Message for LockStatus {}

/// truss_deploy/msg/CableForceCommand (msg/CableForceCommand.msg).
#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
pub struct CableForceCommand {
    pub names: Vec<String>,
    pub tensions_n: Vec<f64>,
}
impl Message for CableForceCommand {}

/// truss_deploy/msg/CableSpeedCommand (msg/CableSpeedCommand.msg).
#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
pub struct CableSpeedCommand {
    pub names: Vec<String>,
    pub speeds_m_s: Vec<f64>,
}
impl Message for CableSpeedCommand {}

/// The custom types as the Rust side declares them: (type, [(field, .msg type)]),
/// in struct order. Kept by hand next to the structs; the test compares it both
/// with the .msg files and with the structs' serde field names.
pub const CUSTOM_FIELDS: &[(&str, &[(&str, &str)])] = &[
    (
        "CableForceCommand",
        &[("names", "string[]"), ("tensions_n", "float64[]")],
    ),
    (
        "CableSpeedCommand",
        &[("names", "string[]"), ("speeds_m_s", "float64[]")],
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
            ("rejected_malformed", "uint32"),
            ("rejected_bad_speed", "uint32"),
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
            ("cable_names", "string[]"),
            ("motor_tensions_n", "float64[]"),
            ("reeled_in_m", "float64[]"),
            ("motor_modes", "string[]"),
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

// ---- simulation_interfaces 2.x (tests/data/simulation_interfaces-2.1.0) ----

/// simulation_interfaces/msg/Result.
#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
pub struct SimResult {
    pub result: u8,
    pub error_message: String,
}

/// simulation_interfaces/msg/SimulationState.
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize, PartialEq)]
pub struct SimulationState {
    pub state: u8,
}

/// simulation_interfaces/msg/SimulatorFeatures.
#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
pub struct SimulatorFeatures {
    pub features: Vec<u16>,
    pub spawn_formats: Vec<String>,
    pub custom_info: String,
}

/// An empty ROS request (GetSimulatorFeatures, GetSimulationState): one dummy byte.
#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
pub struct EmptyRequest {
    pub structure_needs_at_least_one_member: u8,
}
impl Message for EmptyRequest {}

#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
pub struct GetSimulatorFeaturesResponse {
    pub features: SimulatorFeatures,
}
impl Message for GetSimulatorFeaturesResponse {}

#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
pub struct GetSimulationStateResponse {
    pub state: SimulationState,
    pub result: SimResult,
}
impl Message for GetSimulationStateResponse {}

#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
pub struct SetSimulationStateRequest {
    pub state: SimulationState,
}
impl Message for SetSimulationStateRequest {}

/// The response of SetSimulationState, ResetSimulation and StepSimulation: one Result.
#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
pub struct ResultResponse {
    pub result: SimResult,
}
impl Message for ResultResponse {}

#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
pub struct ResetSimulationRequest {
    pub scope: u8,
}
impl Message for ResetSimulationRequest {}

#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
pub struct StepSimulationRequest {
    pub steps: u64,
}
impl Message for StepSimulationRequest {}

/// The SimulateSteps action (simulation_interfaces/action/SimulateSteps.action)
/// and action_msgs, as rcl_action puts them on the wire: a goal id is
/// unique_identifier_msgs/UUID (uint8[16]).
pub mod action {
    use super::*;

    pub type GoalId = [u8; 16];

    /// SimulateSteps_SendGoal request: goal id, then the goal (uint64 steps).
    #[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
    pub struct SendGoalRequest {
        pub goal_id: GoalId,
        pub steps: u64,
    }
    impl Message for SendGoalRequest {}

    #[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
    pub struct SendGoalResponse {
        pub accepted: bool,
        pub stamp: Time,
    }
    impl Message for SendGoalResponse {}

    /// action_msgs/GoalInfo.
    #[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
    pub struct GoalInfo {
        pub goal_id: GoalId,
        pub stamp: Time,
    }

    /// action_msgs/srv/CancelGoal request.
    #[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
    pub struct CancelGoalRequest {
        pub goal_info: GoalInfo,
    }
    impl Message for CancelGoalRequest {}

    #[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
    pub struct CancelGoalResponse {
        pub return_code: i8,
        pub goals_canceling: Vec<GoalInfo>,
    }
    impl Message for CancelGoalResponse {}
    pub const CANCEL_ERROR_NONE: i8 = 0;
    pub const CANCEL_ERROR_UNKNOWN_GOAL_ID: i8 = 2;
    pub const CANCEL_ERROR_GOAL_TERMINATED: i8 = 3;

    /// SimulateSteps_GetResult request.
    #[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
    pub struct GetResultRequest {
        pub goal_id: GoalId,
    }
    impl Message for GetResultRequest {}

    /// SimulateSteps_GetResult response: the goal's status, then the result
    /// (one simulation_interfaces/Result).
    #[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
    pub struct GetResultResponse {
        pub status: i8,
        pub result: SimResult,
    }
    impl Message for GetResultResponse {}

    /// SimulateSteps_FeedbackMessage: goal id, then the feedback.
    #[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
    pub struct FeedbackMessage {
        pub goal_id: GoalId,
        pub completed_steps: u64,
        pub remaining_steps: u64,
    }
    impl Message for FeedbackMessage {}

    /// action_msgs/GoalStatus.
    #[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
    pub struct GoalStatus {
        pub goal_info: GoalInfo,
        pub status: i8,
    }

    /// action_msgs/GoalStatusArray.
    #[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
    pub struct GoalStatusArray {
        pub status_list: Vec<GoalStatus>,
    }
    impl Message for GoalStatusArray {}

    pub const STATUS_UNKNOWN: i8 = 0;
    pub const STATUS_ACCEPTED: i8 = 1;
    pub const STATUS_EXECUTING: i8 = 2;
    pub const STATUS_CANCELING: i8 = 3;
    pub const STATUS_SUCCEEDED: i8 = 4;
    pub const STATUS_CANCELED: i8 = 5;
    pub const STATUS_ABORTED: i8 = 6;
}

/// Constants of simulation_interfaces 2.x used by the node (checked against the
/// .msg/.srv text by tests/node_msgs.rs).
pub mod sim_if {
    pub const RESULT_FEATURE_UNSUPPORTED: u8 = 0;
    pub const RESULT_OK: u8 = 1;
    pub const RESULT_INCORRECT_STATE: u8 = 3;
    pub const RESULT_OPERATION_FAILED: u8 = 4;
    pub const STATE_STOPPED: u8 = 0;
    pub const STATE_PLAYING: u8 = 1;
    pub const STATE_PAUSED: u8 = 2;
    /// SetSimulationState response extra result.
    pub const ALREADY_IN_TARGET_STATE: u8 = 101;
    pub const SCOPE_DEFAULT: u8 = 0;
    pub const SCOPE_TIME: u8 = 1;
    pub const SCOPE_STATE: u8 = 2;
    pub const SCOPE_ALL: u8 = 255;
    pub const SIMULATION_RESET: u16 = 20;
    pub const SIMULATION_STATE_GETTING: u16 = 24;
    pub const SIMULATION_STATE_SETTING: u16 = 25;
    pub const SIMULATION_STATE_PAUSE: u16 = 26;
    pub const STEP_SIMULATION_SINGLE: u16 = 31;
    pub const STEP_SIMULATION_MULTIPLE: u16 = 32;
    pub const STEP_SIMULATION_ACTION: u16 = 33;
    /// (file, constant, value) for the test against the published text.
    pub const ALL: &[(&str, &str, i64)] = &[
        (
            "Result.msg",
            "RESULT_FEATURE_UNSUPPORTED",
            RESULT_FEATURE_UNSUPPORTED as i64,
        ),
        ("Result.msg", "RESULT_OK", RESULT_OK as i64),
        (
            "Result.msg",
            "RESULT_INCORRECT_STATE",
            RESULT_INCORRECT_STATE as i64,
        ),
        (
            "Result.msg",
            "RESULT_OPERATION_FAILED",
            RESULT_OPERATION_FAILED as i64,
        ),
        ("SimulationState.msg", "STATE_STOPPED", STATE_STOPPED as i64),
        ("SimulationState.msg", "STATE_PLAYING", STATE_PLAYING as i64),
        ("SimulationState.msg", "STATE_PAUSED", STATE_PAUSED as i64),
        (
            "SetSimulationState.srv",
            "ALREADY_IN_TARGET_STATE",
            ALREADY_IN_TARGET_STATE as i64,
        ),
        ("ResetSimulation.srv", "SCOPE_DEFAULT", SCOPE_DEFAULT as i64),
        ("ResetSimulation.srv", "SCOPE_TIME", SCOPE_TIME as i64),
        ("ResetSimulation.srv", "SCOPE_STATE", SCOPE_STATE as i64),
        ("ResetSimulation.srv", "SCOPE_ALL", SCOPE_ALL as i64),
        (
            "SimulatorFeatures.msg",
            "SIMULATION_RESET",
            SIMULATION_RESET as i64,
        ),
        (
            "SimulatorFeatures.msg",
            "SIMULATION_STATE_GETTING",
            SIMULATION_STATE_GETTING as i64,
        ),
        (
            "SimulatorFeatures.msg",
            "SIMULATION_STATE_SETTING",
            SIMULATION_STATE_SETTING as i64,
        ),
        (
            "SimulatorFeatures.msg",
            "SIMULATION_STATE_PAUSE",
            SIMULATION_STATE_PAUSE as i64,
        ),
        (
            "SimulatorFeatures.msg",
            "STEP_SIMULATION_ACTION",
            STEP_SIMULATION_ACTION as i64,
        ),
        (
            "SimulatorFeatures.msg",
            "STEP_SIMULATION_SINGLE",
            STEP_SIMULATION_SINGLE as i64,
        ),
        (
            "SimulatorFeatures.msg",
            "STEP_SIMULATION_MULTIPLE",
            STEP_SIMULATION_MULTIPLE as i64,
        ),
    ];
}

/// The simulation_interfaces types as the Rust side declares them:
/// (file, part, [(field, type)]) where part is "msg", "request" or "response".
pub const SIM_IF_FIELDS: &[(&str, &str, &[(&str, &str)])] = &[
    (
        "Result.msg",
        "msg",
        &[("result", "uint8"), ("error_message", "string")],
    ),
    ("SimulationState.msg", "msg", &[("state", "uint8")]),
    (
        "SimulatorFeatures.msg",
        "msg",
        &[
            ("features", "uint16[]"),
            ("spawn_formats", "string[]"),
            ("custom_info", "string"),
        ],
    ),
    ("GetSimulatorFeatures.srv", "request", &[]),
    (
        "GetSimulatorFeatures.srv",
        "response",
        &[("features", "SimulatorFeatures")],
    ),
    ("GetSimulationState.srv", "request", &[]),
    (
        "GetSimulationState.srv",
        "response",
        &[("state", "SimulationState"), ("result", "Result")],
    ),
    (
        "SetSimulationState.srv",
        "request",
        &[("state", "SimulationState")],
    ),
    (
        "SetSimulationState.srv",
        "response",
        &[("result", "Result")],
    ),
    ("ResetSimulation.srv", "request", &[("scope", "uint8")]),
    ("ResetSimulation.srv", "response", &[("result", "Result")]),
    ("StepSimulation.srv", "request", &[("steps", "uint64")]),
    ("StepSimulation.srv", "response", &[("result", "Result")]),
];

/// visualization_msgs/msg/Marker as of ROS 2 Humble, Iron and Jazzy (with the
/// texture, uv and mesh_file fields added by common_interfaces 3.0.0, 2021).
/// Foxy's and Galactic's layout is [`MarkerGalactic`].
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

/// visualization_msgs/msg/Marker as of ROS 2 Foxy and Galactic (before the
/// texture, uv and mesh_file fields).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct MarkerGalactic {
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
pub struct MarkerArrayGalactic {
    pub markers: Vec<MarkerGalactic>,
}
impl Message for MarkerArrayGalactic {}

impl Default for Header {
    fn default() -> Self {
        Header {
            stamp: Time::ZERO,
            frame_id: String::new(),
        }
    }
}

impl From<MarkerJazzy> for MarkerGalactic {
    fn from(m: MarkerJazzy) -> Self {
        MarkerGalactic {
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
