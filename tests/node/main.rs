//! The ROS 2 node (feature `ros`): messages, DDS with ros2-client, the
//! Cyclone DDS and Fast DDS peers, MCAP recording.
#![cfg(feature = "ros")]

mod node_cyclone;
mod node_dds;
mod node_fastdds;
mod node_msgs;
mod record_mcap;
