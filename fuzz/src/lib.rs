//! Shared pieces of the fuzz targets: how an input is cut into messages, who may send them, and
//! the production state machines set up as a small running fleet (central, a mission host, robots)
//! that the messages are then thrown at.
//!
//! An input is a sequence of frames separated by a zero byte; a frame's first byte picks what the
//! rest is (which key it arrives on, from whom), the rest is the payload as it comes off the wire
//! (JSON, or a seal). Every payload goes through the decoder the driver uses, and what decodes goes
//! to the same `handle` the driver calls.
// Functions outside tests are at most 80 lines (clippy.toml); tests may be longer.
#![cfg_attr(not(test), deny(clippy::too_many_lines))]

pub mod targets;

use std::collections::VecDeque;

use mrmm_core::central::system::{self, SystemManager};
use mrmm_core::mission::chain;
use mrmm_core::mission::host::{self, HostCore};
use mrmm_core::mission::planning as planner_service;
use mrmm_core::robot::{self, Robot};
use mrmm_peer::config::RobotConfig;
use mrmm_proto::{CommandAck, Member, MissionStart, MissionView, RobotInfo, RobotSpec, Role, Sender, Telemetry, Time};

/// The frames of an input: (selector, payload).
pub fn frames(data: &[u8]) -> impl Iterator<Item = (u8, &[u8])> {
    data.split(|b| *b == 0).filter_map(|f| f.split_first().map(|(s, rest)| (*s, rest)))
}

/// Who a frame claims to come from (its proven sender, as the seal check would give it):
/// the fleet's own nodes, a rogue robot, the operator, a planner.
pub fn sender(b: u8) -> Sender {
    match b % 8 {
        0 => Sender::new(Role::Central, "central"),
        1 => Sender::new(Role::Robot, "r1"),
        2 => Sender::new(Role::Robot, "r2"),
        3 => Sender::new(Role::Robot, "r3"),
        4 => Sender::new(Role::Robot, "r9"),
        5 => Sender::new(Role::Host, "h1"),
        6 => Sender::new(Role::Operator, "op"),
        _ => Sender::new(Role::Planner, "planner"),
    }
}

/// The robots of the fixture fleet.
pub const ROBOTS: [&str; 3] = ["r1", "r2", "r3"];

/// A simulated robot of the fixture fleet.
pub fn robot(id: &str) -> Robot {
    let text = format!(r#"{{ id: "{id}", type: "ground", kinematics: {{ max_speed: 2, max_turn_rate: 3 }}, time_scale: 4 }}"#);
    match RobotConfig::from_json5("fuzz", &text) {
        Ok(cfg) => Robot::new(cfg.setup()),
        Err(e) => panic!("fixture robot config: {e}"),
    }
}

/// A robot with a ROS 2 body (nothing is opened: the machine only).
pub fn ros_robot(id: &str) -> Robot {
    ros_robot_driven(id, "cmd_vel")
}

/// [`ros_robot`] with `drive` `cmd_vel` or `nav2`.
pub fn ros_robot_driven(id: &str, drive: &str) -> Robot {
    let text = format!(r#"{{ id: "{id}", type: "ground", kinematics: {{ max_speed: 1, max_turn_rate: 2 }}, body: {{ kind: "ros2", drive: "{drive}" }} }}"#);
    match RobotConfig::from_json5("fuzz", &text) {
        Ok(cfg) => Robot::new(cfg.setup()),
        Err(e) => panic!("fixture robot config: {e}"),
    }
}

/// A robot's registration record.
pub fn info(id: &str) -> RobotInfo {
    RobotInfo { max_speed: 2.0, endpoints: vec!["tcp/127.0.0.1:7450".into()], time_scale: 4.0, ..RobotInfo::new(id, "ground", 2.0) }
}

/// A robot's current telemetry, from the robot machine itself.
pub fn telemetry(r: &mut Robot, now: Time) -> Option<Telemetry> {
    r.handle(now, robot::Event::TelemetryDue).into_iter().find_map(|c| match c {
        robot::Command::Telemetry(t) => Some(t),
        _ => None,
    })
}

/// Central's system manager with the fixture robots registered and central's own host up, and
/// one patrol mission `p` of r1 and r2 running (as its host answered).
#[derive(Clone)]
pub struct Central {
    pub sm: SystemManager,
    pub now: Time,
    next_query: u64,
}

impl Central {
    pub fn new() -> Central {
        let mut c = Central { sm: SystemManager::new("central".into(), Time::ZERO), now: Time::ZERO, next_query: 0 };
        c.feed(system::Event::HostAlive { node: "central".into() });
        for id in ROBOTS {
            c.feed(system::Event::RobotAlive { id: id.into() });
            c.feed(system::Event::RobotRegistered(info(id)));
            let mut r = robot(id);
            if let Some(t) = telemetry(&mut r, Time::ZERO) {
                c.feed(system::Event::Telemetry(Box::new(t)));
            }
        }
        // Past the adoption period, so commands are carried out at once.
        c.now = Time::from_secs(system_adopt_s() + 0.1);
        c.feed(system::Event::Tick);
        let create = br#"{"name": "p", "recipe": "patrol", "robots": ["r1", "r2"], "params": {"waypoints": [[0,0],[10,0],[10,10],[0,10]]}}"#;
        if let Ok(request) = system::Request::decode(&mrmm_proto::Key::SystemCmd(mrmm_proto::SystemCmd::Create).to_string(), create) {
            c.operator(request);
        }
        c
    }

    /// An operator request, as the driver hands it over.
    pub fn operator(&mut self, request: system::Request) {
        self.next_query += 1;
        let req = system::Req::Query(self.next_query);
        self.feed(system::Event::Operator { req, request });
    }

    /// Hands `ev` to the system manager and plays the rest of the fleet for what it asks:
    /// hosts start missions and acknowledge controls, dry runs run, robots acknowledge.
    pub fn feed(&mut self, ev: system::Event) {
        let mut queue = VecDeque::from([ev]);
        let mut budget = 10_000u32;
        while let Some(ev) = queue.pop_front() {
            budget = budget.saturating_sub(1);
            if budget == 0 {
                panic!("the system manager keeps asking: a loop");
            }
            for c in self.sm.handle(self.now, ev) {
                match c {
                    system::Command::StartMission { host, start } => queue.push_back(system::Event::MissionStarted {
                        mission: start.spec.name.clone(),
                        result: Ok(Box::new(started_view(host.as_str(), &start))),
                    }),
                    system::Command::Ctl { id, .. } => queue.push_back(system::Event::CtlDone { id, result: Ok(()) }),
                    system::Command::DryRun(dry) => queue.push_back(system::Event::DryRunDone { id: dry.id, result: dry.run() }),
                    system::Command::SendToRobot { req, robot, cmd: _ } => {
                        let ack = CommandAck { ok: true, robot: robot.clone(), behaviour: mrmm_proto::Behaviour::Hold, capabilities: None };
                        queue.push_back(system::Event::RobotCommandDone { req, robot, result: Ok(ack) })
                    }
                    system::Command::FetchInfo { id } => {
                        queue.push_back(system::Event::InfoFailed { id, reason: "not a fixture robot".into() });
                    }
                    _ => {}
                }
            }
        }
    }
}

impl Default for Central {
    fn default() -> Self {
        Central::new()
    }
}

fn system_adopt_s() -> f64 {
    system::ADOPT_S
}

/// The status a host reports for a mission it just started.
pub fn started_view(host: &str, start: &MissionStart) -> MissionView {
    MissionView {
        name: start.spec.name.clone(),
        recipe: start.spec.recipe_name.clone(),
        planner: start.spec.planner.clone(),
        status: mrmm_proto::MissionStatus::Running,
        robots: start.members.iter().map(|m| m.spec.id.clone()).collect(),
        lost: vec![],
        stuck: Default::default(),
        held: vec![],
        teams: Default::default(),
        team_views: vec![],
        manager: mrmm_proto::ManagerView { node: host.into(), epoch: 1, chain_epoch: 1, chain: vec![host.into()], uncommitted_s: None },
        metrics: Default::default(),
        summary: None,
        summary_unchanged: false,
        params: Default::default(),
        error: None,
        plans: None,
        requires: vec![],
        map: None,
    }
}

/// A member record of a fixture robot.
pub fn member(id: &str, x: f64) -> Member {
    Member {
        spec: RobotSpec { id: id.into(), robot_type: "ground".into(), x, y: 0.0, speed: 2.0, turn_rate: None, reach_m: None },
        time_scale: 4.0,
        capabilities: vec![],
    }
}

/// A mission host (`node`) running a patrol `p` of r1 and r2 that central started, with plans
/// from the real planner; its chain replicas' messages are played back to it.
#[derive(Clone)]
pub struct Host {
    pub core: HostCore,
    pub now: Time,
    next_query: u64,
    /// The last planning request: (mission, epoch).
    pub last_plan: Option<(String, u64)>,
    /// What it sent (the seeds program turns these into inputs): chain messages, plans, plans
    /// handed to robots.
    pub sent: Vec<mrmm_proto::ChainEnvelope>,
    pub plans: Vec<mrmm_proto::MissionPlan>,
    pub assignments: Vec<mrmm_proto::PlanAssignment>,
}

impl Host {
    pub fn new(node: &str) -> Host {
        let mut h = Host {
            core: HostCore::new(node, chain::Params::default(), Time::ZERO),
            now: Time::ZERO,
            next_query: 0,
            last_plan: None,
            sent: vec![],
            plans: vec![],
            assignments: vec![],
        };
        for n in ["central", "r1", "r2", "r3"] {
            h.feed(host::Event::HostAlive(n.into()));
            h.feed(host::Event::RobotAlive(n.into()));
        }
        h
    }

    /// Central starts mission `p` on this host, with `replicas` replicas after the head.
    pub fn start_patrol(&mut self, replicas: usize) {
        let start = MissionStart {
            spec: mrmm_proto::MissionSpecWire {
                name: "p".into(),
                recipe_name: "patrol".into(),
                recipe_xml: mrmm_planner::recipe::bank("patrol").unwrap_or_default().into(),
                planner: "patrol".into(),
                params: [("waypoints".to_string(), "[[0,0],[10,0],[10,10],[0,10]]".to_string())].into(),
                replicas,
                map: None,
                paused: false,
            },
            members: vec![member("r1", 0.0), member("r2", 1.0)],
            anew: false,
            lineage: 0,
        };
        self.next_query += 1;
        self.feed(host::Event::Start { query: self.next_query, start: Box::new(start), from: sender(0) });
    }

    pub fn query(&mut self) -> u64 {
        self.next_query += 1;
        self.next_query
    }

    /// Hands `ev` to the host and answers what it asks of the world: plans from the real planner,
    /// deliveries acknowledged. Chain messages it sends go nowhere (the fuzzer plays the others).
    pub fn feed(&mut self, ev: host::Event) {
        let mut queue = VecDeque::from([ev]);
        let mut budget = 10_000u32;
        while let Some(ev) = queue.pop_front() {
            budget = budget.saturating_sub(1);
            if budget == 0 {
                panic!("the host keeps asking: a loop");
            }
            for c in self.core.handle(self.now, ev) {
                match c {
                    host::Command::RequestPlan { mission, epoch, kind, request, .. } => {
                        self.last_plan = Some((mission.to_string(), epoch));
                        let result = planner_service::plan(kind, &request)
                            .inspect(|p| {
                                if self.plans.len() < 4 {
                                    self.plans.push(p.clone());
                                }
                            })
                            .map(Box::new)
                            .map_err(mrmm_core::Failure::fatal);
                        queue.push_back(host::Event::Planned { mission, epoch, result });
                    }
                    host::Command::SendPlan { mission, robot, assignment } => {
                        if self.assignments.len() < 8 {
                            self.assignments.push((*assignment).clone());
                        }
                        queue.push_back(host::Event::PlanDelivered { mission, robot, epoch: assignment.epoch, result: Ok(()) })
                    }
                    host::Command::Chain { envelope, .. } if self.sent.len() < 16 => self.sent.push(*envelope),
                    _ => {}
                }
            }
        }
    }
}

/// The fleet the seal target checks against: a CA and a robot certificate made once by the `seeds`
/// program (kept in `fuzz/fixture/`, test keys only), and the instant the seeds were sealed at.
pub struct SealFixture {
    pub verifier: mrmm_net::security::seal::Verifier,
    pub now_ms: u64,
    /// The key the seeds were sealed for.
    pub key: String,
}

/// Where the fixture PKI lives.
pub fn fixture_dir() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fixture")
}

/// The seal fixture, loaded once.
pub fn seal_fixture() -> &'static SealFixture {
    static F: std::sync::OnceLock<SealFixture> = std::sync::OnceLock::new();
    F.get_or_init(|| {
        let dir = fixture_dir();
        let ca = mrmm_net::security::pki::read_ca_der(&dir).unwrap_or_else(|e| panic!("run the seeds program first: {e}"));
        // r1's own verifier, with its pair keys: seals tagged for r1 take the tag path.
        let me = mrmm_net::security::Identity::load("security", &mrmm_proto::security::SecuritySection::from_dir(&dir, "r1"))
            .unwrap_or_else(|e| panic!("fixture identity: {e}"));
        let pairs = std::sync::Arc::new(mrmm_net::security::pair::Pairs::new(me.pair_secret()));
        let verifier = mrmm_net::security::seal::Verifier::secure(&ca, 60).unwrap_or_else(|e| panic!("fixture CA: {e}")).with_pairs(pairs);
        let now_ms = std::fs::read_to_string(dir.join("now_ms")).ok().and_then(|s| s.trim().parse().ok()).unwrap_or_else(|| panic!("fixture now_ms missing"));
        SealFixture { verifier, now_ms, key: mrmm_proto::Key::RobotTelemetry("r1".into()).to_string() }
    })
}

/// Central set up once per fuzzing process (setting it up plans a patrol): each input starts from
/// a copy.
pub fn central() -> Central {
    static BASE: std::sync::OnceLock<Central> = std::sync::OnceLock::new();
    BASE.get_or_init(Central::new).clone()
}

/// The leading and the following host, set up once per fuzzing process.
pub fn hosts() -> (Host, Host) {
    static BASE: std::sync::OnceLock<(Host, Host)> = std::sync::OnceLock::new();
    BASE.get_or_init(|| {
        let mut head = Host::new("central");
        head.start_patrol(2);
        let mut follower = Host::new("r2");
        follower.feed(host::Event::LocalTeam(vec![("p".into(), vec!["central".into(), "r1".into(), "r2".into()])]));
        (head, follower)
    })
    .clone()
}
