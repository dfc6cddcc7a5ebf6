//! mrmm robot peer: the robot's configuration, its body (simulated, or a ROS 2 robot), plan execution with team
//! barriers ([`executor`], [`barrier`]), the robot as a state machine ([`robot`]) and the runtime
//! that drives it over Zenoh ([`runtime`]).
//!
//! A robot is a Zenoh peer. It registers with the system manager through a liveliness token and an
//! info queryable, streams telemetry, and executes commands (see `mrmm_proto::keys`).

pub mod config;
pub mod error;
pub mod kept;
pub mod runtime;

pub use error::PeerError;
/// The robot's machines (`mrmm-core`), under the names the driver always used.
pub use mrmm_core::{barrier, body, drive, executor, nav_goals, robot, ros_body, viewers};
