//! Robot-side payloads: telemetry, registration, commands and plans.

use crate::geom::Point;
use crate::ids::{MissionName, NodeId, RobotId};
use crate::map::MapRef;
use crate::plan::RobotPlan;
use serde::{Deserialize, Serialize};

/// A planar pose: position in metres, heading in radians (counter-clockwise from +x).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
pub struct Pose {
    pub x: f64,
    pub y: f64,
    pub theta: f64,
}

impl Pose {
    /// Where the robot is, without its heading.
    pub fn point(self) -> Point {
        Point { x: self.x, y: self.y }
    }
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

    /// Where it drives to, while it drives.
    pub fn goal(&self) -> Option<Point> {
        match *self {
            Behaviour::Hold => None,
            Behaviour::Navigate { x, y } => Some(Point { x, y }),
        }
    }
}

/// Periodic state of one robot, on `mrmm/robots/<id>/telemetry`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Telemetry {
    pub id: RobotId,
    /// Sequence number, +1 per publication.
    pub seq: u64,
    /// Simulated time of the robot, seconds since it started.
    pub t: f64,
    pub pose: Pose,
    pub velocity: Velocity,
    pub behaviour: Behaviour,
    pub mission: Option<MissionName>,
    /// Where the robot is in its plan, when it has one.
    pub progress: Option<Progress>,
    /// The missions central admitted this robot to (it may not run their plans yet; more than one
    /// while it moves): a central that restarted learns from it which robots are spoken for.
    #[serde(default)]
    pub admitted: Vec<MissionName>,
    /// Why the robot cannot get to its goal, while that lasts (a real body's navigator rejected
    /// or aborted the goal, or is not running); at most a few hundred characters.
    #[serde(default)]
    pub stuck: Option<String>,
    /// The revision of the robot's [`RobotInfo`]: it counts up each time the robot's
    /// capabilities change, so whoever holds an older record asks `mrmm/robots/<id>/info` again.
    #[serde(default)]
    pub info_rev: u32,
    /// The robot's battery, when it has one that it knows of.
    #[serde(default)]
    pub battery: Option<BatteryState>,
    /// A VDA 5050 vehicle's own word on itself, beyond pose, speed and battery (boxed: most
    /// robots have none, and telemetry travels by value).
    #[serde(default)]
    pub vehicle: Option<Box<VehicleState>>,
}

/// Errors, and actions, a vehicle's state carries at most in telemetry and the robots' view.
pub const MAX_VEHICLE_ITEMS: usize = 8;
/// Characters of a vehicle's node id, error or action type, level or status at most (longer is
/// cut).
pub const MAX_VEHICLE_WORD: usize = 64;
/// Characters of a vehicle's error description at most (longer is cut).
pub const MAX_VEHICLE_TEXT: usize = 256;

/// What a VDA 5050 vehicle says of itself in its `state`, beyond pose, speed and battery
/// (telemetry; `vehicle` in the robots' view).
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct VehicleState {
    /// The node it passed last (`lastNodeId`; empty before its first).
    pub last_node: String,
    pub driving: bool,
    pub paused: bool,
    /// Its errors, FATAL first, at most [`MAX_VEHICLE_ITEMS`].
    #[serde(default)]
    pub errors: Vec<VehicleError>,
    /// Its actions, those not yet ended first, at most [`MAX_VEHICLE_ITEMS`].
    #[serde(default)]
    pub actions: Vec<VehicleAction>,
}

/// An error a vehicle reports (`errors[]`).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct VehicleError {
    /// `errorType`: `orderError`, `noRouteError`, the maker's own.
    pub kind: String,
    /// `errorLevel`: `WARNING` or `FATAL`.
    pub level: String,
    /// (No `skip_serializing_if` here or below: telemetry is bincode, which must see every field.)
    #[serde(default)]
    pub description: Option<String>,
}

/// An action a vehicle reports the state of (`actionStates[]`).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct VehicleAction {
    pub id: String,
    /// `actionType`, where the vehicle says it.
    #[serde(default)]
    pub kind: Option<String>,
    /// `WAITING`, `INITIALIZING`, `RUNNING`, `PAUSED`, `FINISHED` or `FAILED`.
    pub status: String,
}

impl VehicleState {
    /// Checks what a robot says: at most [`MAX_VEHICLE_ITEMS`] errors and actions, no word over
    /// [`MAX_VEHICLE_WORD`] characters, no description over [`MAX_VEHICLE_TEXT`].
    pub fn check(&self) -> Result<(), String> {
        if self.errors.len() > MAX_VEHICLE_ITEMS || self.actions.len() > MAX_VEHICLE_ITEMS {
            return Err(format!("vehicle: more than {MAX_VEHICLE_ITEMS} errors or actions"));
        }
        let words = std::iter::once(&self.last_node)
            .chain(self.errors.iter().flat_map(|e| [&e.kind, &e.level]))
            .chain(self.actions.iter().flat_map(|a| std::iter::once(&a.id).chain(&a.kind).chain(std::iter::once(&a.status))));
        for w in words {
            if w.chars().count() > MAX_VEHICLE_WORD {
                return Err(format!("vehicle: a word of more than {MAX_VEHICLE_WORD} characters"));
            }
        }
        if self.errors.iter().filter_map(|e| e.description.as_ref()).any(|d| d.chars().count() > MAX_VEHICLE_TEXT) {
            return Err(format!("vehicle: an error description of more than {MAX_VEHICLE_TEXT} characters"));
        }
        Ok(())
    }
}

/// Farthest a robot may say its battery takes it, metres (a reach past it is shown as this).
pub const MAX_REACH_M: f64 = 1e7;

/// A robot's battery as it reports it (telemetry; `battery` in the robots' view).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BatteryState {
    /// State of charge, 0 (empty) to 1 (full).
    pub charge: f64,
    /// Standing at a charger, charging.
    pub charging: bool,
    /// How far the charge left takes it at its top speed, metres; None where the robot cannot
    /// tell (a ROS 2 battery reports its charge only).
    #[serde(default)]
    pub reach_m: Option<f64>,
}

impl BatteryState {
    /// Checks what a robot says: a charge in 0–1, a reach in 0–[`MAX_REACH_M`].
    pub fn check(&self) -> Result<(), String> {
        if !(self.charge.is_finite() && (0.0..=1.0).contains(&self.charge)) {
            return Err(format!("battery charge {} is not within 0–1", self.charge));
        }
        match self.reach_m {
            Some(r) if !(r.is_finite() && (0.0..=MAX_REACH_M).contains(&r)) => Err(format!("battery reach {r} m is not within 0–{MAX_REACH_M}")),
            _ => Ok(()),
        }
    }
}

impl Telemetry {
    /// The telemetry of robot `id` holding still at the origin, at time `t` (first of its stream).
    pub fn resting(id: &str, t: f64) -> Telemetry {
        Telemetry {
            id: RobotId::from(id),
            seq: 0,
            t,
            pose: Pose::default(),
            velocity: Velocity::default(),
            behaviour: Behaviour::Hold,
            mission: None,
            progress: None,
            admitted: vec![],
            stuck: None,
            info_rev: 0,
            battery: None,
            vehicle: None,
        }
    }
}

/// Progress of a robot through its plan (part of its telemetry).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Progress {
    pub mission: MissionName,
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
    /// Simulated seconds the plan waited for traffic (a goal on a map with lanes, the next lane
    /// not granted yet, or no orders heard).
    #[serde(default)]
    pub traffic_wait_s: f64,
    /// The plan ran to its end.
    pub done: bool,
}

/// Slowest top speed a robot may say it has, m/s: a plan's times are distances over speeds, and
/// a speed of 5e-324 made them infinite.
pub const MIN_SPEED: f64 = 0.01;
/// Fastest top speed a robot may say it has, m/s.
pub const MAX_SPEED: f64 = 1e3;
/// Time scales a robot may run at (simulated seconds per wall second).
pub const TIME_SCALES: std::ops::RangeInclusive<f64> = 1e-3..=1e3;

/// Slowest turn rate a robot may have, rad/s (half a turn in 314 s).
pub const MIN_TURN_RATE: f64 = 0.01;
/// Fastest turn rate a robot may say it has, rad/s.
pub const MAX_TURN_RATE: f64 = 1e3;

/// What a robot says about itself when it registers (answer of `mrmm/robots/<id>/info`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RobotInfo {
    pub id: RobotId,
    #[serde(rename = "type")]
    pub robot_type: String,
    pub capabilities: Vec<String>,
    /// Maximum linear speed, m/s.
    pub max_speed: f64,
    /// Maximum turn rate, rad/s: a patrol spaces its robots by time with their turns counted.
    /// None: not said (a robot of an older version).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_turn_rate: Option<f64>,
    /// Zenoh endpoints the robot listens on.
    pub endpoints: Vec<String>,
    /// Simulated seconds per wall second (1 for real robots): mission clocks run at this rate.
    #[serde(default = "one")]
    pub time_scale: f64,
    /// The robot keeps its chain state on disk (`state_dir`): after a restart it still holds the
    /// replicas it held, so a mission it replicated comes back through its chain, not anew.
    #[serde(default)]
    pub durable: bool,
    /// Revision of this record (see [`Telemetry::info_rev`]): 0 as started, +1 per change of
    /// `capabilities` at runtime.
    #[serde(default)]
    pub rev: u32,
}

impl RobotInfo {
    /// A robot of `robot_type` at most `max_speed` m/s, with no capabilities, no endpoints, time
    /// scale 1, no state dir, as started.
    pub fn new(id: &str, robot_type: &str, max_speed: f64) -> RobotInfo {
        RobotInfo {
            id: RobotId::from(id),
            robot_type: robot_type.to_string(),
            capabilities: vec![],
            max_speed,
            max_turn_rate: None,
            endpoints: vec![],
            time_scale: 1.0,
            durable: false,
            rev: 0,
        }
    }

    /// Checks what a robot says about itself before anyone relies on it: its names, a bounded
    /// list of valid capabilities, speeds and a time scale within bounds that keep plans finite.
    pub fn check(&self) -> Result<(), String> {
        crate::validate_id(self.id.as_str()).map_err(|e| e.to_string())?;
        crate::validate_id(&self.robot_type).map_err(|_| format!("type {:?}: not an id", self.robot_type))?;
        check_capabilities(&self.capabilities)?;
        if !(self.max_speed.is_finite() && (MIN_SPEED..=MAX_SPEED).contains(&self.max_speed)) {
            return Err(format!("max_speed {}: not a speed from {MIN_SPEED} to {MAX_SPEED} m/s", self.max_speed));
        }
        if !(self.time_scale.is_finite() && TIME_SCALES.contains(&self.time_scale)) {
            return Err(format!("time_scale {}: not a time scale from {} to {}", self.time_scale, TIME_SCALES.start(), TIME_SCALES.end()));
        }
        if let Some(w) = self.max_turn_rate.filter(|w| !(w.is_finite() && (crate::MIN_TURN_RATE..=crate::MAX_TURN_RATE).contains(w))) {
            return Err(format!("max_turn_rate {w}: not a turn rate from {} to {} rad/s", crate::MIN_TURN_RATE, crate::MAX_TURN_RATE));
        }
        if self.endpoints.len() > 64 || self.endpoints.iter().any(|e| e.len() > 256) {
            return Err("endpoints: more than 64, or one longer than 256 characters".into());
        }
        Ok(())
    }
}

/// Checks a list of capabilities: at most [`MAX_CAPABILITIES`], each a valid name.
pub fn check_capabilities(capabilities: &[String]) -> Result<(), String> {
    if capabilities.len() > MAX_CAPABILITIES {
        return Err(format!("{} capabilities (at most {MAX_CAPABILITIES})", capabilities.len()));
    }
    capabilities.iter().try_for_each(|c| validate_capability(c))
}

/// Of `requires`, what `capabilities` lacks (in `requires`' order).
pub fn lacking<'a>(capabilities: &[String], requires: &'a [String]) -> Vec<&'a str> {
    requires.iter().filter(|c| !capabilities.contains(c)).map(String::as_str).collect()
}

/// Capabilities a robot has at most.
pub const MAX_CAPABILITIES: usize = 32;

/// Checks a capability name: 1 to 64 characters of `[A-Za-z0-9_.-]` (`camera`, `arm.gripper`).
pub fn validate_capability(name: &str) -> Result<(), String> {
    let ok_len = !name.is_empty() && name.len() <= 64;
    let ok_chars = name.bytes().all(|c| c.is_ascii_alphanumeric() || matches!(c, b'_' | b'-' | b'.'));
    if ok_len && ok_chars {
        Ok(())
    } else {
        Err(format!("bad capability {name:?}: use 1 to 64 characters of A-Z a-z 0-9 _ - ."))
    }
}

/// `capabilities` with `add` added and `remove` removed, sorted and without repeats; checks every
/// name and the [`MAX_CAPABILITIES`] bound.
pub fn change_capabilities(capabilities: &[String], add: &[String], remove: &[String]) -> Result<Vec<String>, String> {
    if add.len() > MAX_CAPABILITIES || remove.len() > MAX_CAPABILITIES {
        return Err(format!("at most {MAX_CAPABILITIES} capabilities to add or remove at once"));
    }
    for c in add.iter().chain(remove) {
        validate_capability(c)?;
    }
    if let Some(c) = add.iter().find(|c| remove.contains(c)) {
        return Err(format!("capability {c:?} both added and removed"));
    }
    let mut out: Vec<String> = capabilities.iter().filter(|c| !remove.contains(c)).chain(add).cloned().collect();
    out.sort();
    out.dedup();
    if out.len() > MAX_CAPABILITIES {
        return Err(format!("a robot has at most {MAX_CAPABILITIES} capabilities ({} asked)", out.len()));
    }
    Ok(out)
}

fn one() -> f64 {
    1.0
}

/// A command to one robot, query payload on `mrmm/robots/<id>/cmd`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "cmd", rename_all = "snake_case", deny_unknown_fields)]
pub enum RobotCommand {
    /// Drive to (x, y) through the points of `via` (a route on the fleet's map), and hold there
    /// (leaves any plan). On `map` (central names the map the goal is on): a goal of that map's
    /// traffic, driven as traffic grants where the map has lanes.
    Goto {
        x: f64,
        y: f64,
        #[serde(default, skip_serializing_if = "Vec::is_empty")]
        via: Vec<[f64; 2]>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        map: Option<MapRef>,
    },
    /// Stop where you are (leaves any plan).
    Hold,
    /// Execute `plan` as a member of `team` (sub-team `subteam`) of `mission`. Replaces any
    /// plan of another mission, or of the same mission with a lower epoch; a stale epoch is
    /// refused.
    Plan(Box<PlanAssignment>),
    /// Leave `mission` (ignored when the robot is not in it, or holds a newer epoch).
    Leave { mission: MissionName, epoch: u64 },
    /// From the system manager, on the operator's word: the robot's capabilities change (a
    /// sensor broke, a tool was fitted). The robot answers with its capabilities after the change.
    Capabilities {
        #[serde(default)]
        add: Vec<String>,
        #[serde(default)]
        remove: Vec<String>,
    },
    /// From the system manager: this robot now belongs to `mission`, whose managers (its chain:
    /// head first) may plan for it and whose `members` are its teammates. Plans from central and
    /// mission hosts need no admission; a robot leading a mission can plan only for its
    /// teammates and for robots admitted to it.
    Admit {
        mission: MissionName,
        managers: Vec<NodeId>,
        #[serde(default)]
        members: Vec<RobotId>,
    },
    /// From the system manager, on the operator's word: a simulated robot stops at once, as if
    /// its computer died (no goodbye to its teams; its links drop, its missions replan without
    /// it). A robot with a ROS 2 body refuses: a real robot is not crashed from the fleet.
    Crash,
    /// From the system manager's charging policy: start (`on`) or stop charging where the robot
    /// stands (at a charger). A simulated robot with a battery plugs in (it does not drive while
    /// plugged; a new goal unplugs it); a robot without one, or a ROS 2 robot (its own dock
    /// charges it), refuses.
    Charge { on: bool },
}

/// A plan as delivered to a robot.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlanAssignment {
    pub mission: MissionName,
    /// The mission manager's epoch: plans and commands of older epochs are refused.
    pub epoch: u64,
    /// The robot's leaf team: its path from the mission down (`escort/ground`; a mission without
    /// teams: `patrol-1`). Its barriers are the plan's syncs without a scope.
    pub team: String,
    /// Sub-team path (membership token), `<team>/<type>`, e.g. `escort/ground/husky`.
    pub subteam: String,
    /// Every member of the robot's leaf team for this epoch.
    pub members: Vec<RobotId>,
    pub plan: RobotPlan,
    /// The mission's managers when the plan was sent (its chain, head first): who else the robot
    /// takes this mission's plans from (a successor taking over comes from the chain). Not part
    /// of the plan itself: a plan sent again with another chain is the same plan.
    #[serde(default)]
    pub managers: Vec<NodeId>,
    /// How the team runs its barriers.
    #[serde(default)]
    pub barrier: crate::BarrierMode,
    /// The wider teams the plan has barriers with (a parent team, the whole mission), each with
    /// the members that take part in them.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub scopes: Vec<ScopeMembers>,
    /// The map the plan is on: on a graph map the robot drives its navigate steps along the
    /// lanes its traffic authority grants (`mrmm/traffic/<hash>/…`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub map: Option<crate::MapRef>,
    /// The plan carries on an earlier epoch's (a member was replaced, the others go on): a
    /// robot running the same plan of that lineage keeps its place in it; one that does not
    /// (the member that came in) starts where this says.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub handover: Option<Handover>,
}

/// How a plan carries on an earlier one after a hand-over.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Handover {
    /// The epoch the plan was made for (by a planner); hand-overs since keep it.
    pub planned: u64,
    /// The step a robot not running the plan yet starts at, and the round it is in.
    pub step: u32,
    pub round: u32,
}

/// A mission manager's record of the hand-overs since its plan was made: the epoch it was made
/// for, and where each member that came in (or any member, if it did not run the plan) starts.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HandoverState {
    pub planned: u64,
    /// Per member: (step, round).
    pub starts: std::collections::BTreeMap<crate::ids::RobotId, (u32, u32)>,
}

/// The members of a team above a robot's own that take part in its barriers.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ScopeMembers {
    /// The team's path from the mission down (`escort`, `escort/ground`).
    pub team: String,
    pub members: Vec<RobotId>,
}

impl PlanAssignment {
    /// The team path a sync step's `scope` names: its own team without one; else the mission's
    /// path followed by the scope (`""`: the mission itself).
    pub fn scope_path(&self, scope: Option<&str>) -> String {
        match scope {
            None => self.team.clone(),
            Some("") => self.mission.to_string(),
            Some(s) => format!("{}/{s}", self.mission),
        }
    }

    /// The members of the barriers of team path `team`, if the plan has any there.
    pub fn scope_members(&self, team: &str) -> Option<&[RobotId]> {
        if team == self.team {
            return Some(&self.members);
        }
        self.scopes.iter().find(|s| s.team == team).map(|s| s.members.as_slice())
    }

    /// Whether `other` is the same plan (whoever manages it now).
    pub fn same_plan(&self, other: &PlanAssignment) -> bool {
        self.mission == other.mission
            && self.epoch == other.epoch
            && self.team == other.team
            && self.subteam == other.subteam
            && self.members == other.members
            && self.barrier == other.barrier
            && self.plan == other.plan
            && self.scopes == other.scopes
            && self.handover == other.handover
    }

    /// The epoch of the plan this one is a copy of: its own, or the one it carries on.
    pub fn planned(&self) -> u64 {
        self.handover.map_or(self.epoch, |h| h.planned)
    }
}

/// Positive answer to a command.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CommandAck {
    pub ok: bool,
    pub robot: RobotId,
    pub behaviour: Behaviour,
    /// The robot's capabilities after a capabilities command.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub capabilities: Option<Vec<String>>,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What a robot says of its kinematics is checked before a planner relies on it: a turn rate
    /// of none, NaN or below 0.01 rad/s would stretch a patrol's timed route without bound.
    #[test]
    fn a_robot_info_with_a_bad_turn_rate_is_refused() {
        let ok = RobotInfo { max_turn_rate: Some(2.0), ..RobotInfo::new("r1", "ground", 1.0) };
        assert_eq!(ok.check(), Ok(()));
        assert_eq!(RobotInfo::new("r1", "ground", 1.0).check(), Ok(()), "an older robot says none");
        for w in [0.0, 0.001, -1.0, f64::NAN, f64::INFINITY, 2e3] {
            let e = RobotInfo { max_turn_rate: Some(w), ..ok.clone() }.check().unwrap_err();
            assert!(e.starts_with("max_turn_rate"), "{w}: {e}");
        }
        // The wire form of an older robot (no max_turn_rate) still reads.
        let old: RobotInfo = serde_json::from_str(r#"{"id":"r1","type":"ground","capabilities":[],"max_speed":1.0,"endpoints":[]}"#).expect("old");
        assert_eq!(old.max_turn_rate, None);
    }

    /// Issue 50: a max speed of 5e-324 passed the check and made plans infinite.
    #[test]
    fn a_robot_info_with_a_speed_or_time_scale_that_makes_plans_infinite_is_refused() {
        let ok = RobotInfo::new("r1", "ground", 1.0);
        for v in [5e-324, 0.0, 0.001, -1.0, f64::NAN, f64::INFINITY, 1e4] {
            let e = RobotInfo { max_speed: v, ..ok.clone() }.check().unwrap_err();
            assert!(e.starts_with("max_speed"), "{v}: {e}");
            let e = RobotInfo { time_scale: if v == 0.001 { 1e-9 } else { v }, ..ok.clone() }.check().unwrap_err();
            assert!(e.starts_with("time_scale"), "{v}: {e}");
        }
        assert_eq!(RobotInfo { max_speed: MIN_SPEED, time_scale: 100.0, ..ok }.check(), Ok(()));
    }
}
