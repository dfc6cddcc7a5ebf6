//! Plans on the wire: robots as planners see them, plan steps, per-robot plans and a mission's
//! plan with the planner's figures. These are the protocol's own types, decoupled from the
//! planner library's internals (the manager converts between the two), so a planner refactor
//! cannot change what robots and services exchange.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::geom::Point;

/// A robot as planners see it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RobotSpec {
    pub id: crate::ids::RobotId,
    #[serde(rename = "type")]
    pub robot_type: String,
    pub x: f64,
    pub y: f64,
    /// Maximum speed, m/s.
    pub speed: f64,
    /// Maximum turn rate, rad/s (None: not known; turns then take no time in its plans).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub turn_rate: Option<f64>,
    /// How far its battery takes it now, metres (None: no battery it knows of). Planners give
    /// a robot no leg longer than this; one that fits none is left out of the plan ([`MissionPlan::held`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reach_m: Option<f64>,
}

/// One step of a robot plan. JSON is externally tagged: `{"navigate": {"x": 1, "y": 2,
/// "speed": 0.8}}`, `{"sync": {"point": 3}}`, `"stream"`, `{"hold": {"seconds": null}}`,
/// `{"loop": {"to": 2, "rounds": null}}`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Step {
    /// Drive to (x, y); `speed` caps the robot's speed (m/s), `None` means its maximum.
    Navigate { x: f64, y: f64, speed: Option<f64> },
    /// Barrier number `point` of the current round: wait until every live member of the team
    /// arrived. `scope` names the team, as a path below the mission (`""`: the whole mission,
    /// `ground/north`); none: the robot's own team (its plan's `team`).
    Sync {
        point: u32,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        scope: Option<String>,
    },
    /// Stream telemetry (robots always do; kept so recipes can say it explicitly).
    Stream,
    /// Stay put, for `seconds` or (None) until the plan changes.
    Hold { seconds: Option<f64> },
    /// Jump back to step `to`; `rounds` limits how many times (None: forever).
    Loop { to: usize, rounds: Option<u32> },
}

/// The plan of one robot in a mission.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RobotPlan {
    pub robot: crate::ids::RobotId,
    #[serde(rename = "type")]
    pub robot_type: String,
    /// Slot (patrol) or point (coverage) index the robot was assigned.
    pub slot: usize,
    pub steps: Vec<Step>,
    /// The robot's team, as a path below the mission (`ground/north`); empty: the mission's
    /// own team (a recipe without teams).
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub team: String,
}

/// A polygon with holes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Region {
    pub outer: Vec<Point>,
    #[serde(default)]
    pub holes: Vec<Vec<Point>>,
}

/// The patrol planner's figures.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PatrolSummary {
    /// The closed route, in driving order: the waypoints and, on a map, every corner between
    /// them.
    pub tour: Vec<Point>,
    /// The waypoints in visiting order (empty from an older planner: then `tour`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub waypoints: Vec<Point>,
    pub length: f64,
    /// Arc offset of slot 0 along the tour.
    pub offset: f64,
    /// Arc distance between consecutive robots.
    pub spacing: f64,
    pub team_speed: f64,
    /// Sync points per round.
    pub sync_per_round: u32,
    /// Time until the last robot is at its slot, s.
    pub formation_time: f64,
    /// Predicted worst idleness of a waypoint, s.
    pub predicted_worst_idleness: f64,
    /// Lower bound of the worst idleness for these robots, s.
    pub idleness_lower_bound: f64,
}

/// The coverage planner's figures.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CoverageSummary {
    pub region: Region,
    pub points: Vec<Point>,
    /// Largest distance from a point of the region to its nearest robot, metres.
    pub coverage_radius: f64,
    /// Hexagonal covering bound for this area and n.
    pub hexagonal_bound: f64,
    /// Time until the last robot is in place, s.
    pub formation_time: f64,
}

/// A planner's figures, tagged with the planner: `{"planner": "patrol", "tour": …, …}`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "planner", rename_all = "snake_case")]
pub enum PlanSummary {
    Patrol(PatrolSummary),
    Coverage(CoverageSummary),
}

impl PlanSummary {
    /// The planner's name: `patrol` or `coverage`.
    pub fn planner(&self) -> &'static str {
        match self {
            PlanSummary::Patrol(_) => "patrol",
            PlanSummary::Coverage(_) => "coverage",
        }
    }
    pub fn patrol(&self) -> Option<&PatrolSummary> {
        match self {
            PlanSummary::Patrol(p) => Some(p),
            PlanSummary::Coverage(_) => None,
        }
    }
    pub fn coverage(&self) -> Option<&CoverageSummary> {
        match self {
            PlanSummary::Coverage(c) => Some(c),
            PlanSummary::Patrol(_) => None,
        }
    }
}

/// One leaf team's figures in a mission of several teams.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TeamSummary {
    /// The team's path below the mission (`ground/north`).
    pub team: String,
    #[serde(flatten)]
    pub summary: PlanSummary,
}

/// A planned mission, as a planner service answers it: the figures and one plan per robot.
/// A mission of several teams has each leaf team's figures in `teams`; `summary` is then the
/// first leaf team's.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MissionPlan {
    #[serde(flatten)]
    pub summary: PlanSummary,
    pub plans: Vec<RobotPlan>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub teams: Vec<TeamSummary>,
    /// Robots the plan leaves out because their battery's reach is short of every leg it could
    /// give them: they hold where they are (and charge, where the mission lets central send them).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub held: Vec<crate::ids::RobotId>,
}

impl MissionPlan {
    /// The figures of leaf team `team` (a path below the mission; `""`: a mission without
    /// teams).
    pub fn team_summary(&self, team: &str) -> Option<&PlanSummary> {
        if self.teams.is_empty() {
            return team.is_empty().then_some(&self.summary);
        }
        self.teams.iter().find(|t| t.team == team).map(|t| &t.summary)
    }

    /// Every leaf team's figures: (path below the mission, figures).
    pub fn summaries(&self) -> Vec<(&str, &PlanSummary)> {
        if self.teams.is_empty() {
            vec![("", &self.summary)]
        } else {
            self.teams.iter().map(|t| (t.team.as_str(), &t.summary)).collect()
        }
    }
}

/// Query payload of a planner service: a recipe (bank name or XML), overrides, robots.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlanRequest {
    pub recipe: String,
    #[serde(default)]
    pub params: BTreeMap<String, String>,
    pub robots: Vec<RobotSpec>,
    /// Plan on this map (the planner gets it by its hash); none: in the plane.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub map: Option<crate::map::MapRef>,
    /// The robots' capabilities, by id: what puts them in the teams that require some.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub capabilities: BTreeMap<crate::ids::RobotId, Vec<String>>,
    /// A running mission replanned: a team below its `min` (or above its `max`) does not stop
    /// the plan (the create checked them; the advising agent reports a team short of members).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub relax_bounds: bool,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_mission_plan_is_its_summary_tagged_with_the_planner_plus_plans() {
        let plan = MissionPlan {
            summary: PlanSummary::Coverage(CoverageSummary {
                region: Region { outer: vec![Point { x: 0.0, y: 0.0 }], holes: vec![] },
                points: vec![Point { x: 1.0, y: 2.0 }],
                coverage_radius: 3.0,
                hexagonal_bound: 2.5,
                formation_time: 4.0,
            }),
            plans: vec![RobotPlan {
                robot: "r1".into(),
                robot_type: "ground".into(),
                slot: 0,
                steps: vec![Step::Stream, Step::Sync { point: 0, scope: None }, Step::Sync { point: 1, scope: Some(String::new()) }],
                team: String::new(),
            }],
            teams: vec![],
            held: vec![],
        };
        let v = serde_json::to_value(&plan).expect("json");
        assert_eq!(v["planner"], "coverage");
        assert_eq!(v["coverage_radius"], 3.0);
        assert_eq!(v["plans"][0]["steps"][1]["sync"]["point"], 0);
        // Older robots read a plan without teams as they always did.
        assert_eq!(v["plans"][0]["steps"][1], serde_json::json!({"sync": {"point": 0}}));
        assert_eq!(v["plans"][0]["steps"][2], serde_json::json!({"sync": {"point": 1, "scope": ""}}));
        assert!(v["plans"][0].get("team").is_none() && v.get("teams").is_none());
        let back: MissionPlan = serde_json::from_value(v).expect("back");
        assert_eq!(back, plan);
        assert_eq!(back.summary.planner(), "coverage");
    }
}
