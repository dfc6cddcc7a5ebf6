//! The invariants, each checked in one place, from what the machines expose after every event.
//!
//! 1. **One head per mission epoch**: no two nodes lead a mission in the same chain epoch.
//! 2. **No acknowledged update lost**: a node that starts leading a mission holds a state at
//!    least as new (by revision) as every state a head acknowledged a control for, and every
//!    state committed; two committed states of one revision are the same — within one lineage
//!    of the mission (`mrmm_proto::chain::lineage_of`: central starts a mission anew as its next
//!    lineage, whose revisions start over, while the old one may still run cut off).
//! 3. **Every robot in at most one mission**: among missions not terminated, no robot is a member
//!    of the newest committed state of two of them.
//! 4. **No barrier released early**: when a robot passes a barrier, every other member of its
//!    plan has published its arrival there (or further), or this robot lost its liveliness; or
//!    (leader barrier) a leader released it when every member had reached it, the leader's
//!    liveliness view excepted.
//! 5. **Eventually** (checked at the end, after the quiet period): one head per mission whose
//!    chain kept a majority, and every live member of a running mission executes the mission's
//!    current epoch.

use std::collections::hash_map::DefaultHasher;
use std::collections::{BTreeMap, BTreeSet};
use std::hash::{Hash, Hasher};

use mrmm_core::mission::host::HostCore;
use mrmm_core::robot::executor::Executor;
use mrmm_proto::chain::{lineage_of, Version};
use mrmm_proto::{MissionName, MissionSnapshot, NodeId, RobotId, SyncArrival, SyncRelease};

fn digest(s: &MissionSnapshot) -> u64 {
    let mut h = DefaultHasher::new();
    serde_json::to_string(s).unwrap_or_default().hash(&mut h);
    h.finish()
}

/// What the invariants remember.
#[derive(Debug, Default)]
pub struct Invariants {
    /// (mission, chain epoch) → the node that led it.
    heads: BTreeMap<(MissionName, u64), NodeId>,
    /// (node, incarnation, mission) leading at the last look.
    leading: BTreeSet<(usize, u32, MissionName)>,
    /// (mission, lineage, revision) → digest of the committed state.
    committed: BTreeMap<(MissionName, u32, u64), u64>,
    newest_committed: BTreeMap<(MissionName, u32), u64>,
    /// Highest revision a control was acknowledged at, per mission and lineage.
    acked: BTreeMap<(MissionName, u32), u64>,
    /// The newest committed state's members per mission, by chain version — of its newest
    /// lineage (a replaced lineage, cut off, may still commit what central no longer holds).
    teams: BTreeMap<MissionName, (Version, Vec<RobotId>)>,
    /// The newest lineage started per mission.
    lineages: BTreeMap<MissionName, u32>,
    /// Furthest (round, point) each robot published, per (mission, epoch, robot).
    arrivals: BTreeMap<(String, u64, RobotId), (u32, u32)>,
    /// Furthest release a leader announced (and the invariant justified), per (mission, epoch).
    releases: BTreeMap<(String, u64), (u32, u32)>,
    pub leads: u32,
}

impl Invariants {
    /// Looks at one node's host after an event.
    pub fn host(&mut self, node: usize, inc: u32, core: &HostCore) -> Result<(), String> {
        let name = core.node();
        let mut now_leading = BTreeSet::new();
        for (mission, _) in core.heads() {
            let Some(r) = core.replica(mission.as_str()) else { continue };
            let (Some(config), Some(state)) = (r.config(), r.state()) else { continue };
            if r.is_head() {
                let key = (mission.clone(), config.epoch);
                match self.heads.get(&key) {
                    Some(other) if other != name => {
                        return Err(format!("two heads of {mission} in chain epoch {}: {other} and {name}", config.epoch));
                    }
                    _ => {
                        self.heads.insert(key, name.into());
                    }
                }
            }
            now_leading.insert((node, inc, mission.clone()));
            let lin = (mission.clone(), lineage_of(config.epoch));
            if !self.leading.contains(&(node, inc, mission.clone())) {
                self.leads += 1;
                let need = self.acked.get(&lin).copied().unwrap_or(0).max(self.newest_committed.get(&lin).copied().unwrap_or(0));
                if state.revision < need {
                    return Err(format!("{name} leads {mission} from revision {} but revision {need} was acknowledged or committed", state.revision));
                }
                if let Some(d) = self.committed.get(&(mission.clone(), lin.1, state.revision)) {
                    if *d != digest(state) {
                        return Err(format!("{name} leads {mission} from a revision {} that differs from the committed one", state.revision));
                    }
                }
            }
            if r.committed().is_some_and(|c| c == r.version().1) {
                let d = digest(state);
                let lin = (mission.clone(), lineage_of(r.version().0));
                match self.committed.get(&(mission.clone(), lin.1, state.revision)) {
                    Some(other) if *other != d => {
                        return Err(format!("two different states of {mission} committed at revision {} (lineage {})", state.revision, lin.1))
                    }
                    _ => {
                        self.committed.insert((mission.clone(), lin.1, state.revision), d);
                    }
                }
                let n = self.newest_committed.entry(lin).or_insert(0);
                *n = (*n).max(state.revision);
                let members: Vec<RobotId> = state.members.iter().map(|m| m.spec.id.clone()).collect();
                let v = r.version();
                let replaced = self.lineages.get(mission).is_some_and(|l| lineage_of(v.0) < *l);
                if !replaced && self.teams.get(mission).is_none_or(|(old, _)| *old <= v) {
                    self.teams.insert(mission.clone(), (v, members));
                }
            }
        }
        self.leading.retain(|(n, i, _)| *n != node || *i != inc);
        self.leading.extend(now_leading);
        Ok(())
    }

    /// A node's process is gone: it leads nothing any more.
    pub fn gone(&mut self, node: usize) {
        self.leading.retain(|(n, _, _)| *n != node);
    }

    /// A head of `mission`'s `lineage` acknowledged a control query at `revision`.
    pub fn acked(&mut self, mission: &str, lineage: u32, revision: u64) {
        let a = self.acked.entry((mission.into(), lineage)).or_insert(0);
        *a = (*a).max(revision);
    }

    /// Central started `mission` anew as `lineage`: the team of an older lineage no longer counts.
    pub fn lineage_started(&mut self, mission: &str, lineage: u32) {
        let l = self.lineages.entry(mission.into()).or_insert(0);
        *l = (*l).max(lineage);
        if self.teams.get(mission).is_some_and(|((e, _), _)| lineage_of(*e) < lineage) {
            self.teams.remove(mission);
        }
    }

    /// Missions no node replicates any more are over.
    pub fn forget_missions(&mut self, alive: &BTreeSet<MissionName>) {
        self.teams.retain(|m, _| alive.contains(m));
    }

    /// Invariant 3: robots that are members of two missions, as (robot, mission, mission).
    pub fn in_two_missions(&self) -> Vec<(RobotId, MissionName, MissionName)> {
        let mut seen: BTreeMap<&RobotId, &MissionName> = BTreeMap::new();
        let mut out = Vec::new();
        for (mission, (_, members)) in &self.teams {
            for r in members {
                if let Some(other) = seen.insert(r, mission) {
                    out.push((r.clone(), other.clone(), mission.clone()));
                }
            }
        }
        out
    }

    /// A robot published its arrival at a barrier of `mission`.
    pub fn arrival(&mut self, mission: &str, a: &SyncArrival) {
        let e = self.arrivals.entry((mission.to_string(), a.epoch, a.robot.clone())).or_insert((a.round, a.point));
        *e = (*e).max((a.round, a.point));
    }

    /// Invariant 4 for the leader barrier: `leader` announces a release only of barriers every
    /// member reached (the leader itself by its own arrival), except those it believes gone, or of
    /// barriers released before.
    pub fn release(&mut self, leader: &str, e: &Executor, r: &SyncRelease) -> Result<(), String> {
        let a = &e.assignment;
        let at = (r.round, r.point);
        let key = (a.team.clone(), a.epoch);
        if self.releases.get(&key).is_some_and(|f| *f >= at) {
            return Ok(());
        }
        for m in &a.members {
            let there = if m == leader {
                e.barrier().mine().is_some_and(|f| f >= at)
            } else {
                self.arrivals.get(&(a.team.clone(), a.epoch, m.clone())).is_some_and(|f| *f >= at)
            };
            if !there && !e.barrier().is_gone(m.as_str()) {
                return Err(format!("{leader} released barrier (round {}, point {}) of {} epoch {} before {m} arrived there", at.0, at.1, a.team, a.epoch));
            }
        }
        self.releases.insert(key, at);
        Ok(())
    }

    /// Invariant 4: `robot` just passed barriers up to its own furthest arrival, in its own team
    /// and in each wider team its plan has barriers with: every member of that team (and no
    /// one else) that is not gone had arrived there.
    pub fn barrier_passed(&self, robot: &str, e: &Executor) -> Result<(), String> {
        let a = &e.assignment;
        let mut teams = vec![(a.team.as_str(), a.members.as_slice(), e.barrier())];
        teams.extend(a.scopes.iter().filter_map(|s| e.wide_barrier(&s.team).map(|b| (s.team.as_str(), s.members.as_slice(), b))));
        for (team, members, b) in teams {
            let Some(mine) = b.mine() else { continue };
            // Arrived there but not passed (it passed another team's barrier just before).
            if e.waiting_in(team) == Some(mine) {
                continue;
            }
            // A release justified when announced (leader barrier).
            if self.releases.get(&(team.to_string(), a.epoch)).is_some_and(|f| *f >= mine) {
                continue;
            }
            for m in members.iter().filter(|m| *m != robot) {
                let there = self.arrivals.get(&(team.to_string(), a.epoch, m.clone())).is_some_and(|f| *f >= mine);
                if !there && !b.is_gone(m.as_str()) {
                    return Err(format!("{robot} passed barrier (round {}, point {}) of {team} epoch {} before {m} arrived there", mine.0, mine.1, a.epoch));
                }
            }
        }
        Ok(())
    }
}
