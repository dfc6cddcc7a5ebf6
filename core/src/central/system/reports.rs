//! What robots and mission heads report — telemetry and mission statuses — reconciled with the
//! registry: who may report what, robots recorded in or told to leave missions, lost members
//! taken back.

use mrmm_proto::chain::{lineage_floor, lineage_of};
use mrmm_proto::edge::Refused;
use mrmm_proto::{Role, Time};

use super::*;

impl SystemManager {
    /// Whether `from` may report on `view`'s mission ([`mrmm_proto::policy::POLICY`],
    /// `Act::Report`): central and mission hosts may; a robot only if this manager knows it as
    /// one of the mission's managers or members (a successor taking over comes from the chain,
    /// and the chain is made of members). A mission this manager does not know is for
    /// [`Self::adopt`] to judge.
    pub(super) fn may_report(&self, view: &MissionView, from: &Sender) -> bool {
        use mrmm_proto::policy::{allows, Act, Relation};
        let relation = match self.missions.get(&view.name).and_then(|r| r.view.as_ref()) {
            Some(known) => {
                let id = &from.id;
                let former =
                    || view.manager.chain_epoch > known.manager.chain_epoch && self.missions.get(&view.name).is_some_and(|r| r.former.iter().any(|n| n == id));
                if self.managers(view.name.as_str()).iter().any(|n| n == id) || former() {
                    Relation::Manager
                } else if known.robots.iter().any(|r| r == id) || known.lost.iter().any(|r| r == id) {
                    Relation::Member
                } else {
                    Relation::Stranger
                }
            }
            // Not known here (this manager restarted): adopted or not by its own rule; what the
            // report says of other robots is checked against their own telemetry in `reconcile`.
            None => return true,
        };
        allows(Act::Report, from.role, relation)
    }

    /// A robot's telemetry the registry took (newer than the last, or the first since it came
    /// up): the robot steered where it runs or is admitted to what it should not be; then the
    /// registry keeps it as the robot's latest.
    pub(super) fn heard(&mut self, now: Time, t: Telemetry) -> Vec<Command> {
        let mut out = self.leave_admissions(now, &t);
        out.extend(self.admit_forgetful(now, &t));
        out.extend(self.runs(now, t));
        out
    }

    /// Admitted to a mission this manager knows (or terminated) it is not in — a leave order it
    /// missed, or it was moved: told to leave it, which clears the admission. After a restart of
    /// central, missions it never heard of keep running.
    fn leave_admissions(&mut self, now: Time, t: &Telemetry) -> Vec<Command> {
        let retry = self.fleet.get(t.id.as_str()).is_some_and(|r| r.leave_sent.is_none_or(|s| now - s >= LEAVE_RETRY_S));
        let mut leave = Vec::new();
        for admitted in t.admitted.iter().filter(|a| t.mission.as_ref() != Some(*a)) {
            let known = self.missions.contains_key(admitted) || self.terminated.contains(admitted);
            let releasing = self.controls.letting_go(t.id.as_str(), admitted.as_str(), true);
            // A join or leave of this robot still on its way to that mission's head: the head
            // may be taking it into its chain; its admission must hold until the leave is done.
            let in_transit = self.controls.has(admitted.as_str(), |c| match c {
                MissionCtl::Joined { member } => member.spec.id == t.id,
                MissionCtl::Left { ids } => ids.contains(&t.id),
                MissionCtl::Replaced { out, member } => *out == t.id || member.spec.id == t.id,
                _ => false,
            });
            if known && self.assignment.get(&t.id) != Some(admitted) && !releasing && !in_transit && retry {
                leave.push(admitted.clone());
            }
        }
        if let Some(rec) = self.fleet.get_mut(t.id.as_str()).filter(|_| !leave.is_empty()) {
            rec.leave_sent = Some(now);
        }
        leave
            .into_iter()
            .map(|mission| Command::SendToRobot { req: None, robot: t.id.clone(), cmd: RobotCommand::Leave { mission, epoch: u64::MAX } })
            .collect()
    }

    /// In a mission here, but neither running it nor admitted to it (it restarted and forgot
    /// its admission): admitted again, so it trusts the mission's managers when they call.
    fn admit_forgetful(&mut self, now: Time, t: &Telemetry) -> Vec<Command> {
        let Some(m) = self.assignment.get(&t.id).filter(|m| self.missions.contains_key(*m)).cloned() else { return vec![] };
        let forgot = t.mission.as_ref() != Some(&m) && !t.admitted.contains(&m);
        match self.fleet.get_mut(t.id.as_str()) {
            Some(rec) if forgot && rec.admit_sent.is_none_or(|s| now - s >= LEAVE_RETRY_S) => {
                rec.admit_sent = Some(now);
                self.admit(m.as_str(), std::slice::from_ref(&t.id))
            }
            _ => vec![],
        }
    }

    /// What it runs: in no mission here, running one whose head lists it, it is recorded there
    /// (the head's report and its own telemetry agree, see `reconcile`); running a mission this
    /// manager knows it is not in (and not being let go by it), it is told to leave. The
    /// telemetry is kept as its latest.
    fn runs(&mut self, now: Time, t: Telemetry) -> Vec<Command> {
        let mut out = Vec::new();
        let Some(rec) = self.fleet.get_mut(t.id.as_str()) else {
            return out;
        };
        if let Some(running) = &t.mission {
            let assigned = self.assignment.get(&t.id);
            // Looked up in the head's list (O(team)) only for a robot in no mission here.
            let listed = || self.missions.get(running).filter(|m| m.adopted).and_then(|m| m.view.as_ref()).is_some_and(|v| v.robots.contains(&t.id));
            let released = self.controls.letting_go(t.id.as_str(), running.as_str(), false);
            if assigned.is_none() && !released && !self.terminated.contains(running) && listed() {
                tracing::info!(mission = %running, robot = %t.id, "robot recorded in the mission it runs and its head lists");
                let (id, mission) = (t.id.clone(), running.clone());
                self.assignment.insert(id.clone(), mission.clone());
                self.fleet.keep(t);
                return self.admit(mission.as_str(), &[id]);
            }
            let known = self.missions.contains_key(running) || self.terminated.contains(running);
            let retry = rec.leave_sent.is_none_or(|s| now - s >= LEAVE_RETRY_S);
            // Moved out of `running` but not yet let go by it: its head still counts on it, so
            // it keeps its plan until the head has replanned without it.
            let releasing = self.controls.letting_go(t.id.as_str(), running.as_str(), true);
            if assigned != Some(running) && known && retry && !releasing {
                rec.leave_sent = Some(now);
                let epoch = t.progress.as_ref().map_or(u64::MAX, |p| p.epoch);
                out.push(Command::SendToRobot { req: None, robot: t.id.clone(), cmd: RobotCommand::Leave { mission: running.clone(), epoch } });
            }
        }
        self.fleet.keep(t);
        out
    }

    /// A head reported a mission. A mission this manager does not know (it restarted while the
    /// head kept running it) is adopted: record, host and membership come from the report, for
    /// robots not already in another mission. A mission terminated here is ended again.
    pub(super) fn mission_status(&mut self, mut view: MissionView, from: Sender) -> Vec<Command> {
        view.carry_summary(self.missions.get(&view.name).and_then(|r| r.view.as_ref()));
        let status = mrmm_proto::policy::Publication::Status { manager: view.manager.node.as_str() };
        if mrmm_proto::policy::may_publish(status, &from).is_err() {
            return vec![Command::Refused(Refused::NotEntitled { what: format!("report mission {} as managed by {}", view.name, view.manager.node), from })];
        }
        // The head of a lineage this manager replaced (it started the mission anew while that
        // chain was cut off, say): told directly that a newer lineage runs the mission — the two
        // chains may share no node, so neither would hear of the other — and it steps down.
        let lineage = self.missions.get(&view.name).map_or(0, |r| r.def.lineage);
        if lineage_of(view.manager.chain_epoch) < lineage {
            tracing::warn!(mission = %view.name, node = %view.manager.node, chain_epoch = view.manager.chain_epoch, lineage, "the head of a replaced lineage still runs the mission: fenced");
            let floor = lineage_floor(lineage);
            let msg = mrmm_proto::chain::Msg::Stale { promised: floor, last: (floor, 0) };
            let envelope = Box::new(ChainEnvelope { mission: view.name.clone(), from: NodeId::from(proto::CENTRAL_HOST), msg });
            return vec![Command::Chain { to: view.manager.node.clone(), envelope }];
        }
        // A report of an older chain epoch is from a manager that was replaced.
        let known_epoch = self.missions.get(&view.name).and_then(|r| r.view.as_ref()).map_or(0, |v| v.manager.chain_epoch);
        if view.manager.chain_epoch < known_epoch {
            return vec![];
        }
        if !self.may_report(&view, &from) {
            return vec![Command::Refused(Refused::NotEntitled {
                what: format!("report on mission {} (not one of its managers or members)", view.name),
                from,
            })];
        }
        if self.terminated.contains(&view.name) {
            if !self.controls.has(view.name.as_str(), |c| *c == MissionCtl::Terminate) {
                tracing::warn!(mission = %view.name, node = %view.manager.node, "a terminated mission still runs: ending it again");
                self.controls.push(view.name.as_str(), MissionCtl::Terminate, vec![]);
            }
            return vec![];
        }
        if self.missions.contains_key(&view.name) {
            return self.reported(view, from);
        }
        self.adopt(view, from)
    }

    /// A report of a mission this manager knows: where its manager is now, its plan epoch, and
    /// its membership reconciled with ours.
    fn reported(&mut self, view: MissionView, from: Sender) -> Vec<Command> {
        let Some(rec) = self.missions.get_mut(&view.name) else { return vec![] };
        rec.reported_at = self.now;
        let before = rec.managers();
        let moved = rec.host != view.manager.node;
        if moved {
            tracing::info!(mission = %view.name, from = %rec.host, to = %view.manager.node, "mission manager moved");
            rec.host = view.manager.node.clone();
            self.journal.note(JournalEvent::ManagerChanged {
                mission: view.name.clone(),
                manager: view.manager.node.clone(),
                chain_epoch: view.manager.chain_epoch,
            });
        }
        if rec.view.is_none() && view.status == MissionStatus::Planning {
            return vec![];
        }
        let old_epoch = rec.view.as_ref().map(|v| v.manager.epoch);
        if old_epoch.is_some_and(|e| e < view.manager.epoch) {
            self.journal.note(JournalEvent::Replanned { mission: view.name.clone(), plan_epoch: view.manager.epoch, robots: view.robots.clone() });
        }
        let name = view.name.clone();
        let (robots, lost) = (view.robots.clone(), view.lost.clone());
        // The first report since this manager started from its journal: the head may have
        // missed joins ordered before the restart.
        let first = rec.view.is_none() && !rec.adopted;
        if rec.def.spec.is_none() {
            rec.requires = super::capabilities::reported(&view);
        }
        rec.view = Some(view);
        if rec.managers() != before {
            rec.former = before;
        }
        let mut out = self.reconcile(name.as_str(), &robots, &lost, &from);
        if moved {
            // Its members may know only the managers they were admitted under (a robot that
            // restarted while central was away was admitted under the host alone, found by
            // the system sim, seed 3928): the new head may plan for them only once they know it.
            let members: Vec<RobotId> = robots.iter().chain(&lost).filter(|id| self.assignment.get(*id).is_some_and(|m| *m == name)).cloned().collect();
            out.extend(self.admit(name.as_str(), &members));
        }
        self.rejoin(name.as_str());
        if first && !self.pending_create.contains_key(&name) {
            self.resync(name.as_str());
        }
        self.sync_spec(name.as_str());
        out
    }

    /// A mission this manager does not know, reported by a live host (central restarted while
    /// the head kept running it): adopted — record, host and membership from the report.
    ///
    /// A robot's say-so alone adopts nothing: a robot heading a mission (after a takeover) is
    /// believed only when another robot it lists says in its own telemetry that it runs that
    /// mission — a robot certificate cannot invent a mission and take idle robots with it.
    /// Adoptions are bounded ([`MAX_ADOPTED`]); a refused one is logged once per sender.
    fn adopt(&mut self, view: MissionView, from: Sender) -> Vec<Command> {
        if !self.fleet.has_host(view.manager.node.as_str()) || self.pending_create.contains_key(&view.name) {
            return vec![];
        }
        // Its team runs it, by another robot's own telemetry (a robot's say-so is not enough).
        let vouched = || {
            view.robots
                .iter()
                .chain(&view.lost)
                .any(|id| *id != from.id && self.fleet.last(id.as_str()).is_some_and(|t| t.mission.as_ref() == Some(&view.name)))
        };
        let allowed = {
            use mrmm_proto::policy::{allows, need, Act, Need, Relation};
            match need(Act::Adopt, from.role) {
                Need::Always => true,
                Need::Never => false,
                Need::Any(_) => allows(Act::Adopt, from.role, if vouched() { Relation::Runs } else { Relation::Stranger }),
            }
        };
        let why = if !allowed {
            Some("a robot's report of a mission no other robot says it runs")
        } else if self.missions.values().filter(|m| m.adopted).count() >= MAX_ADOPTED {
            Some("too many adopted missions")
        } else {
            None
        };
        if let Some(why) = why {
            if self.adoptions_refused.len() < MAX_ADOPTED && self.adoptions_refused.insert(from.clone()) {
                tracing::warn!(mission = %view.name, %from, robots = view.robots.len(), "mission not adopted: {why} (logged once per sender)");
            }
            return vec![];
        }
        tracing::info!(mission = %view.name, host = %view.manager.node, robots = view.robots.len(), "mission adopted from its head's report");
        let name = view.name.clone();
        let (robots, lost) = (view.robots.clone(), view.lost.clone());
        self.journal.note(JournalEvent::ManagerChanged { mission: name.clone(), manager: view.manager.node.clone(), chain_epoch: view.manager.chain_epoch });
        let def = MissionDef {
            host: view.manager.node.clone(),
            recipe: view.recipe.clone(),
            planner: view.planner.clone(),
            spec: None,
            lineage: lineage_of(view.manager.chain_epoch),
        };
        self.missions.insert(name.clone(), MissionRecord::new(std::sync::Arc::new(def), Some(view), true, self.now));
        let out = self.reconcile(name.as_str(), &robots, &lost, &from);
        self.rejoin(name.as_str());
        out
    }

    /// A mission's head lists `robots` and its `lost` members (it may have taken back a lost
    /// robot while central was away, or central restarted): robots in no mission are recorded in
    /// it; robots in another mission are taken out of it. Robots missing from the lists are left
    /// alone — the report may predate a join this manager ordered.
    ///
    /// A robot reporting as a head (after a takeover) cannot claim robots of other missions or
    /// idle ones: a robot in no mission is recorded from its report only when its own telemetry
    /// says it runs that mission. Central's and mission hosts' reports are trusted.
    pub(super) fn reconcile(&mut self, name: &str, robots: &[RobotId], lost: &[RobotId], reporter: &Sender) -> Vec<Command> {
        let trusted = matches!(reporter.role, Role::Central | Role::Host);
        let adopted = self.missions.get(name).is_some_and(|r| r.adopted);
        // A robot's report is believed of another robot only where that robot's own telemetry
        // names the mission: an idle robot is never taken on a robot's word.
        let mut strangers = Vec::new();
        let mut recorded = Vec::new();
        for id in robots.iter().chain(lost) {
            // A robot being let go (by this mission or another) is in transit: this manager
            // moved it, and decides where it goes.
            if self.controls.letting_go(id.as_str(), name, false) || !self.controls.pending_for(id.as_str()).is_empty() {
                continue;
            }
            // A robot that says it runs this mission, or nothing (it restarted and forgot):
            // never one that says it runs another.
            let runs = |t: &Telemetry| t.mission.as_ref().map(|x| x.as_str()) == Some(name);
            let confirmed =
                trusted || *id == reporter.id || self.fleet.last(id.as_str()).is_some_and(|t| runs(t) || (t.mission.is_none() && reporter.role != Role::Robot));
            match self.assignment.get(id) {
                Some(m) if m == name => {}
                Some(_) => strangers.push(id.clone()),
                // Created or journaled here: this manager's assignment is the truth.
                None if !adopted => strangers.push(id.clone()),
                None if !confirmed => {}
                None => {
                    tracing::info!(mission = %name, robot = %id, "robot recorded in its mission from its head's report");
                    self.assignment.insert(id.clone(), MissionName::from(name));
                    recorded.push(id.clone());
                }
            }
        }
        if !strangers.is_empty() {
            // Until the head lets them go they are still its members: not free for a create.
            self.controls.let_go(name, strangers, vec![]);
        }
        // Recorded here: admitted too (this manager may have restarted; they may have too).
        self.admit(name, &recorded)
    }

    /// Orders `name`'s head to take back its lost members that are alive again (they kept their
    /// place in the mission while away).
    pub(super) fn rejoin(&mut self, name: &str) {
        let (present, lost) = self.missions.get(name).and_then(|r| r.view.as_ref()).map(|v| (v.robots.clone(), v.lost.clone())).unwrap_or_default();
        // A report listing it present well after it (re)appeared has seen it back.
        let now = self.now;
        for id in &present {
            if let Some(r) = self.fleet.get_mut(id.as_str()).filter(|r| now - r.alive_at > SEEN_BACK_S) {
                r.back = false;
            }
        }
        for id in lost {
            let ours = self.assignment.get(&id).is_some_and(|m| m == name);
            // Seen coming back since its head counted it present: a head that saw the loss
            // before this manager did is not answered with a rejoin of a dead robot.
            let alive = self.fleet.get(id.as_str()).is_some_and(|r| r.ready() && r.back);
            if ours && alive && self.join(name, id.as_str(), "lost member back: its mission takes it again") {
                if let Some(r) = self.fleet.get_mut(id.as_str()) {
                    r.back = false;
                }
            }
        }
    }

    /// Orders `name`'s head to take `id` (alive and registered), unless a join of it is already
    /// on its way; whether one was ordered. Never in two teams: if another mission is still
    /// letting it go, after that.
    fn join(&mut self, name: &str, id: &str, why: &str) -> bool {
        let pending = self.controls.has(name, |c| matches!(c, MissionCtl::Joined { member } | MissionCtl::Replaced { member, .. } if member.spec.id == id));
        let alive = self.fleet.ready(id);
        let Some(member) = self.member(id).filter(|_| alive && !pending) else {
            return false;
        };
        tracing::info!(mission = %name, robot = %id, "{why}");
        let after = self.controls.pending_for(id);
        self.controls.push(name, MissionCtl::Joined { member }, after);
        true
    }

    /// Orders `name`'s head to take the robots this manager has in the mission that its view
    /// lists neither as members nor as lost (joins it missed while this manager was down, or
    /// members that were down when the mission was started again), alive and not already on
    /// their way to it.
    pub(super) fn resync(&mut self, name: &str) {
        let Some(view) = self.missions.get(name).and_then(|r| r.view.as_ref()) else {
            return;
        };
        let missing: Vec<RobotId> = self
            .assignment
            .iter()
            .filter(|(id, m)| m.as_str() == name && !view.robots.contains(id) && !view.lost.contains(id))
            .map(|(id, _)| id.clone())
            .collect();
        for id in missing {
            self.join(name, id.as_str(), "in the mission by the journal, unknown to its head: it joins");
        }
    }
}
