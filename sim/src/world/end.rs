//! The end of a run, after the quiet period: which missions could still recover, and the checks
//! that must hold once every fault healed (one head per mission, members on its epoch, every
//! mission the operator was told "ok" about led again when chains are on disk).

use super::*;

impl World {
    /// Whether a majority of `mission`'s newest chain still holds its state.
    pub(super) fn recoverable(&self, mission: &str) -> bool {
        let replicas: Vec<(&String, &mrmm_core::mission::chain::Replica<mrmm_proto::MissionSnapshot>)> =
            self.nodes.iter().filter_map(|n| Some((&n.name, n.host.as_ref()?.replica(mission)?))).collect();
        let Some(newest) = replicas.iter().filter_map(|(_, r)| r.config()).max_by_key(|c| c.epoch) else {
            return false;
        };
        newest.majority(|node| replicas.iter().any(|(n, r)| n.as_str() == node && r.state().is_some()))
    }

    /// Every node's replica of `mission`, for a violation's message.
    fn replicas_of(&self, mission: &str) -> Vec<String> {
        self.nodes
            .iter()
            .filter_map(|n| {
                let r = n.host.as_ref()?.replica(mission)?;
                Some(format!("{}: {:?} {:?} v{:?} committed {:?}", n.name, r.role(), r.config(), r.version(), r.committed()))
            })
            .collect()
    }

    /// After the quiet period: one head per mission, every live member on its current epoch, no
    /// robot in two missions; barrier plans finished.
    pub(super) fn finish(&mut self) -> Result<(), String> {
        let alive: BTreeSet<MissionName> =
            self.nodes.iter().filter_map(|n| n.host.as_ref()).flat_map(|h| h.heads().map(|(m, _)| m.clone()).collect::<Vec<_>>()).collect();
        self.inv.forget_missions(&alive);
        self.one_mission_per_robot()?;
        self.central_knows_who_is_up()?;
        if let Ops::Barriers { .. } = self.cfg.ops {
            return self.plans_finished();
        }
        let mut heads: Heads = BTreeMap::new();
        for n in &self.nodes {
            let Some(h) = &n.host else { continue };
            for (m, mm) in h.heads() {
                heads.entry(m.clone()).or_default().push((n.name.clone(), mm.epoch(), mm.members().cloned().collect()));
            }
        }
        for (m, hs) in &heads {
            if !self.recoverable(m.as_str()) {
                // With disks (central's host keeps its chain state beside its journal) a chain
                // never loses its memory.
                if self.cfg.disks {
                    return Err(format!("{m}'s chain lost its memory although every node of it keeps its chain state on disk"));
                }
                // A majority of its chain restarted and lost what it held (without disks): the
                // chain cannot safely form again; robots keep their plans.
                self.report.unrecoverable += 1;
                continue;
            }
            if hs.len() > 1 {
                let names: Vec<&String> = hs.iter().map(|h| &h.0).collect();
                return Err(format!("{} heads of {m} after healing: {names:?}", hs.len()));
            }
            if !self.op.terminated.contains(m) {
                self.members_after_healing(m.as_str(), &hs[0])?;
            }
        }
        self.central_missions_led(&heads)?;
        self.report.missions_at_end = heads.len();
        self.report.commands_ok = self.op.ok;
        Ok(())
    }

    /// Central shows lost exactly the registered robots whose tokens its node does not hold up,
    /// whatever liveliness changes its system manager missed (`Config::missed_live`).
    fn central_knows_who_is_up(&self) -> Result<(), String> {
        for (i, n) in self.nodes.iter().enumerate() {
            let Some(c) = n.central.as_ref().filter(|_| self.links.up[i]) else { continue };
            for v in c.system().views() {
                let up = self.beliefs.up_for(i).any(|t| *t == Token::Robot(v.id.as_str().to_string()));
                if up == (v.status == mrmm_proto::RobotStatus::Lost) {
                    return Err(format!("after healing, central shows {} {:?} while its token is {}", v.id, v.status, if up { "up" } else { "gone" }));
                }
            }
        }
        Ok(())
    }

    /// In a barrier run, every live robot finished its plan.
    fn plans_finished(&self) -> Result<(), String> {
        for (i, n) in self.nodes.iter().enumerate() {
            let done = n.robot.as_ref().and_then(|r| r.executor()).is_some_and(|e| e.progress().done);
            if self.links.up[i] && !done {
                let at = n.robot.as_ref().and_then(|r| r.executor()).map(|e| e.progress());
                return Err(format!("{} did not finish its plan: {at:?}", n.name));
            }
        }
        Ok(())
    }

    /// The view of mission `m` its head `head` gives.
    fn view_at(&self, head: &str, m: &str) -> Option<mrmm_proto::MissionView> {
        self.index(head).and_then(|i| self.nodes[i].host.as_ref()).and_then(|h| h.heads().find(|(n, _)| *n == m).map(|(_, mm)| mm.view(false)))
    }

    /// Mission `m`'s live members, led by its one head: they hold if it is paused, have what it
    /// requires, and run its current epoch.
    fn members_after_healing(&mut self, m: &str, (head, epoch, members): &(String, u64, Vec<RobotId>)) -> Result<(), String> {
        let view = self.view_at(head, m);
        // A paused mission's live members hold where they are.
        if view.as_ref().is_some_and(|v| v.status == mrmm_proto::MissionStatus::Paused) {
            self.report.paused_at_end += 1;
            for r in members {
                let Some(i) = self.index(r.as_str()).filter(|i| self.links.up[*i]) else { continue };
                let steps = self.nodes[i].robot.as_ref().and_then(|rb| rb.executor()).map(|e| e.assignment.plan.steps.clone());
                let holds =
                    steps.as_deref().is_some_and(|s| s.iter().all(|s| matches!(s, mrmm_proto::Step::Stream | mrmm_proto::Step::Hold { seconds: None })));
                if !holds {
                    return Err(format!("live member {r} of paused mission {m} does not hold: {steps:?}"));
                }
            }
        }
        // Every live member has what its mission requires (a member that lost it was taken out).
        let requires = view.map(|v| v.requires);
        for r in members {
            let Some(i) = self.index(r.as_str()) else { continue };
            let has = self.nodes[i].robot.as_ref().map(|rb| rb.info(vec![]).capabilities).unwrap_or_default();
            if let Some(lacks) = requires.iter().flatten().find(|c| !has.contains(c)).filter(|_| self.links.up[i]) {
                return Err(format!("live member {r} of {m} lacks {lacks}, which {m} requires, after healing"));
            }
            if requires.as_ref().is_some_and(|q| !q.is_empty()) && self.links.up[i] {
                self.report.required_checked += 1;
            }
            let running = self.nodes[i].robot.as_ref().and_then(|rb| rb.executor()).map(|e| (e.mission().to_string(), e.epoch()));
            if self.links.up[i] && running != Some((m.to_string(), *epoch)) {
                return Err(format!("live member {r} of {m} runs {running:?}, not {m}'s epoch {epoch}, after healing; replicas: {:?}", self.replicas_of(m)));
            }
        }
        Ok(())
    }

    /// Missions central's journal defines: without disks, those nobody leads are counted; with
    /// every chain on disk, nothing the operator was told "ok" about is lost — every mission
    /// created ok that the journal still defines is led again after healing.
    fn central_missions_led(&mut self, heads: &Heads) -> Result<(), String> {
        let Some(c) = self.nodes.iter().find_map(|n| n.central.as_ref()) else { return Ok(()) };
        let durable = c.system().durable();
        let unled: Vec<&MissionName> =
            durable.missions.keys().filter(|m| self.op.created.contains(*m) && !durable.terminated.contains(*m) && !heads.contains_key(*m)).collect();
        if self.cfg.disks {
            if let Some(m) = unled.first() {
                return Err(format!("{m} is in central's journal but nobody leads it after healing; replicas: {:?}", self.replicas_of(m.as_str())));
            }
        } else {
            self.report.headless = u32::try_from(unled.len()).unwrap_or(u32::MAX);
        }
        Ok(())
    }
}

/// Each mission's heads: the node, its epoch, its members.
type Heads = BTreeMap<MissionName, Vec<(String, u64, Vec<RobotId>)>>;
