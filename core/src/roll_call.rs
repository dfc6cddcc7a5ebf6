//! The roll call: every [`ROLL_CALL_S`] a machine that follows liveliness tokens (central's
//! system manager, a mission host) asks the network which of them are up — a liveliness query
//! on each pattern it follows — and takes from the answer the changes its liveliness events did
//! not bring. An event can be missed: an inbox that was full dropped it, or a router that lost
//! one link withdrew a token that another link still holds (a robot that moved from its site's
//! router to central, its token declared on the new link before the old one was seen to close,
//! stayed lost for good, for central and for its mission's head alike: `tests/clients.rs` on CI).
//! Nothing else would ever correct it.
//!
//! Tokens are named by their keys (`mrmm/robots/r1/alive`): a missed change is handed back as the
//! key and whether it is up, and the machine translates it with its own ingress into the very
//! event it missed. A token up that the machine holds gone is an appearance at once (an answer
//! lists only tokens declared). A token gone that the machine holds up is a disappearance only
//! when two complete answers in a row miss it (a robot lost has its mission replanned). Neither
//! for a token an event was heard of after the question: that event is newer than the answer.

use std::collections::BTreeSet;

use mrmm_proto::Time;

/// Seconds between two roll calls.
pub const ROLL_CALL_S: f64 = 3.0;
/// Seconds a driver waits for the answers to one liveliness query of a roll call; one that
/// took this long is not complete.
pub const ANSWER_S: f64 = 2.0;
/// A roll call waits until no liveliness event was heard for this long: asked in a storm of
/// them (thousands of tokens declared at once) its answer, as long as the storm, held central's
/// loop up for seconds, and the events will have said most of it anyway.
pub const QUIET_S: f64 = 1.0;
/// A roll call not answered after this long is asked again.
pub const ROLL_CALL_STALE_S: f64 = 30.0;
/// Tokens whose events are remembered between a question and its answer; past this (a flood of
/// tokens) that answer is not acted on.
pub const MAX_TOUCHED: usize = 65_536;
/// Tokens an answer holds at most; past it the answer is cut short (and not complete).
pub const MAX_PRESENT: usize = 32_768;
/// Tokens up that an answer shows and the machine has no record of (not in its `known`), taken
/// per answer at most: a flood of made-up tokens (any fleet certificate can declare them) costs a
/// bounded number of events per roll call, not one per token.
pub const NEW_PER_ANSWER: usize = 16;
/// Missed changes named one by one in the log per answer; the rest are counted.
const LOGGED: usize = 4;

/// The tokens up, as the network answered a roll call: their keys.
#[derive(Debug, Clone, PartialEq)]
pub struct Present {
    pub up: BTreeSet<String>,
    /// Every answer came (none cut off by the deadline or the bound): only then does a token
    /// missing from it count against the machine's view.
    pub complete: bool,
}

impl Default for Present {
    fn default() -> Self {
        Present { up: BTreeSet::new(), complete: true }
    }
}

impl Present {
    /// Takes in the token on `key`; past [`MAX_PRESENT`] the answer is cut short.
    pub fn take(&mut self, key: &str) {
        if self.up.len() >= MAX_PRESENT {
            self.complete = false;
        } else {
            self.up.insert(key.to_string());
        }
    }
}

/// A liveliness change the machine missed: the token's key, and whether it is up.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Missed {
    pub key: String,
    pub up: bool,
}

/// A roll call's state: the question out, the tokens heard of since, the tokens the last
/// complete answer missed.
#[derive(Debug, Clone, Default)]
pub struct RollCall {
    /// When the question out was asked.
    asked: Option<Time>,
    /// When the last one was.
    last: Option<Time>,
    /// Tokens a liveliness event was heard of since the question.
    touched: BTreeSet<String>,
    /// More than [`MAX_TOUCHED`] were.
    flooded: bool,
    /// Tokens up for the machine that the last complete answer missed.
    missing: BTreeSet<String>,
    /// When a liveliness event was last heard.
    heard_at: Option<Time>,
}

impl RollCall {
    /// Whether to ask now: [`ROLL_CALL_S`] after the last question, unless one is out (and not
    /// stale), or a liveliness event was heard within [`QUIET_S`].
    pub fn due(&mut self, now: Time) -> bool {
        let busy = self.heard_at.is_some_and(|t| now - t < QUIET_S);
        if busy || self.asked.is_some_and(|a| now - a < ROLL_CALL_STALE_S) || self.last.is_some_and(|l| now - l < ROLL_CALL_S) {
            return false;
        }
        self.asked = Some(now);
        self.last = Some(now);
        self.touched.clear();
        self.flooded = false;
        true
    }

    /// A liveliness event of the token on `key` was heard at `now`.
    pub fn heard(&mut self, now: Time, key: &str) {
        self.heard_at = Some(now);
        self.missing.remove(key);
        if self.asked.is_none() {
            return;
        }
        if self.touched.len() < MAX_TOUCHED {
            self.touched.insert(key.to_string());
        } else {
            self.flooded = true;
        }
    }

    /// The answer to the question out, against `held`, the keys of the tokens the machine
    /// holds up, and `known`, those it has a record of (a registered robot): the changes it
    /// missed — of known tokens all, of others at most [`NEW_PER_ANSWER`]. An answer with no
    /// question out (a stale one), a failed one, or one after a flood of events is not acted on.
    pub fn answered(&mut self, result: Result<Present, String>, held: &BTreeSet<String>, known: &BTreeSet<String>) -> Vec<Missed> {
        if self.asked.take().is_none() {
            return vec![];
        }
        let present = match result {
            Ok(p) if !self.flooded => p,
            Ok(_) => return vec![],
            Err(e) => {
                tracing::debug!("roll call failed: {e}");
                return vec![];
            }
        };
        let touched = std::mem::take(&mut self.touched);
        let (mut out, mut new, mut skipped) = (Vec::new(), 0, 0usize);
        for k in present.up.difference(held).filter(|k| !touched.contains(*k)) {
            if known.contains(k) || new < NEW_PER_ANSWER {
                new += usize::from(!known.contains(k));
                out.push(Missed { key: k.clone(), up: true });
            } else {
                skipped += 1;
            }
        }
        let ups = out.len();
        if present.complete {
            let missing: BTreeSet<String> = held.difference(&present.up).filter(|k| !touched.contains(*k)).cloned().collect();
            out.extend(missing.intersection(&self.missing).map(|k| Missed { key: k.clone(), up: false }));
            self.missing = missing;
        }
        log(&out[..ups], skipped, "up, whose appearance was never heard");
        log(&out[ups..], 0, "gone twice running, whose disappearance was never heard");
        out
    }
}

/// Says which tokens a roll call found `what` (the first few by name), and how many more were left
/// for later answers.
fn log(missed: &[Missed], skipped: usize, what: &str) {
    if missed.is_empty() && skipped == 0 {
        return;
    }
    let first: Vec<String> = missed.iter().take(LOGGED).map(|m| m.key.chars().take(100).collect()).collect();
    tracing::warn!(tokens = missed.len(), first = ?first, left_for_later = skipped, "roll call: tokens {what}");
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::at;

    fn keys(k: &[&str]) -> BTreeSet<String> {
        k.iter().map(|s| s.to_string()).collect()
    }

    fn present(k: &[&str], complete: bool) -> Result<Present, String> {
        Ok(Present { up: keys(k), complete })
    }

    fn up(k: &str) -> Missed {
        Missed { key: k.into(), up: true }
    }

    #[test]
    fn an_appearance_counts_at_once_a_disappearance_after_two_complete_answers() {
        let mut rc = RollCall::default();
        assert!(rc.due(at(0.0)));
        assert!(!rc.due(at(1.0)), "one question at a time");
        assert_eq!(rc.answered(present(&["a", "b"], true), &keys(&["b", "c"]), &keys(&[])), vec![up("a")]);
        assert!(!rc.due(at(2.0)), "not before its period");
        assert!(rc.due(at(ROLL_CALL_S)));
        assert!(rc.answered(present(&["a", "b"], false), &keys(&["a", "b", "c"]), &keys(&[])).is_empty(), "an answer cut short counts nothing against c");
        assert!(rc.due(at(2.0 * ROLL_CALL_S)));
        assert_eq!(rc.answered(present(&["a", "b"], true), &keys(&["a", "b", "c"]), &keys(&[])), vec![Missed { key: "c".into(), up: false }]);
    }

    #[test]
    fn an_event_after_the_question_wins_and_a_late_answer_is_dropped() {
        let mut rc = RollCall::default();
        assert!(rc.due(at(0.0)));
        rc.heard(at(0.0), "a");
        assert!(rc.answered(present(&["a"], true), &keys(&["c"]), &keys(&[])).is_empty(), "a was heard of after the question; c missed once");
        assert!(rc.due(at(ROLL_CALL_S)));
        rc.heard(at(0.0), "c");
        assert!(rc.answered(present(&[], true), &keys(&["c"]), &keys(&[])).is_empty(), "c was heard of: its first miss no longer counts");
        assert!(rc.answered(present(&["z"], true), &keys(&[]), &keys(&[])).is_empty(), "no question out");
        // A question never answered is asked again once stale.
        rc.heard(at(9.5), "b");
        assert!(!rc.due(at(10.0)), "events still coming: not asked in a storm");
        assert!(rc.due(at(10.5)));
        assert!(!rc.due(at(10.0 + ROLL_CALL_STALE_S - 1.0)));
        assert!(rc.due(at(10.5 + ROLL_CALL_STALE_S)));
    }

    #[test]
    fn a_flood_of_events_or_tokens_is_bounded() {
        let mut rc = RollCall::default();
        assert!(rc.due(at(0.0)));
        for k in 0..=MAX_TOUCHED {
            rc.heard(at(0.0), &format!("t{k}"));
        }
        assert!(rc.answered(present(&["a"], true), &keys(&[]), &keys(&[])).is_empty(), "after a flood the answer is not acted on");
        // 1 000 made-up tokens up: a few taken per answer; a known one always.
        assert!(rc.due(at(ROLL_CALL_S)));
        let made_up: Vec<String> = (0..1_000).map(|k| format!("ghost{k:04}")).collect();
        let mut up: Vec<&str> = made_up.iter().map(String::as_str).collect();
        up.push("zz-known");
        let missed = rc.answered(present(&up, true), &keys(&[]), &keys(&["zz-known"]));
        assert_eq!(missed.len(), NEW_PER_ANSWER + 1);
        assert!(missed.contains(&self::up("zz-known")));
        let mut p = Present::default();
        for k in 0..=MAX_PRESENT {
            p.take(&format!("t{k}"));
        }
        assert_eq!((p.up.len(), p.complete), (MAX_PRESENT, false));
    }
}
