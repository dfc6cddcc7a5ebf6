//! A burst of member losses, planned around once: the replan waits [`LOSS_BURST_S`] after the
//! first loss, [`LOSS_QUIET_S`] after the last, and [`LOSS_BURST_MAX_S`] after the first at most.
//! A member joining while such a replan is held is part of the burst (a robot lost and back
//! within it, as links flap on a loaded machine, costs no plan of its own).

use mrmm_proto::Time;

/// Members lost within this long of the first of a burst are planned around in one replan,
/// seconds (a site's robots lost together cost one plan, not one each).
pub const LOSS_BURST_S: f64 = 1.0;
/// A loss within the burst holds its replan until this long after it: losses seen one after
/// another (a loaded machine notices a tenth of the fleet crashed over more than a second) are
/// still one burst.
pub const LOSS_QUIET_S: f64 = 0.5;
/// A burst's replan is held at most this long after its first loss, however long losses go on
/// (new plans stay within seconds of the first).
pub const LOSS_BURST_MAX_S: f64 = 3.0;

/// The burst a held replan is for (not replicated: a successor taking over replans at once, the
/// epoch having moved on at the first loss).
#[derive(Debug, Clone, Default)]
pub(super) struct LossBurst {
    /// When the replan is due.
    due: Option<Time>,
    /// When the burst began.
    started: Time,
}

impl LossBurst {
    /// A loss at `now`: whether it begins a burst (the plan is outdated from now on).
    pub(super) fn loss(&mut self, now: Time) -> bool {
        match self.due {
            None => {
                self.started = now;
                self.due = Some(now + LOSS_BURST_S);
                true
            }
            Some(due) => {
                self.due = Some(due.max(now + LOSS_QUIET_S).min(self.started + LOSS_BURST_MAX_S));
                false
            }
        }
    }

    /// A member joined at `now`: whether a replan is held for a burst, which then takes it in (held
    /// as for a loss, within the same bound); otherwise it is for the caller to plan.
    pub(super) fn join(&mut self, now: Time) -> bool {
        if self.due.is_none() {
            return false;
        }
        self.loss(now);
        true
    }

    /// When the held replan is due, if one is.
    pub(super) fn due(&self) -> Option<Time> {
        self.due
    }

    /// The replan is made (or no longer needed).
    pub(super) fn clear(&mut self) {
        self.due = None;
    }
}
