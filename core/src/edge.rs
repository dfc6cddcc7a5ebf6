//! A node's edge, shared by every machine: a message as its driver received it ([`Incoming`]) and
//! why one did not become an event of the machine ([`Refused`]) — types of the protocol crate,
//! which the sessions use too — and the translations every machine shares. Each machine
//! translates what it hears itself (`Robot::ingress`, `host::ingress`), in the drivers and the
//! simulations alike.

use mrmm_proto::policy::{may_publish, Publication};
use mrmm_proto::{self as proto, MissionView, Sender};

pub use mrmm_proto::edge::{Incoming, Proof, Refused};

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
