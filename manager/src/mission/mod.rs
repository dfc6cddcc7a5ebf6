//! A mission manager as a state machine: it owns a mission's team, asks for plans when the team
//! changes, hands each robot its plan with the current epoch, and computes the mission's metrics
//! from telemetry. No I/O: [`MissionManager::handle`] returns [`MCommand`]s.

use std::collections::BTreeMap;

use mrmm_peer::proto::{
    ManagerView, Marginal, MissionMetrics, MissionStatus, MissionView, PlanAssignment, PlanRequest, Progress, Telemetry,
};
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
}

impl MissionSpec {
    pub fn to_wire(&self) -> mrmm_peer::proto::MissionSpecWire {
        mrmm_peer::proto::MissionSpecWire {
            name: self.name.clone(),
            recipe_name: self.recipe_name.clone(),
            recipe_xml: self.recipe_xml.clone(),
            planner: self.planner.as_str().to_string(),
            params: self.params.clone(),
        }
    }

    pub fn from_wire(w: mrmm_peer::proto::MissionSpecWire) -> Result<Self, String> {
        let planner = match w.planner.as_str() {
            "patrol" => PlannerKind::Patrol,
            "coverage" => PlannerKind::Coverage,
            other => return Err(format!("unknown planner {other:?}")),
        };
        mrmm_peer::proto::validate_id(&w.name).map_err(|e| e.to_string())?;
        Ok(MissionSpec { name: w.name, recipe_name: w.recipe_name, recipe_xml: w.recipe_xml, planner, params: w.params })
    }
}

/// Something that happened to the mission.
#[derive(Debug, Clone, PartialEq)]
pub enum MEvent {
    /// The mission starts with its initial members.
    Start,
    /// A robot joins (created with it, moved in).
    Joined(RobotSpec),
    /// Robots leave (moved out, ordered out) or are lost; one replan for all of them.
    Left { ids: Vec<String> },
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
        }
    }

    pub fn name(&self) -> &str {
        &self.spec.name
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
                self.members.insert(spec.id.clone(), spec);
                self.replan()
            }
            MEvent::Left { ids } => {
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
            MEvent::PlanReady { epoch, plan } => {
                if epoch != self.epoch {
                    return vec![]; // superseded by a newer team
                }
                let mut out = Vec::new();
                let teams = self.teams();
                let members: Vec<String> = self.members.keys().cloned().collect();
                for rp in plan.plans() {
                    if !self.members.contains_key(&rp.robot) {
                        continue;
                    }
                    let subteam = teams
                        .iter()
                        .find(|(_, ids)| ids.contains(&rp.robot))
                        .map(|(t, _)| t.clone())
                        .unwrap_or_else(|| format!("{}/all", self.spec.name));
                    self.plan_msgs += 1;
                    out.push(MCommand::SendPlan {
                        robot: rp.robot.clone(),
                        assignment: Box::new(PlanAssignment {
                            mission: self.spec.name.clone(),
                            epoch,
                            team: self.spec.name.clone(),
                            subteam,
                            members: members.clone(),
                            plan: rp.clone(),
                        }),
                    });
                }
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
            manager: ManagerView { node: self.node.clone(), epoch: self.epoch },
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
