//! The system manager as a state machine: it knows every robot, every mission and every mission
//! host, answers operator requests, creates and terminates missions and moves robots between
//! them. Missions are run by mission managers on mission hosts (`host/`); the system manager owns
//! the membership — every robot in at most one mission, and a lost robot keeps its place in its
//! mission until it comes back or the operator frees it — and steers hosts with [`MissionCtl`]s
//! that are re-sent until acknowledged (`ctl.rs`). No I/O: [`SystemManager::handle`] takes the
//! time and an [`Event`] and returns the [`Command`]s the driver must carry out.

pub mod asks;
mod candidates;
mod capabilities;
mod changes;
mod controls;
mod ctl;
mod dry_runs;
pub mod durable;
pub mod egress;
mod events;
mod flaps;
mod fleet;
pub mod ingress;
mod journal;
pub mod missions;
mod recovery;
mod replay;
mod reports;
mod steer;
mod touched;
mod views;

use std::collections::{BTreeMap, BTreeSet};
use std::sync::Arc;

use mrmm_proto::{
    self as proto, CapabilitiesRequest, ChainEnvelope, CommandAck, GotoRequest, JournalEvent, Key, Member, MissionCtl, MissionName, MissionStart,
    MissionStatus, MissionView, NodeId, RobotCommand, RobotId, RobotInfo, RobotSpec, RobotStatus, RobotView, Sender, SystemStatus, Telemetry,
};
use mrmm_proto::{ErrorReply, Time};
use serde_json::Value;

pub use ctl::{Ctls, CTL_GIVE_UP_S, CTL_RETRY_S};
pub use durable::{Durable, MissionDef};
pub use egress::{egress, subscriptions};
pub use events::{Command, Event, Req, Request};
use fleet::{Fact, Fleet, Heard};
pub use ingress::{ingress, sealed};
use journal::Journal;

/// Missions adopted from their heads' reports at most (a journal lost, a fleet of missions that
/// ran on): beyond, reports of unknown missions are not adopted.
pub const MAX_ADOPTED: usize = 1_000;
/// A robot lost this long (seconds) and in no mission leaves the registry (default; central's
/// `forget_lost_s`).
pub const FORGET_LOST_S: f64 = 86_400.0;
/// Seconds between two looks for long-lost robots to forget.
const FORGET_EVERY_S: f64 = 60.0;
/// A head's report disagreeing with its mission's definition this long, with no update on its
/// way, has the definition sent again (`changes.rs`).
pub const SPEC_SYNC_S: f64 = 2.0;
/// Seconds between two info requests to a robot that is alive but not yet registered.
pub const INFO_RETRY_S: f64 = 1.0;
/// Robots the registry holds at most.
pub const MAX_FLEET: usize = 10_000;
/// Info queries asked again per tick at most.
pub const FETCH_PER_TICK: usize = 64;
/// Operator commands held at most while a fresh manager learns the fleet.
pub const MAX_HELD: usize = 1_000;
/// Seconds between two leave orders to a robot still running a plan it should not have.
pub const LEAVE_RETRY_S: f64 = 2.0;
/// For this long after a mission acknowledged letting a robot go, its reports listing the robot
/// are taken as older than the order.
pub const RELEASE_GRACE_S: f64 = 5.0;
/// For this long after it starts, the system manager holds commands that assign robots, while
/// the heads of running missions report which robots are theirs (two status periods).
pub const ADOPT_S: f64 = 2.0;
/// A mission of the journal that no live manager reports this long after the system manager
/// started (and that no robot says it runs) may be started again (see `recovery.rs`).
pub const RESTART_S: f64 = 5.0;
/// A mission's member with a state dir that came up this recently may still bring the mission
/// back through its chain, from its disk: the mission is not started anew before.
pub const DURABLE_WAIT_S: f64 = 15.0;
/// A mission of the journal that robots run but that no manager reports this long after the
/// system manager started — or that no manager has reported for this long while it ran — has no
/// chain that can take over (it lost its majority): it is started anew too.
pub const RUNNING_WAIT_S: f64 = 20.0;
/// A mission whose head reports it could not commit for this long has a chain that lost the
/// memory of a majority of its nodes (they restarted without disks): it never commits a change
/// again, so it is started anew (see `recovery.rs`); the host of such a head gives it up for
/// the new lineage.
pub const UNCOMMITTED_WAIT_S: f64 = 20.0;
/// Seconds between two attempts to start a journaled mission again.
pub const RESTART_RETRY_S: f64 = 5.0;
/// A head's report that lists a robot present this long after the robot's liveliness appeared
/// has seen it back (two status periods and then some).
pub const SEEN_BACK_S: f64 = 4.0;

/// What the system manager knows of a mission.
#[derive(Debug, Clone)]
pub(crate) struct MissionRecord {
    /// The node managing it as last reported (its host until a replica takes over).
    host: NodeId,
    /// As defined (durable).
    def: Arc<MissionDef>,
    /// The head's latest view.
    view: Option<MissionView>,
    /// The managers before the latest change of them ([`SystemManager::managers`] then): one
    /// of them heading a newer chain epoch than the latest view's may report. A takeover
    /// reported here before its chain took it may lose its election to a manager it dropped
    /// (membership sim, seed 926: central, seeing its head gone, reported itself head of a
    /// chain without it; the head was alive, won the next epoch, and was refused for ever).
    former: Vec<NodeId>,
    /// When a manager last reported it (or it was defined here): a mission none reports for
    /// [`RUNNING_WAIT_S`] while robots still run it has lost its chain (`recovery.rs`).
    reported_at: Time,
    /// Capabilities every member must have (from its recipe; for an adopted mission, from its
    /// head's reports).
    requires: Vec<String>,
    /// Adopted from its head's report since this manager started: its membership is learnt
    /// from reports. Otherwise (created here, or restored from the journal) this manager's
    /// assignment is the truth and heads are corrected.
    adopted: bool,
    /// Since when its head's reports show another definition than `def`'s (`changes.rs`).
    spec_differs_since: Option<Time>,
}

impl MissionRecord {
    fn new(def: Arc<MissionDef>, view: Option<MissionView>, adopted: bool, now: Time) -> MissionRecord {
        let requires = match &view {
            Some(v) if def.spec.is_none() => capabilities::reported(v),
            _ => capabilities::requirements(&def),
        };
        MissionRecord { host: def.host.clone(), def, view, former: Vec::new(), adopted, reported_at: now, requires, spec_differs_since: None }
    }

    /// Its host, then the head and chain of its latest view.
    fn managers(&self) -> Vec<NodeId> {
        let mut out = vec![self.host.clone()];
        if let Some(v) = &self.view {
            for n in std::iter::once(&v.manager.node).chain(&v.manager.chain) {
                if !out.contains(n) {
                    out.push(n.clone());
                }
            }
        }
        out
    }
}

/// A mission start waiting for the missions its robots come from to let them go.
#[derive(Debug, Clone)]
struct PendingStart {
    host: NodeId,
    start: Box<MissionStart>,
    after: Vec<u64>,
}

/// The system manager: the missions' lifecycle and the operator's commands, over three machines
/// with state of their own — the registry of robots and hosts ([`Fleet`], `fleet.rs`), the
/// controls waiting for heads and the robots being let go ([`controls::Controls`]), and recovery
/// of journaled missions no live manager runs ([`recovery::Recovery`]) — whose decisions it
/// carries out.
#[derive(Debug, Clone)]
pub struct SystemManager {
    node: NodeId,
    started: Time,
    now: Time,
    fleet: Fleet,
    missions: BTreeMap<MissionName, MissionRecord>,
    /// Robot → mission: every robot is in at most one mission (a lost one keeps its place).
    assignment: touched::Touched<BTreeMap<RobotId, MissionName>>,
    /// Missions whose create request waits for the first plan.
    pending_create: BTreeMap<MissionName, Req>,
    starts: Vec<PendingStart>,
    /// Missions terminated here: robots still running them are ordered out, heads still
    /// reporting them are told again.
    terminated: touched::Touched<BTreeSet<MissionName>>,
    /// Robots on charging errands, as central's charging policy has them (journaled here).
    errands: BTreeMap<RobotId, mrmm_proto::ErrandRecord>,
    /// Controls waiting for heads, and the robots missions are letting go.
    controls: controls::Controls,
    /// Commands held while the manager learns the fleet after starting.
    held: Vec<(Req, Request)>,
    /// What the driver refused and took at the node's edge, as it last said.
    edge: views::EdgeCounts,
    /// Creates and updates waiting for their dry run.
    dry_runs: dry_runs::DryRuns,
    /// What the journal holds, and the history to add to it.
    journal: Journal,
    /// Journaled missions no live manager runs, started anew.
    recovery: recovery::Recovery,
    /// The maps missions may plan on, by name (central's config).
    maps: BTreeMap<String, Arc<crate::maps::Held>>,
    /// Former versions of those maps that journaled missions still plan on, by hash.
    superseded: BTreeMap<String, Arc<crate::maps::Held>>,
    /// Robots' recent losses and returns: a flapping robot is journaled as one entry.
    flaps: flaps::Flaps,
    /// What the network says is up, now and then: liveliness events the registry missed.
    roll: crate::roll_call::RollCall,
    /// Robots lost this long and in no mission are forgotten; when that was last looked at.
    forget_lost_s: f64,
    forgot_at: Time,
    /// Senders whose report of an unknown mission was not adopted (logged once each; at most
    /// [`MAX_ADOPTED`]).
    adoptions_refused: BTreeSet<Sender>,
}

impl SystemManager {
    /// `node` is the Zenoh id shown to operators; `now` the driver clock in seconds.
    pub fn new(node: NodeId, now: Time) -> Self {
        SystemManager {
            node,
            started: now,
            now,
            fleet: Fleet::default(),
            missions: BTreeMap::new(),
            assignment: touched::Touched::default(),
            pending_create: BTreeMap::new(),
            starts: Vec::new(),
            terminated: touched::Touched::default(),
            errands: BTreeMap::new(),
            controls: controls::Controls::default(),
            held: Vec::new(),
            edge: views::EdgeCounts::default(),
            dry_runs: dry_runs::DryRuns::default(),
            journal: Journal::default(),
            recovery: recovery::Recovery::new(now),
            maps: BTreeMap::new(),
            superseded: BTreeMap::new(),
            adoptions_refused: BTreeSet::new(),
            flaps: flaps::Flaps::default(),
            roll: crate::roll_call::RollCall::default(),
            forget_lost_s: FORGET_LOST_S,
            forgot_at: now,
        }
    }

    /// The maps missions may plan on (`mrmm/system/maps`, a create's `map`).
    pub fn with_maps(mut self, maps: BTreeMap<String, Arc<crate::maps::Held>>) -> Self {
        self.maps = maps;
        self
    }

    /// Robots lost `s` seconds and in no mission leave the registry.
    pub fn forgetting_lost_after(mut self, s: f64) -> Self {
        self.forget_lost_s = s;
        self
    }

    /// Former versions of the maps (their files changed) that journaled missions plan on: kept
    /// for them, listed as superseded.
    pub fn with_superseded(mut self, maps: Vec<Arc<crate::maps::Held>>) -> Self {
        self.superseded = maps.into_iter().map(|h| (h.info.hash.clone(), h)).collect();
        self
    }

    /// The map of `r`, by its hash: a current one or a superseded one.
    fn map_of(&self, r: &mrmm_proto::MapRef) -> Option<&Arc<crate::maps::Held>> {
        self.maps.get(&r.name).filter(|h| h.info.hash == r.hash).or_else(|| self.superseded.get(&r.hash))
    }

    /// Handles one event.
    pub fn handle(&mut self, now: Time, event: Event) -> Vec<Command> {
        self.now = self.now.max(now);
        let mut out = self.event(now, event);
        out.extend(self.due(now));
        // Whatever changed goes to disk before any of it is said or done.
        let entries = self.journal_entries();
        if !entries.is_empty() {
            out.insert(0, Command::Journal(entries));
        }
        out
    }

    fn event(&mut self, now: Time, event: Event) -> Vec<Command> {
        if let Some(token) = event.token() {
            self.roll.heard(now, &token.to_string());
        }
        match event {
            Event::RobotAlive { id } => self.registry(now, Heard::Alive(id)),
            Event::RobotGone { id } => self.registry(now, Heard::Gone(id)),
            Event::RobotRegistered(info) => self.registry(now, Heard::Info(info)),
            Event::InfoFailed { id, reason } => self.registry(now, Heard::InfoFailed { id, reason }),
            Event::Telemetry(t) => self.registry(now, Heard::Telemetry(t)),
            Event::HostAlive { node } => self.registry(now, Heard::HostAlive(node)),
            Event::HostGone { node } => self.registry(now, Heard::HostGone(node)),
            Event::RollCall(result) => self.roll_call(now, result),
            Event::Tick => self.tick(now),
            Event::Operator { req, request } => self.operator(now, req, request),
            Event::RobotCommandDone { req, robot, result } => self.command_done(now, req, robot.as_str(), result),
            Event::MissionStarted { mission, result } => self.started(mission.as_str(), result),
            Event::Forwarded { req, result } => vec![Command::Reply { req, result }],
            Event::CtlDone { id, result } => {
                self.controls.handle(now, controls::Event::Answered { id, result });
                vec![]
            }
            Event::MissionStatus { view, from } => self.mission_status(*view, from),
            Event::Refusals(r) => {
                self.edge.refused = r;
                vec![]
            }
            Event::Proofs(p) => {
                self.edge.proven = p;
                vec![]
            }
            Event::DryRunDone { id, result } => self.dry_run_done(id, result),
        }
    }

    /// The answer to a roll call: the liveliness changes the registry missed, translated by the
    /// system manager's own ingress into the events it missed, and handled as those.
    fn roll_call(&mut self, now: Time, result: Result<crate::roll_call::Present, String>) -> Vec<Command> {
        let (held, known) = (self.fleet.tokens_up(), self.fleet.tokens_registered());
        let mut out = Vec::new();
        for m in self.roll.answered(result, &held, &known) {
            match ingress(crate::edge::Incoming { key: &m.key, payload: &[], put: m.up, from: None }) {
                Ok(e) if e.token().is_some() => out.extend(self.event(now, e)),
                _ => tracing::debug!(key = %m.key.chars().take(200).collect::<String>(), "roll call: not a robot's or a host's token"),
            }
        }
        out
    }

    /// Hands what was heard of a robot or a host to the registry, and acts on what it decided.
    fn registry(&mut self, now: Time, heard: Heard) -> Vec<Command> {
        let mut out = Vec::new();
        for fact in self.fleet.handle(now, heard) {
            match fact {
                Fact::Fetch(id) => out.push(Command::FetchInfo { id }),
                Fact::Back(robot) => {
                    if let Some(e) = self.flaps.changed(now, &robot, true) {
                        self.journal.note(e);
                    }
                }
                Fact::Lost(robot) => {
                    // Its mission's head plans around it and takes it back when it returns; its
                    // place is kept, so no other mission takes it meanwhile.
                    if let Some(e) = self.flaps.changed(now, &robot, false) {
                        tracing::warn!(robot = %robot, "robot lost");
                        self.journal.note(e);
                    }
                }
                Fact::Registered(id) => out.extend(self.registered(&id)),
                Fact::Heard(t) => out.extend(self.heard(now, *t)),
                Fact::HostLost(node) => self.host_gone(node.as_str()),
            }
        }
        out
    }

    /// A robot said who it is. A member that came back without what its mission requires
    /// leaves it; a lost member back is taken again by its mission, on our order — and admitted
    /// again (it may have restarted and forgotten).
    fn registered(&mut self, id: &RobotId) -> Vec<Command> {
        let (out, left) = self.unfit(id.as_str());
        if left.is_some() {
            return out;
        }
        let Some(m) = self.assignment.get(id).cloned() else { return vec![] };
        self.rejoin(m.as_str());
        // Down when its mission was started again: its head never knew it.
        if self.missions.get(&m).is_some_and(|r| !r.adopted) {
            self.resync(m.as_str());
        }
        self.admit(m.as_str(), std::slice::from_ref(id))
    }

    /// A command to a robot answered: the operator's reply (with the mission it left, if a
    /// change of capabilities made it leave one), or, for our own command that failed, the
    /// robot admitted again.
    fn command_done(&mut self, now: Time, req: Option<Req>, robot: &str, result: Result<CommandAck, ErrorReply>) -> Vec<Command> {
        // The answer to a change of capabilities says what the robot has now.
        let (mut out, left) = match &result {
            Ok(CommandAck { capabilities: Some(c), .. }) => self.capabilities_now(robot, c.clone()),
            _ => (vec![], None),
        };
        match (req, result) {
            (Some(req), result) => {
                let result = match result {
                    Ok(ack) => to_value(&ack).map(|mut v| {
                        if let (Some(m), Some(o)) = (left, v.as_object_mut()) {
                            o.insert("left".into(), Value::String(m.into_string()));
                        }
                        v
                    }),
                    Err(e) => Err(e.context(format_args!("robot {robot}"))),
                };
                out.push(Command::Reply { req, result });
            }
            (None, Err(e)) => {
                tracing::warn!(robot = %robot, "command failed: {e}");
                out.extend(self.admit_again(now, robot));
            }
            (None, Ok(_)) => {}
        }
        out
    }

    /// The missions a lost host managed are shown stalled until a replica reports.
    fn host_gone(&mut self, node: &str) {
        for rec in self.missions.values_mut().filter(|r| r.host == node) {
            if let Some(v) = rec.view.as_mut() {
                v.status = MissionStatus::Stalled;
                v.error = Some(format!("mission manager's node {node} lost; a replica takes over, robots keep their plans"));
            }
        }
    }

    fn tick(&mut self, now: Time) -> Vec<Command> {
        self.controls.handle(now, controls::Event::Tick);
        let mut out = Vec::new();
        if now - self.started >= ADOPT_S {
            for (req, request) in std::mem::take(&mut self.held) {
                out.extend(self.operator(now, req, request));
            }
        }
        // Robots alive that never answered their info query are asked again (bounded per tick).
        out.extend(self.registry(now, Heard::Tick));
        if self.roll.due(now) {
            out.push(Command::RollCall);
        }
        if now - self.forgot_at >= FORGET_EVERY_S {
            self.forgot_at = now;
            let assignment = &self.assignment;
            let controls = &self.controls;
            self.fleet.forget_lost(now, self.forget_lost_s, |id| assignment.contains_key(id) || !controls.pending_for(id.as_str()).is_empty());
        }
        for e in self.flaps.due(now) {
            if let JournalEvent::RobotFlapping { robot, losses, alive } = &e {
                tracing::warn!(%robot, losses, alive, "robot flapped lost/back: journaled as one entry");
            }
            self.journal.note(e);
        }
        if now - self.started >= RESTART_S {
            self.recover(now);
        }
        out
    }

    fn operator(&mut self, now: Time, req: Req, request: Request) -> Vec<Command> {
        if request.is_command() && now - self.started < ADOPT_S {
            // Just started: the heads have not yet said which robots are theirs.
            if self.held.len() >= MAX_HELD {
                return vec![Command::Reply { req, result: Err(ErrorReply::busy("central just started and is busy: try again in a moment")) }];
            }
            self.held.push((req, request));
            return vec![];
        }
        let reply = |req: Req, result| vec![Command::Reply { req, result }];
        match request {
            Request::Status => reply(req, to_value(&self.status(now))),
            Request::Robots => reply(req, to_value(&self.views())),
            Request::Robot(id) => match self.view(id.as_str()) {
                Some(v) => reply(req, to_value(&v)),
                None => reply(req, Err(ErrorReply::not_found(format!("unknown robot {id:?}")))),
            },
            Request::Missions => reply(req, to_value(&self.mission_views())),
            // Central's traffic authority answers it (`CentralCore`); a system manager alone
            // holds no traffic.
            Request::Traffic => reply(req, to_value(&Vec::<mrmm_proto::traffic::TrafficView>::new())),
            Request::ClearTraffic(c) => {
                reply(req, Err(ErrorReply::not_found(format!("robot {} holds nothing in traffic: no traffic authority here", c.robot))))
            }
            // Central's charging policy answers them (`CentralCore`).
            Request::Charge(c) | Request::Release(c) => reply(req, Err(ErrorReply::not_found(format!("robot {}: no charging policy here", c.robot)))),
            Request::Maps => {
                let old = self.superseded.values().map(|h| mrmm_proto::MapInfo { superseded: true, ..h.info.clone() });
                reply(req, to_value(&self.maps.values().map(|h| h.info.clone()).chain(old).collect::<Vec<_>>()))
            }
            Request::Mission(name) => match self.missions.get(&name) {
                Some(r) if r.view.as_ref().is_some_and(|v| v.status != MissionStatus::Stalled) => {
                    let managers = self.managers(name.as_str());
                    vec![Command::Forward { req, key: Key::MissionView(name), managers }]
                }
                Some(_) => reply(req, to_value(&self.mission_view(name.as_str()))),
                None => reply(req, Err(ErrorReply::not_found(format!("unknown mission {name:?}")))),
            },
            Request::Goto(g) => match self.check_goto(&g) {
                Ok((via, map)) => {
                    self.note_command(&req, "robot goto", &serde_json::to_value(&g).unwrap_or(Value::Null));
                    vec![Command::SendToRobot { req: Some(req), robot: g.robot, cmd: RobotCommand::Goto { x: g.x, y: g.y, via, map } }]
                }
                Err(e) => reply(req, Err(e)),
            },
            Request::Create(c) => self.create(req, c),
            Request::Terminate(t) => self.terminate(req, t),
            Request::Update(u) => self.update(req, u),
            Request::Pause(p) => self.pause(req, p.name.as_str(), true),
            Request::Resume(p) => self.pause(req, p.name.as_str(), false),
            Request::Move(m) => self.move_robot(req, m),
            Request::Capabilities(c) => self.change_capabilities(req, c),
            Request::Crash(c) => match self.live_robot(c.robot.as_str()) {
                // The robot decides whether it can be crashed (a ROS 2 robot refuses); its loss is
                // then seen as any other's.
                Ok(_) => {
                    self.note_command(&req, "robot crash", &serde_json::to_value(&c).unwrap_or(Value::Null));
                    vec![Command::SendToRobot { req: Some(req), robot: c.robot, cmd: RobotCommand::Crash }]
                }
                Err(e) => reply(req, Err(e)),
            },
        }
    }

    /// What a mission manager needs to know about a robot.
    fn member(&self, id: &str) -> Option<Member> {
        self.fleet.member(id)
    }

    /// Checks a goto; on a map (the one it names, else central's only one), the route's corner
    /// points between the robot and its goal.
    fn check_goto(&self, g: &GotoRequest) -> Result<(Vec<[f64; 2]>, Option<mrmm_proto::MapRef>), ErrorReply> {
        self.live_robot(g.robot.as_str())?;
        if let Some(m) = self.assignment.get(&g.robot) {
            return Err(ErrorReply::conflict(format!("robot {:?} is in mission {m}: move it out first (robot move {} none)", g.robot, g.robot)));
        }
        if !(g.x.is_finite() && g.y.is_finite()) {
            return Err(ErrorReply::invalid("x and y must be finite numbers"));
        }
        let held = match &g.map {
            Some(name) => Some(self.maps.get(name).ok_or_else(|| ErrorReply::not_found(format!("no map {name:?}")))?),
            None if self.maps.len() == 1 => self.maps.values().next(),
            None => None,
        };
        let (Some(held), Some(pose)) = (held, self.fleet.last(g.robot.as_str()).map(|t| t.pose)) else { return Ok((vec![], None)) };
        let space = held.space().map_err(ErrorReply::invalid)?;
        let name = &held.info.name;
        let from =
            space.locate_robot(g.robot.as_str(), 0, mrmm_maps::Point::new(pose.x, pose.y)).map_err(|e| ErrorReply::conflict(format!("map {name}: {e}")))?;
        let to = space.locate("goal", 0, mrmm_maps::Point::new(g.x, g.y)).map_err(|e| ErrorReply::invalid(format!("map {name}: {e}")))?;
        let route = space
            .route(&from, &to)
            .ok_or_else(|| ErrorReply::invalid(format!("map {name}: ({}, {}) cannot be reached from where {} is", g.x, g.y, g.robot)))?;
        let via = route[1..route.len() - 1].iter().map(|p| [(p.x * 100.0).round() / 100.0, (p.y * 100.0).round() / 100.0]).collect();
        Ok((via, Some(held.info.map_ref())))
    }

    /// The robot's record if it is registered and alive.
    fn live_robot(&self, id: &str) -> Result<&RobotInfo, ErrorReply> {
        self.fleet.live_robot(id)
    }

    /// What a planner needs to know about a robot.
    fn spec(&self, id: &str) -> Option<RobotSpec> {
        self.fleet.spec(id)
    }
}

pub(crate) fn to_value<T: serde::Serialize>(v: &T) -> Result<Value, ErrorReply> {
    serde_json::to_value(v).map_err(|e| ErrorReply::invalid(e.to_string()))
}

#[cfg(test)]
mod tests;
