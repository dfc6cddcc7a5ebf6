//! A seeded, deterministic simulation of robots driving a navigation graph under [`Traffic`]:
//! each robot drives shortest routes between random vertices at its own speed, dwells at each
//! goal, and drives only what it was granted; the run checks, every step, that no two robots on
//! the graph come closer than the clearance (measured on their positions, not on the machine's
//! bookkeeping) and that every robot keeps finishing routes. Without traffic (`controlled:
//! false`) the same robots drive their routes blindly: how often they would meet is the
//! baseline.

use std::collections::BTreeMap;
use std::sync::Arc;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use mrmm_maps::space::GraphSpace;
use mrmm_maps::Point;
use mrmm_proto::{RobotId, Time};

use mrmm_core::traffic::{Command, Event, Layout, Params, Traffic, Why};

pub mod pibt;

/// The simulated world.
#[derive(Debug, Clone, Copy)]
pub struct World {
    pub robots: usize,
    /// Simulated seconds.
    pub duration: f64,
    /// Robots drive under traffic (else blindly: the baseline).
    pub controlled: bool,
    pub params: Params,
    /// Robots' speeds are uniform in this range, m/s.
    pub speed: (f64, f64),
    /// Longest dwell at a goal, seconds.
    pub dwell: f64,
    /// A robot that stands this long wanting to drive is counted as stalled (controlled only),
    /// seconds.
    pub stall: f64,
    /// Step, seconds.
    pub dt: f64,
    /// Keep a trace of every event and command (for replays).
    pub trace: bool,
    /// Count what robots wait for ([`Report::waited_for`]; it costs time per step).
    pub causes: bool,
    /// Robots tell traffic when they are clear of the vertex behind them ([`Event::Left`]), so
    /// that robots following close up: as the fleet's robots do, which report as they pass the
    /// point ([`mrmm_proto::traffic::RouteVertex::release`]).
    pub release: bool,
    /// Robots start and go only to the first this many vertices (the map's own, when its lanes
    /// are cut into segments); none: any vertex.
    pub places: Option<u32>,
}

impl Default for World {
    fn default() -> Self {
        World {
            robots: 8,
            duration: 600.0,
            controlled: true,
            params: Params::default(),
            speed: (0.5, 1.5),
            dwell: 3.0,
            stall: 300.0,
            dt: 0.05,
            trace: false,
            causes: false,
            release: false,
            places: None,
        }
    }
}

/// What a run did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Report {
    pub seed: u64,
    pub robots: usize,
    /// Routes driven to their end.
    pub trips: u64,
    /// Closest two robots on the graph came, metres.
    pub closest: f64,
    /// Times two robots came closer than the clearance.
    pub too_close: u64,
    /// Routes traffic changed (steps aside).
    pub detours: u64,
    /// Blocked reports.
    pub blocked: u64,
    /// Times a robot stood wanting to drive for the world's `stall` seconds (a gridlock
    /// traffic could not break, or a wait that long).
    pub stalled: u64,
    /// Longest a robot went without finishing a route, seconds.
    pub longest_trip: f64,
    /// Seconds robots spent standing for grants, summed.
    pub waited: f64,
    /// Metres driven, summed.
    pub driven: f64,
    /// Events traffic handled.
    pub events: u64,
    /// Every event and command, when the world asks for it.
    pub trace: Vec<String>,
    /// Of `waited`: what the robots stood waiting for (when the world counts it).
    pub waited_for: WaitedFor,
}

/// Seconds robots stood waiting for a grant, by what was in their way (the first that applies,
/// in this order).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct WaitedFor {
    /// A robot parked at the end of its route.
    pub parked: f64,
    /// Robots that stand waiting themselves: a queue, or a gridlock.
    pub queued: f64,
    /// A robot whose way ahead runs through where the waiting one stands: coming the other way.
    pub oncoming: f64,
    /// A robot whose way ahead runs through the waiting one's next vertex: ahead of it the same
    /// way, or crossing there.
    pub ahead: f64,
    /// Anything else (a resource in conflict nearby; a grant not given yet).
    pub other: f64,
}

/// A run that broke what traffic guarantees.
#[derive(Debug, Clone, PartialEq)]
pub struct Violation {
    pub seed: u64,
    pub at: f64,
    pub what: String,
}

impl std::fmt::Display for Violation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "seed {} at {:.2} s: {}", self.seed, self.at, self.what)
    }
}

/// One simulated robot.
#[derive(Debug, Clone)]
struct Bot {
    id: RobotId,
    speed: f64,
    route: Vec<u32>,
    /// Position in the route of the vertex last reached (none: not on the graph).
    reached: Option<usize>,
    /// Position it may drive to.
    granted: Option<usize>,
    /// The version of the route traffic last gave it.
    version: u64,
    /// Metres along the hop after `reached`.
    along: f64,
    /// Dwelling at its goal until then.
    until: f64,
    /// When it last finished a route (or started).
    last_trip: f64,
    /// Since when it stands wanting to drive (none: it drives, dwells or is parked).
    stuck: Option<f64>,
    /// It stood for a grant this step (counted in [`Report::waited`]).
    waited: bool,
    /// It told traffic it is clear of the vertex it last reached ([`Event::Left`]).
    left: bool,
}

impl Bot {
    fn at(&self, layout: &Layout) -> Option<Point> {
        let p = self.reached?;
        let a = layout.point(self.route[p]);
        match self.route.get(p + 1) {
            Some(&b) if self.along > 0.0 => {
                let b = layout.point(b);
                let t = (self.along / a.dist(b)).min(1.0);
                Some(Point::new(a.x + t * (b.x - a.x), a.y + t * (b.y - a.y)))
            }
            _ => Some(a),
        }
    }

    fn may_drive(&self, controlled: bool) -> bool {
        let p = self.reached.unwrap_or(0);
        p + 1 < self.route.len() && (!controlled || self.granted.is_some_and(|g| g > p))
    }
}

/// Runs `world` on `graph` with `seed`.
pub fn run(layout: &Arc<Layout>, space: &GraphSpace, world: World, seed: u64) -> Result<Report, Violation> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut traffic = Traffic::new(layout.clone(), world.params);
    let n = world.places.map_or(layout.vertices() as u32, |p| p.min(layout.vertices() as u32));
    let mut report = Report { seed, robots: world.robots.min(n as usize), closest: f64::INFINITY, ..Report::default() };
    let mut bots: Vec<Bot> = Vec::new();
    let mut starts: Vec<u32> = (0..n).collect();
    for i in 0..world.robots.min(n as usize) {
        let k = rng.gen_range(i..starts.len());
        starts.swap(i, k);
        let speed = rng.gen_range(world.speed.0..=world.speed.1);
        bots.push(Bot {
            id: RobotId::from(format!("r{i}").as_str()),
            speed,
            route: vec![starts[i]],
            reached: None,
            granted: None,
            version: 0,
            along: 0.0,
            until: 0.0,
            last_trip: 0.0,
            stuck: None,
            waited: false,
            left: false,
        });
    }
    let mut cmds = Vec::new();
    let mut goals: Vec<u32> = bots.iter().map(|b| b.route[0]).collect();
    for i in 0..bots.len() {
        let route = random_goal(&mut rng, space, bots[i].route[0], n, &goals);
        bots[i].route.clone_from(&route);
        goals[i] = route[route.len() - 1];
        cmds.extend(traffic.handle(Time::ZERO, Event::Route { robot: bots[i].id.clone(), route }));
    }
    let index: BTreeMap<RobotId, usize> = bots.iter().enumerate().map(|(i, b)| (b.id.clone(), i)).collect();
    let mut close: BTreeMap<(usize, usize), bool> = BTreeMap::new();
    let mut stalled = vec![false; bots.len()];
    let mut now = 0.0;
    while now < world.duration {
        if let Err(v) = apply(&mut bots, &index, std::mem::take(&mut cmds), &mut report, now, layout.vertices()) {
            return Err(annotate(v, &traffic, &bots, &report, &world));
        }
        // Where every robot is going (its own goal is where it stands when it draws a new one).
        goals.clear();
        goals.extend(bots.iter().map(|b| b.route[b.route.len() - 1]));
        for i in 0..bots.len() {
            let events = step(&mut bots[i], layout, space, &world, &mut rng, now, &mut report, &goals);
            goals[i] = bots[i].route[bots[i].route.len() - 1];
            for e in events {
                if world.controlled {
                    let out = traffic.handle(Time::from_secs(now), e.clone());
                    report.events += 1;
                    if world.trace {
                        report.trace.push(format!("{now:.2} {e:?} → {out:?}"));
                    }
                    cmds.extend(out);
                }
            }
        }
        if world.controlled {
            let out = traffic.handle(Time::from_secs(now), Event::Tick);
            report.events += 1;
            if world.trace && !out.is_empty() {
                report.trace.push(format!("{now:.2} Tick → {out:?}"));
            }
            cmds.extend(out);
        }
        if world.controlled && world.causes {
            count_waits(&bots, &traffic, world.dt, &mut report.waited_for);
        }
        if let Err(v) = check(&bots, layout, &world, now, &mut close, &mut stalled, &mut report, seed) {
            return Err(annotate(v, &traffic, &bots, &report, &world));
        }
        now += world.dt;
    }
    Ok(report)
}

/// The violation with the trace (if kept) and where every robot stands in traffic.
fn annotate(mut v: Violation, traffic: &Traffic, bots: &[Bot], report: &Report, world: &World) -> Violation {
    if world.trace {
        v.what.push_str(&format!("\n{}", report.trace.join("\n")));
    }
    for b in bots {
        v.what.push_str(&format!("\n  {}", traffic.describe(&b.id)));
    }
    v
}

/// Takes traffic's commands as the robots' drivers would.
fn apply(bots: &mut [Bot], index: &BTreeMap<RobotId, usize>, cmds: Vec<Command>, report: &mut Report, now: f64, vertices: usize) -> Result<(), Violation> {
    for c in cmds {
        match c {
            Command::Grant { robot, version, upto, vertex } => {
                let b = &mut bots[index[&robot]];
                if version != b.version || b.route.get(upto) != Some(&vertex) {
                    return Err(Violation {
                        seed: report.seed,
                        at: now,
                        what: format!("{robot} granted {upto} (vertex {vertex}) of version {version}; it drives version {} {:?}", b.version, b.route),
                    });
                }
                b.granted = Some(upto);
            }
            Command::Route { robot, version, route, reached, upto, why } => {
                let b = &mut bots[index[&robot]];
                // A route is a shortest path, joined behind what was granted, with steps aside of a
                // few hops: one longer than twice the graph has grown by repeated steps aside.
                if route.len() > 2 * vertices + 64 {
                    return Err(Violation { seed: report.seed, at: now, what: format!("{robot}'s route grew to {} vertices", route.len()) });
                }
                let here = b.reached.map(|p| b.route[p]);
                let next = b.reached.and_then(|p| b.route.get(p + 1)).filter(|_| b.along > 0.0);
                let (there, ahead) = (reached.map(|p| route[p]), reached.and_then(|p| route.get(p + 1)));
                if here != there || (next.is_some() && next != ahead) {
                    return Err(Violation {
                        seed: report.seed,
                        at: now,
                        what: format!("{robot} at {here:?} (driving to {next:?}) given route {route:?} from {reached:?}"),
                    });
                }
                b.route = route;
                b.reached = reached;
                b.granted = upto;
                b.version = version;
                if why != Why::Asked {
                    report.detours += 1;
                }
            }
            Command::Blocked { .. } => report.blocked += 1,
            Command::Refused { robot, why } => return Err(Violation { seed: report.seed, at: now, what: format!("{robot}'s route refused: {why}") }),
        }
    }
    Ok(())
}

/// Moves one robot by a step; what it tells traffic.
#[allow(clippy::too_many_arguments)]
fn step(b: &mut Bot, layout: &Layout, space: &GraphSpace, world: &World, rng: &mut ChaCha8Rng, now: f64, report: &mut Report, taken: &[u32]) -> Vec<Event> {
    let mut events = Vec::new();
    if b.reached.is_none() {
        if !world.controlled || b.granted.is_some() {
            b.reached = Some(0);
            events.push(Event::Reached { robot: b.id.clone(), vertex: b.route[0] });
        }
        return events;
    }
    let mut budget = b.speed * world.dt;
    while budget > 0.0 && b.may_drive(world.controlled) {
        let p = b.reached.unwrap_or(0);
        let len = layout.point(b.route[p]).dist(layout.point(b.route[p + 1]));
        let go = budget.min(len - b.along);
        b.along += go;
        budget -= go;
        report.driven += go;
        if world.release && !b.left && b.along < len - 1e-9 && layout.release_after(b.route[p], b.route[p + 1]).is_some_and(|d| b.along >= d) {
            b.left = true;
            events.push(Event::Left { robot: b.id.clone(), vertex: b.route[p] });
        }
        if b.along >= len - 1e-9 {
            b.left = false;
            b.reached = Some(p + 1);
            b.along = 0.0;
            events.push(Event::Reached { robot: b.id.clone(), vertex: b.route[p + 1] });
        }
    }
    let p = b.reached.unwrap_or(0);
    let at_end = p + 1 == b.route.len();
    if at_end {
        if b.until == 0.0 {
            b.until = now + rng.gen_range(0.0..=world.dwell);
            report.trips += 1;
            report.longest_trip = report.longest_trip.max(now - b.last_trip);
            b.last_trip = now;
        } else if now >= b.until {
            b.until = 0.0;
            let places = world.places.map_or(layout.vertices() as u32, |n| n.min(layout.vertices() as u32));
            b.route = random_goal(rng, space, b.route[p], places, taken);
            b.reached = Some(0);
            b.granted = Some(0);
            // Traffic answers with the route it will grant (joined behind what it granted).
            events.push(Event::Route { robot: b.id.clone(), route: b.route.clone() });
        }
    }
    b.waited = !at_end && budget > 0.0 && b.along == 0.0;
    if b.waited {
        report.waited += world.dt;
    }
    let stands = b.along == 0.0 && budget > 0.0 && p + 1 < b.route.len();
    b.stuck = if stands { b.stuck.or(Some(now)) } else { None };
    events
}

/// Adds a step's waiting, by what each robot standing for a grant waits for.
fn count_waits(bots: &[Bot], traffic: &Traffic, dt: f64, into: &mut WaitedFor) {
    for b in bots.iter().filter(|b| b.waited) {
        let by = traffic.waits_for(&b.id);
        let Some(p) = b.reached.filter(|_| !by.is_empty()) else {
            into.other += dt;
            continue;
        };
        let (here, next) = (b.route[p], b.route.get(p + 1).copied());
        let ways: Vec<(&[u32], Option<usize>, Option<usize>)> =
            by.iter().filter_map(|o| traffic.state(o)).map(|(r, reached, granted, _)| (r, reached, granted)).collect();
        let rests: Vec<&[u32]> = ways.iter().map(|(r, reached, _)| &r[reached.unwrap_or(0)..]).collect();
        let slot = if ways.iter().any(|w| w.1.is_some_and(|x| x + 1 == w.0.len())) {
            &mut into.parked
        } else if ways.iter().all(|w| w.1 == w.2) {
            &mut into.queued
        } else if rests.iter().any(|r| r.contains(&here)) {
            &mut into.oncoming
        } else if rests.iter().any(|r| next.is_some_and(|n| r.contains(&n))) {
            &mut into.ahead
        } else {
            &mut into.other
        };
        *slot += dt;
    }
}

/// A shortest route from `from` to a random other vertex it can reach that no other robot is
/// going to (as a mission's planner gives each robot its own goal).
fn random_goal(rng: &mut ChaCha8Rng, space: &GraphSpace, from: u32, n: u32, taken: &[u32]) -> Vec<u32> {
    for _ in 0..50 {
        let to = rng.gen_range(0..n);
        if to == from || taken.contains(&to) {
            continue;
        }
        if let Some(path) = space.vertex_path(from, to) {
            return path;
        }
    }
    vec![from]
}

/// Checks every pair of robots on the graph, and that every robot keeps finishing routes.
#[allow(clippy::too_many_arguments)]
fn check(
    bots: &[Bot],
    layout: &Layout,
    world: &World,
    now: f64,
    close: &mut BTreeMap<(usize, usize), bool>,
    stalled: &mut [bool],
    report: &mut Report,
    seed: u64,
) -> Result<(), Violation> {
    let at: Vec<Option<Point>> = bots.iter().map(|b| b.at(layout)).collect();
    for i in 0..bots.len() {
        let Some(a) = at[i] else { continue };
        for j in i + 1..bots.len() {
            let Some(b) = at[j] else { continue };
            let d = a.dist(b);
            report.closest = report.closest.min(d);
            let was = close.insert((i, j), d < layout.clearance() - 1e-6).unwrap_or(false);
            if d < layout.clearance() - 1e-6 && !was {
                report.too_close += 1;
                if world.controlled {
                    return Err(Violation {
                        seed,
                        at: now,
                        what: format!("{} and {} are {d:.3} m apart (clearance {})", bots[i].id, bots[j].id, layout.clearance()),
                    });
                }
            }
        }
        let stuck = bots[i].stuck.is_some_and(|since| now - since > world.stall);
        if world.controlled && stuck && !stalled[i] {
            report.stalled += 1;
            if world.trace {
                return Err(Violation { seed, at: now, what: format!("{} stood {} s wanting to drive", bots[i].id, world.stall) });
            }
        }
        stalled[i] = stuck;
    }
    Ok(())
}
