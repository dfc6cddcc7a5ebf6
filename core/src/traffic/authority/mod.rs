//! The fleet's traffic authority: one [`Traffic`] per graph map central publishes, told by the
//! robots' own reports ([`TrafficReport`]) where they go and what they hold, answering each with
//! the robot's order ([`TrafficOrder`]). No I/O: [`Authority::handle`] takes the time and an
//! [`Event`] and returns [`Command`]s.
//!
//! * A robot reports the goal it drives to (the plan's point) and the order it drives by. A new
//!   goal becomes a route along the lanes, from the vertex the robot will stand at (where its
//!   grant ends, or the vertex nearest it when it enters the graph) to the vertex nearest the goal.
//! * **Takeover.** An authority that starts (central restarted, or another took over) knows
//!   nothing: for [`REBUILD_S`] it only takes in what robots report they hold — routes of another
//!   incarnation, restored as far as they were granted ([`super::Event::Restore`]), the vertex a
//!   new robot stands on — and grants nothing. Robots report every [`REPORT_S`], so every robot
//!   still driving has spoken by then. A robot whose liveliness appears and that it has not
//!   heard yet holds grants up the same way, until it speaks or [`REBUILD_S`] passed (robots
//!   whose sessions link again slowly after central's restart).
//! * **Lost robots.** A robot whose liveliness went keeps everything it was granted for
//!   [`LOST_GRACE_S`] — longer than a robot that hears no order takes to stop ([`QUIET_S`]) —
//!   then what it stood on ([`super::Event::Lost`]).
//! * Every report is answered with the robot's order, so an order lost on the way is sent again.
//!   A map that has no lanes answers [`TrafficOrder::Free`].

use std::collections::BTreeMap;
use std::sync::Arc;

use mrmm_maps::space::GraphSpace;
use mrmm_maps::{Map, OccupancyGrid, Point};
use mrmm_proto::traffic::{RouteVertex, TrafficCleared, TrafficGoal, TrafficHeld, TrafficReport, DEPUTIES, QUIET_S, REPORT_S};
use mrmm_proto::{ErrorReply, RobotId, Time, TrafficOrder};

use super::{Layout, Params, Traffic, CLEARANCE};

mod grid;

pub use grid::{lanes_of, OFF_FAR, OFF_MARGIN, OFF_NEAR};
use grid::{leg_off, vertex_for, Leg};

/// Lanes longer than this (metres) are cut into segments ([`super::layout::segmented`]): robots
/// follow one another along a lane a segment apart instead of a lane apart. Measured in `mrmm
/// experiment traffic` (docs/traffic.md): 3 m took the office at 6 – 8 robots from 26 to 37 % of
/// the blind robots' trips; since corridors are cleared ahead of a gridlock's oldest robot 1.5 m
/// keeps more still (1r5 at 4 robots 48 → 60 %, cumberland at 12 46 → 58 %) and stalls less.
pub const SEGMENT_M: f64 = 1.5;
/// Seconds a new authority only listens to what robots hold before it grants anything.
pub const REBUILD_S: f64 = 2.0 * REPORT_S + 0.5;
/// A robot new to traffic this close to a vertex (metres) stands on it.
pub const STANDING: f64 = 0.3;
/// Seconds a robot whose liveliness went keeps all it was granted.
pub const LOST_GRACE_S: f64 = QUIET_S + 2.0;
/// Something that happened to the authority.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    /// Robot `report.robot` (its sender, proven) reported on map `map` (a bundle hash).
    Report { map: String, report: TrafficReport },
    /// The robot's liveliness appeared: until it reports (or [`REBUILD_S`] passed), nothing new
    /// is granted — it may stand where traffic does not know yet.
    Alive(RobotId),
    /// The robot's liveliness went.
    Gone(RobotId),
    /// Time passed.
    Tick,
}

/// What the driver must do.
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    /// Publish `order` for `robot` on `map`.
    Order { map: String, robot: RobotId, order: TrafficOrder },
    /// `robot` waits for `by` and cannot go on (for the operator).
    Blocked { map: String, robot: RobotId, by: Vec<RobotId> },
}

/// What the authority knows of a robot on a map beyond what traffic holds.
#[derive(Debug, Clone, Default)]
struct Seen {
    seq: u64,
    /// When it last reported.
    last: Time,
    /// The goal it was routed to.
    goal: Option<u64>,
    /// Why its goal was refused.
    refused: Option<String>,
    /// The way off the lanes to its goal, if it was given one.
    leg: Option<Leg>,
    /// Its way off the lanes to an earlier goal, kept from other robots' ways until it is back
    /// at that way's vertex.
    left: Option<Leg>,
}

/// Traffic on one map.
struct OnMap {
    /// None: the map has no lanes.
    lanes: Option<(Traffic, GraphSpace)>,
    /// A grid map's cells (its lanes are derived): a robot enters the lanes, and leaves them
    /// for a goal, at a vertex it sees from where it is.
    grid: Option<Arc<Map>>,
    robots: BTreeMap<RobotId, Seen>,
    /// The robots named in every order to take over, in turn, when central is away.
    deputies: Vec<RobotId>,
}

/// The traffic authority of every map.
pub struct Authority {
    /// The robot it runs on, if a deputy took over (it names others as deputies).
    me: Option<RobotId>,
    incarnation: u64,
    started: Time,
    maps: BTreeMap<String, OnMap>,
    /// Robots whose liveliness went, since when.
    gone: BTreeMap<RobotId, Time>,
    /// Robots whose liveliness appeared and that it has not heard yet, since when.
    awaiting: BTreeMap<RobotId, Time>,
    /// Robots it heard.
    heard: std::collections::BTreeSet<RobotId>,
}

impl std::fmt::Debug for Authority {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Authority").field("incarnation", &self.incarnation).field("maps", &self.maps.len()).finish()
    }
}

impl Authority {
    /// An authority started at `now`, `incarnation` above every earlier one's (its orders
    /// supersede theirs), for `maps` by bundle hash.
    pub fn new(now: Time, incarnation: u64, maps: impl IntoIterator<Item = (String, Arc<Map>)>) -> Authority {
        let maps = maps.into_iter().map(|(hash, map)| (hash, OnMap::new(&map))).collect();
        Authority { me: None, incarnation, started: now, maps, gone: BTreeMap::new(), awaiting: BTreeMap::new(), heard: Default::default() }
    }

    /// The authority a deputy, robot `me`, runs after it took over at `now` under
    /// `incarnation`, from what it heard while it followed: each robot's last report, its `held`
    /// as the robot said it or as the old authority's last order to it granted, whichever is
    /// newer (a grant the robot did not report yet is held too). Everything heard is taken in
    /// before anything is granted — no rebuild window: the deputy heard every robot within the
    /// last [`REPORT_S`] — then each robot's goal is routed on and every robot answered.
    pub fn took_over(
        now: Time,
        me: RobotId,
        incarnation: u64,
        maps: impl IntoIterator<Item = (String, Arc<Map>)>,
        heard: Vec<(String, TrafficReport)>,
    ) -> (Authority, Vec<Command>) {
        let mut a = Authority::new(now, incarnation, maps);
        a.me = Some(me);
        let mut out = Vec::new();
        for (map, report) in &heard {
            out.extend(a.handle(now, Event::Report { map: map.clone(), report: report.clone() }));
        }
        a.started = now - REBUILD_S;
        let me = a.me.clone();
        for m in a.maps.values_mut() {
            m.name_deputies(now, me.as_ref(), &a.gone);
        }
        for (map, report) in heard {
            if let Some(m) = a.maps.get_mut(&map) {
                if let Some(seen) = m.robots.get_mut(&report.robot) {
                    seen.seq = report.seq.saturating_sub(1);
                }
            }
            out.extend(a.handle(now, Event::Report { map, report }));
        }
        (a, out)
    }

    /// Traffic on `maps` too (by bundle hash), if not already.
    pub fn add_maps(&mut self, maps: impl IntoIterator<Item = (String, Arc<Map>)>) {
        for (hash, map) in maps {
            self.maps.entry(hash).or_insert_with(|| OnMap::new(&map));
        }
    }

    /// Robots on the maps of these bundle hashes drive without traffic: their reports are
    /// answered [`TrafficOrder::Free`].
    pub fn without_lanes(&mut self, hashes: impl IntoIterator<Item = String>) {
        for hash in hashes {
            self.maps.insert(hash, OnMap { lanes: None, grid: None, robots: BTreeMap::new(), deputies: Vec::new() });
        }
    }

    /// The same authority under `incarnation`, started at `now`.
    pub fn with_incarnation(mut self, incarnation: u64, now: Time) -> Authority {
        self.incarnation = incarnation;
        self.started = now;
        self
    }

    pub fn incarnation(&self) -> u64 {
        self.incarnation
    }

    /// Traffic on every map with lanes, as the operator sees it at `now`.
    pub fn views(&self, now: Time) -> Vec<mrmm_proto::traffic::TrafficView> {
        self.maps
            .iter()
            .filter_map(|(hash, m)| {
                let (t, _) = m.lanes.as_ref()?;
                Some(mrmm_proto::traffic::TrafficView { map: hash.clone(), incarnation: self.incarnation, deputies: m.deputies.clone(), robots: t.views(now) })
            })
            .collect()
    }

    /// Takes lost robot `robot` off the lanes of every map (the operator says it is no longer
    /// where it stood): everything it held is free, and robots waiting for it are granted on.
    /// Refused for a robot whose liveliness did not go, or that holds nothing.
    pub fn clear(&mut self, now: Time, robot: &RobotId) -> Result<(TrafficCleared, Vec<Command>), ErrorReply> {
        let on: Vec<String> =
            self.maps.iter().filter(|(_, m)| m.lanes.as_ref().is_some_and(|(t, _)| t.state(robot).is_some())).map(|(h, _)| h.clone()).collect();
        if on.is_empty() {
            return Err(ErrorReply::not_found(format!("robot {robot} holds nothing in traffic")));
        }
        let lost = self.gone.contains_key(robot) || on.iter().all(|h| self.traffic(h).is_some_and(|t| t.is_lost(robot)));
        if !lost {
            return Err(ErrorReply::conflict(format!(
                "robot {robot} is not lost: it holds where it stands and drives what it was granted; stop it, or drive it out of the way (mrmm op goto {robot} X Y)"
            )));
        }
        let (mut out, mut vertices) = (Vec::new(), 0);
        let incarnation = self.incarnation;
        for hash in &on {
            let Some(m) = self.maps.get_mut(hash) else { continue };
            let Some((t, _)) = m.lanes.as_mut() else { continue };
            let n = t.layout().vertices() as u32;
            vertices += t.held(robot).iter().filter(|&&r| r < n).count();
            let cmds = t.handle(now, super::Event::Remove { robot: robot.clone() });
            m.robots.remove(robot);
            // Said on the map, so that its deputies forget it too.
            out.push(Command::Order { map: hash.clone(), robot: robot.clone(), order: TrafficOrder::Cleared { incarnation } });
            m.orders(hash, incarnation, cmds, &mut out);
        }
        self.gone.remove(robot);
        Ok((TrafficCleared { robot: robot.clone(), maps: on, vertices }, out))
    }

    /// Traffic on map `hash`, if it has lanes.
    pub fn traffic(&self, hash: &str) -> Option<&Traffic> {
        self.maps.get(hash).and_then(|m| m.lanes.as_ref()).map(|(t, _)| t)
    }

    pub fn handle(&mut self, now: Time, event: Event) -> Vec<Command> {
        match event {
            Event::Report { map, report } => {
                self.gone.remove(&report.robot);
                self.awaiting.remove(&report.robot);
                if !self.heard.contains(&report.robot) && self.heard.len() < super::MAX_ROBOTS {
                    self.heard.insert(report.robot.clone());
                }
                let rebuilding = self.rebuilding(now);
                let incarnation = self.incarnation;
                let named = Naming { me: self.me.as_ref(), gone: &self.gone };
                match self.maps.get_mut(&map) {
                    Some(m) => m.report(now, &map, incarnation, rebuilding, report, named),
                    None => Vec::new(),
                }
            }
            Event::Alive(robot) => {
                if !self.heard.contains(&robot) && self.awaiting.len() < super::MAX_ROBOTS {
                    self.awaiting.insert(robot.clone(), now);
                }
                // A new session of the robot (it may have restarted): its reports count again
                // from their first.
                for m in self.maps.values_mut() {
                    if let Some(seen) = m.robots.get_mut(&robot) {
                        seen.seq = 0;
                    }
                }
                Vec::new()
            }
            Event::Gone(robot) => {
                self.awaiting.remove(&robot);
                self.gone.insert(robot, now);
                Vec::new()
            }
            Event::Tick => self.tick(now),
        }
    }

    /// Whether it is still learning what robots hold: just started, or a robot that appeared
    /// has not spoken yet.
    fn rebuilding(&mut self, now: Time) -> bool {
        self.awaiting.retain(|_, t| now - *t < REBUILD_S);
        now < self.started + REBUILD_S || !self.awaiting.is_empty()
    }

    fn tick(&mut self, now: Time) -> Vec<Command> {
        let lost: Vec<RobotId> = self.gone.iter().filter(|(_, &t)| now - t >= LOST_GRACE_S).map(|(r, _)| r.clone()).collect();
        let mut out = Vec::new();
        let incarnation = self.incarnation;
        for (hash, m) in &mut self.maps {
            m.name_deputies(now, self.me.as_ref(), &self.gone);
            let Some((t, _)) = m.lanes.as_mut() else { continue };
            let mut cmds = Vec::new();
            for r in &lost {
                cmds.extend(t.handle(now, super::Event::Lost { robot: r.clone() }));
            }
            cmds.extend(t.handle(now, super::Event::Tick));
            m.orders(hash, incarnation, cmds, &mut out);
        }
        for r in lost {
            self.gone.remove(&r);
        }
        out
    }
}

impl OnMap {
    fn new(map: &Arc<Map>) -> OnMap {
        let lanes = lanes_of(map).map(|g| {
            // Lanes cut into segments: robots follow one another a segment apart.
            let cut = super::layout::segmented(&g, SEGMENT_M);
            (Traffic::new(Arc::new(Layout::new(&cut, CLEARANCE)), Params::default()), GraphSpace::new(&cut))
        });
        let grid = (lanes.is_some() && matches!(**map, Map::Grid(_))).then(|| map.clone());
        OnMap { lanes, grid, robots: BTreeMap::new(), deputies: Vec::new() }
    }

    /// Names the deputies: a deputy that took over (`me`) first — robots take its orders as
    /// their deputy's — then the robots of the lowest ids that reported within
    /// [`LOST_GRACE_S`] and whose liveliness did not go (stable while they stay: a robot of a
    /// lower id that arrives displaces one).
    fn name_deputies(&mut self, now: Time, me: Option<&RobotId>, gone: &BTreeMap<RobotId, Time>) {
        if self.lanes.is_none() {
            return;
        }
        let live = |(id, s): &(&RobotId, &Seen)| now - s.last <= LOST_GRACE_S && Some(*id) != me && !gone.contains_key(*id);
        let others = self.robots.iter().filter(live).map(|(id, _)| id.clone());
        self.deputies = me.cloned().into_iter().chain(others).take(DEPUTIES).collect();
    }

    /// A robot's report on the map: what it holds and reached taken in, its goal routed, and
    /// its order (naming the deputies, the reporting robot counted among them, since it just
    /// spoke) given.
    fn report(&mut self, now: Time, hash: &str, incarnation: u64, rebuilding: bool, report: TrafficReport, named: Naming<'_>) -> Vec<Command> {
        let robot = report.robot.clone();
        let Some((traffic, space)) = self.lanes.as_mut() else {
            return vec![Command::Order { map: hash.to_string(), robot, order: TrafficOrder::Free }];
        };
        // Other robots' ways off the lanes, which a new one keeps clear of (looked up only for a
        // goal to route).
        let routing = !rebuilding && report.goal.is_some_and(|g| self.robots.get(&robot).is_none_or(|s| s.goal != Some(g.id)));
        let others: Vec<Leg> = if routing && self.grid.is_some() {
            self.robots.iter().filter(|(id, _)| **id != robot).flat_map(|(_, s)| s.leg.into_iter().chain(s.left)).collect()
        } else {
            Vec::new()
        };
        let seen = self.robots.entry(robot.clone()).or_default();
        if report.seq <= seen.seq {
            return Vec::new();
        }
        seen.seq = report.seq;
        seen.last = now;
        if seen.left.is_some_and(|l| l.from.dist(Point::new(report.x, report.y)) <= STANDING) {
            seen.left = None;
        }
        let mut cmds = Vec::new();
        if !rebuilding && report.goal.is_none() && seen.goal.is_some() && traffic.state(&robot).is_some() {
            cmds.extend(stopped(now, traffic, seen, &report, incarnation));
        }
        let known = traffic.state(&robot).is_some();
        match &report.held {
            // Held from another authority: taken in as it is, before anything is granted. Its
            // goal is routed on from where the grant ends once the rebuild is over.
            Some(h) if !known && h.incarnation != incarnation && h.upto.is_some() => {
                let (reached, granted) = (h.reached.map(|p| p as usize), h.upto.unwrap_or(0) as usize);
                tracing::info!(%robot, route = h.route.len(), ?reached, granted, "traffic: taken in what the robot holds");
                cmds.extend(traffic.handle(now, super::Event::Restore { robot: robot.clone(), route: h.route.clone(), reached, granted }));
                seen.goal = None;
            }
            // New to traffic, standing on a vertex: it holds it from now on (a robot routed
            // through there would drive into it).
            _ if !known => {
                let (v, d) = space.graph().nearest(Point::new(report.x, report.y));
                if d <= STANDING && space.nodes() > 0 {
                    cmds.extend(traffic.handle(now, super::Event::Restore { robot: robot.clone(), route: vec![v], reached: Some(0), granted: 0 }));
                }
            }
            // Progress along the route traffic holds for it.
            Some(h) if known && h.incarnation == incarnation => cmds.extend(progress(now, traffic, &report, h)),
            _ => {}
        }
        cmds.extend(docked(now, traffic, &report));
        if !rebuilding {
            if let Some(goal) = report.goal.filter(|g| seen.goal != Some(g.id)) {
                seen.goal = Some(goal.id);
                seen.refused = None;
                let grid = match self.grid.as_deref() {
                    Some(Map::Grid(g)) => Some(g),
                    _ => None,
                };
                match route_to(traffic, space, grid, &robot, Point::new(report.x, report.y), goal) {
                    Ok(route) => {
                        seen.left = seen.leg.take().or(seen.left);
                        let last = route[route.len() - 1];
                        seen.leg = grid.and_then(|g| leg_off(traffic.layout(), g, last, Point::new(goal.x, goal.y), &others));
                        cmds.extend(traffic.handle(now, super::Event::Route { robot: robot.clone(), route }));
                    }
                    Err(why) => seen.refused = Some(why),
                }
            }
        }
        if self.deputies.len() < DEPUTIES {
            self.name_deputies(now, named.me, named.gone);
        }
        let mut out = Vec::new();
        let answered = self.orders(hash, incarnation, cmds, &mut out);
        if !answered && !rebuilding {
            if let Some(order) = self.order_of(&robot, incarnation) {
                out.push(Command::Order { map: hash.to_string(), robot, order });
            }
        }
        out
    }

    /// Traffic's commands as orders and blocks; whether robot `robot` got one.
    fn orders(&self, hash: &str, incarnation: u64, cmds: Vec<super::Command>, out: &mut Vec<Command>) -> bool {
        let mut told = std::collections::BTreeSet::new();
        for c in cmds {
            match c {
                super::Command::Route { robot, .. } | super::Command::Grant { robot, .. } => {
                    told.insert(robot);
                }
                super::Command::Refused { robot, why } => {
                    let goal = self.robots.get(&robot).and_then(|s| s.goal).unwrap_or(0);
                    out.push(Command::Order { map: hash.to_string(), robot, order: TrafficOrder::Refused { goal, why } });
                }
                super::Command::Blocked { robot, by } => out.push(Command::Blocked { map: hash.to_string(), robot, by }),
            }
        }
        let any = !told.is_empty();
        for robot in told {
            if let Some(order) = self.order_of(&robot, incarnation) {
                out.push(Command::Order { map: hash.to_string(), robot, order });
            }
        }
        any
    }

    /// The order robot `robot` drives by now.
    fn order_of(&self, robot: &RobotId, incarnation: u64) -> Option<TrafficOrder> {
        let seen = self.robots.get(robot)?;
        let goal = seen.goal.unwrap_or(0);
        if let Some(why) = &seen.refused {
            return Some(TrafficOrder::Refused { goal, why: why.clone() });
        }
        let (traffic, _) = self.lanes.as_ref()?;
        let (route, reached, upto, version) = traffic.state(robot)?;
        let off = seen.leg.filter(|l| route.last() == Some(&l.v)).map(|l| [l.to.x, l.to.y]);
        let layout = traffic.layout();
        let release = |i: usize| route.get(i + 1).and_then(|&n| layout.release_after(route[i], n));
        let route = (0..route.len()).map(|i| RouteVertex { release: release(i), ..layout.route_vertex(route[i]) }).collect();
        Some(TrafficOrder::Route {
            goal,
            incarnation,
            version,
            route,
            reached: reached.map(|p| p as u32),
            upto: upto.map(|p| p as u32),
            deputies: self.deputies.clone(),
            off,
        })
    }
}

/// Who an order to `robot` is sealed for: the robot, and the deputies it names (they follow
/// every order on the map, and a seal tagged for the robot alone they could not check).
pub fn audience(robot: &RobotId, order: &TrafficOrder) -> Vec<mrmm_proto::Sender> {
    let robots = |id: &RobotId| mrmm_proto::Sender::new(mrmm_proto::Role::Robot, id.to_string());
    let mut to = vec![robots(robot)];
    if let TrafficOrder::Route { deputies, .. } = order {
        to.extend(deputies.iter().filter(|d| *d != robot).map(robots));
    }
    to
}

/// What command `c` publishes: an order, sealed for its [`audience`] (a block is the
/// driver's to log).
pub fn egress(c: &Command) -> Option<crate::egress::Out> {
    let Command::Order { map, robot, order } = c else { return None };
    let to = crate::egress::Audience::Only(audience(robot, order));
    crate::egress::Out::json(mrmm_proto::Key::TrafficOrder { map: map.clone(), robot: robot.clone() }, order, to)
}

/// A robot traffic routes reports no goal: it stopped (a hold, its mission paused, its plan
/// over). It drives no further than it says it holds of this authority's route, and the rest is
/// let go (its route ends there, its orders say goal 0); holding nothing of it, it is taken out,
/// and in anew as one new to traffic.
fn stopped(now: Time, traffic: &mut Traffic, seen: &mut Seen, report: &TrafficReport, incarnation: u64) -> Vec<super::Command> {
    seen.goal = None;
    seen.refused = None;
    seen.left = seen.leg.take().or(seen.left);
    let robot = report.robot.clone();
    let event = match &report.held {
        Some(h) if h.incarnation == incarnation && h.upto.is_some() => {
            let (reached, granted) = (h.reached.map(|p| p as usize), h.upto.unwrap_or(0) as usize);
            super::Event::Restore { robot, route: h.route.clone(), reached, granted }
        }
        _ => super::Event::Remove { robot },
    };
    traffic.handle(now, event)
}

/// Progress along the route traffic holds for the robot (the same version: the same route,
/// position for position): every vertex reached since, in order, and the one it last reached
/// let go once it is clear of it. A report of an older version is not read (its robot takes the
/// new order and reports again).
fn progress(now: Time, traffic: &mut Traffic, report: &TrafficReport, h: &TrafficHeld) -> Vec<super::Command> {
    let robot = &report.robot;
    let mut cmds = Vec::new();
    if let (Some((route, at, _, version)), Some(p)) = (traffic.state(robot), h.reached) {
        let from = at.map_or(0, |a| a + 1);
        let vs: Vec<u32> = if version == h.version { route.get(from..=p as usize).map(<[u32]>::to_vec).unwrap_or_default() } else { Vec::new() };
        for v in vs {
            cmds.extend(traffic.handle(now, super::Event::Reached { robot: robot.clone(), vertex: v }));
        }
    }
    if let Some(vertex) = clear_behind(traffic, report, h) {
        cmds.extend(traffic.handle(now, super::Event::Left { robot: robot.clone(), vertex }));
    }
    cmds
}

/// The vertex the robot last reached, when its report puts it clear of it on the hop it drives
/// on from there (the same route as traffic's, granted beyond): a robot following may close up
/// to it ([`super::Event::Left`]).
fn clear_behind(traffic: &Traffic, report: &TrafficReport, h: &TrafficHeld) -> Option<u32> {
    let (route, reached, granted, version) = traffic.state(&report.robot)?;
    let p = reached?;
    let driving = version == h.version && h.reached == Some(p as u32) && granted.is_some_and(|g| g > p);
    let clear = driving && traffic.layout().clear_of(route[p], route[p + 1], Point::new(report.x, report.y));
    clear.then_some(route[p])
}

/// A robot in traffic says whether it stands docked at a charger (it makes no way then).
fn docked(now: Time, traffic: &mut Traffic, report: &TrafficReport) -> Vec<super::Command> {
    if traffic.state(&report.robot).is_none() || traffic.is_docked(&report.robot) == report.docked {
        return Vec::new();
    }
    traffic.handle(now, super::Event::Dock { robot: report.robot.clone(), on: report.docked })
}

/// The route to `goal`: from the vertex the robot will stand at (where its grant ends; where it
/// enters the lanes if it holds nothing yet) to the vertex the goal is reached at.
fn route_to(traffic: &Traffic, space: &GraphSpace, grid: Option<&OccupancyGrid>, robot: &RobotId, at: Point, goal: TrafficGoal) -> Result<Vec<u32>, String> {
    let to = vertex_for(space, grid, Point::new(goal.x, goal.y)).ok_or("the map has no vertices")?;
    let from = match traffic.state(robot) {
        Some((route, _, Some(g), _)) => route[g],
        _ => vertex_for(space, grid, at).unwrap_or(to),
    };
    // Round robots docked at chargers, where there is a way round.
    let docked = traffic.docked_vertices(robot);
    space
        .vertex_path_avoiding(from, to, |v| docked.contains(&v))
        .ok_or_else(|| format!("no lanes lead from vertex {from} to vertex {to} (nearest the goal ({}, {}))", goal.x, goal.y))
}

/// Who may be named a deputy: not the deputy that took over (`me`, named first anyway), not a
/// robot whose liveliness went.
#[derive(Clone, Copy)]
struct Naming<'a> {
    me: Option<&'a RobotId>,
    gone: &'a BTreeMap<RobotId, Time>,
}

#[cfg(test)]
mod tests;
