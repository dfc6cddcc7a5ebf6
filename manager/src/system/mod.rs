//! The system manager as a state machine: it knows every robot, every mission and every mission
//! host, answers operator requests, creates and terminates missions and moves robots between
//! them. Missions are run by mission managers on mission hosts (see `host.rs`); the system
//! manager owns the membership (every robot in at most one mission) and steers hosts with
//! [`MissionCtl`]s. No I/O: [`SystemManager::handle`] takes an [`Event`] and returns the
//! [`Command`]s the driver must carry out.

mod missions;

use std::collections::BTreeMap;

use std::collections::BTreeSet;

use mrmm_peer::proto::{
    self, CommandAck, GotoRequest, ManagerView, Member, MissionCtl, MissionMetrics, MissionStart, MissionStatus, MissionView,
    RobotCommand, RobotInfo, RobotStatus, RobotView, SystemStatus, Telemetry,
};
use mrmm_planner::plan::RobotSpec;
use serde_json::Value;

/// Seconds between two info requests to a robot that is alive but not yet registered.
pub const INFO_RETRY_S: f64 = 1.0;
/// Seconds between two leave orders to a robot still running a plan it should not have.
pub const LEAVE_RETRY_S: f64 = 2.0;
/// For this long after taking a robot out of a mission, that mission's reports listing it are
/// taken as older than the order.
pub const RELEASE_GRACE_S: f64 = 5.0;

/// An operator request, already routed by key; payloads not yet parsed.
#[derive(Debug, Clone, PartialEq)]
pub enum Request {
    Status,
    Robots,
    Robot(String),
    Missions,
    Mission(String),
    Goto(Vec<u8>),
    Move(Vec<u8>),
    Create(Vec<u8>),
    Terminate(Vec<u8>),
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
    /// An operator query `req` arrived.
    Operator { req: u64, request: Request },
    /// A command to a robot completed; `req` is the operator query it answers, if any.
    RobotCommandDone { req: Option<u64>, robot: String, result: Result<CommandAck, String> },
    /// A mission host answered a start: the first plans are out, or planning failed.
    MissionStarted { mission: String, result: Result<Box<MissionView>, String> },
    /// A mission host published a mission's status.
    MissionStatus(Box<MissionView>),
    /// A mission host's liveliness token appeared.
    HostAlive { node: String },
    /// A mission host's liveliness token disappeared.
    HostGone { node: String },
    /// Periodic tick.
    Tick,
}

/// Something the driver must do.
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    /// Ask robot `id` for its [`RobotInfo`].
    FetchInfo { id: String },
    /// Send `cmd` to `robot`; report back with [`Event::RobotCommandDone`].
    SendToRobot { req: Option<u64>, robot: String, cmd: RobotCommand },
    /// Answer operator query `req` with JSON, or with a reply error.
    Reply { req: u64, result: Result<Value, String> },
    /// Start a mission on a host; report back with [`Event::MissionStarted`].
    StartMission { host: String, start: Box<MissionStart> },
    /// Steer a mission through its host.
    Ctl { mission: String, ctl: MissionCtl },
    /// Answer operator query `req` with whatever `key` answers (a host's mission view).
    Forward { req: u64, key: String },
}

/// What the system manager knows of a mission.
#[derive(Debug, Clone)]
pub(crate) struct MissionRecord {
    host: String,
    recipe: String,
    planner: String,
    /// The host's latest view.
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
    /// The mission it was taken out of when it was lost.
    last_mission: Option<String>,
}

/// The registry of robots and missions, and the operator-facing logic.
#[derive(Debug)]
pub struct SystemManager {
    node: String,
    started: f64,
    now: f64,
    robots: BTreeMap<String, Record>,
    missions: BTreeMap<String, MissionRecord>,
    /// Mission hosts alive.
    hosts: BTreeSet<String>,
    /// Robot → mission: every robot is in at most one mission.
    assignment: BTreeMap<String, String>,
    /// Missions whose create request waits for the first plan.
    pending_create: BTreeMap<String, u64>,
    /// Missions terminated here: robots still running them are ordered out.
    terminated: BTreeSet<String>,
    /// Robot → (mission, when) it was taken out of by this manager.
    released: BTreeMap<String, (String, f64)>,
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
            terminated: Default::default(),
            released: BTreeMap::new(),
        }
    }

    /// Handles one event.
    pub fn handle(&mut self, now: f64, event: Event) -> Vec<Command> {
        self.now = self.now.max(now);
        match event {
            Event::RobotAlive { id } => {
                let rec = self.robots.entry(id.clone()).or_insert(Record {
                    info: None,
                    alive: false,
                    last: None,
                    info_asked: None,
                    fresh: true,
                    leave_sent: None,
                    last_mission: None,
                });
                rec.alive = true;
                rec.fresh = true;
                rec.last_mission = None;
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
                match self.assignment.remove(&id) {
                    Some(m) => {
                        if let Some(rec) = self.robots.get_mut(&id) {
                            rec.last_mission = Some(m.clone());
                        }
                        vec![Command::Ctl { mission: m, ctl: MissionCtl::Left { ids: vec![id] } }]
                    }
                    None => vec![],
                }
            }
            Event::RobotRegistered(info) => {
                match self.robots.get_mut(&info.id) {
                    Some(rec) => {
                        if rec.info.is_none() {
                            tracing::info!(robot = %info.id, r#type = %info.robot_type, "robot registered");
                        }
                        rec.info = Some(info);
                    }
                    None => tracing::debug!(robot = %info.id, "info from a robot with no liveliness: ignored"),
                }
                vec![]
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
                        Ok(ack) => serde_json::to_value(ack).map_err(|e| e.to_string()),
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
            Event::MissionStatus(view) => self.mission_status(*view),
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

    fn telemetry(&mut self, now: f64, t: Telemetry) -> Vec<Command> {
        let Some(rec) = self.robots.get_mut(&t.id) else { return vec![] };
        let newer = rec.fresh || rec.last.as_ref().is_none_or(|old| t.seq > old.seq);
        if !newer {
            return vec![];
        }
        rec.fresh = false;
        let mut out = Vec::new();
        // A robot running a plan of a mission it is not in (it was lost and came back, or missed
        // a leave order) is told to leave it — but only for missions this manager knows or
        // terminated: after a restart of central, missions it never heard of keep running.
        if let Some(running) = &t.mission {
            let assigned = self.assignment.get(&t.id);
            let known = self.missions.contains_key(running) || self.terminated.contains(running);
            let retry = rec.leave_sent.is_none_or(|s| now - s >= LEAVE_RETRY_S);
            if assigned != Some(running) && known && retry {
                rec.leave_sent = Some(now);
                let epoch = t.progress.as_ref().map_or(u64::MAX, |p| p.epoch);
                out.push(Command::SendToRobot {
                    req: None,
                    robot: t.id.clone(),
                    cmd: RobotCommand::Leave { mission: running.clone(), epoch },
                });
            }
        }
        rec.last = Some(t);
        out
    }

    fn tick(&mut self, now: f64) -> Vec<Command> {
        self.robots
            .iter_mut()
            .filter(|(_, r)| r.alive && r.info.is_none())
            .filter(|(_, r)| r.info_asked.is_none_or(|t| now - t >= INFO_RETRY_S))
            .map(|(id, r)| {
                r.info_asked = Some(now);
                Command::FetchInfo { id: id.clone() }
            })
            .collect()
    }

    fn operator(&mut self, now: f64, req: u64, request: Request) -> Vec<Command> {
        let reply = |result| vec![Command::Reply { req, result }];
        match request {
            Request::Status => reply(to_value(&self.status(now))),
            Request::Robots => reply(to_value(&self.views())),
            Request::Robot(id) => match self.view(&id) {
                Some(v) => reply(to_value(&v)),
                None => reply(Err(format!("unknown robot {id:?}"))),
            },
            Request::Missions => reply(to_value(&self.missions.keys().map(|n| self.mission_view(n)).collect::<Vec<_>>())),
            Request::Mission(name) => match self.missions.get(&name) {
                Some(r) if r.view.as_ref().is_some_and(|v| v.status != MissionStatus::Stalled) => {
                    vec![Command::Forward { req, key: proto::mission_view(&name) }]
                }
                Some(_) => reply(to_value(&self.mission_view(&name))),
                None => reply(Err(format!("unknown mission {name:?}"))),
            },
            Request::Goto(bytes) => match self.check_goto(&bytes) {
                Ok(g) => vec![Command::SendToRobot {
                    req: Some(req),
                    robot: g.robot,
                    cmd: RobotCommand::Goto { x: g.x, y: g.y },
                }],
                Err(e) => reply(Err(e)),
            },
            Request::Create(bytes) => self.create(req, &bytes),
            Request::Terminate(bytes) => self.terminate(req, &bytes),
            Request::Move(bytes) => self.move_robot(req, &bytes),
        }
    }

    /// A mission as the operator sees it: the host's latest view, with the membership this
    /// manager holds; a placeholder while the host is planning.
    fn mission_view(&self, name: &str) -> MissionView {
        let robots: Vec<String> = self.assignment.iter().filter(|(_, m)| *m == name).map(|(r, _)| r.clone()).collect();
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
                teams: BTreeMap::new(),
                manager: ManagerView { node: rec.map(|r| r.host.clone()).unwrap_or_default(), epoch: 0, chain_epoch: 0, chain: vec![] },
                metrics: MissionMetrics::default(),
                summary: Value::Null,
                params: BTreeMap::new(),
                error: None,
                plans: None,
            },
        }
    }

    /// A host reported a mission. A mission this manager does not know (it restarted while the
    /// host kept running it) is adopted: record, host and membership come from the report, for
    /// robots not already in another mission.
    fn mission_status(&mut self, view: MissionView) -> Vec<Command> {
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
            let robots = view.robots.clone();
            rec.view = Some(view);
            return self.reconcile(&name, &robots);
        }
        if self.terminated.contains(&view.name) || !self.hosts.contains(&view.manager.node) {
            return vec![];
        }
        if self.pending_create.contains_key(&view.name) {
            return vec![];
        }
        tracing::info!(mission = %view.name, host = %view.manager.node, robots = view.robots.len(), "mission adopted from its host's report");
        let mut out = Vec::new();
        let mut strangers = Vec::new();
        for id in &view.robots {
            match self.assignment.get(id) {
                Some(other) if other != &view.name => strangers.push(id.clone()),
                _ => {
                    self.assignment.insert(id.clone(), view.name.clone());
                }
            }
        }
        if !strangers.is_empty() {
            out.push(Command::Ctl { mission: view.name.clone(), ctl: MissionCtl::Left { ids: strangers } });
        }
        self.missions.insert(
            view.name.clone(),
            MissionRecord { host: view.manager.node.clone(), recipe: view.recipe.clone(), planner: view.planner.clone(), view: Some(view) },
        );
        out
    }

    /// A mission's manager lists `robots` (it may have taken back a lost robot that returned while
    /// central was away): robots in no mission are recorded in it; robots this manager put in
    /// another mission are taken out of it. Robots missing from the list are left alone — the
    /// report may predate a join this manager ordered.
    fn reconcile(&mut self, name: &str, robots: &[String]) -> Vec<Command> {
        let mut strangers = Vec::new();
        let now = self.now;
        self.released.retain(|_, (_, when)| now - *when < RELEASE_GRACE_S);
        for id in robots {
            if self.released.get(id).is_some_and(|(m, _)| m == name) {
                continue;
            }
            match self.assignment.get(id) {
                Some(m) if m == name => {}
                Some(_) => strangers.push(id.clone()),
                None => {
                    tracing::info!(mission = %name, robot = %id, "robot rejoined its mission");
                    self.assignment.insert(id.clone(), name.to_string());
                }
            }
        }
        if strangers.is_empty() {
            vec![]
        } else {
            vec![Command::Ctl { mission: name.to_string(), ctl: MissionCtl::Left { ids: strangers } }]
        }
    }

    /// The first plans of a mission are out, or its planning failed.
    fn started(&mut self, name: &str, result: Result<Box<MissionView>, String>) -> Vec<Command> {
        let req = self.pending_create.remove(name);
        match result {
            Ok(view) => {
                tracing::info!(mission = %name, "mission running");
                if let Some(rec) = self.missions.get_mut(name) {
                    rec.view = Some(*view);
                }
                match req {
                    Some(req) => vec![Command::Reply { req, result: to_value(&self.mission_view(name)) }],
                    None => vec![],
                }
            }
            Err(error) => {
                // The mission never ran: forget it, free its robots.
                if self.missions.remove(name).is_none() {
                    return vec![];
                }
                self.assignment.retain(|_, m| m != name);
                tracing::warn!(mission = %name, "mission failed: {error}");
                match req {
                    Some(req) => vec![Command::Reply { req, result: Err(error) }],
                    None => vec![],
                }
            }
        }
    }

    /// What a mission manager needs to know about a robot.
    fn member(&self, id: &str) -> Option<Member> {
        let time_scale = self.robots.get(id)?.info.as_ref()?.time_scale;
        Some(Member { spec: self.spec(id)?, time_scale })
    }

    fn check_goto(&self, bytes: &[u8]) -> Result<GotoRequest, String> {
        let g: GotoRequest = proto::from_json("goto request", bytes).map_err(|e| e.to_string())?;
        self.live_robot(&g.robot)?;
        if let Some(m) = self.assignment.get(&g.robot) {
            return Err(format!("robot {:?} is in mission {m}: move it out first (robot move {} none)", g.robot, g.robot));
        }
        if !(g.x.is_finite() && g.y.is_finite()) {
            return Err("x and y must be finite numbers".into());
        }
        Ok(g)
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

    /// One registered robot.
    pub fn view(&self, id: &str) -> Option<RobotView> {
        let rec = self.robots.get(id)?;
        let info = rec.info.as_ref()?;
        let mission = self.assignment.get(id).cloned();
        let moving = rec.last.as_ref().is_some_and(|t| t.behaviour != proto::Behaviour::Hold);
        let status = if !rec.alive {
            RobotStatus::Lost
        } else if mission.is_some() || moving {
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
        Some(RobotView {
            id: info.id.clone(),
            robot_type: info.robot_type.clone(),
            capabilities: info.capabilities.clone(),
            status,
            mission,
            pose: rec.last.as_ref().map(|t| t.pose),
            behaviour,
            last_mission: if rec.alive { None } else { rec.last_mission.clone() },
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
        }
    }
}

pub(crate) fn to_value<T: serde::Serialize>(v: &T) -> Result<Value, String> {
    serde_json::to_value(v).map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests;
