//! Whose telemetry a host needs, so that its driver subscribes to those robots only (a fleet of n
//! robots where every host heard every robot would deliver n² telemetry messages).
//!
//! A host needs the telemetry of the members (current and lost) of the missions it leads and of
//! the missions it replicates (it may take them over), and, for a short while, of a robot that
//! sent it chain messages about a mission it knows nothing of: its telemetry says whether it runs
//! that mission ([`HostCore::may_chain`]'s last resort).

use mrmm_proto::Time;
use std::collections::BTreeSet;

use super::*;

impl HostCore {
    /// Whether this host needs `robot`'s telemetry.
    pub fn watches(&self, robot: &str) -> bool {
        self.robots.is_unjudged(robot) || self.watches_member(robot)
    }

    /// Whether `robot` is a member (current or lost) of a mission this host leads or replicates.
    fn watches_member(&self, robot: &str) -> bool {
        self.heads.values().any(|h| h.mm.has(robot) || h.mm.lost(robot).is_some())
            || self.replicated().any(|s| s.members.iter().chain(&s.lost).any(|m| m.spec.id == robot))
    }

    /// Every robot whose telemetry this host needs.
    pub fn watched(&self) -> BTreeSet<RobotId> {
        let mut ids: BTreeSet<RobotId> = self.robots.unjudged().cloned().collect();
        for h in self.heads.values() {
            ids.extend(h.mm.members().cloned());
            ids.extend(h.mm.lost_members().map(|m| m.spec.id.clone()));
        }
        for s in self.replicated() {
            ids.extend(s.members.iter().chain(&s.lost).map(|m| m.spec.id.clone()));
        }
        ids
    }

    fn replicated(&self) -> impl Iterator<Item = &MissionSnapshot> {
        self.registry.names().filter_map(|n| self.registry.replica(n.as_str())).filter_map(|r| r.state())
    }

    /// Whether a chain message about `mission` from robot `from` can only be judged by the
    /// robot's own telemetry, which this host has not heard yet: it then listens for it (for
    /// [`super::UNJUDGED_S`] at least, and as long as the robot keeps sending such messages) and drops
    /// the message meanwhile (the head sends again).
    pub(super) fn awaits_telemetry(&mut self, now: Time, mission: &str, from: &Sender) -> bool {
        if from.role != Role::Robot {
            return false;
        }
        let ours = self.trust.ours(mission);
        let holds = self.registry.replica(mission).is_some_and(|r| r.config().is_some() || r.state().is_some());
        if ours || holds {
            return false;
        }
        self.robots.awaits_telemetry(now, &from.id)
    }

    /// Forgets what it heard of robots it no longer watches (what they said may be outdated by
    /// the time it matters again), and robots that stopped sending what only their telemetry
    /// can judge.
    pub(super) fn prune_unwatched(&mut self, now: Time) {
        let mut robots = std::mem::take(&mut self.robots);
        robots.prune(now, |id| self.watches_member(id));
        self.robots = robots;
    }
}
