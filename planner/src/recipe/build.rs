//! From a validated recipe, parameter overrides and robots to a mission plan: run the planner,
//! then expand each robot type's behaviour template into plan steps.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::{check_param, validate, PlannerKind, Recipe, Template};
use crate::coverage::{self, CoverageParams, CoveragePlan};
use crate::error::PlanError;
use crate::geom::Point;
use crate::patrol::{self, PatrolParams, PatrolPlan};
use crate::plan::{RobotPlan, RobotSpec, Step};
use crate::region::Region;

/// A planned mission: the planner's figures and one plan per robot.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "planner", rename_all = "snake_case")]
pub enum MissionPlan {
    Patrol(PatrolPlan),
    Coverage(CoveragePlan),
}

impl MissionPlan {
    pub fn plans(&self) -> &[RobotPlan] {
        match self {
            MissionPlan::Patrol(p) => &p.plans,
            MissionPlan::Coverage(c) => &c.plans,
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

/// Plans the recipe for `robots`; `overrides` replace the recipe's parameters (`waypoints` as
/// JSON `[[x, y], …]`, `region` as JSON `[[x, y], …]` or `{"outer": […], "holes": [[…]]}`).
pub fn build(r: &Recipe, overrides: &BTreeMap<String, String>, robots: &[RobotSpec]) -> Result<MissionPlan, PlanError> {
    validate(r)?;
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
    let get = |k: &str| scalars.get(k).map(|v| v.trim().to_string());
    let num = |k: &str| get(k).and_then(|v| v.parse::<f64>().ok());
    let whole = |k: &str| get(k).and_then(|v| v.parse::<u64>().ok());
    let rounds = get("rounds").and_then(|v| v.parse::<u32>().ok());
    for rb in robots {
        behaviour_for(r, &rb.robot_type)
            .ok_or_else(|| r.pos.err(format!("no <behaviour> for robot type {:?} (robot {}) and no type=\"*\"", rb.robot_type, rb.id)))?;
    }
    match r.planner {
        PlannerKind::Patrol => {
            let waypoints = match overrides.get("waypoints") {
                Some(json) => json_points("waypoints", json)?,
                None => r
                    .waypoints
                    .as_ref()
                    .map(|(w, _)| w.clone())
                    .ok_or_else(|| r.pos.err("a patrol needs waypoints: give <waypoints> in <params> or the parameter waypoints=[[x,y],…]"))?,
            };
            let mut params = PatrolParams::new(waypoints);
            params.rounds = rounds;
            if let Some(v) = num("sync_spacing_max") {
                params.sync_spacing_max = v;
            }
            if let Some(v) = whole("seed") {
                params.seed = v;
            }
            if let Some(v) = whole("max_kicks") {
                params.max_kicks = v;
            }
            let at = |e: PlanError| match (&r.waypoints, overrides.contains_key("waypoints")) {
                (Some((_, pos)), false) => pos.err(format!("waypoints: {e}")),
                _ => e,
            };
            let mut plan = patrol::plan(&params, robots).map_err(at)?;
            plan.plans = plan
                .assignments
                .iter()
                .map(|a| RobotPlan {
                    robot: a.robot.clone(),
                    robot_type: a.robot_type.clone(),
                    slot: a.slot,
                    steps: expand_for(r, &a.robot_type, a.start, &a.round, rounds),
                })
                .collect();
            Ok(MissionPlan::Patrol(plan))
        }
        PlannerKind::Coverage => {
            let (region, pos) = match overrides.get("region") {
                Some(json) => (json_region(json)?, None),
                None => {
                    let (outer, holes, pos) =
                        r.region.clone().ok_or_else(|| r.pos.err("a coverage needs a region: give <region> in <params> or the parameter region=[[x,y],…]"))?;
                    (Region { outer, holes }, Some(pos))
                }
            };
            let at = |e: PlanError| match pos {
                Some(p) => p.err(format!("region: {e}")),
                None => e,
            };
            let region = region.validated().map_err(at)?;
            let mut params = CoverageParams::new(region);
            if let Some(v) = whole("samples") {
                params.samples = v as usize;
            }
            if let Some(v) = whole("lloyd_iterations") {
                params.lloyd_iterations = v as usize;
            }
            if let Some(v) = whole("minimax_iterations") {
                params.minimax_iterations = v as usize;
            }
            if let Some(v) = whole("seed") {
                params.seed = v;
            }
            let mut plan = coverage::plan(&params, robots)?;
            let points = plan.points.clone();
            for p in plan.plans.iter_mut() {
                p.steps = expand_for(r, &p.robot_type, points[p.slot], &[], rounds);
            }
            Ok(MissionPlan::Coverage(plan))
        }
    }
}

fn behaviour_for<'a>(r: &'a Recipe, robot_type: &str) -> Option<&'a [Template]> {
    r.behaviours.iter().find(|b| b.robot_type == robot_type).or_else(|| r.behaviours.iter().find(|b| b.robot_type == "*")).map(|b| b.steps.as_slice())
}

fn expand_for(r: &Recipe, robot_type: &str, slot: Point, round: &[Step], rounds: Option<u32>) -> Vec<Step> {
    let mut out = Vec::new();
    if let Some(t) = behaviour_for(r, robot_type) {
        expand(t, slot, round, rounds, &mut out);
    }
    out
}

fn expand(templates: &[Template], slot: Point, round: &[Step], rounds: Option<u32>, out: &mut Vec<Step>) {
    for t in templates {
        match t {
            Template::Stream => out.push(Step::Stream),
            Template::NavigateSlot => out.push(Step::Navigate { x: slot.x, y: slot.y, speed: None }),
            Template::NavigateTo { x, y, speed } => out.push(Step::Navigate { x: *x, y: *y, speed: *speed }),
            Template::SyncStart => out.push(Step::Sync { point: 0 }),
            Template::Hold { seconds } => out.push(Step::Hold { seconds: *seconds }),
            Template::Round(_) => out.extend(round.iter().cloned()),
            Template::Loop { rounds: fixed, body, .. } => {
                let to = out.len();
                expand(body, slot, round, rounds, out);
                out.push(Step::Loop { to, rounds: fixed.or(rounds) });
            }
        }
    }
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
