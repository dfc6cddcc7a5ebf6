//! Controls and releases as a machine of its own: the [`MissionCtl`]s waiting for their heads
//! ([`Ctls`]: sent until acknowledged, one at a time per mission, in order per robot) and the
//! robots missions are letting go. A robot taken out of a mission is held by it until its head
//! acknowledged letting it go, and for [`RELEASE_GRACE_S`] after: meanwhile that head's reports
//! listing it are older than the order, and the robot joins no other mission before — never in
//! two teams.

use std::collections::{BTreeMap, BTreeSet};

use mrmm_proto::{MissionCtl, MissionName, RobotId, Time};

use super::{Ctls, RELEASE_GRACE_S};
use crate::Failure;

/// What the controls hear.
#[derive(Debug)]
pub(super) enum Event {
    /// A head answered control `id` (or nobody did).
    Answered { id: u64, result: Result<(), Failure> },
    /// Time passed: releases past their grace period are forgotten.
    Tick,
}

/// A mission letting a robot go with control `ctl`, acknowledged at `acked`.
#[derive(Debug, Clone)]
struct Released {
    ctl: u64,
    acked: Option<Time>,
}

/// The controls waiting for heads, and the robots being let go, keyed by (robot, mission): a
/// robot moved on again before its first mission let it go is held by both.
#[derive(Debug, Clone, Default)]
pub(super) struct Controls {
    ctls: Ctls,
    released: BTreeMap<(RobotId, MissionName), Released>,
}

impl Controls {
    pub(super) fn handle(&mut self, now: Time, event: Event) {
        match event {
            Event::Answered { id, result } => {
                self.ctls.done(now, id, result);
                if !self.ctls.is_pending(id) {
                    for r in self.released.values_mut().filter(|r| r.ctl == id && r.acked.is_none()) {
                        r.acked = Some(now);
                    }
                }
            }
            Event::Tick => self.released.retain(|_, r| r.acked.is_none_or(|t| now - t < RELEASE_GRACE_S)),
        }
    }

    /// Queues `ctl` for `mission`, after the controls `after`; returns its id.
    pub(super) fn push(&mut self, mission: &str, ctl: MissionCtl, after: Vec<u64>) -> u64 {
        self.ctls.push(mission, ctl, after)
    }

    /// `mission` lets `ids` go (after the controls `after`): each is held by it until its head
    /// acknowledged. Returns the control's id.
    pub(super) fn let_go(&mut self, mission: &str, ids: Vec<RobotId>, after: Vec<u64>) -> u64 {
        let held = ids.clone();
        let ctl = self.ctls.push(mission, MissionCtl::Left { ids }, after);
        for id in held {
            self.hold(id, mission, ctl);
        }
        ctl
    }

    /// `robot` is held by `mission` until control `ctl` is acknowledged.
    pub(super) fn hold(&mut self, robot: RobotId, mission: &str, ctl: u64) {
        self.released.insert((robot, MissionName::from(mission)), Released { ctl, acked: None });
    }

    /// The controls letting `robot` go from missions, while not yet acknowledged (a robot moved
    /// on before its first mission let it go is let go by several).
    pub(super) fn pending_for(&self, robot: &str) -> Vec<u64> {
        let mine = self.released.range((RobotId::from(robot), MissionName::default())..).take_while(|((r, _), _)| r == robot);
        mine.map(|(_, r)| r.ctl).filter(|c| self.ctls.is_pending(*c)).collect()
    }

    /// Whether `mission` let `robot` go within the grace period or is letting it go; with
    /// `pending`, only while its head has not acknowledged.
    pub(super) fn letting_go(&self, robot: &str, mission: &str, pending: bool) -> bool {
        self.released.get(&(RobotId::from(robot), MissionName::from(mission))).is_some_and(|r| !pending || self.ctls.is_pending(r.ctl))
    }

    /// (Robot, the mission letting it go), while its head has not acknowledged: durable.
    pub(super) fn releasing(&self) -> BTreeSet<(RobotId, MissionName)> {
        self.released.iter().filter(|(_, r)| self.ctls.is_pending(r.ctl)).map(|(k, _)| k.clone()).collect()
    }

    /// `mission` is ended with a terminate that replaces every control of it: what waited for
    /// them (a robot moved out of it, released by it before joining another) waits for the end.
    /// Returns the terminate's id.
    pub(super) fn end(&mut self, mission: &str) -> u64 {
        let gone = self.ctls.cancel_ids(mission);
        let end = self.ctls.push(mission, MissionCtl::Terminate, vec![]);
        self.ctls.wait_instead(&gone, end);
        for r in self.released.values_mut().filter(|r| gone.contains(&r.ctl)) {
            r.ctl = end;
        }
        end
    }

    /// Forgets every control of `mission` (it is gone).
    pub(super) fn cancel(&mut self, mission: &str) {
        self.ctls.cancel(mission);
    }

    /// Whether control `id` is still waiting to be acknowledged.
    pub(super) fn is_pending(&self, id: u64) -> bool {
        self.ctls.is_pending(id)
    }

    /// Whether a control like `pred` is waiting for `mission`.
    pub(super) fn has(&self, mission: &str, pred: impl Fn(&MissionCtl) -> bool) -> bool {
        self.ctls.has(mission, pred)
    }

    /// The controls to send now (see [`Ctls::due`]).
    pub(super) fn due(&mut self, now: Time) -> Vec<(u64, MissionName, MissionCtl)> {
        self.ctls.due(now)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::at;

    fn ack() -> Result<(), Failure> {
        Ok(())
    }

    #[test]
    fn a_robot_let_go_is_held_until_acknowledged_and_for_the_grace_period_after() {
        let mut c = Controls::default();
        let ctl = c.let_go("a", vec!["r1".into()], vec![]);
        assert!(c.letting_go("r1", "a", true) && c.letting_go("r1", "a", false));
        assert_eq!(c.pending_for("r1"), [ctl]);
        assert_eq!(c.releasing(), BTreeSet::from([("r1".into(), "a".into())]));
        assert!(!c.letting_go("r1", "b", false) && c.pending_for("r2").is_empty());
        c.handle(at(10.0), Event::Answered { id: ctl, result: ack() });
        // Acknowledged: no longer pending, still held for the grace period.
        assert!(!c.letting_go("r1", "a", true) && c.letting_go("r1", "a", false));
        assert!(c.pending_for("r1").is_empty() && c.releasing().is_empty());
        c.handle(at(10.0 + RELEASE_GRACE_S - 0.1), Event::Tick);
        assert!(c.letting_go("r1", "a", false));
        c.handle(at(10.0 + RELEASE_GRACE_S), Event::Tick);
        assert!(!c.letting_go("r1", "a", false));
    }

    #[test]
    fn a_robot_moved_on_twice_is_held_by_both_and_an_ended_mission_holds_it_until_its_end() {
        let mut c = Controls::default();
        let first = c.let_go("a", vec!["r1".into()], vec![]);
        let second = c.let_go("b", vec!["r1".into()], vec![first]);
        assert_eq!(c.pending_for("r1"), [first, second]);
        // `b` is ended instead (its start was never answered): r1 is held until the end is.
        let end = c.end("b");
        assert_eq!(c.pending_for("r1"), [first, end]);
        assert!(c.has("b", |x| *x == MissionCtl::Terminate));
        c.handle(at(1.0), Event::Answered { id: first, result: ack() });
        c.handle(at(1.0), Event::Answered { id: end, result: ack() });
        assert!(c.pending_for("r1").is_empty());
        let left = c.push("c", MissionCtl::Left { ids: vec!["r2".into()] }, vec![]);
        c.hold("r2".into(), "c", left);
        c.cancel("c");
        assert!(c.pending_for("r2").is_empty() && c.letting_go("r2", "c", false));
    }
}
