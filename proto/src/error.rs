//! The error type of the protocol crate.

use thiserror::Error;

/// An underlying error of any kind, kept as the source of ours (zenoh's errors are of this type).
pub type BoxError = Box<dyn std::error::Error + Send + Sync + 'static>;

/// Everything that can go wrong on the wire or while reading a config.
#[derive(Debug, Error)]
pub enum ProtoError {
    /// A config file could not be read or is wrong; the message names the file, field and problem.
    #[error("{0}")]
    Config(String),
    #[error("invalid id {0:?}: use 1 to 64 characters of A-Z a-z 0-9 _ -")]
    BadId(String),
    /// A payload that is not what its key promises: `what` it should be, and why not.
    #[error("cannot decode payload: {what}: {source}")]
    Decode {
        what: String,
        #[source]
        source: BoxError,
    },
    #[error("cannot encode payload: {0}")]
    Encode(#[source] BoxError),
    #[error("zenoh: {0}")]
    Zenoh(#[source] BoxError),
    /// Central's routers cannot be reached at `at`.
    #[error("zenoh: cannot reach central at {at}: {source}")]
    Unreachable {
        at: String,
        #[source]
        source: BoxError,
    },
    /// A query got no usable answer.
    #[error(transparent)]
    Query(#[from] QueryError),
}

impl ProtoError {
    /// Wraps a zenoh error (zenoh's errors are boxed trait objects), or says what went wrong.
    pub fn zenoh(e: impl Into<BoxError>) -> Self {
        ProtoError::Zenoh(e.into())
    }

    /// A payload that is not `what` it should be, and why (an error of its own, or words).
    pub fn decode(what: impl Into<String>, why: impl Into<BoxError>) -> Self {
        ProtoError::Decode { what: what.into(), source: why.into() }
    }

    /// A value that could not be encoded.
    pub fn encode(e: impl Into<BoxError>) -> Self {
        ProtoError::Encode(e.into())
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
