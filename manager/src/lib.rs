//! mrmm managers: the system manager (a pure state machine, [`system`]) and the central node that
//! drives it over Zenoh ([`central`]).

pub mod agent;
pub mod chain;
pub mod central;
pub mod client;
pub mod error;
pub mod host;
pub mod mission;
pub mod planner_service;
pub mod system;

pub use error::ManagerError;
