//! A mission this node leads: its mission manager, what it waits to do until the chain has
//! committed the state that asked for it, and the plans it is delivering. Pure; the host core
//! calls it and turns what it returns into commands.

use std::collections::BTreeMap;

use mrmm_proto::{CtlAck, PlanAssignment, PlanSummary, Telemetry, SUMMARY_REFRESH_S};

use crate::mission::{self, MissionManager};

/// Seconds between two sends of a plan a robot has not yet shown it runs.
pub const REDELIVER_S: f64 = 2.0;
/// Plan requests retried at most this many times per epoch when no planner answered.
pub const PLAN_RETRIES: u32 = 3;

/// A plan on its way to a robot: re-sent until the robot's telemetry (or its answer) shows it.
#[derive(Debug, Clone, PartialEq)]
pub struct Delivery {
    pub assignment: Box<PlanAssignment>,
    pub last_sent: f64,
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
    deliveries: BTreeMap<String, Delivery>,
    /// The epoch of the last plan request, and how often it was asked again.
    requested: Option<(u64, u32)>,
    /// Members whose telemetry shows they do not run the current plan (they restarted, say),
    /// and since when.
    astray: BTreeMap<String, f64>,
    /// The last plan sent to each robot (sent only once committed).
    sent: BTreeMap<String, Box<PlanAssignment>>,
    /// What the mission's status last carried of the planner's summary.
    summary: SummaryGate,
}

/// Decides which statuses carry the planner's summary (the tour, the coverage points: O(team)
/// bytes): the one after it changed, and one every [`SUMMARY_REFRESH_S`] seconds for subscribers
/// that came later. Holds the summary last carried and when.
#[derive(Debug, Clone, Default)]
pub struct SummaryGate(Option<(PlanSummary, f64)>);

impl SummaryGate {
    /// Whether the status published at `now`, whose summary is `summary`, carries it.
    pub fn carries(&mut self, now: f64, summary: Option<&PlanSummary>) -> bool {
        let Some(s) = summary else {
            self.0 = None;
            return true;
        };
        match &self.0 {
            Some((last, at)) if last == s && now - at < SUMMARY_REFRESH_S => false,
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
        }
    }

    /// Whether the mission's status published at `now` carries the planner's summary.
    pub fn carries_summary(&mut self, now: f64, summary: Option<&PlanSummary>) -> bool {
        self.summary.carries(now, summary)
    }

    /// Runs one mission event; returns the plan requests to make now (everything else waits for
    /// the commit).
    pub fn run(&mut self, now: f64, ev: mission::Event) -> Vec<mission::Command> {
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

    /// A plan goes out to `robot` now.
    pub fn sending(&mut self, now: f64, robot: &str, assignment: Box<PlanAssignment>) {
        self.sent.insert(robot.to_string(), assignment.clone());
        self.deliveries.insert(robot.to_string(), Delivery { assignment, last_sent: now });
    }

    /// Plans due again: members that have not shown their plan for `REDELIVER_S` and are
    /// alive (`alive`). Deliveries to robots no longer members are dropped.
    pub fn redeliver(&mut self, now: f64, alive: impl Fn(&str) -> bool) -> Vec<(String, Box<PlanAssignment>)> {
        let mm = &self.mm;
        self.deliveries.retain(|robot, d| mm.has(robot) && d.assignment.epoch == mm.epoch());
        let mut out = Vec::new();
        for (robot, d) in self.deliveries.iter_mut() {
            if now - d.last_sent >= REDELIVER_S && alive(robot) {
                d.last_sent = now;
                out.push((robot.clone(), d.assignment.clone()));
            }
        }
        out
    }

    /// The robot answered a plan delivery of `epoch`: accepted (`Ok`), or refused for good.
    pub fn delivered(&mut self, robot: &str, epoch: u64) {
        if self.deliveries.get(robot).is_some_and(|d| d.assignment.epoch <= epoch) {
            self.deliveries.remove(robot);
        }
    }

    /// Telemetry of a member at `now`: it shows the plan it runs. A member that runs none of
    /// this mission's current plan for [`REDELIVER_S`] while no delivery is on its way (it
    /// restarted and forgot it, say) is handed its plan again.
    pub fn telemetry(&mut self, now: f64, t: &Telemetry) {
        let runs = t.progress.as_ref().filter(|p| p.mission == self.mm.name()).map(|p| p.epoch);
        if let Some(epoch) = runs {
            self.delivered(&t.id, epoch);
        }
        let current = runs.is_some_and(|e| e >= self.mm.epoch());
        if current || !self.mm.has(&t.id) || self.deliveries.contains_key(&t.id) {
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
            self.deliveries.insert(t.id.clone(), Delivery { assignment, last_sent: now - REDELIVER_S });
            self.astray.remove(&t.id);
        }
    }

    /// Robots with a plan still on its way.
    pub fn undelivered(&self) -> impl Iterator<Item = &String> {
        self.deliveries.keys()
    }
}

#[cfg(test)]
mod tests {
    use mrmm_proto::plan::{CoverageSummary, Point, Region};

    use super::*;

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
        assert!(h.carries(0.0, Some(&a)), "the first status carries it");
        assert!(!h.carries(1.0, Some(&a)), "unchanged: left out");
        assert!(!h.carries(SUMMARY_REFRESH_S - 0.1, Some(&a)));
        assert!(h.carries(SUMMARY_REFRESH_S, Some(&a)), "due again for late subscribers");
        assert!(h.carries(SUMMARY_REFRESH_S + 1.0, Some(&b)), "a new plan: carried at once");
        assert!(!h.carries(SUMMARY_REFRESH_S + 2.0, Some(&b)));
        assert!(h.carries(SUMMARY_REFRESH_S + 3.0, None), "no plan: nothing to leave out");
        assert!(h.carries(SUMMARY_REFRESH_S + 4.0, Some(&b)), "after no plan, the plan again");
    }
}
