//! The error type of the manager crate.

use thiserror::Error;

/// Everything that can go wrong in a manager.
#[derive(Debug, Error)]
pub enum ManagerError {
    /// A config file could not be read or is wrong; the message names the file, field and problem.
    #[error("{0}")]
    Config(String),
    /// Another node on the mesh already uses this node's name.
    #[error("{0}")]
    NameTaken(String),
    #[error(transparent)]
    Proto(#[from] mrmm_proto::ProtoError),
    #[error("zenoh: {0}")]
    Zenoh(#[source] mrmm_proto::BoxError),
    /// The journal or the chain state on disk could not be opened, read or written: `what` names
    /// the file and what was done.
    #[error("{what}: {source}")]
    Journal {
        what: String,
        #[source]
        source: mrmm_proto::BoxError,
    },
}

impl ManagerError {
    /// What went wrong with a file on disk (`what` names it), and why.
    pub fn journal(what: impl Into<String>, source: impl Into<mrmm_proto::BoxError>) -> Self {
        ManagerError::Journal { what: what.into(), source: source.into() }
    }

    pub fn zenoh(e: impl Into<mrmm_proto::BoxError>) -> Self {
        ManagerError::Zenoh(e.into())
    }
}
