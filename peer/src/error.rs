//! The error type of the peer crate.

use thiserror::Error;

/// Everything that can go wrong in a robot peer.
#[derive(Debug, Error)]
pub enum PeerError {
    /// A config file could not be read or is wrong; the message names the file, field and problem.
    #[error("{0}")]
    Config(String),
    /// Another node on the mesh already uses this robot's id.
    #[error("{0}")]
    NameTaken(String),
    #[error(transparent)]
    Proto(#[from] mrmm_proto::ProtoError),
    #[error("zenoh: {0}")]
    Zenoh(#[source] mrmm_proto::BoxError),
    /// A simulated robot crashed on the operator's order (`mrmm op crash`).
    #[error("robot {0} crashed on the operator's order")]
    Crashed(String),
    /// Stopped (a signal) before it was on the mesh.
    #[error("{0}")]
    Stopped(String),
    /// The ROS 2 body could not start.
    #[error(transparent)]
    Ros2(#[from] mrmm_ros2::Ros2Error),
}

impl PeerError {
    /// Wraps a zenoh error (zenoh's errors are boxed trait objects).
    pub fn zenoh(e: impl Into<mrmm_proto::BoxError>) -> Self {
        PeerError::Zenoh(e.into())
    }
}
