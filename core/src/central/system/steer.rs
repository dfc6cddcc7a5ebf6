//! What the system manager sends to steer missions: controls and starts that are due (with the
//! admissions robots need first), admissions, and who may manage a mission.

use super::*;
use mrmm_proto::Time;

impl SystemManager {
    /// Controls and starts that can go out now.
    pub(super) fn due(&mut self, now: Time) -> Vec<Command> {
        let mut out = Vec::new();
        for (id, mission, ctl) in self.controls.due(now) {
            let managers = self.managers(mission.as_str());
            if let MissionCtl::Joined { member } | MissionCtl::Replaced { member, .. } = &ctl {
                // A robot leading the mission may plan for the newcomer only once it is admitted,
                // and the members take the newcomer's chain messages only once they know it: every
                // member hears of the new membership.
                let view = self.missions.get(&mission).and_then(|r| r.view.as_ref());
                let mut members: Vec<RobotId> = view.map(|v| v.robots.iter().chain(&v.lost).cloned().collect()).unwrap_or_default();
                if let MissionCtl::Replaced { out, .. } = &ctl {
                    members.retain(|m| m != out);
                }
                if !members.contains(&member.spec.id) {
                    members.push(member.spec.id.clone());
                }
                for robot in &members {
                    let admit = RobotCommand::Admit { mission: mission.clone(), managers: managers.clone(), members: members.clone() };
                    out.push(Command::SendToRobot { req: None, robot: robot.clone(), cmd: admit });
                }
            }
            out.push(Command::Ctl { id, mission, ctl, managers });
        }
        let controls = &self.controls;
        let (ready, waiting): (Vec<PendingStart>, Vec<PendingStart>) =
            std::mem::take(&mut self.starts).into_iter().partition(|s| s.after.iter().all(|id| !controls.is_pending(*id)));
        self.starts = waiting;
        for s in ready {
            let members: Vec<RobotId> = s.start.members.iter().map(|m| m.spec.id.clone()).collect();
            for m in &members {
                let admit = RobotCommand::Admit { mission: s.start.spec.name.clone(), managers: vec![s.host.clone()], members: members.clone() };
                out.push(Command::SendToRobot { req: None, robot: m.clone(), cmd: admit });
            }
            out.push(Command::StartMission { host: s.host, start: s.start });
        }
        out
    }

    /// A command of ours to `robot` was lost (an admission naming its mission's new head, say):
    /// an alive member is admitted to its mission again, as managers and members are known now —
    /// else it may refuse the plans of a head it was never told of, for ever (found by the system
    /// sim, seed 166 with capability changes). At most once per [`LEAVE_RETRY_S`].
    pub(super) fn admit_again(&mut self, now: Time, robot: &str) -> Vec<Command> {
        let Some(mission) = self.assignment.get(robot).filter(|m| self.missions.contains_key(*m)).cloned() else {
            return vec![];
        };
        let Some(rec) = self.fleet.get_mut(robot).filter(|r| r.alive) else {
            return vec![];
        };
        if rec.admit_sent.is_some_and(|s| now - s < LEAVE_RETRY_S) {
            return vec![];
        }
        rec.admit_sent = Some(now);
        self.admit(mission.as_str(), &[RobotId::from(robot)])
    }

    /// Admissions of `robots` to `mission`, naming its managers and members as known here.
    pub(super) fn admit(&self, mission: &str, robots: &[RobotId]) -> Vec<Command> {
        if !self.missions.contains_key(mission) {
            return vec![];
        }
        let managers = self.managers(mission);
        let view = self.missions.get(mission).and_then(|r| r.view.as_ref());
        let mut members: Vec<RobotId> = view.map(|v| v.robots.iter().chain(&v.lost).cloned().collect()).unwrap_or_default();
        members.extend(self.assignment.iter().filter(|(_, m)| m.as_str() == mission).map(|(id, _)| id.clone()));
        members.sort();
        members.dedup();
        robots
            .iter()
            .map(|r| Command::SendToRobot {
                req: None,
                robot: r.clone(),
                cmd: RobotCommand::Admit { mission: MissionName::from(mission), managers: managers.clone(), members: members.clone() },
            })
            .collect()
    }

    /// The nodes that may manage `mission` as this manager knows it: its host and its chain (as
    /// last reported), head first.
    pub fn managers(&self, mission: &str) -> Vec<NodeId> {
        self.missions.get(mission).map_or_else(Vec::new, MissionRecord::managers)
    }
}
