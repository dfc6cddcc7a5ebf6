//! From a validated recipe, parameter overrides and robots to a mission plan: run the planner,
//! then expand each robot type's behaviour template into plan steps.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::{assign_as, check_override, check_param, validate, Bounds, PlannerKind, Recipe, Template};
use crate::coverage::{self, CoverageParams, CoveragePlan};
use crate::coverage_map;
use crate::error::PlanError;
use crate::geom::Point;
use crate::patrol::{self, PatrolParams, PatrolPlan};
use crate::region::Region;
use mrmm_maps::{Map, Space};
use mrmm_proto::plan::{RobotPlan, RobotSpec, Step};

/// Radius of a robot, metres, unless the recipe's `robot_radius` says otherwise: obstacles of a
/// map are inflated by it (by [`crate::corner::CORNER_CUT`] at least).
pub const DEFAULT_ROBOT_RADIUS: f64 = 0.25;

/// A planned mission: the planner's figures and one plan per robot.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "planner", rename_all = "snake_case")]
pub enum MissionPlan {
    Patrol(PatrolPlan),
    Coverage(CoveragePlan),
    /// A recipe of teams: each leaf team that has members, planned on its own.
    Teams {
        teams: Vec<TeamPlan>,
    },
}

/// One leaf team's plan in a mission of teams.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TeamPlan {
    /// The team's path below the mission.
    pub team: String,
    #[serde(flatten)]
    pub plan: MissionPlan,
}

impl MissionPlan {
    /// Every robot's plan, team after team.
    pub fn plans(&self) -> Vec<&RobotPlan> {
        match self {
            MissionPlan::Patrol(p) => p.plans.iter().collect(),
            MissionPlan::Coverage(c) => c.plans.iter().collect(),
            MissionPlan::Teams { teams } => teams.iter().flat_map(|t| t.plan.plans()).collect(),
        }
    }

    /// The robots left out for want of reach ([`PatrolPlan::held`], [`CoveragePlan::held`]),
    /// team after team.
    pub fn held(&self) -> Vec<mrmm_proto::RobotId> {
        match self {
            MissionPlan::Patrol(p) => p.held.clone(),
            MissionPlan::Coverage(c) => c.held.clone(),
            MissionPlan::Teams { teams } => teams.iter().flat_map(|t| t.plan.held()).collect(),
        }
    }

    fn plans_mut(&mut self) -> Vec<&mut RobotPlan> {
        match self {
            MissionPlan::Patrol(p) => p.plans.iter_mut().collect(),
            MissionPlan::Coverage(c) => c.plans.iter_mut().collect(),
            MissionPlan::Teams { teams } => teams.iter_mut().flat_map(|t| t.plan.plans_mut()).collect(),
        }
    }
}

/// Parses `key=value` overrides.
pub fn parse_overrides(items: &[String]) -> Result<BTreeMap<String, String>, PlanError> {
    let mut out = BTreeMap::new();
    for item in items {
        let (k, v) = item.split_once('=').ok_or_else(|| PlanError::Invalid(format!("parameter {item:?}: expected key=value")))?;
        out.insert(k.trim().to_string(), v.to_string());
    }
    Ok(out)
}

/// Plans the recipe for `robots` in the plane; see [`build_on`].
pub fn build(r: &Recipe, overrides: &BTreeMap<String, String>, robots: &[RobotSpec]) -> Result<MissionPlan, PlanError> {
    build_on(r, overrides, robots, None)
}

/// Plans the recipe for `robots` without capabilities; see [`build_for`].
pub fn build_on(r: &Recipe, overrides: &BTreeMap<String, String>, robots: &[RobotSpec], map: Option<&Map>) -> Result<MissionPlan, PlanError> {
    build_for(r, overrides, robots, &BTreeMap::new(), map)
}

/// Plans the recipe for `robots`, on `map` if one is given (routes along its free space or its
/// edges); `overrides` replace the recipe's parameters (`waypoints` as JSON `[[x, y], …]` or
/// `all` (every vertex of a graph map), `region` as JSON `[[x, y], …]` or `{"outer": […],
/// "holes": [[…]]}`; `<team path>/<name>` for one leaf team). A recipe of teams puts each robot
/// in a leaf team ([`assign`], by type and `caps`, the robots' capabilities by id) and plans
/// every leaf team on its own members.
pub fn build_for(
    r: &Recipe,
    overrides: &BTreeMap<String, String>,
    robots: &[RobotSpec],
    caps: &BTreeMap<String, Vec<String>>,
    map: Option<&Map>,
) -> Result<MissionPlan, PlanError> {
    build_with(r, overrides, robots, caps, map, Bounds::Strict)
}

/// [`build_for`], the teams' `min` and `max` applied as `bounds` says.
pub fn build_with(
    r: &Recipe,
    overrides: &BTreeMap<String, String>,
    robots: &[RobotSpec],
    caps: &BTreeMap<String, Vec<String>>,
    map: Option<&Map>,
    bounds: Bounds,
) -> Result<MissionPlan, PlanError> {
    validate(r)?;
    if !r.has_teams() {
        return build_leaf(r, overrides, robots, map);
    }
    for (k, v) in overrides {
        check_override(r, k, v).map_err(PlanError::Invalid)?;
    }
    let groups = assign_as(r, robots, caps, bounds)?;
    let mut teams = Vec::new();
    for (leaf, members) in r.leaves().iter().zip(groups) {
        if members.is_empty() {
            continue;
        }
        let path = leaf.path();
        let mut mine = BTreeMap::new();
        for (k, v) in overrides.iter().filter(|(k, _)| !k.contains('/')) {
            if leaf.recipe.planner.takes(k) {
                mine.insert(k.clone(), v.clone());
            }
        }
        for (k, v) in overrides {
            if let Some(param) = k.strip_prefix(path).and_then(|rest| rest.strip_prefix('/')) {
                mine.insert(param.to_string(), v.clone());
            }
        }
        let specs: Vec<RobotSpec> = members.iter().map(|&i| robots[i].clone()).collect();
        let mut plan = build_leaf(leaf.recipe, &mine, &specs, map).map_err(|e| PlanError::Invalid(format!("team {path}: {e}")))?;
        for p in plan.plans_mut() {
            p.team = path.to_string();
        }
        teams.push(TeamPlan { team: path.to_string(), plan });
    }
    Ok(MissionPlan::Teams { teams })
}

/// Plans one team (a recipe without teams, or a leaf team) for its members.
fn build_leaf(r: &Recipe, overrides: &BTreeMap<String, String>, robots: &[RobotSpec], map: Option<&Map>) -> Result<MissionPlan, PlanError> {
    let mut scalars: BTreeMap<String, String> = r.params.iter().map(|(k, (v, _))| (k.clone(), v.clone())).collect();
    for (k, v) in overrides {
        match k.as_str() {
            "waypoints" | "region" => {}
            _ => {
                check_param(r.planner, k, v).map_err(PlanError::Invalid)?;
                scalars.insert(k.clone(), v.clone());
            }
        }
    }
    let scalars = Scalars(scalars);
    // A robot rounds a corner it drives through by up to the corner cut: the walls are kept at
    // least that far from the routes, whatever the radius given.
    let radius = scalars.num("robot_radius").unwrap_or(DEFAULT_ROBOT_RADIUS).max(crate::corner::CORNER_CUT);
    let space = match map {
        Some(m) => Some(Space::new(m, radius)?),
        None => None,
    };
    for rb in robots {
        behaviour_for(r, &rb.robot_type)
            .ok_or_else(|| r.pos.err(format!("no <behaviour> for robot type {:?} (robot {}) and no type=\"*\"", rb.robot_type, rb.id)))?;
    }
    let rounds = scalars.get("rounds").and_then(|v| v.parse::<u32>().ok());
    let leaf = Leaf { r, overrides, scalars, robots, map, space, rounds };
    match r.planner {
        PlannerKind::Patrol => leaf.patrol(),
        PlannerKind::Coverage => leaf.coverage(),
    }
}

/// A recipe's scalar parameters, with the mission's overrides applied.
struct Scalars(BTreeMap<String, String>);

impl Scalars {
    fn get(&self, k: &str) -> Option<String> {
        self.0.get(k).map(|v| v.trim().to_string())
    }

    fn num(&self, k: &str) -> Option<f64> {
        self.get(k).and_then(|v| v.parse::<f64>().ok())
    }

    fn whole(&self, k: &str) -> Option<u64> {
        self.get(k).and_then(|v| v.parse::<u64>().ok())
    }
}

/// One team to plan: its recipe, the mission's overrides, its members and the map.
struct Leaf<'a> {
    r: &'a Recipe,
    overrides: &'a BTreeMap<String, String>,
    scalars: Scalars,
    robots: &'a [RobotSpec],
    map: Option<&'a Map>,
    space: Option<Space>,
    rounds: Option<u32>,
}

impl Leaf<'_> {
    /// The patrol's waypoints: the override (`"all"`: every vertex of a graph map), else the recipe's.
    fn waypoints(&self) -> Result<Vec<Point>, PlanError> {
        match self.overrides.get("waypoints") {
            Some(all) if matches!(all.trim(), "all" | "\"all\"") => match self.map {
                // Vertices drawn on the same spot (some graphs have them) are one waypoint.
                Some(Map::Graph(g)) => {
                    let mut seen = Vec::<Point>::with_capacity(g.vertices.len());
                    for v in &g.vertices {
                        if !seen.contains(&v.at) {
                            seen.push(v.at);
                        }
                    }
                    Ok(seen)
                }
                _ => Err(PlanError::Invalid("waypoints: \"all\" patrols every vertex of a graph map; this mission has none".into())),
            },
            Some(json) => json_points("waypoints", json),
            None => self
                .r
                .waypoints
                .as_ref()
                .map(|(w, _)| w.clone())
                .ok_or_else(|| self.r.pos.err("a patrol needs waypoints: give <waypoints> in <params> or the parameter waypoints=[[x,y],…]")),
        }
    }

    /// Member `id` (a robot the planner was given).
    fn robot(&self, id: &str) -> Result<&RobotSpec, PlanError> {
        self.robots.iter().find(|r| r.id.as_str() == id).ok_or_else(|| PlanError::Invalid(format!("the planner placed robot {id}, which it was not given")))
    }

    fn patrol(&self) -> Result<MissionPlan, PlanError> {
        let (r, s) = (self.r, &self.scalars);
        let mut params = PatrolParams::new(self.waypoints()?);
        params.rounds = self.rounds;
        if let Some(v) = s.num("sync_spacing_max") {
            params.sync_spacing_max = v;
        }
        if let Some(v) = s.whole("seed") {
            params.seed = v;
        }
        if let Some(v) = s.whole("max_kicks") {
            params.max_kicks = v;
        }
        // The recipe's turn rate, else the slowest turner's among the robots that say theirs.
        params.turn_rate = s.num("turn_rate").or_else(|| self.robots.iter().filter_map(|r| r.turn_rate).reduce(f64::min));
        let at = |e: PlanError| match (&r.waypoints, self.overrides.contains_key("waypoints")) {
            (Some((_, pos)), false) => pos.err(format!("waypoints: {e}")),
            _ => e,
        };
        let mut plan = patrol::plan_on(&params, self.robots, self.space.as_ref()).map_err(at)?;
        plan.plans = plan
            .assignments
            .iter()
            .map(|a| {
                let rb = self.robot(&a.robot)?;
                let x = Expand { approach: &a.approach, round: &a.round, start_hold: a.start_hold(), rounds: self.rounds, space: self.space.as_ref() };
                Ok(RobotPlan {
                    robot: a.robot.as_str().into(),
                    robot_type: a.robot_type.clone(),
                    slot: a.slot,
                    steps: expand_for(r, rb, &x)?,
                    team: String::new(),
                })
            })
            .collect::<Result<_, PlanError>>()?;
        Ok(MissionPlan::Patrol(plan))
    }

    fn coverage(&self) -> Result<MissionPlan, PlanError> {
        let (r, s) = (self.r, &self.scalars);
        let (region, pos) = match (self.overrides.get("region"), &r.region, self.map) {
            (Some(json), _, _) => (json_region(json)?, None),
            (None, Some((outer, holes, pos)), _) => (Region { outer: outer.clone(), holes: holes.clone() }, Some(*pos)),
            (None, None, Some(m)) => (map_box(m), None),
            (None, None, None) => return Err(r.pos.err("a coverage needs a region: give <region> in <params> or the parameter region=[[x,y],…]")),
        };
        let at = |e: PlanError| match pos {
            Some(p) => p.err(format!("region: {e}")),
            None => e,
        };
        let region = region.validated().map_err(at)?;
        let mut params = CoverageParams::new(region);
        if let Some(v) = s.whole("samples") {
            params.samples = v as usize;
        }
        if let Some(v) = s.whole("lloyd_iterations") {
            params.lloyd_iterations = v as usize;
        }
        if let Some(v) = s.whole("minimax_iterations") {
            params.minimax_iterations = v as usize;
        }
        if let Some(v) = s.whole("seed") {
            params.seed = v;
        }
        let (mut plan, routes) = match &self.space {
            Some(space) => coverage_map::plan_on(&params, self.robots, space)?,
            None => {
                let plan = coverage::plan(&params, self.robots)?;
                let routes = plan.plans.iter().map(|p| vec![plan.points[p.slot]]).collect();
                (plan, routes)
            }
        };
        for (p, route) in plan.plans.iter_mut().zip(&routes) {
            let rb = self.robot(p.robot.as_str())?;
            p.steps = expand_for(r, rb, &Expand { approach: route, round: &[], start_hold: None, rounds: self.rounds, space: self.space.as_ref() })?;
        }
        Ok(MissionPlan::Coverage(plan))
    }
}

/// The box around a map, as a region (a coverage of the whole map's free space).
fn map_box(m: &Map) -> Region {
    let (lo, hi) = match m {
        Map::Grid(g) => g.bounds(),
        Map::Graph(g) => {
            let (lo, hi) = g.bounds();
            (Point::new(lo.x - 1.0, lo.y - 1.0), Point::new(hi.x + 1.0, hi.y + 1.0))
        }
    };
    Region { outer: vec![lo, Point::new(hi.x, lo.y), hi, Point::new(lo.x, hi.y)], holes: vec![] }
}

fn behaviour_for<'a>(r: &'a Recipe, robot_type: &str) -> Option<&'a [Template]> {
    r.behaviours.iter().find(|b| b.robot_type == robot_type).or_else(|| r.behaviours.iter().find(|b| b.robot_type == "*")).map(|b| b.steps.as_slice())
}

/// What a robot's behaviour template is expanded with.
struct Expand<'a> {
    /// The points the robot drives through to its slot, the slot last.
    approach: &'a [Point],
    round: &'a [Step],
    /// After the start barrier ([`crate::patrol::PatrolAssignment::start_hold`]).
    start_hold: Option<Step>,
    rounds: Option<u32>,
    /// The mission's map: a fixed `<navigate x y>` follows a route on it.
    space: Option<&'a Space>,
}

fn expand_for(r: &Recipe, robot: &RobotSpec, x: &Expand) -> Result<Vec<Step>, PlanError> {
    let mut out = Vec::new();
    if let Some(t) = behaviour_for(r, &robot.robot_type) {
        let mut at = Point::new(robot.x, robot.y);
        expand(t, x, &r.path, &mut at, &mut out)?;
    }
    Ok(out)
}

fn expand(templates: &[Template], x: &Expand, path: &str, at: &mut Point, out: &mut Vec<Step>) -> Result<(), PlanError> {
    for t in templates {
        match t {
            Template::Stream => out.push(Step::Stream),
            Template::NavigateSlot => {
                out.extend(crate::patrol::navigate_through(x.approach, None));
                *at = x.approach.last().copied().unwrap_or(*at);
            }
            Template::NavigateTo { x: tx, y: ty, speed } => {
                let target = Point::new(*tx, *ty);
                let route = match x.space {
                    None => vec![target],
                    Some(space) => {
                        let (from, to) = (space.locate_robot("robot", 0, *at)?, space.locate("<navigate> point", out.len(), target)?);
                        let mut r =
                            space.route(&from, &to).ok_or_else(|| PlanError::Invalid(format!("<navigate x={tx} y={ty}>: cannot be reached on the map")))?;
                        r.remove(0);
                        r
                    }
                };
                out.extend(crate::patrol::navigate_through(&route, *speed));
                *at = target;
            }
            Template::SyncStart(scope) => {
                out.push(Step::Sync { point: 0, scope: scope.resolve(path) });
                out.extend(x.start_hold.clone());
            }
            Template::Hold { seconds } => out.push(Step::Hold { seconds: *seconds }),
            Template::Round(_) => {
                out.extend(x.round.iter().cloned());
                if let Some(Step::Navigate { x, y, .. }) = x.round.iter().rev().find(|s| matches!(s, Step::Navigate { .. })) {
                    *at = Point::new(*x, *y);
                }
            }
            Template::Loop { rounds: fixed, body, .. } => {
                let to = out.len();
                expand(body, x, path, at, out)?;
                out.push(Step::Loop { to, rounds: fixed.or(x.rounds) });
            }
        }
    }
    Ok(())
}

fn json_points(name: &str, json: &str) -> Result<Vec<Point>, PlanError> {
    let raw: Vec<[f64; 2]> = serde_json::from_str(json).map_err(|e| PlanError::Invalid(format!("parameter {name}: expected [[x, y], …]: {e}")))?;
    crate::limits::at_most(name, raw.len(), crate::limits::MAX_WAYPOINTS)?;
    Ok(raw.into_iter().map(|[x, y]| Point::new(x, y)).collect())
}

fn json_region(json: &str) -> Result<Region, PlanError> {
    #[derive(Deserialize)]
    #[serde(deny_unknown_fields)]
    struct Raw {
        outer: Vec<[f64; 2]>,
        #[serde(default)]
        holes: Vec<Vec<[f64; 2]>>,
    }
    let pts = |v: Vec<[f64; 2]>| v.into_iter().map(|[x, y]| Point::new(x, y)).collect::<Vec<_>>();
    if let Ok(outer) = serde_json::from_str::<Vec<[f64; 2]>>(json) {
        return Ok(Region { outer: pts(outer), holes: vec![] });
    }
    let raw: Raw = serde_json::from_str(json)
        .map_err(|e| PlanError::Invalid(format!("parameter region: expected [[x, y], …] or {{\"outer\": […], \"holes\": [[…]]}}: {e}")))?;
    Ok(Region { outer: pts(raw.outer), holes: raw.holes.into_iter().map(pts).collect() })
}
