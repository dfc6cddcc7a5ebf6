//! The advising agent as a state machine: it watches snapshots of the fleet and its missions and
//! raises advice for the operator — robot lost, mission below its standard (with the predicted
//! benefit of one more robot), idle robots available, mission manager lost or moved, robot stuck —
//! each with a priority, a one-line reason, the numbers, and a ready-to-run command.
//!
//! Attention management: the same advice is not raised again while it stands; while the operator
//! is busy (a command in the last `busy_window_s`) only critical advice interrupts and the rest
//! waits; advice whose situation is over is withdrawn. At autonomy `act`, the agent runs its own
//! robot moves and says so, and records how each went. No I/O: [`Agent::handle`] takes the time
//! and an [`Event`] and returns [`Command`]s.

mod forecast;
mod rules;

use std::collections::BTreeMap;

use mrmm_proto::{Advice, AdviceEvent, MissionName, MissionView, NodeId, Pose, Priority, RobotId, RobotMove, RobotView, Time};
use serde::{Deserialize, Serialize};

/// How far the agent may go.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Autonomy {
    /// Advise only (default).
    #[default]
    Advise,
    /// Run its own suggestions (robot moves) and say so.
    Act,
}

/// Agent settings (the `agent` section of central's config).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AgentConfig {
    pub autonomy: Autonomy,
    /// After an operator command, only critical advice interrupts for this long, seconds.
    pub busy_window_s: f64,
    /// A robot driving somewhere that has moved less than `stuck_distance` for this long is stuck.
    pub stuck_after_s: f64,
    /// Metres.
    pub stuck_distance: f64,
    /// How long an event-like advice (manager moved) stands, seconds.
    pub event_advice_s: f64,
    /// A robot waiting this long in traffic for the same robots is raised, seconds (one blocked
    /// — no way around those in its way — at once).
    pub traffic_wait_s: f64,
    /// A robot whose battery is below this charge (0–1) and not charging is raised (Open-RMF's
    /// default recharge threshold, 0.2); with `charging`, it is sent to charge.
    pub battery_low: f64,
    /// The charging policy (`mrmm_core::central::charging`): robots below `battery_low` go to
    /// the nearest free charger of their map, and back to work at `charged`.
    pub charging: bool,
    /// A charging robot is done at this charge (0–1).
    pub charged: f64,
    /// The energy forecast looks this far ahead, seconds: a mission whose robots will need
    /// charging sooner than fitting spares are ready is raised (0: off).
    pub forecast_s: f64,
}

impl Default for AgentConfig {
    fn default() -> Self {
        AgentConfig {
            autonomy: Autonomy::Advise,
            busy_window_s: 10.0,
            stuck_after_s: 10.0,
            stuck_distance: 0.2,
            event_advice_s: 30.0,
            traffic_wait_s: 30.0,
            battery_low: 0.2,
            charging: true,
            charged: 0.99,
            forecast_s: 900.0,
        }
    }
}

impl AgentConfig {
    /// Checks every value; the error is `agent.field: problem`.
    pub fn validate(&self) -> Result<(), String> {
        for (name, v, max) in [
            ("busy_window_s", self.busy_window_s, 3600.0),
            ("stuck_after_s", self.stuck_after_s, 3600.0),
            ("stuck_distance", self.stuck_distance, 1000.0),
            ("event_advice_s", self.event_advice_s, 86400.0),
            ("traffic_wait_s", self.traffic_wait_s, 3600.0),
            ("battery_low", self.battery_low, 1.0),
            ("charged", self.charged, 1.0),
            ("forecast_s", self.forecast_s, 86400.0),
        ] {
            if !(v.is_finite() && v >= 0.0 && v <= max) {
                return Err(format!("agent.{name}: must be a number in [0, {max}] (got {v})"));
            }
        }
        if self.charged <= self.battery_low {
            return Err(format!("agent.charged: must be above battery_low ({}), got {}", self.battery_low, self.charged));
        }
        Ok(())
    }
}

/// What the agent is told.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    /// The fleet, missions and traffic now.
    Snapshot { robots: Vec<RobotView>, missions: Vec<MissionView>, traffic: Vec<mrmm_proto::traffic::TrafficView> },
    /// The operator issued a command.
    OperatorCommand,
    /// How a move the agent ran for advice `advice` went.
    Acted { advice: String, result: Result<(), String> },
}

/// What the agent wants done.
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    /// Publish on `mrmm/agent/advice/live`.
    Publish(AdviceEvent),
    /// Autonomy `act`: move a robot, for advice `advice` (answer with [`Event::Acted`]).
    Move { advice: String, mv: RobotMove },
}

/// A candidate piece of advice from the rules, with the action `act` may take.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Candidate {
    pub advice: Advice,
    pub action: Option<RobotMove>,
}

/// Memory the rules need across snapshots.
#[derive(Debug, Clone, Default)]
pub(crate) struct Memory {
    /// Last mission of every robot seen alive in one.
    pub last_mission: BTreeMap<RobotId, MissionName>,
    /// Where each robot was when it last moved, and when.
    pub last_moved: BTreeMap<RobotId, (Pose, Time)>,
    /// Last manager (node, epoch) of each mission, and event advice with its expiry.
    pub managers: BTreeMap<MissionName, NodeId>,
    pub events: BTreeMap<String, (Candidate, Time)>,
    /// How each robot's charge moves (the energy forecast).
    pub drains: BTreeMap<RobotId, forecast::Drain>,
}

/// The advising agent.
#[derive(Debug, Clone)]
pub struct Agent {
    cfg: AgentConfig,
    standing: BTreeMap<String, Advice>,
    queued: BTreeMap<String, Candidate>,
    acted: std::collections::BTreeSet<String>,
    last_operator: Option<Time>,
    memory: Memory,
}

impl Agent {
    pub fn config(&self) -> &AgentConfig {
        &self.cfg
    }

    pub fn new(cfg: AgentConfig) -> Self {
        Agent { cfg, standing: BTreeMap::new(), queued: BTreeMap::new(), acted: Default::default(), last_operator: None, memory: Memory::default() }
    }

    /// Standing advice, most urgent first.
    pub fn advice(&self) -> Vec<Advice> {
        let mut v: Vec<Advice> = self.standing.values().cloned().collect();
        v.sort_by(|a, b| b.priority.cmp(&a.priority).then(a.since.total_cmp(&b.since)).then(a.id.cmp(&b.id)));
        v
    }

    /// Handles one event at `now` (seconds).
    pub fn handle(&mut self, now: Time, ev: Event) -> Vec<Command> {
        match ev {
            Event::OperatorCommand => {
                self.last_operator = Some(now);
                vec![]
            }
            Event::Snapshot { robots, missions, traffic } => {
                let fresh = rules::evaluate(&self.cfg, &mut self.memory, now, &robots, &missions, &traffic);
                self.reconcile(now, fresh)
            }
            Event::Acted { advice, result } => {
                let Some(a) = self.standing.get_mut(&advice) else { return vec![] };
                match result {
                    Ok(()) => a.outcome = Some("done".into()),
                    Err(e) => {
                        tracing::warn!(%advice, "the agent's move failed: {e}");
                        a.acted = false;
                        a.reason = a.reason.strip_prefix("acting: ").unwrap_or(&a.reason).to_string();
                        a.outcome = Some(format!("failed: {e}"));
                    }
                }
                vec![Command::Publish(AdviceEvent::Raised(a.clone()))]
            }
        }
    }

    fn busy(&self, now: Time) -> bool {
        self.last_operator.is_some_and(|t| now - t < self.cfg.busy_window_s)
    }

    /// Raises what is new (or queues it while the operator is busy), withdraws what is over.
    fn reconcile(&mut self, now: Time, fresh: BTreeMap<String, Candidate>) -> Vec<Command> {
        let mut out = Vec::new();
        let over: Vec<String> = self.standing.keys().filter(|id| !fresh.contains_key(*id)).cloned().collect();
        for id in over {
            self.standing.remove(&id);
            self.acted.remove(&id);
            out.push(Command::Publish(AdviceEvent::Withdrawn { id, reason: "resolved".into() }));
        }
        self.queued.retain(|id, _| fresh.contains_key(id));
        let busy = self.busy(now);
        // One move per robot per look: advice that would move a robot another advice of this
        // look already moves waits for the next look (with the fleet as it is then), instead of
        // pulling the robot from mission to mission.
        let mut moving = std::collections::BTreeSet::new();
        for (id, mut c) in fresh {
            if let Some(s) = self.standing.get_mut(&id) {
                // Still standing: keep its identity and time, refresh text and numbers quietly.
                s.evidence = c.advice.evidence;
                s.reason = if s.acted { format!("acting: {}", c.advice.reason) } else { c.advice.reason };
                if !s.acted {
                    s.suggestion = c.advice.suggestion;
                }
                continue;
            }
            if busy && c.advice.priority < Priority::Critical {
                self.queued.insert(id, c);
                continue;
            }
            self.queued.remove(&id);
            let act = self.cfg.autonomy == Autonomy::Act && !self.acted.contains(&id);
            if act && c.action.as_ref().is_some_and(|mv| moving.contains(&mv.robot)) {
                continue;
            }
            if act {
                if let Some(mv) = c.action.take() {
                    moving.insert(mv.robot.clone());
                    self.acted.insert(id.clone());
                    c.advice.acted = true;
                    c.advice.reason = format!("acting: {}", c.advice.reason);
                    out.push(Command::Move { advice: id.clone(), mv });
                }
            }
            self.standing.insert(id, c.advice.clone());
            out.push(Command::Publish(AdviceEvent::Raised(c.advice)));
        }
        out
    }
}

#[cfg(test)]
mod tests;
