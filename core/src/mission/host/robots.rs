//! What a mission host knows of robots: whose token is up, and what the telemetry of those it
//! listens to says (the mission each runs, the missions central admitted it to) — bounded, and
//! forgotten once the robot is gone or no longer watched.

use std::collections::{BTreeMap, BTreeSet};

use mrmm_proto::{MissionName, RobotId, Telemetry, Time};

/// For this long after a chain message it could not judge, a host listens to its sender's
/// telemetry; once heard, the sender's next message is judged by it.
pub const UNJUDGED_S: f64 = 5.0;
/// Senders waiting for judgement, at most (a flood of them costs bounded subscriptions).
const UNJUDGED_MAX: usize = 64;

/// The robots a host knows of.
#[derive(Debug, Clone, Default)]
pub(super) struct Robots {
    /// Robots whose token is up.
    alive: BTreeSet<RobotId>,
    /// The mission each robot's telemetry says it runs.
    missions: BTreeMap<RobotId, MissionName>,
    /// Robots heard from since they last came up, with the missions central last admitted them
    /// to (from their telemetry).
    admitted: BTreeMap<RobotId, Vec<MissionName>>,
    /// Robots whose chain messages this node judges by their telemetry, and when it last needed
    /// it (see `watch.rs`).
    unjudged: BTreeMap<RobotId, Time>,
}

impl Robots {
    /// A robot's token appeared.
    pub(super) fn up(&mut self, id: &str) {
        self.alive.insert(id.into());
    }

    /// A robot's token disappeared: what it said is forgotten (it may restart and say otherwise).
    pub(super) fn down(&mut self, id: &str) {
        self.alive.remove(id);
        self.missions.remove(id);
        self.admitted.remove(id);
    }

    pub(super) fn alive(&self, id: &str) -> bool {
        self.alive.contains(id)
    }

    /// The robots whose token is up.
    pub(super) fn alive_ids(&self) -> &BTreeSet<RobotId> {
        &self.alive
    }

    /// A robot's telemetry, of a robot whose token is up (else stale: false, nothing learnt).
    pub(super) fn heard(&mut self, t: &Telemetry) -> bool {
        if !self.alive.contains(&t.id) {
            return false;
        }
        match &t.mission {
            Some(m) => self.missions.insert(t.id.clone(), m.clone()),
            None => self.missions.remove(&t.id),
        };
        self.admitted.insert(t.id.clone(), t.admitted.clone());
        true
    }

    /// Its telemetry says it runs `mission`.
    pub(super) fn runs(&self, id: &str, mission: &str) -> bool {
        self.missions.get(id).is_some_and(|m| m == mission)
    }

    /// Whether robot `id`, back, may rejoin `mission` on a head's own word: its telemetry since
    /// it came back says it runs that mission or none, and central admitted it to that one or
    /// none (central, on its side of a partition, may have given it to another mission).
    pub(super) fn free_for(&self, id: &str, mission: &str) -> bool {
        let Some(admitted) = self.admitted.get(id) else {
            return false;
        };
        self.missions.get(id).is_none_or(|m| m == mission) && admitted.iter().all(|m| m == mission)
    }

    /// Robots waiting for judgement by their telemetry.
    pub(super) fn unjudged(&self) -> impl Iterator<Item = &RobotId> {
        self.unjudged.keys()
    }

    pub(super) fn is_unjudged(&self, id: &str) -> bool {
        self.unjudged.contains_key(id)
    }

    /// A chain message from robot `id` that only its telemetry can judge: whether to drop it
    /// while that telemetry is awaited (for [`UNJUDGED_S`] at least, and as long as the robot
    /// keeps sending such messages; at most [`UNJUDGED_MAX`] robots at once).
    pub(super) fn awaits_telemetry(&mut self, now: Time, id: &str) -> bool {
        let heard = self.admitted.contains_key(id);
        let room = self.unjudged.len() < UNJUDGED_MAX;
        match self.unjudged.get_mut(id) {
            Some(since) if heard => {
                *since = now;
                false
            }
            Some(since) => now - *since < UNJUDGED_S,
            None if heard => false,
            None if room => {
                self.unjudged.insert(id.into(), now);
                true
            }
            None => false,
        }
    }

    /// Forgets robots that stopped sending what only their telemetry can judge, then what it
    /// heard of robots neither awaiting judgement nor `member` of a mission it watches (what they
    /// said may be outdated by the time it matters again).
    pub(super) fn prune(&mut self, now: Time, member: impl Fn(&str) -> bool) {
        self.unjudged.retain(|_, since| now - *since < 2.0 * UNJUDGED_S);
        let gone: Vec<RobotId> = self.admitted.keys().filter(|id| !self.unjudged.contains_key(*id) && !member(id.as_str())).cloned().collect();
        for id in gone {
            self.admitted.remove(&id);
            self.missions.remove(&id);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::at;

    fn telemetry(id: &str, mission: Option<&str>, admitted: &[&str]) -> Telemetry {
        let mut t = Telemetry::resting(id, 0.0);
        t.mission = mission.map(Into::into);
        t.admitted = admitted.iter().map(|m| (*m).into()).collect();
        t
    }

    #[test]
    fn telemetry_of_a_robot_that_is_not_up_is_stale() {
        let mut r = Robots::default();
        assert!(!r.heard(&telemetry("r1", Some("p"), &["p"])));
        assert!(!r.runs("r1", "p") && !r.free_for("r1", "p"));
        r.up("r1");
        assert!(r.heard(&telemetry("r1", Some("p"), &["p"])));
        assert!(r.runs("r1", "p") && r.free_for("r1", "p") && !r.free_for("r1", "q"));
        r.down("r1");
        assert!(!r.runs("r1", "p") && !r.free_for("r1", "p"), "forgotten once gone");
    }

    #[test]
    fn a_robot_admitted_elsewhere_is_not_free() {
        let mut r = Robots::default();
        r.up("r1");
        r.heard(&telemetry("r1", None, &["q"]));
        assert!(!r.free_for("r1", "p") && r.free_for("r1", "q"));
    }

    #[test]
    fn unjudged_senders_are_bounded_and_judged_once_heard() {
        let mut r = Robots::default();
        for i in 0..UNJUDGED_MAX {
            assert!(r.awaits_telemetry(at(0.0), &format!("r{i}")));
        }
        assert!(!r.awaits_telemetry(at(0.0), "one-too-many"), "no room: judged as it is");
        assert!(r.awaits_telemetry(at(1.0), "r0"), "still waiting");
        assert!(!r.awaits_telemetry(at(UNJUDGED_S), "r0"), "waited long enough");
        r.up("r1");
        r.heard(&telemetry("r1", Some("p"), &[]));
        assert!(!r.awaits_telemetry(at(1.0), "r1"), "heard: judged by its telemetry");
        r.prune(at(3.0 * UNJUDGED_S), |_| false);
        assert_eq!(r.unjudged().count(), 0);
        assert!(!r.runs("r1", "p"), "not watched: forgotten");
    }
}
