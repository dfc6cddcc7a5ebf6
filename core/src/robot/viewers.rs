//! The viewers a robot has heard announce themselves (`mrmm viz`, the demo's recording): its
//! telemetry is tagged for them while they keep announcing, so a viewer checks every message
//! instead of only the signed ones.

use std::collections::BTreeMap;

use mrmm_proto::Sender;

/// Viewers a robot tags its telemetry for at most (each costs a tag per message).
pub const MAX_VIEWERS: usize = 8;

/// A viewer not heard for this many announcement periods is forgotten.
const FORGET_AFTER_PERIODS: u64 = 3;

/// Outcome of an announcement.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Heard {
    Kept,
    /// Its role does not view (only operators' tools and central do).
    NotAViewer,
    /// [`MAX_VIEWERS`] others are current.
    Full,
}

/// The current viewers, by proven sender, with when each was last heard (ms).
#[derive(Debug, Clone)]
pub struct Viewers {
    hello_ms: u64,
    seen: BTreeMap<Sender, u64>,
}

impl Viewers {
    /// Viewers that announce themselves every `hello_ms`.
    pub fn new(hello_ms: u64) -> Viewers {
        Viewers { hello_ms, seen: BTreeMap::new() }
    }

    /// A proven announcement from `who` at `now_ms`.
    pub fn heard(&mut self, now_ms: u64, who: Sender) -> Heard {
        if !mrmm_proto::policy::allows(mrmm_proto::policy::Act::Viewer, who.role, mrmm_proto::policy::Relation::Stranger) {
            return Heard::NotAViewer;
        }
        self.forget_old(now_ms);
        if !self.seen.contains_key(&who) && self.seen.len() >= MAX_VIEWERS {
            return Heard::Full;
        }
        self.seen.insert(who, now_ms);
        Heard::Kept
    }

    /// Whether `who` is a current viewer at `now_ms`.
    pub fn is_current(&self, now_ms: u64, who: &Sender) -> bool {
        self.seen.get(who).is_some_and(|&t| now_ms.saturating_sub(t) < self.hello_ms.saturating_mul(FORGET_AFTER_PERIODS))
    }

    fn forget_old(&mut self, now_ms: u64) {
        let keep = self.hello_ms.saturating_mul(FORGET_AFTER_PERIODS);
        self.seen.retain(|_, t| now_ms.saturating_sub(*t) < keep);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mrmm_proto::Role;

    #[test]
    fn viewers_are_operators_tools_or_central_kept_while_they_announce_and_bounded() {
        let mut v = Viewers::new(2000);
        let op = Sender::new(Role::Operator, "op");
        assert_eq!(v.heard(0, Sender::new(Role::Robot, "r2")), Heard::NotAViewer);
        assert_eq!(v.heard(0, op.clone()), Heard::Kept);
        assert!(v.is_current(5999, &op));
        assert!(!v.is_current(6000, &op), "a silent viewer is forgotten after three periods");
        assert_eq!(v.heard(5000, op.clone()), Heard::Kept);
        assert!(v.is_current(10_999, &op));
        for i in 1..MAX_VIEWERS {
            assert_eq!(v.heard(6000, Sender::new(Role::Operator, format!("op{i}"))), Heard::Kept);
        }
        assert_eq!(v.heard(6000, Sender::new(Role::Central, "central")), Heard::Full);
        // Once the others fall silent, room again.
        assert_eq!(v.heard(30_000, Sender::new(Role::Central, "central")), Heard::Kept);
        assert!(!v.is_current(30_000, &op));
    }
}
