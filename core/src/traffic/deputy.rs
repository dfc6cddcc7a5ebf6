//! A deputy of a map's traffic authority: a robot the authority names in its orders follows
//! everything the authority hears and says on the map — every robot's report, every order — and
//! takes over when central is away and the orders stopped. No I/O: [`Deputy::handle`] takes the
//! time and an [`Event`] and returns [`Command`]s.
//!
//! * **What it keeps is what the authority's successor needs**: each robot's last report and the
//!   last order it was given. What a robot holds is the newer of what it reported and what it was
//!   granted (a grant the robot did not report yet is held too), so a takeover grants nothing
//!   that robots already drive on — and needs no rebuild window ([`Authority::took_over`]).
//! * **In turn.** The authority names [`DEPUTIES`] robots; the one named `k`-th takes over once
//!   central's liveliness went and no order was heard for [`TAKEOVER_S`] + `k` × [`RANK_S`]: the
//!   first deputy's orders keep the second one waiting. A deputy takes over as `1 + k`
//!   incarnations above the highest it heard — two deputies that both took over are told apart,
//!   and the lower steps down when it hears the higher (robots take a deputy's orders only
//!   within [`mrmm_proto::traffic::DEPUTY_STEPS`] of central's).
//! * **Stepping down.** When central's liveliness comes back, or orders of a higher incarnation
//!   come (central started again, or another deputy), a deputy that took over stops giving
//!   orders and follows again.

use std::collections::BTreeMap;
use std::sync::Arc;

use mrmm_maps::Map;
use mrmm_proto::traffic::{TrafficHeld, TrafficReport, DEPUTIES, REPORT_S};
use mrmm_proto::{RobotId, Time, TrafficOrder};

use super::authority::{self, Authority, REBUILD_S};
use super::MAX_ROBOTS;
use crate::edge::{Incoming, Refused};

/// Seconds without an order, central away, before the first deputy takes over: every robot
/// reports every [`REPORT_S`] and is answered, so orders stop only when the authority did.
pub const TAKEOVER_S: f64 = REPORT_S + 0.2;
/// Seconds a deputy follows before it may take over: long enough to hear every robot report.
pub const FOLLOW_S: f64 = REBUILD_S;
/// Seconds more each deputy after the first waits: a deputy that takes over answers every robot
/// at once, so the next hears its orders well within this.
pub const RANK_S: f64 = 0.5 * REPORT_S;

/// Something the deputy heard.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    /// Central's liveliness appeared (`true`) or went.
    Central(bool),
    /// A robot's report on the map (its sender proven to be that robot).
    Report(TrafficReport),
    /// An order to `robot` on the map, from central or from a deputy (proven).
    Order { robot: RobotId, order: TrafficOrder },
    /// Time passed.
    Tick,
}

/// What the driver must do.
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    /// The authority's command (only once it took over).
    Authority(authority::Command),
    /// It took over as `incarnation` (for the log).
    TookOver { incarnation: u64 },
    /// It stopped giving orders: central is back, or orders of `incarnation` came.
    SteppedDown { incarnation: u64 },
}

/// A deputy of the traffic authority of one map.
pub struct Deputy {
    me: RobotId,
    hash: String,
    map: Arc<Map>,
    central: bool,
    /// Each robot's last report.
    reports: BTreeMap<RobotId, TrafficReport>,
    /// What each robot was last granted, as the orders said.
    granted: BTreeMap<RobotId, TrafficHeld>,
    /// When it last heard an order of another authority.
    last_order: Time,
    /// The highest incarnation it heard.
    incarnation: u64,
    /// Its place among the deputies, as the last order heard named them.
    rank: Option<usize>,
    /// The deputies the last order heard named.
    named: Vec<RobotId>,
    /// When it started following.
    since: Time,
    active: Option<Authority>,
}

impl std::fmt::Debug for Deputy {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Deputy").field("me", &self.me).field("rank", &self.rank).field("active", &self.active.is_some()).finish()
    }
}

impl Deputy {
    /// Robot `me`'s deputy for map `hash` (`map`), started at `now` with central alive or not.
    pub fn new(now: Time, me: RobotId, hash: String, map: Arc<Map>, central: bool) -> Deputy {
        Deputy {
            me,
            hash,
            map,
            central,
            reports: BTreeMap::new(),
            granted: BTreeMap::new(),
            last_order: now,
            incarnation: 0,
            rank: None,
            named: Vec::new(),
            since: now,
            active: None,
        }
    }

    /// What it hears on its map (`mrmm/traffic/<hash>/*/*`) as its event: a robot's report
    /// (from that robot), an order from central, or from a deputy named in the orders it
    /// follows while central is away (another's order could only make it step down or hold
    /// more; still, no one else's is taken).
    pub fn ingress(&self, m: Incoming<'_>) -> Result<Event, Refused> {
        use mrmm_proto::policy::{may_publish, Publication};
        let entitled = |p: Publication<'_>, from: &mrmm_proto::Sender| may_publish(p, from).map_err(|what| Refused::NotEntitled { from: from.clone(), what });
        match mrmm_proto::Key::parse(m.key) {
            Some(mrmm_proto::Key::TrafficReport { map, robot }) if map == self.hash => {
                let what = "traffic report";
                let from = m.from.ok_or(Refused::Unproven { what })?;
                entitled(Publication::TrafficReport(robot.as_str()), from)?;
                let report: TrafficReport = mrmm_proto::from_json_max(what, m.payload, mrmm_proto::traffic::MAX_MESSAGE)
                    .map_err(|e| Refused::Malformed { what, why: e.to_string() })?;
                if report.robot != robot {
                    return Err(Refused::Malformed { what, why: format!("the report of {:?} published on {}", report.robot, m.key) });
                }
                report.check().map_err(|why| Refused::Malformed { what, why })?;
                Ok(Event::Report(report))
            }
            Some(mrmm_proto::Key::TrafficOrder { map, robot }) if map == self.hash => {
                let what = "traffic order";
                let from = m.from.ok_or(Refused::Unproven { what })?;
                let deputy = from.role == mrmm_proto::Role::Robot && !self.central && self.named.iter().any(|d| d.as_str() == from.id);
                entitled(Publication::TrafficOrder { deputy }, from)?;
                let order: TrafficOrder = mrmm_proto::from_json_max(what, m.payload, mrmm_proto::traffic::MAX_MESSAGE)
                    .map_err(|e| Refused::Malformed { what, why: e.to_string() })?;
                order.check().map_err(|why| Refused::Malformed { what, why })?;
                Ok(Event::Order { robot, order })
            }
            _ => Err(Refused::Unexpected { key: m.key.chars().take(200).collect() }),
        }
    }

    /// What command `c` publishes: the orders it gives once it took over.
    pub fn egress(c: &Command) -> Option<crate::egress::Out> {
        match c {
            Command::Authority(c) => authority::egress(c),
            _ => None,
        }
    }

    /// Whether it took over and gives the orders now.
    pub fn active(&self) -> bool {
        self.active.is_some()
    }

    /// Its place among the deputies (none: not named in the last order heard).
    pub fn rank(&self) -> Option<usize> {
        self.rank
    }

    /// The authority it runs, once it took over.
    pub fn authority(&self) -> Option<&Authority> {
        self.active.as_ref()
    }

    pub fn handle(&mut self, now: Time, event: Event) -> Vec<Command> {
        match event {
            Event::Central(up) => {
                // Orders stopped when central did: the quiet is counted from the last one.
                self.central = up;
                match self.active.take() {
                    Some(a) if up => vec![Command::SteppedDown { incarnation: a.incarnation() }],
                    a => {
                        self.active = a;
                        Vec::new()
                    }
                }
            }
            Event::Report(report) => self.report(now, report),
            Event::Order { robot, order } => self.order(now, robot, order),
            Event::Tick => self.tick(now),
        }
    }

    fn report(&mut self, now: Time, report: TrafficReport) -> Vec<Command> {
        if report.check().is_err() {
            return Vec::new();
        }
        let newer = self.reports.get(&report.robot).is_none_or(|r| report.seq > r.seq);
        if newer && (self.reports.contains_key(&report.robot) || self.reports.len() < MAX_ROBOTS) {
            self.reports.insert(report.robot.clone(), report.clone());
        }
        match self.active.as_mut() {
            Some(a) => a.handle(now, authority::Event::Report { map: self.hash.clone(), report }).into_iter().map(Command::Authority).collect(),
            None => Vec::new(),
        }
    }

    fn order(&mut self, now: Time, robot: RobotId, order: TrafficOrder) -> Vec<Command> {
        if order.check().is_err() {
            return Vec::new();
        }
        let incarnation = match &order {
            TrafficOrder::Route { incarnation, .. } | TrafficOrder::Cleared { incarnation } => *incarnation,
            TrafficOrder::Free | TrafficOrder::Refused { .. } => return Vec::new(),
        };
        let mut out = Vec::new();
        if let Some(a) = &self.active {
            if incarnation == a.incarnation() {
                return out; // its own
            }
            if incarnation < a.incarnation() {
                return out; // an older authority's, still on the way
            }
            out.push(Command::SteppedDown { incarnation });
            self.active = None;
        }
        if incarnation < self.incarnation {
            return out;
        }
        self.incarnation = incarnation;
        self.last_order = now;
        let TrafficOrder::Route { version, route, reached, upto, deputies, .. } = order else {
            // Cleared by the operator: nothing of it is handed back at a takeover.
            self.reports.remove(&robot);
            self.granted.remove(&robot);
            return out;
        };
        self.rank = deputies.iter().position(|d| *d == self.me);
        self.named.clone_from(&deputies);
        let held = TrafficHeld { incarnation, version, route: route.iter().map(|v| v.v).collect(), reached, upto };
        let keep = match self.granted.get(&robot) {
            Some(g) => (incarnation, version) >= (g.incarnation, g.version),
            None => self.granted.len() < MAX_ROBOTS,
        };
        if keep {
            self.granted.insert(robot, held);
        }
        out
    }

    fn tick(&mut self, now: Time) -> Vec<Command> {
        if let Some(a) = self.active.as_mut() {
            return a.handle(now, authority::Event::Tick).into_iter().map(Command::Authority).collect();
        }
        let Some(rank) = self.rank.filter(|&r| r < DEPUTIES) else { return Vec::new() };
        let (quiet, followed) = (now - self.last_order, now - self.since);
        let turn = rank as f64 * RANK_S;
        if self.central || quiet < TAKEOVER_S + turn || followed < FOLLOW_S + turn || self.reports.is_empty() {
            return Vec::new();
        }
        // Above all it heard, and apart from every other deputy's: two that both took over
        // (neither heard the other) are told apart, the higher one obeyed.
        let incarnation = self.incarnation + 1 + rank as u64;
        let heard: Vec<(String, TrafficReport)> = self.reports.values().map(|r| (self.hash.clone(), self.merged(r))).collect();
        tracing::info!(deputy = %self.me, incarnation, robots = heard.len(), "traffic: central away and no orders for {:.1} s: taking over", now - self.last_order);
        let (a, cmds) = Authority::took_over(now, self.me.clone(), incarnation, [(self.hash.clone(), self.map.clone())], heard);
        self.active = Some(a);
        self.incarnation = incarnation;
        let mut out = vec![Command::TookOver { incarnation }];
        out.extend(cmds.into_iter().map(Command::Authority));
        out
    }

    /// Robot `r`'s report with what it holds as the newer of its own word and its last order
    /// (a robot that stopped — no goal — drives no further than it says: it gave the rest back).
    fn merged(&self, r: &TrafficReport) -> TrafficReport {
        let mut r = r.clone();
        let Some(g) = self.granted.get(&r.robot) else { return r };
        let stopped = r.goal.is_none();
        r.held = match r.held.take() {
            Some(h) if (h.incarnation, h.version) > (g.incarnation, g.version) => Some(h),
            Some(h) if (h.incarnation, h.version) == (g.incarnation, g.version) => {
                let upto = if stopped { h.upto } else { h.upto.max(g.upto) };
                Some(TrafficHeld { upto, ..h })
            }
            _ => Some(g.clone()),
        };
        r
    }
}

impl crate::machine::Machine for Deputy {
    type Event = Event;
    type Command = Command;

    fn handle(&mut self, now: Time, event: Event) -> Vec<Command> {
        Deputy::handle(self, now, event)
    }

    /// A deputy keeps nothing: it publishes the orders it gives; the rest is its log.
    fn effect(command: &Command) -> crate::machine::Effect {
        match command {
            Command::Authority(authority::Command::Order { .. }) => crate::machine::Effect::Publish,
            Command::Authority(authority::Command::Blocked { .. }) | Command::TookOver { .. } | Command::SteppedDown { .. } => crate::machine::Effect::Local,
        }
    }
}

#[cfg(test)]
mod tests {
    use mrmm_maps::Point;
    use mrmm_proto::traffic::TrafficGoal;

    use super::*;
    use crate::at;

    fn office() -> Arc<Map> {
        let (name, text) = mrmm_maps::data::OPEN_RMF[0];
        Arc::new(Map::Graph(mrmm_maps::rmf::parse(name, text).expect("office graph")))
    }

    fn report(robot: &str, seq: u64, at: Point, goal: Option<Point>) -> TrafficReport {
        TrafficReport { robot: robot.into(), seq, x: at.x, y: at.y, goal: goal.map(|g| TrafficGoal { id: 1, x: g.x, y: g.y }), held: None, docked: false }
    }

    /// Central's traffic authority on `map` (by its hash) and robot b's deputy following it.
    fn central_and_deputy(map: &Arc<Map>) -> (String, Authority, Deputy) {
        let hash = "h".repeat(64);
        let central = Authority::new(at(-10.0), 1, [(hash.clone(), map.clone())]);
        let deputy = Deputy::new(at(0.0), "b".into(), hash.clone(), map.clone(), true);
        (hash, central, deputy)
    }

    /// Central's liveliness goes at `gone`: the deputy takes over within `within` seconds.
    fn central_dies(deputy: &mut Deputy, gone: f64, within: f64) {
        deputy.handle(at(gone), Event::Central(false));
        let mut t = gone;
        while !deputy.active() && t < gone + within {
            t += 0.1;
            deputy.handle(at(t), Event::Tick);
        }
        assert!(deputy.active(), "the deputy did not take over");
    }

    /// A grant central gave that the robot had not reported yet when central died is held by
    /// the deputy that takes over: it follows orders, not only reports. Robot b was granted a
    /// part of its route; robot a (routed first: robots in id order), standing on the vertex
    /// after, wants the vertex where b's grant ends.
    #[test]
    fn a_deputy_holds_what_central_granted_that_no_robot_reported_yet() {
        let map = office();
        let Map::Graph(g) = map.as_ref() else { unreachable!() };
        let (hash, mut central, mut deputy) = central_and_deputy(&map);
        let hear = |central: &mut Authority, deputy: &mut Deputy, t: f64, r: TrafficReport| {
            let mut granted = None;
            deputy.handle(at(t), Event::Report(r.clone()));
            for c in central.handle(at(t), authority::Event::Report { map: hash.clone(), report: r }) {
                if let authority::Command::Order { robot, order, .. } = c {
                    if let TrafficOrder::Route { route, upto, .. } = &order {
                        let all: Vec<u32> = route.iter().map(|v| v.v).collect();
                        let at: Vec<Point> = route.iter().map(|v| Point::new(v.x, v.y)).collect();
                        granted = upto.map(|u| (all[..=u as usize].to_vec(), all, at));
                    }
                    deputy.handle(at(t), Event::Order { robot, order });
                }
            }
            granted
        };
        // Robot b stands on a vertex and goes to the vertex farthest from it.
        let start = g.vertices[0].at;
        let far = g.vertices.iter().map(|v| v.at).max_by(|p, q| start.dist(*p).total_cmp(&start.dist(*q))).expect("vertices");
        hear(&mut central, &mut deputy, 0.0, report("b", 1, start, None));
        let (path, route, at) = hear(&mut central, &mut deputy, 0.5, report("b", 2, start, Some(far))).expect("central granted b a part of its route");
        let end = *path.last().expect("a vertex");
        assert!(path.len() >= 2 && route.len() > path.len(), "b was granted no lane, or all its route: {path:?} of {route:?}");
        // Robot a stands on the vertex after b's grant's end, and goes to that end.
        // (Traffic cuts long lanes: the route's vertices are not all the map's own.)
        let a_at = at[path.len()];
        hear(&mut central, &mut deputy, 0.6, report("a", 1, a_at, None));
        hear(&mut central, &mut deputy, 0.7, report("a", 2, a_at, Some(at[path.len() - 1])));
        assert!(deputy.rank().is_some(), "b is not named a deputy");
        // Central dies before b reports what it was granted.
        central_dies(&mut deputy, 1.0, 4.0);
        let traffic = deputy.authority().and_then(|a| a.traffic(&hash)).expect("traffic on the map");
        let (route, _, upto, _) = traffic.state(&"b".into()).expect("b in traffic");
        assert!(
            upto.is_some_and(|u| route[..=u].contains(&end)),
            "the deputy does not hold what central granted b (up to vertex {end}): {}; {}",
            traffic.describe(&"b".into()),
            traffic.describe(&"a".into())
        );
    }

    /// A robot that stopped (its mission paused) while central's answer to that was lost, central
    /// dying: the deputy that takes over holds for it only what it says it holds, not the rest of
    /// central's last grant (which the robot gave back, and would drive again were it granted).
    #[test]
    fn a_deputy_takes_a_stopped_robots_word_over_centrals_last_grant() {
        let map = office();
        let Map::Graph(g) = map.as_ref() else { unreachable!() };
        let (hash, mut central, mut deputy) = central_and_deputy(&map);
        let mut last = None;
        let start = g.vertices[0].at;
        let far = g.vertices.iter().map(|v| v.at).max_by(|p, q| start.dist(*p).total_cmp(&start.dist(*q))).expect("vertices");
        for (t, seq, goal) in [(0.0, 1, None), (0.5, 2, Some(far)), (0.6, 3, Some(far))] {
            let r = report("b", seq, start, goal);
            deputy.handle(at(t), Event::Report(r.clone()));
            for c in central.handle(at(t), authority::Event::Report { map: hash.clone(), report: r }) {
                if let authority::Command::Order { robot, order, .. } = c {
                    last = Some(order.clone());
                    deputy.handle(at(t), Event::Order { robot, order });
                }
            }
        }
        let Some(TrafficOrder::Route { incarnation, version, route, reached, upto, .. }) = last else { panic!("b was not routed: {last:?}") };
        assert!(upto > reached, "b was granted nothing beyond where it stands");
        // b stops where it stands: its report says so; central's answer never comes.
        let held = TrafficHeld { incarnation, version, route: route.iter().map(|v| v.v).collect(), reached, upto: reached };
        deputy.handle(at(0.7), Event::Report(TrafficReport { held: Some(held), ..report("b", 4, start, None) }));
        central_dies(&mut deputy, 1.0, 4.0);
        let traffic = deputy.authority().and_then(|a| a.traffic(&hash)).expect("traffic on the map");
        let (_, at, granted, _) = traffic.state(&"b".into()).expect("b in traffic");
        assert_eq!(granted, at, "the deputy holds more than the stopped robot does: {}", traffic.describe(&"b".into()));
    }

    /// A robot the operator took off the lanes at central is not handed back what it held when a
    /// deputy takes over: the deputy heard it cleared.
    #[test]
    fn a_robot_cleared_at_central_stays_cleared_after_a_takeover() {
        let map = office();
        let Map::Graph(g) = map.as_ref() else { unreachable!() };
        let (hash, mut central, mut deputy) = central_and_deputy(&map);
        let tell = |deputy: &mut Deputy, t: f64, cmds: Vec<authority::Command>| {
            for c in cmds {
                if let authority::Command::Order { robot, order, .. } = c {
                    deputy.handle(at(t), Event::Order { robot, order });
                }
            }
        };
        let hear = |central: &mut Authority, deputy: &mut Deputy, t: f64, r: TrafficReport| {
            deputy.handle(at(t), Event::Report(r.clone()));
            let cmds = central.handle(at(t), authority::Event::Report { map: hash.clone(), report: r });
            tell(deputy, t, cmds);
        };
        // r1 stands on one vertex; b stands on another and drives to a third.
        let (v0, v1, v2) = (g.vertices[0].at, g.vertices[g.vertices.len() / 2].at, g.vertices[g.vertices.len() - 1].at);
        hear(&mut central, &mut deputy, 0.0, report("r1", 1, v1, None));
        hear(&mut central, &mut deputy, 0.1, report("b", 1, v0, None));
        hear(&mut central, &mut deputy, 0.2, report("b", 2, v0, Some(v2)));
        assert!(central.traffic(&hash).is_some_and(|t| !t.held(&"r1".into()).is_empty()), "r1 holds its vertex");
        // r1's liveliness goes; the operator clears it at central.
        central.handle(at(1.0), authority::Event::Gone("r1".into()));
        let cmds = central.handle(at(1.0 + authority::LOST_GRACE_S + 0.1), authority::Event::Tick);
        tell(&mut deputy, 1.0 + authority::LOST_GRACE_S + 0.1, cmds);
        let (_, cmds) = central.clear(at(10.0), &"r1".into()).expect("cleared");
        tell(&mut deputy, 10.0, cmds);
        // b reports on, as robots do (a robot is named once it was heard lately).
        hear(&mut central, &mut deputy, 10.1, report("b", 3, v0, Some(v2)));
        hear(&mut central, &mut deputy, 10.2, report("b", 4, v0, Some(v2)));
        assert!(deputy.rank().is_some(), "b is not named a deputy");
        // Central dies; b's deputy takes over.
        central_dies(&mut deputy, 10.3, 9.7);
        let traffic = deputy.authority().and_then(|a| a.traffic(&hash)).expect("traffic on the map");
        assert!(traffic.state(&"r1".into()).is_none(), "the cleared robot was handed back what it held: {}", traffic.describe(&"r1".into()));
    }
}
