//! A mission manager as a state machine: it owns a mission's team, asks for plans when the team
//! changes, hands each robot its plan with the current epoch, and computes the mission's metrics
//! from telemetry. No I/O: [`MissionManager::handle`] takes the time and an [`Event`] and returns
//! [`Command`]s; the replicated part of its state is a [`MissionSnapshot`].

mod burst;
pub mod chain;
mod handover;
pub mod host;
mod metrics;
pub mod planning;
mod spec;
mod teams;
mod view;

use std::collections::BTreeMap;

use mrmm_planner::recipe::PlannerKind;
use mrmm_proto::geom::Point;
use mrmm_proto::plan::{MissionPlan, PlanSummary, RobotSpec};
use mrmm_proto::{self as proto, HandoverState, Member, MissionSnapshot, MissionStatus, NodeId, PlanAssignment, PlanRequest, RobotId, Telemetry, Time};

pub use burst::{LOSS_BURST_MAX_S, LOSS_BURST_S, LOSS_QUIET_S};
pub use metrics::{VISIT_DEBOUNCE_S, VISIT_RADIUS};
pub use spec::MissionSpec;

/// Teams of at least this many members run the leader barrier unless the mission says otherwise.
pub const LEADER_BARRIER_FROM: usize = 30;

/// Longest reason kept for a stuck member.
const MAX_STUCK_REASON: usize = 300;

/// Something that happened to the mission.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    /// The mission starts with the members it was created with.
    Start,
    /// A new head goes on from the replicated state: if its predecessor died while planning, it
    /// asks for the plan again.
    Resume,
    /// A robot joins (moved in, or a lost member back).
    Joined(Member),
    /// A robot the system manager put in this mission whose liveliness the head does not see
    /// (a late report made central think it was back): it is kept as a lost member — its place
    /// kept, no replan — and joins when it comes back.
    Absent(Member),
    /// Robots leave (moved out, ordered out); one replan for all of them.
    Left {
        ids: Vec<RobotId>,
    },
    /// A robot takes member `out`'s place (a hand-over): `out` leaves, the robot carries on its
    /// plan from where `out` was, the other members go on with theirs — a new epoch, no replan.
    /// Without a plan to carry on (none yet, paused, a replan pending, `out` not in it or not
    /// heard from on it) it is a leave and a join: one replan.
    Replaced {
        out: RobotId,
        by: Member,
    },
    /// Robots were lost (liveliness): like `Left`, but they are remembered and may rejoin.
    Lost {
        ids: Vec<RobotId>,
    },
    PlanReady {
        epoch: u64,
        plan: Box<MissionPlan>,
    },
    PlanFailed {
        epoch: u64,
        error: String,
    },
    /// A member's telemetry (the time is wall seconds; metrics run on each robot's time scale).
    Telemetry(Box<Telemetry>),
    /// Put the metrics into the replicated state (once a second: telemetry alone never makes
    /// the chain replicate).
    Checkpoint,
    /// Time passed: a replan held back for a burst of losses is due.
    Tick,
    /// The operator changed the mission (parameters, map; paused or resumed it): the members
    /// stay, and get the next epoch's plans.
    Update(Box<MissionSpec>),
}

/// What the mission manager needs done.
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    /// Ask a planner of `kind` for a plan of `epoch`.
    RequestPlan { epoch: u64, kind: PlannerKind, request: PlanRequest },
    /// Hand a robot its plan.
    SendPlan { robot: RobotId, assignment: Box<PlanAssignment> },
    /// The first plan is out: the mission runs.
    Started,
    /// The first plan failed.
    Failed { error: String },
}

/// One mission's manager.
#[derive(Debug, Clone)]
pub struct MissionManager {
    spec: MissionSpec,
    node: NodeId,
    epoch: u64,
    status: MissionStatus,
    error: Option<String>,
    members: BTreeMap<RobotId, Member>,
    /// Members lost through liveliness, kept so they can rejoin.
    lost: BTreeMap<RobotId, Member>,
    plan: Option<(u64, MissionPlan)>,
    started: bool,
    /// Sync publications of members that left, kept so the count never goes back.
    sync_msgs_left: u64,
    plan_msgs: u64,
    metrics: metrics::Metrics,
    /// The replicated state as last handed out by [`MissionManager::changes`].
    replicated: Option<MissionSnapshot>,
    revision: u64,
    /// The metrics as last checkpointed into the replicated state.
    tally: Option<proto::MetricsTally>,
    /// Members that report they cannot get to their goal, with why (from their telemetry; not
    /// replicated: a new head hears it again within a telemetry period).
    stuck: BTreeMap<RobotId, String>,
    /// The burst of losses a held replan is for (its epoch is already counted, so a successor
    /// taking over meanwhile replans).
    burst: burst::LossBurst,
    /// The recipe's leaf teams (none for a recipe planned as a whole).
    shapes: Vec<teams::TeamShape>,
    /// The current plan carries on an earlier epoch's (hand-overs since it was planned).
    handover: Option<HandoverState>,
}

impl MissionManager {
    pub fn new(spec: MissionSpec, node: NodeId, members: Vec<Member>) -> Self {
        MissionManager {
            shapes: teams::shapes(&spec.recipe_xml),
            spec,
            node,
            epoch: 0,
            status: MissionStatus::Planning,
            error: None,
            members: members.into_iter().map(|m| (m.spec.id.clone(), m)).collect(),
            lost: BTreeMap::new(),
            plan: None,
            started: false,
            sync_msgs_left: 0,
            plan_msgs: 0,
            metrics: metrics::Metrics::default(),
            replicated: None,
            revision: 0,
            tally: None,
            stuck: BTreeMap::new(),
            burst: burst::LossBurst::default(),
            handover: None,
        }
    }

    /// Plan epochs start above `floor` (a new lineage of the mission: its plans win over any of
    /// an older lineage that a robot may still hold).
    pub fn with_epoch_floor(mut self, floor: u64) -> Self {
        self.epoch = self.epoch.max(floor);
        self
    }

    /// A manager on `node` going on from a replicated state.
    pub fn restore(snap: MissionSnapshot, node: NodeId) -> Result<Self, String> {
        let spec = MissionSpec::from_wire(snap.spec.clone())?;
        let mut mm = MissionManager::new(spec, node, snap.members.clone());
        mm.lost = snap.lost.iter().map(|m| (m.spec.id.clone(), m.clone())).collect();
        mm.epoch = snap.epoch;
        if let Some((_, p)) = &snap.plan {
            mm.metrics.reset_tour(tour(p).len());
            if let Some(t) = &snap.tally {
                mm.metrics.restore(t);
            }
        }
        mm.tally.clone_from(&snap.tally);
        mm.plan = snap.plan.clone();
        mm.started = snap.started;
        mm.status = snap.status;
        mm.error = snap.error.clone();
        mm.plan_msgs = snap.plan_msgs;
        mm.sync_msgs_left = snap.sync_msgs_left;
        mm.revision = snap.revision;
        mm.handover.clone_from(&snap.handover);
        mm.replicated = Some(snap);
        Ok(mm)
    }

    /// The replicated state.
    pub fn snapshot(&self) -> MissionSnapshot {
        MissionSnapshot {
            spec: self.spec.to_wire(),
            members: self.members.values().cloned().collect(),
            lost: self.lost.values().cloned().collect(),
            epoch: self.epoch,
            plan: self.plan.clone(),
            started: self.started,
            status: self.status,
            error: self.error.clone(),
            plan_msgs: self.plan_msgs,
            sync_msgs_left: self.sync_msgs_left,
            revision: self.revision,
            tally: self.tally.clone(),
            handover: self.handover.clone(),
        }
    }

    /// The replicated state if it changed since the last call (its revision one higher), for the
    /// chain to replicate; `None` if nothing the chain holds changed.
    pub fn changes(&mut self) -> Option<MissionSnapshot> {
        let mut now = self.snapshot();
        if let Some(last) = &self.replicated {
            now.revision = last.revision;
            if *last == now {
                return None;
            }
            self.revision = last.revision.saturating_add(1);
            now.revision = self.revision;
        }
        self.replicated = Some(now.clone());
        Some(now)
    }

    pub fn name(&self) -> &str {
        self.spec.name.as_str()
    }
    pub fn node(&self) -> &str {
        self.node.as_str()
    }
    /// Replicas of this manager's state after the head.
    pub fn replicas(&self) -> usize {
        self.spec.replicas
    }

    /// The map the mission plans on.
    pub fn map(&self) -> Option<&proto::MapRef> {
        self.spec.map.as_ref()
    }
    pub fn epoch(&self) -> u64 {
        self.epoch
    }
    /// When a replan held back for a burst of losses is due.
    pub fn replan_due(&self) -> Option<Time> {
        self.burst.due()
    }
    pub fn revision(&self) -> u64 {
        self.revision
    }
    pub fn members(&self) -> impl Iterator<Item = &RobotId> {
        self.members.keys()
    }
    pub fn has(&self, id: &str) -> bool {
        self.members.contains_key(id)
    }
    /// A lost member that may rejoin.
    pub fn lost(&self, id: &str) -> Option<&Member> {
        self.lost.get(id)
    }
    /// Every lost member.
    pub fn lost_members(&self) -> impl Iterator<Item = &Member> {
        self.lost.values()
    }
    pub fn planner(&self) -> PlannerKind {
        self.spec.planner
    }
    fn time_scale(&self, id: &str) -> f64 {
        self.members.get(id).map_or(1.0, |m| m.time_scale)
    }

    /// Handles one event at `now` (wall seconds).
    pub fn handle(&mut self, now: Time, event: Event) -> Vec<Command> {
        match event {
            Event::Start => self.replan(),
            Event::Resume => {
                let planning = self.plan.as_ref().is_none_or(|(e, _)| *e != self.epoch) && !self.members.is_empty();
                if planning {
                    self.replan()
                } else {
                    vec![]
                }
            }
            Event::Joined(member) => {
                self.lost.remove(&member.spec.id);
                if self.members.contains_key(&member.spec.id) {
                    return vec![]; // already in: nothing changes
                }
                self.members.insert(member.spec.id.clone(), member);
                if self.burst.join(now) {
                    return vec![]; // in the replan held for a burst of losses
                }
                self.replan()
            }
            Event::Absent(member) => {
                if !self.members.contains_key(&member.spec.id) {
                    self.lost.insert(member.spec.id.clone(), member);
                }
                vec![]
            }
            Event::Left { ids } | Event::Lost { ids } if ids.is_empty() => vec![],
            Event::Lost { ids } => self.members_lost(now, ids),
            Event::Replaced { out, by } => self.replaced(out, by),
            Event::Tick => match self.burst.due() {
                Some(due) if now >= due => self.plan_current(),
                _ => vec![],
            },
            Event::Left { ids } => {
                for id in &ids {
                    self.lost.remove(id);
                }
                self.remove(ids)
            }
            Event::PlanReady { epoch, plan } => self.plan_ready(epoch, *plan),
            Event::PlanFailed { epoch, error } => self.plan_failed(epoch, error),
            Event::Telemetry(t) => {
                self.telemetry(now, &t);
                vec![]
            }
            Event::Update(spec) => self.update(*spec),
            Event::Checkpoint => {
                let tally = self.metrics.tally();
                // Nothing counted yet (no tour, or no visit): nothing worth replicating.
                if tally.visits.iter().any(|v| *v > 0) {
                    self.tally = Some(tally);
                }
                vec![]
            }
        }
    }

    /// Members lost: out of the plan at once, and one replan for the whole burst — the plan is
    /// outdated from now (the epoch says so, and a successor taking over replans), asked for
    /// once the burst is over: [`LOSS_BURST_S`] after its first loss, [`LOSS_QUIET_S`] after its
    /// last, [`LOSS_BURST_MAX_S`] after its first at most.
    fn members_lost(&mut self, now: Time, ids: Vec<RobotId>) -> Vec<Command> {
        for id in &ids {
            if let Some(m) = self.members.get(id) {
                self.lost.insert(id.clone(), m.clone());
            }
        }
        if !self.take_out(ids) {
            return vec![];
        }
        if self.members.is_empty() {
            return self.replan();
        }
        if self.burst.loss(now) {
            self.epoch = self.epoch.saturating_add(1);
        }
        vec![]
    }

    /// The planner failed on the current epoch: a mission not started yet fails with it; a
    /// running one goes on with its plans and says why.
    fn plan_failed(&mut self, epoch: u64, error: String) -> Vec<Command> {
        if epoch != self.epoch {
            return vec![];
        }
        tracing::warn!(mission = %self.spec.name, epoch, "planning failed: {error}");
        self.error = Some(error.clone());
        if self.started {
            vec![]
        } else {
            self.status = MissionStatus::Failed;
            vec![Command::Failed { error }]
        }
    }

    /// A member's telemetry: where it is (for the next plan), whether it is stuck, and its visits
    /// (the idleness clock; none while paused).
    fn telemetry(&mut self, now: Time, t: &Telemetry) {
        let Some(m) = self.members.get_mut(&t.id) else { return };
        m.spec.x = t.pose.x;
        m.spec.y = t.pose.y;
        m.spec.reach_m = t.battery.and_then(|b| b.reach_m);
        match &t.stuck {
            Some(why) if self.stuck.get(&t.id) != Some(why) => {
                if !self.stuck.contains_key(&t.id) {
                    tracing::warn!(mission = %self.spec.name, robot = %t.id, "member cannot get to its goal: {why}");
                }
                self.stuck.insert(t.id.clone(), why.chars().take(MAX_STUCK_REASON).collect());
            }
            Some(_) => {}
            None => {
                if self.stuck.remove(&t.id).is_some() {
                    tracing::info!(mission = %self.spec.name, robot = %t.id, "member on its way again");
                }
            }
        }
        if self.spec.paused {
            return;
        }
        let robot_now = Time::from_secs(now.secs() * self.time_scale(t.id.as_str()));
        let tour = self.plan.as_ref().map(|(_, p)| tour(p)).unwrap_or(&[]);
        let carried = self.metrics.telemetry(self.spec.name.as_str(), self.epoch, tour, robot_now, t);
        self.sync_msgs_left = self.sync_msgs_left.saturating_add(carried);
    }

    /// The operator's change: what it is now, and the next epoch's plans if what it plans on
    /// changed or it was paused or resumed. The same spec again (a control re-sent) changes
    /// nothing.
    fn update(&mut self, spec: MissionSpec) -> Vec<Command> {
        if spec.name != self.spec.name {
            return vec![];
        }
        let replan = spec.params != self.spec.params || spec.map != self.spec.map || spec.recipe_xml != self.spec.recipe_xml || spec.paused != self.spec.paused;
        let resumed = self.spec.paused && !spec.paused;
        self.spec = MissionSpec { replicas: self.spec.replicas, ..spec };
        self.shapes = teams::shapes(&self.spec.recipe_xml);
        if resumed {
            // The gaps between visits do not count the pause.
            self.metrics.restart_clocks();
        }
        tracing::info!(mission = %self.spec.name, paused = self.spec.paused, replan, "mission updated");
        if replan {
            self.replan()
        } else {
            vec![]
        }
    }

    /// While paused: a plan that holds every member where it is, with the last plan's figures.
    fn hold_plan(&self) -> MissionPlan {
        let summary = match &self.plan {
            Some((_, p)) => p.summary.clone(),
            None => PlanSummary::Patrol(proto::plan::PatrolSummary {
                tour: vec![],
                waypoints: vec![],
                length: 0.0,
                offset: 0.0,
                spacing: 0.0,
                team_speed: 0.0,
                sync_per_round: 0,
                formation_time: 0.0,
                predicted_worst_idleness: 0.0,
                idleness_lower_bound: 0.0,
            }),
        };
        let planned = self.planned_teams();
        let plans = self
            .members
            .values()
            .enumerate()
            .map(|(slot, m)| proto::RobotPlan {
                robot: m.spec.id.clone(),
                robot_type: m.spec.robot_type.clone(),
                slot,
                steps: vec![proto::Step::Stream, proto::Step::Hold { seconds: None }],
                team: planned.get(m.spec.id.as_str()).map(|t| t.to_string()).unwrap_or_default(),
            })
            .collect();
        MissionPlan { summary, plans, teams: vec![], held: vec![] }
    }

    fn plan_ready(&mut self, epoch: u64, plan: MissionPlan) -> Vec<Command> {
        if epoch != self.epoch {
            return vec![]; // superseded by a newer team
        }
        let mut out = self.assignments(epoch, &plan);
        self.plan_msgs = self.plan_msgs.saturating_add(out.len() as u64);
        self.metrics.reset_tour(tour(&plan).len());
        self.plan = Some((epoch, plan));
        self.status = if self.spec.paused { MissionStatus::Paused } else { MissionStatus::Running };
        self.error = None;
        if !self.started {
            self.started = true;
            out.push(Command::Started);
        }
        out
    }

    /// The current plans again (a new head re-sends them after a takeover; robots already
    /// running them go on undisturbed).
    pub fn current_assignments(&self) -> Vec<Command> {
        match &self.plan {
            Some((e, p)) if *e == self.epoch => self.assignments(*e, p),
            _ => vec![],
        }
    }

    /// Takes members out; one replan if any was in.
    fn remove(&mut self, ids: Vec<RobotId>) -> Vec<Command> {
        if self.take_out(ids) {
            self.replan()
        } else {
            vec![]
        }
    }

    /// Takes members out; whether any was one.
    fn take_out(&mut self, ids: Vec<RobotId>) -> bool {
        let mut any = false;
        for id in ids {
            self.stuck.remove(&id);
            if self.members.remove(&id).is_some() {
                any = true;
                if let Some(p) = self.metrics.forget(id.as_str()) {
                    self.sync_msgs_left = self.sync_msgs_left.saturating_add(u64::from(p.sync_msgs));
                }
            }
        }
        any
    }

    /// New epoch, new plan for the current members.
    fn replan(&mut self) -> Vec<Command> {
        self.epoch = self.epoch.saturating_add(1);
        self.plan_current()
    }

    /// A plan of the current epoch for the current members (a replan held back is no longer).
    fn plan_current(&mut self) -> Vec<Command> {
        self.burst.clear();
        self.handover = None;
        if self.members.is_empty() {
            self.status = MissionStatus::Stalled;
            return vec![];
        }
        if self.spec.paused {
            // Paused: every member holds where it is; no planner is asked.
            let hold = self.hold_plan();
            return self.plan_ready(self.epoch, hold);
        }
        if self.started {
            self.status = MissionStatus::Running;
        }
        tracing::info!(mission = %self.spec.name, epoch = self.epoch, robots = self.members.len(), "planning");
        vec![Command::RequestPlan { epoch: self.epoch, kind: self.spec.planner, request: self.plan_request() }]
    }

    /// What a planner needs for the current team.
    pub fn plan_request(&self) -> PlanRequest {
        PlanRequest {
            recipe: self.spec.recipe_xml.clone(),
            params: self.spec.params.clone(),
            robots: self.members.values().map(|m| m.spec.clone()).collect::<Vec<RobotSpec>>(),
            map: self.spec.map.clone(),
            capabilities: self.members.values().filter(|m| !m.capabilities.is_empty()).map(|m| (m.spec.id.clone(), m.capabilities.clone())).collect(),
            // The create (and every update) checked the teams' bounds with the members then.
            relax_bounds: true,
        }
    }
}

/// A plan's patrol waypoints in tour order (none for coverage).
fn tour(p: &MissionPlan) -> &[Point] {
    match &p.summary {
        PlanSummary::Patrol(s) if !s.waypoints.is_empty() => &s.waypoints,
        PlanSummary::Patrol(s) => &s.tour,
        PlanSummary::Coverage(_) => &[],
    }
}

#[cfg(test)]
mod tests;
