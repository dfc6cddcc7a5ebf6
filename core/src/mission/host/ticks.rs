//! Time passing on a mission host: its ticks (chains, replans held back for a burst of losses,
//! plan re-deliveries), its status ticks, and the answers to the plans it sent.

use mrmm_proto::{MissionName, NodeId, PlanAssignment, RobotId, Time};

use super::{Command, HostCore};
use crate::mission;
use crate::Failure;

impl HostCore {
    /// Every few tens of milliseconds: chains, replans held back for a burst of losses that are
    /// due, plans to send again.
    pub(super) fn tick(&mut self, now: Time, out: &mut Vec<Command>) {
        self.prune_unwatched(now);
        for (name, cmds) in self.registry.tick(now) {
            self.apply(now, name.as_str(), cmds, out);
        }
        let due: Vec<MissionName> = self.heads.iter().filter(|(_, h)| h.mm.replan_due().is_some_and(|d| now >= d)).map(|(n, _)| n.clone()).collect();
        for name in due {
            self.run(now, name.as_str(), mission::Event::Tick, out);
        }
        let (robots, registry) = (&self.robots, &self.registry);
        for (name, h) in self.heads.iter_mut() {
            let managers = registry.replica(name.as_str()).and_then(|r| r.config()).map(|c| c.chain.clone()).unwrap_or_default();
            for (robot, assignment) in h.redeliver(now, |r| robots.alive(r)) {
                out.push(send_plan(name.as_str(), robot, assignment, &managers));
            }
        }
    }

    /// Once a second: each led mission's metrics into its chain (replicated only if they
    /// changed, and then its status is published with the change); else its pool and status.
    pub(super) fn status_tick(&mut self, now: Time, out: &mut Vec<Command>) {
        // Only a host that leads or replicates a mission acts on liveliness: a fleet of idle
        // robot nodes asks nothing.
        let involved = !self.heads.is_empty() || self.registry.names().next().is_some();
        if involved && self.roll.due(now) {
            out.push(Command::RollCall);
        }
        let names: Vec<MissionName> = self.heads.keys().cloned().collect();
        for name in names {
            let before = out.len();
            self.run(now, name.as_str(), mission::Event::Checkpoint, out);
            if !out[before..].iter().any(|c| matches!(c, Command::Status(_))) {
                self.set_pool(now, name.as_str());
                self.status(now, name.as_str(), out);
            }
        }
    }

    /// A robot answered the plan of `mission`'s `epoch`: delivered, refused for good, or to be
    /// tried again; its place in the delivery window goes to the next plan waiting.
    pub(super) fn plan_delivered(&mut self, now: Time, mission: &str, robot: &str, epoch: u64, result: Result<(), Failure>, out: &mut Vec<Command>) {
        let managers = self.registry.replica(mission).and_then(|r| r.config()).map(|c| c.chain.clone()).unwrap_or_default();
        let robots = &self.robots;
        let Some(h) = self.heads.get_mut(mission) else { return };
        match result {
            Ok(()) => h.delivered(robot, epoch),
            Err(f) if f.retryable => {}
            Err(f) => {
                tracing::warn!(%mission, %robot, epoch, "plan refused: {}", f.error);
                h.delivered(robot, epoch);
            }
        }
        for (next, assignment) in h.answered(now, robot, epoch, |r| robots.alive(r)) {
            out.push(send_plan(mission, next, assignment, &managers));
        }
    }
}

/// A plan to send, naming the mission's chain of managers as it is now.
fn send_plan(mission: &str, robot: RobotId, mut assignment: Box<PlanAssignment>, managers: &[NodeId]) -> Command {
    assignment.managers = managers.to_vec();
    Command::SendPlan { mission: mission.into(), robot, assignment }
}
