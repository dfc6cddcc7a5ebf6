//! Steering mission hosts reliably: every [`MissionCtl`] is sent until the mission's head
//! acknowledges it (it acknowledges once its chain committed the change), in order per mission,
//! one at a time; a control may wait for another to be acknowledged first (a robot joins its new
//! mission only once its old one let it go, so it is never in two teams). Pure bookkeeping.

use std::collections::{BTreeMap, VecDeque};

use mrmm_proto::MissionCtl;

use crate::Failure;

/// Seconds before a control nobody answered is sent again.
pub const CTL_RETRY_S: f64 = 1.0;
/// A control nobody answered for this long is given up (its mission has no reachable head).
pub const CTL_GIVE_UP_S: f64 = 60.0;

#[derive(Debug, Clone)]
struct Pending {
    id: u64,
    ctl: MissionCtl,
    /// Sent only once this control is done.
    after: Option<u64>,
    in_flight: bool,
    /// First sent at.
    first: Option<f64>,
    /// Not sent again before.
    retry_at: f64,
}

/// Controls waiting to be acknowledged, per mission.
#[derive(Debug, Clone, Default)]
pub struct Ctls {
    next: u64,
    queues: BTreeMap<String, VecDeque<Pending>>,
}

impl Ctls {
    /// Queues `ctl` for `mission`, after control `after` if given; returns its id.
    pub fn push(&mut self, mission: &str, ctl: MissionCtl, after: Option<u64>) -> u64 {
        let id = self.next;
        self.next += 1;
        self.queues.entry(mission.to_string()).or_default().push_back(Pending { id, ctl, after, in_flight: false, first: None, retry_at: f64::NEG_INFINITY });
        id
    }

    /// Whether control `id` is still waiting to be acknowledged.
    pub fn is_pending(&self, id: u64) -> bool {
        self.queues.values().flatten().any(|p| p.id == id)
    }

    /// Whether a control like `pred` is waiting for `mission`.
    pub fn has(&self, mission: &str, pred: impl Fn(&MissionCtl) -> bool) -> bool {
        self.queues.get(mission).is_some_and(|q| q.iter().any(|p| pred(&p.ctl)))
    }

    /// The controls to send now: the first of each mission's queue, if not in flight, not
    /// waiting for another, and due.
    pub fn due(&mut self, now: f64) -> Vec<(u64, String, MissionCtl)> {
        let waiting: Vec<(String, u64)> = self.queues.iter().filter_map(|(m, q)| q.front().and_then(|p| p.after).map(|a| (m.clone(), a))).collect();
        let blocked: Vec<String> = waiting.into_iter().filter(|(_, a)| self.is_pending(*a)).map(|(m, _)| m).collect();
        let mut out = Vec::new();
        for (mission, q) in self.queues.iter_mut() {
            let Some(p) = q.front_mut() else { continue };
            if p.in_flight || p.retry_at > now || blocked.contains(mission) {
                continue;
            }
            p.in_flight = true;
            p.first.get_or_insert(now);
            out.push((p.id, mission.clone(), p.ctl.clone()));
        }
        out
    }

    /// The answer to control `id`: done (acknowledged, or refused for good), or to be sent again.
    pub fn done(&mut self, now: f64, id: u64, result: Result<(), Failure>) {
        let Some((mission, q)) = self.queues.iter_mut().find(|(_, q)| q.front().is_some_and(|p| p.id == id)) else { return };
        let mission = mission.clone();
        match result {
            Ok(()) => {
                q.pop_front();
            }
            Err(f) => {
                let Some(p) = q.front_mut() else { return };
                let given_up = p.first.is_some_and(|t| now - t >= CTL_GIVE_UP_S);
                if !f.retryable || given_up {
                    tracing::warn!(%mission, ctl = ?p.ctl, "mission control given up: {}", f.error);
                    q.pop_front();
                } else {
                    tracing::debug!(%mission, "mission control not answered ({}); again in {CTL_RETRY_S} s", f.error);
                    p.in_flight = false;
                    p.retry_at = now + CTL_RETRY_S;
                }
            }
        }
        if q.is_empty() {
            self.queues.remove(&mission);
        }
    }

    /// Forgets every control of `mission` (it is gone).
    pub fn cancel(&mut self, mission: &str) {
        self.queues.remove(mission);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn left(id: &str) -> MissionCtl {
        MissionCtl::Left { ids: vec![id.into()] }
    }
    fn no_answer() -> Result<(), Failure> {
        Err(Failure { retryable: true, error: "no answer".into() })
    }

    #[test]
    fn one_at_a_time_per_mission_retried_until_acknowledged() {
        let mut c = Ctls::default();
        let a = c.push("m", left("r1"), None);
        let b = c.push("m", left("r2"), None);
        assert_eq!(c.due(0.0), vec![(a, "m".into(), left("r1"))]);
        assert!(c.due(0.1).is_empty(), "in flight");
        c.done(2.0, a, no_answer());
        assert!(c.due(2.5).is_empty(), "not before the retry delay");
        assert_eq!(c.due(3.0).len(), 1);
        c.done(3.1, a, Ok(()));
        assert_eq!(c.due(3.1), vec![(b, "m".into(), left("r2"))]);
        c.done(3.2, b, Err(Failure { retryable: false, error: "refused".into() }));
        assert!(c.due(10.0).is_empty());
    }

    #[test]
    fn a_join_waits_for_the_leave_it_depends_on_and_controls_are_given_up() {
        let mut c = Ctls::default();
        let l = c.push("m1", left("r1"), None);
        let j = c.push("m2", MissionCtl::Terminate, Some(l));
        assert_eq!(c.due(0.0).iter().map(|d| d.0).collect::<Vec<_>>(), [l]);
        c.done(1.0, l, no_answer());
        assert!(c.due(2.0).iter().all(|d| d.0 == l), "m2 still waits");
        c.done(61.0, l, no_answer());
        assert_eq!(c.due(61.0).iter().map(|d| d.0).collect::<Vec<_>>(), [j], "given up after a minute");
        c.cancel("m2");
        assert!(c.due(70.0).is_empty());
    }
}
