//! mrmm managers: every decision of the system's managers as a pure state machine, and the thin
//! drivers that run them over Zenoh.
//!
//! | machine | what it decides | driver |
//! |---|---|---|
//! | [`system::SystemManager`] | membership, operator commands, mission lifecycle | [`central`] |
//! | [`agent::Agent`] | advice to the operator, its own moves (`act`) | [`central`] |
//! | [`central::CentralCore`] | the two above, composed | [`central`] |
//! | [`mission::MissionManager`] | one mission's team, plans, metrics | [`host`] |
//! | [`chain::Replica`], [`chain::Registry`] | chain replication of mission managers | [`host`] |
//! | [`host::HostCore`] | the missions a node replicates and leads | [`host`] |
//!
//! Each machine is module `x` with `x::Event`, `x::Command` and `X::handle(now, Event) ->
//! Vec<Command>`; the simulations in `sim/` drive these same machines.

pub mod agent;
pub mod central;
pub mod chain;
pub mod error;
pub mod host;
pub mod inbox;
pub mod journal;
pub mod maps;
pub mod mission;
pub mod planner_service;
pub mod site_router;
pub mod system;
pub mod wire;

pub use error::ManagerError;

/// Why a request to another node has no result.
#[derive(Debug, Clone, PartialEq)]
pub struct Failure {
    /// Nobody answered (the node died, or is unreachable): asking again may work.
    pub retryable: bool,
    pub error: String,
}

impl From<mrmm_proto::QueryError> for Failure {
    fn from(e: mrmm_proto::QueryError) -> Self {
        Failure { retryable: e.retryable(), error: e.to_string() }
    }
}
