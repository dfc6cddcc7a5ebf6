//! What a mission host hears on its subscriptions, translated at its edge: robots' telemetry,
//! chain messages, missions' status, and the liveliness of hosts, robots and planners become
//! [`Event`]s of the host's machine, or a [`Refused`] saying why not — with the protocol's one
//! publication policy, in the host's driver (`mrmm_manager::host`) and the simulations alike.
//! (Queries — starts, controls, views — are the driver's to hold; their payloads are checked by
//! the machine.)

use mrmm_proto::{self as proto, ChainEnvelope, Key};

use super::Event;
use crate::edge::{self, json, Incoming, Refused};

/// What a sealed message on `key` is (for the driver to prove its sender under that name), or
/// `None` for the liveliness tokens, which carry no seal.
pub fn sealed(key: &str) -> Option<&'static str> {
    match Key::parse(key)? {
        Key::RobotTelemetry(_) => Some("telemetry"),
        Key::HostChain(_) => Some("chain message"),
        Key::MissionStatus(_) => Some("mission status"),
        _ => None,
    }
}

/// Translates a publication or a liveliness change into the host machine's event.
pub fn ingress(m: Incoming<'_>) -> Result<Event, Refused> {
    let proven = |what: &'static str| m.from.cloned().ok_or(Refused::Unproven { what });
    let malformed = |what: &'static str, why: String| Refused::Malformed { what, why };
    match Key::parse(m.key) {
        Some(Key::RobotTelemetry(id)) => Ok(Event::Telemetry(Box::new(edge::telemetry(&m, &id)?))),
        Some(Key::HostChain(_)) => {
            let env: ChainEnvelope = json("chain message", m.payload)?;
            if proto::validate_id(&env.mission).is_err() || proto::validate_id(&env.from).is_err() {
                return Err(malformed("chain message", "a bad mission or node name".into()));
            }
            let from = proven("chain message")?;
            if !from.role.hosts_missions() {
                return Err(Refused::NotEntitled { from, what: "send chain messages".into() });
            }
            Ok(Event::Chain { envelope: Box::new(env), from })
        }
        Some(Key::MissionStatus(name)) => {
            let (view, from) = edge::mission_status(&m, &name)?;
            Ok(Event::MissionStatus { view: Box::new(view), from })
        }
        Some(Key::HostAlive(node)) => Ok(if m.put { Event::HostAlive(node) } else { Event::HostGone(node) }),
        Some(Key::RobotAlive(id)) => Ok(if m.put { Event::RobotAlive(id) } else { Event::RobotGone(id) }),
        Some(Key::PlannerAlive { kind, zid }) => Ok(if m.put { Event::PlannerAlive { kind, zid } } else { Event::PlannerGone { kind, zid } }),
        _ => Err(Refused::Unexpected { key: m.key.chars().take(200).collect() }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mrmm_proto::{Role, Sender};

    fn telemetry(id: &str) -> Vec<u8> {
        proto::encode_telemetry(&proto::Telemetry::resting(id, 0.0)).expect("telemetry")
    }

    #[test]
    fn a_host_hears_only_what_its_sender_may_say() {
        let (r1, r2) = (Sender::new(Role::Robot, "r1"), Sender::new(Role::Robot, "r2"));
        let key = Key::RobotTelemetry("r1".into()).to_string();
        let heard = |payload: &[u8], from: Option<&Sender>| ingress(Incoming { key: &key, payload, put: true, from });
        assert!(matches!(heard(&telemetry("r1"), Some(&r1)), Ok(Event::Telemetry(t)) if t.id == "r1"));
        // r2 speaking for r1, unsealed, on another robot's key, or garbage: refused.
        assert!(matches!(heard(&telemetry("r1"), Some(&r2)), Err(Refused::NotEntitled { .. })));
        assert!(matches!(heard(&telemetry("r1"), None), Err(Refused::Unproven { .. })));
        assert!(matches!(heard(&telemetry("r2"), Some(&r2)), Err(Refused::Malformed { .. })));
        assert!(matches!(heard(b"MRM3\xff", Some(&r1)), Err(Refused::Malformed { .. })));
        // Chain messages only from nodes that host missions.
        let env = ChainEnvelope { mission: "p".into(), from: "op".into(), msg: mrmm_proto::chain::Msg::Grant { epoch: 1 } };
        let payload = serde_json::to_vec(&env).expect("json");
        let key = Key::HostChain("h1".into()).to_string();
        let op = Sender::new(Role::Operator, "op");
        assert!(matches!(ingress(Incoming { key: &key, payload: &payload, put: true, from: Some(&op) }), Err(Refused::NotEntitled { .. })));
        assert!(matches!(ingress(Incoming { key: &key, payload: &payload, put: true, from: Some(&r1) }), Ok(Event::Chain { .. })));
        // Tokens carry no seal.
        let alive = Key::RobotAlive("r1".into()).to_string();
        assert_eq!(sealed(&alive), None);
        assert_eq!(sealed(&key), Some("chain message"));
        assert_eq!(ingress(Incoming { key: &alive, payload: b"", put: false, from: None }), Ok(Event::RobotGone("r1".into())));
    }
}
