//! A plan request answered by the planner library: the recipe checked against the planner kind,
//! the robots and the map translated, the plan translated back to the wire.

use mrmm_maps::Map;
use mrmm_planner::recipe::{self, PlannerKind};
use mrmm_proto::{MissionPlan, PlanRequest};

/// Plans a request with the planner library, checking that the recipe is of `kind`; a request
/// that names a map needs [`plan_on`].
pub fn plan(kind: PlannerKind, req: &PlanRequest) -> Result<MissionPlan, String> {
    plan_on(kind, req, None)
}

/// Plans a request on `map`, the map it names (held by this node).
pub fn plan_on(kind: PlannerKind, req: &PlanRequest, map: Option<&Map>) -> Result<MissionPlan, String> {
    if let (Some(r), None) = (&req.map, map) {
        return Err(format!("map {} ({}) is not held here", r.name, r.hash));
    }
    let xml = recipe::bank(&req.recipe).unwrap_or(&req.recipe);
    let r = recipe::parse(xml).map_err(|e| format!("recipe: {e}"))?;
    if r.planner != kind {
        return Err(format!("this is the {} planner; the recipe needs {}", kind.as_str(), r.planner.as_str()));
    }
    let bounds = if req.relax_bounds { recipe::Bounds::Relaxed } else { recipe::Bounds::Strict };
    let caps = req.capabilities.iter().map(|(id, c)| (id.to_string(), c.clone())).collect();
    let planned = recipe::build_with(&r, &req.params, &req.robots, &caps, map, bounds).map_err(|e| e.to_string())?;
    Ok(planned.to_wire())
}
