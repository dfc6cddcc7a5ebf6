//! Hand-overs on the robot: a plan carried on under a new epoch with a new team, and a plan taken
//! over from a member that left, from where it was.

use mrmm_proto::{BarrierMode, PlanAssignment, Step};

use super::Executor;

impl Executor {
    /// A plan taken over from a member that left (a hand-over, [`PlanAssignment::handover`]):
    /// the robot starts on the leg that member was on — the navigate step at or before `step` —
    /// in its `round`, as a member already past the formation once the formation is behind.
    pub fn taking_over(assignment: PlanAssignment, step: u32, round: u32) -> Self {
        let mut e = Executor::new(assignment);
        let steps = &e.assignment.plan.steps;
        let mut pc = (step as usize).min(steps.len());
        while pc > 0 && !matches!(steps.get(pc), Some(Step::Navigate { .. })) {
            pc -= 1;
        }
        let formation = steps.iter().position(|s| matches!(s, Step::Sync { .. }));
        if round > 0 || formation.is_some_and(|f| pc > f) {
            e.syncs_passed = 1;
        }
        for (j, s) in steps.iter().enumerate() {
            if let Step::Loop { to, .. } = s {
                if *to <= pc && pc < j {
                    e.loops.insert(j, round);
                }
            }
        }
        if let Some(at) = passed_before(steps, pc, round) {
            e.barrier.arrived(at);
        }
        e.pc = pc;
        e.round = round;
        e
    }

    /// Whether `a` carries on the plan this executor runs (a hand-over replaced another member:
    /// same mission, same plan of the same lineage, a newer epoch).
    pub fn carried_on_by(&self, a: &PlanAssignment) -> bool {
        a.handover.is_some()
            && a.mission == self.assignment.mission
            && a.epoch > self.assignment.epoch
            && a.planned() == self.assignment.planned()
            && a.plan == self.assignment.plan
            && a.team == self.assignment.team
    }

    /// Goes on with the same plan under `a`'s epoch and team ([`Executor::carried_on_by`]):
    /// where the robot is stays — its step, round and loops, the leg it drives, the barriers it
    /// reached and knows released; the barriers are the new epoch's, with the new members. Where
    /// it waits its arrival is announced again (under the new epoch). Barrier messages count
    /// afresh, as under any new plan.
    pub fn carry_on(&mut self, a: PlanAssignment) {
        self.barrier = self.barrier.carried_into(a.epoch, &a.members, a.barrier);
        for s in &a.scopes {
            if let Some(w) = self.wide.get_mut(&s.team) {
                w.barrier = w.barrier.carried_into(a.epoch, &s.members, BarrierMode::Mesh);
                w.waiting = None;
                w.turning = false;
                w.gap = self.republish;
                w.echo_due = false;
            }
        }
        self.assignment = a;
        self.waiting = None;
        self.turning = false;
        self.gap = self.republish;
        self.echo_due = false;
        self.announced = None;
        self.release_echo_due = false;
        self.acked_by = None;
        self.sync_msgs = 0;
    }
}

/// The team's own barrier a robot starting at step `pc` of round `round` has passed last: the
/// member it replaces passed it, and a teammate still waiting there is answered with it.
fn passed_before(steps: &[Step], pc: usize, round: u32) -> Option<(u32, u32)> {
    let own = |s: &Step| match s {
        Step::Sync { point, scope: None } => Some(*point),
        _ => None,
    };
    let loop_to = steps.iter().find_map(|s| match s {
        Step::Loop { to, .. } => Some(*to),
        _ => None,
    });
    let from = if round > 0 { loop_to.unwrap_or(0).min(pc) } else { 0 };
    if let Some(point) = steps.get(from..pc).and_then(|s| s.iter().rev().find_map(own)) {
        return Some((round, point));
    }
    let body = steps.get(loop_to?..)?;
    round.checked_sub(1).and_then(|r| body.iter().rev().find_map(own).map(|point| (r, point)))
}
