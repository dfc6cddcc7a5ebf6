//! What a mission host hears on its subscriptions, translated at its edge: robots' telemetry,
//! chain messages, missions' status, and the liveliness of hosts, robots and planners become
//! [`Event`]s of the host's machine, or a [`Refused`] saying why not — with the protocol's one
//! publication policy, in the host's driver (`mrmm_manager::host`) and the simulations alike.
//! Questions to it — starts, controls, views, marginal values — are translated here too
//! ([`question`]); the driver holds each under an id until the machine answers it.

use mrmm_proto::{self as proto, ChainEnvelope, Key, Sender};

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
        Some(Key::RobotTelemetry(id)) => Ok(Event::Telemetry(Box::new(edge::telemetry(&m, id.as_str())?))),
        Some(Key::HostChain(_)) => {
            let env: ChainEnvelope = json("chain message", m.payload)?;
            if proto::validate_id(env.mission.as_str()).is_err() || proto::validate_id(env.from.as_str()).is_err() {
                return Err(malformed("chain message", "a bad mission or node name".into()));
            }
            let from = proven("chain message")?;
            // Whether the sender is the mission's to speak of is the host's to say (`trust.rs`);
            // a role the policy never lets send chain messages is refused here.
            if proto::policy::need(proto::policy::Act::Chain, from.role) == proto::policy::Need::Never {
                return Err(Refused::NotEntitled { from, what: proto::policy::row(proto::policy::Act::Chain).what.into() });
            }
            Ok(Event::Chain { envelope: Box::new(env), from })
        }
        Some(Key::MissionStatus(name)) => {
            let (view, from) = edge::mission_status(&m, name.as_str())?;
            Ok(Event::MissionStatus { view: Box::new(view), from })
        }
        Some(Key::HostAlive(node)) => Ok(if m.put { Event::HostAlive(node) } else { Event::HostGone(node) }),
        Some(Key::RobotAlive(id)) => Ok(if m.put { Event::RobotAlive(id) } else { Event::RobotGone(id) }),
        Some(Key::PlannerAlive { kind, zid }) => Ok(if m.put { Event::PlannerAlive { kind, zid } } else { Event::PlannerGone { kind, zid } }),
        _ => Err(Refused::Unexpected { key: m.key.chars().take(200).collect() }),
    }
}

/// A question on one of this host's queryables, as its driver received it.
#[derive(Debug, Clone, Copy)]
pub struct Question<'a> {
    pub key: &'a str,
    /// The selector's parameters (`add=-1`).
    pub params: &'a str,
    pub payload: &'a [u8],
    /// Its sender as its seal proves it, if it does.
    pub from: Option<&'a Sender>,
    /// The id the driver holds it under.
    pub query: u64,
}

/// Whether a question on `key` is taken only from a proven sender (what it is, for the driver's
/// refusal): a mission's start and control.
pub fn question_sealed(key: &str) -> Option<&'static str> {
    match Key::parse(key)? {
        Key::HostStart(_) | Key::MissionCtl(_) => Some("mission control"),
        _ => None,
    }
}

/// Translates a question to this host into its event; `Err` is the error to answer it with.
pub fn question(q: Question<'_>) -> Result<Event, String> {
    let proven = || q.from.cloned().ok_or_else(|| "refused: unproven sender".to_string());
    let query = q.query;
    match Key::parse(q.key) {
        Some(Key::HostStart(_)) => {
            let start = proto::from_json("mission start", q.payload).map_err(|e| e.to_string())?;
            Ok(Event::Start { query, start: Box::new(start), from: proven()? })
        }
        Some(Key::MissionCtl(mission)) => {
            let ctl = proto::from_json("mission control", q.payload).map_err(|e| e.to_string())?;
            Ok(Event::Ctl { query, mission, ctl, from: proven()? })
        }
        Some(Key::MissionView(mission)) => Ok(Event::View { query, mission }),
        Some(Key::MissionMarginal(mission)) => {
            let add = q.params.split([';', '&']).find_map(|p| p.strip_prefix("add="));
            match add {
                None => Ok(Event::Marginal { query, mission, add: 1 }),
                Some(v) => v
                    .parse::<i64>()
                    .map(|add| Event::Marginal { query, mission, add })
                    .map_err(|_| format!("add={v}: give a non-zero whole number, e.g. add=1 or add=-1")),
            }
        }
        _ => Err(format!("nothing is asked on {}", q.key.chars().take(200).collect::<String>())),
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
        assert!(matches!(heard(b"MRM5\xff", Some(&r1)), Err(Refused::Malformed { .. })));
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

    #[test]
    fn questions_become_events_or_the_error_to_answer() {
        let central = Sender::new(Role::Central, "central");
        let ask = |key: Key, params: &str, payload: &[u8], from: Option<&Sender>| question(Question { key: &key.to_string(), params, payload, from, query: 4 });
        let ctl = serde_json::to_vec(&mrmm_proto::MissionCtl::Terminate).expect("json");
        assert!(matches!(ask(Key::MissionCtl("p".into()), "", &ctl, Some(&central)), Ok(Event::Ctl { query: 4, ref mission, .. }) if mission == "p"));
        assert_eq!(ask(Key::MissionCtl("p".into()), "", &ctl, None), Err("refused: unproven sender".into()));
        assert!(ask(Key::MissionCtl("p".into()), "", b"{", Some(&central)).is_err());
        assert_eq!(ask(Key::MissionMarginal("p".into()), "add=-2", b"", None), Ok(Event::Marginal { query: 4, mission: "p".into(), add: -2 }));
        assert_eq!(ask(Key::MissionMarginal("p".into()), "", b"", None), Ok(Event::Marginal { query: 4, mission: "p".into(), add: 1 }));
        assert!(ask(Key::MissionMarginal("p".into()), "add=x", b"", None).is_err());
        assert_eq!(ask(Key::MissionView("p".into()), "", b"", None), Ok(Event::View { query: 4, mission: "p".into() }));
        assert_eq!(question_sealed(&Key::HostStart("h".into()).to_string()), Some("mission control"));
        assert_eq!(question_sealed(&Key::MissionView("p".into()).to_string()), None);
    }
}
