//! What an observer of the fleet — the Rerun viewer, the browser console — hears, translated at
//! its edge with the protocol's one publication policy: robots' telemetry, missions' status,
//! the agent's advice, barrier arrivals and releases become [`Seen`], or a [`Refused`] saying why
//! not. An observer is not a member of any team: it can prove only the signed messages of a
//! stream tagged for others ([`proof`]).

use mrmm_proto::policy::{may_publish, Publication};
use mrmm_proto::{AdviceEvent, Key, MissionView, Pattern, SyncArrival, SyncRelease, Telemetry};

use crate::edge::{self, json, Incoming, Proof, Refused};
use crate::egress::Sub;

/// What an observer saw.
#[derive(Debug, Clone, PartialEq)]
pub enum Seen {
    Telemetry(Box<Telemetry>),
    Mission(Box<MissionView>),
    Advice(Box<AdviceEvent>),
    /// An arrival at a barrier of team `team`.
    Arrival {
        team: String,
        arrival: SyncArrival,
    },
    /// A barrier of team `team` released by its leader.
    Release {
        team: String,
        release: SyncRelease,
    },
}

/// What a message on `key` is and how its sender is proven; `None` for what an observer does not
/// listen to.
pub fn proof(key: &str) -> Option<(&'static str, Proof)> {
    match Key::parse(key)? {
        Key::RobotTelemetry(_) => Some(("telemetry", Proof::Own)),
        Key::MissionStatus(_) => Some(("mission status", Proof::Own)),
        Key::AgentAdviceLive => Some(("advice", Proof::Own)),
        Key::TeamSync { .. } => Some(("barrier arrival", Proof::Observed)),
        Key::TeamRelease { .. } => Some(("barrier release", Proof::Observed)),
        _ => None,
    }
}

/// What an observer listens to. (Under the leader barrier only the leader hears arrivals: its
/// releases show the team's progress.)
pub fn subscriptions() -> Vec<Sub> {
    [Pattern::AllTelemetry, Pattern::AllMissionStatus, Pattern::AllTeamSync, Pattern::AllTeamRelease]
        .into_iter()
        .map(Sub::any)
        .chain([Sub::any(Key::AgentAdviceLive)])
        .collect()
}

/// Translates what an observer heard.
pub fn observe(m: Incoming<'_>) -> Result<Seen, Refused> {
    let proven = |what: &'static str| m.from.cloned().ok_or(Refused::Unproven { what });
    let entitled = |p: Publication<'_>, from: mrmm_proto::Sender| may_publish(p, &from).map_err(|what| Refused::NotEntitled { from, what });
    match Key::parse(m.key) {
        Some(Key::RobotTelemetry(id)) => Ok(Seen::Telemetry(Box::new(edge::telemetry(&m, id.as_str())?))),
        Some(Key::MissionStatus(name)) => {
            let (view, from) = edge::mission_status(&m, name.as_str())?;
            entitled(Publication::Status { manager: view.manager.node.as_str() }, from)?;
            Ok(Seen::Mission(Box::new(view)))
        }
        Some(Key::AgentAdviceLive) => {
            let from = proven("advice")?;
            let a: AdviceEvent = json("advice", m.payload)?;
            entitled(Publication::Advice, from)?;
            Ok(Seen::Advice(Box::new(a)))
        }
        Some(Key::TeamSync { team, .. }) => {
            let from = proven("barrier arrival")?;
            let arrival: SyncArrival = json("barrier arrival", m.payload)?;
            entitled(Publication::Arrival(arrival.robot.as_str()), from)?;
            Ok(Seen::Arrival { team, arrival })
        }
        Some(Key::TeamRelease { team, .. }) => {
            let from = proven("barrier release")?;
            let release: SyncRelease = json("barrier release", m.payload)?;
            entitled(Publication::Release(release.leader.as_str()), from)?;
            Ok(Seen::Release { team, release })
        }
        _ => Err(Refused::Unexpected { key: m.key.chars().take(200).collect() }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mrmm_proto::{Role, Sender};

    #[test]
    fn an_observer_draws_only_what_its_sender_may_publish() {
        let r1 = Sender::new(Role::Robot, "r1");
        let key = Key::TeamSync { team: "p".into(), point: 0, round: 0 }.to_string();
        let arrival = |robot: &str| serde_json::to_vec(&SyncArrival { robot: robot.into(), epoch: 1, point: 0, round: 0 }).expect("json");
        let seen = |payload: &[u8], from: Option<&Sender>| observe(Incoming { key: &key, payload, put: true, from });
        assert!(matches!(seen(&arrival("r1"), Some(&r1)), Ok(Seen::Arrival { ref team, .. }) if team == "p"));
        assert!(matches!(seen(&arrival("r2"), Some(&r1)), Err(Refused::NotEntitled { .. })));
        assert!(matches!(seen(&arrival("r1"), None), Err(Refused::Unproven { .. })));
        // A status that names another manager than its sender.
        let view = MissionView::running("p", "patrol", "h2", 1, &[]);
        let status = serde_json::to_vec(&view).expect("json");
        let key = Key::MissionStatus("p".into()).to_string();
        let h1 = Sender::new(Role::Host, "h1");
        let got = observe(Incoming { key: &key, payload: &status, put: true, from: Some(&h1) });
        assert!(matches!(got, Err(Refused::NotEntitled { .. })), "{got:?}");
        let h2 = Sender::new(Role::Host, "h2");
        assert!(matches!(observe(Incoming { key: &key, payload: &status, put: true, from: Some(&h2) }), Ok(Seen::Mission(_))));
        // Advice only from central.
        let key = Key::AgentAdviceLive.to_string();
        let advice = serde_json::to_vec(&AdviceEvent::Withdrawn { id: "x".into(), reason: "gone".into() }).expect("json");
        assert!(matches!(observe(Incoming { key: &key, payload: &advice, put: true, from: Some(&r1) }), Err(Refused::NotEntitled { .. })));
        assert_eq!(proof(&Key::TeamRelease { team: "p".into(), point: 0, round: 0 }.to_string()), Some(("barrier release", Proof::Observed)));
        assert!(subscriptions().iter().any(|s| s.takes(&Key::AgentAdviceLive.to_string(), false)));
    }
}
