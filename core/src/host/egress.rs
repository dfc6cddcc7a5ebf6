//! What a mission host puts on the network and listens to (see [`crate::egress`]): chain
//! messages on the receiving host's key, each led mission's status; its own chain key, the
//! telemetry of the robots it watches and, on a robot node, the status of its robot's missions.

use mrmm_proto::Key;

use super::{Command, HostCore};
use crate::egress::{Audience, Out, Sub};

/// What command `c` publishes, if anything (queries, replies and the disk are the driver's).
pub fn egress(c: &Command) -> Option<Out> {
    match c {
        Command::Chain { to, envelope } => chain(to, envelope),
        Command::Status(view) => Out::json(Key::MissionStatus(view.name.clone()), view, Audience::Fleet),
        _ => None,
    }
}

/// A chain message to host `to`, on its chain key.
pub fn chain(to: &str, envelope: &mrmm_proto::ChainEnvelope) -> Option<Out> {
    Out::json(Key::HostChain(to.into()), envelope, Audience::Fleet)
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
