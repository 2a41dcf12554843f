//! The ROS 2 node (feature `ros`): messages, DDS with ros2-client, the
//! Cyclone DDS and Fast DDS peers, the ROS 2 conventions (node_ros), MCAP recording.
#![cfg(feature = "ros")]

/// The ROS_DOMAIN_ID of test slot `slot` (0..32) in this test process: each
/// test that runs a node has its own slot, so parallel tests never share a
/// domain (they did: node_dds's and node_fastdds's formulas could meet). The
/// process id spreads concurrent test processes over 7 blocks of 32; every id
/// stays <= 224, whose RTPS ports are below 65536.
/// Slots: node_dds 0-3 and 22, node_fastdds 4, node_cyclone 5, record_mcap 6-9, node_ros 10-21.
/// The four-unit mast's `/joint_states` names: each scissor hinge and
/// sleeve, then the drive cable's motor.
pub const MAST_JOINTS: [&str; 9] = [
    "U1",
    "S1",
    "U2",
    "S2",
    "U3",
    "S3",
    "U4",
    "S4",
    "drive_motor",
];

pub fn domain(slot: u16) -> u16 {
    assert!(slot < 32, "domain slot {slot}");
    1 + (std::process::id() as u16 % 7) * 32 + slot
}

/// A pantograph mast that stays taut under speed control: started at 30 deg
/// (near the flat start the cable goes slack at a constant reel-in speed) and
/// damped (node_dds, and the Cyclone and Fast DDS peers' speed phase).
/// Written once per test process.
pub fn taut_mast() -> String {
    static PATH: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    PATH.get_or_init(|| {
        let path = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
            .join(format!("speed_mast_{}.toml", std::process::id()));
        let st = std::process::Command::new(env!("CARGO_BIN_EXE_truss-deploy"))
            .args([
                "generate",
                "mast",
                "--start-deg",
                "30",
                "--damping",
                "0.5",
                "-o",
            ])
            .arg(&path)
            .stdout(std::process::Stdio::null())
            .status()
            .expect("run generate mast");
        assert!(st.success(), "generate mast: {st}");
        path.display().to_string()
    })
    .clone()
}

mod node_cyclone;
mod node_dds;
mod node_fastdds;
mod node_msgs;
mod node_ros;
mod record_mcap;
