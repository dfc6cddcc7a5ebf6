//! Robots' machines and the traffic authority together, closed loop: every report a robot makes
//! goes to the authority, every order back to its robot, as the drivers carry them. The robots
//! drive plans of random vertices of a real floor plan (Open-RMF's office graph); their bodies'
//! positions are measured every step, never the machines' bookkeeping. The authority is replaced
//! by a new incarnation in the middle of a run (central killed and restarted), and robots go on;
//! or central is killed for good, and the robots' deputies take over. Orders reach robots
//! through the robot's own ingress (the policy: a robot's orders count only from a deputy, with
//! central away), and reports and orders are lost at random where a test says so.

use crate::at;
use std::sync::Arc;

use mrmm_maps::{Map, NavGraph};
use mrmm_proto::{BarrierMode, MapRef, PlanAssignment, Pose, RobotCommand, RobotPlan, Role, Sender, Step, Time};

use super::authority::{self, Authority};
use super::deputy::{self, Deputy};
use super::CLEARANCE;
use crate::body::Limits;
use crate::robot::{self, Robot, RobotSetup};

const STEP: f64 = 0.02;

/// A small deterministic generator (xorshift): the seeds named below are its.
struct Rng(u64);
impl Rng {
    fn below(&mut self, n: usize) -> usize {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 % n as u64) as usize
    }
}

fn office() -> NavGraph {
    let (name, text) = mrmm_maps::data::OPEN_RMF[0];
    mrmm_maps::rmf::parse(name, text).expect("office graph")
}

/// Robot `id`'s plan of `steps` in `mission` (a team of its own) on `map`.
fn assignment(id: &str, mission: &str, epoch: u64, steps: Vec<Step>, map: &MapRef) -> PlanAssignment {
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
fn give(r: &mut Robot, now: Time, a: PlanAssignment) {
    let out = r.handle(now, robot::Event::Command { cmd: RobotCommand::Plan(Box::new(a)), from: Sender::new(Role::Central, "central") });
    assert!(out.iter().any(|c| matches!(c, robot::Command::Reply(Ok(_)))), "plan refused: {out:?}");
}

struct Fleet {
    graph: Arc<Map>,
    map: MapRef,
    authority: Authority,
    robots: Vec<Robot>,
    now: Time,
    closest: (f64, Time, String),
    /// Whether orders reach the robots (false: the authority is down).
    up: bool,
    /// Robots drive on without grants (to show the test fails then).
    ignore_grants: bool,
    /// Each robot's deputy (it acts only when named in the orders).
    deputies: Vec<Deputy>,
    /// Robots crashed: they stand where they are, say and hear nothing.
    crashed: Vec<bool>,
    /// Percent of reports and orders lost on the way.
    loss: usize,
    rng: Rng,
    /// Orders given by deputies, with when (the first after a kill: grants resumed).
    deputy_orders: Vec<(Time, usize)>,
}

impl Fleet {
    /// `n` robots at distinct vertices, each with a plan looping over `goals` random vertices.
    fn new(seed: u64, n: usize, goals: usize) -> Fleet {
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
    fn with(g: NavGraph, plans: Vec<(usize, Vec<usize>, bool)>, seed: u64) -> Fleet {
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
    fn through(&mut self) -> bool {
        self.loss == 0 || self.rng.below(100) >= self.loss
    }

    /// Orders of central (`from` none) or of robot `from`'s deputy: to their robots through each
    /// robot's own ingress, and to every deputy that follows.
    fn deliver(&mut self, cmds: Vec<authority::Command>, from: Option<usize>) {
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
    fn kill_central(&mut self) {
        self.up = false;
        for r in &mut self.robots {
            r.handle(self.now, robot::Event::CentralAlive(false));
        }
        for d in &mut self.deputies {
            d.handle(self.now, deputy::Event::Central(false));
        }
    }

    /// The robot whose deputy gives the orders now, if one does.
    fn active_deputy(&self) -> Option<usize> {
        (0..self.deputies.len()).find(|&d| !self.crashed[d] && self.deputies[d].active())
    }

    fn step(&mut self) {
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

    fn run(&mut self, seconds: f64) {
        let end = self.now + seconds;
        while self.now < end {
            self.step();
        }
    }

    fn deputy_out(&mut self, d: usize, out: Vec<deputy::Command>) {
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
    fn progress(&self) -> u64 {
        self.progress_of(|_| true)
    }

    /// Goals reached by the robots `which` picks by index.
    fn progress_of(&self, which: impl Fn(usize) -> bool) -> u64 {
        let of = |e: &crate::robot::executor::Executor| u64::from(e.progress().step) + 100 * u64::from(e.progress().round);
        self.robots.iter().enumerate().filter(|(i, _)| which(*i)).filter_map(|(_, r)| r.executor()).map(of).sum()
    }

    /// Central killed and started again: a new authority, which hears the robots after `down`
    /// seconds.
    fn restart_authority(&mut self, down: f64, heard_late: bool) {
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

/// Every other seed, the new authority first hears the robots after its rebuild (their sessions
/// link again slowly): seed 6 found robots 0.01 m apart when it granted the first robot heard
/// before the others had said where they stand. A seed whose robots make no progress after the
/// restart is a gridlock that no single step aside breaks (seed 18: four robots waiting in a
/// cycle while two others step aside and back for ever) — counted, at most one in twenty.
#[test]
fn robots_of_two_missions_on_a_floor_plan_never_come_closer_than_the_clearance() {
    let mut stalled = Vec::new();
    for seed in 1..=20 {
        let mut f = Fleet::new(seed, 6, 6);
        f.run(150.0);
        let before = f.progress();
        assert!(f.closest.0 >= CLEARANCE - 0.05, "seed {seed}: {} were {:.2} m apart at {:.1} s", f.closest.2, f.closest.0, f.closest.1);
        assert!(before > 0, "seed {seed}: no robot reached a goal");
        // Central killed and back: robots stop at their grants' ends, then go on.
        f.restart_authority(5.0, seed.is_multiple_of(2));
        f.run(100.0);
        assert!(f.closest.0 >= CLEARANCE - 0.05, "seed {seed} after the restart: {} were {:.2} m apart at {:.1} s", f.closest.2, f.closest.0, f.closest.1);
        println!("seed {seed}: closest {:.2} m ({}), progress {before} then {}", f.closest.0, f.closest.2, f.progress());
        if f.progress() == before {
            stalled.push(seed);
        }
    }
    assert!(stalled.len() <= 1, "no robot went on after the authority's restart in seeds {stalled:?}");
}

/// Central killed for good while robots of two missions drive, 3 % of reports and orders lost on
/// the way: the first deputy the authority named takes over and grants resume within 2 s; then
/// that deputy's robot crashes (it stands where it is) and the second deputy takes over within
/// 2 s too. Never closer than the clearance — the crashed robot included.
#[test]
fn central_killed_for_good_its_deputies_take_over_in_turn() {
    let mut stalled = Vec::new();
    for seed in 1..=20 {
        let mut f = Fleet::new(seed, 6, 6);
        f.loss = 3;
        f.run(60.0);
        f.kill_central();
        let (killed, before) = (f.now, f.progress());
        f.run(40.0);
        let first = f.deputy_orders.first().copied();
        let Some((t, d)) = first else { panic!("seed {seed}: no deputy took over") };
        assert!(t - killed <= 2.0, "seed {seed}: the first deputy's orders came {:.2} s after central died", t - killed);
        assert!(f.closest.0 >= CLEARANCE - 0.05, "seed {seed}, deputy: {} were {:.2} m apart at {:.1} s", f.closest.2, f.closest.0, f.closest.1);
        if f.progress() == before {
            stalled.push(seed);
        }
        // The acting deputy's robot crashes: the next takes over.
        let acting = f.active_deputy().unwrap_or(d);
        f.crashed[acting] = true;
        let crashed = f.now;
        f.run(40.0);
        let next = f.deputy_orders.iter().find(|(t, d)| *t > crashed && *d != acting).copied();
        let Some((t2, d2)) = next else { panic!("seed {seed}: no deputy took over from {}", f.robots[acting].id()) };
        assert!(t2 - crashed <= 2.0, "seed {seed}: {}'s orders came {:.2} s after {} crashed", f.robots[d2].id(), t2 - crashed, f.robots[acting].id());
        assert!(f.closest.0 >= CLEARANCE - 0.05, "seed {seed}, second deputy: {} were {:.2} m apart at {:.1} s", f.closest.2, f.closest.0, f.closest.1);
        println!(
            "seed {seed}: {} took over {:.2} s after central, {} {:.2} s after it; closest {:.2} m",
            f.robots[d].id(),
            t - killed,
            f.robots[d2].id(),
            t2 - crashed,
            f.closest.0
        );
    }
    assert!(stalled.len() <= 1, "no robot went on under a deputy in seeds {stalled:?}");
}

/// The takeover test above can fail: robots that drive on whatever was granted meet, under a
/// deputy too.
#[test]
fn robots_driving_on_without_grants_under_a_deputy_meet() {
    let met = (1..=6).any(|seed| {
        let mut f = Fleet::new(seed, 6, 6);
        f.run(30.0);
        f.kill_central();
        f.ignore_grants = true;
        f.run(120.0);
        f.closest.0 < CLEARANCE - 0.05
    });
    assert!(met, "robots ignoring their deputy's grants never met: the takeover test could not fail");
}

/// A robot's order counts only from a deputy its authority named, and only with central away:
/// central up, a deputy's order is refused; a robot never named is refused either way.
#[test]
fn a_robots_order_counts_only_from_a_named_deputy_with_central_away() {
    let mut f = Fleet::new(4, 6, 6);
    f.run(10.0);
    let r = &f.robots[0];
    let named: Vec<String> = r.traffic().map(|g| g.deputies().iter().map(|d| d.to_string()).collect()).unwrap_or_default();
    assert_eq!(named.len(), mrmm_proto::traffic::DEPUTIES, "the orders name no deputies");
    let stranger = f.robots.iter().map(|r| r.id().to_string()).find(|id| !named.contains(id)).expect("a robot not named");
    let order = mrmm_proto::TrafficOrder::Free;
    let key = mrmm_proto::Key::TrafficOrder { map: f.map.hash.clone(), robot: r.id().into() }.to_string();
    let payload = serde_json::to_vec(&order).expect("json");
    let from = |id: &str| Sender::new(Role::Robot, id);
    let try_from = |f: &Fleet, id: &str| f.robots[0].ingress(robot::Incoming { key: &key, payload: &payload, put: true, from: Some(&from(id)) }).is_ok();
    assert!(!try_from(&f, &named[0]), "a deputy's order taken while central is up");
    f.kill_central();
    assert!(try_from(&f, &named[0]), "the deputy's order refused with central away");
    assert!(!try_from(&f, &stranger), "an order of {stranger}, never named, taken");
}

/// The test above can fail: robots that drive their whole route whatever was granted meet.
#[test]
fn robots_driving_without_grants_meet() {
    let met = (1..=6).any(|seed| {
        let mut f = Fleet::new(seed, 6, 6);
        f.ignore_grants = true;
        f.run(150.0);
        f.closest.0 < CLEARANCE - 0.05
    });
    assert!(met, "robots ignoring their grants never met: the clearance test could not fail");
}

/// An operator's goto to a robot on the map (after its plan, or the robot let go) is driven along
/// the lanes traffic grants too, not straight through the others.
#[test]
fn an_operators_goto_on_the_map_goes_through_traffic() {
    let mut f = Fleet::new(3, 6, 6);
    f.run(30.0);
    // The vertex farthest from the other robots, which hold where they are.
    let g = office();
    let others: Vec<mrmm_maps::Point> = f.robots[1..].iter().map(|r| mrmm_maps::Point::new(r.pose().x, r.pose().y)).collect();
    let far = |v: &mrmm_maps::graph::Vertex| others.iter().map(|o| o.dist(v.at)).fold(f64::INFINITY, f64::min);
    let target = g.vertices.iter().max_by(|a, b| far(a).total_cmp(&far(b))).map(|v| v.at).expect("vertices");
    for r in &mut f.robots {
        let cmd = if r.id() == "r0" { RobotCommand::Goto { x: target.x, y: target.y, via: vec![], map: None } } else { RobotCommand::Hold };
        let out = r.handle(f.now, robot::Event::Command { cmd, from: Sender::new(Role::Central, "central") });
        assert!(out.iter().any(|c| matches!(c, robot::Command::Reply(Ok(_)))), "{out:?}");
    }
    f.run(60.0);
    let p = f.robots[0].pose();
    assert!((p.x - target.x).hypot(p.y - target.y) < 0.2, "r0 at ({:.2}, {:.2}), not at its goto ({:.2}, {:.2})", p.x, p.y, target.x, target.y);
    assert!(f.closest.0 >= CLEARANCE - 0.05, "{} were {:.2} m apart at {:.1} s", f.closest.2, f.closest.0, f.closest.1);
    // Traffic knew where it went: it holds the goto's vertex (driven straight, it would not).
    let (v, _) = g.nearest(target);
    let held = f.authority.traffic(&f.map.hash).and_then(|t| t.state(&"r0".into())).map(|(route, reached, ..)| reached.map(|p| route[p]));
    assert_eq!(held, Some(Some(v)), "traffic does not hold r0 at its goto's vertex");
}

/// The time a plan waits for traffic is counted in the robot's progress (what the mission's
/// metrics sum): robots sharing the office wait some of the time, never more than all of it; a
/// robot alone on the map waits far less than they do.
#[test]
fn the_time_plans_wait_for_traffic_is_counted() {
    let waits = |f: &Fleet| -> Vec<f64> { f.robots.iter().filter_map(|r| r.executor()).map(|e| e.progress().traffic_wait_s).collect() };
    let mut crowd = Fleet::new(2, 6, 6);
    crowd.run(60.0);
    let w = waits(&crowd);
    assert!(w.iter().all(|&s| (0.0..=60.0).contains(&s)), "{w:?}");
    let crowd_mean = w.iter().sum::<f64>() / w.len() as f64;
    let mut alone = Fleet::new(2, 1, 6);
    alone.run(60.0);
    let alone_w = waits(&alone)[0];
    println!("waited for traffic in 60 s: {crowd_mean:.1} s per robot of six, {alone_w:.1} s alone");
    assert!(crowd_mean > 0.0 && alone_w < crowd_mean, "six robots wait {crowd_mean:.1} s each, one alone {alone_w:.1} s");
}

/// The case: two robots of two missions meet head-on in a corridor with a pocket and
/// wait for each other while central dies; the first deputy takes over and both arrive, never
/// closer than the clearance. Corridor 0 – 1 – 2 – 3 – 4, 2 m a lane, pocket 5 off vertex 2.
#[test]
fn central_dies_while_two_robots_wait_for_each_other_in_a_corridor_and_both_arrive() {
    let points = [(0.0, 0.0), (2.0, 0.0), (4.0, 0.0), (6.0, 0.0), (8.0, 0.0), (4.0, 2.0)];
    let vertices = points
        .iter()
        .enumerate()
        .map(|(i, &(x, y))| mrmm_maps::graph::Vertex { charger: false, name: format!("v{i}"), at: mrmm_maps::Point::new(x, y) })
        .collect();
    let mut edges = Vec::new();
    for (a, b) in [(0u32, 1u32), (1, 2), (2, 3), (3, 4), (2, 5)] {
        edges.push(mrmm_maps::graph::Edge { from: a, to: b, length: 2.0 });
        edges.push(mrmm_maps::graph::Edge { from: b, to: a, length: 2.0 });
    }
    let g = NavGraph { vertices, edges };
    let mut f = Fleet::with(g, vec![(0, vec![4], false), (4, vec![0], false)], 1);
    // Until they stand waiting for each other (one of them may already be stepping aside).
    let waiting = |f: &Fleet| {
        let t = f.authority.traffic(&f.map.hash).expect("traffic");
        t.views(f.now).iter().filter(|r| r.waiting_s.is_some()).count()
    };
    while waiting(&f) == 0 && f.now < at(20.0) {
        f.step();
    }
    assert!(waiting(&f) > 0, "the robots never waited for each other");
    f.kill_central();
    let killed = f.now;
    f.run(60.0);
    let first = f.deputy_orders.first().map(|(t, _)| *t - killed);
    assert!(first.is_some_and(|t| t <= 2.0), "the deputy's first orders came {first:?} s after central died");
    for (r, goal) in [(0, (8.0, 0.0)), (1, (0.0, 0.0))] {
        let p = f.robots[r].pose();
        assert!((p.x - goal.0).hypot(p.y - goal.1) < 0.2, "{} at ({:.2}, {:.2}), not at its goal {goal:?}", f.robots[r].id(), p.x, p.y);
    }
    assert!(f.closest.0 >= CLEARANCE - 0.05, "{} were {:.2} m apart at {:.1} s", f.closest.2, f.closest.0, f.closest.1);
    println!("deputy's orders {:.2} s after central died; both arrived; closest {:.2} m", first.unwrap_or(0.0), f.closest.0);
}

/// A mission paused while robots of two missions drive the office (its robots given the hold
/// plan, as its manager pauses it): each of its robots stops at the end of the lane it drives and
/// gives back what it was granted beyond (5 s on it stands within a lane of where it was) while
/// the other mission's robots go on (a paused robot parked in their way steps aside); resumed,
/// they go on too. Never closer than the clearance. (Before, a paused robot drove on toward its
/// last goal as far as traffic granted, and traffic went on granting it.)
#[test]
fn a_paused_missions_robots_stop_where_they_are_and_the_others_go_on() {
    for seed in 1..=10 {
        let mut f = Fleet::new(seed, 6, 6);
        f.run(30.0);
        let even = |i: usize| i.is_multiple_of(2);
        let paused: Vec<usize> = (0..f.robots.len()).filter(|&i| even(i)).collect();
        let plans: Vec<PlanAssignment> = paused.iter().map(|&i| f.robots[i].executor().expect("a plan").assignment().clone()).collect();
        let at: Vec<Pose> = paused.iter().map(|&i| f.robots[i].pose()).collect();
        for &i in &paused {
            let id = f.robots[i].id().to_string();
            let hold = assignment(&id, "even", 2, vec![Step::Stream, Step::Hold { seconds: None }], &f.map);
            give(&mut f.robots[i], f.now, hold);
        }
        let others = f.progress_of(|i| !even(i));
        f.run(5.0);
        let traffic = f.authority.traffic(&f.map.hash).expect("traffic");
        for (k, &i) in paused.iter().enumerate() {
            let (id, p) = (f.robots[i].id(), f.robots[i].pose());
            let moved = (p.x - at[k].x).hypot(p.y - at[k].y);
            assert!(moved <= authority::SEGMENT_M + 0.2, "seed {seed}: paused {id} drove {moved:.2} m on: {}", traffic.describe(&id.into()));
        }
        f.run(60.0);
        assert!(f.progress_of(|i| !even(i)) > others, "seed {seed}: the other mission stood still while this one was paused");
        for (k, &i) in paused.iter().enumerate() {
            let mut resumed = plans[k].clone();
            resumed.epoch = 3;
            give(&mut f.robots[i], f.now, resumed);
        }
        f.run(60.0);
        assert!(f.progress_of(even) > 0, "seed {seed}: the resumed mission's robots did not go on");
        assert!(f.closest.0 >= CLEARANCE - 0.05, "seed {seed}: {} were {:.2} m apart at {:.1} s", f.closest.2, f.closest.0, f.closest.1);
        println!("seed {seed}: closest {:.2} m; the other mission {others} → {}", f.closest.0, f.progress_of(|i| !even(i)));
    }
}

/// Two robots in one direction down a corridor, the second following the first: the robot ahead
/// reports as it passes the point where the vertex behind it may be let go
/// ([`mrmm_proto::traffic::RouteVertex::release`]), so traffic lets go of it within a step or
/// two of the robot being clear of it, not at the robot's next periodic report (up to
/// [`mrmm_proto::traffic::REPORT_S`] later), and the robot following closes up at once.
#[test]
fn the_robot_ahead_reports_as_it_passes_the_release_point_and_the_vertex_behind_goes_at_once() {
    let vertices =
        (0..8).map(|i| mrmm_maps::graph::Vertex { charger: false, name: format!("v{i}"), at: mrmm_maps::Point::new(1.4 * f64::from(i), 0.0) }).collect();
    // Lanes shorter than the authority's segments: not cut.
    let mut edges = Vec::new();
    for a in 0u32..7 {
        edges.push(mrmm_maps::graph::Edge { from: a, to: a + 1, length: 1.4 });
        edges.push(mrmm_maps::graph::Edge { from: a + 1, to: a, length: 1.4 });
    }
    let mut f = Fleet::with(NavGraph { vertices, edges }, vec![(1, vec![7], false), (0, vec![6], false)], 1);
    let leader = mrmm_proto::RobotId::from("r0");
    // The vertex behind the leader, since when the leader is clear of it, and whether traffic
    // let go of it since.
    let mut behind: Option<(u32, Option<Time>, bool)> = None;
    let mut delays = Vec::new();
    while f.now < at(30.0) {
        f.step();
        let t = f.authority.traffic(&f.map.hash).expect("traffic");
        let Some((route, Some(p), _, _)) = t.state(&leader) else { continue };
        let Some(&next) = route.get(p + 1) else { continue };
        let (u, pose) = (route[p], f.robots[0].pose());
        if let Some((v, Some(since), false)) = behind.filter(|b| b.0 != u) {
            delays.push((v, f.now - since)); // reached the next vertex still holding it
        }
        let b = behind.get_or_insert((u, None, false));
        if b.0 != u {
            *b = (u, None, false);
        }
        if b.1.is_none() && t.layout().clear_of(u, next, mrmm_maps::Point::new(pose.x, pose.y)) {
            b.1 = Some(f.now);
        }
        if let (Some(since), false) = (b.1, b.2) {
            if !t.held(&leader).contains(&u) {
                delays.push((u, f.now - since));
                b.2 = true;
            }
        }
    }
    assert!(delays.len() >= 5, "the leader let go of {} vertices: {delays:?}", delays.len());
    let worst = delays.iter().map(|d| d.1).fold(0.0, f64::max);
    assert!(worst <= 2.0 * STEP + 1e-9, "the vertex behind the leader went up to {worst:.2} s after it was clear of it: {delays:?}");
    assert!(f.closest.0 >= CLEARANCE - 0.05, "{} were {:.2} m apart at {:.1} s", f.closest.2, f.closest.0, f.closest.1);
    println!("vertices let go after {delays:?} s; closest {:.2} m", f.closest.0);
}
