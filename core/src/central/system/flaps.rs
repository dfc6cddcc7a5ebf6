//! What of a robot's losses and returns goes to the journal: each one while they are few, and a
//! robot that flaps lost/back (a link that expires under load, a token declared and withdrawn
//! again and again) as one entry once it is quiet — so the journal grows with what happened to
//! the fleet, not with how often a link blinked.

use std::collections::BTreeMap;

use mrmm_proto::{JournalEvent, RobotId, Time};

/// Losses and returns of one robot journaled one by one within a window at most.
pub const FLAP_ENTRIES: u8 = 4;
/// The window, seconds; a robot quiet this long after its last loss or return has the ones not
/// journaled written as one [`JournalEvent::RobotFlapping`].
pub const FLAP_WINDOW_S: f64 = 10.0;

#[derive(Debug, Clone, Copy, PartialEq)]
struct Window {
    start: Time,
    entries: u8,
    /// Losses not journaled one by one.
    losses: u32,
    /// Its last loss or return.
    last: Time,
    alive: bool,
}

/// Per robot, its recent losses and returns.
#[derive(Debug, Clone, Default)]
pub(super) struct Flaps {
    windows: BTreeMap<RobotId, Window>,
}

impl Flaps {
    /// `robot` was lost (`alive` false) or came back at `now`: the entry to journal now, if any.
    pub(super) fn changed(&mut self, now: Time, robot: &RobotId, alive: bool) -> Option<JournalEvent> {
        let w = self.windows.entry(robot.clone()).or_insert(Window { start: now, entries: 0, losses: 0, last: now, alive });
        if now - w.start >= FLAP_WINDOW_S && w.losses == 0 {
            *w = Window { start: now, entries: 0, losses: 0, last: now, alive };
        }
        w.last = now;
        w.alive = alive;
        if w.entries < FLAP_ENTRIES {
            w.entries += 1;
            return Some(if alive { JournalEvent::RobotBack { robot: robot.clone() } } else { JournalEvent::RobotLost { robot: robot.clone() } });
        }
        if !alive {
            w.losses = w.losses.saturating_add(1);
        }
        None
    }

    /// The robots quiet for [`FLAP_WINDOW_S`] since their last change: one entry each for what
    /// was not journaled; windows of quiet robots are dropped.
    pub(super) fn due(&mut self, now: Time) -> Vec<JournalEvent> {
        let mut out = Vec::new();
        self.windows.retain(|robot, w| {
            if now - w.last < FLAP_WINDOW_S {
                return true;
            }
            if w.losses > 0 {
                out.push(JournalEvent::RobotFlapping { robot: robot.clone(), losses: w.losses, alive: w.alive });
            }
            false
        });
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::at;

    fn lost(r: &str) -> JournalEvent {
        JournalEvent::RobotLost { robot: r.into() }
    }

    #[test]
    fn a_few_losses_are_journaled_one_by_one_and_flapping_as_one_entry() {
        let mut f = Flaps::default();
        let r1 = RobotId::from("r1");
        assert_eq!(f.changed(at(0.0), &r1, false), Some(lost("r1")));
        assert_eq!(f.changed(at(1.0), &r1, true), Some(JournalEvent::RobotBack { robot: r1.clone() }));
        assert!(f.due(at(5.0)).is_empty(), "not quiet yet");
        assert!(f.due(at(11.0)).is_empty(), "quiet, nothing left out");
        // 100 000 losses and returns in 50 s: four entries, then one when it is quiet.
        let mut entries = 0;
        for k in 0..100_000 {
            entries += usize::from(f.changed(at(20.0 + f64::from(k) * 5e-4), &r1, k % 2 == 1).is_some());
            entries += f.due(at(20.0 + f64::from(k) * 5e-4)).len();
        }
        assert_eq!(entries, usize::from(FLAP_ENTRIES));
        assert!(f.due(at(75.0)).is_empty(), "not quiet yet");
        assert_eq!(f.due(at(90.0)), vec![JournalEvent::RobotFlapping { robot: r1.clone(), losses: 49_998, alive: true }]);
        assert!(f.windows.is_empty());
    }
}
