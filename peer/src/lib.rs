//! mrmm robot peer: the robot's configuration, its body (simulated, or a ROS 2 robot), plan execution with team
//! barriers ([`executor`], [`barrier`]), the robot as a state machine ([`robot`]) and the runtime
//! that drives it over Zenoh ([`runtime`]).
//!
//! A robot is a Zenoh peer. It registers with the system manager through a liveliness token and an
//! info queryable, streams telemetry, and executes commands (see `mrmm_proto::keys`).

pub mod barrier;
pub mod body;
pub mod config;
pub mod drive;
pub mod error;
pub mod executor;
pub mod kept;
pub mod nav_goals;
pub mod robot;
pub mod ros_body;
pub mod runtime;
pub mod viewers;

pub use error::PeerError;
