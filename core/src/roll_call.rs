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

/// Seconds between two roll calls.
pub const ROLL_CALL_S: f64 = 3.0;
/// Seconds a driver waits for the answers to one liveliness query of a roll call; one that
/// took this long is not complete.
pub const ANSWER_S: f64 = 2.0;
/// A roll call not answered after this long is asked again.
pub const ROLL_CALL_STALE_S: f64 = 30.0;
/// Tokens whose events are remembered between a question and its answer; past this (a flood of
/// tokens) that answer is not acted on.
pub const MAX_TOUCHED: usize = 65_536;
/// Tokens an answer holds at most; past it the answer is cut short (and not complete).
pub const MAX_PRESENT: usize = 32_768;

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
    asked: Option<f64>,
    /// When the last one was.
    last: Option<f64>,
    /// Tokens a liveliness event was heard of since the question.
    touched: BTreeSet<String>,
    /// More than [`MAX_TOUCHED`] were.
    flooded: bool,
    /// Tokens up for the machine that the last complete answer missed.
    missing: BTreeSet<String>,
}

impl RollCall {
    /// Whether to ask now: [`ROLL_CALL_S`] after the last question, unless one is out (and not
    /// stale).
    pub fn due(&mut self, now: f64) -> bool {
        if self.asked.is_some_and(|a| now - a < ROLL_CALL_STALE_S) || self.last.is_some_and(|l| now - l < ROLL_CALL_S) {
            return false;
        }
        self.asked = Some(now);
        self.last = Some(now);
        self.touched.clear();
        self.flooded = false;
        true
    }

    /// A liveliness event of the token on `key` was heard.
    pub fn heard(&mut self, key: &str) {
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
    /// holds up: the changes it missed. An answer with no question out (a stale one), a failed
    /// one, or one after a flood of events is not acted on.
    pub fn answered(&mut self, result: Result<Present, String>, held: &BTreeSet<String>) -> Vec<Missed> {
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
        let mut out: Vec<Missed> = present.up.difference(held).filter(|k| !touched.contains(*k)).map(|k| Missed { key: k.clone(), up: true }).collect();
        if present.complete {
            let missing: BTreeSet<String> = held.difference(&present.up).filter(|k| !touched.contains(*k)).cloned().collect();
            out.extend(missing.intersection(&self.missing).map(|k| Missed { key: k.clone(), up: false }));
            self.missing = missing;
        }
        for m in &out {
            let key: String = m.key.chars().take(200).collect();
            match m.up {
                true => tracing::warn!(token = %key, "roll call: a token is up whose appearance was never heard"),
                false => tracing::warn!(token = %key, "roll call: a token is gone, twice running, whose disappearance was never heard"),
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
        assert!(rc.due(0.0));
        assert!(!rc.due(1.0), "one question at a time");
        assert_eq!(rc.answered(present(&["a", "b"], true), &keys(&["b", "c"])), vec![up("a")]);
        assert!(!rc.due(2.0), "not before its period");
        assert!(rc.due(ROLL_CALL_S));
        assert!(rc.answered(present(&["a", "b"], false), &keys(&["a", "b", "c"])).is_empty(), "an answer cut short counts nothing against c");
        assert!(rc.due(2.0 * ROLL_CALL_S));
        assert_eq!(rc.answered(present(&["a", "b"], true), &keys(&["a", "b", "c"])), vec![Missed { key: "c".into(), up: false }]);
    }

    #[test]
    fn an_event_after_the_question_wins_and_a_late_answer_is_dropped() {
        let mut rc = RollCall::default();
        assert!(rc.due(0.0));
        rc.heard("a");
        assert!(rc.answered(present(&["a"], true), &keys(&["c"])).is_empty(), "a was heard of after the question; c missed once");
        assert!(rc.due(ROLL_CALL_S));
        rc.heard("c");
        assert!(rc.answered(present(&[], true), &keys(&["c"])).is_empty(), "c was heard of: its first miss no longer counts");
        assert!(rc.answered(present(&["z"], true), &keys(&[])).is_empty(), "no question out");
        // A question never answered is asked again once stale.
        assert!(rc.due(10.0));
        assert!(!rc.due(10.0 + ROLL_CALL_STALE_S - 1.0));
        assert!(rc.due(10.0 + ROLL_CALL_STALE_S));
    }

    #[test]
    fn a_flood_of_events_or_tokens_is_bounded() {
        let mut rc = RollCall::default();
        assert!(rc.due(0.0));
        for k in 0..=MAX_TOUCHED {
            rc.heard(&format!("t{k}"));
        }
        assert!(rc.answered(present(&["a"], true), &keys(&[])).is_empty(), "after a flood the answer is not acted on");
        let mut p = Present::default();
        for k in 0..=MAX_PRESENT {
            p.take(&format!("t{k}"));
        }
        assert_eq!((p.up.len(), p.complete), (MAX_PRESENT, false));
    }
}
