//! What stops a node.

use mrmm_manager::ManagerError;
use mrmm_peer::PeerError;

#[derive(Debug, thiserror::Error)]
pub enum NodeError {
    /// The robot's driver stopped (or was ordered to crash: [`NodeError::crashed`]).
    #[error(transparent)]
    Robot(#[from] PeerError),
    /// The chain state in `state_dir` could not be opened (locked by another process, damaged).
    #[error("state_dir: {0}")]
    StateDir(#[source] ManagerError),
    /// The robot's mission host stopped: its chain state could not be written.
    #[error("mission host stopped: {0}")]
    Host(#[source] ManagerError),
    /// The robot's traffic deputy stopped.
    #[error("traffic deputy stopped: {0}")]
    Deputy(#[source] ManagerError),
    /// The VDA 5050 gateway cannot start (its config names the problem).
    #[error("vda5050: {0}")]
    Gateway(String),
    /// A task of the node panicked.
    #[error("robot task: {0}")]
    Task(#[source] tokio::task::JoinError),
}

impl NodeError {
    /// Whether the robot stopped because it was ordered to crash.
    pub fn crashed(&self) -> bool {
        matches!(self, NodeError::Robot(PeerError::Crashed(_)))
    }
}

/// What goes wrong with a node started as a child process ([`crate::procs`]).
#[derive(Debug, thiserror::Error)]
pub enum ProcError {
    #[error("cannot locate the mrmm executable: {0}")]
    NoExe(#[source] std::io::Error),
    #[error("cannot create {}: {source}", path.display())]
    Log { path: std::path::PathBuf, source: std::io::Error },
    #[error("cannot start a child mrmm process: {0}")]
    Spawn(#[source] std::io::Error),
    #[error("child stdout not captured")]
    NoStdout,
    #[error("child exited before it was ready: {0}")]
    Exited(String),
    #[error("child not ready after {0} s: {1}")]
    NotReady(u64, String),
}
