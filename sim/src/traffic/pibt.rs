//! A reference for traffic's throughput: lifelong PIBT (Priority Inheritance with Backtracking,
//! Okumura, Machida, Défago and Tamura, *Artificial Intelligence* 2022), written here from the
//! published algorithm, on the same maps and the same kind of task stream as [`super::sim`].
//!
//! The map's lanes are cut into moves of at least the clearance ([`layout::segmented`] at twice
//! it, so every piece is between one and two clearances long) and time into synchronous steps:
//! at each step every robot moves one hop or stays. No two robots are ever at one vertex or swap
//! along a lane, so robots on two vertices of a lane are a clearance apart — the discrete model
//! lifelong multi-agent path finding is measured in (the League of Robot Runners). A step lasts
//! the cut graph's mean hop over the robots' mean speed. Each step, robots are served in order of
//! priority (how long since they last reached a goal); a robot takes the free neighbour closest to
//! its goal, and one standing there is asked to move out of its way first (priority inheritance),
//! trying its own neighbours in turn; one that cannot makes its asker try its next neighbour
//! (backtracking). A robot that reaches its goal dwells up to the world's dwell (it can be pushed
//! meanwhile) and draws a new goal no other robot is going to.
//!
//! The same robots driving the discrete model blindly (through each other) give the reference's
//! own baseline: the reference's share of the blind trips is what traffic's share is compared
//! with. This is a yardstick, not a fleet controller: it assumes every robot moves in lockstep at
//! one speed and obeys within a step.

use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use mrmm_maps::NavGraph;

use mrmm_core::traffic::layout::segmented;

use super::World;

/// What a run of the reference did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Reference {
    /// Goals reached under PIBT.
    pub trips: u64,
    /// Goals reached by the same robots driving the discrete model through each other.
    pub blind_trips: u64,
    /// Seconds one step stands for.
    pub step_s: f64,
    /// Vertices of the cut graph.
    pub vertices: usize,
}

const NONE: u32 = u32::MAX;

/// The cut graph: out-neighbours of each vertex, and hop distances from every vertex to every
/// place a robot may go to.
struct Moves {
    out: Vec<Vec<u32>>,
    dist: Vec<Vec<u32>>,
}

impl Moves {
    fn new(graph: &NavGraph, places: u32) -> Moves {
        let n = graph.vertices.len();
        let (mut out, mut into) = (vec![Vec::new(); n], vec![Vec::new(); n]);
        for e in graph.edges.iter().filter(|e| e.from != e.to) {
            out[e.from as usize].push(e.to);
            into[e.to as usize].push(e.from);
        }
        for v in out.iter_mut().chain(into.iter_mut()) {
            v.sort_unstable();
            v.dedup();
        }
        let dist = (0..places)
            .map(|goal| {
                let mut d = vec![NONE; n];
                d[goal as usize] = 0;
                let mut queue = std::collections::VecDeque::from([goal]);
                while let Some(v) = queue.pop_front() {
                    for &u in &into[v as usize] {
                        if d[u as usize] == NONE {
                            d[u as usize] = d[v as usize] + 1;
                            queue.push_back(u);
                        }
                    }
                }
                d
            })
            .collect();
        Moves { out, dist }
    }

    /// Hops from every vertex to place `goal` (`NONE`: it cannot get there).
    fn to(&self, goal: u32) -> &[u32] {
        &self.dist[goal as usize]
    }
}

/// One robot of the discrete model.
#[derive(Debug, Clone)]
struct Agent {
    pos: u32,
    goal: u32,
    /// Steps left to dwell at the goal (none: on its way).
    dwell: Option<u32>,
    /// Steps since it last reached a goal, plus a tie-breaker below one.
    priority: f64,
    tie: f64,
}

/// Runs the reference on `graph` (the map's own, uncut) for `world` with `seed`, robots at least
/// `clearance` apart.
pub fn run(graph: &NavGraph, world: &World, clearance: f64, seed: u64) -> Result<Reference, String> {
    let cut = segmented(graph, 2.0 * clearance);
    let places = world.places.map_or(graph.vertices.len() as u32, |p| p.min(graph.vertices.len() as u32));
    let hops: Vec<f64> = cut.edges.iter().filter(|e| e.from != e.to).map(|e| cut.vertices[e.from as usize].at.dist(cut.vertices[e.to as usize].at)).collect();
    let mean_hop = hops.iter().sum::<f64>() / hops.len().max(1) as f64;
    let step_s = (mean_hop / (0.5 * (world.speed.0 + world.speed.1))).max(1e-3);
    let steps = (world.duration / step_s).round() as u64;
    let moves = Moves::new(&cut, places);
    let trips = drive(&moves, world, places, step_s, steps, seed, true)?;
    let blind_trips = drive(&moves, world, places, step_s, steps, seed, false)?;
    Ok(Reference { trips, blind_trips, step_s, vertices: cut.vertices.len() })
}

/// Robots start at distinct places drawn as the simulation draws them; `controlled`: under PIBT, else
/// each takes its next hop regardless of the others.
fn drive(moves: &Moves, world: &World, places: u32, step_s: f64, steps: u64, seed: u64, controlled: bool) -> Result<u64, String> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n = world.robots.min(places as usize);
    let mut starts: Vec<u32> = (0..places).collect();
    let mut agents: Vec<Agent> = Vec::with_capacity(n);
    for i in 0..n {
        let k = rng.gen_range(i..starts.len());
        starts.swap(i, k);
        let _speed: f64 = rng.gen_range(world.speed.0..=world.speed.1);
        agents.push(Agent { pos: starts[i], goal: starts[i], dwell: Some(0), priority: 0.0, tie: (i as f64 + 0.5) / (n as f64 + 1.0) });
    }
    let vertices = moves.out.len();
    let mut trips = 0;
    let mut next = vec![NONE; n];
    let (mut now_at, mut next_at) = (vec![NONE; vertices], vec![NONE; vertices]);
    for _ in 0..steps {
        // Goals reached, dwells counted down, new goals drawn.
        for i in 0..n {
            match agents[i].dwell {
                None if agents[i].pos == agents[i].goal => {
                    trips += 1;
                    agents[i].dwell = Some((rng.gen_range(0.0..=world.dwell) / step_s).round() as u32);
                    agents[i].priority = 0.0;
                }
                Some(0) => {
                    let taken: Vec<u32> = agents.iter().map(|a| a.goal).collect();
                    let at = agents[i].pos;
                    if let Some(goal) = new_goal(&mut rng, moves, at, places, &taken) {
                        agents[i].goal = goal;
                        agents[i].dwell = None;
                    }
                }
                Some(d) => agents[i].dwell = Some(d - 1),
                None => agents[i].priority += 1.0,
            }
        }
        if !controlled {
            for a in &mut agents {
                let d = moves.to(a.goal);
                if let Some(&v) = moves.out[a.pos as usize].iter().filter(|&&v| d[v as usize] < d[a.pos as usize]).min_by_key(|&&v| d[v as usize]) {
                    a.pos = v;
                }
            }
            continue;
        }
        for (i, a) in agents.iter().enumerate() {
            now_at[a.pos as usize] = i as u32;
        }
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|&a, &b| (agents[b].priority + agents[b].tie).total_cmp(&(agents[a].priority + agents[a].tie)));
        let mut step = Step { agents: &agents, next: &mut next, now_at: &now_at, next_at: &mut next_at };
        for &i in &order {
            if step.next[i] == NONE {
                step.plan(i, moves, &mut rng);
            }
        }
        check(&agents, &next)?;
        for (i, a) in agents.iter_mut().enumerate() {
            now_at[a.pos as usize] = NONE;
            next_at[next[i] as usize] = NONE;
            a.pos = next[i];
            next[i] = NONE;
        }
    }
    Ok(trips)
}

/// One step's plan: where each robot is and will be.
struct Step<'a> {
    agents: &'a [Agent],
    next: &'a mut [u32],
    now_at: &'a [u32],
    next_at: &'a mut [u32],
}

impl Step<'_> {
    /// Who stands at `v` now, if anyone.
    fn at(&self, v: u32) -> Option<usize> {
        let k = self.now_at[v as usize];
        (k != NONE).then_some(k as usize)
    }

    /// Plans agent `i`'s next vertex: whether it got one it wanted (else it stays). With the swap
    /// of LaCAM* (Okumura 2024): where the robot it would push has nowhere to go but back along a
    /// dead end, the two pass each other at the nearest branch instead — the robot goes the
    /// other way and pulls the one behind it along.
    fn plan(&mut self, i: usize, moves: &Moves, rng: &mut ChaCha8Rng) -> bool {
        let here = self.agents[i].pos;
        let mut candidates: Vec<u32> = moves.out[here as usize].iter().copied().chain([here]).collect();
        candidates.shuffle(rng);
        let d = moves.to(self.agents[i].goal);
        candidates.sort_by_key(|&v| d[v as usize]);
        let swap = self.swap_partner(i, candidates[0], moves);
        if swap.is_some() {
            candidates.reverse();
        }
        for (n, &v) in candidates.iter().enumerate() {
            if self.next_at[v as usize] != NONE {
                continue;
            }
            let k = self.at(v).filter(|&k| k != i);
            if k.is_some_and(|k| self.next[k] == here) {
                continue; // the two would swap along one lane
            }
            self.next[i] = v;
            self.next_at[v as usize] = i as u32;
            if let Some(k) = k.filter(|&k| self.next[k] == NONE) {
                if !self.plan(k, moves, rng) {
                    continue; // `k` stays where it is (it took `v` back): try the next vertex
                }
            }
            if let Some(s) = swap.filter(|&s| n == 0 && self.next[s] == NONE && self.next_at[here as usize] == NONE) {
                self.next[s] = here;
                self.next_at[here as usize] = s as u32;
            }
            return true;
        }
        self.next[i] = here;
        self.next_at[here as usize] = i as u32;
        false
    }

    /// The robot agent `i` should swap places with instead of pushing it, if any: the one at
    /// `want` when pushing it only drives it into a dead end, or a neighbour behind `i` that
    /// needs to get past it.
    fn swap_partner(&self, i: usize, want: u32, moves: &Moves) -> Option<usize> {
        let here = self.agents[i].pos;
        if want == here {
            return None;
        }
        if let Some(j) = self.at(want).filter(|&j| self.next[j] == NONE) {
            if self.swap_required(i, j, here, want, moves) && self.swap_possible(want, here, moves) {
                return Some(j);
            }
        }
        for &u in &moves.out[here as usize] {
            let Some(k) = self.at(u) else { continue };
            if u == want || self.next[k] != NONE {
                continue;
            }
            if self.swap_required(k, i, here, want, moves) && self.swap_possible(want, here, moves) {
                return Some(k);
            }
        }
        None
    }

    /// The ways out of `v` other than back to `from` and into a dead end where a robot stands
    /// at its goal; and one of them.
    fn ways_on(&self, v: u32, from: u32, moves: &Moves) -> (usize, Option<u32>) {
        let mut ways = 0;
        let mut one = None;
        for &u in &moves.out[v as usize] {
            let parked = moves.out[u as usize].len() == 1 && self.at(u).is_some_and(|a| self.agents[a].goal == u);
            if u != from && !parked {
                ways += 1;
                one = Some(u);
            }
        }
        (ways, one)
    }

    /// Whether `pusher` (at `pusher_at`) driving towards its goal through `puller` (at
    /// `puller_at`) would only push it down a corridor to its end, and the two want to pass.
    fn swap_required(&self, pusher: usize, puller: usize, pusher_at: u32, puller_at: u32, moves: &Moves) -> bool {
        let (mut behind, mut ahead) = (pusher_at, puller_at);
        let to_pusher = moves.to(self.agents[pusher].goal);
        let mut walked = 0;
        while to_pusher[ahead as usize] < to_pusher[behind as usize] && walked < moves.out.len() {
            let (ways, one) = self.ways_on(ahead, behind, moves);
            if ways >= 2 {
                return false; // a branch: they can pass there
            }
            let Some(one) = one.filter(|_| ways == 1) else { break };
            behind = ahead;
            ahead = one;
            walked += 1;
        }
        let to_puller = moves.to(self.agents[puller].goal);
        to_puller[behind as usize] < to_puller[ahead as usize] && (to_pusher[behind as usize] == 0 || to_pusher[ahead as usize] < to_pusher[behind as usize])
    }

    /// Whether a robot at `puller_at` pulling one at `pusher_at` after it (backing away from
    /// `pusher_at`) reaches a branch where the two can pass.
    fn swap_possible(&self, pusher_at: u32, puller_at: u32, moves: &Moves) -> bool {
        let (mut behind, mut ahead) = (pusher_at, puller_at);
        let mut walked = 0;
        while ahead != pusher_at && walked < moves.out.len() {
            let (ways, one) = self.ways_on(ahead, behind, moves);
            if ways >= 2 {
                return true;
            }
            let Some(one) = one.filter(|_| ways == 1) else { return false };
            behind = ahead;
            ahead = one;
            walked += 1;
        }
        false
    }
}

/// No two robots at one vertex, none swapping along a lane: what PIBT guarantees.
fn check(agents: &[Agent], next: &[u32]) -> Result<(), String> {
    let mut seen = std::collections::HashMap::new();
    for (i, &v) in next.iter().enumerate() {
        if v == NONE {
            return Err(format!("robot {i} was given no move"));
        }
        if let Some(j) = seen.insert(v, i) {
            return Err(format!("robots {j} and {i} both move to vertex {v}"));
        }
    }
    for i in 0..agents.len() {
        for j in i + 1..agents.len() {
            if next[i] == agents[j].pos && next[j] == agents[i].pos {
                return Err(format!("robots {i} and {j} swap between vertices {} and {}", agents[i].pos, agents[j].pos));
            }
        }
    }
    Ok(())
}

/// A place other than `at` that no robot is going to and `at` can reach.
fn new_goal(rng: &mut ChaCha8Rng, moves: &Moves, at: u32, places: u32, taken: &[u32]) -> Option<u32> {
    for _ in 0..50 {
        let to = rng.gen_range(0..places);
        if to != at && !taken.contains(&to) && moves.to(to)[at as usize] != NONE {
            return Some(to);
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use mrmm_maps::graph::{Edge, Vertex};
    use mrmm_maps::Point;

    fn line(n: u32, pocket: bool) -> NavGraph {
        let mut vertices: Vec<Vertex> = (0..n).map(|i| Vertex { charger: false, name: format!("v{i}"), at: Point::new(f64::from(i), 0.0) }).collect();
        let mut edges = Vec::new();
        let two_way = |a: u32, b: u32, edges: &mut Vec<Edge>| {
            edges.push(Edge { from: a, to: b, length: 1.0, passing: false });
            edges.push(Edge { from: b, to: a, length: 1.0, passing: false });
        };
        for i in 1..n {
            two_way(i - 1, i, &mut edges);
        }
        if pocket {
            vertices.push(Vertex { charger: false, name: "pocket".into(), at: Point::new(f64::from(n / 2), 1.0) });
            two_way(n / 2, n, &mut edges);
        }
        NavGraph { vertices, edges }
    }

    /// A `w` × `h` grid of two-way lanes 1 m long: every lane on a cycle, where PIBT brings
    /// every robot to its goal.
    fn grid(w: u32, h: u32) -> NavGraph {
        let vertices = (0..w * h).map(|i| Vertex { charger: false, name: format!("v{i}"), at: Point::new(f64::from(i % w), f64::from(i / w)) }).collect();
        let mut edges = Vec::new();
        for i in 0..w * h {
            for j in [(i % w + 1 < w).then_some(i + 1), (i / w + 1 < h).then_some(i + w)].into_iter().flatten() {
                edges.push(Edge { from: i, to: j, length: 1.0, passing: false });
                edges.push(Edge { from: j, to: i, length: 1.0, passing: false });
            }
        }
        NavGraph { vertices, edges }
    }

    #[test]
    fn robots_never_share_a_vertex_nor_swap_and_keep_reaching_goals() {
        for seed in 0..20 {
            let world = World { robots: 5, duration: 300.0, ..World::default() };
            let r = run(&grid(3, 3), &world, 0.6, seed).unwrap_or_else(|e| panic!("seed {seed}: {e}"));
            // Five robots on nine vertices: crowded, but every one keeps reaching goals.
            assert!(r.trips * 4 > r.blind_trips, "seed {seed}: {r:?}");
            assert!(r.trips <= r.blind_trips + 5, "seed {seed}: {r:?}");
        }
    }

    #[test]
    fn a_robot_pushed_into_a_dead_end_swaps_at_the_branch() {
        // Two robots on a line with one pocket: without the swap the one pushed away from its
        // goal never gets past.
        let world = World { robots: 2, duration: 300.0, ..World::default() };
        let r = run(&line(7, true), &world, 0.6, 3).unwrap();
        assert!(r.trips * 3 > r.blind_trips, "{r:?}");
    }

    #[test]
    fn lanes_are_cut_into_moves_of_a_clearance_or_more() {
        let r = run(&line(4, false), &World { robots: 1, duration: 10.0, ..World::default() }, 0.6, 1).unwrap();
        // Lanes of 1 m are shorter than two clearances: not cut.
        assert_eq!(r.vertices, 4);
        assert!((r.step_s - 1.0).abs() < 1e-9, "{r:?}");
    }

    #[test]
    fn the_check_sees_a_swap() {
        let agents = vec![Agent { pos: 0, goal: 1, dwell: None, priority: 0.0, tie: 0.0 }, Agent { pos: 1, goal: 0, dwell: None, priority: 0.0, tie: 0.0 }];
        assert!(check(&agents, &[1, 0]).is_err());
        assert!(check(&agents, &[1, 1]).is_err());
        assert!(check(&agents, &[0, 2]).is_ok());
    }
}
