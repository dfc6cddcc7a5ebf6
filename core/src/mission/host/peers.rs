//! Chain messages from other nodes: taken by this node's replica when their sender may send
//! them; otherwise refused, and the sender told what it should know (the mission ended here, it
//! is behind, or this node is not in its chain).

use mrmm_proto::edge::Refused;
use mrmm_proto::{ChainEnvelope, MissionSnapshot, Sender, Time};

use super::{trust, Command, HostCore};
use crate::mission::chain;

impl HostCore {
    /// A chain message `envelope` from proven sender `sender`.
    pub(super) fn chain_message(&mut self, now: Time, envelope: ChainEnvelope, sender: Sender, out: &mut Vec<Command>) {
        let ChainEnvelope { mission, from, msg } = envelope;
        let holds = self.registry.replica(mission.as_str()).is_some_and(|r| r.config().is_some());
        if !holds && !self.heads.contains_key(&mission) {
            self.trust.handle(trust::Heard::Foreign { now, mission: mission.clone(), from: from.clone() });
        }
        if sender.id == from && !self.may_chain(mission.as_str(), &sender) && self.awaits_telemetry(now, mission.as_str(), &sender) {
            tracing::debug!(%mission, %from, "chain message held back until its sender's telemetry is heard");
            return;
        }
        if sender.id != from || !self.may_chain(mission.as_str(), &sender) {
            if sender.id == from {
                if let Some(answer) = self.answer_outsider(mission.as_str(), from.as_str(), &msg) {
                    out.push(answer);
                }
            }
            out.push(Command::Refused(Refused::NotEntitled { what: format!("send chain messages for mission {mission} as {from}"), from: sender }));
            return;
        }
        tracing::trace!(%mission, %from, msg = msg.describe(), "chain: received");
        let cmds = self.registry.receive(now, mission.as_str(), from, msg);
        self.apply(now, mission.as_str(), cmds, out);
    }

    /// What a node this one no longer counts in the mission (it left the chain while cut off,
    /// say) is told: nothing it sent is taken, but a straggler of a chain that ended here (a
    /// robot released since) hears it ended, as anyone would — else it could stand again with
    /// its old team (system sim, seed 1948); a head or candidate behind this node's replica hears
    /// it is stale, and steps down; a head that counts this node in its chain (which would wait
    /// for an ack that never comes: this node restarted, say, and knows nothing of it) is
    /// declined, so it changes its chain without us.
    fn answer_outsider(&self, mission: &str, from: &str, msg: &chain::Msg<MissionSnapshot>) -> Option<Command> {
        let to_them =
            |to: &str, msg| Command::Chain { to: to.into(), envelope: Box::new(ChainEnvelope { mission: mission.into(), from: self.node.clone(), msg }) };
        if let Some(msg) = self.registry.tomb_answer(mission, msg) {
            return Some(to_them(from, msg));
        }
        let theirs = match msg {
            chain::Msg::Update { config, seq, .. } | chain::Msg::Beat { config, seq } => Some((config.epoch, *seq)),
            chain::Msg::Vote { last, .. } => Some(*last),
            _ => None,
        };
        let behind = |r: &&chain::Replica<MissionSnapshot>| r.config().is_some() && theirs.is_some_and(|v| r.version() > v);
        if let Some(r) = self.registry.replica(mission).filter(behind) {
            return Some(to_them(from, chain::Msg::Stale { promised: r.promised(), last: r.version() }));
        }
        match msg {
            chain::Msg::Update { config, .. } | chain::Msg::Beat { config, .. } if config.contains(self.node.as_str()) && config.head() != self.node => {
                Some(to_them(config.head(), chain::Msg::Decline { epoch: config.epoch }))
            }
            _ => None,
        }
    }
}
