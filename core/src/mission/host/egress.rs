//! What a mission host puts on the network and listens to (see [`crate::egress`]): chain
//! messages on the receiving host's key, each led mission's status; its own chain key, the
//! telemetry of the robots it watches and, on a robot node, the status of its robot's missions.

use mrmm_proto::Key;

use super::{Command, HostCore};
use crate::egress::{Audience, Out, Sub};

/// What command `c` publishes, if anything (queries, replies and the disk are the driver's).
pub fn egress(c: &Command) -> Option<Out> {
    match c {
        Command::Chain { to, envelope } => chain(to.as_str(), envelope),
        Command::Status(view) => Out::json(Key::MissionStatus(view.name.clone()), view, Audience::Fleet),
        _ => None,
    }
}

/// A chain message to host `to`, on its chain key; packed when large (a mission's plans).
pub fn chain(to: &str, envelope: &mrmm_proto::ChainEnvelope) -> Option<Out> {
    Out::packed(Key::HostChain(to.into()), envelope, Audience::Fleet)
}

impl HostCore {
    /// What this host listens to now. Only what it needs: a host that heard every robot's
    /// telemetry would cost a fleet of n robots n² deliveries.
    pub fn subscriptions(&self) -> Vec<Sub> {
        let mut subs = vec![Sub::any(Key::HostChain(self.node.clone()))];
        subs.extend(self.watched().into_iter().map(|id| Sub::any(Key::RobotTelemetry(id))));
        subs.extend(self.trust.teams().iter().map(|(m, _)| Sub::any(Key::MissionStatus(m.into()))));
        subs
    }
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use crate::at;

    use mrmm_planner::recipe::{self, PlannerKind};
    use mrmm_proto::chain::{Config, Msg};
    use mrmm_proto::{ChainEnvelope, Member, RobotSpec};

    use crate::mission::{self, MissionManager, MissionSpec};

    /// Zenoh's message limit as every node sets it by default (`mrmm_net`'s
    /// `DEFAULT_MAX_MESSAGE_SIZE`): a larger message is dropped by its receiver.
    const MESSAGE_LIMIT: usize = 1 << 20;

    /// A patrol of `n` robots, planned and running.
    fn patrol(n: usize) -> MissionManager {
        let spec = MissionSpec {
            name: "p".into(),
            recipe_name: "patrol".into(),
            recipe_xml: recipe::bank("patrol").expect("bank").to_string(),
            planner: PlannerKind::Patrol,
            params: BTreeMap::from([("waypoints".to_string(), "[[0,0],[200,0],[200,100],[0,100]]".to_string())]),
            replicas: 2,
            requires: vec![],
            map: None,
            paused: false,
        };
        let spec_of = |i: usize| RobotSpec {
            id: format!("r{i}").into(),
            robot_type: "ground".into(),
            x: (i % 50) as f64,
            y: -1.0 - (i / 50) as f64,
            speed: 1.0,
            turn_rate: None,
            reach_m: None,
        };
        let members = (0..n).map(|i| Member { spec: spec_of(i), time_scale: 1.0, capabilities: vec![] }).collect();
        let mut m = MissionManager::new(spec, "h1".into(), members);
        let Some(mission::Command::RequestPlan { epoch, kind, request }) = m.handle(at(0.0), mission::Event::Start).into_iter().next() else {
            panic!("a plan request")
        };
        let plan = crate::mission::planning::plan(kind, &request).expect("plan");
        m.handle(at(0.0), mission::Event::PlanReady { epoch, plan: Box::new(plan) });
        m
    }

    #[test]
    fn a_thousand_robot_patrol_is_replicated_within_the_message_limit() {
        let m = patrol(1000);
        let state = m.snapshot();
        let update = ChainEnvelope {
            mission: "p".into(),
            from: "h1".into(),
            msg: Msg::Update { config: Config { epoch: 1, chain: vec!["h1".into(), "h2".into()] }, seq: 1, state },
        };
        let plain = mrmm_proto::to_json(&update).expect("json").len();
        let out = super::chain("h2", &update).expect("encoded");
        assert!(plain > MESSAGE_LIMIT, "{plain} bytes as JSON: within the limit, proving nothing");
        assert!(out.payload.len() < MESSAGE_LIMIT / 4, "{plain} bytes as JSON, {} sent", out.payload.len());
        let back: ChainEnvelope = mrmm_proto::from_json("chain message", &out.payload).expect("decoded");
        assert_eq!(back, update);
        // What central and the operators read of it stays plain JSON, and small.
        let status = crate::egress::Out::json(mrmm_proto::Key::MissionStatus("p".into()), &m.view(false), crate::egress::Audience::Fleet).expect("status");
        assert!(!mrmm_proto::codec::is_packed(&status.payload) && status.payload.len() < MESSAGE_LIMIT / 4, "status of {} bytes", status.payload.len());
    }
}
