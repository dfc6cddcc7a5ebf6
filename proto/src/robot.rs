//! Robot-side payloads: telemetry, registration, commands and plans.

use crate::plan::RobotPlan;
use serde::{Deserialize, Serialize};

/// A planar pose: position in metres, heading in radians (counter-clockwise from +x).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
pub struct Pose {
    pub x: f64,
    pub y: f64,
    pub theta: f64,
}

/// Linear (m/s) and angular (rad/s) velocity.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
pub struct Velocity {
    pub v: f64,
    pub omega: f64,
}

/// What a robot is doing right now. Externally tagged (bincode cannot carry internal tags):
/// JSON `"hold"` or `{"navigate": {"x": 1.0, "y": 2.0}}`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Behaviour {
    /// Standing still.
    Hold,
    /// Driving to a point.
    Navigate { x: f64, y: f64 },
}

impl Behaviour {
    /// Short human-readable form for tables.
    pub fn describe(&self) -> String {
        match self {
            Behaviour::Hold => "hold".to_string(),
            Behaviour::Navigate { x, y } => format!("goto({x:.1},{y:.1})"),
        }
    }
}

/// Periodic state of one robot, on `mrmm/robots/<id>/telemetry`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Telemetry {
    pub id: String,
    /// Sequence number, +1 per publication.
    pub seq: u64,
    /// Simulated time of the robot, seconds since it started.
    pub t: f64,
    pub pose: Pose,
    pub velocity: Velocity,
    pub behaviour: Behaviour,
    pub mission: Option<String>,
    /// Where the robot is in its plan, when it has one.
    pub progress: Option<Progress>,
    /// The missions central admitted this robot to (it may not run their plans yet; more than one
    /// while it moves): a central that restarted learns from it which robots are spoken for.
    #[serde(default)]
    pub admitted: Vec<String>,
    /// Why the robot cannot get to its goal, while that lasts (a real body's navigator rejected
    /// or aborted the goal, or is not running); at most a few hundred characters.
    #[serde(default)]
    pub stuck: Option<String>,
}

/// Progress of a robot through its plan (part of its telemetry).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Progress {
    pub mission: String,
    pub epoch: u64,
    /// Index of the current step.
    pub step: u32,
    /// Completed loop rounds.
    pub round: u32,
    /// Barriers passed since the plan started.
    pub syncs_passed: u32,
    /// Barrier arrival publications sent since the plan started.
    pub sync_msgs: u32,
    /// The barrier (point, round) the robot is waiting at, if any.
    pub waiting: Option<(u32, u32)>,
    /// Simulated seconds spent waiting at barriers that released, after the plan's first (the
    /// formation's): the cost of synchronisation, which the evaluation's figures show.
    #[serde(default)]
    pub sync_wait_s: f64,
    /// The plan ran to its end.
    pub done: bool,
}

/// What a robot says about itself when it registers (answer of `mrmm/robots/<id>/info`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RobotInfo {
    pub id: String,
    #[serde(rename = "type")]
    pub robot_type: String,
    pub capabilities: Vec<String>,
    /// Maximum linear speed, m/s.
    pub max_speed: f64,
    /// Zenoh endpoints the robot listens on.
    pub endpoints: Vec<String>,
    /// Simulated seconds per wall second (1 for real robots): mission clocks run at this rate.
    #[serde(default = "one")]
    pub time_scale: f64,
    /// The robot keeps its chain state on disk (`state_dir`): after a restart it still holds the
    /// replicas it held, so a mission it replicated comes back through its chain, not anew.
    #[serde(default)]
    pub durable: bool,
}

fn one() -> f64 {
    1.0
}

/// How a reply error starts when the sender of a command may not give it (yet): a robot refusing
/// a plan from a head it was not admitted under. The head keeps re-sending.
pub const REFUSED: &str = "refused:";

/// How a host's answer to a mission start begins when the mission was taken over by another of
/// its managers before the start was confirmed: it runs, elsewhere.
pub const TAKEN_OVER: &str = "taken over:";

/// A command to one robot, query payload on `mrmm/robots/<id>/cmd`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "cmd", rename_all = "snake_case", deny_unknown_fields)]
pub enum RobotCommand {
    /// Drive to (x, y) and hold there (leaves any plan).
    Goto { x: f64, y: f64 },
    /// Stop where you are (leaves any plan).
    Hold,
    /// Execute `plan` as a member of `team` (sub-team `subteam`) of `mission`. Replaces any
    /// plan of another mission, or of the same mission with a lower epoch; a stale epoch is
    /// refused.
    Plan(Box<PlanAssignment>),
    /// Leave `mission` (ignored when the robot is not in it, or holds a newer epoch).
    Leave { mission: String, epoch: u64 },
    /// From the system manager: this robot now belongs to `mission`, whose managers (its chain:
    /// head first) may plan for it and whose `members` are its teammates. Plans from central and
    /// mission hosts need no admission; a robot leading a mission can plan only for its
    /// teammates and for robots admitted to it.
    Admit {
        mission: String,
        managers: Vec<String>,
        #[serde(default)]
        members: Vec<String>,
    },
}

/// A plan as delivered to a robot.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlanAssignment {
    pub mission: String,
    /// The mission manager's epoch: plans and commands of older epochs are refused.
    pub epoch: u64,
    /// Top-level team path (barriers), e.g. `patrol-1`.
    pub team: String,
    /// Sub-team path (membership), e.g. `patrol-1/ground`.
    pub subteam: String,
    /// Every member of the team for this epoch.
    pub members: Vec<String>,
    pub plan: RobotPlan,
    /// The mission's managers when the plan was sent (its chain, head first): who else the robot
    /// takes this mission's plans from (a successor taking over comes from the chain). Not part
    /// of the plan itself: a plan sent again with another chain is the same plan.
    #[serde(default)]
    pub managers: Vec<String>,
    /// How the team runs its barriers.
    #[serde(default)]
    pub barrier: crate::BarrierMode,
}

impl PlanAssignment {
    /// Whether `other` is the same plan (whoever manages it now).
    pub fn same_plan(&self, other: &PlanAssignment) -> bool {
        self.mission == other.mission
            && self.epoch == other.epoch
            && self.team == other.team
            && self.subteam == other.subteam
            && self.members == other.members
            && self.barrier == other.barrier
            && self.plan == other.plan
    }
}

/// Positive answer to a command.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CommandAck {
    pub ok: bool,
    pub robot: String,
    pub behaviour: Behaviour,
}
