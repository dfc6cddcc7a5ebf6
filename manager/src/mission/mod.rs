//! A mission manager as a state machine: it owns a mission's team, asks for plans when the team
//! changes, hands each robot its plan with the current epoch, and computes the mission's metrics
//! from telemetry. No I/O: [`MissionManager::handle`] returns [`MCommand`]s.

use std::collections::BTreeMap;

use mrmm_peer::proto::{
    ManagerView, Marginal, Member, MissionMetrics, MissionSpecWire, MissionStatus, MissionView, PlanAssignment, PlanRequest,
    Progress, Telemetry,
};
use serde::{Deserialize, Serialize};
use mrmm_planner::geom::Point;
use mrmm_planner::plan::RobotSpec;
use mrmm_planner::recipe::{MissionPlan, PlannerKind};

/// A waypoint counts as visited by a robot passing within this distance, metres.
pub const VISIT_RADIUS: f64 = 1.5;
/// Two passes of the same waypoint closer in time than this are one visit, seconds.
pub const VISIT_DEBOUNCE_S: f64 = 1.0;

/// What a mission is.
#[derive(Debug, Clone, PartialEq)]
pub struct MissionSpec {
    pub name: String,
    /// Bank name, or `custom` for an inline recipe.
    pub recipe_name: String,
    pub recipe_xml: String,
    pub planner: PlannerKind,
    pub params: BTreeMap<String, String>,
    /// Replicas of the manager's state after the head.
    pub replicas: usize,
}

impl MissionSpec {
    pub fn to_wire(&self) -> mrmm_peer::proto::MissionSpecWire {
        mrmm_peer::proto::MissionSpecWire {
            name: self.name.clone(),
            recipe_name: self.recipe_name.clone(),
            recipe_xml: self.recipe_xml.clone(),
            planner: self.planner.as_str().to_string(),
            params: self.params.clone(),
            replicas: self.replicas,
        }
    }

    pub fn from_wire(w: mrmm_peer::proto::MissionSpecWire) -> Result<Self, String> {
        let planner = match w.planner.as_str() {
            "patrol" => PlannerKind::Patrol,
            "coverage" => PlannerKind::Coverage,
            other => return Err(format!("unknown planner {other:?}")),
        };
        mrmm_peer::proto::validate_id(&w.name).map_err(|e| e.to_string())?;
        if w.replicas > mrmm_peer::proto::MAX_REPLICAS {
            return Err(format!("replicas: at most {} (got {})", mrmm_peer::proto::MAX_REPLICAS, w.replicas));
        }
        Ok(MissionSpec {
            name: w.name,
            recipe_name: w.recipe_name,
            recipe_xml: w.recipe_xml,
            planner,
            params: w.params,
            replicas: w.replicas,
        })
    }
}

/// Something that happened to the mission.
#[derive(Debug, Clone, PartialEq)]
pub enum MEvent {
    /// The mission starts with its initial members.
    Start,
    /// A robot joins (created with it, moved in).
    Joined(RobotSpec),
    /// Robots leave (moved out, ordered out); one replan for all of them.
    Left { ids: Vec<String> },
    /// Robots were lost (liveliness): like `Left`, but they are remembered and may rejoin.
    Lost { ids: Vec<String> },
    PlanReady { epoch: u64, plan: Box<MissionPlan> },
    PlanFailed { epoch: u64, error: String },
    Telemetry { now: f64, t: Box<Telemetry> },
}

/// What the mission manager needs done.
#[derive(Debug, Clone, PartialEq)]
pub enum MCommand {
    /// Ask a planner service of `kind` for a plan of `epoch`.
    RequestPlan { epoch: u64, kind: PlannerKind, request: PlanRequest },
    /// Hand a robot its plan.
    SendPlan { robot: String, assignment: Box<PlanAssignment> },
    /// The first plan is out: the mission runs.
    Started,
    /// The first plan failed.
    Failed { error: String },
}

#[derive(Debug, Clone, Default)]
struct Idleness {
    last_visit: Vec<Option<(f64, String)>>,
    visits: Vec<u32>,
    sum: f64,
    count: u64,
    worst: f64,
}

/// The state a mission manager replicates along its chain (JSON in chain messages): enough for a
/// successor to go on. Metrics are not in it: a new head counts from its takeover.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MissionSnapshot {
    pub spec: MissionSpecWire,
    pub members: Vec<Member>,
    /// Members lost through liveliness; they rejoin when they come back.
    pub lost: Vec<Member>,
    pub epoch: u64,
    pub plan: Option<(u64, MissionPlan)>,
    pub started: bool,
    pub status: MissionStatus,
    pub error: Option<String>,
    pub plan_msgs: u64,
    pub sync_msgs_left: u64,
}

/// One mission's manager.
#[derive(Debug, Clone)]
pub struct MissionManager {
    spec: MissionSpec,
    node: String,
    epoch: u64,
    status: MissionStatus,
    error: Option<String>,
    members: BTreeMap<String, RobotSpec>,
    plan: Option<(u64, MissionPlan)>,
    started: bool,
    progress: BTreeMap<String, Progress>,
    /// Sync publications of members that left, kept so the count never goes back.
    sync_msgs_left: u64,
    plan_msgs: u64,
    idleness: Idleness,
    last_now: f64,
    /// Members lost through liveliness, kept so they can rejoin.
    lost: BTreeMap<String, RobotSpec>,
    /// Simulated seconds per wall second, per robot.
    time_scales: BTreeMap<String, f64>,
}

impl MissionManager {
    pub fn new(spec: MissionSpec, node: String, members: Vec<RobotSpec>) -> Self {
        MissionManager {
            spec,
            node,
            epoch: 0,
            status: MissionStatus::Planning,
            error: None,
            members: members.into_iter().map(|m| (m.id.clone(), m)).collect(),
            plan: None,
            started: false,
            progress: BTreeMap::new(),
            sync_msgs_left: 0,
            plan_msgs: 0,
            idleness: Idleness::default(),
            last_now: 0.0,
            lost: BTreeMap::new(),
            time_scales: BTreeMap::new(),
        }
    }

    /// The replicated state, with each robot's time scale.
    pub fn snapshot(&self) -> MissionSnapshot {
        let member = |spec: &RobotSpec| Member { spec: spec.clone(), time_scale: self.time_scale(&spec.id) };
        MissionSnapshot {
            spec: self.spec.to_wire(),
            members: self.members.values().map(member).collect(),
            lost: self.lost.values().map(member).collect(),
            epoch: self.epoch,
            plan: self.plan.clone(),
            started: self.started,
            status: self.status,
            error: self.error.clone(),
            plan_msgs: self.plan_msgs,
            sync_msgs_left: self.sync_msgs_left,
        }
    }

    /// A manager on `node` going on from a replicated state.
    pub fn restore(snap: MissionSnapshot, node: String) -> Result<Self, String> {
        let spec = MissionSpec::from_wire(snap.spec)?;
        let mut mm = MissionManager::new(spec, node, snap.members.iter().map(|m| m.spec.clone()).collect());
        for m in snap.members.iter().chain(&snap.lost) {
            mm.time_scales.insert(m.spec.id.clone(), m.time_scale);
        }
        mm.lost = snap.lost.into_iter().map(|m| (m.spec.id.clone(), m.spec)).collect();
        mm.epoch = snap.epoch;
        if let Some((_, MissionPlan::Patrol(p))) = &snap.plan {
            mm.idleness = Idleness { last_visit: vec![None; p.tour.len()], visits: vec![0; p.tour.len()], ..Idleness::default() };
        }
        mm.plan = snap.plan;
        mm.started = snap.started;
        mm.status = snap.status;
        mm.error = snap.error;
        mm.plan_msgs = snap.plan_msgs;
        mm.sync_msgs_left = snap.sync_msgs_left;
        Ok(mm)
    }

    pub fn set_time_scale(&mut self, id: &str, scale: f64) {
        self.time_scales.insert(id.to_string(), scale);
    }
    pub fn time_scale(&self, id: &str) -> f64 {
        self.time_scales.get(id).copied().unwrap_or(1.0)
    }
    /// A lost member that may rejoin.
    pub fn lost(&self, id: &str) -> Option<&RobotSpec> {
        self.lost.get(id)
    }
    /// Whether the first plan is still being made (a new head must ask again).
    pub fn planning(&self) -> bool {
        self.plan.as_ref().is_none_or(|(e, _)| *e != self.epoch) && !self.members.is_empty()
    }
    /// Asks for a plan again at a new epoch (a new head whose predecessor died while planning).
    pub fn replan_now(&mut self) -> Vec<MCommand> {
        self.replan()
    }

    pub fn name(&self) -> &str {
        &self.spec.name
    }
    /// Replicas of this manager's state after the head.
    pub fn replicas(&self) -> usize {
        self.spec.replicas
    }
    pub fn epoch(&self) -> u64 {
        self.epoch
    }
    pub fn members(&self) -> impl Iterator<Item = &String> {
        self.members.keys()
    }
    pub fn has(&self, id: &str) -> bool {
        self.members.contains_key(id)
    }

    /// Handles one event.
    pub fn handle(&mut self, event: MEvent) -> Vec<MCommand> {
        match event {
            MEvent::Start => self.replan(),
            MEvent::Joined(spec) => {
                self.lost.remove(&spec.id);
                if self.members.contains_key(&spec.id) {
                    return vec![]; // already in: nothing changes
                }
                self.members.insert(spec.id.clone(), spec);
                self.replan()
            }
            MEvent::Left { ids } | MEvent::Lost { ids } if ids.is_empty() => vec![],
            MEvent::Lost { ids } => {
                for id in &ids {
                    if let Some(spec) = self.members.get(id) {
                        self.lost.insert(id.clone(), spec.clone());
                    }
                }
                self.remove(ids)
            }
            MEvent::Left { ids } => {
                for id in &ids {
                    self.lost.remove(id);
                }
                self.remove(ids)
            }
            MEvent::PlanReady { epoch, plan } => {
                if epoch != self.epoch {
                    return vec![]; // superseded by a newer team
                }
                let mut out = self.assignments(epoch, &plan);
                self.plan_msgs += out.len() as u64;
                let waypoints = match plan.as_ref() {
                    MissionPlan::Patrol(p) => p.tour.len(),
                    MissionPlan::Coverage(_) => 0,
                };
                if self.idleness.visits.len() != waypoints {
                    self.idleness = Idleness { last_visit: vec![None; waypoints], visits: vec![0; waypoints], ..Idleness::default() };
                }
                self.plan = Some((epoch, *plan));
                self.status = MissionStatus::Running;
                self.error = None;
                if !self.started {
                    self.started = true;
                    out.push(MCommand::Started);
                }
                out
            }
            MEvent::PlanFailed { epoch, error } => {
                if epoch != self.epoch {
                    return vec![];
                }
                tracing::warn!(mission = %self.spec.name, epoch, "planning failed: {error}");
                self.error = Some(error.clone());
                if self.started {
                    vec![]
                } else {
                    self.status = MissionStatus::Failed;
                    vec![MCommand::Failed { error }]
                }
            }
            MEvent::Telemetry { now, t } => {
                self.telemetry(now, &t);
                vec![]
            }
        }
    }

    /// One `SendPlan` per member with a plan.
    fn assignments(&self, epoch: u64, plan: &MissionPlan) -> Vec<MCommand> {
        let teams = self.teams();
        let members: Vec<String> = self.members.keys().cloned().collect();
        plan.plans()
            .iter()
            .filter(|rp| self.members.contains_key(&rp.robot))
            .map(|rp| {
                let subteam = teams
                    .iter()
                    .find(|(_, ids)| ids.contains(&rp.robot))
                    .map(|(t, _)| t.clone())
                    .unwrap_or_else(|| format!("{}/all", self.spec.name));
                MCommand::SendPlan {
                    robot: rp.robot.clone(),
                    assignment: Box::new(PlanAssignment {
                        mission: self.spec.name.clone(),
                        epoch,
                        team: self.spec.name.clone(),
                        subteam,
                        members: members.clone(),
                        plan: rp.clone(),
                    }),
                }
            })
            .collect()
    }

    /// The current plans again (a new head re-sends them after a takeover; robots already
    /// running them go on undisturbed).
    pub fn current_assignments(&self) -> Vec<MCommand> {
        match &self.plan {
            Some((e, p)) if *e == self.epoch => self.assignments(*e, p),
            _ => vec![],
        }
    }

    /// Takes members out; one replan if any was in.
    fn remove(&mut self, ids: Vec<String>) -> Vec<MCommand> {
        let mut any = false;
        for id in ids {
            if self.members.remove(&id).is_some() {
                any = true;
                if let Some(p) = self.progress.remove(&id) {
                    self.sync_msgs_left += p.sync_msgs as u64;
                }
            }
        }
        if any {
            self.replan()
        } else {
            vec![]
        }
    }

    /// New epoch, new plan for the current members.
    fn replan(&mut self) -> Vec<MCommand> {
        self.epoch += 1;
        if self.members.is_empty() {
            self.status = MissionStatus::Stalled;
            return vec![];
        }
        if self.started {
            self.status = MissionStatus::Running;
        }
        let request = PlanRequest {
            recipe: self.spec.recipe_xml.clone(),
            params: self.spec.params.clone(),
            robots: self.members.values().cloned().collect(),
        };
        tracing::info!(mission = %self.spec.name, epoch = self.epoch, robots = self.members.len(), "planning");
        vec![MCommand::RequestPlan { epoch: self.epoch, kind: self.spec.planner, request }]
    }

    fn telemetry(&mut self, now: f64, t: &Telemetry) {
        let Some(spec) = self.members.get_mut(&t.id) else { return };
        spec.x = t.pose.x;
        spec.y = t.pose.y;
        self.last_now = self.last_now.max(now);
        if let Some(p) = &t.progress {
            if p.mission == self.spec.name && p.epoch == self.epoch {
                self.progress.insert(t.id.clone(), p.clone());
            }
        }
        let Some((_, MissionPlan::Patrol(plan))) = &self.plan else { return };
        // Only robots on their round count: the way to the slot is not patrolling.
        let patrolling = t.progress.as_ref().is_some_and(|p| p.mission == self.spec.name && p.syncs_passed > 0);
        if !patrolling {
            return;
        }
        let here = Point::new(t.pose.x, t.pose.y);
        let idl = &mut self.idleness;
        for (i, wp) in plan.tour.iter().enumerate() {
            if wp.dist(here) > VISIT_RADIUS || i >= idl.last_visit.len() {
                continue;
            }
            match &idl.last_visit[i] {
                Some((when, who)) if who == &t.id && now - when < VISIT_DEBOUNCE_S => {}
                Some((when, _)) if now - when < VISIT_DEBOUNCE_S => {}
                Some((when, _)) => {
                    let gap = now - when;
                    idl.sum += gap;
                    idl.count += 1;
                    idl.worst = idl.worst.max(gap);
                    idl.visits[i] += 1;
                    idl.last_visit[i] = Some((now, t.id.clone()));
                }
                None => {
                    idl.visits[i] += 1;
                    idl.last_visit[i] = Some((now, t.id.clone()));
                }
            }
        }
    }

    /// Sub-teams by robot type: `<mission>/<type>` → members.
    pub fn teams(&self) -> BTreeMap<String, Vec<String>> {
        let mut teams: BTreeMap<String, Vec<String>> = BTreeMap::new();
        for m in self.members.values() {
            teams.entry(format!("{}/{}", self.spec.name, m.robot_type)).or_default().push(m.id.clone());
        }
        teams
    }

    pub fn metrics(&self) -> MissionMetrics {
        let idl = &self.idleness;
        // Waypoints waiting right now count too: the worst idleness is never below the current wait.
        let open = idl.last_visit.iter().flatten().map(|(w, _)| self.last_now - w).fold(0.0, f64::max);
        let any = idl.visits.iter().any(|&v| v > 0);
        let current: Vec<&Progress> = self.members.keys().filter_map(|id| self.progress.get(id)).collect();
        let full = current.len() == self.members.len() && !current.is_empty();
        let sync_msgs: u64 = self.sync_msgs_left + self.progress.values().map(|p| p.sync_msgs as u64).sum::<u64>();
        MissionMetrics {
            rounds: if full { current.iter().map(|p| p.round).min().unwrap_or(0) } else { 0 },
            avg_idleness: (idl.count > 0).then(|| idl.sum / idl.count as f64),
            worst_idleness: any.then(|| idl.worst.max(open)),
            visits: idl.visits.clone(),
            sync_points_passed: if full { current.iter().map(|p| p.syncs_passed).min().unwrap_or(0) } else { 0 },
            messages: BTreeMap::from([("plan".to_string(), self.plan_msgs), ("sync".to_string(), sync_msgs)]),
        }
    }

    /// The operator's view.
    pub fn view(&self, with_plans: bool) -> MissionView {
        let mut summary = self
            .plan
            .as_ref()
            .and_then(|(_, p)| serde_json::to_value(p).ok())
            .unwrap_or(serde_json::Value::Null);
        if let Some(o) = summary.as_object_mut() {
            o.remove("plans");
        }
        MissionView {
            name: self.spec.name.clone(),
            recipe: self.spec.recipe_name.clone(),
            planner: self.spec.planner.as_str().to_string(),
            status: self.status,
            robots: self.members.keys().cloned().collect(),
            teams: self.teams(),
            manager: ManagerView { node: self.node.clone(), epoch: self.epoch, chain_epoch: 0, chain: vec![] },
            metrics: self.metrics(),
            summary,
            params: self.spec.params.clone(),
            error: self.error.clone(),
            plans: with_plans.then(|| self.plan.as_ref().map(|(_, p)| p.plans().to_vec()).unwrap_or_default()),
        }
    }

    /// Predicted metric with `add` robots more (or fewer): patrol worst idleness `L / (n·v)`,
    /// coverage radius scaled by `√(n / n')` (radius ∝ 1/√n for a fixed area).
    pub fn marginal(&self, add: i64) -> Result<Marginal, String> {
        let (_, plan) = self.plan.as_ref().ok_or("the mission has no plan yet")?;
        let n = self.members.len();
        let with = n as i64 + add;
        if with < 1 {
            return Err(format!("the mission has {n} robots; cannot remove {}", -add));
        }
        let with = with as usize;
        let (metric, current, predicted) = match plan {
            MissionPlan::Patrol(p) => {
                let cur = p.predicted_worst_idleness;
                ("worst_idleness", cur, p.length / (with as f64 * p.team_speed))
            }
            MissionPlan::Coverage(c) => ("coverage_radius", c.coverage_radius, c.coverage_radius * (n as f64 / with as f64).sqrt()),
        };
        Ok(Marginal { mission: self.spec.name.clone(), metric: metric.into(), robots: n, current, with_robots: with, predicted })
    }
}

#[cfg(test)]
mod tests;
