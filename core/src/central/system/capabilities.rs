//! Capabilities: what a mission requires of every robot in it (its recipe's `<requires>`),
//! checked whenever robots are assigned to it, and a robot's capabilities changing at runtime —
//! the operator's change relayed to the robot, and a member that no longer has what its mission
//! requires taken out of it (the mission replans without it; the agent suggests a robot that has
//! it).

use mrmm_proto::ErrorReply;
use serde_json::json;

use super::*;

/// What a mission as defined here requires (nothing known for one adopted from its head's
/// report: its reports say).
pub(super) fn requirements(def: &MissionDef) -> Vec<String> {
    def.spec.as_ref().and_then(|s| mrmm_planner::recipe::parse(&s.recipe_xml).ok()).map(|r| r.required()).unwrap_or_default()
}

/// What a head's report says its mission requires (nothing, if that is not a valid list).
pub(super) fn reported(view: &MissionView) -> Vec<String> {
    match proto::check_capabilities(&view.requires) {
        Ok(()) => view.requires.clone(),
        Err(e) => {
            tracing::warn!(mission = %view.name, "requirements in a report ignored: {e}");
            vec![]
        }
    }
}

/// Whether robot `id` with `has` may be in `mission`, which requires `requires`; the error names
/// what it lacks.
pub(super) fn capable(id: &str, has: &[String], mission: &str, requires: &[String]) -> Result<(), ErrorReply> {
    let lacks = proto::lacking(has, requires);
    if lacks.is_empty() {
        Ok(())
    } else {
        Err(ErrorReply::conflict(format!("robot {id:?} lacks {} (mission {mission} requires {})", lacks.join(", "), requires.join(", "))))
    }
}

impl SystemManager {
    /// The capabilities every member of `mission` must have.
    pub(super) fn requires(&self, mission: &str) -> &[String] {
        self.missions.get(mission).map(|r| r.requires.as_slice()).unwrap_or(&[])
    }

    /// Whether robot `id` has every capability `mission` requires; the error names what it lacks.
    pub(super) fn check_capable(&self, id: &str, mission: &str) -> Result<(), ErrorReply> {
        capable(id, self.capabilities_of(id), mission, self.requires(mission))
    }

    /// What robot `id` has (nothing while its info is unknown).
    pub(super) fn capabilities_of(&self, id: &str) -> &[String] {
        self.fleet.capabilities_of(id)
    }

    /// Whether registered robot `id` has every capability of `requires`.
    pub(super) fn has_all(&self, id: &str, requires: &[String]) -> bool {
        self.fleet.known(id) && proto::lacking(self.capabilities_of(id), requires).is_empty()
    }

    /// The operator changes a robot's capabilities: checked here, carried out by the robot, whose
    /// answer (its capabilities after the change) comes back as [`Event::RobotCommandDone`].
    pub(super) fn change_capabilities(&mut self, req: Req, c: CapabilitiesRequest) -> Vec<Command> {
        let checked = self
            .live_robot(c.robot.as_str())
            .and_then(|info| proto::change_capabilities(&info.capabilities, &c.add, &c.remove).map(|_| ()).map_err(ErrorReply::invalid));
        if let Err(e) = checked {
            return vec![Command::Reply { req, result: Err(e) }];
        }
        self.note_command(&req, "robot capabilities", &serde_json::to_value(&c).unwrap_or(Value::Null));
        vec![Command::SendToRobot { req: Some(req), robot: c.robot, cmd: RobotCommand::Capabilities { add: c.add, remove: c.remove } }]
    }

    /// Robot `id` says its capabilities are now `capabilities` (its answer to a change). A member
    /// that lacks what its mission requires leaves it; returns the commands and that mission.
    pub(super) fn capabilities_now(&mut self, id: &str, capabilities: Vec<String>) -> (Vec<Command>, Option<MissionName>) {
        if let Err(e) = proto::check_capabilities(&capabilities) {
            tracing::warn!(robot = %id, "capabilities in a command answer ignored: {e}");
            return (vec![], None);
        }
        let Some(info) = self.fleet.get_mut(id).and_then(|r| r.info.as_mut()) else {
            return (vec![], None);
        };
        if info.capabilities != capabilities {
            tracing::info!(robot = %id, was = ?info.capabilities, now = ?capabilities, "robot capabilities changed");
            info.capabilities = capabilities;
        }
        self.unfit(id)
    }

    /// A member that lacks what its mission requires (its capabilities changed, or it came back
    /// with fewer) is taken out of the mission, as the operator would move it out.
    pub(super) fn unfit(&mut self, id: &str) -> (Vec<Command>, Option<MissionName>) {
        let Some(mission) = self.assignment.get(id).cloned() else {
            return (vec![], None);
        };
        if !self.fleet.known(id) {
            // Not heard what it has yet.
            return (vec![], None);
        }
        let Err(why) = self.check_capable(id, mission.as_str()) else {
            return (vec![], None);
        };
        let alive = self.fleet.alive(id);
        tracing::warn!(robot = %id, %mission, "{why}: taken out of the mission");
        let request = json!({"robot": id, "to": null, "reason": why.error});
        self.journal.note(JournalEvent::Command { by: "central".into(), command: "robot move".into(), request });
        (self.apply_move(id, Some(mission.clone()), None, alive), Some(mission))
    }
}
