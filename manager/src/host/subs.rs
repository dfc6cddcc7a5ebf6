//! The host's per-robot and per-mission subscriptions, kept in step with what its core needs:
//! the telemetry of the robots it watches ([`HostCore::watched`]) and, on a robot node, the status
//! of its robot's missions. Subscribing to everything would cost every node every robot's
//! telemetry: n² deliveries in a fleet of n.

use std::collections::{BTreeSet, HashMap};

use mrmm_proto::Key;
use zenoh::pubsub::Subscriber;
use zenoh::Session;

use super::{HostCore, Input, LocalTeam};
use crate::inbox::Inbox;

/// Subscriptions by robot id or mission name.
pub(super) struct Subs {
    session: Session,
    net: Inbox<Input>,
    telemetry: HashMap<String, Subscriber<()>>,
    status: HashMap<String, Subscriber<()>>,
}

impl Subs {
    pub(super) fn new(session: Session, net: Inbox<Input>) -> Self {
        Subs { session, net, telemetry: HashMap::new(), status: HashMap::new() }
    }

    /// Subscribes to the telemetry of the robots `core` watches now, and only those.
    pub(super) async fn follow(&mut self, core: &HostCore) {
        let wanted = core.watched();
        if wanted.len() == self.telemetry.len() && wanted.iter().all(|id| self.telemetry.contains_key(id)) {
            return;
        }
        self.telemetry.retain(|id, _| wanted.contains(id));
        for id in wanted {
            if !self.telemetry.contains_key(&id) {
                if let Some(s) = self.subscribe(Key::RobotTelemetry(id.clone())).await {
                    self.telemetry.insert(id, s);
                }
            }
        }
    }

    /// Subscribes to the status of the missions of this node's robot.
    pub(super) async fn follow_team(&mut self, team: &LocalTeam) {
        let wanted: BTreeSet<&String> = team.iter().map(|(m, _)| m).collect();
        self.status.retain(|m, _| wanted.contains(m));
        for m in wanted {
            if !self.status.contains_key(m) {
                if let Some(s) = self.subscribe(Key::MissionStatus(m.clone())).await {
                    self.status.insert(m.clone(), s);
                }
            }
        }
    }

    async fn subscribe(&self, key: Key) -> Option<Subscriber<()>> {
        let net = self.net.clone();
        match self.session.declare_subscriber(key.to_string()).callback(move |s| net.push(Input::Sample(s))).await {
            Ok(s) => Some(s),
            Err(e) => {
                tracing::warn!("cannot subscribe to {key}: {e}");
                None
            }
        }
    }
}
