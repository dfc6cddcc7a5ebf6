//! Grants: which hops a robot may drive next — what each needs, who is in the way of it
//! (holders of resources in conflict, robots against it in a corridor) — and every grant given
//! when something changed, longest-waiting robots first.

use std::collections::BTreeSet;

use mrmm_proto::{RobotId, Time};

use super::layout::Res;
use super::{Command, Robot, Traffic};

impl Traffic {
    /// The robots other than `id` ahead of it in the corridor of the lane `a` → `b` that do not
    /// drive it the same way: one driving the other way, or standing in it (parked, or about to
    /// leave it either way). Robots behind it going the other way drive apart: not in its way.
    pub(super) fn against(&self, id: &RobotId, a: u32, b: u32) -> BTreeSet<RobotId> {
        let mut by = BTreeSet::new();
        let Some((c, forward)) = self.layout.corridor(a, b) else { return by };
        let along = self.layout.corridor_resources(c);
        let Some(me) = self.layout.lane(a, b).and_then(|l| along.iter().position(|&r| r == l)) else { return by };
        let ahead: &[Res] = if forward { &along[me + 1..] } else { &along[..me] };
        for &res in ahead {
            let Some(h) = self.holder(res).filter(|h| *h != id) else { continue };
            if by.contains(h) {
                continue;
            }
            let Some(other) = self.robots.get(h) else { continue };
            // Its way through the corridor: the next hop of its route in it from where it is.
            let from = other.reached.unwrap_or(0);
            let way = other.route.windows(2).skip(from).find_map(|w| self.layout.corridor(w[0], w[1]).filter(|&(oc, _)| oc == c)).map(|(_, f)| f);
            if way != Some(forward) {
                by.insert(h.clone());
            }
        }
        by
    }

    /// The robots that hold `res` or a resource in conflict with it, other than `id`.
    pub(super) fn in_the_way(&self, id: &RobotId, res: &[Res]) -> BTreeSet<RobotId> {
        let mut by = BTreeSet::new();
        for &r in res {
            for &c in std::iter::once(&r).chain(self.layout.conflicts(r)) {
                if let Some(h) = &self.holder[c as usize] {
                    if h != id {
                        by.insert(h.clone());
                    }
                }
            }
        }
        by
    }

    /// What hop `i` of robot `id`'s route needs, if it can be granted now; else the robots in
    /// its way. A vertex or lane the robot comes back to is granted again only once it has let
    /// it go (else a robot stepping aside would never make way). And don't block the box: a
    /// robot stops on a junction only where its route ends, or if it can leave it at once.
    pub(super) fn grantable(&self, id: &RobotId, r: &Robot, i: usize) -> Result<Vec<Res>, BTreeSet<RobotId>> {
        let need = self.hop(&r.route, i);
        let mut by = self.in_the_way(id, &need);
        let own = need.iter().any(|x| r.held.contains_key(x));
        if i + 1 < r.route.len() && self.layout.is_junction(r.route[i]) {
            by.extend(self.in_the_way(id, &self.hop(&r.route, i + 1)));
        }
        if self.params.corridors && i >= 1 {
            by.extend(self.against(id, r.route[i - 1], r.route[i]));
        }
        if by.is_empty() && !own {
            Ok(need)
        } else {
            Err(by)
        }
    }

    /// Grants every hop it can, longest-waiting robots first.
    pub(super) fn grant_all(&mut self, now: Time, out: &mut Vec<Command>) {
        let mut order: Vec<(Time, RobotId)> =
            self.robots.iter().filter(|(_, r)| !r.lost && r.wants_more()).map(|(id, r)| (r.waiting.unwrap_or(Time::NEVER), id.clone())).collect();
        order.sort_by(|a, b| a.0.total_cmp(&b.0).then_with(|| a.1.cmp(&b.1)));
        for (_, id) in order {
            let Some(r) = self.robots.get(&id) else { continue };
            let before = r.granted;
            let limit = r.reached.map_or(0, |p| p + self.params.ahead).min(r.route.len() - 1);
            while let Some(r) = self.robots.get(&id) {
                if r.granted.is_some_and(|g| g >= limit) {
                    break;
                }
                let i = r.granted.map_or(0, |g| g + 1);
                let Ok(need) = self.grantable(&id, r, i) else { break };
                for &res in &need {
                    self.holder[res as usize] = Some(id.clone());
                }
                let Some(r) = self.robots.get_mut(&id) else { break };
                for res in need {
                    *r.held.entry(res).or_insert(0) += 1;
                }
                r.granted = Some(i);
            }
            let Some(r) = self.robots.get_mut(&id) else { continue };
            if r.granted != before {
                let g = r.granted.unwrap_or(0);
                out.push(Command::Grant { robot: id.clone(), version: r.version, upto: g, vertex: r.route[g] });
                r.blocked.clear();
            }
            r.waiting = if r.stands_waiting() || r.granted.is_none() { r.waiting.or(Some(now)) } else { None };
        }
    }
}
