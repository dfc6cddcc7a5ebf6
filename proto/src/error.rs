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
    /// A query got no usable answer.
    #[error(transparent)]
    Query(#[from] QueryError),
}

impl ProtoError {
    /// Wraps a zenoh error (zenoh's errors are boxed trait objects).
    pub fn zenoh(e: impl std::fmt::Display) -> Self {
        ProtoError::Zenoh(e.to_string())
    }
}

/// Why a query has no usable answer.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum QueryError {
    /// Nobody answered in time (nobody serves the key, or it is unreachable): worth retrying.
    #[error("no answer on {key} within {ms} ms")]
    NoAnswer { key: String, ms: u128 },
    /// The other side answered with an error (final, unless its code says otherwise).
    #[error("{0}")]
    Remote(crate::operator::ErrorReply),
    /// The answer is not what the key promises.
    #[error("bad answer on {key}: {why}")]
    Decode { key: String, why: String },
    #[error("query {key}: {why}")]
    Zenoh { key: String, why: String },
}

impl QueryError {
    /// Whether asking again later may succeed (nobody answered), as opposed to a final answer.
    pub fn retryable(&self) -> bool {
        matches!(self, QueryError::NoAnswer { .. } | QueryError::Zenoh { .. })
    }
}
