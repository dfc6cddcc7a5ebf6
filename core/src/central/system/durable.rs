//! What of the system manager survives a restart — missions as defined, the mission each robot
//! is in, missions terminated, robots being let go, robots on charging errands — as a value ([`Durable`]), the journal entries that take one such
//! value to another ([`Durable::diff`]) and their replay ([`Durable::apply`]). The system
//! manager diffs after every event, so whatever changed is committed before anything of it is
//! said or done (see [`super::Command::Journal`]).

use std::collections::{BTreeMap, BTreeSet};
use std::sync::Arc;

use mrmm_proto::{ErrandRecord, JournalEvent, MissionName, MissionSpecWire, NodeId, RobotId};

/// A mission as it was defined: where it was created and, when central created it, its whole
/// spec (recipe XML and parameters) — what it takes to start it again.
#[derive(Debug, Clone, PartialEq)]
pub struct MissionDef {
    pub host: NodeId,
    pub recipe: String,
    pub planner: String,
    /// `None` for a mission adopted from its head's report: it cannot be started again here.
    pub spec: Option<MissionSpecWire>,
    /// Its lineage: how many times it was started anew from the journal (see
    /// `mrmm_proto::chain::lineage_of`). Reports of an older lineage come from a chain that
    /// was replaced.
    pub lineage: u32,
}

/// The durable part of the system manager.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Durable {
    pub missions: BTreeMap<MissionName, Arc<MissionDef>>,
    /// Robot → mission (a lost robot keeps its place).
    pub assignment: BTreeMap<RobotId, MissionName>,
    pub terminated: BTreeSet<MissionName>,
    /// (Robot, the mission letting it go), until its head acknowledges: a robot moved on again
    /// before its first mission let it go is held by both.
    pub releasing: BTreeSet<(RobotId, MissionName)>,
    /// Robots on a charging errand (the charging policy's, kept here to be journaled with the
    /// rest).
    pub errands: BTreeMap<RobotId, ErrandRecord>,
}

impl Durable {
    /// Replays one entry (history entries change nothing).
    pub fn apply(&mut self, e: &JournalEvent) {
        match e {
            JournalEvent::MissionDefined { mission, host, recipe, planner, spec, lineage } => {
                let def =
                    MissionDef { host: host.clone(), recipe: recipe.clone(), planner: planner.clone(), spec: spec.as_deref().cloned(), lineage: *lineage };
                self.missions.insert(mission.clone(), Arc::new(def));
                self.terminated.remove(mission);
            }
            JournalEvent::MissionRemoved { mission, terminated } => {
                self.missions.remove(mission);
                if *terminated {
                    self.terminated.insert(mission.clone());
                } else {
                    self.terminated.remove(mission);
                }
            }
            JournalEvent::RobotAssigned { robot, mission: Some(m) } => {
                self.assignment.insert(robot.clone(), m.clone());
            }
            JournalEvent::RobotAssigned { robot, mission: None } => {
                self.assignment.remove(robot);
            }
            JournalEvent::RobotReleasing { robot, mission: Some(m) } => {
                self.releasing.insert((robot.clone(), m.clone()));
            }
            JournalEvent::RobotReleasing { robot, mission: None } => {
                self.releasing.retain(|(r, _)| r != robot);
            }
            JournalEvent::RobotLetGo { robot, mission } => {
                self.releasing.remove(&(robot.clone(), mission.clone()));
            }
            JournalEvent::RobotErrand { robot, errand: Some(e) } => {
                self.errands.insert(robot.clone(), (**e).clone());
            }
            JournalEvent::RobotErrand { robot, errand: None } => {
                self.errands.remove(robot);
            }
            _ => {}
        }
    }

    /// The entries that take `self` to `new`: applied in order, they give exactly `new`.
    pub fn diff(&self, new: &Durable) -> Vec<JournalEvent> {
        let mut out = Vec::new();
        for (name, def) in &new.missions {
            let same = self.missions.get(name).is_some_and(|d| Arc::ptr_eq(d, def) || **d == **def);
            if !same || self.terminated.contains(name) {
                out.push(JournalEvent::MissionDefined {
                    mission: name.clone(),
                    host: def.host.clone(),
                    recipe: def.recipe.clone(),
                    planner: def.planner.clone(),
                    spec: def.spec.clone().map(Box::new),
                    lineage: def.lineage,
                });
            }
        }
        // Missions gone, and names whose terminated mark changed without a definition.
        let names: BTreeSet<&MissionName> = self.missions.keys().chain(&self.terminated).chain(&new.terminated).collect();
        for name in names {
            if new.missions.contains_key(name) {
                continue;
            }
            let was = (self.missions.contains_key(name), self.terminated.contains(name));
            let now = new.terminated.contains(name);
            if was.0 || was.1 != now {
                out.push(JournalEvent::MissionRemoved { mission: name.clone(), terminated: now });
            }
        }
        let robots: BTreeSet<&RobotId> = self.assignment.keys().chain(new.assignment.keys()).collect();
        for robot in robots {
            let (old, now) = (self.assignment.get(robot), new.assignment.get(robot));
            if old != now {
                out.push(JournalEvent::RobotAssigned { robot: robot.clone(), mission: now.cloned() });
            }
        }
        for (robot, mission) in self.releasing.difference(&new.releasing) {
            out.push(JournalEvent::RobotLetGo { robot: robot.clone(), mission: mission.clone() });
        }
        for (robot, mission) in new.releasing.difference(&self.releasing) {
            out.push(JournalEvent::RobotReleasing { robot: robot.clone(), mission: Some(mission.clone()) });
        }
        let robots: BTreeSet<&RobotId> = self.errands.keys().chain(new.errands.keys()).collect();
        for robot in robots {
            let now = new.errands.get(robot);
            if self.errands.get(robot) != now {
                out.push(JournalEvent::RobotErrand { robot: robot.clone(), errand: now.cloned().map(Box::new) });
            }
        }
        out
    }

    /// Replays `entries` from empty.
    pub fn replay<'a>(entries: impl IntoIterator<Item = &'a JournalEvent>) -> Durable {
        let mut d = Durable::default();
        for e in entries {
            d.apply(e);
        }
        d
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn random(rng: &mut ChaCha8Rng) -> Durable {
        let mut d = Durable::default();
        let names = ["a", "b", "c", "d"];
        for n in names {
            match rng.gen_range(0..4) {
                0 => {
                    let host = if rng.gen_bool(0.5) { "central" } else { "h1" };
                    let def = MissionDef { host: host.into(), recipe: "patrol".into(), planner: "patrol".into(), spec: None, lineage: rng.gen_range(0..2) };
                    d.missions.insert(n.into(), Arc::new(def));
                }
                1 => {
                    d.terminated.insert(n.into());
                }
                2 => {
                    let def = MissionDef { host: "central".into(), recipe: "coverage".into(), planner: "coverage".into(), spec: None, lineage: 0 };
                    d.missions.insert(n.into(), Arc::new(def));
                    d.terminated.insert(n.into());
                }
                _ => {}
            }
        }
        for r in 0..6 {
            if rng.gen_bool(0.6) {
                d.assignment.insert(format!("r{r}").into(), names[rng.gen_range(0..names.len())].into());
            }
            for n in names {
                if rng.gen_bool(0.15) {
                    d.releasing.insert((format!("r{r}").into(), n.into()));
                }
            }
            if rng.gen_bool(0.3) {
                let charger = mrmm_proto::map::Charger { name: format!("c{}", rng.gen_range(0..2)), at: mrmm_proto::geom::Point { x: 1.0, y: 2.0 } };
                let left = rng.gen_bool(0.5).then(|| (names[rng.gen_range(0..names.len())].into(), rng.gen_range(1..4)));
                let e = ErrandRecord { map: "office".into(), charger, left, spare: None, from: Some((0.5, 1.5)) };
                d.errands.insert(format!("r{r}").into(), e);
            }
        }
        d
    }

    #[test]
    fn releases_are_per_mission_and_an_older_journal_still_replays() {
        let ev = |robot: &str, m: Option<&str>| JournalEvent::RobotReleasing { robot: robot.into(), mission: m.map(Into::into) };
        let d = Durable::replay(&[
            ev("r1", Some("a")),
            ev("r1", Some("b")),
            ev("r2", Some("a")),
            JournalEvent::RobotLetGo { robot: "r1".into(), mission: "a".into() },
        ]);
        assert_eq!(d.releasing, BTreeSet::from([("r1".into(), "b".into()), ("r2".into(), "a".into())]));
        // Written by an older version: `None` means every mission let it go.
        let d = Durable::replay(&[ev("r1", Some("a")), ev("r1", Some("b")), ev("r2", Some("a")), ev("r1", None)]);
        assert_eq!(d.releasing, BTreeSet::from([("r2".into(), "a".into())]));
    }

    #[test]
    fn a_diff_applied_gives_the_new_state_exactly() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for _ in 0..5_000 {
            let (old, new) = (random(&mut rng), random(&mut rng));
            // A state with a mission both defined and terminated is not one the manager makes;
            // the replay of its diff keeps the definition.
            let mut want = new.clone();
            for m in want.missions.keys() {
                want.terminated.remove(m);
            }
            let mut got = old.clone();
            for e in old.diff(&new) {
                got.apply(&e);
            }
            assert_eq!(got, want, "from {old:?}");
            assert!(want.diff(&want).is_empty());
        }
    }
}
