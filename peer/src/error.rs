//! The error type of the peer crate.

use thiserror::Error;

/// Everything that can go wrong in a robot peer or on the wire.
#[derive(Debug, Error)]
pub enum PeerError {
    /// A config file could not be read or is wrong; the message names the file, field and problem.
    #[error("{0}")]
    Config(String),
    #[error("invalid robot id {0:?}: use 1 to 64 characters of A-Z a-z 0-9 _ -")]
    BadId(String),
    #[error("cannot decode payload: {0}")]
    Decode(String),
    #[error("cannot encode payload: {0}")]
    Encode(String),
    #[error("zenoh: {0}")]
    Zenoh(String),
}

impl PeerError {
    /// Wraps a zenoh error (zenoh's errors are boxed trait objects).
    pub fn zenoh(e: impl std::fmt::Display) -> Self {
        PeerError::Zenoh(e.to_string())
    }
}
