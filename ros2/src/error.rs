//! The error type of the ROS 2 crate.

use thiserror::Error;

#[derive(Debug, Error)]
pub enum Ros2Error {
    /// A `body` section that cannot work; the message names the field and the problem.
    #[error("{0}")]
    Config(String),
    #[error("cannot decode ROS 2 message {0}")]
    Decode(String),
    #[error("cannot encode ROS 2 message {0}")]
    Encode(String),
    #[error("ROS 2 side (zenoh): {0}")]
    Zenoh(String),
}

impl Ros2Error {
    pub fn zenoh(e: impl std::fmt::Display) -> Self {
        Ros2Error::Zenoh(e.to_string())
    }
}
