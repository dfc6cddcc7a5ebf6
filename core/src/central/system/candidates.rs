//! Robots heard of but not registered: an id whose liveliness token appeared, or whose sealed
//! telemetry came, before it answered the info question. A liveliness token carries no seal, so
//! anyone on the mesh can declare thousands of them; until its robot answers the question with
//! a sealed reply an id is only a candidate — asked at a bounded rate, never in the registry,
//! never journaled, forgotten when its token goes — and a candidate that proved itself by its
//! own sealed telemetry (**vouched**) is asked first, so a real robot registers at once however
//! many made-up tokens wait.

use std::collections::BTreeMap;

use mrmm_proto::{RobotId, Time};

use super::INFO_RETRY_S;

/// Candidates held at most; beyond, a new unvouched id is ignored (a vouched one takes the
/// place of the unvouched candidate asked longest ago).
pub const MAX_CANDIDATES: usize = 4_096;
/// While fewer candidates than this wait, a new one is asked at once (a fleet starting); beyond,
/// at the tick, at most [`UNVOUCHED_PER_TICK`] unvouched ones.
pub const ASK_AT_ONCE_BELOW: usize = 256;
/// Unvouched candidates asked per tick at most (vouched ones: every one due).
pub const UNVOUCHED_PER_TICK: usize = 8;

#[derive(Debug, Clone, Copy, PartialEq)]
struct Candidate {
    /// When its token appeared (or its telemetry first came).
    since: Time,
    /// When it was last asked who it is.
    asked: Option<Time>,
    /// Its own sealed telemetry came.
    vouched: bool,
}

/// The candidates, bounded.
#[derive(Debug, Clone, Default)]
pub(super) struct Candidates {
    by_id: BTreeMap<RobotId, Candidate>,
    /// New ids ignored because [`MAX_CANDIDATES`] were waiting.
    ignored: u64,
}

impl Candidates {
    /// Its token appeared at `now`; whether to ask it at once.
    pub(super) fn appeared(&mut self, id: &str, now: Time) -> bool {
        if let Some(c) = self.by_id.get_mut(id) {
            c.since = now;
            return false;
        }
        if self.by_id.len() >= MAX_CANDIDATES {
            self.ignore(id);
            return false;
        }
        let at_once = self.by_id.len() < ASK_AT_ONCE_BELOW;
        self.by_id.insert(RobotId::from(id), Candidate { since: now, asked: at_once.then_some(now), vouched: false });
        at_once
    }

    /// Its sealed telemetry came at `now`: vouched, and whether to ask it now (not asked within
    /// [`INFO_RETRY_S`]). A vouched id takes the place of an unvouched one if none is free.
    pub(super) fn vouched(&mut self, id: &str, now: Time) -> bool {
        if !self.by_id.contains_key(id) && self.by_id.len() >= MAX_CANDIDATES {
            let Some(evicted) = self
                .by_id
                .iter()
                .filter(|(_, c)| !c.vouched)
                .min_by(|a, b| a.1.asked.unwrap_or(Time::NEVER).total_cmp(&b.1.asked.unwrap_or(Time::NEVER)))
                .map(|(id, _)| id.clone())
            else {
                self.ignore(id);
                return false;
            };
            self.by_id.remove(&evicted);
        }
        let c = self.by_id.entry(RobotId::from(id)).or_insert(Candidate { since: now, asked: None, vouched: true });
        c.vouched = true;
        let due = c.asked.is_none_or(|a| now - a >= INFO_RETRY_S);
        if due {
            c.asked = Some(now);
        }
        due
    }

    /// Its token went: forgotten.
    pub(super) fn gone(&mut self, id: &str) {
        self.by_id.remove(id);
    }

    /// It answered: no longer a candidate; when it appeared, if it was one.
    pub(super) fn take(&mut self, id: &str) -> Option<Time> {
        self.by_id.remove(id).map(|c| c.since)
    }

    /// The candidates' ids.
    pub(super) fn ids(&self) -> impl Iterator<Item = &RobotId> {
        self.by_id.keys()
    }

    #[cfg(test)]
    fn contains(&self, id: &str) -> bool {
        self.by_id.contains_key(id)
    }

    #[cfg(test)]
    fn len(&self) -> usize {
        self.by_id.len()
    }

    /// Candidates to ask again at `now`: every vouched one not asked within [`INFO_RETRY_S`]
    /// (at most `budget`), then at most [`UNVOUCHED_PER_TICK`] unvouched ones, those asked
    /// longest ago first.
    pub(super) fn due(&mut self, now: Time, budget: usize) -> Vec<RobotId> {
        let ready = |c: &Candidate| c.asked.is_none_or(|a| now - a >= INFO_RETRY_S);
        let mut due: Vec<RobotId> = self.by_id.iter().filter(|(_, c)| c.vouched && ready(c)).map(|(id, _)| id.clone()).take(budget).collect();
        let room = budget.saturating_sub(due.len()).min(UNVOUCHED_PER_TICK);
        if room > 0 {
            let mut waiting: Vec<(Time, &RobotId)> =
                self.by_id.iter().filter(|(_, c)| !c.vouched && ready(c)).map(|(id, c)| (c.asked.unwrap_or(Time::LONG_AGO), id)).collect();
            if waiting.len() > room {
                waiting.select_nth_unstable_by(room - 1, |a, b| a.0.total_cmp(&b.0));
                waiting.truncate(room);
            }
            due.extend(waiting.into_iter().map(|(_, id)| id.clone()));
        }
        for id in &due {
            if let Some(c) = self.by_id.get_mut(id) {
                c.asked = Some(now);
            }
        }
        due
    }

    fn ignore(&mut self, id: &str) {
        self.ignored = self.ignored.saturating_add(1);
        if self.ignored.is_power_of_two() {
            tracing::warn!(robot = %id, ignored = self.ignored, "{MAX_CANDIDATES} unregistered robots wait to answer who they are: new ones ignored");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::at;

    #[test]
    fn a_flood_of_tokens_is_bounded_and_a_vouched_robot_goes_first() {
        let mut c = Candidates::default();
        let mut at_once = 0;
        for i in 0..10_000 {
            at_once += usize::from(c.appeared(&format!("ghost{i}"), at(0.0)));
        }
        assert_eq!((c.len(), at_once), (MAX_CANDIDATES, ASK_AT_ONCE_BELOW), "bounded; the first asked at once");
        // The real robot's token was ignored (full), but its sealed telemetry vouches for it.
        assert!(c.vouched("r1", at(0.5)), "asked at once");
        assert!(c.contains("r1") && c.len() == MAX_CANDIDATES);
        assert!(!c.vouched("r1", at(0.7)), "not again within the retry period");
        let due = c.due(at(0.5 + INFO_RETRY_S), 64);
        assert_eq!(due.len(), 1 + UNVOUCHED_PER_TICK);
        assert_eq!(due[0], RobotId::from("r1"), "the vouched robot first");
        assert!(due[1..].iter().all(|id| id.as_str().starts_with("ghost")));
        // Asked ones wait their turn: the next tick asks others.
        let next = c.due(at(0.6 + INFO_RETRY_S), 64);
        assert!(next.iter().all(|id| !due.contains(id)), "{next:?}");
        assert_eq!(c.take("r1"), Some(at(0.5)));
        c.gone("ghost1");
        assert!(!c.contains("ghost1") && !c.contains("r1"));
    }
}
