//! The ROS 2 node (feature `ros`): messages, DDS with ros2-client, the
//! Cyclone DDS and Fast DDS peers, the ROS 2 conventions (node_ros), MCAP recording.
#![cfg(feature = "ros")]

mod node_cyclone;
mod node_dds;
mod node_fastdds;
mod node_msgs;
mod node_ros;
mod record_mcap;
