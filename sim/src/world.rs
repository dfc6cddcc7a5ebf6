//! The simulated world: nodes running the production machines, and the event loop that plays the
//! drivers' part — it delivers publications, routes queries to whoever serves their key and
//! answers to whoever asked, declares liveliness tokens, ticks the machines, and injects faults.

use std::collections::{BTreeMap, BTreeSet};

use mrmm_manager::agent::{AgentConfig, Autonomy};
use mrmm_manager::central::{self, CentralCore};
use mrmm_manager::chain::Params;
use mrmm_manager::host::{self, HostCore};
use mrmm_manager::system::{self, Ctls, Req};
use mrmm_manager::Failure;
use mrmm_peer::config::RobotConfig;
use mrmm_peer::robot::{self, Robot};
use mrmm_proto::{
    CommandAck, CtlAck, Member, MissionCtl, MissionPlan, MissionSpecWire, MissionStart, MissionView, PlanAssignment, PlanRequest, RobotCommand,
    RobotInfo, RobotPlan, RobotSpec, Role, Sender, Step, CENTRAL_HOST,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::invariants::Invariants;
use crate::net::{Change, Links, Queue, Token, Beliefs};
use crate::ops::{cheap_params, Operator};
use crate::{Config, Ops, Report, Violation};

/// Robots' simulated seconds per wall second.
const TIME_SCALE: f64 = 4.0;
/// How long a query waits for an answer (the drivers' timeouts).
fn timeout(p: &Payload) -> f64 {
    match p {
        Payload::HostStart(_) => 25.0,
        Payload::Planner(..) => 20.0,
        _ => 2.0,
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Kind {
    Central,
    Host,
    Robot,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum TickKind {
    Physics,
    Telemetry,
    Host,
    Status,
    Central,
}

struct Node {
    name: String,
    kind: Kind,
    central: Option<CentralCore>,
    host: Option<HostCore>,
    robot: Option<Robot>,
    cfg: Option<RobotConfig>,
    /// Missions whose queryables this node's host serves.
    served: BTreeSet<String>,
    /// The robot's team: (team, subteam).
    team: Option<(String, String)>,
    /// Central's journal: what it committed, kept across crashes (the disk).
    disk: mrmm_manager::system::Durable,
    /// When central last crashed.
    down: Option<f64>,
}

/// What a query asks of its server.
#[derive(Debug, Clone)]
enum Payload {
    RobotCmd(RobotCommand),
    RobotInfo,
    HostStart(Box<MissionStart>),
    Ctl { mission: String, ctl: MissionCtl },
    View(String),
    Planner(PlanRequest, mrmm_planner::recipe::PlannerKind),
}

/// Who asked, and what the answer goes back as.
#[derive(Debug, Clone)]
enum Ctx {
    CentralInfo(String),
    CentralRobot { req: Option<Req>, robot: String },
    CentralStart(String),
    CentralCtl(u64),
    CentralForward,
    HostPlan { mission: String, epoch: u64 },
    HostSendPlan { mission: String, robot: String, epoch: u64 },
    OpStart,
    OpCtl(u64),
}

/// An answer on the wire.
#[derive(Debug, Clone)]
enum Answer {
    Ack(CommandAck),
    Info(RobotInfo),
    Json(serde_json::Value),
    Plan(Box<MissionPlan>),
}

struct Pending {
    /// `None`: the operator, who reaches every node.
    asker: Option<usize>,
    asker_inc: u32,
    server: usize,
    payload: Option<Payload>,
    ctx: Ctx,
    done: bool,
}

enum Ev {
    Tick { node: usize, inc: u32, kind: TickKind },
    Host { from: usize, to: usize, ev: Box<host::Event> },
    Central { from: usize, to: usize, ev: Box<central::Event> },
    Robot { from: usize, to: usize, ev: Box<robot::Event> },
    /// An answer a node computed for itself (local planning).
    Local { node: usize, inc: u32, ev: Box<host::Event> },
    /// An answer central's driver computed for it (a dry run).
    LocalCentral { node: usize, inc: u32, ev: Box<central::Event> },
    Query(u64),
    Answer { qid: u64, result: Result<Answer, Failure> },
    Timeout(u64),
    Live(Change, u32),
    Crash,
    Restart(usize),
    Partition,
    Heal,
    Suspect,
    Unsuspect(usize, usize),
    Op,
}

/// One run.
pub struct World {
    cfg: Config,
    rng: ChaCha8Rng,
    now: f64,
    nodes: Vec<Node>,
    links: Links,
    beliefs: Beliefs,
    queue: Queue<Ev>,
    queries: BTreeMap<u64, Pending>,
    next_qid: u64,
    inv: Invariants,
    op: Operator,
    /// OneMission: the operator's controls, and the team it wants.
    ctls: Ctls,
    team: BTreeSet<String>,
    /// OneMission: the mission's chain as last seen (whom admissions name as managers).
    managers: Vec<String>,
    report: Report,
    trace: Option<Vec<String>>,
}

fn robot_cfg(id: &str, x: f64, y: f64) -> RobotConfig {
    let text = format!(
        r#"{{ id: "{id}", type: "ground", kinematics: {{ max_speed: 1.0, max_turn_rate: 2.0 }}, start: {{ x: {x}, y: {y} }}, time_scale: {TIME_SCALE}, telemetry_hz: 5 }}"#
    );
    match RobotConfig::from_json5("sim", &text) {
        Ok(c) => c,
        Err(e) => panic!("the simulation's robot config is wrong: {e}"),
    }
}

fn json<T: serde::de::DeserializeOwned>(a: Result<Answer, Failure>) -> Result<T, Failure> {
    match a? {
        Answer::Json(v) => serde_json::from_value(v).map_err(|e| Failure { retryable: false, error: e.to_string() }),
        other => Err(Failure { retryable: false, error: format!("unexpected answer {other:?}") }),
    }
}

impl World {
    pub fn new(cfg: Config, trace: bool) -> World {
        let mut nodes = Vec::new();
        if cfg.central {
            nodes.push(Node { name: CENTRAL_HOST.into(), kind: Kind::Central, central: None, host: None, robot: None, cfg: None, served: BTreeSet::new(), team: None, disk: Default::default(), down: None });
        }
        for i in 1..=cfg.hosts {
            nodes.push(Node { name: format!("h{i}"), kind: Kind::Host, central: None, host: None, robot: None, cfg: None, served: BTreeSet::new(), team: None, disk: Default::default(), down: None });
        }
        for i in 1..=cfg.robots {
            let id = format!("r{i}");
            let c = robot_cfg(&id, i as f64 * 2.0, -3.0);
            nodes.push(Node { name: id, kind: Kind::Robot, central: None, host: None, robot: None, cfg: Some(c), served: BTreeSet::new(), team: None, disk: Default::default(), down: None });
        }
        let n = nodes.len();
        let mut w = World {
            cfg,
            rng: ChaCha8Rng::seed_from_u64(cfg.seed),
            now: 0.0,
            nodes,
            links: Links::new(n),
            beliefs: Beliefs::default(),
            queue: Queue::new(),
            queries: BTreeMap::new(),
            next_qid: 0,
            inv: Invariants::default(),
            op: Operator::default(),
            ctls: Ctls::default(),
            team: BTreeSet::new(),
            managers: Vec::new(),
            report: Report { seed: cfg.seed, ..Report::default() },
            trace: trace.then(Vec::new),
        };
        for i in 0..n {
            w.boot(i);
        }
        w
    }

    fn log(&mut self, f: impl FnOnce() -> String) {
        if let Some(t) = &mut self.trace {
            t.push(format!("{:8.3} {}", self.now, f()));
        }
    }

    fn index(&self, name: &str) -> Option<usize> {
        self.nodes.iter().position(|n| n.name == name)
    }

    fn delay(&mut self) -> f64 {
        self.rng.gen_range(0.0..=self.cfg.max_delay)
    }

    /// Whether a message is lost (never in the quiet period).
    fn lost(&mut self) -> bool {
        self.now < self.cfg.duration && self.cfg.loss > 0.0 && self.rng.gen_bool(self.cfg.loss.min(1.0))
    }

    /// Starts node `i`'s process: fresh machines, its timers.
    fn boot(&mut self, i: usize) {
        let now = self.now;
        let params = Params::default();
        let n = &mut self.nodes[i];
        n.served.clear();
        n.team = None;
        match n.kind {
            Kind::Central => {
                let agent = AgentConfig { autonomy: Autonomy::Act, ..AgentConfig::default() };
                // The sim's clock is central's: its last sign of life is when it crashed.
                n.central = Some(CentralCore::restore(n.name.clone(), agent, now, n.disk.clone(), n.down));
                n.host = Some(HostCore::new(&n.name, params, now));
            }
            Kind::Host => n.host = Some(HostCore::new(&n.name, params, now)),
            Kind::Robot => {
                if !matches!(self.cfg.ops, Ops::Barriers { .. }) {
                    n.host = Some(HostCore::new(&n.name, params, now).with_robot());
                }
                n.robot = n.cfg.clone().map(Robot::new);
            }
        }
        let inc = self.links.inc[i];
        let kinds: &[(TickKind, f64)] = match self.nodes[i].kind {
            Kind::Central => &[(TickKind::Central, 0.25), (TickKind::Host, 0.05), (TickKind::Status, 1.0)],
            Kind::Host => &[(TickKind::Host, 0.05), (TickKind::Status, 1.0)],
            Kind::Robot if self.nodes[i].host.is_some() => &[(TickKind::Physics, 0.05), (TickKind::Telemetry, 0.2), (TickKind::Host, 0.05), (TickKind::Status, 1.0)],
            Kind::Robot => &[(TickKind::Physics, 0.05), (TickKind::Telemetry, 0.2)],
        };
        for &(kind, period) in kinds {
            let phase = self.rng.gen_range(0.0..period);
            self.queue.push(now + phase, Ev::Tick { node: i, inc, kind });
        }
        self.liveliness(0.02);
    }

    /// Runs the simulation to its end; the first violated invariant stops it.
    pub fn run(mut self) -> Result<Report, Violation> {
        match self.run_inner() {
            Ok(()) => {
                self.report.trace = self.trace.take().unwrap_or_default();
                self.report.leads = self.inv.leads;
                Ok(self.report)
            }
            Err(what) => Err(Violation { seed: self.cfg.seed, at: self.now, what, trace: self.trace.take().unwrap_or_default() }),
        }
    }

    fn run_inner(&mut self) -> Result<(), String> {
        let end = self.cfg.duration + self.cfg.quiet;
        self.schedule_faults();
        match self.cfg.ops {
            Ops::Barriers { points, rounds } => self.hand_out_barrier_plans(points, rounds),
            Ops::OneMission | Ops::Random => self.queue.push(0.5, Ev::Op),
        }
        while let Some(t) = self.queue.peek_time() {
            if t > end {
                break;
            }
            let Some((t, ev)) = self.queue.pop() else { break };
            self.now = t;
            self.report.events += 1;
            self.event(ev)?;
        }
        self.finish()
    }

    fn schedule_faults(&mut self) {
        let d = self.cfg.duration;
        let first = |every: f64, rng: &mut ChaCha8Rng| (every > 0.0).then(|| rng.gen_range(0.2 * every..1.8 * every)).filter(|t| *t < d);
        if let Some(t) = first(self.cfg.crash_every, &mut self.rng) {
            self.queue.push(t + 2.0, Ev::Crash);
        }
        if let Some(t) = first(self.cfg.partition_every, &mut self.rng) {
            self.queue.push(t + 2.0, Ev::Partition);
        }
        if let Some(t) = first(self.cfg.suspect_every, &mut self.rng) {
            self.queue.push(t + 2.0, Ev::Suspect);
        }
    }

    fn next_fault(&mut self, every: f64, ev: Ev) {
        let at = self.now + self.rng.gen_range(0.2 * every..1.8 * every);
        if at < self.cfg.duration {
            self.queue.push(at, ev);
        }
    }

    fn event(&mut self, ev: Ev) -> Result<(), String> {
        match ev {
            Ev::Tick { node, inc, kind } => {
                if !self.links.up[node] || self.links.inc[node] != inc {
                    return Ok(());
                }
                let period = match kind {
                    TickKind::Physics | TickKind::Host => 0.05,
                    TickKind::Telemetry => 0.2,
                    TickKind::Central => 0.25,
                    TickKind::Status => 1.0,
                };
                self.queue.push(self.now + period, Ev::Tick { node, inc, kind });
                match kind {
                    TickKind::Physics => self.robot(node, robot::Event::Tick)?,
                    TickKind::Telemetry => self.robot(node, robot::Event::TelemetryDue)?,
                    TickKind::Host => self.host(node, host::Event::Tick)?,
                    TickKind::Status => self.host(node, host::Event::StatusTick)?,
                    TickKind::Central => self.central(node, central::Event::System(system::Event::Tick))?,
                }
            }
            Ev::Host { from, to, ev } => {
                if self.links.connected(from, to) {
                    self.report.messages += 1;
                    self.host(to, *ev)?;
                }
            }
            Ev::Central { from, to, ev } => {
                if self.links.connected(from, to) {
                    self.report.messages += 1;
                    self.central(to, *ev)?;
                }
            }
            Ev::Robot { from, to, ev } => {
                if self.links.connected(from, to) {
                    self.report.messages += 1;
                    self.robot(to, *ev)?;
                }
            }
            Ev::Local { node, inc, ev } => {
                if self.links.up[node] && self.links.inc[node] == inc {
                    self.host(node, *ev)?;
                }
            }
            Ev::LocalCentral { node, inc, ev } => {
                if self.links.up[node] && self.links.inc[node] == inc {
                    self.central(node, *ev)?;
                }
            }
            Ev::Query(qid) => self.serve(qid)?,
            Ev::Answer { qid, result } => self.answer(qid, result)?,
            Ev::Timeout(qid) => {
                let pending = self.queries.get(&qid).is_some_and(|q| !q.done);
                if pending {
                    let error = Failure { retryable: true, error: "no answer".into() };
                    self.answer(qid, Err(error))?;
                }
            }
            Ev::Live(c, inc) => {
                if self.links.up[c.observer] && self.links.inc[c.observer] == inc {
                    self.tell(c.observer, &c.token, c.up)?;
                }
            }
            Ev::Crash => {
                self.next_fault(self.cfg.crash_every, Ev::Crash);
                if self.links.up.iter().all(|u| *u) {
                    let candidates: Vec<usize> = (0..self.nodes.len()).filter(|i| self.nodes[*i].kind != Kind::Central || self.cfg.crash_central).collect();
                    if !candidates.is_empty() {
                        let i = candidates[self.rng.gen_range(0..candidates.len())];
                        self.crash(i);
                        if self.cfg.restart {
                            let back = self.now + self.rng.gen_range(0.5..4.0);
                            self.queue.push(back, Ev::Restart(i));
                        }
                    }
                }
            }
            Ev::Restart(i) => {
                self.links.up[i] = true;
                self.links.inc[i] += 1;
                let name = self.nodes[i].name.clone();
                self.log(|| format!("restart {name}"));
                self.beliefs.forget(i, |_| false);
                self.boot(i);
            }
            Ev::Partition => {
                self.next_fault(self.cfg.partition_every, Ev::Partition);
                if !self.links.partitioned() {
                    let side: Vec<bool> = (0..self.nodes.len()).map(|_| self.rng.gen_bool(0.5)).collect();
                    self.log(|| format!("partition {side:?}"));
                    self.links.partition(side);
                    self.report.partitions += 1;
                    let heal = (self.now + self.rng.gen_range(0.5..6.0)).min(self.cfg.duration);
                    self.queue.push(heal, Ev::Heal);
                    self.liveliness(self.cfg.lease);
                }
            }
            Ev::Heal => {
                self.log(|| "heal".into());
                self.links.heal();
                self.liveliness(0.05);
            }
            Ev::Suspect => {
                self.next_fault(self.cfg.suspect_every, Ev::Suspect);
                let n = self.nodes.len();
                let (a, b) = (self.rng.gen_range(0..n), self.rng.gen_range(0..n));
                if a != b {
                    self.log(|| format!("n{a} falsely loses n{b}"));
                    self.report.suspicions += 1;
                    self.links.suspect(a, b, true);
                    let until = (self.now + self.rng.gen_range(1.5..5.0)).min(self.cfg.duration);
                    self.queue.push(until, Ev::Unsuspect(a, b));
                    self.liveliness(self.cfg.lease);
                }
            }
            Ev::Unsuspect(a, b) => {
                self.links.suspect(a, b, false);
                self.liveliness(0.05);
            }
            Ev::Op => self.operate()?,
        }
        Ok(())
    }

    fn crash(&mut self, i: usize) {
        let name = self.nodes[i].name.clone();
        self.log(|| format!("crash {name}"));
        self.report.crashes += 1;
        self.links.up[i] = false;
        let n = &mut self.nodes[i];
        if let (Some(r), Some(c)) = (&n.robot, &mut n.cfg) {
            // The body stays where it is: the restarted process starts from there.
            let t = r.pose();
            c.start.x = t.x;
            c.start.y = t.y;
            c.start.theta = t.theta;
        }
        if n.central.is_some() {
            n.down = Some(self.now);
        }
        n.central = None;
        n.host = None;
        n.robot = None;
        n.served.clear();
        n.team = None;
        self.inv.gone(i);
        self.liveliness(0.02);
    }

    /// Every token present now, with its holder.
    fn tokens(&self) -> Vec<(Token, usize)> {
        let mut out = Vec::new();
        for (i, n) in self.nodes.iter().enumerate() {
            if !self.links.up[i] {
                continue;
            }
            if n.host.is_some() {
                out.push((Token::Host(n.name.clone()), i));
            }
            match n.kind {
                Kind::Central => out.push((Token::Planner, i)),
                Kind::Robot => {
                    out.push((Token::Robot(n.name.clone()), i));
                    if let Some((_, subteam)) = &n.team {
                        out.push((Token::Member { subteam: subteam.clone(), robot: n.name.clone() }, i));
                    }
                }
                Kind::Host => {}
            }
        }
        out
    }

    /// Tells every observer what changed in what it watches, `delay` from now.
    fn liveliness(&mut self, delay: f64) {
        let tokens = self.tokens();
        let teams: Vec<Option<String>> = self.nodes.iter().map(|n| n.team.as_ref().map(|(t, _)| t.clone())).collect();
        let kinds: Vec<(bool, bool)> = self.nodes.iter().map(|n| (n.central.is_some() || n.host.is_some(), n.robot.is_some())).collect();
        let watches = |o: usize, t: &Token| match t {
            Token::Member { subteam, .. } => kinds[o].1 && teams[o].as_ref().is_some_and(|team| subteam.split('/').next() == Some(team.as_str())),
            _ => kinds[o].0,
        };
        for c in self.beliefs.update(self.now, delay, &self.links, &tokens, watches) {
            let inc = self.links.inc[c.observer];
            self.queue.push(c.at, Ev::Live(c, inc));
        }
    }

    /// A liveliness change reaches the machines of `node` that watch it.
    fn tell(&mut self, node: usize, token: &Token, up: bool) -> Result<(), String> {
        if !matches!(token, Token::Member { .. }) {
            let name = self.nodes[node].name.clone();
            self.log(|| format!("{name} sees {token:?} {}", if up { "up" } else { "gone" }));
        }
        match token {
            Token::Robot(id) => {
                let (a, b) = (system::Event::RobotAlive { id: id.clone() }, system::Event::RobotGone { id: id.clone() });
                self.central(node, central::Event::System(if up { a } else { b }))?;
                self.host(node, if up { host::Event::RobotAlive(id.clone()) } else { host::Event::RobotGone(id.clone()) })
            }
            Token::Host(name) => {
                let (a, b) = (system::Event::HostAlive { node: name.clone() }, system::Event::HostGone { node: name.clone() });
                self.central(node, central::Event::System(if up { a } else { b }))?;
                if name == CENTRAL_HOST {
                    self.robot(node, robot::Event::CentralAlive(up))?;
                }
                self.host(node, if up { host::Event::HostAlive(name.clone()) } else { host::Event::HostGone(name.clone()) })
            }
            Token::Planner => {
                for kind in ["patrol", "coverage"] {
                    let (kind, zid) = (kind.to_string(), CENTRAL_HOST.to_string());
                    self.host(node, if up { host::Event::PlannerAlive { kind, zid } } else { host::Event::PlannerGone { kind, zid } })?;
                }
                Ok(())
            }
            Token::Member { robot, .. } => self.robot(node, if up { robot::Event::MemberAlive(robot.clone()) } else { robot::Event::MemberGone(robot.clone()) }),
        }
    }

    // ---- the machines ----------------------------------------------------------------------

    fn central(&mut self, i: usize, ev: central::Event) -> Result<(), String> {
        let now = self.now;
        let Some(c) = self.nodes[i].central.as_mut() else { return Ok(()) };
        let cmds = c.handle(now, ev);
        // The journal comes first, as the driver commits it before anything else.
        let journaled = cmds.iter().any(|c| matches!(c, central::Command::System(system::Command::Journal(_))));
        for cmd in cmds {
            match cmd {
                central::Command::Publish(_) => {}
                central::Command::System(s) => self.system_command(i, s)?,
            }
        }
        if let (true, Some(c)) = (journaled, self.nodes[i].central.as_ref()) {
            let want = c.system().durable();
            if self.nodes[i].disk != want {
                return Err(format!("central's journal replays to {:?}, but central holds {want:?}", self.nodes[i].disk));
            }
        }
        Ok(())
    }

    fn system_command(&mut self, i: usize, c: system::Command) -> Result<(), String> {
        match &c {
            system::Command::SendToRobot { robot, cmd, .. } => {
                let line = format!("central -> {robot}: {cmd:?}").chars().take(160).collect::<String>();
                self.log(|| line);
            }
            system::Command::Ctl { id, mission, ctl, .. } => {
                let line = format!("central ctl {id} {mission}: {ctl:?}").chars().take(160).collect::<String>();
                self.log(|| line);
            }
            _ => {}
        }
        match c {
            system::Command::FetchInfo { id } => self.ask(Some(i), &id, Payload::RobotInfo, Ctx::CentralInfo(id.clone())),
            system::Command::SendToRobot { req, robot, cmd } => self.ask(Some(i), &robot.clone(), Payload::RobotCmd(cmd), Ctx::CentralRobot { req, robot }),
            system::Command::StartMission { host, start } => {
                let mission = start.spec.name.clone();

                self.ask(Some(i), &host, Payload::HostStart(start), Ctx::CentralStart(mission))
            }
            system::Command::Ctl { id, mission, ctl, .. } => self.ask_mission(Some(i), &mission.clone(), Payload::Ctl { mission, ctl }, Ctx::CentralCtl(id)),
            system::Command::Refused { from, what } => return Err(format!("central refused {from}: {what} (no node of the simulation is a rogue)")),
            system::Command::Journal(entries) => {
                // Committed before anything else of this event happens, as the driver does; what
                // is on the disk must be exactly what central holds.
                let disk = &mut self.nodes[i].disk;
                for e in &entries {
                    disk.apply(e);
                }
            }
            system::Command::DryRun(dry) => {
                // Off central's loop in the driver: here, answered a little later.
                let result = dry.run();
                let at = self.now + self.rng.gen_range(0.001..0.05);
                let inc = self.links.inc[i];
                self.queue.push(at, Ev::LocalCentral { node: i, inc, ev: Box::new(central::Event::System(system::Event::DryRunDone { id: dry.id, result })) });
            }
            system::Command::Forward { key, .. } => {
                if let Some(mrmm_proto::Key::MissionView(m)) = mrmm_proto::Key::parse(&key.to_string()) {
                    self.ask_mission(Some(i), &m.clone(), Payload::View(m), Ctx::CentralForward);
                }
            }
            system::Command::Reply { req: Req::Query(q), result } => {
                let short = result.as_ref().map(|_| "ok".to_string()).unwrap_or_else(|e| e.clone());
                self.log(|| format!("operator request {q}: {short}"));
                self.op.answered(q, result.is_ok())
            }
            system::Command::Reply { req: Req::Agent(_), .. } => return Err("an answer to the agent left central".into()),
        }
        Ok(())
    }

    fn host(&mut self, i: usize, ev: host::Event) -> Result<(), String> {
        let now = self.now;
        let Some(h) = self.nodes[i].host.as_mut() else { return Ok(()) };
        let cmds = h.handle(now, ev);
        for c in cmds {
            self.host_command(i, c)?;
        }
        if let Some(h) = self.nodes[i].host.as_ref() {
            self.inv.host(i, self.links.inc[i], h)?;
        }
        self.one_mission_per_robot()
    }

    /// Invariant 3, over missions that have a head and are neither terminated by the operator
    /// nor unrecoverable (their chain lost a majority of its memory: they can never commit, so
    /// never act, again).
    fn one_mission_per_robot(&self) -> Result<(), String> {
        for (r, a, b) in self.inv.in_two_missions() {
            let led = |m: &str| self.nodes.iter().any(|n| n.host.as_ref().is_some_and(|h| h.heads().any(|(x, _)| x == m)));
            let counts = |m: &str| !self.op.terminated.contains(m) && led(m) && self.recoverable(m);
            if counts(&a) && counts(&b) {
                return Err(format!("robot {r} is a member of {a} and of {b}"));
            }
        }
        Ok(())
    }

    fn host_command(&mut self, i: usize, c: host::Command) -> Result<(), String> {
        if self.trace.is_some() {
            let name = self.nodes[i].name.clone();
            let line = match &c {
                host::Command::Chain { to, envelope } => Some(format!("{name} -> {to}: {} {}", envelope.mission, envelope.msg.describe())),
                host::Command::Status(_) => None,
                host::Command::SendPlan { mission, robot, assignment } => Some(format!("{name}: plan of {mission} epoch {} to {robot}", assignment.epoch)),
                host::Command::RequestPlan { mission, epoch, local, .. } => Some(format!("{name}: plan {mission} epoch {epoch} (local {local})")),
                other => Some(format!("{name}: {other:?}")),
            };
            if let Some(l) = line {
                self.log(|| l);
            }
        }
        match c {
            host::Command::Chain { to, envelope } => {
                if let Some(j) = self.index(&to) {
                    if !self.lost() {
                        let at = self.now + self.delay();
                        let from = self.sender(i);
                        self.queue.push(at, Ev::Host { from: i, to: j, ev: Box::new(host::Event::Chain { envelope, from }) });
                    }
                }
            }
            host::Command::Reply { query, result } => {
                if let (Ok(_), Some(Payload::Ctl { mission, .. })) = (&result, self.queries.get(&query).and_then(|q| q.payload.as_ref())) {
                    let mission = mission.clone();
                    let revision = self.nodes[i].host.as_ref().and_then(|h| h.heads().find(|(m, _)| **m == mission).map(|(_, mm)| mm.revision()));
                    if let Some(r) = revision {
                        self.inv.acked(&mission, r);
                        self.report.acked += 1;
                    }
                }
                let result = result.map(Answer::Json).map_err(|error| Failure { retryable: false, error });
                self.reply(query, result);
            }
            host::Command::Drop { query } => self.reply(query, Err(Failure { retryable: true, error: "dropped".into() })),
            host::Command::Serve { mission } => {
                self.nodes[i].served.insert(mission);
            }
            host::Command::Unserve { mission } => {
                self.nodes[i].served.remove(&mission);
            }
            host::Command::RequestPlan { mission, epoch, kind, request, local } => {
                if local {
                    let result = mrmm_manager::planner_service::plan(kind, &request).map(Box::new).map_err(|error| Failure { retryable: false, error });
                    let at = self.now + self.rng.gen_range(0.01..0.2);
                    let inc = self.links.inc[i];
                    self.queue.push(at, Ev::Local { node: i, inc, ev: Box::new(host::Event::Planned { mission, epoch, result }) });
                } else {
                    self.ask(Some(i), CENTRAL_HOST, Payload::Planner(request, kind), Ctx::HostPlan { mission, epoch });
                }
            }
            host::Command::SendPlan { mission, robot, assignment } => {
                let epoch = assignment.epoch;
                self.ask(Some(i), &robot.clone(), Payload::RobotCmd(RobotCommand::Plan(assignment)), Ctx::HostSendPlan { mission, robot, epoch });
            }
            host::Command::Refused { from, what } => {
                // Honest nodes only: a refusal is a chain message crossing a stale belief (a
                // node that left the mission's chain). Logged, not a violation.
                let name = self.nodes[i].name.clone();
                self.log(|| format!("{name} refused {from}: {what}"));
            }
            host::Command::Status(view) => {
                let from = self.sender(i);
                if let Some(c) = self.nodes.iter().position(|n| n.kind == Kind::Central) {
                    if !self.lost() {
                        let at = self.now + self.delay();
                        let ev = central::Event::System(system::Event::MissionStatus { view: view.clone(), from: from.clone() });
                        self.queue.push(at, Ev::Central { from: i, to: c, ev: Box::new(ev) });
                    }
                }
                // Robot nodes' hosts hear it too (they learn their mission's chain from it).
                for j in 0..self.nodes.len() {
                    if j != i && self.nodes[j].kind == Kind::Robot && self.nodes[j].host.is_some() && !self.lost() {
                        let at = self.now + self.delay();
                        let ev = host::Event::MissionStatus { view: view.clone(), from: from.clone() };
                        self.queue.push(at, Ev::Host { from: i, to: j, ev: Box::new(ev) });
                    }
                }
            }
        }
        Ok(())
    }

    fn robot(&mut self, i: usize, ev: robot::Event) -> Result<(), String> {
        let now = self.now;
        let name = self.nodes[i].name.clone();
        let Some(r) = self.nodes[i].robot.as_mut() else { return Ok(()) };
        let before = r.executor().map(|e| (e.mission().to_string(), e.epoch(), e.progress().syncs_passed));
        let cmds = r.handle(now, ev);
        if let (Some((m, epoch, passed)), Some(e)) = (before, r.executor()) {
            if e.mission() == m && e.epoch() == epoch && e.progress().syncs_passed > passed {
                self.report.barriers += e.progress().syncs_passed - passed;
                self.inv.barrier_passed(&name, e)?;
            }
        }
        self.robot_commands(i, cmds)
    }

    fn robot_commands(&mut self, i: usize, cmds: Vec<robot::Command>) -> Result<(), String> {
        for c in cmds {
            match c {
                robot::Command::Reply(_) => {}
                // An honest head planning for a robot not admitted yet: it re-sends.
                robot::Command::Refuse(e) => {
                    let name = self.nodes[i].name.clone();
                    self.log(|| format!("{name} refuses: {e}"));
                }
                robot::Command::JoinTeam { team, subteam } => {
                    self.nodes[i].team = Some((team, subteam));
                    self.beliefs.forget(i, |t| !matches!(t, Token::Member { .. }));
                    self.liveliness(0.02);
                    self.local_team(i)?;
                }
                robot::Command::LeaveTeam => {
                    self.nodes[i].team = None;
                    self.beliefs.forget(i, |t| !matches!(t, Token::Member { .. }));
                    self.liveliness(0.02);
                    self.local_team(i)?;
                }
                robot::Command::Publish(a) => {
                    let Some((team, _)) = self.nodes[i].team.clone() else { continue };
                    self.inv.arrival(&team, &a);
                    for j in 0..self.nodes.len() {
                        let same = self.nodes[j].team.as_ref().is_some_and(|(t, _)| *t == team);
                        if j != i && same && !self.lost() {
                            let at = self.now + self.delay();
                            self.queue.push(at, Ev::Robot { from: i, to: j, ev: Box::new(robot::Event::Heard(a.clone())) });
                        }
                    }
                }
                robot::Command::Telemetry(t) => {
                    for j in 0..self.nodes.len() {
                        if self.lost() {
                            continue;
                        }
                        let at = self.now + self.delay();
                        if self.nodes[j].central.is_some() {
                            let ev = central::Event::System(system::Event::Telemetry(Box::new(t.clone())));
                            self.queue.push(at, Ev::Central { from: i, to: j, ev: Box::new(ev) });
                        }
                        if self.nodes[j].host.is_some() {
                            self.queue.push(at, Ev::Host { from: i, to: j, ev: Box::new(host::Event::Telemetry(Box::new(t.clone()))) });
                        }
                    }
                }
            }
        }
        Ok(())
    }

    /// The robot of node `i` changed team: its host hears of it at once (same process).
    fn local_team(&mut self, i: usize) -> Result<(), String> {
        if self.nodes[i].host.is_none() {
            return Ok(());
        }
        let team = self.nodes[i].robot.as_ref().map(|r| r.team()).unwrap_or_default();
        self.host(i, host::Event::LocalTeam(team))
    }

    /// Who node `i` is, as its certificate would prove; `None` (the simulation's operator) acts
    /// as central does.
    fn sender(&self, i: usize) -> Sender {
        let n = &self.nodes[i];
        match n.kind {
            Kind::Central => Sender::new(Role::Central, n.name.clone()),
            Kind::Host => Sender::new(Role::Host, n.name.clone()),
            Kind::Robot => Sender::new(Role::Robot, n.name.clone()),
        }
    }

    fn asker(&self, asker: Option<usize>) -> Sender {
        asker.map_or_else(|| Sender::new(Role::Central, CENTRAL_HOST), |a| self.sender(a))
    }

    // ---- queries ---------------------------------------------------------------------------

    /// A query to the node named `server`.
    fn ask(&mut self, asker: Option<usize>, server: &str, payload: Payload, ctx: Ctx) {
        let server = self.index(server);
        self.send_query(asker, server, payload, ctx);
    }

    /// A query to whoever serves `mission` (the operator reaches every node).
    fn ask_mission(&mut self, asker: Option<usize>, mission: &str, payload: Payload, ctx: Ctx) {
        let servers: Vec<usize> = (0..self.nodes.len())
            .filter(|j| self.nodes[*j].served.contains(mission) && asker.is_none_or(|a| self.links.connected(a, *j)))
            .collect();
        let server = (!servers.is_empty()).then(|| servers[self.rng.gen_range(0..servers.len())]);
        self.send_query(asker, server, payload, ctx);
    }

    fn send_query(&mut self, asker: Option<usize>, server: Option<usize>, payload: Payload, ctx: Ctx) {
        let qid = self.next_qid;
        self.next_qid += 1;
        let asker_inc = asker.map_or(0, |a| self.links.inc[a]);
        let reachable = server.filter(|s| asker.is_none_or(|a| self.links.connected(a, *s)));
        let wait = timeout(&payload);
        self.queries.insert(qid, Pending { asker, asker_inc, server: server.unwrap_or(usize::MAX), payload: Some(payload), ctx, done: false });
        match reachable {
            // Nobody serves the key: the query ends at once, empty.
            None => {
                let at = self.now + self.delay();
                self.queue.push(at, Ev::Answer { qid, result: Err(Failure { retryable: true, error: "no queryable".into() }) });
            }
            Some(_) => {
                if !self.lost() {
                    let at = self.now + self.delay();
                    self.queue.push(at, Ev::Query(qid));
                }
                self.queue.push(self.now + wait, Ev::Timeout(qid));
            }
        }
    }

    /// The query reaches its server.
    fn serve(&mut self, qid: u64) -> Result<(), String> {
        let Some(q) = self.queries.get_mut(&qid) else { return Ok(()) };
        let (s, asker) = (q.server, q.asker);
        if s >= self.nodes.len() || !self.links.up[s] || asker.is_some_and(|a| !self.links.connected(a, s)) {
            return Ok(());
        }
        let Some(payload) = q.payload.clone() else { return Ok(()) };
        let now = self.now;
        let from = self.asker(asker);
        match payload {
            Payload::RobotCmd(cmd) => {
                let Some(r) = self.nodes[s].robot.as_mut() else { return Ok(()) };
                let cmds = r.handle(now, robot::Event::Command { cmd, from });
                // A refusal (its sender may not send this, yet) may be retried: as the driver does.
                let reply = cmds.iter().find_map(|c| match c {
                    robot::Command::Reply(r) => Some(r.clone().map_err(|error| Failure { retryable: false, error })),
                    robot::Command::Refuse(e) => Some(Err(Failure { retryable: true, error: e.clone() })),
                    _ => None,
                });
                self.robot_commands(s, cmds)?;
                // An admission changes whom the robot trusts: its host hears of it at once.
                self.local_team(s)?;
                if let Some(r) = reply {
                    self.reply(qid, r.map(Answer::Ack));
                }
            }
            Payload::RobotInfo => {
                if let Some(r) = self.nodes[s].robot.as_ref() {
                    let info = r.info(vec![]);
                    self.reply(qid, Ok(Answer::Info(info)));
                }
            }
            Payload::HostStart(start) => {
                let mission = start.spec.name.clone();
                let again = self.nodes.iter().any(|n| n.central.as_ref().is_some_and(|c| c.system().restarting(&mission)));
                let before = self.nodes[s].host.as_ref().is_some_and(|h| h.heads().any(|(m, _)| *m == mission));
                // Central starts a mission again from its journal: a new lineage, which the host
                // may take only when no other live node replicates the old one.
                let holders: Vec<String> = (0..self.nodes.len())
                    .filter(|n| *n != s && self.links.up[*n])
                    .filter(|n| self.nodes[*n].host.as_ref().and_then(|h| h.replica(&mission)).is_some_and(|r| r.state().is_some()))
                    .map(|n| self.nodes[n].name.clone())
                    .collect();
                if again && !before {
                    self.inv.started_again(&mission);
                }
                self.host(s, host::Event::Start { query: qid, start, from })?;
                let after = self.nodes[s].host.as_ref().is_some_and(|h| h.heads().any(|(m, _)| *m == mission));
                if again && !before && after && !holders.is_empty() {
                    return Err(format!("{} started {mission} anew while {holders:?} still replicate it", self.nodes[s].name));
                }
            }
            Payload::Ctl { mission, ctl } => self.host(s, host::Event::Ctl { query: qid, mission, ctl, from })?,
            Payload::View(mission) => self.host(s, host::Event::View { query: qid, mission })?,
            Payload::Planner(request, kind) => {
                if self.nodes[s].kind == Kind::Central {
                    let result = mrmm_manager::planner_service::plan(kind, &request).map(|p| Answer::Plan(Box::new(p))).map_err(|error| Failure { retryable: false, error });
                    self.reply(qid, result);
                }
            }
        }
        Ok(())
    }

    /// The server answers query `qid` (or lets it go): the answer travels back to the asker.
    fn reply(&mut self, qid: u64, result: Result<Answer, Failure>) {
        let Some(q) = self.queries.get(&qid) else { return };
        if q.done {
            return;
        }
        if !self.lost() {
            let at = self.now + self.delay();
            self.queue.push(at, Ev::Answer { qid, result });
        }
    }

    /// An answer reaches the asker.
    fn answer(&mut self, qid: u64, result: Result<Answer, Failure>) -> Result<(), String> {
        let Some(q) = self.queries.get_mut(&qid) else { return Ok(()) };
        if q.done {
            return Ok(());
        }
        let arrives = match q.asker {
            None => true,
            Some(a) => self.links.up[a] && self.links.inc[a] == q.asker_inc && (q.server >= self.nodes.len() || result.is_err() || self.links.connected(a, q.server)),
        };
        if !arrives && result.is_ok() {
            return Ok(());
        }
        q.done = true;
        let (asker, ctx) = (q.asker, q.ctx.clone());
        self.queries.remove(&qid);
        if asker.is_some_and(|a| !self.links.up[a]) {
            return Ok(());
        }
        let sys = |e: system::Event| central::Event::System(e);
        match (ctx, asker) {
            (Ctx::CentralInfo(id), Some(a)) => {
                let ev = match result {
                    Ok(Answer::Info(info)) if info.id == id => system::Event::RobotRegistered(info),
                    Ok(_) => system::Event::InfoFailed { id, reason: "bad answer".into() },
                    Err(f) => system::Event::InfoFailed { id, reason: f.error },
                };
                self.central(a, sys(ev))
            }
            (Ctx::CentralRobot { req, robot }, Some(a)) => {
                let result = match result {
                    Ok(Answer::Ack(ack)) => Ok(ack),
                    Ok(other) => Err(format!("unexpected {other:?}")),
                    Err(f) => Err(f.error),
                };
                self.central(a, sys(system::Event::RobotCommandDone { req, robot, result }))
            }
            (Ctx::CentralStart(mission), Some(a)) => {
                let result = json::<MissionView>(result).map(Box::new);
                self.central(a, sys(system::Event::MissionStarted { mission, result }))
            }
            (Ctx::CentralCtl(id), Some(a)) => {
                let result = json::<CtlAck>(result).map(|_| ());
                self.central(a, sys(system::Event::CtlDone { id, result }))
            }
            (Ctx::HostPlan { mission, epoch }, Some(a)) => {
                let ok = result.as_ref().map(|_| ()).map_err(|f| f.error.clone());
                self.log(|| format!("plan of {mission} epoch {epoch} answered: {ok:?}"));
                let result = match result {
                    Ok(Answer::Plan(p)) => Ok(p),
                    Ok(other) => Err(Failure { retryable: false, error: format!("unexpected {other:?}") }),
                    Err(f) => Err(f),
                };
                self.host(a, host::Event::Planned { mission, epoch, result })
            }
            (Ctx::HostSendPlan { mission, robot, epoch }, Some(a)) => {
                let result = result.map(|_| ());
                self.host(a, host::Event::PlanDelivered { mission, robot, epoch, result })
            }
            (Ctx::OpCtl(id), _) => {
                let result = json::<CtlAck>(result).map(|_| ());
                self.ctls.done(self.now, id, result);
                Ok(())
            }
            (Ctx::OpStart, _) | (Ctx::CentralForward, _) => Ok(()),
            (_, None) => Ok(()),
        }
    }

    // ---- the operator ----------------------------------------------------------------------

    fn robot_names(&self) -> Vec<String> {
        self.nodes.iter().filter(|n| n.kind == Kind::Robot).map(|n| n.name.clone()).collect()
    }

    fn operate(&mut self) -> Result<(), String> {
        let active = self.now < self.cfg.duration;
        match self.cfg.ops {
            Ops::Barriers { .. } => {}
            Ops::Random => {
                let next = self.now + self.rng.gen_range(1.0..3.0);
                self.queue.push(next, Ev::Op);
                let Some(c) = self.nodes.iter().position(|n| n.kind == Kind::Central) else { return Ok(()) };
                if !active || !self.links.up[c] {
                    return Ok(());
                }
                let robots = self.robot_names();
                let (req, request) = self.op.command(&mut self.rng, &robots);
                self.log(|| format!("operator: {request:?}"));
                self.central(c, central::Event::System(system::Event::Operator { req: Req::Query(req), request }))?;
            }
            Ops::OneMission => {
                self.queue.push(self.now + 0.25, Ev::Op);
                if !active {
                    // Quiet: the operator stops, controls not yet acknowledged included.
                    self.ctls.cancel("p");
                }
                if self.now < 0.6 {
                    self.start_one_mission();
                } else {
                    // As central does for members that join or come back: a robot the mission's
                    // state counts in (or lost) that does not know the whole team (it restarted,
                    // or others joined since its plan) is admitted with the team, so robot heads
                    // may plan for it and it takes their chain messages.
                    let mut counted: BTreeSet<String> = BTreeSet::new();
                    // The managers central would name: the chain of the newest configuration.
                    let mut chain: Option<(u64, Vec<String>)> = None;
                    for n in &self.nodes {
                        let Some(r) = n.host.as_ref().and_then(|h| h.replica("p")) else { continue };
                        if let Some(state) = r.state() {
                            counted.extend(state.members.iter().chain(&state.lost).map(|m| m.spec.id.clone()));
                        }
                        if let Some(c) = r.config() {
                            if chain.as_ref().is_none_or(|(e, _)| c.epoch > *e) {
                                chain = Some((c.epoch, c.chain.clone()));
                            }
                        }
                    }
                    self.managers = chain.map(|(_, c)| c).unwrap_or_default();
                    let unaware: Vec<String> = counted
                        .iter()
                        .filter(|r| {
                            let teams = self.index(r).and_then(|i| self.nodes[i].robot.as_ref()).map(|rb| rb.team()).unwrap_or_default();
                            !teams.iter().any(|(m, ids)| m == "p" && counted.iter().all(|c| ids.contains(c)))
                        })
                        .cloned()
                        .collect();
                    let team: Vec<String> = counted.into_iter().collect();
                    for r in unaware {
                        self.admit(&r, &team);
                    }
                }
                if self.now >= 0.6 && active && self.rng.gen_bool(0.15) {
                    let robots = self.robot_names();
                    let r = robots[self.rng.gen_range(0..robots.len())].clone();
                    let ctl = if self.team.contains(&r) && self.team.len() > 1 {
                        self.team.remove(&r);
                        MissionCtl::Left { ids: vec![r] }
                    } else if !self.team.contains(&r) {
                        self.team.insert(r.clone());
                        self.admit_one(&r);
                        let spec = RobotSpec { id: r, robot_type: "ground".into(), x: 0.0, y: 0.0, speed: 1.0 };
                        MissionCtl::Joined { member: Member { spec, time_scale: TIME_SCALE } }
                    } else {
                        return Ok(());
                    };
                    self.ctls.push("p", ctl, None);
                }
                for (id, mission, ctl) in self.ctls.due(self.now) {
                    self.ask_mission(None, &mission.clone(), Payload::Ctl { mission, ctl }, Ctx::OpCtl(id));
                }
            }
        }
        Ok(())
    }

    /// OneMission: mission `p` of every robot, on the first mission host.
    fn start_one_mission(&mut self) {
        let robots = self.robot_names();
        self.team = robots.iter().cloned().collect();
        let members = robots
            .iter()
            .enumerate()
            .map(|(i, r)| Member { spec: RobotSpec { id: r.clone(), robot_type: "ground".into(), x: i as f64 * 2.0, y: -3.0, speed: 1.0 }, time_scale: TIME_SCALE })
            .collect();
        let params = cheap_params(true).into_iter().map(|(k, v)| (k, v.to_string())).collect();
        let spec = MissionSpecWire {
            name: "p".into(),
            recipe_name: "patrol".into(),
            recipe_xml: mrmm_planner::recipe::bank("patrol").unwrap_or_default().into(),
            planner: "patrol".into(),
            params,
            replicas: 2,
        };
        let host = self.nodes.iter().find(|n| n.kind == Kind::Host).map(|n| n.name.clone()).unwrap_or_else(|| robots[0].clone());
        for r in &robots {
            self.admit_one(r);
        }
        self.ask(None, &host, Payload::HostStart(Box::new(MissionStart { spec, members })), Ctx::OpStart);
    }

    /// OneMission: admits robot `r` to mission `p` with the operator's team.
    fn admit_one(&mut self, r: &str) {
        let team: Vec<String> = self.team.iter().cloned().collect();
        self.admit(r, &team);
    }

    /// Admits robot `r` to mission `p` (as the system manager does): its managers are the host
    /// and any member of `team`, its members `team` (and `r`).
    fn admit(&mut self, r: &str, team: &[String]) {
        let mut team = team.to_vec();
        if !team.iter().any(|t| t == r) {
            team.push(r.to_string());
        }
        let mut managers: Vec<String> = self.nodes.iter().filter(|n| n.kind == Kind::Host).map(|n| n.name.clone()).collect();
        managers.extend(self.managers.iter().cloned());
        managers.extend(team.iter().cloned());
        managers.sort();
        managers.dedup();
        let admit = RobotCommand::Admit { mission: "p".into(), managers, members: team };
        self.log(|| format!("operator: admit {r} to p"));
        self.ask(None, r, Payload::RobotCmd(admit), Ctx::OpStart);
    }

    /// Barriers: every robot gets the same plan of barriers with work between them.
    fn hand_out_barrier_plans(&mut self, points: u32, rounds: u32) {
        let robots = self.robot_names();
        for (i, r) in robots.iter().enumerate() {
            let mut steps = vec![Step::Sync { point: 0 }];
            for p in 1..points {
                let x = (i as f64 + p as f64) * self.rng.gen_range(0.5..2.0);
                steps.push(Step::Navigate { x, y: self.rng.gen_range(-3.0..3.0), speed: None });
                steps.push(Step::Sync { point: p });
            }
            steps.push(Step::Hold { seconds: Some(self.rng.gen_range(0.0..2.0)) });
            steps.push(Step::Loop { to: 1, rounds: Some(rounds) });
            let assignment = PlanAssignment {
                mission: "b".into(),
                epoch: 1,
                team: "b".into(),
                subteam: "b/ground".into(),
                members: robots.clone(),
                plan: RobotPlan { robot: r.clone(), robot_type: "ground".into(), slot: i, steps },
                managers: vec![],
            };
            let j = self.index(r).unwrap_or(0);
            let from = Sender::new(Role::Host, "planner");
            let cmds = self.nodes[j].robot.as_mut().map(|rb| rb.handle(0.0, robot::Event::Command { cmd: RobotCommand::Plan(Box::new(assignment)), from })).unwrap_or_default();
            let _ = self.robot_commands(j, cmds);
        }
    }

    // ---- the end ---------------------------------------------------------------------------

    /// Whether a majority of `mission`'s newest chain still holds its state.
    fn recoverable(&self, mission: &str) -> bool {
        let replicas: Vec<(&String, &mrmm_manager::chain::Replica<mrmm_proto::MissionSnapshot>)> =
            self.nodes.iter().filter_map(|n| Some((&n.name, n.host.as_ref()?.replica(mission)?))).collect();
        let Some(newest) = replicas.iter().filter_map(|(_, r)| r.config()).max_by_key(|c| c.epoch) else { return false };
        newest.majority(|node| replicas.iter().any(|(n, r)| n.as_str() == node && r.state().is_some()))
    }

    /// After the quiet period: one head per mission, every live member on its current epoch, no
    /// robot in two missions; barrier plans finished.
    fn finish(&mut self) -> Result<(), String> {
        let alive: BTreeSet<String> = self
            .nodes
            .iter()
            .filter_map(|n| n.host.as_ref())
            .flat_map(|h| h.heads().map(|(m, _)| m.clone()).collect::<Vec<_>>())
            .collect();
        self.inv.forget_missions(&alive);
        self.one_mission_per_robot()?;
        if let Ops::Barriers { .. } = self.cfg.ops {
            for (i, n) in self.nodes.iter().enumerate() {
                let done = n.robot.as_ref().and_then(|r| r.executor()).is_some_and(|e| e.progress().done);
                if self.links.up[i] && !done {
                    let at = n.robot.as_ref().and_then(|r| r.executor()).map(|e| e.progress());
                    return Err(format!("{} did not finish its plan: {at:?}", n.name));
                }
            }
            return Ok(());
        }
        let mut heads: BTreeMap<String, Vec<(String, u64, Vec<String>)>> = BTreeMap::new();
        for n in &self.nodes {
            let Some(h) = &n.host else { continue };
            for (m, mm) in h.heads() {
                heads.entry(m.clone()).or_default().push((n.name.clone(), mm.epoch(), mm.members().cloned().collect()));
            }
        }
        for (m, hs) in &heads {
            if !self.recoverable(m) {
                // A majority of its chain restarted and lost what it held (memory is not
                // durable yet): the chain cannot safely form again; robots keep their plans.
                self.report.unrecoverable += 1;
                continue;
            }
            if hs.len() > 1 {
                let names: Vec<&String> = hs.iter().map(|h| &h.0).collect();
                return Err(format!("{} heads of {m} after healing: {names:?}", hs.len()));
            }
            if self.op.terminated.contains(m) {
                continue;
            }
            let (_, epoch, members) = &hs[0];
            for r in members {
                let Some(i) = self.index(r) else { continue };
                let running = self.nodes[i].robot.as_ref().and_then(|rb| rb.executor()).map(|e| (e.mission().to_string(), e.epoch()));
                if self.links.up[i] && running != Some((m.clone(), *epoch)) {
                    let chains: Vec<String> = self
                        .nodes
                        .iter()
                        .filter_map(|n| {
                            let r = n.host.as_ref()?.replica(m)?;
                            Some(format!("{}: {:?} {:?} v{:?} committed {:?}", n.name, r.role(), r.config(), r.version(), r.committed()))
                        })
                        .collect();
                    return Err(format!("live member {r} of {m} runs {running:?}, not {m}'s epoch {epoch}, after healing; replicas: {chains:?}"));
                }
            }
        }
        self.report.missions_at_end = heads.len();
        self.report.commands_ok = self.op.ok;
        Ok(())
    }
}
