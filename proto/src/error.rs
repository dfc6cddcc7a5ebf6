//! The error type of the protocol crate.

use thiserror::Error;

/// Everything that can go wrong on the wire or while reading a config.
#[derive(Debug, Error)]
pub enum ProtoError {
    /// A config file could not be read or is wrong; the message names the file, field and problem.
    #[error("{0}")]
    Config(String),
    #[error("invalid id {0:?}: use 1 to 64 characters of A-Z a-z 0-9 _ -")]
    BadId(String),
    #[error("cannot decode payload: {0}")]
    Decode(String),
    #[error("cannot encode payload: {0}")]
    Encode(String),
    #[error("zenoh: {0}")]
    Zenoh(String),
    /// A query got no usable answer (see [`crate::net::QueryError`]).
    #[error(transparent)]
    Query(#[from] crate::net::QueryError),
}

impl ProtoError {
    /// Wraps a zenoh error (zenoh's errors are boxed trait objects).
    pub fn zenoh(e: impl std::fmt::Display) -> Self {
        ProtoError::Zenoh(e.to_string())
    }
}
