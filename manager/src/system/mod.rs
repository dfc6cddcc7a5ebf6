//! The system manager as a state machine: it knows every robot, every mission and every mission
//! host, answers operator requests, creates and terminates missions and moves robots between
//! them. Missions are run by mission managers on mission hosts (`host/`); the system manager owns
//! the membership — every robot in at most one mission, and a lost robot keeps its place in its
//! mission until it comes back or the operator frees it — and steers hosts with [`MissionCtl`]s
//! that are re-sent until acknowledged (`ctl.rs`). No I/O: [`SystemManager::handle`] takes the
//! time and an [`Event`] and returns the [`Command`]s the driver must carry out.

mod ctl;
pub mod durable;
pub mod missions;
mod reports;
mod views;

use std::collections::{BTreeMap, BTreeSet};
use std::sync::Arc;

use mrmm_proto::{
    self as proto, CommandAck, GotoRequest, JournalEvent, Key, ManagerView, Member, MissionCreate, MissionCtl, MissionMetrics, MissionStart, MissionStatus,
    MissionTerminate, MissionView, RobotCommand, RobotInfo, RobotMove, RobotSpec, RobotStatus, RobotView, Sender, SystemStatus, Telemetry,
};
use serde_json::Value;

pub use ctl::{Ctls, CTL_GIVE_UP_S, CTL_RETRY_S};
pub use durable::{Durable, MissionDef};

use crate::Failure;

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
/// started (and that no robot says it runs) is started again with its live robots.
pub const RESTART_S: f64 = 5.0;
/// Seconds between two attempts to start a journaled mission again.
pub const RESTART_RETRY_S: f64 = 5.0;
/// How stale the previous manager's last sign of life may be (its heartbeat period).
pub const RESTART_BEAT_S: f64 = 2.0;

/// Who asked: an operator query held by the driver, or the advising agent (for an advice).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Req {
    Query(u64),
    Agent(String),
}

/// An operator request, decoded at the edge.
#[derive(Debug, Clone, PartialEq)]
pub enum Request {
    Status,
    Robots,
    Robot(String),
    Missions,
    Mission(String),
    Goto(GotoRequest),
    Move(RobotMove),
    Create(MissionCreate),
    Terminate(MissionTerminate),
}

impl Request {
    /// The request an operator query on `key` with `payload` makes: the one decoder of operator
    /// input (the driver answers its error to the query).
    pub fn decode(key: &str, payload: &[u8]) -> Result<Request, String> {
        use mrmm_proto::SystemCmd;
        let r = match Key::parse(key) {
            Some(Key::SystemStatus) => Ok(Request::Status),
            Some(Key::SystemRobots) => Ok(Request::Robots),
            Some(Key::SystemRobot(id)) => Ok(Request::Robot(id)),
            Some(Key::SystemMissions) => Ok(Request::Missions),
            Some(Key::SystemMission(name)) => Ok(Request::Mission(name)),
            Some(Key::SystemCmd(SystemCmd::Goto)) => proto::from_json("goto request", payload).map(Request::Goto),
            Some(Key::SystemCmd(SystemCmd::Move)) => proto::from_json("robot move request", payload).map(Request::Move),
            Some(Key::SystemCmd(SystemCmd::Create)) => proto::from_json("mission create request", payload).map(Request::Create),
            Some(Key::SystemCmd(SystemCmd::Terminate)) => proto::from_json("mission terminate request", payload).map(Request::Terminate),
            _ => return Err(format!("unknown key {key}")),
        };
        r.map_err(|e| e.to_string())
    }

    /// Whether the request changes the fleet (the agent waits while the operator is busy).
    pub fn is_command(&self) -> bool {
        matches!(self, Request::Goto(_) | Request::Move(_) | Request::Create(_) | Request::Terminate(_))
    }
}

/// Something that happened.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    /// A robot's liveliness token appeared.
    RobotAlive { id: String },
    /// A robot's liveliness token disappeared (crash, freeze past the lease, or clean exit).
    RobotGone { id: String },
    /// A robot answered its info query.
    RobotRegistered(RobotInfo),
    /// An info query failed.
    InfoFailed { id: String, reason: String },
    Telemetry(Box<Telemetry>),
    /// An operator request.
    Operator { req: Req, request: Request },
    /// A command to a robot completed; `req` is the request it answers, if any.
    RobotCommandDone { req: Option<Req>, robot: String, result: Result<CommandAck, String> },
    /// A mission host answered a start: the first plans are out, or planning failed (or, when
    /// `retryable`, nobody answered: the mission may or may not run).
    MissionStarted { mission: String, result: Result<Box<MissionView>, Failure> },
    /// The answer to [`Command::Ctl`] `id`.
    CtlDone { id: u64, result: Result<(), Failure> },
    /// A mission's head published its status; `from` is its proven sender.
    MissionStatus { view: Box<MissionView>, from: Sender },
    /// A mission host's liveliness token appeared.
    HostAlive { node: String },
    /// A mission host's liveliness token disappeared.
    HostGone { node: String },
    /// What the driver refused so far, by reason (reported in the fleet status).
    Refusals(BTreeMap<String, u64>),
    /// The answer to [`Command::DryRun`] `id`.
    DryRunDone { id: u64, result: Result<(), String> },
    /// Periodic tick.
    Tick,
}

/// Something the driver must do.
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    /// Ask robot `id` for its [`RobotInfo`]; answer with [`Event::RobotRegistered`] or [`Event::InfoFailed`].
    FetchInfo { id: String },
    /// Send `cmd` to `robot`; answer with [`Event::RobotCommandDone`].
    SendToRobot { req: Option<Req>, robot: String, cmd: RobotCommand },
    /// Answer request `req` with JSON, or with a reply error.
    Reply { req: Req, result: Result<Value, String> },
    /// Start a mission on a host; answer with [`Event::MissionStarted`].
    StartMission { host: String, start: Box<MissionStart> },
    /// Steer a mission through its head; answer with [`Event::CtlDone`]. Only an answer from
    /// one of `managers` (the mission's chain as last reported, or its host) counts.
    Ctl { id: u64, mission: String, ctl: MissionCtl, managers: Vec<String> },
    /// Answer request `req` with whatever `key` answers (a head's mission view), taking only an
    /// answer from one of `managers`.
    Forward { req: Req, key: Key, managers: Vec<String> },
    /// A proven sender sent what it may not: count it and say so in the log.
    Refused { from: Sender, what: String },
    /// Plan `DryRun` off this loop; answer with [`Event::DryRunDone`].
    DryRun(Box<missions::DryRun>),
    /// Commit these entries to the journal (fsync) before carrying out any command after this
    /// one: it always comes first, so nothing of a change is said or done before it is on disk.
    Journal(Vec<JournalEvent>),
}

/// What the system manager knows of a mission.
#[derive(Debug, Clone)]
pub(crate) struct MissionRecord {
    /// The node managing it as last reported (its host until a replica takes over).
    host: String,
    /// As defined (durable).
    def: Arc<MissionDef>,
    /// The head's latest view.
    view: Option<MissionView>,
    /// Adopted from its head's report since this manager started: its membership is learnt
    /// from reports. Otherwise (created here, or restored from the journal) this manager's
    /// assignment is the truth and heads are corrected.
    adopted: bool,
}

impl MissionRecord {
    fn new(def: MissionDef, view: Option<MissionView>, adopted: bool) -> MissionRecord {
        MissionRecord { host: def.host.clone(), def: Arc::new(def), view, adopted }
    }
}

/// A journaled mission being started again (no live manager runs it).
#[derive(Debug, Clone, Copy)]
struct Restart {
    /// A start is out.
    inflight: bool,
    /// Not before this time.
    next: f64,
}

#[derive(Debug, Clone)]
struct Record {
    info: Option<RobotInfo>,
    alive: bool,
    last: Option<Telemetry>,
    /// When the last info request went out (seconds, driver clock).
    info_asked: Option<f64>,
    /// Set when the robot (re)appears: its sequence numbers may restart from 1.
    fresh: bool,
    /// When we last ordered it out of a plan it should not run.
    leave_sent: Option<f64>,
    /// When it was last admitted again to its mission (it restarted and forgot).
    admit_sent: Option<f64>,
    /// Seen coming (back) since a head last listed it as present: only such a robot is taken
    /// back when its head reports it lost (a head may see a loss before this manager does).
    back: bool,
    /// When its liveliness last appeared.
    alive_at: f64,
}

/// A robot this manager took out of a mission: until the mission acknowledged it (and for a
/// grace period after), that mission's reports listing it are older than the order.
#[derive(Debug, Clone)]
struct Released {
    mission: String,
    ctl: u64,
    acked: Option<f64>,
}

/// A mission start waiting for the missions its robots come from to let them go.
#[derive(Debug, Clone)]
struct PendingStart {
    host: String,
    start: Box<MissionStart>,
    after: Vec<u64>,
}

/// The registry of robots and missions, and the operator-facing logic.
#[derive(Debug, Clone)]
pub struct SystemManager {
    node: String,
    started: f64,
    now: f64,
    robots: BTreeMap<String, Record>,
    missions: BTreeMap<String, MissionRecord>,
    /// Mission hosts alive.
    hosts: BTreeSet<String>,
    /// Robot → mission: every robot is in at most one mission (a lost one keeps its place).
    assignment: BTreeMap<String, String>,
    /// Missions whose create request waits for the first plan.
    pending_create: BTreeMap<String, Req>,
    starts: Vec<PendingStart>,
    /// Missions terminated here: robots still running them are ordered out, heads still
    /// reporting them are told again.
    terminated: BTreeSet<String>,
    released: BTreeMap<String, Released>,
    ctls: Ctls,
    /// Commands held while the manager learns the fleet after starting.
    held: Vec<(Req, Request)>,
    /// Messages the driver refused, by reason.
    refused: BTreeMap<String, u64>,
    /// New robot ids ignored because the registry is full.
    ignored: u64,
    /// Creates waiting for their dry run, by check id.
    checking: BTreeMap<u64, (Req, MissionCreate)>,
    next_check: u64,
    /// What the journal holds (as of the last [`Command::Journal`]).
    journaled: Durable,
    /// History for the journal, out with the next [`Command::Journal`].
    notes: Vec<JournalEvent>,
    /// Journaled missions being started again.
    restarts: BTreeMap<String, Restart>,
    /// When the previous system manager of this journal was last known alive (this manager's
    /// clock): a robot up since before then may hold replicas of the missions it managed.
    prev_alive: Option<f64>,
    /// Said once that missions wait for such robots.
    restart_blocked: bool,
}

impl SystemManager {
    /// `node` is the Zenoh id shown to operators; `now` the driver clock in seconds.
    pub fn new(node: String, now: f64) -> Self {
        SystemManager {
            node,
            started: now,
            now,
            robots: BTreeMap::new(),
            missions: BTreeMap::new(),
            hosts: BTreeSet::new(),
            assignment: BTreeMap::new(),
            pending_create: BTreeMap::new(),
            starts: Vec::new(),
            terminated: BTreeSet::new(),
            released: BTreeMap::new(),
            ctls: Ctls::default(),
            held: Vec::new(),
            refused: BTreeMap::new(),
            checking: BTreeMap::new(),
            next_check: 0,
            ignored: 0,
            journaled: Durable::default(),
            notes: Vec::new(),
            restarts: BTreeMap::new(),
            prev_alive: None,
            restart_blocked: false,
        }
    }

    /// A system manager that starts from what its journal holds: the missions it defined are
    /// known (those no live manager reports are started again after [`RESTART_S`]), robots are
    /// in the missions the journal says, terminated missions stay terminated.
    ///
    /// `prev_alive` is when the previous manager was last known alive (this manager's clock,
    /// within `beat` seconds): only a fleet whose live robots all started after that is known
    /// to hold no replica of a mission, so only then is a mission started again.
    pub fn restore(node: String, now: f64, state: Durable, prev_alive: Option<f64>) -> Self {
        let mut m = SystemManager::new(node, now);
        m.prev_alive = prev_alive;
        for (name, def) in &state.missions {
            m.missions.insert(name.clone(), MissionRecord { host: def.host.clone(), def: def.clone(), view: None, adopted: false });
        }
        m.assignment = state.assignment.clone();
        m.terminated = state.terminated.clone();
        m.notes.push(JournalEvent::CentralStarted { missions: state.missions.len(), robots: state.assignment.len(), terminated: state.terminated.len() });
        m.journaled = state;
        m
    }

    /// Whether `mission` is being started again from the journal (no live manager ran it).
    pub fn restarting(&self, mission: &str) -> bool {
        self.restarts.contains_key(mission)
    }

    /// The durable part as it is now.
    pub fn durable(&self) -> Durable {
        Durable {
            missions: self.missions.iter().map(|(n, r)| (n.clone(), r.def.clone())).collect(),
            assignment: self.assignment.clone(),
            terminated: self.terminated.clone(),
        }
    }

    /// Whether the durable part differs from what the journal holds (cheap: no copies).
    fn durable_changed(&self) -> bool {
        let j = &self.journaled;
        self.assignment != j.assignment
            || self.terminated != j.terminated
            || self.missions.len() != j.missions.len()
            || self.missions.iter().zip(&j.missions).any(|((n, r), (jn, jd))| n != jn || !Arc::ptr_eq(&r.def, jd))
    }

    /// Handles one event.
    pub fn handle(&mut self, now: f64, event: Event) -> Vec<Command> {
        self.now = self.now.max(now);
        let mut out = self.event(now, event);
        out.extend(self.due(now));
        // Whatever changed goes to disk before any of it is said or done.
        let mut entries = Vec::new();
        if self.durable_changed() {
            let now_state = self.durable();
            entries = self.journaled.diff(&now_state);
            self.journaled = now_state;
        }
        entries.append(&mut self.notes);
        if !entries.is_empty() {
            out.insert(0, Command::Journal(entries));
        }
        out
    }


    fn event(&mut self, now: f64, event: Event) -> Vec<Command> {
        match event {
            Event::RobotAlive { id } => {
                // A flood of made-up tokens must not grow the registry without bound: past
                // MAX_FLEET robots, a new id is ignored (the ones registered keep working).
                if !self.robots.contains_key(&id) && self.robots.len() >= MAX_FLEET {
                    self.ignored = self.ignored.saturating_add(1);
                    if self.ignored.is_power_of_two() {
                        tracing::warn!(robot = %id, ignored = self.ignored, "fleet registry full ({MAX_FLEET} robots): new robots ignored");
                    }
                    return vec![];
                }
                if let Some(r) = self.robots.get_mut(&id).filter(|r| !r.alive) {
                    self.notes.push(JournalEvent::RobotBack { robot: id.clone() });
                    r.back = true;
                }
                let rec = self.robots.entry(id.clone()).or_insert(Record {
                    info: None,
                    alive: false,
                    last: None,
                    info_asked: None,
                    fresh: true,
                    leave_sent: None,
                    admit_sent: None,
                    back: true,
                    alive_at: now,
                });
                rec.alive = true;
                rec.alive_at = now;
                rec.fresh = true;
                // Ask again even if known: a restarted robot may have changed type or endpoints.
                rec.info_asked = Some(now);
                vec![Command::FetchInfo { id }]
            }
            Event::RobotGone { id } => {
                if let Some(rec) = self.robots.get_mut(&id) {
                    if rec.alive {
                        tracing::warn!(robot = %id, "robot lost");
                        self.notes.push(JournalEvent::RobotLost { robot: id.clone() });
                    }
                    rec.alive = false;
                }
                // Its mission's head plans around it and takes it back when it returns; its
                // place is kept, so no other mission takes it meanwhile.
                vec![]
            }
            Event::RobotRegistered(info) => {
                let id = info.id.clone();
                match self.robots.get_mut(&id) {
                    Some(rec) => {
                        if rec.info.is_none() {
                            tracing::info!(robot = %id, r#type = %info.robot_type, "robot registered");
                        }
                        rec.info = Some(info);
                    }
                    None => tracing::debug!(robot = %id, "info from a robot with no liveliness: ignored"),
                }
                // A lost member back: its mission takes it again, on our order — and it is
                // admitted again (it may have restarted and forgotten).
                match self.assignment.get(&id).cloned() {
                    Some(m) => {
                        self.rejoin(&m);
                        // Down when its mission was started again: its head never knew it.
                        if self.missions.get(&m).is_some_and(|r| !r.adopted) {
                            self.resync(&m);
                        }
                        self.admit(&m, std::slice::from_ref(&id))
                    }
                    None => vec![],
                }
            }
            Event::InfoFailed { id, reason } => {
                tracing::debug!(robot = %id, "info request failed: {reason}");
                vec![]
            }
            Event::Telemetry(t) => self.telemetry(now, *t),
            Event::Tick => self.tick(now),
            Event::Operator { req, request } => self.operator(now, req, request),
            Event::RobotCommandDone { req, robot, result } => match req {
                Some(req) => {
                    let result = match result {
                        Ok(ack) => to_value(&ack),
                        Err(e) => Err(format!("robot {robot}: {e}")),
                    };
                    vec![Command::Reply { req, result }]
                }
                None => {
                    if let Err(e) = result {
                        tracing::warn!(robot = %robot, "command failed: {e}");
                    }
                    vec![]
                }
            },
            Event::MissionStarted { mission, result } => self.started(&mission, result),
            Event::CtlDone { id, result } => {
                self.ctls.done(now, id, result);
                for r in self.released.values_mut().filter(|r| r.ctl == id && r.acked.is_none()) {
                    if !self.ctls.is_pending(id) {
                        r.acked = Some(now);
                    }
                }
                vec![]
            }
            Event::MissionStatus { view, from } => self.mission_status(*view, from),
            Event::Refusals(r) => {
                self.refused = r;
                vec![]
            }
            Event::DryRunDone { id, result } => self.dry_run_done(id, result),
            Event::HostAlive { node } => {
                tracing::info!(%node, "mission host up");
                self.hosts.insert(node);
                vec![]
            }
            Event::HostGone { node } => {
                tracing::warn!(%node, "mission host lost");
                self.hosts.remove(&node);
                for rec in self.missions.values_mut().filter(|r| r.host == node) {
                    if let Some(v) = rec.view.as_mut() {
                        v.status = MissionStatus::Stalled;
                        v.error = Some(format!("mission manager's node {node} lost; a replica takes over, robots keep their plans"));
                    }
                }
                vec![]
            }
        }
    }

    /// Controls and starts that can go out now.
    fn due(&mut self, now: f64) -> Vec<Command> {
        let mut out = Vec::new();
        for (id, mission, ctl) in self.ctls.due(now) {
            let managers = self.managers(&mission);
            if let MissionCtl::Joined { member } = &ctl {
                // A robot leading the mission may plan for the newcomer only once it is admitted,
                // and the members take the newcomer's chain messages only once they know it: every
                // member hears of the new membership.
                let view = self.missions.get(&mission).and_then(|r| r.view.as_ref());
                let mut members: Vec<String> = view.map(|v| v.robots.iter().chain(&v.lost).cloned().collect()).unwrap_or_default();
                if !members.contains(&member.spec.id) {
                    members.push(member.spec.id.clone());
                }
                for robot in &members {
                    let admit = RobotCommand::Admit { mission: mission.clone(), managers: managers.clone(), members: members.clone() };
                    out.push(Command::SendToRobot { req: None, robot: robot.clone(), cmd: admit });
                }
            }
            out.push(Command::Ctl { id, mission, ctl, managers });
        }
        let ctls = &self.ctls;
        let (ready, waiting): (Vec<PendingStart>, Vec<PendingStart>) =
            std::mem::take(&mut self.starts).into_iter().partition(|s| s.after.iter().all(|id| !ctls.is_pending(*id)));
        self.starts = waiting;
        for s in ready {
            let members: Vec<String> = s.start.members.iter().map(|m| m.spec.id.clone()).collect();
            for m in &members {
                let admit = RobotCommand::Admit { mission: s.start.spec.name.clone(), managers: vec![s.host.clone()], members: members.clone() };
                out.push(Command::SendToRobot { req: None, robot: m.clone(), cmd: admit });
            }
            out.push(Command::StartMission { host: s.host, start: s.start });
        }
        out
    }

    /// Admissions of `robots` to `mission`, naming its managers and members as known here.
    fn admit(&self, mission: &str, robots: &[String]) -> Vec<Command> {
        if !self.missions.contains_key(mission) {
            return vec![];
        }
        let managers = self.managers(mission);
        let view = self.missions.get(mission).and_then(|r| r.view.as_ref());
        let mut members: Vec<String> = view.map(|v| v.robots.iter().chain(&v.lost).cloned().collect()).unwrap_or_default();
        members.extend(self.assignment.iter().filter(|(_, m)| m.as_str() == mission).map(|(id, _)| id.clone()));
        members.sort();
        members.dedup();
        robots
            .iter()
            .map(|r| Command::SendToRobot {
                req: None,
                robot: r.clone(),
                cmd: RobotCommand::Admit { mission: mission.to_string(), managers: managers.clone(), members: members.clone() },
            })
            .collect()
    }

    /// The nodes that may manage `mission` as this manager knows it: its host and its chain (as
    /// last reported), head first.
    pub fn managers(&self, mission: &str) -> Vec<String> {
        let Some(rec) = self.missions.get(mission) else { return vec![] };
        let mut out = vec![rec.host.clone()];
        if let Some(v) = &rec.view {
            for n in std::iter::once(&v.manager.node).chain(&v.manager.chain) {
                if !out.contains(n) {
                    out.push(n.clone());
                }
            }
        }
        out
    }

    fn tick(&mut self, now: f64) -> Vec<Command> {
        let grace = |r: &Released| r.acked.is_none_or(|t| now - t < RELEASE_GRACE_S);
        self.released.retain(|_, r| grace(r));
        let mut out = Vec::new();
        if now - self.started >= ADOPT_S {
            for (req, request) in std::mem::take(&mut self.held) {
                out.extend(self.operator(now, req, request));
            }
        }
        // Robots alive that never answered their info query are asked again, a bounded number
        // per tick (a flood of tokens costs a bounded number of queries).
        let fetch: Vec<Command> = self.robots
            .iter_mut()
            .filter(|(_, r)| r.alive && r.info.is_none())
            .filter(|(_, r)| r.info_asked.is_none_or(|t| now - t >= INFO_RETRY_S))
            .take(FETCH_PER_TICK)
            .map(|(id, r)| {
                r.info_asked = Some(now);
                Command::FetchInfo { id: id.clone() }
            })
            .collect();
        out.extend(fetch);
        if now - self.started >= RESTART_S {
            self.restart_orphans(now);
        }
        out
    }

    /// Journaled missions that no live manager runs are started again with their live robots
    /// (the others rejoin as they come back). A mission some robot says it runs is left alone:
    /// its managers are alive somewhere, and will report.
    fn restart_orphans(&mut self, now: f64) {
        // A robot up since before the previous manager went down may replicate one of its
        // missions (even one it left): starting that mission anew would make a second lineage
        // beside the chain that may still take over. Every live robot's start is known from its
        // telemetry (simulated seconds since it started, over its time scale).
        // A robot started after this manager did is new: the previous one was gone by then (it
        // held the journal until it died).
        let Some(down) = self.prev_alive else { return };
        let before = (down + RESTART_BEAT_S).min(self.started);
        let old: Vec<&String> = self
            .robots
            .iter()
            .filter(|(_, r)| r.alive)
            .filter(|(_, r)| match (&r.last, &r.info) {
                (Some(t), Some(i)) if i.time_scale > 0.0 => now - t.t / i.time_scale <= before,
                _ => true,
            })
            .map(|(id, _)| id)
            .collect();
        if !old.is_empty() {
            if !self.restart_blocked && self.missions.values().any(|r| r.view.is_none()) {
                tracing::warn!(robots = ?old, "robots up since before central went down may still replicate its missions: missions no manager reports are not started anew");
                self.restart_blocked = true;
            }
            return;
        }
        let orphans: Vec<String> = self
            .missions
            .iter()
            .filter(|(_, r)| r.view.is_none() && r.def.spec.is_some())
            .filter(|(n, _)| !self.pending_create.contains_key(*n) && !self.starts.iter().any(|s| &s.start.spec.name == *n))
            .filter(|(n, _)| self.restarts.get(*n).is_none_or(|r| !r.inflight && now >= r.next))
            .map(|(n, _)| n.clone())
            .collect();
        for name in orphans {
            let runs = self.robots.values().any(|r| r.alive && r.last.as_ref().is_some_and(|t| t.mission.as_deref() == Some(name.as_str())));
            if runs {
                continue;
            }
            let Some(rec) = self.missions.get(&name) else { continue };
            let Some(spec) = rec.def.spec.clone() else { continue };
            let host = [rec.def.host.as_str(), proto::CENTRAL_HOST].into_iter().find(|h| self.hosts.contains(*h)).map(str::to_string);
            let Some(host) = host else { continue };
            let ids: Vec<String> = self.assignment.iter().filter(|(_, m)| **m == name).map(|(r, _)| r.clone()).collect();
            // Every member back: one still away may be cut off with the mission's chain, which
            // would go on beside a new one. (Free a robot that never comes back to let its
            // mission start without it.)
            if !ids.iter().all(|id| self.robots.get(id).is_some_and(|r| r.alive && r.info.is_some())) {
                continue;
            }
            let members: Vec<Member> = ids.iter().filter(|id| self.robots.get(*id).is_some_and(|r| r.alive)).filter_map(|id| self.member(id)).collect();
            if members.is_empty() {
                continue;
            }
            let robots: Vec<String> = members.iter().map(|m| m.spec.id.clone()).collect();
            tracing::info!(mission = %name, %host, ?robots, "no live manager runs this mission of the journal: starting it again");
            self.notes.push(JournalEvent::MissionRestarted { mission: name.clone(), robots: robots.clone() });
            let after = robots.iter().filter_map(|id| self.pending_release(id)).collect();
            self.restarts.insert(name.clone(), Restart { inflight: true, next: now + RESTART_RETRY_S });
            self.starts.push(PendingStart { host, start: Box::new(MissionStart { spec, members }), after });
        }
    }

    fn operator(&mut self, now: f64, req: Req, request: Request) -> Vec<Command> {
        if request.is_command() && now - self.started < ADOPT_S {
            // Just started: the heads have not yet said which robots are theirs.
            if self.held.len() >= MAX_HELD {
                return vec![Command::Reply { req, result: Err("central just started and is busy: try again in a moment".into()) }];
            }
            self.held.push((req, request));
            return vec![];
        }
        let reply = |req: Req, result| vec![Command::Reply { req, result }];
        match request {
            Request::Status => reply(req, to_value(&self.status(now))),
            Request::Robots => reply(req, to_value(&self.views())),
            Request::Robot(id) => match self.view(&id) {
                Some(v) => reply(req, to_value(&v)),
                None => reply(req, Err(format!("unknown robot {id:?}"))),
            },
            Request::Missions => reply(req, to_value(&self.mission_views())),
            Request::Mission(name) => match self.missions.get(&name) {
                Some(r) if r.view.as_ref().is_some_and(|v| v.status != MissionStatus::Stalled) => {
                    let managers = self.managers(&name);
                    vec![Command::Forward { req, key: Key::MissionView(name), managers }]
                }
                Some(_) => reply(req, to_value(&self.mission_view(&name))),
                None => reply(req, Err(format!("unknown mission {name:?}"))),
            },
            Request::Goto(g) => match self.check_goto(&g) {
                Ok(()) => {
                    self.note_command(&req, "robot goto", &serde_json::to_value(&g).unwrap_or(Value::Null));
                    vec![Command::SendToRobot { req: Some(req), robot: g.robot, cmd: RobotCommand::Goto { x: g.x, y: g.y } }]
                }
                Err(e) => reply(req, Err(e)),
            },
            Request::Create(c) => self.create(req, c),
            Request::Terminate(t) => self.terminate(req, t),
            Request::Move(m) => self.move_robot(req, m),
        }
    }

    /// The first plans of a mission are out, or its planning failed, or its host did not answer.
    fn started(&mut self, name: &str, result: Result<Box<MissionView>, Failure>) -> Vec<Command> {
        if let Some(r) = self.restarts.get_mut(name) {
            // A journaled mission started again: it is never forgotten for failing; tried again.
            r.inflight = false;
            match result {
                Ok(view) => {
                    tracing::info!(mission = %name, "mission running again");
                    self.restarts.remove(name);
                    if let Some(rec) = self.missions.get_mut(name) {
                        rec.view = Some(*view);
                    }
                    self.resync(name);
                }
                Err(f) => {
                    r.next = self.now + RESTART_RETRY_S;
                    tracing::warn!(mission = %name, "starting the mission again failed ({}); trying again in {RESTART_RETRY_S} s", f.error);
                }
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
                }
                reply(to_value(&self.mission_view(name)))
            }
            Err(f) if !self.missions.contains_key(name) => reply(Err(f.error)),
            Err(f) if f.error.starts_with(proto::TAKEN_OVER) => {
                // Another manager of its chain runs it: its head's reports will say which.
                tracing::info!(mission = %name, "mission started; another of its managers took it over");
                reply(to_value(&self.mission_view(name)))
            }
            Err(f) if f.retryable => {
                // Nobody answered: the mission may be running. End it, and free its robots
                // only once its head acknowledged the end — never in two missions.
                tracing::warn!(mission = %name, "no answer to the start: ending the mission in case it started");
                self.missions.remove(name);
                self.terminated.insert(name.to_string());
                self.ctls.cancel(name);
                let end = self.ctls.push(name, MissionCtl::Terminate, None);
                let robots: Vec<String> = self.assignment.iter().filter(|(_, m)| *m == name).map(|(r, _)| r.clone()).collect();
                let mut out = Vec::new();
                for id in robots {
                    self.assignment.remove(&id);
                    self.released.insert(id.clone(), Released { mission: name.to_string(), ctl: end, acked: None });
                    out.push(Command::SendToRobot { req: None, robot: id, cmd: RobotCommand::Leave { mission: name.to_string(), epoch: u64::MAX } });
                }
                out.extend(reply(Err(format!("mission {name} did not start: {}; it was ended in case it had", f.error))));
                out
            }
            Err(f) => {
                // The mission never ran: forget it, free its robots.
                self.missions.remove(name);
                self.assignment.retain(|_, m| m != name);
                self.ctls.cancel(name);
                tracing::warn!(mission = %name, "mission failed: {}", f.error);
                reply(Err(f.error))
            }
        }
    }

    /// What a mission manager needs to know about a robot.
    fn member(&self, id: &str) -> Option<Member> {
        let time_scale = self.robots.get(id)?.info.as_ref()?.time_scale;
        Some(Member { spec: self.spec(id)?, time_scale })
    }

    fn check_goto(&self, g: &GotoRequest) -> Result<(), String> {
        self.live_robot(&g.robot)?;
        if let Some(m) = self.assignment.get(&g.robot) {
            return Err(format!("robot {:?} is in mission {m}: move it out first (robot move {} none)", g.robot, g.robot));
        }
        if !(g.x.is_finite() && g.y.is_finite()) {
            return Err("x and y must be finite numbers".into());
        }
        Ok(())
    }

    /// The robot's record if it is registered and alive.
    fn live_robot(&self, id: &str) -> Result<&RobotInfo, String> {
        let rec = self.robots.get(id).filter(|r| r.info.is_some()).ok_or_else(|| format!("unknown robot {id:?}"))?;
        if !rec.alive {
            return Err(format!("robot {id:?} is lost"));
        }
        rec.info.as_ref().ok_or_else(|| format!("unknown robot {id:?}"))
    }

    /// What a planner needs to know about a robot.
    fn spec(&self, id: &str) -> Option<RobotSpec> {
        let rec = self.robots.get(id)?;
        let info = rec.info.as_ref()?;
        let pose = rec.last.as_ref().map(|t| t.pose).unwrap_or_default();
        Some(RobotSpec { id: id.to_string(), robot_type: info.robot_type.clone(), x: pose.x, y: pose.y, speed: info.max_speed })
    }

}

pub(crate) fn to_value<T: serde::Serialize>(v: &T) -> Result<Value, String> {
    serde_json::to_value(v).map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests;
