//! What one event costs the traffic authority as robots share one map: N robots on a warehouse
//! floor (a 30 × 30 grid of lanes 2 m apart, which the authority cuts into segments as it cuts
//! every map's lanes) drive plans of random vertices, closed loop — every report of a robot's
//! machine goes to the authority and every order back, as the drivers carry them — for 60
//! simulated seconds, the authority ticked every 50 ms. Only the authority's `handle` is timed:
//! mean and worst µs per event (reports and ticks), and a tick's mean, for N = 50, 100, 200.
//!
//! `cargo bench -p mrmm-core --bench traffic`

use std::sync::Arc;
use std::time::{Duration, Instant};

use mrmm_core::body::Limits;
use mrmm_core::robot::{self, Robot, RobotSetup};
use mrmm_core::traffic::authority::{self, Authority};
use mrmm_maps::graph::{Edge, Vertex};
use mrmm_maps::{Map, NavGraph, Point};
use mrmm_proto::{BarrierMode, MapRef, PlanAssignment, Pose, RobotCommand, RobotPlan, Role, Sender, Step, Time};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const SIDE: u32 = 30;
const SPACING: f64 = 2.0;
const STEP: f64 = 0.05;

fn warehouse() -> NavGraph {
    let at = |i: u32, j: u32| Point::new(f64::from(i) * SPACING, f64::from(j) * SPACING);
    let vertices = (0..SIDE * SIDE).map(|k| Vertex { charger: false, name: format!("v{k}"), at: at(k % SIDE, k / SIDE) }).collect();
    let mut edges = Vec::new();
    for j in 0..SIDE {
        for i in 0..SIDE {
            let k = j * SIDE + i;
            for (n, ok) in [(k + 1, i + 1 < SIDE), (k + SIDE, j + 1 < SIDE)] {
                if ok {
                    edges.push(Edge { from: k, to: n, length: SPACING, passing: false });
                    edges.push(Edge { from: n, to: k, length: SPACING, passing: false });
                }
            }
        }
    }
    NavGraph { vertices, edges }
}

fn run(n: usize) -> (u64, Duration, Duration, f64) {
    let g = warehouse();
    let map = MapRef { name: "warehouse".into(), hash: "b".repeat(64) };
    let mut auth = Authority::new(Time::from_secs(-10.0), 1, [(map.hash.clone(), Arc::new(Map::Graph(g.clone())))]);
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mut used = std::collections::BTreeSet::new();
    let mut robots: Vec<Robot> = (0..n)
        .map(|i| {
            let start = loop {
                let v = rng.gen_range(0..SIDE * SIDE);
                if used.insert(v) {
                    break v;
                }
            };
            let id = format!("r{i}");
            let p = g.vertices[start as usize].at;
            let mut r = Robot::new(RobotSetup::sim(&id, "ground", Limits { max_speed: 1.0, max_turn_rate: 2.0 }, Pose { x: p.x, y: p.y, theta: 0.0 }));
            let mut steps: Vec<Step> = (0..8)
                .map(|_| {
                    let q = g.vertices[rng.gen_range(0..SIDE * SIDE) as usize].at;
                    Step::Navigate { x: q.x, y: q.y, speed: None }
                })
                .collect();
            steps.push(Step::Loop { to: 0, rounds: None });
            let a = PlanAssignment {
                handover: None,
                mission: "m".into(),
                epoch: 1,
                team: "m".into(),
                subteam: "m/ground".into(),
                members: vec![id.clone().into()],
                plan: RobotPlan { robot: id.clone().into(), robot_type: "ground".into(), slot: 0, steps, team: String::new() },
                managers: vec![],
                barrier: BarrierMode::Mesh,
                scopes: vec![],
                map: Some(map.clone()),
            };
            r.handle(Time::ZERO, robot::Event::Command { cmd: RobotCommand::Plan(Box::new(a)), from: Sender::new(Role::Central, "central") });
            r
        })
        .collect();
    let (mut events, mut total, mut worst) = (0u64, Duration::ZERO, Duration::ZERO);
    let mut ticks = (0u64, Duration::ZERO);
    let mut now = Time::ZERO;
    while now < Time::from_secs(60.0) {
        now += STEP;
        let mut heard = Vec::new();
        for r in &mut robots {
            for c in r.handle(now, robot::Event::Tick) {
                if let robot::Command::TrafficReport { map, report } = c {
                    heard.push(authority::Event::Report { map, report });
                }
            }
        }
        heard.push(authority::Event::Tick);
        for ev in heard {
            let tick = ev == authority::Event::Tick;
            let t = Instant::now();
            let out = auth.handle(now, ev);
            let dt = t.elapsed();
            if tick {
                ticks.0 += 1;
                ticks.1 += dt;
            }
            (events, total, worst) = (events + 1, total + dt, worst.max(dt));
            for c in out {
                if let authority::Command::Order { map, robot, order } = c {
                    if let Some(r) = robots.iter_mut().find(|r| r.id() == robot.as_str()) {
                        r.handle(now, robot::Event::Traffic { map, order, deputy: false });
                    }
                }
            }
        }
    }
    (events, total, worst, ticks.1.as_secs_f64() * 1e6 / ticks.0.max(1) as f64)
}

fn main() {
    println!("robots  events  mean µs/event  worst µs  mean µs/tick");
    for n in [50, 100, 200] {
        let (events, total, worst, tick) = run(n);
        println!("{n:>6}  {events:>6}  {:>13.1}  {:>8.0}  {tick:>12.1}", total.as_secs_f64() * 1e6 / events as f64, worst.as_secs_f64() * 1e6);
    }
}
