//! The error type of the ROS 2 crate.

use thiserror::Error;

#[derive(Debug, Error)]
pub enum Ros2Error {
    /// A `body` section that cannot work; the message names the field and the problem.
    #[error("{0}")]
    Config(String),
    /// A message that is not the ROS 2 type `name` its topic carries.
    #[error("cannot decode ROS 2 message {name}: {source}")]
    Decode {
        name: String,
        #[source]
        source: mrmm_proto::BoxError,
    },
    #[error("cannot encode ROS 2 message {name}: {source}")]
    Encode {
        name: String,
        #[source]
        source: mrmm_proto::BoxError,
    },
    #[error("ROS 2 side (zenoh): {0}")]
    Zenoh(#[source] mrmm_proto::BoxError),
}

impl Ros2Error {
    pub fn zenoh(e: impl Into<mrmm_proto::BoxError>) -> Self {
        Ros2Error::Zenoh(e.into())
    }
}
