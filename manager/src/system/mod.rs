//! The system manager as a state machine: it knows every robot, every mission and every mission
//! host, answers operator requests, creates and terminates missions and moves robots between
//! them. Missions are run by mission managers on mission hosts (`host/`); the system manager owns
//! the membership — every robot in at most one mission, and a lost robot keeps its place in its
//! mission until it comes back or the operator frees it — and steers hosts with [`MissionCtl`]s
//! that are re-sent until acknowledged (`ctl.rs`). No I/O: [`SystemManager::handle`] takes the
//! time and an [`Event`] and returns the [`Command`]s the driver must carry out.

mod ctl;
pub mod missions;

use std::collections::{BTreeMap, BTreeSet};

use mrmm_proto::{
    self as proto, CommandAck, GotoRequest, Key, ManagerView, Member, MissionCreate, MissionCtl, MissionMetrics, MissionStart, MissionStatus,
    MissionTerminate, MissionView, Role, RobotCommand, RobotInfo, RobotMove, RobotSpec, RobotStatus, RobotView, Sender, SystemStatus, Telemetry,
};
use serde_json::Value;

pub use ctl::{Ctls, CTL_GIVE_UP_S, CTL_RETRY_S};

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
}

/// What the system manager knows of a mission.
#[derive(Debug, Clone)]
pub(crate) struct MissionRecord {
    host: String,
    recipe: String,
    planner: String,
    /// The head's latest view.
    view: Option<MissionView>,
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
        }
    }

    /// Handles one event.
    pub fn handle(&mut self, now: f64, event: Event) -> Vec<Command> {
        self.now = self.now.max(now);
        let mut out = self.event(now, event);
        out.extend(self.due(now));
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
                let rec = self.robots.entry(id.clone()).or_insert(Record {
                    info: None,
                    alive: false,
                    last: None,
                    info_asked: None,
                    fresh: true,
                    leave_sent: None,
                    admit_sent: None,
                });
                rec.alive = true;
                rec.fresh = true;
                // Ask again even if known: a restarted robot may have changed type or endpoints.
                rec.info_asked = Some(now);
                vec![Command::FetchInfo { id }]
            }
            Event::RobotGone { id } => {
                if let Some(rec) = self.robots.get_mut(&id) {
                    if rec.alive {
                        tracing::warn!(robot = %id, "robot lost");
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

    /// Whether `from` may report on `view`'s mission: central and mission hosts may; a robot
    /// only if this manager knows it as one of the mission's managers or members (a successor
    /// taking over comes from the chain, and the chain is made of members).
    fn may_report(&self, view: &MissionView, from: &Sender) -> bool {
        if matches!(from.role, Role::Central | Role::Host) {
            return true;
        }
        match self.missions.get(&view.name).and_then(|r| r.view.as_ref()) {
            Some(known) => {
                let id = &from.id;
                self.managers(&view.name).contains(id) || known.robots.contains(id) || known.lost.contains(id)
            }
            // Not known here (this manager restarted): what the report says of other robots
            // is checked against their own telemetry in `reconcile`.
            None => true,
        }
    }

    fn telemetry(&mut self, now: f64, t: Telemetry) -> Vec<Command> {
        let Some(rec) = self.robots.get_mut(&t.id) else { return vec![] };
        let newer = rec.fresh || rec.last.as_ref().is_none_or(|old| t.seq > old.seq);
        if !newer {
            return vec![];
        }
        rec.fresh = false;
        let mut out = Vec::new();
        // A robot running a plan of a mission it is not in (it missed a leave order, or was
        // moved) is told to leave it — but only for missions this manager knows or terminated:
        // after a restart of central, missions it never heard of keep running.
        // Admitted to a mission this manager knows it is not in (a leave order it missed):
        // told to leave it, which clears the admission.
        let retry = rec.leave_sent.is_none_or(|s| now - s >= LEAVE_RETRY_S);
        let mut leave = Vec::new();
        for admitted in t.admitted.iter().filter(|a| t.mission.as_ref() != Some(*a)) {
            let known = self.missions.contains_key(admitted) || self.terminated.contains(admitted);
            let releasing = self.released.get(&t.id).is_some_and(|r| r.mission == *admitted && self.ctls.is_pending(r.ctl));
            // A join or leave of this robot still on its way to that mission's head: the head
            // may be taking it into its chain; its admission must hold until the leave is done.
            let in_transit = self.ctls.has(admitted, |c| match c {
                MissionCtl::Joined { member } => member.spec.id == t.id,
                MissionCtl::Left { ids } => ids.contains(&t.id),
                _ => false,
            });
            if known && self.assignment.get(&t.id) != Some(admitted) && !releasing && !in_transit && retry {
                leave.push(admitted.clone());
            }
        }
        if !leave.is_empty() {
            rec.leave_sent = Some(now);
        }
        for mission in leave {
            out.push(Command::SendToRobot { req: None, robot: t.id.clone(), cmd: RobotCommand::Leave { mission, epoch: u64::MAX } });
        }
        // In a mission here, but neither running it nor admitted to it (it restarted and forgot
        // its admission): admitted again, so it trusts the mission's managers when they call.
        if let Some(m) = self.assignment.get(&t.id).filter(|m| self.missions.contains_key(*m)) {
            let forgot = t.mission.as_ref() != Some(m) && !t.admitted.contains(m);
            if forgot && rec.admit_sent.is_none_or(|s| now - s >= LEAVE_RETRY_S) {
                rec.admit_sent = Some(now);
                let (id, m) = (t.id.clone(), m.clone());
                out.extend(self.admit(&m, &[id]));
            }
        }
        let Some(rec) = self.robots.get_mut(&t.id) else { return out };
        if let Some(running) = &t.mission {
            let assigned = self.assignment.get(&t.id);
            // In no mission here, running one whose head lists it: the head's report and the
            // robot's own telemetry agree — it is that mission's (see `reconcile`).
            let listed = self.missions.get(running).and_then(|m| m.view.as_ref()).is_some_and(|v| v.robots.contains(&t.id));
            let released = self.released.get(&t.id).is_some_and(|r| r.mission == *running);
            if assigned.is_none() && listed && !released && !self.terminated.contains(running) {
                tracing::info!(mission = %running, robot = %t.id, "robot recorded in the mission it runs and its head lists");
                let (id, mission) = (t.id.clone(), running.clone());
                self.assignment.insert(id.clone(), mission.clone());
                rec.last = Some(t);
                return self.admit(&mission, &[id]);
            }
            let known = self.missions.contains_key(running) || self.terminated.contains(running);
            let retry = rec.leave_sent.is_none_or(|s| now - s >= LEAVE_RETRY_S);
            // Moved out of `running` but not yet let go by it: its head still counts on it, so
            // it keeps its plan until the head has replanned without it.
            let releasing = self.released.get(&t.id).is_some_and(|r| r.mission == *running && self.ctls.is_pending(r.ctl));
            if assigned != Some(running) && known && retry && !releasing {
                rec.leave_sent = Some(now);
                let epoch = t.progress.as_ref().map_or(u64::MAX, |p| p.epoch);
                out.push(Command::SendToRobot { req: None, robot: t.id.clone(), cmd: RobotCommand::Leave { mission: running.clone(), epoch } });
            }
        }
        rec.last = Some(t);
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
        out
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
                Ok(()) => vec![Command::SendToRobot { req: Some(req), robot: g.robot, cmd: RobotCommand::Goto { x: g.x, y: g.y } }],
                Err(e) => reply(req, Err(e)),
            },
            Request::Create(c) => self.create(req, c),
            Request::Terminate(t) => self.terminate(req, t),
            Request::Move(m) => self.move_robot(req, m),
        }
    }

    /// A mission as the operator sees it: the head's latest view, with the (live) members this
    /// manager holds; a placeholder while the host is planning.
    fn mission_view(&self, name: &str) -> MissionView {
        let robots: Vec<String> = self
            .assignment
            .iter()
            .filter(|(id, m)| *m == name && self.robots.get(*id).is_some_and(|r| r.alive))
            .map(|(r, _)| r.clone())
            .collect();
        let rec = self.missions.get(name);
        match rec.and_then(|r| r.view.clone()) {
            Some(mut v) => {
                v.robots = robots;
                v
            }
            None => MissionView {
                name: name.to_string(),
                recipe: rec.map(|r| r.recipe.clone()).unwrap_or_default(),
                planner: rec.map(|r| r.planner.clone()).unwrap_or_default(),
                status: MissionStatus::Planning,
                robots,
                lost: vec![],
                teams: BTreeMap::new(),
                manager: ManagerView { node: rec.map(|r| r.host.clone()).unwrap_or_default(), epoch: 0, chain_epoch: 0, chain: vec![] },
                metrics: MissionMetrics::default(),
                summary: None,
                params: BTreeMap::new(),
                error: None,
                plans: None,
            },
        }
    }

    /// A head reported a mission. A mission this manager does not know (it restarted while the
    /// head kept running it) is adopted: record, host and membership come from the report, for
    /// robots not already in another mission. A mission terminated here is ended again.
    fn mission_status(&mut self, view: MissionView, from: Sender) -> Vec<Command> {
        if view.manager.node != from.id || !from.role.hosts_missions() {
            return vec![Command::Refused { what: format!("report mission {} as managed by {}", view.name, view.manager.node), from }];
        }
        // A report of an older chain epoch is from a manager that was replaced.
        let known_epoch = self.missions.get(&view.name).and_then(|r| r.view.as_ref()).map_or(0, |v| v.manager.chain_epoch);
        if view.manager.chain_epoch < known_epoch {
            return vec![];
        }
        if !self.may_report(&view, &from) {
            return vec![Command::Refused { what: format!("report on mission {} (not one of its managers or members)", view.name), from }];
        }
        if self.terminated.contains(&view.name) {
            if !self.ctls.has(&view.name, |c| *c == MissionCtl::Terminate) {
                tracing::warn!(mission = %view.name, node = %view.manager.node, "a terminated mission still runs: ending it again");
                self.ctls.push(&view.name, MissionCtl::Terminate, None);
            }
            return vec![];
        }
        if let Some(rec) = self.missions.get_mut(&view.name) {
            // A report of an older chain epoch is from a manager that was replaced.
            let known = rec.view.as_ref().map_or(0, |v| v.manager.chain_epoch);
            if view.manager.chain_epoch < known {
                return vec![];
            }
            if rec.host != view.manager.node {
                tracing::info!(mission = %view.name, from = %rec.host, to = %view.manager.node, "mission manager moved");
                rec.host = view.manager.node.clone();
            }
            if rec.view.is_none() && view.status == MissionStatus::Planning {
                return vec![];
            }
            let name = view.name.clone();
            let (robots, lost) = (view.robots.clone(), view.lost.clone());
            rec.view = Some(view);
            let out = self.reconcile(&name, &robots, &lost, &from);
            self.rejoin(&name);
            return out;
        }
        if !self.hosts.contains(&view.manager.node) || self.pending_create.contains_key(&view.name) {
            return vec![];
        }
        tracing::info!(mission = %view.name, host = %view.manager.node, robots = view.robots.len(), "mission adopted from its head's report");
        let name = view.name.clone();
        let (robots, lost) = (view.robots.clone(), view.lost.clone());
        self.missions.insert(
            name.clone(),
            MissionRecord { host: view.manager.node.clone(), recipe: view.recipe.clone(), planner: view.planner.clone(), view: Some(view) },
        );
        let out = self.reconcile(&name, &robots, &lost, &from);
        self.rejoin(&name);
        out
    }

    /// A mission's head lists `robots` and its `lost` members (it may have taken back a lost
    /// robot while central was away, or central restarted): robots in no mission are recorded in
    /// it; robots in another mission are taken out of it. Robots missing from the lists are left
    /// alone — the report may predate a join this manager ordered.
    ///
    /// A robot reporting as a head (after a takeover) cannot claim robots of other missions: a
    /// robot in no mission is recorded from its report only when its own telemetry says it runs
    /// that mission or none. Central's and mission hosts' reports are trusted.
    fn reconcile(&mut self, name: &str, robots: &[String], lost: &[String], reporter: &Sender) -> Vec<Command> {
        let trusted = matches!(reporter.role, Role::Central | Role::Host);
        let mut strangers = Vec::new();
        let mut recorded = Vec::new();
        for id in robots.iter().chain(lost) {
            // A robot being let go (by this mission or another) is in transit: this manager
            // moved it, and decides where it goes.
            if self.released.get(id).is_some_and(|r| r.mission == name || self.ctls.is_pending(r.ctl)) {
                continue;
            }
            // A robot that says it runs this mission, or nothing (it restarted and forgot):
            // never one that says it runs another.
            let confirmed = trusted
                || *id == reporter.id
                || self.robots.get(id).and_then(|r| r.last.as_ref()).is_some_and(|t| t.mission.is_none() || t.mission.as_deref() == Some(name));
            match self.assignment.get(id) {
                Some(m) if m == name => {}
                Some(_) => strangers.push(id.clone()),
                None if !confirmed => {}
                None => {
                    tracing::info!(mission = %name, robot = %id, "robot recorded in its mission from its head's report");
                    self.assignment.insert(id.clone(), name.to_string());
                    recorded.push(id.clone());
                }
            }
        }
        if !strangers.is_empty() {
            self.ctls.push(name, MissionCtl::Left { ids: strangers }, None);
        }
        // Recorded here: admitted too (this manager may have restarted; they may have too).
        self.admit(name, &recorded)
    }

    /// Orders `name`'s head to take back its lost members that are alive again (they kept their
    /// place in the mission while away).
    fn rejoin(&mut self, name: &str) {
        let lost = self.missions.get(name).and_then(|r| r.view.as_ref()).map(|v| v.lost.clone()).unwrap_or_default();
        for id in lost {
            let ours = self.assignment.get(&id).is_some_and(|m| m == name);
            let alive = self.robots.get(&id).is_some_and(|r| r.alive && r.info.is_some());
            let pending = self.ctls.has(name, |c| matches!(c, MissionCtl::Joined { member } if member.spec.id == id));
            if ours && alive && !pending {
                if let Some(member) = self.member(&id) {
                    tracing::info!(mission = %name, robot = %id, "lost member back: its mission takes it again");
                    // Never in two teams: if another mission is still letting it go, after that.
                    let after = self.pending_release(&id);
                    self.ctls.push(name, MissionCtl::Joined { member }, after);
                }
            }
        }
    }

    /// The first plans of a mission are out, or its planning failed, or its host did not answer.
    fn started(&mut self, name: &str, result: Result<Box<MissionView>, Failure>) -> Vec<Command> {
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

    /// Every mission as the operator sees it, by name.
    pub fn mission_views(&self) -> Vec<MissionView> {
        self.missions.keys().map(|n| self.mission_view(n)).collect()
    }

    /// Registered robots, sorted by id.
    pub fn views(&self) -> Vec<RobotView> {
        self.robots.keys().filter_map(|id| self.view(id)).collect()
    }

    /// The mission each robot is in (lost robots keep theirs).
    pub fn assignment(&self) -> &BTreeMap<String, String> {
        &self.assignment
    }

    /// One registered robot.
    pub fn view(&self, id: &str) -> Option<RobotView> {
        let rec = self.robots.get(id)?;
        let info = rec.info.as_ref()?;
        let assigned = self.assignment.get(id).cloned();
        let moving = rec.last.as_ref().is_some_and(|t| t.behaviour != proto::Behaviour::Hold);
        let status = if !rec.alive {
            RobotStatus::Lost
        } else if assigned.is_some() || moving {
            RobotStatus::Busy
        } else {
            RobotStatus::Idle
        };
        let behaviour = rec.last.as_ref().map(|t| match &t.progress {
            Some(p) if p.waiting.is_some() => format!("sync {:?}", p.waiting.unwrap_or_default()),
            Some(p) if p.done => "plan done".to_string(),
            Some(p) => format!("step {} {}", p.step, t.behaviour.describe()),
            None => t.behaviour.describe(),
        });
        let (mission, last_mission) = if rec.alive { (assigned, None) } else { (None, assigned) };
        Some(RobotView {
            id: info.id.clone(),
            robot_type: info.robot_type.clone(),
            capabilities: info.capabilities.clone(),
            status,
            mission,
            pose: rec.last.as_ref().map(|t| t.pose),
            behaviour,
            last_mission,
        })
    }

    /// Fleet summary.
    pub fn status(&self, now: f64) -> SystemStatus {
        let views = self.views();
        let count = |s| views.iter().filter(|v| v.status == s).count();
        SystemStatus {
            node: self.node.clone(),
            uptime_s: now - self.started,
            robots_total: views.len(),
            idle: count(RobotStatus::Idle),
            busy: count(RobotStatus::Busy),
            lost: count(RobotStatus::Lost),
            missions: self.missions.len(),
            refused: self.refused.clone(),
        }
    }
}

pub(crate) fn to_value<T: serde::Serialize>(v: &T) -> Result<Value, String> {
    serde_json::to_value(v).map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests;
