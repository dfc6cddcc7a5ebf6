//! Local search and iterated local search on an array tour.
//!
//! The tour is an array of cities plus each city's position. Moves are 2-opt (reverse a path)
//! and Or-opt (move a segment of 1 to 3 cities elsewhere, either way round), each applied as a
//! sequence of 2-opt reversals so that the tour's orientation never matters; every reversal
//! takes the shorter side of the cycle. Candidate moves come from each city's K nearest
//! neighbours; a FIFO of active cities plays the role of don't-look bits.

use std::collections::VecDeque;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::{Budget, Instance};

/// Neighbour-list size.
pub const K: usize = 10;
/// Improvements smaller than this are ignored (lengths are in metres or TSPLIB units).
const EPS: f64 = 1e-7;
/// Longest segment a kick moves.
const KICK_SEGMENT: usize = 50;
/// Kicks between two calls of the stop predicate.
const STOP_EVERY: u64 = 8;

/// What the search did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Stats {
    /// Length of the construction.
    pub start_length: f64,
    /// Length after the first local search.
    pub local_length: f64,
    /// Kicks tried.
    pub kicks: u64,
    /// Kicks that led to a strictly shorter tour.
    pub improving_kicks: u64,
}

/// The `k` nearest other points of each point, nearest first.
pub fn neighbours(inst: &Instance, k: usize) -> Vec<Vec<u32>> {
    let n = inst.len();
    let k = k.min(n.saturating_sub(1));
    let mut out = Vec::with_capacity(n);
    let mut cand: Vec<(f64, u32)> = Vec::with_capacity(n);
    for i in 0..n {
        cand.clear();
        cand.extend((0..n).filter(|&j| j != i).map(|j| (inst.d(i, j), j as u32)));
        if k < cand.len() {
            cand.select_nth_unstable_by(k, |a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            cand.truncate(k);
        }
        cand.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        out.push(cand.iter().map(|&(_, j)| j).collect());
    }
    out
}

struct Search<'a> {
    inst: &'a Instance,
    n: usize,
    t: Vec<u32>,
    pos: Vec<u32>,
    len: f64,
    /// Flattened neighbour lists, `k` per city, with their distances.
    neigh: Vec<u32>,
    neigh_d: Vec<f64>,
    k: usize,
    queue: VecDeque<u32>,
    queued: Vec<bool>,
}

impl<'a> Search<'a> {
    fn new(inst: &'a Instance, order: &[usize], lists: &[Vec<u32>]) -> Self {
        let n = inst.len();
        let k = lists.iter().map(Vec::len).min().unwrap_or(0);
        let mut neigh = Vec::with_capacity(n * k);
        let mut neigh_d = Vec::with_capacity(n * k);
        for (i, l) in lists.iter().enumerate() {
            for &j in &l[..k] {
                neigh.push(j);
                neigh_d.push(inst.d(i, j as usize));
            }
        }
        let t: Vec<u32> = order.iter().map(|&c| c as u32).collect();
        let mut pos = vec![0u32; n];
        for (p, &c) in t.iter().enumerate() {
            pos[c as usize] = p as u32;
        }
        Search { inst, n, len: inst.tour_length(order), t, pos, neigh, neigh_d, k, queue: VecDeque::with_capacity(n), queued: vec![false; n] }
    }

    #[inline]
    fn d(&self, a: usize, b: usize) -> f64 {
        self.inst.d(a, b)
    }
    #[inline]
    fn next(&self, c: usize) -> usize {
        let p = self.pos[c] as usize + 1;
        self.t[if p == self.n { 0 } else { p }] as usize
    }
    #[inline]
    fn prev(&self, c: usize) -> usize {
        let p = self.pos[c] as usize;
        self.t[if p == 0 { self.n - 1 } else { p - 1 }] as usize
    }

    fn push(&mut self, c: usize) {
        if !self.queued[c] {
            self.queued[c] = true;
            self.queue.push_back(c as u32);
        }
    }

    /// Reverses the path from `from` to `to` (following `next`), or equivalently its complement,
    /// whichever is shorter.
    fn reverse_path(&mut self, from: usize, to: usize) {
        let n = self.n;
        let (mut i, mut j) = (self.pos[from] as usize, self.pos[to] as usize);
        let mut len = (j + n - i) % n + 1;
        if 2 * len > n {
            let (f2, t2) = (self.next(to), self.prev(from));
            i = self.pos[f2] as usize;
            j = self.pos[t2] as usize;
            len = n - len;
        }
        for _ in 0..len / 2 {
            let (ci, cj) = (self.t[i], self.t[j]);
            self.t[i] = cj;
            self.t[j] = ci;
            self.pos[cj as usize] = i as u32;
            self.pos[ci as usize] = j as u32;
            i = if i + 1 == n { 0 } else { i + 1 };
            j = if j == 0 { n - 1 } else { j - 1 };
        }
    }

    /// Replaces tour edges (a,b) and (c,d), oriented the same way, by (a,c) and (b,d).
    fn two_opt(&mut self, a: usize, b: usize, c: usize, d: usize) {
        if self.next(a) == b {
            self.reverse_path(b, c);
        } else {
            self.reverse_path(a, d);
        }
    }

    /// Tries improving 2-opt moves around `a`; applies the first one found.
    fn improve_2opt(&mut self, a: usize) -> bool {
        for succ in [true, false] {
            let b = if succ { self.next(a) } else { self.prev(a) };
            let g1 = self.d(a, b);
            for k in 0..self.k {
                let g2 = self.neigh_d[a * self.k + k];
                if g2 >= g1 {
                    break;
                }
                let c = self.neigh[a * self.k + k] as usize;
                let dd = if succ { self.next(c) } else { self.prev(c) };
                if c == b || dd == a {
                    continue;
                }
                let delta = g2 + self.d(b, dd) - g1 - self.d(c, dd);
                if delta < -EPS {
                    self.two_opt(a, b, c, dd);
                    self.len += delta;
                    for x in [a, b, c, dd] {
                        self.push(x);
                    }
                    return true;
                }
            }
        }
        false
    }

    #[inline]
    fn in_segment(&self, c: usize, s1: usize, len: usize) -> bool {
        (self.pos[c] as usize + self.n - self.pos[s1] as usize) % self.n < len
    }

    /// Tries improving Or-opt moves of segments of 1 to 3 cities that start or end at `a`.
    fn improve_oropt(&mut self, a: usize) -> bool {
        for seg in 1..=3usize {
            if self.n < seg + 4 {
                break;
            }
            for a_first in [true, false] {
                if seg == 1 && !a_first {
                    continue;
                }
                let (s1, s2) = if a_first {
                    let mut s2 = a;
                    for _ in 1..seg {
                        s2 = self.next(s2);
                    }
                    (a, s2)
                } else {
                    let mut s1 = a;
                    for _ in 1..seg {
                        s1 = self.prev(s1);
                    }
                    (s1, a)
                };
                let (p, nx) = (self.prev(s1), self.next(s2));
                let g_rem = self.d(p, s1) + self.d(s2, nx) - self.d(p, nx);
                if g_rem <= EPS {
                    continue;
                }
                for (end, other) in [(s1, s2), (s2, s1)] {
                    for k in 0..self.k {
                        let dce = self.neigh_d[end * self.k + k];
                        if dce >= g_rem {
                            break;
                        }
                        let c = self.neigh[end * self.k + k] as usize;
                        if self.in_segment(c, s1, seg) {
                            continue;
                        }
                        for e in [self.next(c), self.prev(c)] {
                            if self.in_segment(e, s1, seg) {
                                continue;
                            }
                            let delta = dce + self.d(other, e) - self.d(c, e) - g_rem;
                            if delta < -EPS {
                                // Normalise to a forward edge (u, w) with x next to u.
                                let (u, w, x) = if e == self.next(c) { (c, e, end) } else { (e, c, other) };
                                if w == p {
                                    continue;
                                }
                                self.move_segment(s1, s2, p, nx, u, w, x);
                                self.len += delta;
                                for y in [p, nx, s1, s2, c, e] {
                                    self.push(y);
                                }
                                return true;
                            }
                        }
                    }
                }
            }
        }
        false
    }

    /// Moves the forward segment s1..s2 (between p and nx) into the forward edge (u, w), with
    /// segment end `x` next to u.
    #[allow(clippy::too_many_arguments)]
    fn move_segment(&mut self, s1: usize, s2: usize, p: usize, nx: usize, u: usize, w: usize, x: usize) {
        // p S nx .. u w  →  p u .. nx s2..s1 w
        self.two_opt(p, s1, u, w);
        if u != nx {
            // → p nx .. u s2..s1 w
            self.two_opt(p, u, nx, s2);
        }
        if x == s1 && s1 != s2 {
            // → u s1..s2 w
            self.two_opt(u, s2, s1, w);
        }
    }

    /// Runs local search until no active city is left.
    fn local_search(&mut self) {
        while let Some(a) = self.queue.pop_front() {
            let a = a as usize;
            self.queued[a] = false;
            if self.improve_2opt(a) || self.improve_oropt(a) {
                self.push(a);
            }
        }
    }

    /// Segment double bridge: swaps two adjacent segments of random lengths at a random place.
    fn kick(&mut self, rng: &mut ChaCha8Rng) {
        let n = self.n;
        let max_seg = KICK_SEGMENT.min((n - 2) / 3).max(1);
        let l1 = rng.gen_range(1..=max_seg);
        let l2 = rng.gen_range(1..=max_seg);
        let p0 = rng.gen_range(0..n);
        let at = |k: usize| (p0 + k) % n;
        let (a, b0, b1, c0, c1, z) = (
            self.t[at(0)] as usize,
            self.t[at(1)] as usize,
            self.t[at(l1)] as usize,
            self.t[at(l1 + 1)] as usize,
            self.t[at(l1 + l2)] as usize,
            self.t[at(l1 + l2 + 1)] as usize,
        );
        let delta = self.d(a, c0) + self.d(c1, b0) + self.d(b1, z) - self.d(a, b0) - self.d(b1, c0) - self.d(c1, z);
        let moved: Vec<u32> = (l1 + 1..=l1 + l2).chain(1..=l1).map(|k| self.t[at(k)]).collect();
        for (k, c) in moved.into_iter().enumerate() {
            let p = at(k + 1);
            self.t[p] = c;
            self.pos[c as usize] = p as u32;
        }
        self.len += delta;
        for x in [a, b0, b1, c0, c1, z] {
            self.push(x);
        }
    }

    fn order(&self) -> Vec<usize> {
        self.t.iter().map(|&c| c as usize).collect()
    }
}

/// Local search then iterated local search within the budget; returns the best order found.
pub fn optimise(inst: &Instance, start: Vec<usize>, budget: &Budget) -> (Vec<usize>, Stats) {
    let lists = neighbours(inst, K);
    let mut s = Search::new(inst, &start, &lists);
    let mut stats = Stats { start_length: s.len, ..Stats::default() };
    for c in 0..s.n {
        s.push(c);
    }
    s.local_search();
    stats.local_length = s.len;
    if s.n < 8 {
        return (s.order(), stats);
    }
    let mut rng = ChaCha8Rng::seed_from_u64(budget.seed);
    let mut best_t = s.t.clone();
    let mut best_len = s.len;
    while stats.kicks < budget.max_kicks {
        if stats.kicks.is_multiple_of(STOP_EVERY) {
            if let Some(stop) = budget.stop {
                if stop() {
                    break;
                }
            }
        }
        stats.kicks += 1;
        s.kick(&mut rng);
        s.local_search();
        if s.len < best_len - EPS {
            stats.improving_kicks += 1;
            best_len = s.len;
            best_t.copy_from_slice(&s.t);
        } else if s.len > best_len + EPS {
            s.t.copy_from_slice(&best_t);
            for (p, &c) in s.t.iter().enumerate() {
                s.pos[c as usize] = p as u32;
            }
            s.len = best_len;
        } else {
            // Equal length: keep the new tour (a sideways step), but remember it as best.
            best_t.copy_from_slice(&s.t);
        }
    }
    (best_t.iter().map(|&c| c as usize).collect(), stats)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tsp::is_permutation;
    use crate::tsp::tests::random_instance;

    fn random(n: usize, seed: u64) -> Instance {
        random_instance(n, seed, 1000.0)
    }

    #[test]
    fn tracked_length_matches_recomputed_length() {
        for seed in 0..5 {
            let inst = random(150, seed);
            let start: Vec<usize> = (0..150).collect();
            let lists = neighbours(&inst, K);
            let mut s = Search::new(&inst, &start, &lists);
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            for c in 0..s.n {
                s.push(c);
            }
            s.local_search();
            for _ in 0..200 {
                s.kick(&mut rng);
                s.local_search();
                let order = s.order();
                assert!(is_permutation(&order, 150));
                let real = inst.tour_length(&order);
                assert!((real - s.len).abs() < 1e-6 * real, "seed {seed}: tracked {} real {real}", s.len);
                for (p, &c) in s.t.iter().enumerate() {
                    assert_eq!(s.pos[c as usize] as usize, p);
                }
            }
        }
    }

    #[test]
    fn local_optimum_has_no_improving_2opt_among_neighbours() {
        let inst = random(120, 7);
        let (order, stats) = optimise(&inst, (0..120).collect(), &Budget { max_kicks: 0, stop: None, seed: 1 });
        assert!(stats.local_length < stats.start_length);
        let lists = neighbours(&inst, K);
        let mut s = Search::new(&inst, &order, &lists);
        for a in 0..120 {
            assert!(!s.improve_2opt(a), "2-opt move left at {a}");
            assert!(!s.improve_oropt(a), "or-opt move left at {a}");
        }
    }
}
