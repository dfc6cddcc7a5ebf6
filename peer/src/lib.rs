//! mrmm robot peer: the wire protocol, node configuration, the simulated body and the robot runtime.
//!
//! A robot is a Zenoh peer. It registers with the system manager through a liveliness token and an
//! info queryable, streams telemetry, and executes commands (see [`proto`] for the key space).

pub mod barrier;
pub mod body;
pub mod config;
pub mod error;
pub mod executor;
pub mod net;
pub mod proto;
pub mod robot;

pub use error::PeerError;
