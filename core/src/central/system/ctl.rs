//! Steering mission hosts reliably: every [`MissionCtl`] is sent until the mission's head
//! acknowledges it (it acknowledges once its chain committed the change), one at a time per
//! mission, in order for each robot; a control may wait for another to be acknowledged first (a robot joins its new
//! mission only once its old one let it go, so it is never in two teams). Pure bookkeeping.

use std::collections::{BTreeMap, VecDeque};

use mrmm_proto::{MissionCtl, MissionName, Time};

use crate::Failure;

/// Seconds before a control nobody answered is sent again.
pub const CTL_RETRY_S: f64 = 1.0;
/// A control nobody answered for this long is given up (its mission has no reachable head).
pub const CTL_GIVE_UP_S: f64 = 60.0;

#[derive(Debug, Clone)]
struct Pending {
    id: u64,
    ctl: MissionCtl,
    /// Sent only once these controls are done.
    after: Vec<u64>,
    in_flight: bool,
    /// First sent at.
    first: Option<Time>,
    /// Not sent again before.
    retry_at: Time,
}

/// Controls waiting to be acknowledged, per mission.
#[derive(Debug, Clone, Default)]
pub struct Ctls {
    next: u64,
    queues: BTreeMap<MissionName, VecDeque<Pending>>,
}

impl Ctls {
    /// Queues `ctl` for `mission`, after the controls `after`; returns its id.
    pub fn push(&mut self, mission: &str, ctl: MissionCtl, after: Vec<u64>) -> u64 {
        let id = self.next;
        self.next += 1;
        self.queues.entry(MissionName::from(mission)).or_default().push_back(Pending {
            id,
            ctl,
            after,
            in_flight: false,
            first: None,
            retry_at: Time::LONG_AGO,
        });
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

    /// The controls to send now: per mission, the first of its queue that is not waiting for
    /// another control and concerns no robot of a waiting one before it (a control waiting for
    /// another mission does not hold up the controls of other robots behind it), if none is in
    /// flight and it is due.
    pub fn due(&mut self, now: Time) -> Vec<(u64, MissionName, MissionCtl)> {
        let pending: std::collections::BTreeSet<u64> = self.queues.values().flatten().map(|p| p.id).collect();
        let mut out = Vec::new();
        for (mission, q) in self.queues.iter_mut() {
            if q.iter().any(|p| p.in_flight) {
                continue;
            }
            let mut held: Vec<&str> = Vec::new();
            let mut pick = None;
            for (i, p) in q.iter().enumerate() {
                let robots = robots(&p.ctl);
                let clear = match &robots {
                    Some(r) => r.iter().all(|id| !held.contains(id)),
                    None => held.is_empty(),
                };
                if p.after.iter().any(|a| pending.contains(a)) || !clear {
                    match robots {
                        Some(r) => held.extend(r),
                        // A terminate holds up everything after it.
                        None => break,
                    }
                    continue;
                }
                pick = Some(i);
                break;
            }
            let Some(p) = pick.and_then(|i| q.get_mut(i)) else { continue };
            if p.retry_at > now {
                continue;
            }
            p.in_flight = true;
            p.first.get_or_insert(now);
            out.push((p.id, mission.clone(), p.ctl.clone()));
        }
        out
    }

    /// The answer to control `id`: done (acknowledged, or refused for good), or to be sent again.
    pub fn done(&mut self, now: Time, id: u64, result: Result<(), Failure>) {
        let Some((mission, q)) = self.queues.iter_mut().find(|(_, q)| q.iter().any(|p| p.id == id)) else { return };
        let mission = mission.clone();
        let Some(at) = q.iter().position(|p| p.id == id) else { return };
        match result {
            Ok(()) => {
                q.remove(at);
            }
            Err(f) => {
                let Some(p) = q.get_mut(at) else { return };
                let given_up = p.first.is_some_and(|t| now - t >= CTL_GIVE_UP_S);
                if !f.retryable || given_up {
                    tracing::warn!(%mission, ctl = ?p.ctl, "mission control given up: {}", f.error);
                    q.remove(at);
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

    /// Forgets every control of `mission`; returns their ids.
    pub fn cancel_ids(&mut self, mission: &str) -> Vec<u64> {
        self.queues.remove(mission).map(|q| q.iter().map(|p| p.id).collect()).unwrap_or_default()
    }

    /// Makes the controls that wait for one of `gone` wait for control `instead`.
    pub fn wait_instead(&mut self, gone: &[u64], instead: u64) {
        for p in self.queues.values_mut().flatten() {
            if p.after.iter().any(|a| gone.contains(a)) {
                p.after.retain(|a| !gone.contains(a));
                p.after.push(instead);
            }
        }
    }
}

/// The robots a control concerns; `None`: the whole mission.
fn robots(ctl: &MissionCtl) -> Option<Vec<&str>> {
    match ctl {
        MissionCtl::Joined { member } => Some(vec![member.spec.id.as_str()]),
        MissionCtl::Left { ids } => Some(ids.iter().map(|id| id.as_str()).collect()),
        MissionCtl::Replaced { out, member } => Some(vec![out.as_str(), member.spec.id.as_str()]),
        MissionCtl::Terminate => None,
        // A change of the mission itself: no robot's controls wait for it, nor it for theirs.
        MissionCtl::Update { .. } => Some(vec![]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::at;

    fn left(id: &str) -> MissionCtl {
        MissionCtl::Left { ids: vec![id.into()] }
    }
    fn no_answer() -> Result<(), Failure> {
        Err(Failure::retry("no answer"))
    }

    #[test]
    fn one_at_a_time_per_mission_retried_until_acknowledged() {
        let mut c = Ctls::default();
        let a = c.push("m", left("r1"), vec![]);
        let b = c.push("m", left("r2"), vec![]);
        assert_eq!(c.due(at(0.0)), vec![(a, "m".into(), left("r1"))]);
        assert!(c.due(at(0.1)).is_empty(), "in flight");
        c.done(at(2.0), a, no_answer());
        assert!(c.due(at(2.5)).is_empty(), "not before the retry delay");
        assert_eq!(c.due(at(3.0)).len(), 1);
        c.done(at(3.1), a, Ok(()));
        assert_eq!(c.due(at(3.1)), vec![(b, "m".into(), left("r2"))]);
        c.done(at(3.2), b, Err(Failure::fatal("refused")));
        assert!(c.due(at(10.0)).is_empty());
    }

    #[test]
    fn a_join_waits_for_the_leave_it_depends_on_and_controls_are_given_up() {
        let mut c = Ctls::default();
        let l = c.push("m1", left("r1"), vec![]);
        let j = c.push("m2", MissionCtl::Terminate, vec![l]);
        assert_eq!(c.due(at(0.0)).iter().map(|d| d.0).collect::<Vec<_>>(), [l]);
        c.done(at(1.0), l, no_answer());
        assert!(c.due(at(2.0)).iter().all(|d| d.0 == l), "m2 still waits");
        c.done(at(61.0), l, no_answer());
        assert_eq!(c.due(at(61.0)).iter().map(|d| d.0).collect::<Vec<_>>(), [j], "given up after a minute");
        c.cancel("m2");
        assert!(c.due(at(70.0)).is_empty());
    }

    #[test]
    fn a_control_waiting_for_another_mission_holds_up_only_its_robots() {
        let mut c = Ctls::default();
        let x = c.push("other", left("r1"), vec![]);
        let a = c.push("m", left("r1"), vec![x]);
        let b = c.push("m", left("r1"), vec![]);
        let d = c.push("m", left("r2"), vec![]);
        let due = |c: &mut Ctls, now| c.due(now).iter().map(|d| d.0).collect::<Vec<_>>();
        assert_eq!(due(&mut c, at(0.0)), [d, x], "r2's control goes past r1's waiting ones");
        c.done(at(0.1), d, Ok(()));
        assert!(due(&mut c, at(0.2)).is_empty(), "b stays behind a (same robot)");
        // The other mission is gone; its end (answered at once here) stands in for its control.
        let gone = c.cancel_ids("other");
        let end = c.push("other", MissionCtl::Terminate, vec![]);
        c.wait_instead(&gone, end);
        assert_eq!(due(&mut c, at(0.3)), [end]);
        c.done(at(0.4), end, Ok(()));
        assert_eq!(due(&mut c, at(0.5)), [a]);
        c.done(at(0.6), a, Ok(()));
        assert_eq!(due(&mut c, at(0.7)), [b]);
    }
}
