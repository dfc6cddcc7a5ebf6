//! The protocol crate's errors: its own ([`ProtoError`]), and the one every reply error carries
//! on the wire ([`ErrorReply`], with its [`ErrorCode`]).

use serde::{Deserialize, Serialize};
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
    Remote(ErrorReply),
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

/// Error payload of every reply error: what went wrong in words, and for the errors an asker acts
/// on, a code — so that no node decides anything from the words.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ErrorReply {
    pub error: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub code: Option<ErrorCode>,
}

/// What an asker does about an error, as its code says. Every error central answers an
/// operator with carries one (docs/api.md lists them).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ErrorCode {
    /// What the request names (a robot, a mission, a map, a host) does not exist: do not ask
    /// again as it is.
    NotFound,
    /// The request itself is wrong (a malformed field, a recipe that does not parse, a value out
    /// of bounds): fix it.
    Invalid,
    /// The request is well formed but the fleet's state refuses it now (the name is taken, the
    /// robot is lost or in another mission, too few robots are idle): change the state or the
    /// request.
    Conflict,
    /// Central (or the node it asked) cannot answer now (just started, a robot or host did not
    /// answer in time): the same request may succeed if asked again in a moment.
    Busy,
    /// The sender may not ask this.
    Forbidden,
    /// The sender may not give this (yet): a robot refusing a plan from a head it was not
    /// admitted under. The head keeps re-sending.
    Refused,
    /// The query's seal was not proven (its tag was for an older certificate): ask again, signed.
    Unproven,
    /// The mission was taken over by another of its managers before its start was confirmed: it
    /// runs, elsewhere.
    TakenOver,
}

impl ErrorCode {
    /// Its name on the wire (`not_found`, `busy`, …).
    pub fn as_str(self) -> &'static str {
        match self {
            ErrorCode::NotFound => "not_found",
            ErrorCode::Invalid => "invalid",
            ErrorCode::Conflict => "conflict",
            ErrorCode::Busy => "busy",
            ErrorCode::Forbidden => "forbidden",
            ErrorCode::Refused => "refused",
            ErrorCode::Unproven => "unproven",
            ErrorCode::TakenOver => "taken_over",
        }
    }
}

impl ErrorReply {
    /// An error with a code.
    pub fn coded(code: ErrorCode, error: impl Into<String>) -> ErrorReply {
        ErrorReply { error: error.into(), code: Some(code) }
    }

    pub fn is(&self, code: ErrorCode) -> bool {
        self.code == Some(code)
    }

    /// [`ErrorCode::NotFound`].
    pub fn not_found(error: impl Into<String>) -> ErrorReply {
        ErrorReply::coded(ErrorCode::NotFound, error)
    }

    /// [`ErrorCode::Invalid`].
    pub fn invalid(error: impl Into<String>) -> ErrorReply {
        ErrorReply::coded(ErrorCode::Invalid, error)
    }

    /// [`ErrorCode::Conflict`].
    pub fn conflict(error: impl Into<String>) -> ErrorReply {
        ErrorReply::coded(ErrorCode::Conflict, error)
    }

    /// [`ErrorCode::Busy`].
    pub fn busy(error: impl Into<String>) -> ErrorReply {
        ErrorReply::coded(ErrorCode::Busy, error)
    }

    /// The same error, its words prefixed by `context` (`"{context}: {error}"`), its code kept.
    pub fn context(self, context: impl std::fmt::Display) -> ErrorReply {
        ErrorReply { error: format!("{context}: {}", self.error), code: self.code }
    }
}

impl From<String> for ErrorReply {
    fn from(error: String) -> ErrorReply {
        ErrorReply { error, code: None }
    }
}

impl From<&str> for ErrorReply {
    fn from(error: &str) -> ErrorReply {
        ErrorReply { error: error.to_string(), code: None }
    }
}

impl std::fmt::Display for ErrorReply {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.error)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A code's name is its name on the wire.
    #[test]
    fn error_codes_are_named_as_on_the_wire() {
        use ErrorCode::*;
        for c in [NotFound, Invalid, Conflict, Busy, Forbidden, Refused, Unproven, TakenOver] {
            assert_eq!(serde_json::to_value(c).expect("json"), serde_json::Value::String(c.as_str().into()));
        }
        let e: ErrorReply = serde_json::from_str(r#"{"error": "unknown robot \"r9\"", "code": "not_found"}"#).expect("reply");
        assert!(e.is(NotFound));
    }
}
