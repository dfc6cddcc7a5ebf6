//! The simulated world: nodes running the production machines, and the event loop that plays the
//! drivers' part — it delivers publications, routes queries to whoever serves their key and
//! answers to whoever asked, declares liveliness tokens, ticks the machines, and injects faults.

use std::collections::{BTreeMap, BTreeSet};

use mrmm_core::body::Limits;
use mrmm_core::central::agent::{AgentConfig, Autonomy};
use mrmm_core::central::system::{self, Ctls, Req};
use mrmm_core::central::{self, CentralCore};
use mrmm_core::mission::chain::Params;
use mrmm_core::mission::host::{self, HostCore};
use mrmm_core::robot::RobotSetup;
use mrmm_core::robot::{self, Robot};
use mrmm_core::Failure;
use mrmm_proto::{
    CtlAck, Member, MissionCtl, MissionName, MissionSpecWire, MissionStart, NodeId, PlanAssignment, PlanRequest, RobotCommand, RobotId, RobotPlan, RobotSpec,
    Role, Sender, Step, Time, CENTRAL_HOST,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::invariants::Invariants;
use crate::net::{Beliefs, Change, Links, Queue, Token};
use crate::ops::{cheap_params, Operator};
use crate::{Config, Ops, Report, Violation};

mod driver;
mod end;
mod faults;
mod machines;
mod operator;
mod queries;
mod wire;

use wire::Wire;

/// Robots' simulated seconds per wall second.
const TIME_SCALE: f64 = 4.0;
/// How long a query waits for an answer: the drivers' own timeouts.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Kind {
    Central,
    Host,
    Robot,
}

impl Kind {
    /// Whether a node of this kind keeps its host's chain state on disk: central always (beside
    /// its journal, it always has a state dir here), the others when the run has disks.
    fn keeps_chain_state(self, disks: bool) -> bool {
        disks || self == Kind::Central
    }
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
    cfg: Option<RobotSetup>,
    /// Missions whose queryables this node's host serves.
    served: BTreeSet<MissionName>,
    /// The robot's team as the network sees it (what it publishes on, what it hears).
    links: robot::Links,
    /// Central's journal: what it committed, kept across crashes (the disk).
    disk: mrmm_core::central::system::Durable,
    /// A robot's or mission host's chain state on disk ([`Config::disks`]), kept across crashes.
    chain_disk: BTreeMap<MissionName, mrmm_core::mission::chain::Disk<mrmm_proto::MissionSnapshot>>,
    /// A robot's capabilities as changed at runtime, kept in its state dir ([`Config::disks`]).
    kept_caps: Option<Vec<String>>,
}

/// What a query asks of its server.
#[derive(Debug, Clone)]
enum Payload {
    RobotCmd(RobotCommand),
    RobotInfo,
    HostStart(Box<MissionStart>),
    Ctl { mission: MissionName, ctl: MissionCtl },
    View(MissionName),
    Planner(PlanRequest, mrmm_planner::recipe::PlannerKind),
}

/// Who asked, and what the answer goes back as.
#[derive(Debug, Clone)]
enum Ctx {
    /// Central's system manager asked: the answer becomes its event.
    Central(system::asks::Then),
    /// A mission host asked.
    Host(host::asks::Then),
    OpStart,
    OpCtl(u64),
}

/// An answer on the wire.
#[derive(Debug, Clone)]
enum Answer {
    Json(serde_json::Value),
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
    Tick {
        node: usize,
        inc: u32,
        kind: TickKind,
    },
    /// A message to a mission host, as its driver receives it: translated by the host's ingress.
    Host {
        from: usize,
        to: usize,
        msg: Box<Wire>,
    },
    /// A message to central, as its driver receives it: translated by the system manager's ingress.
    Central {
        from: usize,
        to: usize,
        msg: Box<Wire>,
    },
    /// A message to a robot, as its driver receives it: translated by the robot's own ingress.
    Robot {
        from: usize,
        to: usize,
        msg: Box<Wire>,
    },
    /// A forger publishes in another robot's name (never changes what honest nodes do).
    Forge,
    /// An answer a node computed for itself (local planning).
    Local {
        node: usize,
        inc: u32,
        ev: Box<host::Event>,
    },
    /// An answer central's driver computed for it (a dry run).
    LocalCentral {
        node: usize,
        inc: u32,
        ev: Box<central::Event>,
    },
    Query(u64),
    Answer {
        qid: u64,
        result: Result<Answer, Failure>,
    },
    Timeout(u64),
    Live(Change, u32),
    Crash,
    Restart(usize),
    Partition,
    Heal,
    Suspect,
    Unsuspect(usize, usize),
    Op,
    /// Every node on central's side of the partition loses power (see `Config::side_cycles`).
    CycleSide,
}

/// One run.
pub struct World {
    cfg: Config,
    rng: ChaCha8Rng,
    /// The random stream of the side power cycles (`Config::side_cycles`).
    fault_rng: ChaCha8Rng,
    /// The operator's changes of robots' capabilities, drawn from a stream of their own so that
    /// the other draws of a seed stay as they were.
    caps_rng: ChaCha8Rng,
    /// The operator's hand-overs (a robot takes a member's place), a stream of their own too.
    swap_rng: ChaCha8Rng,
    /// The stream of central's missed liveliness changes (`Config::missed_live`).
    miss_rng: ChaCha8Rng,
    /// The forger's stream ([`wire`]).
    forge_rng: ChaCha8Rng,
    now: Time,
    nodes: Vec<Node>,
    links: Links,
    beliefs: Beliefs,
    queue: Queue<Ev>,
    queries: BTreeMap<u64, Pending>,
    next_qid: u64,
    /// Publications made, lost or not (what a command classified as no publication must not
    /// change: `driver.rs`).
    published: u64,
    inv: Invariants,
    op: Operator,
    /// OneMission: the operator's controls, and the team it wants.
    ctls: Ctls,
    team: BTreeSet<String>,
    /// OneMission: the mission's chain as last seen (whom admissions name as managers).
    managers: Vec<NodeId>,
    report: Report,
    trace: Option<Vec<String>>,
}

fn robot_cfg(id: &str, x: f64, y: f64) -> RobotSetup {
    RobotSetup {
        capabilities: vec!["camera".to_string()],
        time_scale: TIME_SCALE,
        ..RobotSetup::sim(id, "ground", Limits { max_speed: 1.0, max_turn_rate: 2.0 }, mrmm_proto::Pose { x, y, theta: 0.0 })
    }
}

fn json<T: serde::de::DeserializeOwned>(a: Result<Answer, Failure>) -> Result<T, Failure> {
    match a? {
        Answer::Json(v) => serde_json::from_value(v).map_err(|e| Failure::fatal(e.to_string())),
    }
}

impl Node {
    /// A node whose process has not started yet (see `World::boot`).
    fn new(name: String, kind: Kind, cfg: Option<RobotSetup>) -> Node {
        let links = robot::Links::new(&name);
        Node {
            name,
            kind,
            central: None,
            host: None,
            robot: None,
            cfg,
            served: BTreeSet::new(),
            links,
            disk: Default::default(),
            kept_caps: None,
            chain_disk: BTreeMap::new(),
        }
    }
}

impl World {
    pub fn new(cfg: Config, trace: bool) -> World {
        let mut nodes = Vec::new();
        if cfg.central {
            nodes.push(Node::new(CENTRAL_HOST.into(), Kind::Central, None));
        }
        for i in 1..=cfg.hosts {
            nodes.push(Node::new(format!("h{i}"), Kind::Host, None));
        }
        for i in 1..=cfg.robots {
            let id = format!("r{i}");
            let mut c = robot_cfg(&id, i as f64 * 2.0, -3.0);
            // With disks, robots keep state across restarts (the simulated disk is `chain_disk`).
            c.durable = cfg.disks;
            nodes.push(Node::new(id, Kind::Robot, Some(c)));
        }
        let n = nodes.len();
        let mut w = World {
            cfg,
            rng: ChaCha8Rng::seed_from_u64(cfg.seed),
            fault_rng: ChaCha8Rng::seed_from_u64(cfg.seed ^ 0x51de_c1c1e),
            caps_rng: ChaCha8Rng::seed_from_u64(cfg.seed ^ 0xca9a_b1e5),
            swap_rng: ChaCha8Rng::seed_from_u64(cfg.seed ^ 0x5a4d_0e12),
            miss_rng: ChaCha8Rng::seed_from_u64(cfg.seed ^ 0x0_1055),
            forge_rng: ChaCha8Rng::seed_from_u64(cfg.seed ^ 0xf0_29e5),
            now: Time::ZERO,
            nodes,
            links: Links::new(n),
            beliefs: Beliefs::default(),
            queue: Queue::new(),
            queries: BTreeMap::new(),
            next_qid: 0,
            published: 0,
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

    /// When faults, losses and operations stop (the quiet period follows).
    fn end(&self) -> Time {
        Time::from_secs(self.cfg.duration)
    }

    fn delay(&mut self) -> f64 {
        self.rng.gen_range(0.0..=self.cfg.max_delay)
    }

    /// Whether a message is lost (never in the quiet period).
    fn lost(&mut self) -> bool {
        self.now < self.end() && self.cfg.loss > 0.0 && self.rng.gen_bool(self.cfg.loss.min(1.0))
    }

    /// Starts node `i`'s process: fresh machines, its timers.
    fn boot(&mut self, i: usize) {
        let now = self.now;
        let params = Params::default();
        let disks = self.cfg.disks;
        // A node's host: from its disk when it has one.
        let host = |n: &Node| {
            if n.kind.keeps_chain_state(disks) {
                HostCore::restore(&n.name, params, now, n.chain_disk.clone().into_iter().collect())
            } else {
                HostCore::new(&n.name, params, now)
            }
        };
        let n = &mut self.nodes[i];
        n.served.clear();
        n.links = robot::Links::new(&n.name);
        match n.kind {
            Kind::Central => {
                let agent = AgentConfig { autonomy: Autonomy::Act, ..AgentConfig::default() };
                // The sim's clock is central's: its last sign of life is when it crashed.
                n.central = Some(CentralCore::restore(n.name.clone().into(), agent, now, n.disk.clone()));
                n.host = Some(host(n));
            }
            Kind::Host => n.host = Some(host(n)),
            Kind::Robot => {
                if !matches!(self.cfg.ops, Ops::Barriers { .. }) {
                    n.host = Some(host(n).with_robot());
                }
                n.robot = n.cfg.clone().map(Robot::new);
                // With its state dir, a robot comes back with the capabilities it was left with.
                if let (Some(r), Some(now)) = (n.robot.as_mut(), n.kept_caps.clone()) {
                    r.restore_capabilities(now);
                }
            }
        }
        let inc = self.links.inc[i];
        let kinds: &[(TickKind, f64)] = match self.nodes[i].kind {
            Kind::Central => &[(TickKind::Central, 0.25), (TickKind::Host, 0.05), (TickKind::Status, 1.0)],
            Kind::Host => &[(TickKind::Host, 0.05), (TickKind::Status, 1.0)],
            Kind::Robot if self.nodes[i].host.is_some() => {
                &[(TickKind::Physics, 0.05), (TickKind::Telemetry, 0.2), (TickKind::Host, 0.05), (TickKind::Status, 1.0)]
            }
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
            Err(what) => Err(Violation { seed: self.cfg.seed, at: self.now.secs(), what, trace: self.trace.take().unwrap_or_default() }),
        }
    }

    fn run_inner(&mut self) -> Result<(), String> {
        let end = self.end() + self.cfg.quiet;
        self.schedule_faults();
        self.schedule_forgery();
        match self.cfg.ops {
            Ops::Barriers { points, rounds, mode, teams } => self.hand_out_barrier_plans(points, rounds, mode, teams),
            Ops::OneMission | Ops::Random => self.queue.push(Time::from_secs(0.5), Ev::Op),
        }
        while let Some(t) = self.queue.peek_time() {
            if t > end {
                break;
            }
            let Some((t, ev)) = self.queue.pop() else {
                break;
            };
            self.now = t;
            self.report.events += 1;
            self.event(ev)?;
        }
        self.finish()
    }

    fn event(&mut self, ev: Ev) -> Result<(), String> {
        match ev {
            Ev::Tick { node, inc, kind } => self.tick(node, inc, kind)?,
            Ev::Host { from, to, msg } => {
                if self.links.connected(from, to) {
                    self.report.messages += 1;
                    self.host_hears(to, *msg)?;
                }
            }
            Ev::Central { from, to, msg } => {
                if self.links.connected(from, to) {
                    self.report.messages += 1;
                    self.central_hears(to, *msg)?;
                }
            }
            Ev::Robot { from, to, msg } => {
                if self.links.connected(from, to) {
                    self.report.messages += 1;
                    self.robot_hears(to, *msg)?;
                }
            }
            Ev::Forge => self.forge()?,
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
                    let error = Failure::retry("no answer");
                    self.answer(qid, Err(error))?;
                }
            }
            Ev::Live(c, inc) => {
                if self.links.up[c.observer] && self.links.inc[c.observer] == inc {
                    let missed = self.cfg.missed_live > 0.0 && self.miss_rng.gen_bool(self.cfg.missed_live);
                    self.tell(c.observer, &c.token, c.up, missed)?;
                }
            }
            Ev::Crash => self.random_crash(),
            Ev::Restart(i) => self.restart(i),
            Ev::Partition => self.random_partition(),
            Ev::CycleSide => self.cycle_side(),
            Ev::Heal => {
                self.log(|| "heal".into());
                self.links.heal();
                self.liveliness(0.05);
            }
            Ev::Suspect => self.random_suspicion(),
            Ev::Unsuspect(a, b) => {
                self.links.suspect(a, b, false);
                self.liveliness(0.05);
            }
            Ev::Op => self.operate()?,
        }
        Ok(())
    }

    /// A node's periodic tick of `kind` (if it is still the same incarnation), and the next one.
    fn tick(&mut self, node: usize, inc: u32, kind: TickKind) -> Result<(), String> {
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
            TickKind::Physics => self.robot(node, robot::Event::Tick),
            TickKind::Telemetry => self.robot(node, robot::Event::TelemetryDue),
            TickKind::Host => self.host(node, host::Event::Tick),
            TickKind::Status => self.host(node, host::Event::StatusTick),
            TickKind::Central => self.central(node, central::Event::System(system::Event::Tick)),
        }
    }
}
