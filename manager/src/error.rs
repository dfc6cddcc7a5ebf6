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
    Zenoh(String),
    /// The journal on disk could not be opened, read or written; the message names the file.
    #[error("{0}")]
    Journal(String),
}

impl ManagerError {
    pub fn zenoh(e: impl std::fmt::Display) -> Self {
        ManagerError::Zenoh(e.to_string())
    }
}
