//! A robot on a graph map drives only what traffic grants: the plan's navigate steps become
//! goals it reports to its map's traffic authority, whose orders say the route along the lanes
//! and how far of it the robot may drive ([`mrmm_proto::traffic`]). The [`Gate`] drives the
//! body vertex by vertex up to the grant's end, and starts no new lane once it has heard no order
//! for [`QUIET_S`]: a robot that lost its authority stops at the end of the lane it is on. A goal
//! off the lanes is reached at the vertex nearest it, or, where the order says the way there is
//! clear (`off`), driven to straight from that vertex — and the robot drives back to the vertex
//! before anything else. A map without lanes is answered [`TrafficOrder::Free`], and the plan is
//! driven as it is.

use std::collections::VecDeque;

use mrmm_proto::traffic::{RouteVertex, TrafficGoal, TrafficHeld, TrafficReport, DEPUTY_STEPS, QUIET_S, REPORT_S};
use mrmm_proto::{MapRef, RobotId, Time, TrafficOrder};

use crate::body::drive::Drive;

/// A vertex counts as reached within this distance of the body (metres).
pub const REACH: f64 = 0.15;
/// Vertices of the route driven that the robot remembers (to match a new order to where it is).
const TRAIL: usize = 16;

/// The goal the plan drives to.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Goal {
    id: u64,
    x: f64,
    y: f64,
    speed: Option<f64>,
}

/// The order the robot drives by.
#[derive(Debug, Clone, PartialEq)]
struct Held {
    goal: u64,
    incarnation: u64,
    version: u64,
    route: Vec<RouteVertex>,
    reached: Option<usize>,
    upto: Option<usize>,
    /// The goal off the lanes, driven to from the route's last vertex.
    off: Option<[f64; 2]>,
}

/// What a robot on a map does with traffic.
#[derive(Debug, Clone)]
pub struct Gate {
    map: MapRef,
    /// The map has no lanes: the plan is driven as it is.
    free: bool,
    goal: Option<Goal>,
    next_goal: u64,
    held: Option<Held>,
    /// The vertices it reached last, oldest first.
    trail: VecDeque<u32>,
    /// The vertex the body drives to.
    driving: Option<RouteVertex>,
    /// Why the goal was refused.
    refused: Option<String>,
    heard: Time,
    reported: Option<Time>,
    changed: bool,
    seq: u64,
    /// The robots the authority named to take over from it (central away).
    deputies: Vec<RobotId>,
    /// The highest incarnation of central's own orders heard: a deputy's may be at most
    /// [`DEPUTY_STEPS`] above it.
    central_incarnation: u64,
    /// At the last step: a goal to go to, and the robot stands waiting for traffic.
    waiting: bool,
    /// It drove off the lanes from this vertex (to the goal an order's `off` named, for goal
    /// `.1`, at `.2`): back there before it drives anything else.
    left: Option<(RouteVertex, u64, [f64; 2])>,
    /// Taken off the lanes: it stops at its next step, even on a lane (it holds nothing).
    halt: bool,
    /// The hop (incarnation, version, position of the vertex behind) on which it passed the point
    /// where that vertex is let go ([`RouteVertex::release`]), and reported it.
    released: Option<(u64, u64, usize)>,
}

impl Gate {
    pub fn new(map: MapRef) -> Gate {
        Gate {
            map,
            free: false,
            goal: None,
            next_goal: 0,
            held: None,
            trail: VecDeque::new(),
            driving: None,
            refused: None,
            heard: Time::LONG_AGO,
            reported: None,
            changed: true,
            seq: 0,
            deputies: Vec::new(),
            central_incarnation: 0,
            waiting: false,
            left: None,
            halt: false,
            released: None,
        }
    }

    /// Whether the robot stood waiting for traffic at the last step: a goal not reached, its next
    /// lane not granted (or no route yet, or no orders heard for [`QUIET_S`]).
    pub fn waiting(&self) -> bool {
        self.waiting
    }

    /// The robots the authority named its deputies on this map.
    pub fn deputies(&self) -> &[RobotId] {
        &self.deputies
    }

    pub fn map(&self) -> &MapRef {
        &self.map
    }

    /// Traffic said the map has no lanes.
    pub fn free(&self) -> bool {
        self.free
    }

    /// Why the last goal cannot be driven to, if it cannot.
    pub fn refused(&self) -> Option<&str> {
        self.refused.as_deref()
    }

    /// The plan drives to (x, y): a new goal, reported at once.
    pub fn navigate(&mut self, x: f64, y: f64, speed: Option<f64>) {
        self.next_goal += 1;
        self.goal = Some(Goal { id: self.next_goal, x, y, speed });
        self.refused = None;
        self.changed = true;
    }

    /// The plan holds (a hold step, its mission paused, the plan over) or the operator holds the
    /// robot: it has no goal, stops at the end of the lane it drives (a body that drives on
    /// through its grant — a VDA 5050 vehicle — where its hold paused it) and gives back what it
    /// was granted beyond: it reports that it holds no further, and traffic cuts its route there
    /// (answering with goal 0). Grants of that route heard meanwhile do not take it further; a
    /// new route of traffic's for it (a step aside for another robot) it drives.
    pub fn stop(&mut self) {
        if self.goal.take().is_none() {
            return;
        }
        self.changed = true;
        self.waiting = false;
        if let Some(h) = self.held.as_mut() {
            let next = h.reached.map_or(0, |p| p + 1);
            let on_lane = self.driving.as_ref().is_some_and(|v| h.route.get(next).is_some_and(|r| r.v == v.v));
            h.upto = h.upto.min(if on_lane { Some(next) } else { h.reached });
        }
    }

    /// An order of the map's traffic authority, heard at `now` (`deputy`: from one of its
    /// deputies, central away).
    pub fn order(&mut self, now: Time, order: TrafficOrder, deputy: bool) {
        if order.check().is_err() {
            return;
        }
        if let TrafficOrder::Route { incarnation, deputies, .. } = &order {
            if deputy && *incarnation > self.central_incarnation.saturating_add(DEPUTY_STEPS) {
                tracing::warn!(map = %self.map.name, incarnation, "a deputy's traffic order far above central's incarnation: ignored");
                return;
            }
            if !deputy {
                self.central_incarnation = self.central_incarnation.max(*incarnation);
            }
            if self.held.as_ref().is_none_or(|h| *incarnation >= h.incarnation) {
                self.deputies.clone_from(deputies);
            }
        }
        self.heard = now;
        // Stopped, it takes routes of traffic's that know it stopped (goal 0) and no grant further.
        let goal = self.goal.map_or(0, |g| g.id);
        match order {
            TrafficOrder::Free => self.free = true,
            TrafficOrder::Refused { goal: g, why } if g == goal && goal != 0 => self.refused = Some(why),
            TrafficOrder::Refused { .. } => {}
            // Taken off the lanes while it was away: what it held is others' now. It stops and
            // asks for its way anew.
            TrafficOrder::Cleared { .. } if !deputy => {
                if self.held.take().is_some() {
                    tracing::warn!(map = %self.map.name, "taken off the lanes by the operator: asking for the way anew");
                    self.changed = true;
                    self.halt = true;
                }
            }
            TrafficOrder::Cleared { .. } => {}
            TrafficOrder::Route { goal: g, incarnation, version, route, reached, upto, off, .. } => {
                let newer = self.held.as_ref().is_none_or(|h| (incarnation, version) > (h.incarnation, h.version));
                let same = self.held.as_ref().is_some_and(|h| (incarnation, version) == (h.incarnation, h.version));
                let stopped = self.goal.is_none();
                if same {
                    // The authority's word on how far, as it is now (it only takes a grant back
                    // from a robot it lost, which has stopped by then).
                    if let Some(h) = self.held.as_mut() {
                        let upto = upto.map(|u| u as usize).filter(|&u| h.reached.is_none_or(|r| u >= r)).or(h.reached);
                        h.upto = if stopped { upto.min(h.upto) } else { upto };
                        h.off = off;
                    }
                } else if newer && (g == goal || (!stopped && self.held.is_some())) {
                    if self.held.as_ref().is_some_and(|h| h.incarnation != incarnation) {
                        tracing::info!(map = %self.map.name, incarnation, "a new traffic authority: driving by its orders");
                    }
                    let reached = self.where_on(&route, reached.map(|p| p as usize));
                    let upto = upto.map(|u| u as usize).max(reached);
                    self.held = Some(Held { goal: g, incarnation, version, route, reached, upto, off });
                    self.refused = None;
                    self.changed = true;
                }
            }
        }
    }

    /// Where on `route` the robot is: the authority said `said`; the robot may have reached
    /// vertices beyond it since (its trail goes on along the route).
    fn where_on(&self, route: &[RouteVertex], said: Option<usize>) -> Option<usize> {
        let start = said.or_else(|| (self.trail.back() == route.first().map(|v| &v.v)).then_some(0))?;
        let Some(p) = self.trail.iter().rposition(|&v| v == route[start].v) else { return Some(start) };
        let mut j = start;
        for &v in self.trail.iter().skip(p + 1) {
            if route.get(j + 1).is_some_and(|r| r.v == v) {
                j += 1;
            } else {
                break;
            }
        }
        Some(j)
    }

    /// Drives the body on at `now`; whether the goal is reached (the plan goes on).
    pub fn step(&mut self, now: Time, body: &mut Drive) -> bool {
        self.waiting = false;
        if std::mem::take(&mut self.halt) {
            body.hold();
            (self.driving, self.left) = (None, None);
        }
        let pose = body.pose();
        let near = |x: f64, y: f64| (pose.x - x).hypot(pose.y - y) <= REACH;
        let quiet = now - self.heard > QUIET_S;
        if let Some(v) = self.driving.clone() {
            if !body.idle() {
                if body.drives_on() && !quiet {
                    self.tell_grant(&v, body);
                }
                self.passing(&v, pose.x, pose.y);
                return false;
            }
            if !near(v.x, v.y) && !body.passed(&v) {
                if body.drives_on() && self.goal.is_none() {
                    return true; // paused on the lane, which it holds, until its next goal
                }
                // Stopped on the lane (held by the plan): on to the vertex, the lane is ours.
                body.navigate_vertex(&v, self.goal.and_then(|g| g.speed));
                return false;
            }
            self.driving = None;
            self.trail.push_back(v.v);
            if self.trail.len() > TRAIL {
                self.trail.pop_front();
            }
            if let Some(h) = self.held.as_mut() {
                let next = h.reached.map_or(0, |p| p + 1);
                if h.route.get(next).is_some_and(|r| r.v == v.v) {
                    h.reached = Some(next);
                }
            }
            self.changed = true;
        }
        let Some(goal) = self.goal else { return self.step_stopped(quiet, body) };
        if self.held.is_none() {
            self.waiting = self.refused.is_none();
            return false;
        }
        if self.on_way_back(goal, quiet, body) {
            return false;
        }
        let Some(h) = self.held.as_ref() else { return false };
        let next = h.reached.map_or(0, |p| p + 1);
        if next < h.route.len() {
            if !quiet && h.upto.is_some_and(|u| next <= u) {
                let v = &h.route[next];
                self.driving = Some(v.clone());
                let (granted, then) = Self::beyond(h, next);
                body.navigate_lane(v, granted, then, goal.speed);
            } else {
                self.waiting = true;
            }
            return false;
        }
        // At the route's last vertex, the one nearest the goal: a point off the lanes is driven
        // to only where the order says the way there is clear.
        if h.goal != goal.id {
            return false;
        }
        match h.off {
            Some(at) if !quiet || self.left.is_some() => {
                if near(at[0], at[1]) {
                    return body.idle();
                }
                if body.idle() {
                    self.left = Some((h.route[h.route.len() - 1].clone(), goal.id, at));
                    body.navigate_through(at[0], at[1], None, goal.speed);
                }
                false
            }
            // A way off the lanes was given, but traffic went quiet before the robot set out on
            // it: it waits at the vertex for traffic's word (the goal is not reached).
            Some(_) => {
                self.waiting = true;
                false
            }
            None => body.idle(),
        }
    }

    /// Stopped (no goal): it drives only a new route of traffic's (a step aside), as far as
    /// granted; whether it stands.
    fn step_stopped(&mut self, quiet: bool, body: &mut Drive) -> bool {
        let Some(h) = self.held.as_ref().filter(|_| self.left.is_none()) else { return body.idle() };
        let next = h.reached.map_or(0, |p| p + 1);
        if quiet || next >= h.route.len() || h.upto.is_none_or(|u| next > u) {
            return body.idle();
        }
        let v = &h.route[next];
        self.driving = Some(v.clone());
        let (granted, then) = Self::beyond(h, next);
        body.navigate_lane(v, granted, then, None);
        false
    }

    /// Off the lanes: it stays while its order still gives that way for its goal; else it drives
    /// back to the vertex it left them at first (the way back is the way there). Whether it is on
    /// its way back there (the step ends).
    fn on_way_back(&mut self, goal: Goal, quiet: bool, body: &mut Drive) -> bool {
        let (Some((v, for_goal, at)), Some(h)) = (self.left.clone(), self.held.as_ref()) else { return false };
        let last = h.route.len() - 1;
        let stays = for_goal == goal.id && h.goal == goal.id && h.off == Some(at) && h.reached == Some(last) && h.route[last].v == v.v;
        if stays {
            return false;
        }
        let pose = body.pose();
        if (pose.x - v.x).hypot(pose.y - v.y) <= REACH {
            self.left = None;
            return false;
        }
        if !self.drive_back_on(&v, goal, quiet, body) && (body.idle() || body.goal() != Some((v.x, v.y))) {
            body.navigate_vertex(&v, goal.speed);
        }
        true
    }

    /// A body that drives on through its grant, on its way back from off the lanes to vertex `v`,
    /// whose order for `goal` goes on from `v` with more granted: it is told that way at once, to
    /// drive back to `v` and on through it (`v` is still the first vertex it drives to, as
    /// traffic's rule wants, and what lies past it is granted). Whether it was.
    fn drive_back_on(&mut self, v: &RouteVertex, goal: Goal, quiet: bool, body: &mut Drive) -> bool {
        let Some(h) = self.held.as_ref() else { return false };
        let from_v = h.reached.is_some_and(|r| h.route.get(r).is_some_and(|x| x.v == v.v) && h.upto.is_some_and(|u| u > r));
        if !body.drives_on() || quiet || h.goal != goal.id || !from_v {
            return false;
        }
        self.left = None;
        self.driving = Some(v.clone());
        self.tell_grant(v, body);
        true
    }

    /// A body that drives on through its grant (driving to `v`: the route's next vertex, or the
    /// one it reached in traffic's eyes, when it drives back there) is told the grant as it grows.
    fn tell_grant(&self, v: &RouteVertex, body: &mut Drive) {
        let Some(h) = &self.held else { return };
        let next = h.reached.map_or(0, |p| p + 1);
        let at = if h.route.get(next).is_some_and(|r| r.v == v.v) {
            next
        } else if let Some(r) = h.reached.filter(|&r| h.route.get(r).is_some_and(|x| x.v == v.v)) {
            r
        } else {
            return;
        };
        let (granted, then) = Self::beyond(h, at);
        body.navigate_lane(v, granted, then, self.goal.and_then(|g| g.speed));
    }

    /// Driving to `v` from the vertex it reached last, at (`x`, `y`): a report as it passes the
    /// point where that vertex is let go (once per hop), so that the robot following closes up
    /// at once. Off the lane's line, the authority may find it not yet clear; its next periodic
    /// report tells again.
    fn passing(&mut self, v: &RouteVertex, x: f64, y: f64) {
        let Some(h) = &self.held else { return };
        let Some(p) = h.reached else { return };
        let (Some(u), Some(n)) = (h.route.get(p), h.route.get(p + 1)) else { return };
        let hop = (h.incarnation, h.version, p);
        let Some(d) = u.release.filter(|_| n.v == v.v && self.released != Some(hop)) else { return };
        let len = (n.x - u.x).hypot(n.y - u.y);
        if len > 0.0 && ((x - u.x) * (n.x - u.x) + (y - u.y) * (n.y - u.y)) / len >= d {
            self.released = Some(hop);
            self.changed = true;
        }
    }

    /// The route after its vertex `next`: what traffic granted of it, and the rest.
    fn beyond(h: &Held, next: usize) -> (&[RouteVertex], &[RouteVertex]) {
        let end = h.upto.map_or(next, |u| u.max(next)).min(h.route.len() - 1);
        (&h.route[next + 1..=end], &h.route[end + 1..])
    }

    /// The report due at `now`, if one is: at every change, and every [`REPORT_S`].
    pub fn report(&mut self, now: Time, robot: &RobotId, body: &Drive) -> Option<TrafficReport> {
        if self.free || !(self.changed || self.reported.is_none_or(|t| now - t >= REPORT_S)) {
            return None;
        }
        self.changed = false;
        self.reported = Some(now);
        // Wall-clock milliseconds, so that a robot restarted is not taken for a stale one.
        self.seq = (self.seq + 1).max((now.secs() * 1000.0) as u64);
        let pose = body.pose();
        // Plugged in, it stopped (`Robot::charge`): docked until a goal takes it away.
        let docked = self.goal.is_none() && self.driving.is_none() && body.battery().is_some_and(|b| b.charging);
        Some(TrafficReport {
            robot: robot.clone(),
            seq: self.seq,
            x: pose.x,
            y: pose.y,
            goal: self.goal.map(|g| TrafficGoal { id: g.id, x: g.x, y: g.y }),
            held: self.held.as_ref().map(|h| TrafficHeld {
                incarnation: h.incarnation,
                version: h.version,
                route: h.route.iter().map(|v| v.v).collect(),
                reached: h.reached.map(|p| p as u32),
                upto: h.upto.map(|p| p as u32),
            }),
            docked,
        })
    }
}
