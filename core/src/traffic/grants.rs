//! Grants: which hops a robot may drive next — what each needs, who is in the way of it
//! (holders of resources in conflict, robots against it in a corridor) — and every grant given
//! when something changed, longest-waiting robots first.

use std::collections::BTreeSet;

use mrmm_proto::{RobotId, Time};

use super::layout::Res;
use super::{Command, Robot, Traffic};

impl Traffic {
    /// The resources hop `i` of a route needs (its entry when `i` is 0).
    pub(super) fn hop(&self, route: &[u32], i: usize) -> Hop {
        let v = route[i];
        match i.checked_sub(1).and_then(|p| self.layout.lane(route[p], v)) {
            Some(lane) => Hop { res: [lane, v], len: 2 },
            None => Hop { res: [v, v], len: 1 },
        }
    }

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

    /// The robots other than `id` that hold `x` or a resource in conflict with it.
    fn holders<'a>(&'a self, id: &'a RobotId, x: Res) -> impl Iterator<Item = &'a RobotId> + 'a {
        std::iter::once(x).chain(self.layout.conflicts(x).iter().copied()).filter_map(move |c| self.holder[c as usize].as_ref()).filter(move |h| *h != id)
    }

    /// The robots that hold `res` or a resource in conflict with it, other than `id`.
    pub(super) fn in_the_way(&self, id: &RobotId, res: &[Res]) -> BTreeSet<RobotId> {
        res.iter().flat_map(|&x| self.holders(id, x)).cloned().collect()
    }

    /// What hop `i` of robot `id`'s route needs, whether the robot still holds some of it, the
    /// robots holding what it needs (found as they are asked for: a check stops at the first),
    /// and the lane whose corridor other robots may hold against it. A vertex or lane the robot
    /// comes back to is granted again only once it has let it go (else a robot stepping aside
    /// would never make way). And don't block the box: a robot stops on a junction only where
    /// its route ends, or if it can leave it at once.
    fn hop_and_way<'a>(&'a self, id: &'a RobotId, r: &'a Robot, i: usize) -> (Hop, bool, impl Iterator<Item = &'a RobotId> + 'a, Option<(u32, u32)>) {
        let need = self.hop(&r.route, i);
        let own = need.iter().any(|x| r.held.contains_key(x));
        // The hop out of the box, looked at only if nothing of this hop is held.
        let box_exit = (i + 1 < r.route.len() && self.layout.is_junction(r.route[i])).then_some(i + 1);
        let exit = box_exit.into_iter().flat_map(move |j| self.hop(&r.route, j));
        let holding = need.into_iter().chain(exit).flat_map(move |x| self.holders(id, x));
        let corridor = (self.params.corridors && i >= 1).then(|| (r.route[i - 1], r.route[i]));
        (need, own, holding, corridor)
    }

    /// What hop `i` of robot `id`'s route needs if it can be granted now: [`Self::grantable`]'s
    /// answer without who is in the way (what a look at every waiting robot after each event
    /// needs, without a set of names built for each).
    pub(super) fn free_hop(&self, id: &RobotId, r: &Robot, i: usize) -> Option<Hop> {
        let (need, own, mut holding, corridor) = self.hop_and_way(id, r, i);
        let free = !own && holding.next().is_none() && corridor.is_none_or(|(a, b)| self.against(id, a, b).is_empty());
        free.then_some(need)
    }

    /// What hop `i` of robot `id`'s route needs, if it can be granted now; else the robots in
    /// its way ([`Self::hop_and_way`]).
    pub(super) fn grantable(&self, id: &RobotId, r: &Robot, i: usize) -> Result<Hop, BTreeSet<RobotId>> {
        let (need, own, holding, corridor) = self.hop_and_way(id, r, i);
        let mut by: BTreeSet<RobotId> = holding.cloned().collect();
        if let Some((a, b)) = corridor {
            by.extend(self.against(id, a, b));
        }
        if by.is_empty() && !own {
            Ok(need)
        } else {
            Err(by)
        }
    }

    /// Grants every hop it can, longest-waiting robots first: whether it granted any.
    pub(super) fn grant_all(&mut self, now: Time, out: &mut Vec<Command>) -> bool {
        // Robots iterate in id order and the sort is stable: ties stay in id order.
        let mut order: Vec<(Time, RobotId)> =
            self.robots.iter().filter(|(_, r)| !r.lost && r.wants_more()).map(|(id, r)| (r.waiting.unwrap_or(Time::NEVER), id.clone())).collect();
        order.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut any = false;
        for (_, id) in order {
            let Some(r) = self.robots.get(&id) else { continue };
            let before = r.granted;
            let limit = r.reached.map_or(0, |p| p + self.params.ahead).min(r.route.len() - 1);
            if r.granted.is_some_and(|g| g >= limit) || self.free_hop(&id, r, r.granted.map_or(0, |g| g + 1)).is_none() {
                // Nothing to grant (most robots at most looks): only since when it waits may change.
                let waiting = waiting_since(now, r);
                if waiting != r.waiting {
                    if let Some(r) = self.robots.get_mut(&id) {
                        r.waiting = waiting;
                    }
                }
                continue;
            }
            while let Some(r) = self.robots.get(&id) {
                if r.granted.is_some_and(|g| g >= limit) {
                    break;
                }
                let i = r.granted.map_or(0, |g| g + 1);
                let Some(need) = self.free_hop(&id, r, i) else { break };
                for &res in need.iter() {
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
                any = true;
            }
            r.waiting = waiting_since(now, r);
        }
        any
    }
}

/// Since when robot `r` waits, at `now`: since it first stood waiting (or unrouted) and not
/// granted on, none once it drives.
fn waiting_since(now: Time, r: &Robot) -> Option<Time> {
    if r.stands_waiting() || r.granted.is_none() {
        r.waiting.or(Some(now))
    } else {
        None
    }
}

/// What one hop of a route needs: the lane it drives (where it has one), then the vertex it
/// drives to; no allocation, as every look at every waiting robot takes one or two.
#[derive(Debug, Clone, Copy)]
pub(super) struct Hop {
    res: [Res; 2],
    len: usize,
}

impl std::ops::Deref for Hop {
    type Target = [Res];

    fn deref(&self) -> &[Res] {
        &self.res[..self.len]
    }
}

impl IntoIterator for Hop {
    type Item = Res;
    type IntoIter = std::iter::Take<std::array::IntoIter<Res, 2>>;

    fn into_iter(self) -> Self::IntoIter {
        self.res.into_iter().take(self.len)
    }
}
