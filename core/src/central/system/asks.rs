//! The system manager's questions to robots and mission hosts (see [`crate::ask`]): a robot's
//! info, a command to a robot, a mission's start, a mission's control, a mission's view for the
//! operator — and what each answer becomes.

use mrmm_proto::{CommandAck, CtlAck, Key, MissionName, MissionView, RobotId, RobotInfo};
use serde_json::Value;

use super::{Command, Event, Req};
use crate::ask::{decode, Answerer, Ask};
use crate::timeouts;
use crate::Failure;

/// What an answer to the system manager becomes.
#[derive(Debug, Clone, PartialEq)]
pub enum Then {
    /// [`Event::RobotRegistered`] or [`Event::InfoFailed`].
    Info { id: RobotId },
    /// [`Event::RobotCommandDone`].
    Robot { req: Option<Req>, robot: RobotId },
    /// [`Event::MissionStarted`].
    Start { mission: MissionName },
    /// [`Event::CtlDone`].
    Ctl { id: u64 },
    /// [`Event::Forwarded`]: the answer goes to the operator as it came.
    Forward { req: Req },
}

/// The question command `c` asks, if it is one.
pub fn ask(c: &Command) -> Option<Ask<Then>> {
    match c {
        Command::FetchInfo { id } => Some(Ask {
            key: Key::RobotInfo(id.clone()),
            payload: None,
            timeout_s: None,
            answerer: Answerer::Robot(id.clone()),
            then: Then::Info { id: id.clone() },
        }),
        Command::SendToRobot { req, robot, cmd } => {
            Ask::json(Key::RobotCmd(robot.clone()), cmd, None, Answerer::Robot(robot.clone()), Then::Robot { req: req.clone(), robot: robot.clone() })
        }
        Command::StartMission { host, start } => Ask::json(
            Key::HostStart(host.clone()),
            &**start,
            Some(timeouts::START_S),
            Answerer::Host(host.clone()),
            Then::Start { mission: start.spec.name.clone() },
        ),
        Command::Ctl { id, mission, ctl, managers } => {
            Ask::json(Key::MissionCtl(mission.clone()), ctl, None, Answerer::Managers(managers.clone()), Then::Ctl { id: *id })
        }
        Command::Forward { req, key, managers } => Some(Ask {
            key: key.clone(),
            payload: None,
            timeout_s: None,
            answerer: Answerer::Managers(managers.clone()),
            then: Then::Forward { req: req.clone() },
        }),
        _ => None,
    }
}

impl Then {
    /// What the answer on `key` (its JSON, or why there is none) becomes.
    pub fn answer(self, key: &str, result: Result<Value, Failure>) -> Event {
        match self {
            Then::Info { id } => match decode::<RobotInfo>(key, result) {
                Ok(info) if info.id != id => Event::InfoFailed { id, reason: format!("answered as {:?}", info.id) },
                Ok(info) => match info.check() {
                    Ok(()) => Event::RobotRegistered(info),
                    Err(e) => Event::InfoFailed { id, reason: format!("bad info: {e}") },
                },
                Err(f) => Event::InfoFailed { id, reason: f.error },
            },
            Then::Robot { req, robot } => Event::RobotCommandDone { req, robot, result: decode::<CommandAck>(key, result).map_err(Failure::reply) },
            Then::Start { mission } => Event::MissionStarted { mission, result: decode::<MissionView>(key, result).map(Box::new) },
            Then::Ctl { id } => Event::CtlDone { id, result: decode::<CtlAck>(key, result).map(|_| ()) },
            Then::Forward { req } => Event::Forwarded { req, result: result.map_err(Failure::reply) },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mrmm_proto::{Role, Sender};

    #[test]
    fn a_robots_info_is_asked_of_that_robot_and_checked() {
        let a = ask(&Command::FetchInfo { id: "r1".into() }).expect("a question");
        assert_eq!(a.key, Key::RobotInfo("r1".into()));
        assert!(a.answerer.admits(&Sender::new(Role::Robot, "r1")) && !a.answerer.admits(&Sender::new(Role::Robot, "r2")));
        let ev = a.then.clone().answer("k", Ok(serde_json::json!({"id": "r2"})));
        assert!(matches!(ev, Event::InfoFailed { ref id, .. } if id == "r1"), "{ev:?}");
        let ev = a.then.answer("k", Err(Failure::retry("no answer")));
        assert_eq!(ev, Event::InfoFailed { id: "r1".into(), reason: "no answer".into() });
    }

    #[test]
    fn a_ctl_answer_that_is_not_an_ack_fails_it_for_good() {
        let ev = Then::Ctl { id: 3 }.answer("k", Ok(serde_json::json!([1, 2])));
        assert!(matches!(ev, Event::CtlDone { id: 3, result: Err(Failure { retryable: false, .. }) }), "{ev:?}");
    }
}
