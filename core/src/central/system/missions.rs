//! Operator commands on missions: create (validated in full, with a dry-run plan, before anything
//! changes), terminate, and moving robots between missions.

use std::collections::{BTreeMap, BTreeSet};

use mrmm_planner::recipe::{self, PlannerKind};
use mrmm_proto::ErrorReply;
use mrmm_proto::{
    self as proto, Member, MissionCreate, MissionCtl, MissionName, MissionStart, MissionTerminate, MissionView, NodeId, RobotCommand, RobotId, RobotMove,
    RobotSpec,
};
use serde_json::{json, Value};

use super::dry_runs::Checking;
use super::{recovery, to_value, Command, MissionDef, MissionRecord, PendingStart, Req, SystemManager, RESTART_RETRY_S};
use crate::mission::MissionSpec;
use crate::Failure;

/// The parameters of a dry run: `params` with little planning effort.
pub(super) fn cheap(r: &recipe::Recipe, params: &BTreeMap<String, String>) -> BTreeMap<String, String> {
    let mut dry = params.clone();
    for leaf in r.leaves() {
        let key = |k: &str| if leaf.path().is_empty() { k.to_string() } else { format!("{}/{k}", leaf.path()) };
        match leaf.recipe.planner {
            PlannerKind::Patrol => {
                dry.insert(key("max_kicks"), "10".into());
            }
            PlannerKind::Coverage => {
                for (k, v) in [("samples", "200"), ("lloyd_iterations", "1"), ("minimax_iterations", "1")] {
                    dry.insert(key(k), v.into());
                }
            }
        }
    }
    dry
}

/// An operator's parameters as the recipe takes them: strings (JSON for the rest).
pub(super) fn param_strings(params: &BTreeMap<String, Value>) -> BTreeMap<String, String> {
    params
        .iter()
        .map(|(k, v)| {
            let v = match v {
                Value::String(s) => s.clone(),
                other => other.to_string(),
            };
            (k.clone(), v)
        })
        .collect()
}

/// A create checked but for its dry run.
struct Checked {
    spec: MissionSpec,
    host: NodeId,
    robots: Vec<RobotSpec>,
    /// (robot, mission) taken from running missions.
    steal: Vec<(RobotId, MissionName)>,
    /// The parameters of the dry run (little effort) and its robots.
    dry: BTreeMap<String, String>,
    planner_robots: Vec<mrmm_proto::plan::RobotSpec>,
    caps: BTreeMap<String, Vec<String>>,
    map: Option<std::sync::Arc<mrmm_maps::Map>>,
}

impl Checked {
    fn dry_run(self, id: u64) -> DryRun {
        DryRun { id, recipe_xml: self.spec.recipe_xml, params: self.dry, robots: self.planner_robots, caps: self.caps, map: self.map }
    }
}

/// A plan to make with little effort before a create takes effect: it catches bad waypoints,
/// regions and parameters. Made by the driver off the system manager's loop, under a deadline.
#[derive(Debug, Clone, PartialEq)]
pub struct DryRun {
    pub id: u64,
    pub recipe_xml: String,
    pub params: BTreeMap<String, String>,
    pub robots: Vec<mrmm_proto::plan::RobotSpec>,
    /// The robots' capabilities (what puts them in a recipe's teams).
    pub caps: BTreeMap<String, Vec<String>>,
    /// The mission's map.
    pub map: Option<std::sync::Arc<mrmm_maps::Map>>,
}

impl DryRun {
    /// Plans it (pure; bounded by the planner's limits).
    pub fn run(&self) -> Result<(), String> {
        let r = recipe::parse(&self.recipe_xml).map_err(|e| e.to_string())?;
        recipe::build_for(&r, &self.params, &self.robots, &self.caps, self.map.as_deref()).map(|_| ()).map_err(|e| e.to_string())
    }
}

impl SystemManager {
    /// A create: checked in full here, then dry-run planned by the driver off this loop
    /// ([`Command::DryRun`]); it takes effect on [`SystemManager::dry_run_done`].
    pub(super) fn create(&mut self, req: Req, c: MissionCreate) -> Vec<Command> {
        let checked = match self.check_create(c.clone()) {
            Ok(x) => x,
            Err(e) => return vec![Command::Reply { req, result: Err(e) }],
        };
        let id = self.dry_runs.push(req, Checking::Create(c));
        vec![Command::DryRun(Box::new(checked.dry_run(id)))]
    }

    /// The dry run of check `id` is done: the create takes effect (checked again: the fleet may
    /// have changed meanwhile), or its error is the answer.
    pub(super) fn dry_run_done(&mut self, id: u64, result: Result<(), String>) -> Vec<Command> {
        let (req, c) = match self.dry_runs.take(id) {
            Some((req, Checking::Create(c))) => (req, c),
            Some((req, Checking::Update(u))) => return self.update_checked(req, u, result),
            None => return vec![],
        };
        if let Err(e) = result {
            return vec![Command::Reply { req, result: Err(ErrorReply::invalid(format!("mission {}: {e}", c.name))) }];
        }
        let c_json = serde_json::to_value(&c).unwrap_or(Value::Null);
        let Checked { spec, host, robots, steal, .. } = match self.check_create(c) {
            Ok(x) => x,
            Err(e) => return vec![Command::Reply { req, result: Err(e) }],
        };
        let name = spec.name.clone();
        // Robots taken from running missions leave them first (those missions replan); the new
        // mission starts once they are let go.
        let mut leaving: BTreeMap<MissionName, Vec<RobotId>> = BTreeMap::new();
        for (id, from) in steal {
            self.assignment.remove(&id);
            leaving.entry(from).or_default().push(id);
        }
        for (from, ids) in leaving {
            self.controls.let_go(from.as_str(), ids, vec![]);
        }
        // After every mission its robots are being let go by (just now, or earlier).
        let mut after: Vec<u64> = robots.iter().flat_map(|r| self.controls.pending_for(r.id.as_str())).collect();
        after.sort_unstable();
        after.dedup();
        let members = robots.iter().filter_map(|r| self.member(r.id.as_str())).collect();
        for r in &robots {
            self.assignment.insert(r.id.clone(), name.clone());
        }
        tracing::info!(mission = %name, %host, robots = robots.len(), "mission created");
        self.terminated.remove(&name);
        let wire = spec.to_wire();
        let def =
            MissionDef { host: host.clone(), recipe: spec.recipe_name.clone(), planner: spec.planner.as_str().into(), spec: Some(wire.clone()), lineage: 0 };
        self.missions.insert(name.clone(), MissionRecord::new(std::sync::Arc::new(def), None, false, self.now));
        self.recovery.handle(self.now, recovery::Event::Settled(name.as_str()));
        self.note_command(&req, "mission create", &c_json);
        self.pending_create.insert(name, req);
        self.starts.push(PendingStart { host, start: Box::new(MissionStart { spec: wire, members, anew: false, lineage: 0 }), after });
        vec![]
    }

    /// A new mission's name: valid, and neither a mission's here nor one robots still run.
    fn check_name(&self, name: &str) -> Result<(), ErrorReply> {
        proto::validate_id(name).map_err(|_| ErrorReply::invalid(format!("mission name {name:?}: use 1 to 64 characters of A-Z a-z 0-9 _ -")))?;
        if self.missions.contains_key(name) {
            return Err(ErrorReply::conflict(format!("mission {name:?} already exists")));
        }
        // A mission this manager does not know (it restarted, and that mission's head is gone
        // or has not reported) may still run on robots: its name is taken.
        let running: Vec<&str> = self
            .fleet
            .iter()
            .filter(|(_, r)| r.alive && r.last.as_ref().is_some_and(|t| t.mission.as_ref().map(|x| x.as_str()) == Some(name)))
            .map(|(id, _)| id.as_str())
            .collect();
        if !running.is_empty() && !self.terminated.contains(name) {
            return Err(ErrorReply::conflict(format!(
                "mission {name:?} still runs on robots {} though no manager of it has reported: choose another name",
                running.join(", ")
            )));
        }
        Ok(())
    }

    /// The robots a create asks for (listed, a count of idle ones, or the equal share) and the
    /// robots taken from other missions for it, or why not.
    #[allow(clippy::type_complexity)]
    fn choose_robots(&self, c: &MissionCreate, r: &recipe::Recipe, requires: &[String]) -> Result<(Vec<RobotId>, Vec<(RobotId, MissionName)>), ErrorReply> {
        match (&c.robots, c.count) {
            (Some(_), Some(_)) => Err(ErrorReply::invalid("give robots or count, not both")),
            (Some(list), None) => {
                let mut seen = BTreeSet::new();
                for id in list {
                    let info = self.live_robot(id.as_str())?;
                    super::capabilities::capable(id.as_str(), &info.capabilities, c.name.as_str(), requires)?;
                    if !seen.insert(id) {
                        return Err(ErrorReply::invalid(format!("robot {id:?} listed twice")));
                    }
                    if let Some(m) = self.assignment.get(id) {
                        return Err(ErrorReply::conflict(format!("robot {id:?} is in mission {m}: move it (robot move) or leave it out")));
                    }
                }
                Ok((list.clone(), vec![]))
            }
            (None, Some(k)) => {
                let idle = self.for_teams(r, self.idle_robots(requires));
                if k == 0 || k > idle.len() {
                    let with = if requires.is_empty() { String::new() } else { format!(" with {}", requires.join(", ")) };
                    return Err(ErrorReply::conflict(format!("count {k}: {} idle robots{with} available", idle.len())));
                }
                Ok((idle.into_iter().take(k).collect(), vec![]))
            }
            (None, None) => self.equal_share(requires, r),
        }
    }

    /// Everything a create needs but its dry run, or the first problem. Changes nothing.
    fn check_create(&self, c: MissionCreate) -> Result<Checked, ErrorReply> {
        self.check_name(c.name.as_str())?;
        let host = c.host.clone().unwrap_or_else(|| NodeId::from(proto::CENTRAL_HOST));
        if !self.fleet.has_host(host.as_str()) {
            let known: Vec<&str> = self.fleet.hosts().iter().map(|h| h.as_str()).collect();
            return Err(ErrorReply::not_found(format!(
                "no mission host {host:?} (hosts up: {})",
                if known.is_empty() { "none".into() } else { known.join(", ") }
            )));
        }
        let (recipe_name, xml) = match recipe::bank(&c.recipe) {
            Some(xml) => (c.recipe.clone(), xml.to_string()),
            None if c.recipe.trim_start().starts_with('<') => ("custom".to_string(), c.recipe.clone()),
            None => return Err(ErrorReply::not_found(format!("unknown recipe {:?}: give patrol, coverage, or a recipe XML document", c.recipe))),
        };
        let r = recipe::parse(&xml).map_err(|e| ErrorReply::invalid(format!("recipe {recipe_name}: {e}")))?;
        recipe::validate(&r).map_err(|e| ErrorReply::invalid(format!("recipe {recipe_name}: {e}")))?;
        let params = param_strings(&c.params);
        // Every scalar the operator gave is checked as given (the dry run below replaces some).
        for (k, v) in &params {
            recipe::check_override(&r, k, v).map_err(|e| ErrorReply::invalid(format!("mission {}: {e}", c.name)))?;
        }

        let held = match &c.map {
            None => None,
            Some(m) => Some(self.maps.get(m).cloned().ok_or_else(|| {
                let known: Vec<&str> = self.maps.keys().map(String::as_str).collect();
                ErrorReply::not_found(format!(
                    "no map {m:?} (maps: {})",
                    if known.is_empty() { "none: give central --map NAME=FILE".into() } else { known.join(", ") }
                ))
            })?),
        };
        let requires = r.required();
        let (ids, steal) = self.choose_robots(&c, &r, &requires)?;
        if ids.is_empty() {
            return Err(ErrorReply::invalid("a mission needs at least one robot"));
        }
        let specs: Vec<RobotSpec> = ids.iter().filter_map(|id| self.spec(id.as_str())).collect();
        // Dry run with little effort: catches bad waypoints, regions and parameters now.
        let dry = cheap(&r, &params);
        let caps = ids.iter().map(|id| (id.to_string(), self.capabilities_of(id.as_str()).to_vec())).collect();
        let planner_robots = specs.clone();
        let replicas = c.replicas.unwrap_or(proto::DEFAULT_REPLICAS);
        if replicas > proto::MAX_REPLICAS {
            return Err(ErrorReply::invalid(format!("replicas: at most {} (got {replicas})", proto::MAX_REPLICAS)));
        }
        let spec = MissionSpec {
            name: c.name,
            recipe_name,
            recipe_xml: xml,
            planner: r.planner,
            params,
            replicas,
            requires: r.required(),
            map: held.as_ref().map(|h| h.map_ref()),
            paused: false,
        };
        Ok(Checked { spec, host, robots: specs, steal, dry, planner_robots, caps, map: held.map(|h| h.map.clone()) })
    }

    /// Alive, registered robots in no mission and running no plan, by id. A robot that runs a
    /// plan of a mission this manager does not know belongs to a mission whose head has not
    /// reported yet (after a restart of central, or a partition): it is not free.
    /// Only robots with every capability of `requires`.
    /// Whether robot `id` fits a leaf team of `r` (any robot fits a recipe without teams).
    fn fits(&self, r: &recipe::Recipe, id: &str) -> bool {
        !r.has_teams() || self.spec(id).is_some_and(|s| r.leaves().iter().any(|l| l.fits(&s.robot_type, self.capabilities_of(id))))
    }

    /// The robots of `ids` that fit a team of `r`, those a team's `min` needs first (each leaf
    /// team's minimum in turn, in document order), the others after, in their order.
    fn for_teams(&self, r: &recipe::Recipe, ids: Vec<RobotId>) -> Vec<RobotId> {
        if !r.has_teams() {
            return ids;
        }
        let mut rest: Vec<RobotId> = ids.into_iter().filter(|id| self.fits(r, id.as_str())).collect();
        let mut first = Vec::new();
        for leaf in r.leaves() {
            for _ in 0..leaf.min {
                let Some(at) = rest.iter().position(|id| self.spec(id.as_str()).is_some_and(|s| leaf.fits(&s.robot_type, self.capabilities_of(id.as_str()))))
                else {
                    break;
                };
                first.push(rest.remove(at));
            }
        }
        first.extend(rest);
        first
    }

    fn idle_robots(&self, requires: &[String]) -> Vec<RobotId> {
        self.fleet
            .iter()
            .filter(|(id, r)| r.ready() && !self.assignment.contains_key(*id))
            .filter(|(id, _)| self.has_all(id.as_str(), requires))
            // Running no plan, and not admitted to a mission that may still count on it (a
            // central that restarted may not know that mission yet).
            .filter(|(_, r)| r.last.as_ref().is_some_and(|t| t.mission.is_none() && t.admitted.iter().all(|m| self.terminated.contains(m))))
            .map(|(id, _)| id.clone())
            .collect()
    }

    /// The paper's default: the fleet split equally over the missions, the new one included.
    /// Idle robots first; then robots taken from the largest missions, never below their share.
    /// Only robots with every capability of `requires` that fit a team of `r` are chosen, those its
    /// teams' minimums need first.
    #[allow(clippy::type_complexity)]
    fn equal_share(&self, requires: &[String], r: &recipe::Recipe) -> Result<(Vec<RobotId>, Vec<(RobotId, MissionName)>), ErrorReply> {
        let fits = |id: &str| self.fits(r, id);
        let alive = self.fleet.ready_count();
        let share = (alive / (self.missions.len() + 1)).max(1);
        // The robots its teams' minimums need first.
        let mut chosen: Vec<RobotId> = self.for_teams(r, self.idle_robots(requires)).into_iter().take(share).collect();
        let mut steal = Vec::new();
        let mut sizes: BTreeMap<MissionName, Vec<RobotId>> = BTreeMap::new();
        for (robot, m) in self.assignment.iter() {
            if self.fleet.alive(robot.as_str()) {
                sizes.entry(m.clone()).or_default().push(robot.clone());
            }
        }
        let capable = |id: &str| self.has_all(id, requires) && fits(id);
        while chosen.len() < share {
            let Some((name, members)) =
                sizes.iter_mut().filter(|(_, v)| v.len() > share && v.iter().any(|id| capable(id.as_str()))).max_by_key(|(_, v)| v.len())
            else {
                break;
            };
            let Some(at) = members.iter().rposition(|id| capable(id.as_str())) else { break };
            let id = members.remove(at);
            chosen.push(id.clone());
            steal.push((id, name.clone()));
        }
        if chosen.is_empty() && !requires.is_empty() {
            return Err(ErrorReply::conflict(format!(
                "no robot with {} available: every such robot is lost or in a mission that cannot spare one",
                requires.join(", ")
            )));
        }
        if chosen.is_empty() {
            return Err(ErrorReply::conflict("no robot available: every robot is lost or in a mission that cannot spare one"));
        }
        Ok((chosen, steal))
    }

    pub(super) fn terminate(&mut self, req: Req, t: MissionTerminate) -> Vec<Command> {
        if self.missions.remove(&t.name).is_none() {
            return vec![Command::Reply { req, result: Err(ErrorReply::not_found(format!("unknown mission {:?}", t.name))) }];
        }
        let robots: Vec<RobotId> = self.assignment.iter().filter(|(_, m)| **m == t.name).map(|(r, _)| r.clone()).collect();
        self.terminated.insert(t.name.clone());
        self.controls.cancel(t.name.as_str());
        self.controls.push(t.name.as_str(), MissionCtl::Terminate, vec![]);
        self.starts.retain(|s| s.start.spec.name != t.name);
        let mut out = Vec::new();
        for id in &robots {
            self.assignment.remove(id);
            out.push(Command::SendToRobot { req: None, robot: id.clone(), cmd: RobotCommand::Leave { mission: t.name.clone(), epoch: u64::MAX } });
        }
        if let Some(pending) = self.pending_create.remove(&t.name) {
            out.push(Command::Reply { req: pending, result: Err(ErrorReply::conflict(format!("mission {} was terminated", t.name))) });
        }
        self.recovery.handle(self.now, recovery::Event::Settled(t.name.as_str()));
        self.note_command(&req, "mission terminate", &serde_json::to_value(&t).unwrap_or(Value::Null));
        tracing::info!(mission = %t.name, "mission terminated");
        out.push(Command::Reply { req, result: Ok(json!({"ok": true, "mission": t.name, "robots": robots})) });
        out
    }

    /// Moves a robot to mission `to`, or frees it (`to: null`; a lost robot may be freed too).
    pub(super) fn move_robot(&mut self, req: Req, mv: RobotMove) -> Vec<Command> {
        let reply = |req: Req, result| vec![Command::Reply { req, result }];
        if mv.replaces.is_some() && mv.to.is_none() {
            return reply(req, Err(ErrorReply::invalid("a robot replaces a member of the mission it moves to: `to` is needed")));
        }
        let from = self.assignment.get(&mv.robot).cloned();
        // A robot of a mission that has not come back since central restarted may be freed too.
        let alive = match self.fleet.get(mv.robot.as_str()).filter(|r| r.info.is_some()) {
            Some(r) => r.alive,
            None if from.is_some() && mv.to.is_none() => false,
            None => return reply(req, Err(ErrorReply::not_found(format!("unknown robot {:?}", mv.robot)))),
        };
        if !alive && mv.to.is_some() {
            return reply(req, Err(ErrorReply::conflict(format!("robot {:?} is lost", mv.robot))));
        }
        if let Some(to) = &mv.to {
            if !self.missions.contains_key(to) {
                return reply(req, Err(ErrorReply::not_found(format!("unknown mission {to:?}"))));
            }
            if from.as_ref() == Some(to) {
                return reply(req, Err(ErrorReply::conflict(format!("robot {:?} is already in mission {to}", mv.robot))));
            }
            if let Err(e) = self.check_capable(mv.robot.as_str(), to.as_str()) {
                return reply(req, Err(e));
            }
        } else if from.is_none() {
            return reply(req, Err(ErrorReply::conflict(format!("robot {:?} is in no mission", mv.robot))));
        }
        let member = match &mv.to {
            Some(_) => match self.member(mv.robot.as_str()) {
                Some(m) => Some(m),
                None => return reply(req, Err(ErrorReply::not_found(format!("unknown robot {:?}", mv.robot)))),
            },
            None => None,
        };
        let mut out = match (&mv.replaces, mv.to.clone().zip(member)) {
            (Some(gone), Some((to, member))) => match self.check_replace(mv.robot.as_str(), gone, &to) {
                Ok(gone_alive) => self.apply_replace(mv.robot.as_str(), from.clone(), (&to, member), gone, gone_alive),
                Err(e) => return reply(req, Err(e)),
            },
            (_, to) => self.apply_move(mv.robot.as_str(), from.clone(), to, alive),
        };
        self.note_command(&req, "robot move", &serde_json::to_value(&mv).unwrap_or(Value::Null));
        tracing::info!(robot = %mv.robot, ?from, to = ?mv.to, "robot moved");
        let answer = match &mv.replaces {
            Some(gone) => json!({"ok": true, "robot": mv.robot, "from": from, "to": mv.to, "replaces": gone}),
            None => json!({"ok": true, "robot": mv.robot, "from": from, "to": mv.to}),
        };
        out.push(Command::Reply { req, result: to_value(&answer) });
        out
    }

    /// Takes `robot` out of mission `from` (its head lets it go; an `alive` robot freed is told to
    /// leave) and into `to` with its member record, once every mission it was in let it go.
    pub(super) fn apply_move(&mut self, robot: &str, from: Option<MissionName>, to: Option<(MissionName, Member)>, alive: bool) -> Vec<Command> {
        let mut out = Vec::new();
        let mut left = self.controls.pending_for(robot);
        if let Some(f) = &from {
            self.assignment.remove(robot);
            // After the release still pending from the mission before (whose head may still
            // count it: found by the system sim, seed 375 with digest beats), so that it joins
            // its next mission only once every mission it was in let it go.
            let ctl = self.controls.let_go(f.as_str(), vec![RobotId::from(robot)], left.clone());
            left.push(ctl);
            if to.is_none() && alive {
                out.push(Command::SendToRobot { req: None, robot: RobotId::from(robot), cmd: RobotCommand::Leave { mission: f.clone(), epoch: u64::MAX } });
            }
        }
        if let Some((to, member)) = to {
            self.assignment.insert(RobotId::from(robot), to.clone());
            // It joins once its old mission let it go: never in two teams.
            self.controls.push(to.as_str(), MissionCtl::Joined { member }, left);
        }
        out
    }

    /// Whether `robot` may take `gone`'s place in mission `to`: `gone` is another robot, a
    /// member of `to`. Answers whether `gone` is alive.
    fn check_replace(&self, robot: &str, gone: &RobotId, to: &MissionName) -> Result<bool, ErrorReply> {
        if gone.as_str() == robot {
            return Err(ErrorReply::invalid(format!("robot {robot:?} cannot replace itself")));
        }
        if self.assignment.get(gone) != Some(to) {
            return Err(ErrorReply::conflict(format!("robot {gone:?} is not in mission {to}")));
        }
        Ok(self.fleet.get(gone.as_str()).is_some_and(|r| r.alive))
    }

    /// `robot` takes `gone`'s place in mission `to` (a hand-over): one control takes `gone` out
    /// and `robot` in, so the head carries its plan on instead of replanning twice; `gone` is
    /// held by the mission until the head acknowledged, and told to leave if alive; `robot` is
    /// let go first by a mission it was in.
    fn apply_replace(
        &mut self,
        robot: &str,
        from: Option<MissionName>,
        (to, member): (&MissionName, Member),
        gone: &RobotId,
        gone_alive: bool,
    ) -> Vec<Command> {
        let mut out = Vec::new();
        let mut after = self.controls.pending_for(robot);
        after.extend(self.controls.pending_for(gone.as_str()));
        if let Some(f) = &from {
            self.assignment.remove(robot);
            after.push(self.controls.let_go(f.as_str(), vec![RobotId::from(robot)], after.clone()));
        }
        self.assignment.remove(gone);
        self.assignment.insert(RobotId::from(robot), to.clone());
        let ctl = self.controls.push(to.as_str(), MissionCtl::Replaced { out: gone.clone(), member }, after);
        self.controls.hold(gone.clone(), to.as_str(), ctl);
        if gone_alive {
            out.push(Command::SendToRobot { req: None, robot: gone.clone(), cmd: RobotCommand::Leave { mission: to.clone(), epoch: u64::MAX } });
        }
        out
    }

    /// Records an accepted operator (or agent) command in the journal's history.
    pub(super) fn note_command(&mut self, req: &Req, command: &str, request: &Value) {
        let by = match req {
            Req::Query(_) => "operator".to_string(),
            Req::Agent(_) => "agent".to_string(),
        };
        self.journal.note(proto::JournalEvent::Command { by, command: command.to_string(), request: request.clone() });
    }

    /// The first plans of a mission are out, or its planning failed, or its host did not answer.
    pub(super) fn started(&mut self, name: &str, result: Result<Box<MissionView>, Failure>) -> Vec<Command> {
        let answered = recovery::Event::Answered { mission: name, ok: result.is_ok() };
        if self.recovery.handle(self.now, answered).contains(&recovery::Decision::Restarted) {
            // A journaled mission started again: it is never forgotten for failing; tried again.
            match result {
                Ok(view) => {
                    tracing::info!(mission = %name, "mission running again");
                    if let Some(rec) = self.missions.get_mut(name) {
                        rec.view = Some(*view);
                        rec.reported_at = self.now;
                    }
                    self.resync(name);
                }
                Err(f) => tracing::warn!(mission = %name, "starting the mission again failed ({}); trying again in {RESTART_RETRY_S} s", f.error),
            }
            return vec![];
        }
        let req = self.pending_create.remove(name);
        let reply = |result| req.map(|req| Command::Reply { req, result }).into_iter().collect::<Vec<_>>();
        match result {
            Ok(view) => {
                tracing::info!(mission = %name, "mission running");
                if let Some(rec) = self.missions.get_mut(name) {
                    rec.view = Some(*view);
                    rec.reported_at = self.now;
                }
                reply(to_value(&self.mission_view(name)))
            }
            Err(f) if !self.missions.contains_key(name) => reply(Err(ErrorReply::conflict(f.error))),
            Err(f) if f.is(mrmm_proto::ErrorCode::TakenOver) => {
                // Another manager of its chain runs it: its head's reports will say which.
                tracing::info!(mission = %name, "mission started; another of its managers took it over");
                reply(to_value(&self.mission_view(name)))
            }
            Err(f) if f.retryable => {
                // Nobody answered: the mission may be running. End it, and free its robots
                // only once its head acknowledged the end — never in two missions.
                tracing::warn!(mission = %name, "no answer to the start: ending the mission in case it started");
                self.missions.remove(name);
                self.terminated.insert(MissionName::from(name));
                // What waited for this mission's controls (a robot moved out of it, released by
                // it before joining another) now waits for its end.
                let end = self.controls.end(name);
                let robots: Vec<RobotId> = self.assignment.iter().filter(|(_, m)| *m == name).map(|(r, _)| r.clone()).collect();
                let mut out = Vec::new();
                for id in robots {
                    self.assignment.remove(&id);
                    // Held until the end is acknowledged (and by any release still pending from a
                    // mission it was moved out of: its head may still count it; system sim, seed 3516).
                    self.controls.hold(id.clone(), name, end);
                    out.push(Command::SendToRobot { req: None, robot: id, cmd: RobotCommand::Leave { mission: MissionName::from(name), epoch: u64::MAX } });
                }
                out.extend(reply(Err(ErrorReply::busy(format!("mission {name} did not start: {}; it was ended in case it had", f.error)))));
                out
            }
            Err(f) => {
                // The mission never ran: forget it, free its robots.
                self.missions.remove(name);
                self.assignment.retain(|_, m| m != name);
                self.controls.cancel(name);
                tracing::warn!(mission = %name, "mission failed: {}", f.error);
                reply(Err(f.reply()))
            }
        }
    }
}
