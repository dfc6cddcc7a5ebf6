//! Robot plans: the sequence of behaviour steps a robot executes, as sent to robots (JSON).

use serde::{Deserialize, Serialize};

/// One step of a robot plan. JSON is externally tagged: `{"navigate": {"x": 1, "y": 2,
/// "speed": 0.8}}`, `{"sync": {"point": 3}}`, `"stream"`, `{"hold": {"seconds": null}}`,
/// `{"loop": {"to": 2, "rounds": null}}`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Step {
    /// Drive to (x, y); `speed` caps the robot's speed (m/s), `None` means its maximum.
    Navigate { x: f64, y: f64, speed: Option<f64> },
    /// Barrier number `point` of the current round: wait until every live member of the team
    /// arrived. `scope` names the team as a path below the mission (`""`: the whole mission);
    /// none: the robot's own team.
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
    pub robot: String,
    #[serde(rename = "type")]
    pub robot_type: String,
    /// Slot (patrol) or point (coverage) index the robot was assigned.
    pub slot: usize,
    pub steps: Vec<Step>,
    /// The robot's team, as a path below the mission; empty: a recipe without teams.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub team: String,
}

/// A robot as planners see it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RobotSpec {
    pub id: String,
    #[serde(rename = "type")]
    pub robot_type: String,
    pub x: f64,
    pub y: f64,
    /// Maximum speed, m/s.
    pub speed: f64,
    /// Maximum turn rate, rad/s: a patrol spaces robots by time with the turns of the slowest
    /// turner counted. None: not known (turns take no time).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub turn_rate: Option<f64>,
}

impl RobotSpec {
    pub(crate) fn check(robots: &[RobotSpec]) -> Result<(), crate::PlanError> {
        if robots.is_empty() {
            return Err(crate::PlanError::Invalid("no robots".into()));
        }
        for r in robots {
            crate::limits::coordinate(&format!("robot {} position", r.id), r.x, r.y)?;
            if !(r.speed.is_finite() && r.speed > 0.0) {
                return Err(crate::PlanError::Invalid(format!("robot {}: speed must be positive (got {})", r.id, r.speed)));
            }
            if let Some(w) = r.turn_rate {
                crate::limits::turn_rate(&format!("robot {} turn_rate", r.id), w)?;
            }
        }
        let mut ids: Vec<&str> = robots.iter().map(|r| r.id.as_str()).collect();
        ids.sort_unstable();
        if let Some(w) = ids.windows(2).find(|w| w[0] == w[1]) {
            return Err(crate::PlanError::Invalid(format!("robot {} given twice", w[0])));
        }
        Ok(())
    }
}
