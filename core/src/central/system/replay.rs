//! Central's journal on the system manager's side: what it holds after a restart
//! ([`SystemManager::restore`], the journal replayed), what changed since the last commit
//! ([`SystemManager::journal_entries`], see [`Durable`]), and recovery's decisions carried out
//! (a mission of the journal started anew: journaled before its start goes out).

use super::*;
use mrmm_proto::Time;

impl SystemManager {
    /// A system manager that starts from what its journal holds: the missions it defined are
    /// known (those no live manager reports are started again after [`RESTART_S`]), robots are
    /// in the missions the journal says, terminated missions stay terminated.
    pub fn restore(node: NodeId, now: Time, state: Durable) -> Self {
        let mut m = SystemManager::new(node, now);
        for (name, def) in &state.missions {
            m.missions.insert(name.clone(), MissionRecord::new(def.clone(), None, false, now));
        }
        m.assignment = touched::Touched::new(state.assignment.clone());
        m.terminated = touched::Touched::new(state.terminated.clone());
        m.errands.clone_from(&state.errands);
        // Robots whose head had not let them go yet: told again, and held until it does.
        for (robot, mission) in &state.releasing {
            if m.missions.contains_key(mission) {
                m.controls.let_go(mission.as_str(), vec![robot.clone()], vec![]);
            }
        }
        let started = JournalEvent::CentralStarted { missions: state.missions.len(), robots: state.assignment.len(), terminated: state.terminated.len() };
        m.journal = Journal::holding(state);
        m.journal.note(started);
        m
    }

    /// The durable part as it is now.
    pub fn durable(&self) -> Durable {
        Durable {
            missions: self.missions.iter().map(|(n, r)| (n.clone(), r.def.clone())).collect(),
            assignment: (*self.assignment).clone(),
            terminated: (*self.terminated).clone(),
            releasing: self.controls.releasing(),
            errands: self.errands.clone(),
        }
    }

    /// Robots on charging errands as the charging policy has them now: journaled with the next
    /// commit, before anything that event sends.
    pub fn keep_errands(&mut self, errands: BTreeMap<RobotId, mrmm_proto::ErrandRecord>) {
        self.errands = errands;
    }

    /// Whether the durable part differs from what the journal holds (cheap: no copies; the
    /// robot → mission map and the terminated set are compared only when an event touched them).
    pub(super) fn durable_changed(&self) -> bool {
        let j = self.journal.committed();
        (self.assignment.touched() && *self.assignment != j.assignment)
            || (self.terminated.touched() && *self.terminated != j.terminated)
            || self.controls.releasing() != j.releasing
            || self.errands != j.errands
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

    /// Recovery looks for journaled missions that no live manager runs, and those it starts anew
    /// are journaled as their new lineage, then started (once the missions their robots come
    /// from let them go).
    pub(super) fn recover(&mut self, now: Time) {
        let busy = self.pending_create.keys().map(MissionName::as_str).chain(self.starts.iter().map(|s| s.start.spec.name.as_str())).collect();
        let look = recovery::Look { missions: &self.missions, assignment: &self.assignment, fleet: &self.fleet, busy };
        for decision in self.recovery.handle(now, recovery::Event::Tick(look)) {
            if let recovery::Decision::Anew(anew) = decision {
                self.start_anew(anew);
            }
        }
    }

    fn start_anew(&mut self, anew: recovery::Anew) {
        let recovery::Anew { mission, host, members, lineage, .. } = anew;
        let Some(rec) = self.missions.get_mut(&mission) else { return };
        let Some(spec) = rec.def.spec.clone() else { return };
        // The new lineage is journaled before the start goes out (the journal comes first).
        rec.def = Arc::new(MissionDef { lineage, ..(*rec.def).clone() });
        let robots: Vec<RobotId> = members.iter().map(|m| m.spec.id.clone()).collect();
        let after = robots.iter().flat_map(|id| self.controls.pending_for(id.as_str())).collect();
        self.journal.note(JournalEvent::MissionRestarted { mission, robots });
        self.starts.push(PendingStart { host, start: Box::new(MissionStart { spec, members, anew: true, lineage }), after });
    }

    /// Whether `mission` is being started again from the journal (no live manager ran it).
    pub fn restarting(&self, mission: &str) -> bool {
        self.recovery.restarting(mission)
    }
}
