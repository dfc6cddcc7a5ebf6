//! Central's journal on the system manager's side: what it holds after a restart
//! ([`SystemManager::restore`]), what changed since the last commit
//! ([`SystemManager::journal_entries`], see [`Durable`]), and journaled missions that no live
//! manager runs, started anew as their next lineage (`mrmm_proto::chain::lineage_of`) with the
//! members alive: a chain of the old lineage still alive somewhere (with members cut off) loses
//! wherever it meets the new one, and its head is fenced when it reports (`reports.rs`).

use super::*;

impl SystemManager {
    /// A system manager that starts from what its journal holds: the missions it defined are
    /// known (those no live manager reports are started again after [`RESTART_S`]), robots are
    /// in the missions the journal says, terminated missions stay terminated.
    pub fn restore(node: NodeId, now: f64, state: Durable) -> Self {
        let mut m = SystemManager::new(node, now);
        for (name, def) in &state.missions {
            m.missions.insert(name.clone(), MissionRecord::new(def.clone(), None, false, now));
        }
        m.assignment = touched::Touched::new(state.assignment.clone());
        m.terminated = touched::Touched::new(state.terminated.clone());
        // Robots whose head had not let them go yet: told again, and held until it does.
        for (robot, mission) in &state.releasing {
            if m.missions.contains_key(mission) {
                let ctl = m.ctls.push(mission, MissionCtl::Left { ids: vec![robot.clone()] }, vec![]);
                m.release(robot, mission, ctl);
            }
        }
        let started = JournalEvent::CentralStarted { missions: state.missions.len(), robots: state.assignment.len(), terminated: state.terminated.len() };
        m.journal = Journal::holding(state);
        m.journal.note(started);
        m
    }

    /// Whether `mission` is being started again from the journal (no live manager ran it).
    pub fn restarting(&self, mission: &str) -> bool {
        self.restarts.inflight.contains_key(mission)
    }

    /// The durable part as it is now.
    pub fn durable(&self) -> Durable {
        Durable {
            missions: self.missions.iter().map(|(n, r)| (n.clone(), r.def.clone())).collect(),
            assignment: (*self.assignment).clone(),
            terminated: (*self.terminated).clone(),
            releasing: self.releasing(),
        }
    }

    /// (Robot, the mission letting it go), while its head has not acknowledged.
    fn releasing(&self) -> BTreeSet<(RobotId, MissionName)> {
        self.released.iter().filter(|(_, r)| self.ctls.is_pending(r.ctl)).map(|(k, _)| k.clone()).collect()
    }

    /// Whether the durable part differs from what the journal holds (cheap: no copies; the
    /// robot → mission map and the terminated set are compared only when an event touched them).
    pub(super) fn durable_changed(&self) -> bool {
        let j = self.journal.committed();
        (self.assignment.touched() && *self.assignment != j.assignment)
            || (self.terminated.touched() && *self.terminated != j.terminated)
            || self.releasing() != j.releasing
            || self.missions.len() != j.missions.len()
            || self.missions.iter().zip(&j.missions).any(|((n, r), (jn, jd))| n != jn || !Arc::ptr_eq(&r.def, jd))
    }

    /// The entries to commit for what the last event changed: the durable part's diff since the
    /// last commit, then the history noted meanwhile.
    pub(super) fn journal_entries(&mut self) -> Vec<JournalEvent> {
        let now = self.durable_changed().then(|| self.durable());
        let entries = self.journal.entries(now);
        // The journal holds what they hold now.
        self.assignment.committed();
        self.terminated.committed();
        entries
    }

    /// Journaled missions that no live manager runs are started again as their next lineage,
    /// with the members that are back; the others rejoin as they come back. A mission some robot
    /// says it runs is left alone for [`RUNNING_WAIT_S`]: its managers may be alive somewhere, and
    /// report.
    ///
    /// So is a mission whose managers stopped reporting while this manager ran (its chain lost
    /// its majority): started anew once none reported for [`RUNNING_WAIT_S`], with the members
    /// this manager still hears. A central cut off alone hears none, and leaves every mission
    /// alone. And one whose head reports it could not commit for [`UNCOMMITTED_WAIT_S`] (its
    /// chain lost the memory of a majority of its nodes: it never commits again).
    pub(super) fn restart_orphans(&mut self, now: f64) {
        // A robot up since before the previous manager went down may replicate a mission, and
        // its chain may take over again: a new lineage wins over it wherever they meet, and its
        // head is fenced when it reports — so that does not hold a start back.
        let stuck = |r: &MissionRecord| r.view.as_ref().and_then(|v| v.manager.uncommitted_s).is_some_and(|s| s >= UNCOMMITTED_WAIT_S);
        let orphans: Vec<MissionName> = self
            .missions
            .iter()
            .filter(|(_, r)| (r.view.is_none() || now - r.reported_at >= RUNNING_WAIT_S || stuck(r)) && r.def.spec.is_some())
            .filter(|(n, _)| !self.pending_create.contains_key(*n) && !self.starts.iter().any(|s| &s.start.spec.name == *n))
            .filter(|(n, _)| self.restarts.may_start(n, now))
            .map(|(n, _)| n.clone())
            .collect();
        for name in orphans {
            // A robot runs it: its managers may be alive somewhere and report soon. If none has
            // reported for this long, its chain lost its majority: the mission is started anew,
            // with those robots too (the new lineage's plans win at them).
            let runs = self.fleet.iter().any(|(_, r)| r.alive && r.last.as_ref().is_some_and(|t| t.mission.as_deref() == Some(name.as_str())));
            let silent = self.missions.get(&name).is_some_and(|r| r.view.is_some());
            let uncommitted = self.missions.get(&name).is_some_and(stuck);
            if runs && now - self.started < RUNNING_WAIT_S {
                continue;
            }
            // A member with a state dir that came up lately may bring the mission back through
            // its chain, from its disk (with its metrics): it gets the time to.
            let reforming: Vec<&RobotId> = self
                .fleet
                .iter()
                .filter(|(id, r)| r.alive && now - r.alive_at < DURABLE_WAIT_S && self.assignment.get(*id) == Some(&name))
                .filter(|(_, r)| r.info.as_ref().is_some_and(|i| i.durable))
                .map(|(id, _)| id)
                .collect();
            if !reforming.is_empty() {
                if self.restarts.held.insert(name.clone()) {
                    tracing::info!(mission = %name, robots = ?reforming, "members with a state dir are back: waiting for the mission's chain to come back from their disks before starting it anew");
                }
                continue;
            }
            let Some(rec) = self.missions.get(&name) else {
                continue;
            };
            let Some(spec) = rec.def.spec.clone() else {
                continue;
            };
            let host = [rec.def.host.as_str(), proto::CENTRAL_HOST].into_iter().find(|h| self.fleet.has_host(h)).map(NodeId::from);
            let Some(host) = host else { continue };
            // The members back (a member still away may be cut off with the mission's chain: the
            // new lineage's epochs are above all of that chain's, and its head is fenced when it
            // reports). The others rejoin as they come back.
            let members: Vec<Member> =
                self.assignment.iter().filter(|(id, m)| **m == name && self.fleet.ready(id)).filter_map(|(id, _)| self.member(id)).collect();
            if members.is_empty() {
                continue;
            }
            let Some(lineage) = rec.def.lineage.checked_add(1) else {
                tracing::error!(mission = %name, "started anew too many times: not started again");
                continue;
            };
            let robots: Vec<RobotId> = members.iter().map(|m| m.spec.id.clone()).collect();
            if uncommitted {
                tracing::warn!(mission = %name, %host, ?robots, lineage, "this mission's head could not commit for {UNCOMMITTED_WAIT_S} s (its chain lost the memory of a majority of its nodes): starting it again");
            } else if silent {
                tracing::warn!(mission = %name, %host, ?robots, lineage, "no manager reported this mission for {RUNNING_WAIT_S} s while central ran (its chain lost its majority): starting it again");
            } else {
                tracing::info!(mission = %name, %host, ?robots, lineage, "no live manager runs this mission of the journal: starting it again");
            }
            // The new lineage is journaled before the start goes out (the journal comes first).
            let def = MissionDef { lineage, ..(*rec.def).clone() };
            if let Some(r) = self.missions.get_mut(&name) {
                r.def = Arc::new(def);
            }
            self.journal.note(JournalEvent::MissionRestarted { mission: name.clone(), robots: robots.clone() });
            let after = robots.iter().flat_map(|id| self.pending_releases(id)).collect();
            self.restarts.inflight.insert(name.clone(), Restart { inflight: true, next: now + RESTART_RETRY_S });
            self.starts.push(PendingStart { host, start: Box::new(MissionStart { spec, members, anew: true, lineage }), after });
        }
    }
}

/// A journaled mission being started again (no live manager runs it).
#[derive(Debug, Clone, Copy)]
pub(super) struct Restart {
    /// A start is out.
    pub inflight: bool,
    /// Not before this time.
    pub next: f64,
}

/// Journaled missions being started again, and those held for members with a state dir.
#[derive(Debug, Clone, Default)]
pub(super) struct Restarts {
    /// Missions being started again.
    pub inflight: BTreeMap<MissionName, Restart>,
    /// Missions said to wait for members with a state dir (said once each).
    pub held: BTreeSet<MissionName>,
}

impl Restarts {
    /// Whether `mission` may be started (again) at `now`: no start of it out, none too recent.
    fn may_start(&self, mission: &str, now: f64) -> bool {
        self.inflight.get(mission).is_none_or(|r| !r.inflight && now >= r.next)
    }

    /// The restart of `mission`, if one is under way.
    pub fn get_mut(&mut self, mission: &str) -> Option<&mut Restart> {
        self.inflight.get_mut(mission)
    }

    /// `mission` runs again, or was created or terminated by the operator: no restart of it.
    pub fn remove(&mut self, mission: &str) {
        self.inflight.remove(mission);
    }
}
