//! Hand-overs: a robot takes a member's place in the current plan, which goes on under the next
//! epoch — no planner asked, the other members where they are ([`super::Event::Replaced`]).

use std::collections::BTreeMap;

use mrmm_proto::plan::MissionPlan;
use mrmm_proto::{self as proto, HandoverState, Member, RobotId};

use super::{Command, MissionManager};

impl MissionManager {
    /// `by` takes `out`'s place in the current plan ([`super::Event::Replaced`]): the plan is the same
    /// with `by` for `out`, under a new epoch; `by` starts where `out` last said it was, every
    /// other member goes on where it is (or, not running the plan, starts where it last said).
    pub(super) fn replaced(&mut self, out: RobotId, by: Member) -> Vec<Command> {
        self.lost.remove(&by.spec.id);
        // Out for good, as with `Left`: a lost leaver coming back must not rejoin (found by the
        // system sim, seed 176 with hand-overs).
        self.lost.remove(&out);
        let id = by.spec.id.clone();
        let Some((mut plan, handover)) = self.handover_of(&out, &id) else {
            tracing::info!(mission = %self.spec.name, %out, by = %id, "no plan to hand over: replanning");
            self.take_out(vec![out]);
            self.members.insert(id, by);
            return self.replan();
        };
        for rp in plan.plans.iter_mut().filter(|rp| rp.robot == out) {
            rp.robot = id.clone();
            rp.robot_type.clone_from(&by.spec.robot_type);
        }
        self.take_out(vec![out.clone()]);
        self.members.insert(id.clone(), by);
        self.epoch = self.epoch.saturating_add(1);
        let epoch = self.epoch;
        tracing::info!(mission = %self.spec.name, epoch, %out, by = %id, "hand-over: the plan goes on");
        self.handover = Some(handover);
        let cmds = self.assignments(epoch, &plan);
        self.plan_msgs = self.plan_msgs.saturating_add(cmds.len() as u64);
        self.plan = Some((epoch, plan));
        cmds
    }

    /// What a hand-over of `out`'s place to `by` carries on: the current plan, and the epoch it
    /// was planned for with where each member starts (`by` where `out` was). `None` if there is
    /// no plan to carry on.
    fn handover_of(&self, out: &RobotId, by: &RobotId) -> Option<(MissionPlan, HandoverState)> {
        let (epoch, plan) = self.plan.as_ref().filter(|(e, _)| *e == self.epoch)?;
        let usable = self.members.contains_key(out) && !self.members.contains_key(by) && !self.spec.paused && self.burst.due().is_none();
        if !usable || !plan.plans.iter().any(|rp| &rp.robot == out) {
            return None;
        }
        let at = |id: &RobotId| self.metrics.progress_of(id.as_str()).filter(|p| p.epoch == *epoch && p.mission == self.spec.name).map(|p| (p.step, p.round));
        let from = at(out)?;
        let mut starts: BTreeMap<RobotId, (u32, u32)> = self.members.keys().filter(|m| *m != out).filter_map(|m| Some((m.clone(), at(m)?))).collect();
        starts.insert(by.clone(), from);
        let planned = self.handover.as_ref().map_or(*epoch, |h| h.planned);
        Some((plan.clone(), HandoverState { planned, starts }))
    }

    /// The hand-over a member's plan of the current epoch carries, if the plan carries on one.
    pub(crate) fn handover_for(&self, robot: &RobotId) -> Option<proto::Handover> {
        let h = self.handover.as_ref()?;
        let (step, round) = h.starts.get(robot).copied().unwrap_or((0, 0));
        Some(proto::Handover { planned: h.planned, step, round })
    }
}
