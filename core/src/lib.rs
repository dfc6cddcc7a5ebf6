//! mrmm's decisions: every machine of the fleet as a pure state machine, with no I/O — no Zenoh,
//! no async runtime, no database, no crypto, no ROS (CI checks `cargo tree -p mrmm-core`). Each
//! machine is module `x` with `x::Event`, `x::Command` and `X::handle(now, Event) -> Vec<Command>`
//! ([`machine::Machine`]); the drivers (`mrmm-manager`, `mrmm-peer`) and the seeded simulations (`mrmm-sim`) run these
//! same machines. The machines live in wings by the node that runs them: [`robot`] (the robot,
//! its plan executor and barriers), [`mission`] (mission managers, their chain replication and
//! the host that runs them), [`central`] (system manager and advising agent), [`traffic`]; the
//! bodies in [`body`]; the edges every node shares beside them ([`edge`], [`egress`], [`ask`]).
//!
//! | machine | what it decides | driven by |
//! |---|---|---|
//! | [`central::system::SystemManager`] | membership, operator commands, mission lifecycle; composes three machines of its own: the registry (`central/system/fleet.rs`), controls and releases (`central/system/controls.rs`), recovery (`central/system/recovery.rs`) | `mrmm_manager::central` |
//! | [`central::agent::Agent`] | advice to the operator, its own moves (`act`) | `mrmm_manager::central` |
//! | [`central::CentralCore`] | the two above, composed | `mrmm_manager::central` |
//! | [`mission::MissionManager`] | one mission's teams, plans, metrics | `mrmm_manager::host` |
//! | [`mission::chain::Replica`], [`mission::chain::Registry`] | chain replication of mission managers | `mrmm_manager::host` |
//! | [`mission::host::HostCore`] | the missions a node replicates and leads; whom it trusts with their chains (`mission/host/trust.rs`) | `mrmm_manager::host` |
//! | [`robot::Robot`] | one robot: commands, plans, its body | `mrmm_peer::runtime` |
//! | [`robot::executor::Executor`] | a plan's steps and team barriers ([`robot::barrier`]) | [`robot::Robot`] |
//! | [`traffic::Traffic`] | who may drive which lanes of a navigation graph: grants, deadlocks broken | [`traffic::authority::Authority`] (in [`central::CentralCore`] and [`traffic::deputy::Deputy`]), `mrmm_sim::traffic` |
// Functions outside tests are at most 80 lines (clippy.toml); tests may be longer.
#![cfg_attr(not(test), deny(clippy::too_many_lines))]

pub mod ask;
pub mod body;
pub mod central;
pub mod edge;
pub mod egress;
pub mod machine;
pub mod maps;
pub mod mission;
pub mod observer;
pub mod robot;
pub mod roll_call;
pub mod timeouts;
pub mod traffic;

/// Why a request to another node has no result.
#[derive(Debug, Clone, PartialEq)]
pub struct Failure {
    /// Nobody answered (the node died, or is unreachable), or the answer's code says so: asking
    /// again may work.
    pub retryable: bool,
    pub error: String,
    /// The code of the other side's error, if it gave one.
    pub code: Option<mrmm_proto::ErrorCode>,
}

impl Failure {
    /// No answer (or one worth asking again for).
    pub fn retry(error: impl Into<String>) -> Failure {
        Failure { retryable: true, error: error.into(), code: None }
    }

    /// A final answer.
    pub fn fatal(error: impl Into<String>) -> Failure {
        Failure { retryable: false, error: error.into(), code: None }
    }

    /// The other side's error as it answered it: final, unless it refused the sender for now
    /// (worth re-sending).
    pub fn answered(e: mrmm_proto::ErrorReply) -> Failure {
        Failure { retryable: e.is(mrmm_proto::ErrorCode::Refused), error: e.error, code: e.code }
    }

    pub fn is(&self, code: mrmm_proto::ErrorCode) -> bool {
        self.code == Some(code)
    }

    /// The failure as an answer to the operator: the other side's code as it gave it; else busy
    /// when nobody answered (asking again may work), a conflict when the other side refused.
    pub fn reply(self) -> mrmm_proto::ErrorReply {
        use mrmm_proto::ErrorCode;
        let code = self.code.unwrap_or(if self.retryable { ErrorCode::Busy } else { ErrorCode::Conflict });
        mrmm_proto::ErrorReply::coded(code, self.error)
    }
}

impl From<mrmm_proto::QueryError> for Failure {
    fn from(e: mrmm_proto::QueryError) -> Self {
        match e {
            mrmm_proto::QueryError::Remote(reply) => Failure::answered(reply),
            e => Failure { retryable: e.retryable(), error: e.to_string(), code: None },
        }
    }
}

/// The instant `secs` seconds after the epoch: tests write their times as numbers.
#[cfg(test)]
pub(crate) fn at(secs: f64) -> mrmm_proto::Time {
    mrmm_proto::Time::from_secs(secs)
}

#[cfg(test)]
mod tests {
    use super::*;
    use mrmm_proto::{ErrorCode, ErrorReply, QueryError};

    /// Whether a failure is worth another try is read from the answer's code, never its words.
    #[test]
    fn a_refusal_is_retried_by_its_code() {
        let refused = Failure::from(QueryError::Remote(ErrorReply::coded(ErrorCode::Refused, "r1 may not take plans from h1 yet")));
        assert!(refused.retryable && refused.is(ErrorCode::Refused));
        let worded = Failure::from(QueryError::Remote(ErrorReply::from("refused: r1 may not take plans from h1 yet")));
        assert!(!worded.retryable && worded.code.is_none());
        assert!(Failure::from(QueryError::NoAnswer { key: "k".into(), ms: 10 }).retryable);
        // On the wire: the code when there is one, and old answers (no code) still read.
        assert_eq!(serde_json::to_string(&ErrorReply::from("x")).expect("json"), r#"{"error":"x"}"#);
        assert_eq!(serde_json::to_string(&ErrorReply::coded(ErrorCode::TakenOver, "x")).expect("json"), r#"{"error":"x","code":"taken_over"}"#);
        let old: ErrorReply = serde_json::from_str(r#"{"error":"x"}"#).expect("old answer");
        assert_eq!(old.code, None);
    }
}
