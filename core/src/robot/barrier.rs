//! A robot's view of its team's barriers: who must arrive, who has. No I/O.
//!
//! A barrier `(point, round)` of epoch `e` releases for a member once every *required* member has
//! arrived there or beyond. Required members are the plan's members minus those whose liveliness
//! was lost while this plan ran (dead, moved out, or left). Members arrive in the same order of
//! barriers, so an arrival at a later barrier implies the earlier ones: a member that joins the
//! topic late, or missed a publication, never blocks the team.
//!
//! Under [`BarrierMode::Leader`] only the leader (the lowest id among the members not gone)
//! hears arrivals; the others learn from its releases, each of which releases every barrier up
//! to it. A release is safe to announce by anyone who has seen every required member arrive, or
//! who has itself been released there — so a new leader, or two members briefly both believing
//! they lead, never release a barrier early.

use std::collections::{BTreeMap, BTreeSet};

use mrmm_proto::{BarrierMode, RobotId, SyncArrival, SyncRelease};

/// Barrier bookkeeping for one plan (one epoch of one team).
#[derive(Debug, Clone)]
pub struct Barrier {
    me: RobotId,
    epoch: u64,
    members: BTreeSet<RobotId>,
    gone: BTreeSet<RobotId>,
    /// Furthest barrier (round, point) each member reported.
    furthest: BTreeMap<RobotId, (u32, u32)>,
    mode: BarrierMode,
    /// The furthest barrier (round, point) known released: by a leader's release, or because
    /// this robot passed it.
    released: Option<(u32, u32)>,
}

impl Barrier {
    pub fn new(me: &str, epoch: u64, members: &[RobotId]) -> Self {
        Barrier {
            me: RobotId::from(me),
            epoch,
            members: members.iter().cloned().collect(),
            gone: BTreeSet::new(),
            furthest: BTreeMap::new(),
            mode: BarrierMode::Mesh,
            released: None,
        }
    }

    /// This robot's barriers carried into epoch `epoch` with `members` (a hand-over: the plan
    /// goes on): its own furthest arrival stays (echoed to a member that waits behind it), and
    /// whom it saw gone among those who stay. Nothing counts as released under the new epoch
    /// until every member of it arrived there: the others' arrivals are heard again.
    pub fn carried_into(&self, epoch: u64, members: &[RobotId], mode: BarrierMode) -> Self {
        let mut b = Barrier::new(self.me.as_str(), epoch, members).with_mode(mode);
        if let Some(mine) = self.mine() {
            b.arrived(mine);
        }
        b.gone = self.gone.iter().filter(|g| b.members.contains(*g)).cloned().collect();
        b
    }

    /// This robot stands for an arrival at `at` (round, point) it did not announce under this
    /// epoch: the barrier it carried on from, or the one the member it replaced passed last.
    pub fn arrived(&mut self, at: (u32, u32)) {
        let e = self.furthest.entry(self.me.clone()).or_insert(at);
        *e = (*e).max(at);
    }

    /// The same barrier run in `mode`.
    pub fn with_mode(mut self, mode: BarrierMode) -> Self {
        self.mode = mode;
        self
    }

    pub fn mode(&self) -> BarrierMode {
        self.mode
    }

    /// Records a leader's release; other epochs and non-members are ignored. Returns whether it
    /// counted.
    pub fn release_heard(&mut self, r: &SyncRelease) -> bool {
        if r.epoch != self.epoch || !self.members.contains(&r.leader) {
            return false;
        }
        self.passed((r.round, r.point));
        true
    }

    /// This robot passed (or learnt released) barrier `(round, point)`.
    pub fn passed(&mut self, at: (u32, u32)) {
        if self.released.is_none_or(|r| at > r) {
            self.released = Some(at);
        }
    }

    /// The lowest id among the members still required: the team's leader as this robot sees it.
    pub fn leader(&self) -> &str {
        self.members.iter().find(|m| !self.gone.contains(*m)).map_or(self.me.as_str(), |m| m.as_str())
    }

    /// Whether this robot leads the team's barriers (always false in [`BarrierMode::Mesh`]).
    pub fn leading(&self) -> bool {
        self.mode == BarrierMode::Leader && self.leader() == self.me
    }

    /// The furthest barrier (round, point) every required member has reached.
    fn frontier(&self) -> Option<(u32, u32)> {
        self.members.iter().filter(|m| !self.gone.contains(*m)).map(|m| self.furthest.get(m).copied()).min().flatten()
    }

    /// The furthest barrier (round, point) this robot knows released, by what it heard or saw
    /// everyone reach: what a leader announces.
    pub fn releasable(&self) -> Option<(u32, u32)> {
        self.frontier().max(self.released)
    }

    /// Records an arrival; other epochs and non-members are ignored. Returns whether it counted.
    pub fn arrival(&mut self, a: &SyncArrival) -> bool {
        if a.epoch != self.epoch || !self.members.contains(&a.robot) {
            return false;
        }
        let at = (a.round, a.point);
        let e = self.furthest.entry(a.robot.clone()).or_insert(at);
        if at > *e {
            *e = at;
        }
        true
    }

    /// A member's liveliness token appeared.
    pub fn member_alive(&mut self, id: &str) {
        self.gone.remove(id);
    }

    /// A member's liveliness token disappeared: it no longer holds anyone up.
    pub fn member_gone(&mut self, id: &str) {
        if self.members.contains(id) && id != self.me {
            self.gone.insert(RobotId::from(id));
        }
    }

    /// Whether barrier `(point, round)` is released (our own arrival must be recorded first).
    pub fn released(&self, point: u32, round: u32) -> bool {
        self.releasable().is_some_and(|r| r >= (round, point))
    }

    /// Our own furthest arrival, as (round, point).
    pub fn mine(&self) -> Option<(u32, u32)> {
        self.furthest.get(&self.me).copied()
    }

    /// Whether another member's arrival `a` is at or before our own furthest arrival: if we are
    /// not waiting there ourselves, its sender may be waiting for an arrival of ours it missed.
    pub fn at_or_behind_us(&self, a: &SyncArrival) -> bool {
        a.epoch == self.epoch && a.robot != self.me && self.mine().is_some_and(|m| (a.round, a.point) <= m)
    }

    /// Whether this robot believes `id` gone (its liveliness was lost while this plan ran).
    pub fn is_gone(&self, id: &str) -> bool {
        self.gone.contains(id)
    }

    /// Members still required.
    pub fn required(&self) -> usize {
        self.members.len() - self.gone.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn arr(robot: &str, epoch: u64, point: u32, round: u32) -> SyncArrival {
        SyncArrival { robot: robot.into(), epoch, point, round }
    }

    fn team() -> Barrier {
        Barrier::new("a", 1, &["a".into(), "b".into(), "c".into()])
    }

    #[test]
    fn releases_when_all_arrived() {
        let mut b = team();
        b.arrival(&arr("a", 1, 1, 0));
        b.arrival(&arr("b", 1, 1, 0));
        assert!(!b.released(1, 0));
        b.arrival(&arr("c", 1, 1, 0));
        assert!(b.released(1, 0));
        assert!(!b.released(2, 0));
    }

    #[test]
    fn a_lost_member_releases_at_once_and_a_returning_one_counts_again() {
        let mut b = team();
        b.arrival(&arr("a", 1, 1, 0));
        b.arrival(&arr("b", 1, 1, 0));
        b.member_gone("c");
        assert!(b.released(1, 0));
        assert_eq!(b.required(), 2);
        b.member_alive("c");
        assert!(!b.released(1, 0));
    }

    #[test]
    fn later_arrivals_imply_earlier_ones_and_foreign_epochs_do_not_count() {
        let mut b = team();
        b.arrival(&arr("a", 1, 0, 0));
        b.arrival(&arr("b", 1, 3, 0));
        b.arrival(&arr("c", 1, 1, 1));
        assert!(b.released(0, 0));
        assert!(!b.released(3, 0), "we ourselves are only at barrier 0");
        b.arrival(&arr("a", 1, 3, 0));
        assert!(b.released(3, 0));
        assert!(!b.arrival(&arr("a", 2, 9, 9)));
        assert!(!b.arrival(&arr("zz", 1, 9, 9)));
        assert!(b.released(3, 0));
        // An older arrival never moves a member back.
        b.arrival(&arr("c", 1, 0, 0));
        assert!(b.released(3, 0));
        // We never remove ourselves.
        b.member_gone("a");
        assert_eq!(b.required(), 3);
    }

    fn rel(leader: &str, epoch: u64, point: u32, round: u32) -> SyncRelease {
        SyncRelease { leader: leader.into(), epoch, point, round }
    }

    #[test]
    fn a_barrier_carried_into_a_new_epoch_keeps_what_this_robot_reached_and_waits_for_the_newcomer() {
        let mut b = team();
        for r in ["a", "b", "c"] {
            b.arrival(&arr(r, 1, 2, 0));
        }
        b.passed((0, 2));
        b.member_gone("b");
        // c handed its place to d.
        let mut n = b.carried_into(2, &["a".into(), "b".into(), "d".into()], BarrierMode::Mesh);
        assert_eq!(n.mine(), Some((0, 2)));
        assert!(!n.released(2, 0), "released under the new epoch only once everyone arrived there");
        assert!(n.at_or_behind_us(&arr("d", 2, 2, 0)), "a member waiting there hears our arrival again");
        assert!(n.is_gone("b") && !n.is_gone("c"));
        assert!(!n.arrival(&arr("c", 2, 3, 0)), "the leaver is no member");
        assert!(!n.arrival(&arr("d", 1, 3, 0)), "the old epoch's arrivals do not count");
        n.arrival(&arr("a", 2, 3, 0));
        assert!(!n.released(3, 0) && !n.released(2, 0), "the newcomer holds the barriers");
        n.arrival(&arr("d", 2, 3, 0));
        assert!(n.released(3, 0));
    }

    #[test]
    fn the_leader_is_the_lowest_member_still_required() {
        let mut b = Barrier::new("b", 1, &["c".into(), "a".into(), "b".into()]).with_mode(BarrierMode::Leader);
        assert_eq!(b.leader(), "a");
        assert!(!b.leading());
        b.member_gone("a");
        assert!(b.leading());
        b.member_alive("a");
        assert!(!b.leading());
        let mesh = Barrier::new("a", 1, &["a".into(), "b".into()]);
        assert!(!mesh.leading(), "nobody leads a mesh barrier");
    }

    #[test]
    fn a_release_frees_every_barrier_up_to_it_and_foreign_ones_do_not_count() {
        let mut b = Barrier::new("b", 1, &["a".into(), "b".into(), "c".into()]).with_mode(BarrierMode::Leader);
        b.arrival(&arr("b", 1, 2, 0));
        assert!(!b.released(2, 0), "a member hears no arrivals: only its own");
        assert!(!b.release_heard(&rel("a", 2, 2, 0)), "another epoch");
        assert!(!b.release_heard(&rel("zz", 1, 2, 0)), "not a member");
        assert!(!b.released(2, 0));
        assert!(b.release_heard(&rel("c", 1, 2, 0)), "any member may announce what it knows released");
        assert!(b.released(2, 0) && b.released(0, 0));
        assert!(!b.released(3, 0));
        // An older release never takes one back.
        b.release_heard(&rel("a", 1, 1, 0));
        assert!(b.released(2, 0));
    }

    #[test]
    fn what_a_leader_announces_is_what_everyone_required_reached_or_it_passed() {
        let mut b = team().with_mode(BarrierMode::Leader);
        assert_eq!(b.releasable(), None);
        b.arrival(&arr("a", 1, 2, 0));
        b.arrival(&arr("b", 1, 1, 0));
        assert_eq!(b.releasable(), None, "c has not arrived anywhere");
        b.arrival(&arr("c", 1, 3, 0));
        assert_eq!(b.releasable(), Some((0, 1)), "b is the furthest behind");
        b.member_gone("b");
        assert_eq!(b.releasable(), Some((0, 2)));
        b.passed((1, 0));
        assert_eq!(b.releasable(), Some((1, 0)), "a barrier it passed was released by someone who knew");
    }
}
