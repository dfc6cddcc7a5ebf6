//! Traffic on a navigation graph: robots that share corridors without meeting in them, as a pure
//! state machine. No I/O, no clock: [`Traffic::handle`] takes the time and an [`Event`] and
//! returns [`Command`]s.
//!
//! # Model
//! Robots drive routes of vertices along the graph's directed edges. The graph's vertices and
//! lanes are **resources** ([`Layout`]): a robot standing at a vertex holds it; a robot driving
//! from `u` to `v` holds `u`, the lane and `v` until it reaches `v`, where it lets `u` and the
//! lane go. A resource is held by one robot at a time, and never while another robot holds one
//! it conflicts with (closer than the clearance). So two robots are never closer than the
//! clearance, never on one lane (head-on or one behind the other), and never at one vertex.
//!
//! * **Grants.** A robot may drive its route up to the vertex it was last granted
//!   ([`Command::Grant`]), at most `ahead` hops beyond where it stands (VDA 5050's released
//!   nodes: the rest of the route is the horizon). Hops are granted in route order; when several
//!   robots want one resource, the one that has waited longest gets it.
//! * **Deadlocks.** Robots standing and waiting for each other in a cycle (two robots facing
//!   each other across a lane, a robot coming out of a dead end meeting one going in) are found
//!   after every event; one of them steps aside to the nearest free vertex off the others' way
//!   (a few hops at most) and comes back ([`Command::Route`] with the new route). The one that
//!   asked for its way last gives way first, so the oldest trip always goes on (no livelock of
//!   robots taking turns stepping aside). When none can, they are reported
//!   ([`Command::Blocked`]).
//! * **Parked robots** (at the end of their route) in the way of one that has waited
//!   `yield_after` seconds step aside and come back the same way.
//! * **Lost robots** keep what they stood on (they may still be there); only their grants ahead
//!   are let go. A robot removed from traffic lets everything go.
//!
//! Routes that do not follow the graph's edges, or that start elsewhere than where the robot
//! is, are refused ([`Command::Refused`]); reports of vertices a robot was not granted are
//! ignored. Every decision is deterministic (robots in id order, waits by age).

pub mod authority;
mod clear;
mod deadlock;
pub mod deputy;
#[cfg(test)]
mod fleet_tests;
mod grants;
pub mod layout;
mod push;
mod search;
mod segments;
#[cfg(test)]
mod tests;

use std::collections::{BTreeMap, BTreeSet};
use std::sync::Arc;

use mrmm_proto::{RobotId, Time};

pub use layout::{Layout, Res};

/// Longest route taken, in vertices (a route asked for, or joined behind what was granted).
pub const MAX_ROUTE: usize = 10_000;
/// Most robots in traffic on one graph.
pub const MAX_ROBOTS: usize = 20_000;
/// Robots stay this far apart, centre to centre (metres): robots of the default radius, 0.25 m,
/// with 0.1 m to spare.
pub const CLEARANCE: f64 = 0.6;

/// A robot's route, the position it last reached, the one it may drive to, the route's version.
pub type RouteState<'a> = (&'a [u32], Option<usize>, Option<usize>, u64);

/// How traffic is run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Params {
    /// Hops a robot may be granted beyond the vertex it stands at.
    pub ahead: usize,
    /// A parked robot in the way of one that waited this long (seconds) steps aside.
    pub yield_after: f64,
    /// A corridor (a chain of lanes without a junction) is held for one direction at a time: a
    /// robot enters a lane of it only if every other robot in it drives it the same way.
    pub corridors: bool,
}

impl Default for Params {
    fn default() -> Self {
        Params { ahead: 2, yield_after: 3.0, corridors: false }
    }
}

/// Something that happened.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    /// `robot` will drive `route` (vertices along directed edges). A robot new to traffic enters
    /// the graph at `route[0]` (once granted); one already in it must start where it stands, or,
    /// while it drives a hop, at the vertex the hop goes to. Replaces the robot's route.
    Route { robot: RobotId, route: Vec<u32> },
    /// `robot` reached `vertex`, the next vertex of its route.
    Reached { robot: RobotId, vertex: u32 },
    /// The robot's liveliness was lost: it keeps what it stood on.
    Lost { robot: RobotId },
    /// The robot stands charging at a charger (`on`), or no longer: a docked robot is a parked
    /// one that does not make way.
    Dock { robot: RobotId, on: bool },
    /// The robot is out of traffic (left the map, taken away): everything it held is free.
    Remove { robot: RobotId },
    /// What `robot` holds by its own report, to an authority that does not know it (one that
    /// took over), or to its own that it stopped (it drives no further, the rest of its route
    /// is let go): `route` up to position `granted`, reached up to `reached`. The robot holds
    /// the vertex it reached and the hops granted beyond; traffic grants nothing in conflict
    /// with them, and holds them even where they conflict with another robot's (both robots
    /// may be there).
    Restore { robot: RobotId, route: Vec<u32>, reached: Option<usize>, granted: usize },
    /// `robot`, driving the hop from `vertex`, is far enough along it for `vertex` to be let go
    /// ([`Layout::release_after`]): a robot following it may close up to that vertex. Ignored
    /// unless `vertex` is the one it last reached and it drives on from it.
    Left { robot: RobotId, vertex: u32 },
    /// Time passed.
    Tick,
}

/// Why a robot's route was changed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Why {
    /// The robot asked for it.
    Asked,
    /// It was in a cycle of robots waiting for each other.
    Deadlock,
    /// It was parked in the way of a robot.
    Yield,
}

/// What the drivers must do.
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    /// The route `robot` drives, version `version`: the one it asked for, joined behind what it
    /// was already granted, or one traffic made (a step aside, then the rest of its way). It
    /// last reached position `reached` of it (none: it is not at `route[0]` yet) and may drive
    /// up to position `upto` (none: it waits to enter at `route[0]`). Supersedes every earlier
    /// version.
    Route { robot: RobotId, version: u64, route: Vec<u32>, reached: Option<usize>, upto: Option<usize>, why: Why },
    /// `robot` may drive route `version` up to position `upto` of it (vertex `vertex`).
    Grant { robot: RobotId, version: u64, upto: usize, vertex: u32 },
    /// `robot` has waited for `by` (lost, or with nowhere to make way) and cannot go on.
    Blocked { robot: RobotId, by: Vec<RobotId> },
    /// The route was not taken.
    Refused { robot: RobotId, why: String },
}

/// One robot in traffic.
#[derive(Debug, Clone, Default)]
struct Robot {
    route: Vec<u32>,
    /// Position in `route` of the vertex the robot last reached (none: not on the graph yet).
    reached: Option<usize>,
    /// Position in `route` up to which it may drive (none: not even its entry).
    granted: Option<usize>,
    /// Version of the route, +1 each time it changes.
    version: u64,
    /// When it asked for the way it is on: the longer ago, the less it gives way.
    asked: Time,
    /// Resources held, with how many granted hops need each.
    held: BTreeMap<Res, u32>,
    /// Since when it stands waiting for a grant.
    waiting: Option<Time>,
    lost: bool,
    /// Parked at a charger: it does not make way.
    docked: bool,
    /// Robots it was reported blocked by (reported once).
    blocked: Vec<RobotId>,
    /// It let go of the vertex it last reached, driving on from it ([`Event::Left`]).
    left: bool,
    /// The steps aside it made out of cycles of waits on the way it asked for (from where, to
    /// which next vertex, how often): a step made [`deadlock::REPEATS`] times is tried after
    /// the other robots' (two cycles undoing each other's steps kept robots stepping back and
    /// forth for good).
    asides: BTreeMap<(u32, u32), u32>,
}

impl Robot {
    /// Whether it stands still wanting to go on.
    fn stands_waiting(&self) -> bool {
        !self.lost && self.granted == self.reached && self.wants_more()
    }

    fn wants_more(&self) -> bool {
        self.granted.map_or(!self.route.is_empty(), |g| g + 1 < self.route.len())
    }

    /// At the end of its route, holding its last vertex.
    fn parked(&self) -> bool {
        self.reached.is_some_and(|r| r + 1 == self.route.len())
    }

    /// The vertex it stands at, if it stands (not driving a hop).
    fn standing(&self) -> Option<u32> {
        match (self.reached, self.granted) {
            (Some(r), Some(g)) if r == g => Some(self.route[r]),
            _ => None,
        }
    }
}

/// Traffic on one graph.
#[derive(Debug, Clone)]
pub struct Traffic {
    layout: Arc<Layout>,
    params: Params,
    robots: BTreeMap<RobotId, Robot>,
    /// Who holds each resource.
    holder: Vec<Option<RobotId>>,
    /// Something happened since deadlocks and grants were last looked at.
    dirty: bool,
    /// When they were last looked at.
    looked: Time,
    /// The robots of the last searches that found no way out, where they stood (at most
    /// [`search::FAILED`], the last first).
    searched: Vec<search::Standing>,
    /// The robots last sent ahead to clear a way, where they stood ([`Traffic::clear_through`]).
    cleared: Option<search::Standing>,
}

impl Traffic {
    pub fn new(layout: Arc<Layout>, params: Params) -> Traffic {
        let holder = vec![None; layout.resources()];
        Traffic { layout, params, robots: BTreeMap::new(), holder, dirty: false, looked: Time::LONG_AGO, searched: Vec::new(), cleared: None }
    }

    pub fn layout(&self) -> &Layout {
        &self.layout
    }

    /// Who holds resource `r`.
    pub fn holder(&self, r: Res) -> Option<&RobotId> {
        self.holder.get(r as usize).and_then(Option::as_ref)
    }

    /// The resources `robot` holds.
    pub fn held(&self, robot: &RobotId) -> Vec<Res> {
        self.robots.get(robot).map(|r| r.held.keys().copied().collect()).unwrap_or_default()
    }

    /// Whether `robot` stands docked at a charger (it does not make way).
    pub fn is_docked(&self, robot: &RobotId) -> bool {
        self.robots.get(robot).is_some_and(|r| r.docked)
    }

    /// The vertices robots other than `robot` stand docked at: routes go round them where they
    /// can.
    pub fn docked_vertices(&self, robot: &RobotId) -> BTreeSet<u32> {
        self.robots.iter().filter(|(id, r)| r.docked && *id != robot).filter_map(|(_, r)| r.standing()).collect()
    }

    /// Whether `robot`'s liveliness went (it keeps what it stood on).
    pub fn is_lost(&self, robot: &RobotId) -> bool {
        self.robots.get(robot).is_some_and(|r| r.lost)
    }

    /// `robot`'s route and the position in it it may drive to.
    pub fn route(&self, robot: &RobotId) -> Option<(&[u32], Option<usize>)> {
        self.robots.get(robot).map(|r| (r.route.as_slice(), r.granted))
    }

    /// `robot`'s route, the position it last reached, the one it may drive to, and the route's
    /// version.
    pub fn state(&self, robot: &RobotId) -> Option<RouteState<'_>> {
        self.robots.get(robot).map(|r| (r.route.as_slice(), r.reached, r.granted, r.version))
    }

    /// Every robot in traffic as the operator sees it, at `now`.
    pub fn views(&self, now: Time) -> Vec<mrmm_proto::traffic::TrafficRobotView> {
        let vertices = self.layout.vertices() as u32;
        self.robots
            .iter()
            .map(|(id, r)| {
                let waits_for = self.waits_for(id);
                mrmm_proto::traffic::TrafficRobotView {
                    robot: id.clone(),
                    route: r.route.clone(),
                    points: r.route.iter().map(|&v| self.layout.point(v)).map(|p| [p.x, p.y]).collect(),
                    reached: r.reached.map(|p| p as u32),
                    granted: r.granted.map(|p| p as u32),
                    holds: r.held.keys().copied().filter(|&x| x < vertices).collect(),
                    waits_for: waits_for.into_iter().collect(),
                    waiting_s: r.waiting.map(|t| (now - t).max(0.0)),
                    blocked: r.blocked.clone(),
                    lost: r.lost,
                    docked: r.docked,
                }
            })
            .collect()
    }

    /// The robots in the way of `robot`'s next hop while it stands waiting for it (none when it
    /// drives, or is not in traffic).
    pub fn waits_for(&self, robot: &RobotId) -> BTreeSet<RobotId> {
        let Some(r) = self.robots.get(robot) else { return BTreeSet::new() };
        let next = r.granted.map_or(0, |g| g + 1);
        if r.stands_waiting() && next < r.route.len() {
            self.grantable(robot, r, next).err().unwrap_or_default()
        } else {
            BTreeSet::new()
        }
    }

    /// One line on a robot: its route, how far it got and may go, what it holds, whom it waits
    /// for (for logs and failed simulations).
    pub fn describe(&self, robot: &RobotId) -> String {
        let Some(r) = self.robots.get(robot) else { return format!("{robot}: not in traffic") };
        let next = r.granted.map_or(0, |g| g + 1);
        let by = if next < r.route.len() { self.grantable(robot, r, next).err().unwrap_or_default() } else { BTreeSet::new() };
        format!(
            "{robot}: route {:?}, reached {:?}, granted {:?}, holds {:?}, waits since {} for {by:?}{}",
            r.route,
            r.reached,
            r.granted,
            r.held,
            r.waiting.map_or_else(|| "-".to_string(), |t| t.to_string()),
            if r.lost { ", lost" } else { "" }
        )
    }

    pub fn handle(&mut self, now: Time, event: Event) -> Vec<Command> {
        let mut out = Vec::new();
        self.dirty |= self.take_in(now, event, &mut out);
        // With nothing new since the last look, only time can change a decision: a robot that
        // has now waited `yield_after` for a parked one, long enough for a gridlock it is in to
        // be searched out ([`search::AFTER`]), or long enough to count as starved
        // ([`deadlock::STARVED_S`]). (Grants and cycles depend on holdings and routes alone:
        // looking again would find what the last look found.)
        let due = |since: Time, after: f64| since + after <= now && since + after > self.looked;
        let time_due =
            |r: &Robot| r.waiting.is_some_and(|since| [self.params.yield_after, search::AFTER, deadlock::STARVED_S].into_iter().any(|after| due(since, after)));
        if !self.dirty && !self.robots.values().any(time_due) {
            return out;
        }
        self.looked = now;
        let before = out.len();
        // Deadlocks are broken before anything freed is granted: a robot that steps aside into
        // a vertex just let go keeps its place in the queue.
        let waits = self.waits();
        let stepped = self.resolve(now, &waits, &mut out);
        let granted = self.grant_all(now, &mut out);
        // Waits depend on holdings and routes alone: unless a route or a grant changed, a second
        // look would find what the first found (robots that began to wait just now are in the
        // next look's).
        if stepped || granted {
            let waits = self.waits();
            if self.resolve(now, &waits, &mut out) || stepped {
                self.grant_all(now, &mut out);
            }
        }
        // What this look decided may make the next one decide more.
        self.dirty = out.len() > before;
        out
    }

    /// Takes `event` in: whether it changed anything (a robot reports where it is clear of the
    /// vertex behind it at every report past that point: only the first lets it go).
    fn take_in(&mut self, now: Time, event: Event, out: &mut Vec<Command>) -> bool {
        match event {
            Event::Route { robot, route } => {
                self.set_route(now, robot, route, out);
                true
            }
            Event::Reached { robot, vertex } => self.reached(&robot, vertex),
            Event::Lost { robot } => {
                self.lost(&robot);
                true
            }
            Event::Dock { robot, on } => {
                if let Some(r) = self.robots.get_mut(&robot) {
                    r.docked = on;
                }
                true
            }
            Event::Remove { robot } => {
                if let Some(mut r) = self.robots.remove(&robot) {
                    self.release_all(&robot, &mut r);
                }
                true
            }
            Event::Restore { robot, route, reached, granted } => {
                self.restore(now, robot, route, reached, granted, out);
                true
            }
            Event::Left { robot, vertex } => self.left(&robot, vertex),
            Event::Tick => false,
        }
    }

    fn set_route(&mut self, now: Time, id: RobotId, mut route: Vec<u32>, out: &mut Vec<Command>) {
        route.dedup();
        if let Err(why) = self.check_route(&route) {
            out.push(Command::Refused { robot: id, why });
            return;
        }
        if !self.robots.contains_key(&id) && self.robots.len() >= MAX_ROBOTS {
            out.push(Command::Refused { robot: id, why: format!("{MAX_ROBOTS} robots are in traffic already") });
            return;
        }
        let mut r = self.robots.remove(&id).unwrap_or_default();
        let joined = match r.granted {
            None => {
                self.release_all(&id, &mut r);
                r.reached = None;
                Ok(route)
            }
            Some(g) => self.join(&r, g, &route),
        };
        match joined {
            Ok(joined) => {
                // What was driven before the robot's last vertex is dropped from the route.
                let b = r.reached.unwrap_or(0);
                r.route = joined[b..].to_vec();
                r.reached = r.reached.map(|p| p - b);
                r.granted = r.granted.map(|g| g - b);
                r.lost = false;
                r.docked = false;
                r.waiting = None;
                r.asked = now;
                r.asides.clear();
                self.announce(&id, &mut r, Why::Asked, out);
            }
            Err(why) => out.push(Command::Refused { robot: id.clone(), why }),
        }
        self.robots.insert(id, r);
    }

    fn restore(&mut self, now: Time, id: RobotId, mut route: Vec<u32>, reached: Option<usize>, granted: usize, out: &mut Vec<Command>) {
        if let Err(why) = self.check_route(&route) {
            out.push(Command::Refused { robot: id, why });
            return;
        }
        if granted >= route.len() || reached.is_some_and(|p| p > granted) {
            out.push(Command::Refused { robot: id, why: format!("positions reached {reached:?}, granted {granted} do not fit a route of {}", route.len()) });
            return;
        }
        if !self.robots.contains_key(&id) && self.robots.len() >= MAX_ROBOTS {
            out.push(Command::Refused { robot: id, why: format!("{MAX_ROBOTS} robots are in traffic already") });
            return;
        }
        // A robot traffic knows (it stopped) goes on counting its route's versions.
        let version = match self.robots.remove(&id) {
            Some(mut old) => {
                self.release_all(&id, &mut old);
                old.version
            }
            None => 0,
        };
        route.truncate(granted + 1);
        let b = reached.unwrap_or(0);
        let route = route[b..].to_vec();
        let (reached, granted) = (reached.map(|p| p - b), granted - b);
        let mut r = Robot { route, reached, granted: Some(granted), version, asked: now, ..Robot::default() };
        let mut need: Vec<Res> = Vec::new();
        match reached {
            Some(_) => {
                need.push(r.route[0]);
                need.extend((1..=granted).flat_map(|i| self.hop(&r.route, i)));
            }
            None => need.extend((0..=granted).flat_map(|i| self.hop(&r.route, i))),
        }
        for res in need {
            *r.held.entry(res).or_insert(0) += 1;
            if self.holder[res as usize].is_none() {
                self.holder[res as usize] = Some(id.clone());
            }
        }
        self.announce(&id, &mut r, Why::Asked, out);
        self.robots.insert(id, r);
    }

    /// The robot's route up to what it was granted (position `g`), then `route` — which must
    /// start at a vertex it will be at: one at or after `g`, or one it passed since it last
    /// stood (it drives back to it along the granted way, lane by lane).
    fn join(&self, r: &Robot, g: usize, route: &[u32]) -> Result<Vec<u32>, String> {
        let b = r.reached.unwrap_or(0);
        let s = route[0];
        let fits = |joined: Vec<u32>| {
            if joined.len() - b > MAX_ROUTE {
                Err(format!("joined behind what the robot was granted, the route would be {} vertices; at most {MAX_ROUTE}", joined.len() - b))
            } else {
                Ok(joined)
            }
        };
        if let Some(k) = (g..r.route.len()).find(|&k| r.route[k] == s) {
            return fits(r.route[..=k].iter().chain(&route[1..]).copied().collect());
        }
        if let Some(k) = (b..g).rev().find(|&k| r.route[k] == s) {
            let mut joined = r.route[..=g].to_vec();
            joined.extend(r.route[k..g].iter().rev());
            if joined[g..].windows(2).all(|w| self.layout.is_edge(w[0], w[1])) {
                joined.extend(&route[1..]);
                return fits(joined);
            }
        }
        let here = match r.reached {
            Some(p) if p == g => format!("stands at vertex {}", r.route[p]),
            _ => format!("may drive on to vertex {}", r.route[g]),
        };
        Err(format!("the route starts at vertex {s}, but the robot {here} and cannot get back to it along its way"))
    }

    /// Tells the robot its route changed (a new version).
    fn announce(&self, id: &RobotId, r: &mut Robot, why: Why, out: &mut Vec<Command>) {
        r.version += 1;
        out.push(Command::Route { robot: id.clone(), version: r.version, route: r.route.clone(), reached: r.reached, upto: r.granted, why });
    }

    fn check_route(&self, route: &[u32]) -> Result<(), String> {
        if route.is_empty() {
            return Err("the route is empty".into());
        }
        if route.len() > MAX_ROUTE {
            return Err(format!("{} vertices; at most {MAX_ROUTE}", route.len()));
        }
        let n = self.layout.vertices() as u32;
        if let Some(v) = route.iter().find(|&&v| v >= n) {
            return Err(format!("vertex {v} is not on the map ({n} vertices)"));
        }
        if let Some(w) = route.windows(2).find(|w| !self.layout.is_edge(w[0], w[1])) {
            return Err(format!("no lane leads from vertex {} to {}", w[0], w[1]));
        }
        Ok(())
    }

    fn reached(&mut self, id: &RobotId, vertex: u32) -> bool {
        let Some(mut r) = self.robots.remove(id) else { return false };
        let next = r.reached.map_or(0, |p| p + 1);
        let on = r.granted.is_some_and(|g| g >= next) && r.route.get(next) == Some(&vertex);
        if on {
            if let Some(p) = r.reached {
                let from = r.route[p];
                let left = std::mem::take(&mut r.left);
                for res in std::iter::once(from).filter(|_| !left).chain(self.layout.lane(from, vertex)) {
                    self.release(id, &mut r, res);
                }
            }
            r.reached = Some(next);
            r.lost = false;
        }
        self.robots.insert(id.clone(), r);
        on
    }

    /// The robot drives on from the vertex it last reached and is clear of it: that vertex is let
    /// go (once; the lane and the vertex ahead stay held).
    fn left(&mut self, id: &RobotId, vertex: u32) -> bool {
        let Some(r) = self.robots.get_mut(id) else { return false };
        let Some(p) = r.reached else { return false };
        if r.left || r.lost || r.route.get(p) != Some(&vertex) || r.granted.is_none_or(|g| g <= p) {
            return false;
        }
        r.left = true;
        let Some(mut r) = self.robots.remove(id) else { return false };
        self.release(id, &mut r, vertex);
        self.robots.insert(id.clone(), r);
        true
    }

    /// A lost robot keeps what it stood on or the hop it drove (it may still be there); its
    /// grants beyond are let go.
    fn lost(&mut self, id: &RobotId) {
        let Some(mut r) = self.robots.remove(id) else { return };
        let keep = match r.reached {
            Some(p) => r.granted.map(|g| g.min(p + 1)),
            None => r.granted.map(|_| 0),
        };
        while r.granted > keep {
            let g = r.granted.unwrap_or(0);
            for res in self.hop(&r.route, g) {
                self.release(id, &mut r, res);
            }
            r.granted = g.checked_sub(1);
        }
        r.lost = true;
        r.waiting = None;
        self.robots.insert(id.clone(), r);
    }

    fn release(&mut self, id: &RobotId, r: &mut Robot, res: Res) {
        if let Some(c) = r.held.get_mut(&res) {
            *c -= 1;
            if *c == 0 {
                r.held.remove(&res);
                if self.holder[res as usize].as_ref() == Some(id) {
                    self.holder[res as usize] = None;
                }
            }
        }
    }

    fn release_all(&mut self, id: &RobotId, r: &mut Robot) {
        for res in std::mem::take(&mut r.held).into_keys() {
            if self.holder[res as usize].as_ref() == Some(id) {
                self.holder[res as usize] = None;
            }
        }
    }
}
