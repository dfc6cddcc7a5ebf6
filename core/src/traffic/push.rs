//! Gridlocks no robot can step out of: the robot of a cycle of waits that asked for its way
//! first pushes the robots in its way back one hop, and each of them the robot in its own way
//! (priority inheritance, as in PIBT: Okumura et al., *Artificial Intelligence* 2022), so that
//! a queue in a corridor backs off as a train until it reaches a branch.

use std::collections::{BTreeMap, BTreeSet};

use mrmm_proto::{RobotId, Time};

use super::{Command, Robot, Traffic, Why};

/// How many robots one push moves, at most (a queue backs off this many at once).
const DEPTH: usize = 24;
/// How many vertices a push looks at, at most (bounds the work of one look).
const BUDGET: usize = 512;

/// A push being planned: who moves from where to where, the vertices taken, the work left.
struct Plan {
    /// Who moves from where to where, and whether the hop is free now (the end of a chain).
    moves: Vec<(RobotId, u32, u32, bool)>,
    taken: Vec<u32>,
    budget: usize,
}

impl Traffic {
    /// Makes the robots in the way of the oldest of `stuck` (a cycle of waits and the robots
    /// queued behind it) back off one hop each, pushing the ones behind them: whether any route
    /// changed.
    pub(super) fn push_through(&mut self, stuck: &[RobotId], waits: &BTreeMap<RobotId, BTreeSet<RobotId>>, out: &mut Vec<Command>) -> bool {
        let asked = |id: &RobotId| self.robots.get(id).map_or(Time::NEVER, |r| r.asked);
        let Some(p) = stuck.iter().min_by(|a, b| asked(a).total_cmp(&asked(b)).then_with(|| a.cmp(b))) else { return false };
        let Some(pr) = self.robots.get(p) else { return false };
        let Some(vp) = pr.standing() else { return false };
        // The pusher's way ahead: the robots pushed go off it where they can.
        let from = pr.reached.unwrap_or(0);
        let way: Vec<u32> = pr.route.iter().skip(from).take(8).copied().collect();
        // Every robot in its way (two, where it must not stop on a junction) backs off together,
        // none onto the vertex the pusher stands at (keeping them off its next hops too stalled
        // more: docs/traffic.md).
        let mut plan = Plan { moves: Vec::new(), taken: vec![vp], budget: BUDGET };
        for b in waits.get(p).into_iter().flatten() {
            if !self.push(b, vp, &way, DEPTH, &mut plan) {
                return false;
            }
        }
        self.apply(&plan, out)
    }

    /// Plans moving robot `id` one hop off its vertex, not back to `pusher` (where the robot
    /// pushing it stands), pushing the robot in the way of that hop in turn.
    fn push(&self, id: &RobotId, pusher: u32, way: &[u32], depth: usize, plan: &mut Plan) -> bool {
        let Some(r) = self.robots.get(id) else { return false };
        if r.lost || r.docked || plan.moves.iter().any(|(m, ..)| m == id) {
            return false;
        }
        let Some(v) = r.standing() else { return false };
        let here = self.layout.point(v);
        let mut to: Vec<u32> = self.layout.next(v).iter().copied().filter(|&w| w != pusher && self.layout.is_edge(w, v) && !plan.taken.contains(&w)).collect();
        // Off the pusher's way first, then the nearest.
        to.sort_by(|&a, &b| way.contains(&a).cmp(&way.contains(&b)).then_with(|| here.dist(self.layout.point(a)).total_cmp(&here.dist(self.layout.point(b)))));
        for w in to {
            if plan.budget == 0 {
                return false;
            }
            plan.budget -= 1;
            let need: Vec<_> = self.layout.lane(v, w).into_iter().chain([w]).collect();
            let by = self.in_the_way(id, &need);
            let (moves, taken) = (plan.moves.len(), plan.taken.len());
            plan.moves.push((id.clone(), v, w, by.is_empty()));
            plan.taken.push(w);
            if by.is_empty() {
                return true;
            }
            let next = by.iter().next().filter(|_| by.len() == 1 && depth > 0);
            if let Some(h) = next.filter(|h| self.robots.get(*h).and_then(Robot::standing) == Some(w)) {
                if self.push(h, v, way, depth - 1, plan) {
                    return true;
                }
            }
            plan.moves.truncate(moves);
            plan.taken.truncate(taken);
        }
        false
    }

    /// Sends every robot of the plan one hop aside and back on its route: whether it did (the
    /// last of each chain must be able to go at once, else nothing moves and nothing changes;
    /// nor if each of its moves was made [`REPEATS`](super::deadlock::REPEATS) times on the
    /// robot's way).
    fn apply(&mut self, plan: &Plan, out: &mut Vec<Command>) -> bool {
        if plan.moves.is_empty() {
            return false;
        }
        let mut moved = Vec::new();
        let mut again = 0;
        for (id, v, w, end) in &plan.moves {
            match self.diverted(id, &[*v, *w], *end) {
                // Pushed on along its own route: it goes once the robots ahead of it have.
                Some(r) if !self.changes_way(id, &r) => {}
                Some(mut r) => {
                    let made = r.asides.entry((*v, *w)).or_insert(0);
                    again += usize::from(*made >= super::deadlock::REPEATS);
                    *made += 1;
                    moved.push((id.clone(), r));
                }
                None => return false,
            }
        }
        // A push every robot of which was made twice already goes round in circles (robots
        // pushed back and forth every few seconds for good): the search gets its turn.
        if again == moved.len() {
            return false;
        }
        for (id, r) in moved {
            self.divert(&id, r, Why::Deadlock, out);
        }
        true
    }
}
