//! mrmm robot peer: the robot's configuration ([`config`]), what it keeps across restarts
//! ([`kept`]) and the runtime that drives its machine over Zenoh ([`runtime`]). The machine
//! itself (the robot, its body, plan execution with team barriers) is `mrmm_core::robot`.
//!
//! A robot is a Zenoh peer. It registers with the system manager through a liveliness token and an
//! info queryable, streams telemetry, and executes commands (see `mrmm_proto::keys`).
// Functions outside tests are at most 80 lines (clippy.toml); tests may be longer.
#![cfg_attr(not(test), deny(clippy::too_many_lines))]

pub mod config;
pub mod error;
pub mod kept;
pub mod runtime;

pub use error::PeerError;
