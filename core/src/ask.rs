//! A node's questions to others, as they go on the network — a key, a payload, who may answer,
//! how long to wait ([`Ask`]) — with what the answer becomes (`then`: each machine's own, which
//! turns the answer's JSON into the machine's event). The drivers ask Zenoh; the simulations
//! route the same `Ask` to whoever serves its key.

use mrmm_proto::{Key, NodeId, RobotId, Role, Sender};
use serde_json::Value;

use crate::Failure;

/// A question to another node.
#[derive(Debug, Clone, PartialEq)]
pub struct Ask<T> {
    pub key: Key,
    /// The question's JSON body, if it has one.
    pub payload: Option<Vec<u8>>,
    /// How long to wait for an answer; `None`: the node's default query timeout.
    pub timeout_s: Option<f64>,
    /// Only an answer from such a sender counts (a stranger answering first is refused and the
    /// wait goes on).
    pub answerer: Answerer,
    /// What the answer becomes.
    pub then: T,
}

/// Who may answer a question.
#[derive(Debug, Clone, PartialEq)]
pub enum Answerer {
    /// That robot.
    Robot(RobotId),
    /// The mission host of that node.
    Host(NodeId),
    /// One of these mission hosts (a mission's chain, as last reported).
    Managers(Vec<NodeId>),
    /// A planner service (central runs one).
    Planner,
}

impl Answerer {
    /// Whether an answer proven from `s` counts.
    pub fn admits(&self, s: &Sender) -> bool {
        match self {
            Answerer::Robot(id) => s.is(Role::Robot, id.as_str()),
            Answerer::Host(node) => s.id == *node && s.role.hosts_missions(),
            Answerer::Managers(nodes) => s.role.hosts_missions() && nodes.iter().any(|n| *n == s.id),
            Answerer::Planner => mrmm_proto::policy::allows(mrmm_proto::policy::Act::PlanAnswer, s.role, mrmm_proto::policy::Relation::Stranger),
        }
    }
}

impl<T> Ask<T> {
    /// A question on `key` with `body` as its JSON; `None` (logged) if it cannot be encoded,
    /// which no type of the protocol does.
    pub fn json<B: serde::Serialize>(key: Key, body: &B, timeout_s: Option<f64>, answerer: Answerer, then: T) -> Option<Ask<T>> {
        match mrmm_proto::to_json(body) {
            Ok(payload) => Some(Ask { key, payload: Some(payload), timeout_s, answerer, then }),
            Err(e) => {
                tracing::warn!("cannot encode for {key}: {e}");
                None
            }
        }
    }
}

/// An answer's JSON as `T`, or why not (a final failure: the answerer said something else).
pub fn decode<T: serde::de::DeserializeOwned>(key: &str, answer: Result<Value, Failure>) -> Result<T, Failure> {
    serde_json::from_value(answer?).map_err(|e| Failure::fatal(format!("the answer on {key} is not what it should be: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_the_named_answerers_count() {
        let robot = Sender::new(Role::Robot, "r1");
        let host = Sender::new(Role::Host, "h1");
        assert!(Answerer::Robot("r1".into()).admits(&robot));
        assert!(!Answerer::Robot("r2".into()).admits(&robot));
        assert!(!Answerer::Robot("h1".into()).admits(&host), "a host named like the robot is not the robot");
        assert!(Answerer::Host("h1".into()).admits(&host));
        assert!(Answerer::Managers(vec!["r1".into()]).admits(&robot), "a robot's mission host answers as the robot");
        assert!(!Answerer::Managers(vec!["h2".into()]).admits(&host));
        assert!(!Answerer::Planner.admits(&host));
        assert!(Answerer::Planner.admits(&Sender::new(Role::Central, "central")));
        assert!(!Answerer::Host("h1".into()).admits(&Sender::new(Role::Operator, "h1")));
    }
}
