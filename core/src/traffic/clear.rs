//! Corridors that no search clears in its few moves: the robots standing on the way of the robot
//! that waited longest drive on ahead of it, in the order they stand, to the nearest free places
//! off its way — the one in front to the farthest, so that none stops on another's way there
//! (the *clear* operation of push and swap: Luna and Bekris, IJCAI 2011). Three robots that
//! followed each other into a dead end a dozen segments deep, with the fourth coming out of it,
//! back out together to the branches past the corridor's mouth; then each goes back on its own
//! route, behind the robot that passed.

use std::collections::{BTreeSet, HashMap, VecDeque};

use mrmm_proto::RobotId;

use super::layout::Res;
use super::search::Standing;
use super::{Command, Traffic, Why};

/// Vertices of the way looked along for robots standing on it.
const SCAN: usize = 32;
/// Vertices looked at for free places, at most (bounds the work of one look).
const BUDGET: usize = 2048;

/// Who drives where in a clearing: each robot with the vertices it drives through.
type Clearing = Vec<(RobotId, Vec<u32>)>;
/// Each vertex a breadth-first look reached, with the one it was reached from.
type Parents = HashMap<u32, u32>;

impl Traffic {
    /// Sends the robots standing on the way of `p` (the oldest robot of a gridlock) ahead of it
    /// to free places off its way: whether any route changed. The same robots standing where
    /// they stood when they were last sent are not sent again (they came back before `p`
    /// passed: sending them again would go round in circles).
    pub(super) fn clear_through(&mut self, p: &RobotId, out: &mut Vec<Command>) -> bool {
        let Some(clearing) = self.clearing(p) else { return false };
        let standing: Standing = clearing.iter().map(|(id, path)| (id.clone(), path[0])).collect();
        if self.cleared.as_ref() == Some(&standing) {
            return false;
        }
        let mut moved = Vec::new();
        for (id, path) in &clearing {
            let Some(r) = self.driven_then_back(id, path) else { return false };
            if self.changes_way(id, &r) {
                moved.push((id.clone(), r));
            }
        }
        if moved.is_empty() {
            return false;
        }
        self.cleared = Some(standing);
        for (id, r) in moved {
            self.divert(&id, r, Why::Deadlock, out);
        }
        true
    }

    /// The robots standing on the way of `p`, each with its path: along the way to where the
    /// front one stands, then out to its free place; none if a robot on the way does not stand
    /// there (it drives, is lost or docked) or there are not places enough.
    fn clearing(&self, p: &RobotId) -> Option<Clearing> {
        let r = self.robots.get(p)?;
        let vp = r.standing()?;
        let way: Vec<u32> = std::iter::once(vp).chain(r.route.iter().skip(r.reached? + 1).take(SCAN).copied()).collect();
        // What the way needs (and what is in conflict with it): no robot stops there.
        let mut on_way: BTreeSet<Res> = BTreeSet::new();
        for (i, &w) in way.iter().enumerate() {
            let prev = way[i.saturating_sub(1)];
            for x in self.layout.lane(prev, w).into_iter().chain([w]) {
                on_way.insert(x);
                on_way.extend(self.layout.conflicts(x));
            }
        }
        // The robots on it, each at the position along the way where it stands.
        let mut train: Vec<(RobotId, usize)> = Vec::new();
        for (i, &w) in way.iter().enumerate().skip(1) {
            for x in self.layout.lane(way[i - 1], w).into_iter().chain([w]) {
                for &c in std::iter::once(&x).chain(self.layout.conflicts(x)) {
                    let Some(h) = self.holder(c).filter(|h| *h != p && !train.iter().any(|(t, _)| t == *h)) else { continue };
                    let o = self.robots.get(h)?;
                    if o.lost || o.docked || o.standing() != Some(w) {
                        return None;
                    }
                    train.push((h.clone(), i));
                }
            }
        }
        let &(_, front) = train.last()?;
        // Every lane of the way the train drives must go back too (it comes back along it).
        if !way[..=front].windows(2).all(|h| self.layout.is_edge(h[0], h[1]) && self.layout.is_edge(h[1], h[0])) {
            return None;
        }
        let (pockets, parent) = self.pockets(&way, front, &train, &on_way)?;
        // The front robot to the farthest place, the one behind it to the next: none drives
        // through a place taken before it gets there.
        let mut clearing = Vec::new();
        for ((id, i), &pocket) in train.iter().rev().zip(pockets.iter().rev()) {
            let mut out = vec![pocket];
            while let Some(&up) = parent.get(&out[out.len() - 1]) {
                out.push(up);
            }
            out.pop(); // the front's vertex, the last of the way it drives
            out.reverse();
            let path: Vec<u32> = way[*i..=front].iter().copied().chain(out).collect();
            clearing.push((id.clone(), path));
        }
        Some(clearing)
    }

    /// Breadth-first from where the front of the train stands (way position `front`), over
    /// two-way lanes no other robot holds and not back along the way: the nearest free places
    /// off the way, one per robot of the train, not in conflict with each other, in the order
    /// found; with each vertex reached the one it was reached from.
    fn pockets(&self, way: &[u32], front: usize, train: &[(RobotId, usize)], on_way: &BTreeSet<Res>) -> Option<(Vec<u32>, Parents)> {
        let ours = |h: &RobotId| train.iter().any(|(t, _)| t == h);
        let free = |x: Res| std::iter::once(&x).chain(self.layout.conflicts(x)).all(|&c| self.holder(c).is_none_or(&ours));
        let behind: BTreeSet<u32> = way[..front].iter().copied().collect();
        let root = way[front];
        let mut parent = Parents::new();
        let mut queue = VecDeque::from([root]);
        let mut pockets: Vec<u32> = Vec::new();
        let mut taken: BTreeSet<Res> = BTreeSet::new();
        let mut budget = BUDGET;
        while let Some(v) = queue.pop_front() {
            for &w in self.layout.next(v) {
                if w == root || behind.contains(&w) || parent.contains_key(&w) || !self.layout.is_edge(w, v) {
                    continue;
                }
                budget = budget.checked_sub(1)?;
                let need: Vec<Res> = self.layout.lane(v, w).into_iter().chain([w]).collect();
                if !need.iter().all(|&x| free(x)) {
                    continue;
                }
                parent.insert(w, v);
                queue.push_back(w);
                // Not on a junction: a robot stops there only where its route ends.
                if !on_way.contains(&w) && !taken.contains(&w) && !self.layout.is_junction(w) {
                    pockets.push(w);
                    taken.insert(w);
                    taken.extend(self.layout.conflicts(w));
                    if pockets.len() == train.len() {
                        return Some((pockets, parent));
                    }
                }
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use mrmm_maps::graph::{Edge, Vertex};
    use mrmm_maps::{NavGraph, Point};

    use super::*;
    use crate::at;
    use crate::traffic::{Layout, Params, Robot};

    /// A corridor 0 – 1 – … – 8 (2 m lanes, east to a dead end at 8) off junction 0, which also
    /// leads west to 9 – 11 and to pockets 10 (north) and 12 (south).
    fn corridor() -> Traffic {
        let mut points: Vec<(f64, f64)> = (0..9).map(|i| (2.0 * f64::from(i), 0.0)).collect();
        points.extend([(-2.0, 0.0), (0.0, 2.0), (-4.0, 0.0), (0.0, -2.0)]);
        let vertices = points.iter().enumerate().map(|(i, &(x, y))| Vertex { charger: false, name: format!("v{i}"), at: Point::new(x, y) }).collect();
        let mut edges = Vec::new();
        for (a, b) in (0..8u32).map(|i| (i, i + 1)).chain([(0, 9), (9, 11), (0, 10), (0, 12)]) {
            edges.push(Edge { from: a, to: b, length: 2.0, passing: false });
            edges.push(Edge { from: b, to: a, length: 2.0, passing: false });
        }
        Traffic::new(Arc::new(Layout::new(&NavGraph { vertices, edges }, 0.6)), Params::default())
    }

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
    fn robots_that_followed_each_other_down_a_corridor_drive_out_ahead_of_the_one_coming_back() {
        let mut t = corridor();
        // a at the dead end wants out west to 9; b, c and d followed it in, east.
        stand(&mut t, &[("a", &[8, 7, 6, 5, 4, 3, 2, 1, 0, 9]), ("b", &[7, 8]), ("c", &[6, 7, 8]), ("d", &[5, 6, 7, 8])]);
        let clearing = t.clearing(&RobotId::from("a")).expect("three places off a's way");
        let paths: Vec<(&str, Vec<u32>)> = clearing.iter().map(|(id, p)| (id.as_str(), p.clone())).collect();
        // d, in front, to the farthest place (past 9, on a's way); c and b to the pockets.
        assert_eq!(paths, vec![("d", vec![5, 4, 3, 2, 1, 0, 9, 11]), ("c", vec![6, 5, 4, 3, 2, 1, 0, 12]), ("b", vec![7, 6, 5, 4, 3, 2, 1, 0, 10])],);
        let mut out = Vec::new();
        assert!(t.clear_through(&RobotId::from("a"), &mut out));
        assert_eq!(out.len(), 3, "{out:?}");
        // b drives to its pocket, then back east to the dead end.
        let b = &t.robots[&RobotId::from("b")];
        assert_eq!(b.route, vec![7, 6, 5, 4, 3, 2, 1, 0, 10, 0, 1, 2, 3, 4, 5, 6, 7, 8]);
        // The same robots standing where they stood are not sent again.
        for (id, v) in [("b", 7), ("c", 6), ("d", 5)] {
            let r = t.robots.get_mut(&RobotId::from(id)).expect("in traffic");
            *r = Robot { route: vec![v, v + 1], reached: Some(0), granted: Some(0), ..r.clone() };
        }
        assert!(!t.clear_through(&RobotId::from("a"), &mut out));
    }

    #[test]
    fn with_too_few_places_off_the_way_no_robot_is_sent() {
        let mut t = corridor();
        // Pockets 10 and 12 are held by robots entering the graph there (not standing).
        for (id, v) in [("p", 10u32), ("q", 12)] {
            t.holder[v as usize] = Some(RobotId::from(id));
            t.robots.insert(RobotId::from(id), Robot { route: vec![v], granted: Some(0), held: [(v, 1)].into(), ..Robot::default() });
        }
        stand(&mut t, &[("a", &[8, 7, 6, 5, 4, 3, 2, 1, 0, 9]), ("b", &[7, 8]), ("c", &[6, 7, 8])]);
        assert_eq!(t.clearing(&RobotId::from("a")), None, "one place (11) for two robots");
    }
}
