//! A node's edge, shared by every machine: a message as its driver received it ([`Incoming`]) and
//! why one did not become an event of the machine ([`Refused`]). Each machine translates what it
//! hears itself (`Robot::ingress`, `host::ingress`), in the drivers and the simulations alike.

use std::fmt;

use mrmm_proto::{self as proto, Sender};

/// Why a message did not become an event.
#[derive(Debug, Clone, PartialEq)]
pub enum Refused {
    /// The message needs a proven sender and has none (no seal, or one that does not verify).
    Unproven { what: &'static str },
    /// Its proven sender may not send it (a robot speaking for another, …).
    NotEntitled { from: Sender, what: String },
    /// Its payload is not what its key promises (`why` names it).
    Malformed { what: &'static str, why: String },
    /// Nothing this robot listens to is on that key.
    Unexpected { key: String },
}

impl fmt::Display for Refused {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Refused::Unproven { what } => write!(f, "{what} without a proven sender"),
            Refused::NotEntitled { from, what } => write!(f, "{from} may not {what}"),
            Refused::Malformed { why, .. } => f.write_str(why),
            Refused::Unexpected { key } => write!(f, "nothing is expected on {key}"),
        }
    }
}

/// A message as the driver received it.
#[derive(Debug, Clone, Copy)]
pub struct Incoming<'a> {
    pub key: &'a str,
    pub payload: &'a [u8],
    /// A put (or a liveliness token appearing) rather than a delete (a token gone).
    pub put: bool,
    /// The sender its seal proves (liveliness tokens carry none).
    pub from: Option<&'a Sender>,
}

/// A JSON payload as `T`, or why not.
pub(crate) fn json<T: serde::de::DeserializeOwned>(what: &'static str, payload: &[u8]) -> Result<T, Refused> {
    proto::from_json(what, payload).map_err(|e| Refused::Malformed { what, why: e.to_string() })
}

/// A robot's telemetry at rest, for the edges' tests.
#[cfg(test)]
pub(crate) fn telemetry(id: &str) -> mrmm_proto::Telemetry {
    mrmm_proto::Telemetry {
        id: id.into(),
        seq: 1,
        t: 0.0,
        pose: mrmm_proto::Pose::default(),
        velocity: mrmm_proto::Velocity::default(),
        behaviour: mrmm_proto::Behaviour::Hold,
        mission: None,
        progress: None,
        admitted: vec![],
        stuck: None,
        info_rev: 0,
    }
}
