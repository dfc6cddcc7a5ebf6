//! A node's edge, shared by every machine: a message as its driver received it ([`Incoming`]) and
//! why one did not become an event of the machine ([`Refused`]). Each machine translates what it
//! hears itself (`Robot::ingress`, `host::ingress`), in the drivers and the simulations alike.

use std::fmt;

use mrmm_proto::policy::{may_publish, Publication};
use mrmm_proto::{self as proto, MissionView, Sender};

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

/// Telemetry published on robot `id`'s key: decoded, of that robot, and from that robot.
pub(crate) fn telemetry(m: &Incoming<'_>, id: &str) -> Result<proto::Telemetry, Refused> {
    let t = proto::decode_telemetry(m.payload).map_err(|e| Refused::Malformed { what: "telemetry", why: e.to_string() })?;
    if t.id != id {
        return Err(Refused::Malformed { what: "telemetry", why: format!("telemetry of {:?} published on {}", t.id, m.key) });
    }
    let from = m.from.cloned().ok_or(Refused::Unproven { what: "telemetry" })?;
    may_publish(Publication::Telemetry(id), &from).map_err(|what| Refused::NotEntitled { from, what })?;
    Ok(t)
}

/// Mission `name`'s status, with the node that published it.
pub(crate) fn mission_status(m: &Incoming<'_>, name: &str) -> Result<(MissionView, Sender), Refused> {
    let view: MissionView = json("mission status", m.payload)?;
    if view.name != name {
        return Err(Refused::Malformed { what: "mission status", why: format!("the status of {:?} published on {}", view.name, m.key) });
    }
    let from = m.from.cloned().ok_or(Refused::Unproven { what: "mission status" })?;
    Ok((view, from))
}
