//! The closed loop the tests drive: a fleet of robots' machines, their bodies and deputies, and
//! the traffic authority, with the orders and reports between them carried (or lost) as the
//! drivers carry them.

use crate::at;
use std::sync::Arc;

use mrmm_maps::{Map, NavGraph};
use mrmm_proto::{BarrierMode, MapRef, PlanAssignment, Pose, RobotCommand, RobotPlan, Role, Sender, Step, Time};

use crate::body::Limits;
use crate::robot::{self, Robot, RobotSetup};
use crate::traffic::authority::{self, Authority};
use crate::traffic::deputy::{self, Deputy};
use crate::traffic::CLEARANCE;

pub(super) const STEP: f64 = 0.02;

/// A small deterministic generator (xorshift): the seeds named below are its.
pub(super) struct Rng(pub(super) u64);
impl Rng {
    pub(super) fn below(&mut self, n: usize) -> usize {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 % n as u64) as usize
    }
}

pub(super) fn office() -> NavGraph {
    let (name, text) = mrmm_maps::data::OPEN_RMF[0];
    mrmm_maps::rmf::parse(name, text).expect("office graph")
}

/// Robot `id`'s plan of `steps` in `mission` (a team of its own) on `map`.
pub(super) fn assignment(id: &str, mission: &str, epoch: u64, steps: Vec<Step>, map: &MapRef) -> PlanAssignment {
    PlanAssignment {
        handover: None,
        mission: mission.into(),
        epoch,
        team: mission.into(),
        subteam: format!("{mission}/ground"),
        members: vec![id.into()],
        plan: RobotPlan { robot: id.into(), robot_type: "ground".into(), slot: 0, steps, team: String::new() },
        managers: vec![],
        barrier: BarrierMode::Mesh,
        scopes: vec![],
        map: Some(map.clone()),
    }
}

/// Central gives robot `r` plan `a` at `now`.
pub(super) fn give(r: &mut Robot, now: Time, a: PlanAssignment) {
    let out = r.handle(now, robot::Event::Command { cmd: RobotCommand::Plan(Box::new(a)), from: Sender::new(Role::Central, "central") });
    assert!(out.iter().any(|c| matches!(c, robot::Command::Reply(Ok(_)))), "plan refused: {out:?}");
}

pub(super) struct Fleet {
    pub(super) graph: Arc<Map>,
    pub(super) map: MapRef,
    pub(super) authority: Authority,
    pub(super) robots: Vec<Robot>,
    pub(super) now: Time,
    pub(super) closest: (f64, Time, String),
    /// Whether orders reach the robots (false: the authority is down).
    pub(super) up: bool,
    /// Robots drive on without grants (to show the test fails then).
    pub(super) ignore_grants: bool,
    /// Each robot's deputy (it acts only when named in the orders).
    pub(super) deputies: Vec<Deputy>,
    /// Robots crashed: they stand where they are, say and hear nothing.
    pub(super) crashed: Vec<bool>,
    /// Percent of reports and orders lost on the way.
    pub(super) loss: usize,
    pub(super) rng: Rng,
    /// Orders given by deputies, with when (the first after a kill: grants resumed).
    pub(super) deputy_orders: Vec<(Time, usize)>,
}

impl Fleet {
    /// `n` robots at distinct vertices, each with a plan looping over `goals` random vertices.
    pub(super) fn new(seed: u64, n: usize, goals: usize) -> Fleet {
        let g = office();
        let mut rng = Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1);
        let mut starts: Vec<usize> = Vec::new();
        while starts.len() < n {
            let v = rng.below(g.vertices.len());
            let p = g.vertices[v].at;
            if starts.iter().all(|&s| g.vertices[s].at.dist(p) > 2.0 * CLEARANCE) {
                starts.push(v);
            }
        }
        let plans = starts.iter().map(|&s| (s, (0..goals).map(|_| rng.below(g.vertices.len())).collect(), true)).collect();
        Fleet::with(g, plans, seed)
    }

    /// Robots on graph `g`, each at vertex `start` with a plan of its `goals` (vertices), looped
    /// or not.
    pub(super) fn with(g: NavGraph, plans: Vec<(usize, Vec<usize>, bool)>, seed: u64) -> Fleet {
        let map = MapRef { name: "office".into(), hash: "a".repeat(64) };
        let graph = Arc::new(Map::Graph(g.clone()));
        let authority = Authority::new(at(0.0), 1, [(map.hash.clone(), graph.clone())]);
        let robots: Vec<Robot> = plans
            .iter()
            .enumerate()
            .map(|(i, (s, goals, looped))| {
                let id = format!("r{i}");
                let start = g.vertices[*s].at;
                let mut r =
                    Robot::new(RobotSetup::sim(&id, "ground", Limits { max_speed: 1.0, max_turn_rate: 2.0 }, Pose { x: start.x, y: start.y, theta: 0.0 }));
                let mut steps: Vec<Step> = goals
                    .iter()
                    .map(|&v| {
                        let p = g.vertices[v].at;
                        Step::Navigate { x: p.x, y: p.y, speed: None }
                    })
                    .collect();
                if *looped {
                    steps.push(Step::Loop { to: 0, rounds: None });
                }
                let mission = if i % 2 == 0 { "even" } else { "odd" };
                let a = assignment(&id, mission, 1, steps, &map);
                r.handle(at(0.0), robot::Event::CentralAlive(true));
                give(&mut r, at(0.0), a);
                r
            })
            .collect();
        let deputies = robots.iter().map(|r| Deputy::new(at(0.0), r.id().into(), map.hash.clone(), graph.clone(), true)).collect();
        let crashed = vec![false; robots.len()];
        Fleet {
            graph,
            map,
            authority,
            robots,
            now: at(0.0),
            closest: (f64::INFINITY, Time::ZERO, String::new()),
            up: true,
            ignore_grants: false,
            deputies,
            crashed,
            loss: 0,
            rng: Rng(seed | 1),
            deputy_orders: Vec::new(),
        }
    }

    /// Whether a message gets through.
    pub(super) fn through(&mut self) -> bool {
        self.loss == 0 || self.rng.below(100) >= self.loss
    }

    /// Orders of central (`from` none) or of robot `from`'s deputy: to their robots through each
    /// robot's own ingress, and to every deputy that follows.
    pub(super) fn deliver(&mut self, cmds: Vec<authority::Command>, from: Option<usize>) {
        let sender = match from {
            None => Sender::new(Role::Central, "central"),
            Some(i) => Sender::new(Role::Robot, self.robots[i].id()),
        };
        for c in cmds {
            let authority::Command::Order { map, robot, order } = c else { continue };
            let mut order = order;
            if self.ignore_grants {
                if let mrmm_proto::TrafficOrder::Route { route, upto, .. } = &mut order {
                    *upto = Some(route.len() as u32 - 1);
                }
            }
            if let Some(d) = from {
                self.deputy_orders.push((self.now, d));
            }
            for d in 0..self.deputies.len() {
                if Some(d) != from && !self.crashed[d] && self.through() {
                    self.deputies[d].handle(self.now, deputy::Event::Order { robot: robot.clone(), order: order.clone() });
                }
            }
            let Some(i) = self.robots.iter().position(|r| r.id() == robot.as_str()) else { continue };
            if self.crashed[i] || !self.through() {
                continue;
            }
            let key = mrmm_proto::Key::TrafficOrder { map: map.clone(), robot: robot.clone() }.to_string();
            let payload = serde_json::to_vec(&order).expect("json");
            match self.robots[i].ingress(robot::Incoming { key: &key, payload: &payload, put: true, from: Some(&sender) }) {
                Ok(ev) => {
                    self.robots[i].handle(self.now, ev);
                }
                Err(e) => panic!("{robot} refused an order of {sender}: {e}"),
            }
        }
    }

    /// Central's authority killed for good (its liveliness goes for every robot and deputy).
    pub(super) fn kill_central(&mut self) {
        self.up = false;
        for r in &mut self.robots {
            r.handle(self.now, robot::Event::CentralAlive(false));
        }
        for d in &mut self.deputies {
            d.handle(self.now, deputy::Event::Central(false));
        }
    }

    /// The robot whose deputy gives the orders now, if one does.
    pub(super) fn active_deputy(&self) -> Option<usize> {
        (0..self.deputies.len()).find(|&d| !self.crashed[d] && self.deputies[d].active())
    }

    pub(super) fn step(&mut self) {
        self.now += STEP;
        for i in 0..self.robots.len() {
            if self.crashed[i] {
                continue;
            }
            let out = self.robots[i].handle(self.now, robot::Event::Tick);
            for c in out {
                let robot::Command::TrafficReport { map, report } = c else { continue };
                if self.up && self.through() {
                    let cmds = self.authority.handle(self.now, authority::Event::Report { map, report: report.clone() });
                    self.deliver(cmds, None);
                }
                for d in 0..self.deputies.len() {
                    if self.crashed[d] || !self.through() {
                        continue;
                    }
                    let out = self.deputies[d].handle(self.now, deputy::Event::Report(report.clone()));
                    self.deputy_out(d, out);
                }
            }
        }
        if ((self.now.secs() / STEP).round() as u64).is_multiple_of(5) {
            if self.up {
                let cmds = self.authority.handle(self.now, authority::Event::Tick);
                self.deliver(cmds, None);
            }
            for d in 0..self.deputies.len() {
                if !self.crashed[d] {
                    let out = self.deputies[d].handle(self.now, deputy::Event::Tick);
                    self.deputy_out(d, out);
                }
            }
        }
        for i in 0..self.robots.len() {
            for j in i + 1..self.robots.len() {
                let (a, b) = (self.robots[i].pose(), self.robots[j].pose());
                let d = (a.x - b.x).hypot(a.y - b.y);
                if d < self.closest.0 {
                    self.closest = (d, self.now, format!("{} and {}", self.robots[i].id(), self.robots[j].id()));
                }
            }
        }
    }

    pub(super) fn run(&mut self, seconds: f64) {
        let end = self.now + seconds;
        while self.now < end {
            self.step();
        }
    }

    pub(super) fn deputy_out(&mut self, d: usize, out: Vec<deputy::Command>) {
        let mut cmds = Vec::new();
        for c in out {
            match c {
                deputy::Command::Authority(c) => cmds.push(c),
                deputy::Command::TookOver { incarnation } => println!("{:.2} s: {} took over as {incarnation}", self.now, self.robots[d].id()),
                deputy::Command::SteppedDown { incarnation } => println!("{:.2} s: {} stepped down for {incarnation}", self.now, self.robots[d].id()),
            }
        }
        self.deliver(cmds, Some(d));
    }

    /// Goals reached by all robots (plan steps passed).
    pub(super) fn progress(&self) -> u64 {
        self.progress_of(|_| true)
    }

    /// Goals reached by the robots `which` picks by index.
    pub(super) fn progress_of(&self, which: impl Fn(usize) -> bool) -> u64 {
        let of = |e: &crate::robot::executor::Executor| u64::from(e.progress().step) + 100 * u64::from(e.progress().round);
        self.robots.iter().enumerate().filter(|(i, _)| which(*i)).filter_map(|(_, r)| r.executor()).map(of).sum()
    }

    /// Central killed and started again: a new authority, which hears the robots after `down`
    /// seconds.
    pub(super) fn restart_authority(&mut self, down: f64, heard_late: bool) {
        self.kill_central();
        self.run(down);
        // Robots whose sessions take a while to link again are first heard after the rebuild.
        let started = if heard_late { self.now - authority::REBUILD_S - 0.1 } else { self.now };
        // Central counts incarnations in milliseconds: far above what its deputies took over as.
        self.authority = Authority::new(started, 1_000, [(self.map.hash.clone(), self.graph.clone())]);
        // Their liveliness tokens, as central hears them again.
        for r in &self.robots {
            self.authority.handle(self.now, authority::Event::Alive(r.id().into()));
        }
        self.up = true;
        for r in &mut self.robots {
            r.handle(self.now, robot::Event::CentralAlive(true));
        }
        for d in &mut self.deputies {
            d.handle(self.now, deputy::Event::Central(true));
        }
    }
}
