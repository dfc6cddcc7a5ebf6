//! Gridlocks that neither a step aside nor a push breaks: a short breadth-first search over the
//! moves of the few robots standing on and beside the way of the robot that waited longest, for
//! places that leave its way clear up to past the next junction (two robots head-on in a corridor
//! with others behind them, a dead end that robots followed each other into). Each robot moved
//! drives its part of the plan, then back on its own route; grants keep them apart as always.

use std::collections::{BTreeSet, HashSet, VecDeque};

use mrmm_proto::{RobotId, Time};

use super::layout::Res;
use super::{Command, Robot, Traffic, Why};

/// Robots moved in one search, the one whose way is cleared included (5 found no way out of
/// DIAG's crowded corridor at 12 robots; 9 and 11 did as well as each other).
const MOVERS: usize = 9;
/// Joint positions looked at in one search, at most (bounds its work: 20 000 found every plan
/// 200 000 did).
const STATES: usize = 20_000;
/// Vertices of the way cleared, at most.
const WAY: usize = 16;
/// Robots move within this many hops of the way (3 left too few free places in a crowd).
const AROUND: usize = 6;
/// Searches that found nothing remembered, so as not to run them again while their robots stand
/// where they stood (each robot of a gridlock may be searched for in one look).
pub(super) const FAILED: usize = 8;
/// A robot searched for has waited this long, seconds: the steps aside and pushes of the
/// first seconds of a gridlock break most; searching at once moved robots for nothing.
pub(super) const AFTER: f64 = 5.0;

/// A search's robots and where they stand (the first is the one whose way is cleared).
pub(super) type Standing = Vec<(RobotId, u32)>;

impl Traffic {
    /// Clears the way of robot `p` (the oldest of a gridlock) by moving the robots standing on
    /// and beside it: whether any route changed. A search that found nothing is not run again
    /// while the same robots stand where they stood.
    pub(super) fn search_through(&mut self, p: &RobotId, out: &mut Vec<Command>) -> bool {
        let Some((way, region)) = self.way_and_region(p) else { return false };
        let movers = self.movers(p, &region);
        if self.searched.contains(&movers) {
            return false;
        }
        let plan = self.plan(&movers, &way, &region);
        let moved = plan.and_then(|paths| {
            let mut moved = Vec::new();
            for ((id, _), path) in movers.iter().zip(paths).filter(|(_, path)| path.len() > 1) {
                let r = self.driven_then_back(id, &path)?;
                // Moved on along its own route: it goes once the robots ahead of it have.
                if self.changes_way(id, &r) {
                    moved.push((id.clone(), r));
                }
            }
            Some(moved).filter(|m| !m.is_empty())
        });
        let Some(moved) = moved else {
            self.searched.insert(0, movers);
            self.searched.truncate(FAILED);
            return false;
        };
        self.searched.clear();
        for (id, r) in moved {
            self.divert(&id, r, Why::Deadlock, out);
        }
        true
    }

    /// The standing robots of `stuck`, those that asked for their way first first, if the
    /// first has waited [`AFTER`]: the ones whose ways a search or a clearing opens.
    pub(super) fn oldest_waiting(&self, now: Time, stuck: &[RobotId]) -> Vec<RobotId> {
        let asked = |id: &RobotId| self.robots.get(id).map_or(Time::NEVER, |r| r.asked);
        let standing = |id: &&RobotId| self.robots.get(*id).is_some_and(|r| !r.lost && r.standing().is_some());
        let mut by_age: Vec<RobotId> = stuck.iter().filter(standing).cloned().collect();
        by_age.sort_by(|a, b| asked(a).total_cmp(&asked(b)).then_with(|| a.cmp(b)));
        let waited = by_age.first().and_then(|p| self.robots.get(p)?.waiting).is_some_and(|since| now - since >= AFTER);
        if !waited {
            by_age.clear();
        }
        by_age
    }

    /// The way of robot `p` from where it stands (its next vertices up to the one past its next
    /// junction), and the vertices within [`AROUND`] hops of it and of where it stands.
    fn way_and_region(&self, p: &RobotId) -> Option<(Vec<u32>, BTreeSet<u32>)> {
        let r = self.robots.get(p)?;
        let v = r.standing()?;
        let from = r.reached.unwrap_or(0);
        let mut way = Vec::new();
        let mut past = false;
        for &w in r.route.iter().skip(from + 1).take(WAY) {
            way.push(w);
            // Past the junction (and any next to it): clearing further moved more robots for
            // nothing (to the second junction: 30 stalls, not 10, in the tuning runs).
            if past && !self.layout.is_junction(w) {
                break;
            }
            past |= self.layout.is_junction(w);
        }
        // Vertices in conflict with one of the region (a lane drawn over another: two vertices at
        // one place) are in it too: a robot there is on the way as much as one on it.
        let nv = self.layout.vertices() as u32;
        let mut region: BTreeSet<u32> = BTreeSet::new();
        let mut frontier: Vec<u32> = Vec::new();
        let add = |w: u32, region: &mut BTreeSet<u32>, next: &mut Vec<u32>| {
            for x in std::iter::once(w).chain(self.layout.conflicts(w).iter().copied().filter(|&c| c < nv)) {
                if region.insert(x) {
                    next.push(x);
                }
            }
        };
        for w in way.iter().copied().chain([v]) {
            add(w, &mut region, &mut frontier);
        }
        for _ in 0..AROUND {
            let mut next = Vec::new();
            for x in frontier {
                for &w in self.layout.next(x) {
                    add(w, &mut region, &mut next);
                }
            }
            frontier = next;
        }
        Some((way, region))
    }

    /// Robot `p` and the standing robots nearest to it in `region` (at most [`MOVERS`] in all),
    /// with where each stands.
    fn movers(&self, p: &RobotId, region: &BTreeSet<u32>) -> Standing {
        let Some(vp) = self.robots.get(p).and_then(Robot::standing) else { return Vec::new() };
        let here = self.layout.point(vp);
        let mut others: Vec<(f64, RobotId, u32)> = self
            .robots
            .iter()
            .filter(|(id, r)| *id != p && !r.lost && !r.docked)
            .filter_map(|(id, r)| r.standing().filter(|v| region.contains(v)).map(|v| (here.dist(self.layout.point(v)), id.clone(), v)))
            .collect();
        others.sort_by(|a, b| a.0.total_cmp(&b.0).then_with(|| a.1.cmp(&b.1)));
        std::iter::once((p.clone(), vp)).chain(others.into_iter().take(MOVERS - 1).map(|(_, id, v)| (id, v))).collect()
    }

    /// Breadth-first over the movers' one-hop moves within `region` (the first mover stays): the
    /// vertices each drives through to the nearest places where none of the others is in
    /// conflict with `way`; none if there are none within [`STATES`].
    fn plan(&self, movers: &Standing, way: &[u32], region: &BTreeSet<u32>) -> Option<Vec<Vec<u32>>> {
        let ids: BTreeSet<&RobotId> = movers.iter().map(|(id, _)| id).collect();
        let fixed = |x: Res| self.holder(x).is_some_and(|h| !ids.contains(h));
        // What the way needs, and everything in conflict with it.
        let mut on_way: BTreeSet<Res> = BTreeSet::new();
        let mut prev = movers.first()?.1;
        for &w in way {
            for x in self.layout.lane(prev, w).into_iter().chain([w]) {
                on_way.insert(x);
                on_way.extend(self.layout.conflicts(x));
            }
            prev = w;
        }
        let clear = |pos: &[u32]| pos.iter().skip(1).all(|v| !on_way.contains(v));
        let start: Vec<u32> = movers.iter().map(|(_, v)| *v).collect();
        if clear(&start) {
            return None;
        }
        let mut states = vec![start.clone()];
        let mut parent: Vec<(usize, usize)> = vec![(0, 0)];
        let mut seen: HashSet<Vec<u32>> = HashSet::from([start]);
        let mut queue = VecDeque::from([0usize]);
        while let Some(s) = queue.pop_front() {
            for i in 1..movers.len() {
                let v = states[s][i];
                for &w in self.layout.next(v) {
                    if !region.contains(&w) || !self.layout.is_edge(w, v) {
                        continue;
                    }
                    let mut need = self.layout.lane(v, w).into_iter().chain([w]);
                    let others = |x: Res| states[s].iter().enumerate().any(|(j, &u)| j != i && u == x);
                    if need.any(|x| std::iter::once(&x).chain(self.layout.conflicts(x)).any(|&c| fixed(c) || others(c))) {
                        continue;
                    }
                    let mut next = states[s].clone();
                    next[i] = w;
                    if seen.contains(&next) {
                        continue;
                    }
                    if states.len() >= STATES {
                        return None;
                    }
                    let done = clear(&next);
                    seen.insert(next.clone());
                    states.push(next);
                    parent.push((s, i));
                    if done {
                        return Some(paths(&states, &parent, states.len() - 1));
                    }
                    queue.push_back(states.len() - 1);
                }
            }
        }
        None
    }

    /// The standing robot `id` driven along `path` (from where it stands), then back along it
    /// as far as the last vertex of it its route goes on from, and on along its route; none if
    /// the route would be too long.
    pub(super) fn driven_then_back(&self, id: &RobotId, path: &[u32]) -> Option<Robot> {
        let r = self.robots.get(id)?;
        let g = r.granted?;
        let rest = &r.route[g + 1..];
        // The last vertex of the path its route goes on from (where it stands, if none).
        let (m, q) = (1..path.len()).rev().find_map(|m| rest.iter().position(|&x| x == path[m]).map(|q| (m, q + 1))).unwrap_or((0, 0));
        let mut route = r.route[..=g].to_vec();
        route.extend(&path[1..]);
        route.extend(path[m..path.len() - 1].iter().rev());
        route.extend(&rest[q..]);
        super::deadlock::rerouted(r, &route)
    }
}

/// Each mover's vertices from where it stood to where state `s` has it, by the moves that led
/// there.
fn paths(states: &[Vec<u32>], parent: &[(usize, usize)], mut s: usize) -> Vec<Vec<u32>> {
    let mut moves = Vec::new();
    while s != 0 {
        let (from, i) = parent[s];
        moves.push((i, states[s][i]));
        s = from;
    }
    let mut paths: Vec<Vec<u32>> = states[0].iter().map(|&v| vec![v]).collect();
    for (i, w) in moves.into_iter().rev() {
        paths[i].push(w);
    }
    paths
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use mrmm_maps::graph::{Edge, Vertex};
    use mrmm_maps::{NavGraph, Point};

    use super::*;
    use crate::at;
    use crate::traffic::{Layout, Params};

    /// A dead end 0 – 1 – 2 – 3 off junction 0, which also leads west to 4 – 7 and to pockets
    /// 5 and 6; lanes 2 m, two-way.
    fn dead_end() -> Traffic {
        let points = [(0.0, 0.0), (2.0, 0.0), (4.0, 0.0), (6.0, 0.0), (-2.0, 0.0), (0.0, 2.0), (0.0, -2.0), (-4.0, 0.0)];
        let vertices = points.iter().enumerate().map(|(i, &(x, y))| Vertex { charger: false, name: format!("v{i}"), at: Point::new(x, y) }).collect();
        let mut edges = Vec::new();
        for (a, b) in [(0u32, 1u32), (1, 2), (2, 3), (0, 4), (4, 7), (0, 5), (0, 6)] {
            edges.push(Edge { from: a, to: b, length: 2.0, passing: false });
            edges.push(Edge { from: b, to: a, length: 2.0, passing: false });
        }
        Traffic::new(Arc::new(Layout::new(&NavGraph { vertices, edges }, 0.6)), Params::default())
    }

    /// Robots standing each at the first vertex of its route, wanting to drive it: placed as
    /// traffic would have them, with no look at them (which would break their gridlock).
    fn stand(t: &mut Traffic, robots: &[(&str, &[u32])]) {
        for (id, route) in robots {
            let id = RobotId::from(*id);
            t.holder[route[0] as usize] = Some(id.clone());
            let r =
                Robot { route: route.to_vec(), reached: Some(0), granted: Some(0), held: [(route[0], 1)].into(), waiting: Some(at(0.0)), ..Robot::default() };
            t.robots.insert(id, r);
        }
    }

    #[test]
    fn robots_that_followed_each_other_into_a_dead_end_back_out_of_the_way() {
        let mut t = dead_end();
        // a at the dead end wants out west; b and c followed it in and want to go on to it.
        stand(&mut t, &[("a", &[3, 2, 1, 0, 4, 7]), ("b", &[2, 3]), ("c", &[1, 2, 3])]);
        let a = RobotId::from("a");
        let (way, region) = t.way_and_region(&a).expect("a stands");
        assert_eq!(way, vec![2, 1, 0, 4], "to the vertex past its junction");
        let movers = t.movers(&a, &region);
        assert_eq!(movers.iter().map(|(id, v)| (id.as_str(), *v)).collect::<Vec<_>>(), vec![("a", 3), ("b", 2), ("c", 1)]);
        let paths = t.plan(&movers, &way, &region).expect("the pockets take b and c");
        assert_eq!(paths[0], vec![3], "a stays");
        for path in &paths[1..] {
            assert!(path.windows(2).all(|w| t.layout.is_edge(w[0], w[1])), "{path:?} drives lanes");
            let end = path[path.len() - 1];
            assert!([5, 6].contains(&end), "{path:?} ends in a pocket, off a's way");
        }
        // c, nearer the junction, goes first and farthest; b follows it out.
        assert_ne!(paths[1].last(), paths[2].last());
        // b drives to its pocket, then back along the way it came and on to the dead end.
        let b = t.driven_then_back(&RobotId::from("b"), &paths[1]).expect("a short route");
        let mut expected = paths[1].clone();
        expected.extend(paths[1][..paths[1].len() - 1].iter().rev());
        expected.push(3);
        assert_eq!(b.route, expected);
        assert_eq!((b.reached, b.granted), (Some(0), Some(0)));
    }

    #[test]
    fn a_robot_moved_along_its_own_route_goes_on_from_where_the_plan_leaves_it() {
        let mut t = dead_end();
        stand(&mut t, &[("c", &[1, 0, 4, 7])]);
        // Moved 1 → 0 → 5: back to 0, where its route goes on to 4.
        let c = t.driven_then_back(&RobotId::from("c"), &[1, 0, 5]).expect("a short route");
        assert_eq!(c.route, vec![1, 0, 5, 0, 4, 7]);
    }

    #[test]
    fn with_no_free_place_near_the_way_there_is_no_plan() {
        let mut t = dead_end();
        stand(&mut t, &[("a", &[3, 2, 1, 0, 4, 7]), ("b", &[2, 3])]);
        // Every other place is held by robots on their way onto the graph there: they do not
        // stand, so none is moved.
        for (id, v) in [("p", 5u32), ("q", 6), ("r", 7)] {
            t.holder[v as usize] = Some(RobotId::from(id));
            t.robots.insert(RobotId::from(id), Robot { route: vec![v], granted: Some(0), held: [(v, 1)].into(), ..Robot::default() });
        }
        let a = RobotId::from("a");
        let (way, region) = t.way_and_region(&a).expect("a stands");
        let movers = t.movers(&a, &region);
        assert_eq!(movers.len(), 2, "{movers:?}");
        assert_eq!(t.plan(&movers, &way, &region), None);
    }
}
