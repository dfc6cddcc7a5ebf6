//! mrmm's decisions: every machine of the fleet as a pure state machine, with no I/O — no Zenoh,
//! no async runtime, no database, no crypto, no ROS (CI checks `cargo tree -p mrmm-core`). Each
//! machine is module `x` with `x::Event`, `x::Command` and `X::handle(now, Event) -> Vec<Command>`;
//! the drivers (`mrmm-manager`, `mrmm-peer`) and the seeded simulations (`mrmm-sim`) run these
//! same machines.
//!
//! | machine | what it decides | driven by |
//! |---|---|---|
//! | [`system::SystemManager`] | membership, operator commands, mission lifecycle | `mrmm_manager::central` |
//! | [`agent::Agent`] | advice to the operator, its own moves (`act`) | `mrmm_manager::central` |
//! | [`central::CentralCore`] | the two above, composed | `mrmm_manager::central` |
//! | [`mission::MissionManager`] | one mission's teams, plans, metrics | `mrmm_manager::host` |
//! | [`chain::Replica`], [`chain::Registry`] | chain replication of mission managers | `mrmm_manager::host` |
//! | [`host::HostCore`] | the missions a node replicates and leads | `mrmm_manager::host` |
//! | [`robot::Robot`] | one robot: commands, plans, its body | `mrmm_peer::runtime` |
//! | [`executor::Executor`] | a plan's steps and team barriers ([`barrier`]) | [`robot::Robot`] |

pub mod agent;
pub mod barrier;
pub mod body;
pub mod central;
pub mod chain;
pub mod drive;
pub mod executor;
pub mod host;
pub mod maps;
pub mod mission;
pub mod nav_goals;
pub mod planning;
pub mod robot;
pub mod ros_body;
pub mod system;
pub mod viewers;
pub mod wire;

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
