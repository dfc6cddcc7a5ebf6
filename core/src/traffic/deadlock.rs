//! Robots waiting for each other: cycles of waits broken by one robot stepping aside, and parked
//! robots making way.

use std::collections::{BTreeMap, BTreeSet};

use mrmm_proto::{RobotId, Time};

use super::{Command, Robot, Traffic, Why, MAX_ROUTE};

/// A robot steps aside at most this many hops: on lanes cut into segments the nearest pocket
/// may be a dozen segments back (4 kept `--segment 2` at 73 % of the blind robots' trips at 4
/// robots with 68 stalls in 400 robot-runs; 12: 83 %, 9 stalls).
const ASIDE_HOPS: usize = 12;
/// How many robots queued behind a cycle of waits are tried for making room, at most.
const BEHIND: usize = 32;
/// Seconds a robot waits outside any cycle of waits before the robots on its way are searched
/// out of it or sent ahead of it ([`Traffic::unstarve`]). Seeds 1 – 100 of every map and size at
/// 1.5 m cuts: stalls 5 → 4 (DIAG_labs, 8 robots, seed 6: a robot at a dead end's mouth waited
/// 300 s while the robots of the corridor it wanted took the junction in turn), trips 258 842 →
/// 258 880; 30 s kept the stall away too, with 19 trips fewer on seeds 1 – 10.
pub(super) const STARVED_S: f64 = 60.0;
/// A step aside a robot made this many times on one way is tried after every other robot's of
/// its cycle (or of the queue behind it).
pub(super) const REPEATS: u32 = 2;

/// Who each robot that stands waiting waits for.
pub(super) type Waits = BTreeMap<RobotId, BTreeSet<RobotId>>;

impl Traffic {
    /// Who each robot that stands waiting waits for: a function of holdings and routes alone.
    pub(super) fn waits(&self) -> Waits {
        let mut waits = BTreeMap::new();
        for (id, r) in &self.robots {
            if r.lost || !(r.stands_waiting() || (r.granted.is_none() && !r.route.is_empty())) {
                continue;
            }
            let i = r.granted.map_or(0, |g| g + 1);
            let by = self.grantable(id, r, i).err().unwrap_or_default();
            if !by.is_empty() {
                waits.insert(id.clone(), by);
            }
        }
        waits
    }

    /// Breaks one cycle of `waits` (what [`Self::waits`] says now), or makes a parked robot give
    /// way: whether a route changed.
    pub(super) fn resolve(&mut self, now: Time, waits: &Waits, out: &mut Vec<Command>) -> bool {
        if let Some(cycle) = find_cycle(waits) {
            let avoid = self.ahead_of(cycle.iter());
            let by_cost = self.cheapest_aside_first(&cycle, &avoid);
            // If none of the cycle can, one that waits for them, or for one of those, may make
            // room behind them. Steps aside made often on this way come last: two cycles can
            // undo each other's steps (a robot sent into a pocket and out again, for good).
            let queued = behind(waits, &cycle);
            for group in [&by_cost, &queued] {
                for fresh in [true, false] {
                    for m in group {
                        if self.step_aside(m, &avoid, Why::Deadlock, fresh, out) {
                            return true;
                        }
                    }
                }
            }
            // None can step aside: the oldest pushes the ones in its way back, and they the ones
            // behind them.
            let stuck: Vec<RobotId> = cycle.iter().chain(&queued).cloned().collect();
            if self.push_through(&stuck, waits, out) {
                return true;
            }
            // Then, if it has waited a while, a search for places that clear its way, or (a
            // way longer than a search reaches) the robots on it sent ahead to places off it:
            // else another's way (the oldest may be the one going into a dead end).
            let oldest = self.oldest_waiting(now, &stuck);
            if oldest.iter().any(|p| self.search_through(p, out)) || oldest.iter().any(|p| self.clear_through(p, out)) {
                return true;
            }
            for m in &cycle {
                let by = waits.get(m).cloned().unwrap_or_default();
                self.report_blocked(m, by, out);
            }
            return false;
        }
        for (id, by) in waits {
            let long = self.robots.get(id).and_then(|r| r.waiting).is_some_and(|since| now - since >= self.params.yield_after);
            if !long {
                continue;
            }
            let mut stuck = BTreeSet::new();
            for b in by {
                let Some(rb) = self.robots.get(b) else { continue };
                if rb.stands_waiting() || (!rb.lost && !rb.parked()) {
                    continue; // it moves, or waits itself: not in the way for good
                }
                // A robot docked at a charger does not leave it: others go round it, or wait.
                if !rb.lost && !rb.docked && self.step_aside(b, &self.ahead_of([id].into_iter()), Why::Yield, false, out) {
                    return true;
                }
                stuck.insert(b.clone());
            }
            if !stuck.is_empty() {
                self.report_blocked(id, stuck, out);
            }
        }
        self.unstarve(now, waits, out)
    }

    /// The robot that has waited longest, if that is [`STARVED_S`], outside any cycle (robots
    /// of a busy corridor take the vertex it needs in turn, for good): the robots on its way are
    /// searched out of it or sent ahead of it. One robot a look: a search or clearing that found
    /// nothing is not made again while the same robots stand where they stood, and that memory
    /// holds one.
    fn unstarve(&mut self, now: Time, waits: &Waits, out: &mut Vec<Command>) -> bool {
        let longest = self
            .robots
            .iter()
            .filter_map(|(id, r)| r.waiting.filter(|since| now - *since >= STARVED_S).map(|since| (since, id)))
            .filter(|(_, id)| waits.contains_key(*id))
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .map(|(_, id)| id.clone());
        longest.is_some_and(|id| self.search_through(&id, out) || self.clear_through(&id, out))
    }

    /// The robots of `cycle`, the one with the shortest step aside off `avoid` first (metres;
    /// ties: the one that asked for its way last): on a tree of corridors the one that asked last
    /// was often the one deep in a dead end, sent deeper past the other's goal and out again
    /// (seeds 11 – 40, all maps and sizes: trips +1.7 %; ctcv at 4 robots 57 → 60 % of the blind
    /// robots', DIAG_floor1 at 8 66 → 70 %).
    fn cheapest_aside_first(&self, cycle: &[RobotId], avoid: &BTreeSet<u32>) -> Vec<RobotId> {
        let mut by_cost: Vec<(f64, Time, RobotId)> = cycle
            .iter()
            .map(|id| {
                let r = self.robots.get(id);
                let path = r.and_then(|r| r.standing()).and_then(|v| self.aside(id, v, avoid));
                let metres = path.map_or(f64::INFINITY, |p| p.windows(2).map(|w| self.layout.point(w[0]).dist(self.layout.point(w[1]))).sum());
                (metres, r.map_or(Time::NEVER, |r| r.asked), id.clone())
            })
            .collect();
        by_cost.sort_by(|a, b| a.0.total_cmp(&b.0).then_with(|| b.1.total_cmp(&a.1)).then_with(|| b.2.cmp(&a.2)));
        by_cost.into_iter().map(|(_, _, id)| id).collect()
    }

    /// The rest of these robots' routes, from where each stands: a robot stepping aside to a
    /// place only a few vertices off a long way (six, once) stood in it again a few seconds
    /// later (seeds 11 – 40, all maps and sizes: trips +1.2 %; ctcv at 2 robots 60 → 81 % of the
    /// blind robots').
    fn ahead_of<'a>(&self, ids: impl Iterator<Item = &'a RobotId>) -> BTreeSet<u32> {
        let mut avoid = BTreeSet::new();
        for id in ids {
            if let Some(r) = self.robots.get(id) {
                avoid.extend(&r.route[r.reached.unwrap_or(0).min(r.route.len())..]);
            }
        }
        avoid
    }

    /// Sends a standing robot to the nearest vertex not in `avoid` it can reach over free
    /// lanes and vertices (at most [`ASIDE_HOPS`] hops, each of which it can drive back), then
    /// back the same way and on its route; only a step it made fewer than [`REPEATS`] times on
    /// this way, if `fresh`.
    fn step_aside(&mut self, id: &RobotId, avoid: &BTreeSet<u32>, why: Why, fresh: bool, out: &mut Vec<Command>) -> bool {
        let Some(r) = self.robots.get(id) else { return false };
        let Some(v) = r.standing() else { return false };
        let Some(path) = self.aside(id, v, avoid) else { return false };
        let step = (path[0], path[1]);
        let made = r.asides.get(&step).copied().unwrap_or(0);
        if fresh && made >= REPEATS {
            return false;
        }
        // Only a step it can take at once: a robot that stayed where it is would be sent aside
        // again at the next event, its route longer each time.
        match self.diverted(id, &path, true) {
            Some(mut moved) if self.changes_way(id, &moved) => {
                if why == Why::Deadlock {
                    moved.asides.insert(step, made + 1);
                }
                self.divert(id, moved, why, out);
                true
            }
            _ => false,
        }
    }

    /// The robot standing at `path[0]`, sent along `path`, then back the same way and on its
    /// route; none if the route would be too long or (`at_once`) its first hop cannot be granted
    /// now.
    pub(super) fn diverted(&self, id: &RobotId, path: &[u32], at_once: bool) -> Option<Robot> {
        let r = self.robots.get(id)?;
        let g = r.granted?;
        // Back along the way it stepped aside by, as far as where its route goes on from.
        let rest = &r.route[g + 1..];
        let back_to = rest.first().and_then(|next| path.iter().position(|p| p == next)).map_or(0, |k| k);
        let skip_next = usize::from(rest.first().is_some_and(|next| path[back_to] == *next));
        let mut route = r.route[..=g].to_vec();
        route.extend(&path[1..]);
        route.extend(path[back_to..path.len() - 1].iter().rev());
        route.extend(&rest[skip_next..]);
        let moved = rerouted(r, &route)?;
        if at_once && self.free_hop(id, &moved, moved.granted? + 1).is_none() {
            return None;
        }
        Some(moved)
    }

    /// Whether robot `id`, `moved`, drives another way than it drove: one moved only along its
    /// own route is told nothing, and a look that took it for a change looked again at once,
    /// for good (DIAG_floor1, 12 robots, seed 18: a search's plan moved two robots on along their
    /// own routes onto a junction neither could be granted, at every tick).
    pub(super) fn changes_way(&self, id: &RobotId, moved: &Robot) -> bool {
        self.robots.get(id).is_none_or(|r| r.route.get(r.reached.unwrap_or(0)..) != Some(moved.route.as_slice()))
    }

    /// Gives the robot its new route and tells it.
    pub(super) fn divert(&mut self, id: &RobotId, mut r: Robot, why: Why, out: &mut Vec<Command>) {
        self.robots.remove(id);
        self.announce(id, &mut r, why, out);
        self.robots.insert(id.clone(), r);
    }

    /// Breadth-first over free two-way lanes from `v`: the path to the first vertex neither in
    /// `avoid` nor in conflict with one in it (nearest in hops, then in metres).
    fn aside(&self, id: &RobotId, v: u32, avoid: &BTreeSet<u32>) -> Option<Vec<u32>> {
        let mut parent: BTreeMap<u32, u32> = BTreeMap::new();
        let mut frontier = vec![v];
        for _ in 0..ASIDE_HOPS {
            let mut next = Vec::new();
            for &x in &frontier {
                let mut out: Vec<u32> = self.layout.next(x).to_vec();
                let here = self.layout.point(x);
                out.sort_by(|a, b| here.dist(self.layout.point(*a)).total_cmp(&here.dist(self.layout.point(*b))));
                for w in out {
                    if w == v || parent.contains_key(&w) || !self.layout.is_edge(w, x) {
                        continue;
                    }
                    let need: Vec<_> = self.layout.lane(x, w).into_iter().chain([w]).collect();
                    if !self.in_the_way(id, &need).is_empty() {
                        continue;
                    }
                    parent.insert(w, x);
                    // Off the way, and not beside it either (two lanes of a map drawn one over
                    // the other: a step to the other's vertex was no step aside).
                    if !avoid.contains(&w) && !self.layout.conflicts(w).iter().any(|c| avoid.contains(c)) {
                        let mut path = vec![w];
                        while let Some(&p) = parent.get(path.last().unwrap_or(&v)) {
                            path.push(p);
                            if p == v {
                                break;
                            }
                        }
                        path.reverse();
                        return Some(path);
                    }
                    next.push(w);
                }
            }
            frontier = next;
        }
        None
    }

    fn report_blocked(&mut self, id: &RobotId, by: BTreeSet<RobotId>, out: &mut Vec<Command>) {
        let Some(r) = self.robots.get_mut(id) else { return };
        let by: Vec<RobotId> = by.into_iter().collect();
        if r.blocked != by {
            r.blocked.clone_from(&by);
            out.push(Command::Blocked { robot: id.clone(), by });
        }
    }
}

/// Robot `r` on `route` (its own up to the position it was granted, then where traffic sends
/// it), without what it drove before the vertex it last reached; none if too long.
pub(super) fn rerouted(r: &Robot, route: &[u32]) -> Option<Robot> {
    let (b, g) = (r.reached.unwrap_or(0), r.granted?);
    let moved = Robot { route: route[b..].to_vec(), reached: r.reached.map(|p| p - b), granted: Some(g - b), ..r.clone() };
    (moved.route.len() <= MAX_ROUTE).then_some(moved)
}

/// The robots that wait for a member of `cycle`, directly or through others that do (at most
/// [`BEHIND`]), the farthest first: in a queue behind a robot of the cycle, the last one is the
/// one free to make room, and then the one before it (only the nearest ones were tried before:
/// a queue in one of DIAG's corridors stalled its robots for good).
fn behind(waits: &Waits, cycle: &[RobotId]) -> Vec<RobotId> {
    let mut queue: Vec<RobotId> = Vec::new();
    let mut grew = true;
    while grew {
        grew = false;
        for (w, by) in waits {
            if queue.len() < BEHIND && !cycle.contains(w) && !queue.contains(w) && by.iter().any(|b| cycle.contains(b) || queue.contains(b)) {
                queue.push(w.clone());
                grew = true;
            }
        }
    }
    queue.reverse();
    queue
}

/// A cycle of waits (each member waits for the next), the first found in id order: a
/// depth-first search over the robots by index, successors tried in id order.
fn find_cycle(waits: &Waits) -> Option<Vec<RobotId>> {
    const NEW: u8 = 0;
    const OPEN: u8 = 1;
    const DONE: u8 = 2;
    let keys: Vec<&RobotId> = waits.keys().collect();
    let index = |id: &RobotId| keys.binary_search(&id).ok();
    // Each robot's successors that wait themselves, last first (popped in id order).
    let succ: Vec<Vec<usize>> = waits.values().map(|by| by.iter().filter_map(index).rev().collect()).collect();
    let mut mark = vec![NEW; keys.len()];
    for start in 0..keys.len() {
        if mark[start] != NEW {
            continue;
        }
        let mut path = vec![start];
        let mut stack: Vec<Vec<usize>> = vec![succ[start].clone()];
        mark[start] = OPEN;
        while let Some(next) = stack.last_mut() {
            match next.pop() {
                Some(n) => match mark[n] {
                    OPEN => {
                        let at = path.iter().position(|&p| p == n).unwrap_or(0);
                        return Some(path[at..].iter().map(|&p| keys[p].clone()).collect());
                    }
                    DONE => {}
                    _ => {
                        mark[n] = OPEN;
                        path.push(n);
                        stack.push(succ[n].clone());
                    }
                },
                None => {
                    stack.pop();
                    if let Some(done) = path.pop() {
                        mark[done] = DONE;
                    }
                }
            }
        }
    }
    None
}
