//! A mission host's questions (see [`crate::ask`]): a plan of a planner service, a plan handed
//! to a robot — and what each answer becomes.

use mrmm_proto::{CommandAck, Key, MissionName, MissionPlan, RobotCommand, RobotId};
use serde_json::Value;

use super::{Command, Event};
use crate::ask::{decode, Answerer, Ask};
use crate::timeouts;
use crate::Failure;

/// What an answer to the host becomes.
#[derive(Debug, Clone, PartialEq)]
pub enum Then {
    /// [`Event::Planned`].
    Plan { mission: MissionName, epoch: u64 },
    /// [`Event::PlanDelivered`].
    Delivered { mission: MissionName, robot: RobotId, epoch: u64 },
}

/// The question command `c` asks, if it is one (a plan made here, with no planner service
/// alive, is not a question: the driver plans it itself).
pub fn ask(c: &Command) -> Option<Ask<Then>> {
    match c {
        Command::RequestPlan { mission, epoch, kind, request, local: false } => Ask::json(
            Key::Planner(kind.as_str().to_string()),
            request,
            Some(timeouts::PLAN_S),
            Answerer::Planner,
            Then::Plan { mission: mission.clone(), epoch: *epoch },
        ),
        Command::SendPlan { mission, robot, assignment } => Ask::json(
            Key::RobotCmd(robot.clone()),
            &RobotCommand::Plan(assignment.clone()),
            Some(timeouts::ROBOT_PLAN_S),
            Answerer::Robot(robot.clone()),
            Then::Delivered { mission: mission.clone(), robot: robot.clone(), epoch: assignment.epoch },
        ),
        _ => None,
    }
}

impl Then {
    /// What the answer on `key` (its JSON, or why there is none) becomes. A robot that does not
    /// take plans from this node yet (it awaits its admission) refuses with a code that makes
    /// the failure worth another try: the plan is re-sent.
    pub fn answer(self, key: &str, result: Result<Value, Failure>) -> Event {
        match self {
            Then::Plan { mission, epoch } => Event::Planned { mission, epoch, result: decode::<MissionPlan>(key, result).map(Box::new) },
            Then::Delivered { mission, robot, epoch } => Event::PlanDelivered { mission, robot, epoch, result: decode::<CommandAck>(key, result).map(|_| ()) },
        }
    }
}
