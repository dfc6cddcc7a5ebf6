//! The missions this node leads: starting one, its controls, its plans, its chain's commands
//! carried out (lead, step down, flush updates, end), and its view.

use mrmm_proto::chain::lineage_floor;
use mrmm_proto::Time;

use super::*;

/// Orders to take back members gone here kept per mission at most (central sends one per lost
/// member back; bounded whatever it sends).
const MAX_ORDERED_BACK: usize = 1_024;

impl HostCore {
    pub(super) fn start(&mut self, now: Time, query: u64, start: MissionStart, out: &mut Vec<Command>) {
        let spec = match MissionSpec::from_wire(start.spec) {
            Ok(s) => s,
            Err(e) => return out.push(Command::Reply { query, result: Err(e.into()) }),
        };
        let name = spec.name.clone();
        // Central starts anew a mission whose head reported it could not commit: if that head
        // is this node's, it gives the mission up for the new lineage.
        let stuck = crate::central::system::UNCOMMITTED_WAIT_S / 2.0;
        if start.anew && self.heads.contains_key(&name) && self.registry.replica(name.as_str()).and_then(|r| r.uncommitted_for(now)).is_some_and(|s| s >= stuck)
        {
            tracing::warn!(mission = %name, "giving up this node's head of the mission, which could not commit: the mission starts anew");
            self.step_down(name.as_str(), "it could not commit, and the mission starts anew", out);
            let cmds = self.registry.abandon(now, name.as_str(), stuck);
            self.apply(now, name.as_str(), cmds, out);
        }
        let replaced = start.anew && !self.heads.contains_key(&name) && self.registry.replica(name.as_str()).is_some_and(|r| !r.leads());
        if replaced {
            // Central made sure nobody else can replicate it: what this node kept from before
            // is outdated.
            tracing::info!(mission = %name, "replacing the outdated replica kept from before: the mission starts anew");
            let cmds = self.registry.discard(now, name.as_str());
            self.apply(now, name.as_str(), cmds, out);
        }
        if self.heads.contains_key(&name) || self.registry.replica(name.as_str()).is_some_and(|r| r.config().is_some()) {
            return out.push(Command::Reply { query, result: Err(format!("mission {name:?} is already hosted here").into()) });
        }
        if let Some(node) = self.trust.chain_elsewhere(now, name.as_str()) {
            return out
                .push(Command::Reply { query, result: Err(format!("mission {name:?} still has a chain ({node} replicates it): not started anew").into()) });
        }
        // A start anew is the mission's next lineage: its chain and plan epochs are above all of
        // the old one's, so an old chain still alive somewhere loses wherever the two meet.
        let floor = lineage_floor(start.lineage);
        let mut mm = MissionManager::new(spec, self.node.clone(), start.members.clone()).with_epoch_floor(floor);
        // The first replicas: members whose hosts are up, in id order.
        let alive = self.registry.alive();
        let replicas: Vec<NodeId> =
            start.members.iter().map(|m| NodeId::from(m.spec.id.as_str())).filter(|id| *id != self.node && alive.contains(id)).take(mm.replicas()).collect();
        tracing::info!(mission = %name, ?replicas, lineage = start.lineage, "hosting mission");
        let state = mm.changes().unwrap_or_else(|| mm.snapshot());
        self.heads.insert(name.clone(), Head::new(mm, Some(query)));
        out.push(Command::Serve { mission: name.clone() });
        let cmds = self.registry.create(now, name.as_str(), replicas, state, floor);
        self.apply(now, name.as_str(), cmds, out);
        self.set_pool(now, name.as_str());
        self.run(now, name.as_str(), mission::Event::Start, out);
    }

    pub(super) fn ctl(&mut self, now: Time, query: u64, name: &str, ctl: MissionCtl, out: &mut Vec<Command>) {
        if !self.heads.contains_key(name) {
            // Not (or no longer) the head: the system manager asks again, of the new head.
            return out.push(Command::Drop { query });
        }
        match ctl {
            // Only a robot whose liveliness this node sees joins the team: one that is gone (the
            // order came from a report older than its loss) would hold every barrier of the new
            // plan (its teammates wait for a member they never saw leave).
            MissionCtl::Joined { member } if !self.robots.alive(member.spec.id.as_str()) => {
                tracing::info!(mission = %name, robot = %member.spec.id, "told to take back a robot that is gone here: kept as lost until its token comes up");
                if let Some(h) = self.heads.get_mut(name).filter(|h| h.ordered_back.len() < MAX_ORDERED_BACK) {
                    h.ordered_back.insert(member.spec.id.clone(), now);
                }
                self.run(now, name, mission::Event::Absent(member), out)
            }
            MissionCtl::Joined { member } => self.run(now, name, mission::Event::Joined(member), out),
            // A hand-over to a robot gone here: `out` leaves, the robot is kept as lost (as above).
            MissionCtl::Replaced { out: gone, member } if !self.robots.alive(member.spec.id.as_str()) => {
                if let Some(h) = self.heads.get_mut(name) {
                    h.ordered_back.remove(&gone);
                }
                self.run(now, name, mission::Event::Left { ids: vec![gone] }, out);
                self.run(now, name, mission::Event::Absent(member), out)
            }
            MissionCtl::Replaced { out: gone, member } => {
                if let Some(h) = self.heads.get_mut(name) {
                    h.ordered_back.remove(&gone);
                }
                self.run(now, name, mission::Event::Replaced { out: gone, by: member }, out)
            }
            // The system manager took these robots out (moved elsewhere or freed): out for good,
            // alive or not — a robot lost now and back later must not come back into this team.
            MissionCtl::Left { ids } => {
                if let Some(h) = self.heads.get_mut(name) {
                    h.ordered_back.retain(|id, _| !ids.contains(id));
                }
                self.run(now, name, mission::Event::Left { ids }, out)
            }
            MissionCtl::Update { spec } => match crate::mission::MissionSpec::from_wire(spec) {
                Ok(spec) if spec.name == name => self.run(now, name, mission::Event::Update(Box::new(spec)), out),
                Ok(spec) => return out.push(Command::Reply { query, result: Err(format!("an update of mission {:?} sent to {name}", spec.name).into()) }),
                Err(e) => return out.push(Command::Reply { query, result: Err(format!("update of {name}: {e}").into()) }),
            },
            MissionCtl::Terminate => {
                let epoch = self.heads.get(name).map_or(0, |h| h.mm.epoch());
                if let Some(q) = self.heads.get_mut(name).and_then(|h| h.start.take()) {
                    out.push(Command::Reply { query: q, result: Err(format!("mission {name} was terminated").into()) });
                }
                tracing::info!(mission = %name, "mission terminated");
                self.end(now, name, out);
                return out.push(Command::Reply { query, result: json(&CtlAck { ok: true, epoch }).map_err(ErrorReply::from) });
            }
        }
        // Answered once what it changed is on every node of the chain.
        if let Some(h) = self.heads.get_mut(name) {
            h.reply_on_commit(query);
        }
        self.flush(now, name, out);
    }

    pub(super) fn planned(&mut self, now: Time, name: &str, epoch: u64, result: Result<Box<MissionPlan>, Failure>, out: &mut Vec<Command>) {
        let ev = match result {
            Ok(plan) => mission::Event::PlanReady { epoch, plan },
            Err(f) if f.retryable && self.heads.get_mut(name).is_some_and(|h| h.retry_plan(epoch)) => {
                // Planned here this time: a planner service that does not answer (cut off, or
                // gone while its liveliness has not expired yet) must not leave the team on an
                // outdated plan (system sim seed 1482: four immediate asks of an unreachable
                // service, and the replan was given up).
                tracing::warn!(mission = %name, epoch, "no plan ({}); planning here", f.error);
                if let Some(h) = self.heads.get(name) {
                    let (kind, request) = (h.mm.planner(), h.mm.plan_request());
                    out.push(Command::RequestPlan { mission: name.into(), epoch, kind, request, local: true });
                }
                return;
            }
            Err(f) => mission::Event::PlanFailed { epoch, error: f.error },
        };
        self.run(now, name, ev, out);
    }

    pub(super) fn plan_command(&self, mission: &str, epoch: u64, kind: PlannerKind, request: PlanRequest) -> Command {
        let local = !self.planners.iter().any(|(k, _)| k == kind.as_str());
        if local {
            tracing::info!(%mission, "no planner service alive; planning locally");
        }
        Command::RequestPlan { mission: mission.into(), epoch, kind, request, local }
    }

    /// Runs one event of a led mission, hands the new state to the chain, acts on what is committed.
    pub(super) fn run(&mut self, now: Time, name: &str, ev: mission::Event, out: &mut Vec<Command>) {
        let telemetry = matches!(ev, mission::Event::Telemetry(_));
        let Some(h) = self.heads.get_mut(name) else {
            return;
        };
        let requests = h.run(now, ev);
        for r in requests {
            if let mission::Command::RequestPlan { epoch, kind, request } = r {
                out.push(self.plan_command(name, epoch, kind, request));
            }
        }
        if telemetry {
            return;
        }
        let Some(state) = self.heads.get_mut(name).and_then(|h| h.mm.changes()) else {
            return self.flush(now, name, out);
        };
        let cmds = self.registry.handle(now, name, chain::Event::Propose(state));
        self.apply(now, name, cmds, out);
        self.set_pool(now, name);
        self.status(now, name, out);
        self.flush(now, name, out);
    }

    /// Carries out a replica's commands (and those they lead to).
    pub(super) fn apply(&mut self, now: Time, name: &str, cmds: Vec<ChainCmd>, out: &mut Vec<Command>) {
        let mut queue: VecDeque<ChainCmd> = cmds.into();
        while let Some(c) = queue.pop_front() {
            match c {
                chain::Command::Send { to, msg } => {
                    tracing::trace!(mission = %name, %to, msg = msg.describe(), "chain: sending");
                    out.push(Command::Chain { to, envelope: Box::new(ChainEnvelope { mission: name.into(), from: self.node.clone(), msg }) });
                }
                chain::Command::Lead { config, state } => self.lead(now, name, config, state, out),
                chain::Command::Committed { .. } => self.flush(now, name, out),
                chain::Command::StepDown => self.step_down(name, "a newer manager took over", out),
                chain::Command::Retired => self.step_down(name, "this node left the mission's chain", out),
                chain::Command::Persist(disk) => out.push(Command::Persist { mission: name.into(), disk: Box::new(disk) }),
            }
        }
    }

    /// This node won the mission's chain: go on from the replicated state.
    pub(super) fn lead(&mut self, now: Time, name: &str, config: chain::Config, state: MissionSnapshot, out: &mut Vec<Command>) {
        if self.heads.contains_key(name) {
            return;
        }
        let mm = match MissionManager::restore(state, self.node.clone()) {
            Ok(mm) => mm,
            Err(e) => return tracing::warn!(mission = %name, "cannot take over: {e}"),
        };
        tracing::info!(mission = %name, chain_epoch = config.epoch, chain = ?config.chain, "took over the mission");
        // Robots already running the committed plans go on; those that missed them get them.
        let resend = mm.current_assignments();
        let lost: Vec<RobotId> = mm.members().filter(|id| !self.robots.alive(id.as_str())).cloned().collect();
        let back: Vec<Member> =
            if self.central_reachable() { vec![] } else { self.robots.alive_ids().iter().filter_map(|id| mm.lost(id.as_str()).cloned()).collect() };
        let mut head = Head::new(mm, None);
        head.defer(resend);
        self.heads.insert(name.into(), head);
        out.push(Command::Serve { mission: name.into() });
        if !lost.is_empty() {
            self.run(now, name, mission::Event::Lost { ids: lost }, out);
        }
        for member in back {
            self.run(now, name, mission::Event::Joined(member), out);
        }
        // The predecessor died while planning, and nothing above asked again: ask.
        if self.heads.get(name).is_some_and(|h| !h.asked_for_current()) {
            self.run(now, name, mission::Event::Resume, out);
        }
        self.set_pool(now, name);
        self.status(now, name, out);
    }

    pub(super) fn step_down(&mut self, name: &str, why: &str, out: &mut Vec<Command>) {
        let Some(h) = self.heads.remove(name) else {
            return;
        };
        tracing::info!(mission = %name, "no longer managing the mission: {why}");
        out.push(Command::Unserve { mission: name.into() });
        if let Some(q) = h.start {
            // The mission goes on under another manager of its chain: it started.
            out.push(Command::Reply { query: q, result: Err(ErrorReply::coded(ErrorCode::TakenOver, format!("taken over: mission {name}: {why}"))) });
        }
        for q in h.waiting_queries() {
            out.push(Command::Drop { query: q });
        }
    }

    /// Carries out what waited for the commit, once everything proposed is committed.
    pub(super) fn flush(&mut self, now: Time, name: &str, out: &mut Vec<Command>) {
        let committed = self.registry.replica(name).is_some_and(|r| r.committed().is_some_and(|c| c == r.version().1));
        if !committed {
            return;
        }
        let view = self.view(now, name, false);
        let managers = self.registry.replica(name).and_then(|r| r.config()).map(|c| c.chain.clone()).unwrap_or_default();
        let Some(h) = self.heads.get_mut(name) else {
            return;
        };
        let (effects, replies) = h.committed();
        for (query, ack) in replies {
            out.push(Command::Reply { query, result: json(&ack).map_err(ErrorReply::from) });
        }
        for c in effects {
            match c {
                mission::Command::SendPlan { robot, mut assignment } => {
                    assignment.managers = managers.clone();
                    if h.sending(now, robot.as_str(), assignment.clone()) {
                        out.push(Command::SendPlan { mission: name.into(), robot, assignment });
                    }
                }
                mission::Command::Started => {
                    if let (Some(q), Some(v)) = (h.start.take(), &view) {
                        out.push(Command::Reply { query: q, result: json(v).map_err(ErrorReply::from) });
                    }
                }
                mission::Command::Failed { error } => {
                    if let Some(q) = h.start.take() {
                        out.push(Command::Reply { query: q, result: Err(format!("mission {name}: planning failed: {error}").into()) });
                    }
                    return self.end(now, name, out);
                }
                mission::Command::RequestPlan { .. } => {}
            }
        }
    }

    /// Ends a led mission; the chain carries the end to every node of its chain.
    pub(super) fn end(&mut self, now: Time, name: &str, out: &mut Vec<Command>) {
        if self.heads.remove(name).is_some() {
            out.push(Command::Unserve { mission: name.into() });
        }
        let cmds = self.registry.handle(now, name, chain::Event::End);
        self.apply(now, name, cmds, out);
    }

    /// Tells a led mission's replica which nodes may join its chain: members with a host up.
    pub(super) fn set_pool(&mut self, now: Time, name: &str) {
        let Some(h) = self.heads.get(name) else {
            return;
        };
        let alive = self.registry.alive();
        let nodes: Vec<NodeId> = h.mm.members().map(|id| NodeId::from(id.as_str())).filter(|id| *id != self.node && alive.contains(id)).collect();
        let k = h.mm.replicas();
        let _ = self.registry.handle(now, name, chain::Event::Pool { nodes, k });
    }

    /// The mission's status, with the planner's summary only when it changed (or is due again).
    pub(super) fn status(&mut self, now: Time, name: &str, out: &mut Vec<Command>) {
        let Some(mut v) = self.view(now, name, false) else { return };
        if let Some(h) = self.heads.get_mut(name) {
            if !h.carries_summary(now, v.summary.as_ref()) {
                v.summary = None;
                v.summary_unchanged = true;
            }
        }
        out.push(Command::Status(Box::new(v)));
    }

    /// A led mission as the operator sees it at `now`, with its chain (and how long its head
    /// could not commit, if it cannot).
    pub fn view(&self, now: Time, name: &str, with_plans: bool) -> Option<MissionView> {
        let h = self.heads.get(name)?;
        let mut v = h.mm.view(with_plans);
        if let Some(r) = self.registry.replica(name) {
            if let Some(c) = r.config() {
                v.manager.chain_epoch = c.epoch;
                v.manager.chain = c.chain.clone();
            }
            v.manager.uncommitted_s = r.uncommitted_for(now).filter(|s| *s >= 1.0).map(|s| (s * 10.0).round() / 10.0);
        }
        Some(v)
    }
}
