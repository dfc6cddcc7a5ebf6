//! What a mission is ([`MissionSpec`]), and its form on the wire (checked when read).

use std::collections::BTreeMap;

use mrmm_planner::recipe::PlannerKind;
use mrmm_proto::{self as proto, MissionSpecWire};

/// What a mission is.
#[derive(Debug, Clone, PartialEq)]
pub struct MissionSpec {
    pub name: mrmm_proto::MissionName,
    /// Bank name, or `custom` for an inline recipe.
    pub recipe_name: String,
    pub recipe_xml: String,
    pub planner: PlannerKind,
    pub params: BTreeMap<String, String>,
    /// Replicas of the manager's state after the head.
    pub replicas: usize,
    /// Capabilities every member must have (the recipe's `<requires>`, sorted).
    pub requires: Vec<String>,
    /// The map it plans on; none: the plane.
    pub map: Option<proto::MapRef>,
    /// Paused by the operator: its members hold where they are.
    pub paused: bool,
}

impl MissionSpec {
    pub fn to_wire(&self) -> MissionSpecWire {
        MissionSpecWire {
            name: self.name.clone(),
            recipe_name: self.recipe_name.clone(),
            recipe_xml: self.recipe_xml.clone(),
            planner: self.planner.as_str().to_string(),
            params: self.params.clone(),
            replicas: self.replicas,
            map: self.map.clone(),
            paused: self.paused,
        }
    }

    pub fn from_wire(w: MissionSpecWire) -> Result<Self, String> {
        let planner = match w.planner.as_str() {
            "patrol" => PlannerKind::Patrol,
            "coverage" => PlannerKind::Coverage,
            other => return Err(format!("unknown planner {other:?}")),
        };
        proto::validate_id(w.name.as_str()).map_err(|e| e.to_string())?;
        if w.replicas > proto::MAX_REPLICAS {
            return Err(format!("replicas: at most {} (got {})", proto::MAX_REPLICAS, w.replicas));
        }
        if let Some(m) = &w.map {
            m.check().map_err(|e| format!("map: {e}"))?;
        }
        // A recipe that does not parse requires nothing here: planning reports its error.
        let requires = mrmm_planner::recipe::parse(&w.recipe_xml).map(|r| r.required()).unwrap_or_default();
        Ok(MissionSpec {
            name: w.name,
            recipe_name: w.recipe_name,
            recipe_xml: w.recipe_xml,
            planner,
            params: w.params,
            replicas: w.replicas,
            requires,
            map: w.map,
            paused: w.paused,
        })
    }
}
