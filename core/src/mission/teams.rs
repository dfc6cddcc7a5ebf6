//! The mission's teams: which leaf team each member is in (its plan says), the plans handed out
//! with each member's team and the wider teams its barriers wait on, and the teams as the
//! operator sees them.

use std::collections::BTreeMap;

use mrmm_proto::plan::MissionPlan;
use mrmm_proto::{self as proto, BarrierMode, PlanAssignment, RobotId, ScopeMembers};

use super::{Command, MissionManager, LEADER_BARRIER_FROM};

/// A leaf team of a recipe of teams, as the operator's view shows it (read from the recipe once
/// per definition, not at every view).
#[derive(Debug, Clone, PartialEq)]
pub(super) struct TeamShape {
    path: String,
    planner: String,
    min: usize,
    wants: String,
    robot_type: Option<String>,
    requires: Vec<String>,
}

/// The leaf teams of recipe `xml` (none for a recipe planned as a whole, or one that does not
/// parse: planning reports its error).
pub(super) fn shapes(xml: &str) -> Vec<TeamShape> {
    let Ok(r) = mrmm_planner::recipe::parse(xml) else { return vec![] };
    if !r.has_teams() {
        return vec![];
    }
    r.leaves()
        .iter()
        .map(|l| TeamShape {
            path: l.path().to_string(),
            planner: l.recipe.planner.as_str().into(),
            min: l.min,
            wants: l.wants(),
            robot_type: l.types.first().map(|t| t.to_string()),
            requires: l.requires.iter().map(|c| c.to_string()).collect(),
        })
        .collect()
}

impl MissionManager {
    /// One `SendPlan` per member with a plan. A member's team is its leaf team's path
    /// (`<mission>/<team>…`, the mission's name for a recipe without teams) and its members that
    /// leaf's; each wider team the plan has barriers with comes with the members whose plans
    /// have barriers there too.
    pub(super) fn assignments(&self, epoch: u64, plan: &MissionPlan) -> Vec<Command> {
        let mission = &self.spec.name;
        let path = |team: &str| if team.is_empty() { mission.to_string() } else { format!("{mission}/{team}") };
        let mut leaves: BTreeMap<&str, Vec<RobotId>> = BTreeMap::new();
        let mut scoped: BTreeMap<String, Vec<RobotId>> = BTreeMap::new();
        for rp in plan.plans.iter().filter(|rp| self.members.contains_key(&rp.robot)) {
            leaves.entry(rp.team.as_str()).or_default().push(rp.robot.clone());
            for scope in scopes_of(rp) {
                let p = if scope.is_empty() { mission.to_string() } else { path(&scope) };
                scoped.entry(p).or_default().push(rp.robot.clone());
            }
        }
        for v in scoped.values_mut() {
            v.sort();
            v.dedup();
        }
        plan.plans
            .iter()
            .filter_map(|rp| {
                let m = self.members.get(&rp.robot)?;
                let team = path(&rp.team);
                let scopes = scopes_of(rp)
                    .into_iter()
                    .map(|s| if s.is_empty() { mission.to_string() } else { path(&s) })
                    .filter(|p| *p != team)
                    .map(|p| ScopeMembers { members: scoped.get(&p).cloned().unwrap_or_default(), team: p })
                    .collect();
                Some(Command::SendPlan {
                    robot: rp.robot.clone(),
                    assignment: Box::new(PlanAssignment {
                        mission: mission.clone(),
                        epoch,
                        subteam: format!("{team}/{}", m.spec.robot_type),
                        team,
                        members: leaves.get(rp.team.as_str()).cloned().unwrap_or_default(),
                        plan: rp.clone(),
                        // Filled in by the host with the chain when the plan goes out.
                        managers: vec![],
                        barrier: self.barrier(),
                        scopes,
                        map: self.spec.map.clone(),
                        handover: self.handover_for(&rp.robot),
                    }),
                })
            })
            .chain(self.holds(epoch, plan))
            .collect()
    }

    /// For each member the plan leaves out for want of reach ([`MissionPlan::held`]): a plan
    /// that holds it where it is, in a team of its own (no barrier of the others waits on it).
    fn holds<'a>(&'a self, epoch: u64, plan: &'a MissionPlan) -> impl Iterator<Item = Command> + 'a {
        plan.held.iter().filter_map(move |id| {
            let m = self.members.get(id)?;
            let team = self.spec.name.to_string();
            Some(Command::SendPlan {
                robot: id.clone(),
                assignment: Box::new(PlanAssignment {
                    mission: self.spec.name.clone(),
                    epoch,
                    subteam: format!("{team}/{}", m.spec.robot_type),
                    team,
                    members: vec![id.clone()],
                    plan: proto::RobotPlan {
                        robot: id.clone(),
                        robot_type: m.spec.robot_type.clone(),
                        slot: 0,
                        steps: vec![proto::Step::Stream, proto::Step::Hold { seconds: None }],
                        team: String::new(),
                    },
                    managers: vec![],
                    barrier: self.barrier(),
                    scopes: vec![],
                    map: self.spec.map.clone(),
                    handover: None,
                }),
            })
        })
    }

    /// The members the current plan leaves out for want of reach.
    pub(super) fn held(&self) -> Vec<RobotId> {
        self.plan.as_ref().map(|(_, p)| p.held.iter().filter(|id| self.members.contains_key(*id)).cloned().collect()).unwrap_or_default()
    }

    /// How the mission's team runs its barriers: the patrol parameter `barrier` (checked on
    /// create), or by the team's size — the mesh barrier up to [`LEADER_BARRIER_FROM`] members,
    /// the leader barrier from there (docs/evaluation.md: equal idleness up to 20 robots with
    /// the mesh's shorter wait; from 30 the mesh's n(n−1) deliveries per barrier cost more than
    /// the leader's extra hop).
    fn barrier(&self) -> BarrierMode {
        match self.spec.params.get("barrier").and_then(|v| BarrierMode::parse(v)) {
            Some(mode) => mode,
            None if self.members.len() >= LEADER_BARRIER_FROM => BarrierMode::Leader,
            None => BarrierMode::Mesh,
        }
    }

    /// Each member's leaf team as last planned (a path below the mission; `""`: a recipe
    /// without teams).
    pub(super) fn planned_teams(&self) -> BTreeMap<&str, &str> {
        self.plan.as_ref().map(|(_, p)| p.plans.iter().map(|rp| (rp.robot.as_str(), rp.team.as_str())).collect()).unwrap_or_default()
    }

    /// Teams by path: a recipe of teams gives each leaf team (`<mission>/<team>…`) its members as
    /// last planned (a member not planned yet is under the mission's own name); a recipe without
    /// teams, the sub-teams by robot type (`<mission>/<type>`).
    pub fn teams(&self) -> BTreeMap<String, Vec<RobotId>> {
        let planned = self.planned_teams();
        let of_teams = planned.values().any(|t| !t.is_empty());
        let mut teams: BTreeMap<String, Vec<RobotId>> = BTreeMap::new();
        for m in self.members.values() {
            let key = match planned.get(m.spec.id.as_str()) {
                Some(t) if !t.is_empty() => format!("{}/{t}", self.spec.name),
                _ if of_teams => self.spec.name.to_string(),
                _ => format!("{}/{}", self.spec.name, m.spec.robot_type),
            };
            teams.entry(key).or_default().push(m.spec.id.clone());
        }
        teams
    }

    /// A recipe of teams: each leaf team with its planner, members (as last planned), barriers
    /// passed and what it needs; empty otherwise.
    pub fn team_views(&self) -> Vec<proto::TeamView> {
        if self.shapes.is_empty() {
            return vec![];
        }
        let mut teams = self.teams();
        self.shapes
            .iter()
            .map(|s| {
                let team = format!("{}/{}", self.spec.name, s.path);
                let members = teams.remove(&team).unwrap_or_default();
                proto::TeamView {
                    barriers_passed: self.metrics.syncs_passed(&members),
                    planner: s.planner.clone(),
                    min: s.min,
                    wants: s.wants.clone(),
                    robot_type: s.robot_type.clone(),
                    requires: s.requires.clone(),
                    members,
                    team,
                }
            })
            .collect()
    }
}
/// The scopes (team paths below the mission, `""` the mission) of a plan's barriers that are
/// not its own team's.
fn scopes_of(rp: &proto::RobotPlan) -> Vec<String> {
    let mut out: Vec<String> =
        rp.steps.iter().filter_map(|s| if let proto::Step::Sync { scope: Some(sc), .. } = s { Some(sc.clone()) } else { None }).collect();
    out.sort();
    out.dedup();
    out
}
