//! A mission this node leads: its mission manager, what it waits to do until the chain has
//! committed the state that asked for it, and the plans it is delivering. Pure; the host core
//! calls it and turns what it returns into commands.

use std::collections::BTreeMap;

use mrmm_proto::{CtlAck, PlanAssignment, PlanSummary, RobotId, Telemetry, Time, SUMMARY_REFRESH_S};

use crate::mission::{self, MissionManager};

/// Seconds between two sends of a plan a robot has not yet shown it runs.
pub const REDELIVER_S: f64 = 2.0;
/// Plan requests retried at most this many times per epoch when no planner answered.
pub const PLAN_RETRIES: u32 = 3;
/// Plans of one mission on their way at once (sent, not answered): a 500-robot team is handed
/// its plans 32 at a time, each answer letting the next one go, instead of 500 queries at once.
pub const DELIVERY_WINDOW: usize = 32;
/// A plan sent this long ago without an answer no longer holds a place in the window (its
/// query's answer, even a timeout, was lost).
const IN_FLIGHT_STALE_S: f64 = crate::timeouts::ROBOT_PLAN_S + REDELIVER_S;

/// A plan on its way to a robot: re-sent until the robot's telemetry (or its answer) shows it.
#[derive(Debug, Clone, PartialEq)]
pub struct Delivery {
    pub assignment: Box<PlanAssignment>,
    /// When it was last sent (`None`: waiting for a place in the window).
    pub last_sent: Option<Time>,
    /// Sent and not answered yet: it holds a place in the window.
    pub in_flight: bool,
}

impl Delivery {
    fn holds_place(&self, now: Time) -> bool {
        self.in_flight && self.last_sent.is_some_and(|t| now - t < IN_FLIGHT_STALE_S)
    }
}

/// A mission this node leads.
#[derive(Debug, Clone)]
pub struct Head {
    pub mm: MissionManager,
    /// The start query, answered once the first plans are out (and committed).
    pub start: Option<u64>,
    /// Effects waiting for the chain to commit the state that produced them.
    pending: Vec<mission::Command>,
    /// Answers to control queries, waiting for the commit of what they changed.
    replies: Vec<(u64, CtlAck)>,
    /// Plans being delivered, by robot.
    deliveries: BTreeMap<RobotId, Delivery>,
    /// The epoch of the last plan request, and how often it was asked again.
    requested: Option<(u64, u32)>,
    /// Members whose telemetry shows they do not run the current plan (they restarted, say),
    /// and since when.
    astray: BTreeMap<RobotId, Time>,
    /// The last plan sent to each robot (sent only once committed).
    sent: BTreeMap<RobotId, Box<PlanAssignment>>,
    /// What the mission's status last carried of the planner's summary.
    summary: SummaryGate,
    /// Lost members central ordered back while their token was gone here, and when: one whose
    /// token comes up within [`ORDERED_BACK_S`] is taken back then (central orders only once,
    /// and this host may hear the robot come back after central did).
    pub ordered_back: BTreeMap<RobotId, Time>,
}

/// How long an order to take back a member whose token was gone here holds (two roll calls
/// and their answers: `crate::roll_call`).
pub const ORDERED_BACK_S: f64 = 2.0 * (crate::roll_call::ROLL_CALL_S + crate::roll_call::ANSWER_S);

/// Decides which statuses carry the planner's summary (the tour, the coverage points: O(team)
/// bytes): the one after it changed, and one every [`SUMMARY_REFRESH_S`] seconds for subscribers
/// that came later. Holds the summary last carried and when.
#[derive(Debug, Clone, Default)]
pub struct SummaryGate(Option<(PlanSummary, Time)>);

impl SummaryGate {
    /// Whether the status published at `now`, whose summary is `summary`, carries it.
    pub fn carries(&mut self, now: Time, summary: Option<&PlanSummary>) -> bool {
        let Some(s) = summary else {
            self.0 = None;
            return true;
        };
        match &self.0 {
            Some((last, at)) if last == s && now - *at < SUMMARY_REFRESH_S => false,
            _ => {
                self.0 = Some((s.clone(), now));
                true
            }
        }
    }
}

impl Head {
    pub fn new(mm: MissionManager, start: Option<u64>) -> Self {
        Head {
            mm,
            start,
            pending: Vec::new(),
            replies: Vec::new(),
            deliveries: BTreeMap::new(),
            requested: None,
            astray: BTreeMap::new(),
            sent: BTreeMap::new(),
            summary: SummaryGate::default(),
            ordered_back: BTreeMap::new(),
        }
    }

    /// Whether the mission's status published at `now` carries the planner's summary.
    pub fn carries_summary(&mut self, now: Time, summary: Option<&PlanSummary>) -> bool {
        self.summary.carries(now, summary)
    }

    /// Runs one mission event; returns the plan requests to make now (everything else waits for
    /// the commit).
    pub fn run(&mut self, now: Time, ev: mission::Event) -> Vec<mission::Command> {
        let cmds = self.mm.handle(now, ev);
        self.defer(cmds)
    }

    /// Keeps effects for the commit; returns the plan requests, which are made at once.
    pub fn defer(&mut self, cmds: Vec<mission::Command>) -> Vec<mission::Command> {
        let mut now = Vec::new();
        for c in cmds {
            match c {
                mission::Command::RequestPlan { epoch, .. } => {
                    self.requested = Some((epoch, 0));
                    now.push(c);
                }
                other => self.pending.push(other),
            }
        }
        now
    }

    /// Whether a plan was asked for the current epoch already.
    pub fn asked_for_current(&self) -> bool {
        self.requested.is_some_and(|(e, _)| e == self.mm.epoch())
    }

    /// A planner did not answer a request of `epoch`: whether to ask again (the current epoch,
    /// fewer than [`PLAN_RETRIES`] times).
    pub fn retry_plan(&mut self, epoch: u64) -> bool {
        match &mut self.requested {
            Some((e, n)) if *e == epoch && epoch == self.mm.epoch() && *n < PLAN_RETRIES => {
                *n += 1;
                true
            }
            _ => false,
        }
    }

    /// An answer to a control query, once what it changed is committed.
    pub fn reply_on_commit(&mut self, query: u64) {
        let ack = CtlAck { ok: true, epoch: self.mm.epoch() };
        self.replies.push((query, ack));
    }

    /// Everything that waited for the commit: effects and control answers.
    pub fn committed(&mut self) -> (Vec<mission::Command>, Vec<(u64, CtlAck)>) {
        (std::mem::take(&mut self.pending), std::mem::take(&mut self.replies))
    }

    /// Control queries still waiting (to be dropped when this node stops leading).
    pub fn waiting_queries(&self) -> Vec<u64> {
        self.replies.iter().map(|(q, _)| *q).collect()
    }

    /// A plan for `robot` is to go out now: whether it goes at once (`false`: it waits for a
    /// place in the window, and goes out from [`Head::redeliver`] or [`Head::answered`]).
    pub fn sending(&mut self, now: Time, robot: &str, assignment: Box<PlanAssignment>) -> bool {
        self.sent.insert(robot.into(), assignment.clone());
        let go = self.in_flight(now) < DELIVERY_WINDOW;
        self.deliveries.insert(robot.into(), Delivery { assignment, last_sent: go.then_some(now), in_flight: go });
        go
    }

    /// Plans on their way that hold a place in the window.
    fn in_flight(&self, now: Time) -> usize {
        self.deliveries.values().filter(|d| d.holds_place(now)).count()
    }

    /// Plans due now, as many as the window has places for: those waiting for a place, then
    /// members that have not shown their plan for `REDELIVER_S` — alive ones (`alive`).
    /// Deliveries to robots no longer members are dropped.
    pub fn redeliver(&mut self, now: Time, alive: impl Fn(&str) -> bool) -> Vec<(RobotId, Box<PlanAssignment>)> {
        let mm = &self.mm;
        self.deliveries.retain(|robot, d| mm.has(robot.as_str()) && d.assignment.epoch == mm.epoch());
        let mut places = DELIVERY_WINDOW.saturating_sub(self.in_flight(now));
        let mut due: Vec<(&RobotId, &mut Delivery)> = self
            .deliveries
            .iter_mut()
            .filter(|(r, d)| !d.holds_place(now) && d.last_sent.is_none_or(|t| now - t >= REDELIVER_S) && alive(r.as_str()))
            .collect();
        // Never sent first.
        due.sort_by_key(|(_, d)| d.last_sent.is_some());
        let mut out = Vec::new();
        for (robot, d) in due {
            if places == 0 {
                break;
            }
            places -= 1;
            d.last_sent = Some(now);
            d.in_flight = true;
            out.push((robot.clone(), d.assignment.clone()));
        }
        out
    }

    /// The robot answered a plan delivery of `epoch`: accepted (`Ok`), or refused for good.
    pub fn delivered(&mut self, robot: &str, epoch: u64) {
        if self.deliveries.get(robot).is_some_and(|d| d.assignment.epoch <= epoch) {
            self.deliveries.remove(robot);
        }
    }

    /// Any answer to a delivery of `epoch` to `robot` (taken, refused, or none in time): its
    /// place in the window is free; the plans waiting for one go out (at most one per place).
    pub fn answered(&mut self, now: Time, robot: &str, epoch: u64, alive: impl Fn(&str) -> bool) -> Vec<(RobotId, Box<PlanAssignment>)> {
        if let Some(d) = self.deliveries.get_mut(robot).filter(|d| d.assignment.epoch == epoch) {
            d.in_flight = false;
        }
        // With none waiting, re-sends keep to the tick.
        if self.deliveries.values().any(|d| d.last_sent.is_none()) {
            self.redeliver(now, alive)
        } else {
            vec![]
        }
    }

    /// Telemetry of a member at `now`: it shows the plan it runs. A member that runs none of
    /// this mission's current plan for [`REDELIVER_S`] while no delivery is on its way (it
    /// restarted and forgot it, say) is handed its plan again.
    pub fn telemetry(&mut self, now: Time, t: &Telemetry) {
        let runs = t.progress.as_ref().filter(|p| p.mission == self.mm.name()).map(|p| p.epoch);
        if let Some(epoch) = runs {
            self.delivered(t.id.as_str(), epoch);
        }
        let current = runs.is_some_and(|e| e >= self.mm.epoch());
        if current || !self.mm.has(t.id.as_str()) || self.deliveries.contains_key(&t.id) {
            self.astray.remove(&t.id);
            return;
        }
        let since = *self.astray.entry(t.id.clone()).or_insert(now);
        if now - since < REDELIVER_S {
            return;
        }
        // Only a plan already sent: it was committed (the manager's own may not be yet).
        let plan = self.sent.get(&t.id).filter(|a| a.epoch == self.mm.epoch()).cloned();
        if let Some(assignment) = plan {
            // Due at the next redelivery round.
            self.deliveries.insert(t.id.clone(), Delivery { assignment, last_sent: None, in_flight: false });
            self.astray.remove(&t.id);
        }
    }

    /// Robots with a plan still on its way.
    pub fn undelivered(&self) -> impl Iterator<Item = &RobotId> {
        self.deliveries.keys()
    }
}

#[cfg(test)]
mod tests {
    use mrmm_proto::geom::Point;
    use mrmm_proto::plan::{CoverageSummary, Region};

    use super::*;
    use crate::at;

    fn summary(points: usize) -> PlanSummary {
        let points = (0..points).map(|i| Point { x: i as f64, y: 0.0 }).collect();
        PlanSummary::Coverage(CoverageSummary {
            region: Region { outer: vec![], holes: vec![] },
            points,
            coverage_radius: 1.0,
            hexagonal_bound: 1.0,
            formation_time: 0.0,
        })
    }

    #[test]
    fn the_status_carries_the_summary_when_it_changes_and_every_refresh_period() {
        let (a, b) = (summary(2), summary(3));
        let mut h = SummaryGate::default();
        assert!(h.carries(at(0.0), Some(&a)), "the first status carries it");
        assert!(!h.carries(at(1.0), Some(&a)), "unchanged: left out");
        assert!(!h.carries(at(SUMMARY_REFRESH_S - 0.1), Some(&a)));
        assert!(h.carries(at(SUMMARY_REFRESH_S), Some(&a)), "due again for late subscribers");
        assert!(h.carries(at(SUMMARY_REFRESH_S + 1.0), Some(&b)), "a new plan: carried at once");
        assert!(!h.carries(at(SUMMARY_REFRESH_S + 2.0), Some(&b)));
        assert!(h.carries(at(SUMMARY_REFRESH_S + 3.0), None), "no plan: nothing to leave out");
        assert!(h.carries(at(SUMMARY_REFRESH_S + 4.0), Some(&b)), "after no plan, the plan again");
    }
}
