//! A navigation graph laid out for traffic: its vertices and lanes as resources a robot holds,
//! and which resources are too close to be held by two robots at once.
//!
//! A resource is a vertex (`0..vertices`) or an undirected lane (`vertices..`). Two resources
//! **conflict** when robots on them could come closer than the clearance: vertices closer than
//! it, a vertex that close to a lane it is not an end of, lanes that close (crossing included)
//! that share no end. Resources that meet at a vertex do not conflict through it: a robot on a
//! lane holds both its ends, so the shared vertex keeps them apart.

use std::collections::HashMap;

use mrmm_maps::geom::point_segment_distance;
use mrmm_maps::{NavGraph, Point};
use mrmm_proto::traffic::RouteVertex;

pub use super::segments::{segmented, PASSING_OFFSET_M, SIDE_SEGMENT_M, WRONG_SIDE};

/// A resource: a vertex or a lane.
pub type Res = u32;

/// Beyond the distance at which a robot leaving a vertex is clear of it, how much farther it
/// drives before traffic lets the vertex go, metres (the robot's report of its position lags).
pub const RELEASE_MARGIN_M: f64 = 0.05;

/// A graph prepared for traffic.
#[derive(Debug, Clone)]
pub struct Layout {
    points: Vec<Point>,
    /// Each vertex's name where it names that vertex alone ([`RouteVertex::may_name`]).
    names: Vec<Option<String>>,
    /// Lanes, each `(a, b)` with `a < b`.
    lanes: Vec<(u32, u32)>,
    /// Each vertex's lanes: the vertex at the other end, and the lane (a scan of a vertex's few
    /// lanes is cheaper than a hash of the pair, and a route's every hop looks one up).
    lanes_at: Vec<Vec<(u32, Res)>>,
    /// Directed edges out of each vertex.
    out: Vec<Vec<u32>>,
    /// For each resource, the others it conflicts with.
    conflicts: Vec<Vec<Res>>,
    clearance: f64,
    /// Vertices joining three or more lanes.
    junction: Vec<bool>,
    /// Each corridor's resources (its lanes and the vertices inside it), and for each lane its
    /// corridor with whether driving it from its lower vertex to its higher is the corridor's
    /// forward way (none: not in a corridor of two lanes or more with two ends).
    corridors: Vec<Vec<Res>>,
    corridor_of: HashMap<Res, (u32, bool)>,
    /// For each lane driven from `u` to `v`, how far along it `u` may be let go
    /// ([`Layout::release_after`]).
    behind: HashMap<(u32, u32), f64>,
}

/// Each vertex's name, where no other vertex of `graph` has it and it may name a vertex in a
/// route ([`RouteVertex::may_name`]).
fn own_names(graph: &NavGraph) -> Vec<Option<String>> {
    let mut count: HashMap<&str, u32> = HashMap::new();
    for v in &graph.vertices {
        *count.entry(v.name.as_str()).or_default() += 1;
    }
    graph.vertices.iter().map(|v| (count[v.name.as_str()] == 1 && RouteVertex::may_name(&v.name)).then(|| v.name.clone())).collect()
}

impl Layout {
    /// Lays `graph` out for robots that must stay `clearance` metres apart (centre to centre).
    pub fn new(graph: &NavGraph, clearance: f64) -> Layout {
        let points: Vec<Point> = graph.vertices.iter().map(|v| v.at).collect();
        let lanes = graph.lanes();
        let nv = points.len() as u32;
        let mut lanes_at = vec![Vec::new(); points.len()];
        for (i, &(a, b)) in lanes.iter().enumerate() {
            lanes_at[a as usize].push((b, nv + i as u32));
            lanes_at[b as usize].push((a, nv + i as u32));
        }
        let mut out = vec![Vec::new(); points.len()];
        for e in &graph.edges {
            if e.from != e.to && !out[e.from as usize].contains(&e.to) {
                out[e.from as usize].push(e.to);
            }
        }
        let mut degree = vec![0u32; points.len()];
        for &(a, b) in &lanes {
            degree[a as usize] += 1;
            degree[b as usize] += 1;
        }
        let junction = degree.iter().map(|&d| d >= 3).collect();
        let mut layout = Layout {
            points,
            names: own_names(graph),
            lanes,
            lanes_at,
            out,
            conflicts: Vec::new(),
            clearance,
            junction,
            corridors: Vec::new(),
            corridor_of: HashMap::new(),
            behind: HashMap::new(),
        };
        layout.conflicts = layout.find_conflicts();
        layout.behind = layout.find_behind();
        layout.find_corridors(&degree);
        layout
    }

    /// Where along each lane, each way, its start may be let go ([`Layout::release_after`]).
    fn find_behind(&self) -> HashMap<(u32, u32), f64> {
        let mut by_vertex: Vec<Vec<u32>> = vec![Vec::new(); self.points.len()];
        for &(a, b) in &self.lanes {
            by_vertex[a as usize].push(b);
            by_vertex[b as usize].push(a);
        }
        let mut behind = HashMap::new();
        for &(a, b) in &self.lanes {
            for (u, v) in [(a, b), (b, a)] {
                let (pu, pv) = (self.point(u), self.point(v));
                let len = pu.dist(pv);
                // The smallest sine of the angle to another lane of `u` leaving less than square.
                let mut sine: f64 = 1.0;
                for &x in by_vertex[u as usize].iter().filter(|&&x| x != v) {
                    let px = self.point(x);
                    let (d1, d2) = ((pv.x - pu.x, pv.y - pu.y), (px.x - pu.x, px.y - pu.y));
                    let cos = (d1.0 * d2.0 + d1.1 * d2.1) / (len * pu.dist(px)).max(1e-12);
                    if cos > 0.0 {
                        sine = sine.min((1.0 - cos * cos).max(0.0).sqrt());
                    }
                }
                let d = self.clearance / sine.max(1e-9) + RELEASE_MARGIN_M;
                if d + self.clearance <= len {
                    behind.insert((u, v), d);
                }
            }
        }
        behind
    }

    /// Corridors: chains of two lanes or more through vertices of two lanes, walked from one
    /// end (a vertex of one lane, or of three or more) to the other. Rings have no end: none.
    fn find_corridors(&mut self, degree: &[u32]) {
        let nv = self.points.len() as u32;
        let mut by_vertex: Vec<Vec<u32>> = vec![Vec::new(); self.points.len()];
        for (i, &(a, b)) in self.lanes.iter().enumerate() {
            by_vertex[a as usize].push(i as u32);
            by_vertex[b as usize].push(i as u32);
        }
        let mut seen = vec![false; self.lanes.len()];
        for start in 0..self.points.len() {
            if degree[start] == 2 {
                continue;
            }
            for &first in &by_vertex[start] {
                if seen[first as usize] {
                    continue;
                }
                // Walk from `start` along the chain.
                let (mut at, mut lane) = (start as u32, first);
                let mut walk: Vec<(u32, u32, u32)> = Vec::new();
                loop {
                    seen[lane as usize] = true;
                    let (a, b) = self.lanes[lane as usize];
                    let to = if a == at { b } else { a };
                    walk.push((lane, at, to));
                    if degree[to as usize] != 2 {
                        break;
                    }
                    let Some(&next) = by_vertex[to as usize].iter().find(|&&l| l != lane) else { break };
                    at = to;
                    lane = next;
                }
                if walk.len() < 2 {
                    continue;
                }
                let c = self.corridors.len() as u32;
                let mut res = Vec::new();
                for (k, &(lane, from, to)) in walk.iter().enumerate() {
                    self.corridor_of.insert(nv + lane, (c, from < to));
                    res.push(nv + lane);
                    if k + 1 < walk.len() {
                        res.push(to);
                    }
                }
                self.corridors.push(res);
            }
        }
    }

    /// The corridor the lane from `a` to `b` is in, and whether driving it that way is the
    /// corridor's forward way.
    pub fn corridor(&self, a: u32, b: u32) -> Option<(u32, bool)> {
        let (c, low_to_high) = *self.corridor_of.get(&self.lane(a, b)?)?;
        Some((c, low_to_high == (a < b)))
    }

    /// A corridor's resources: its lanes and the vertices inside it.
    pub fn corridor_resources(&self, c: u32) -> &[Res] {
        self.corridors.get(c as usize).map_or(&[], Vec::as_slice)
    }

    pub fn vertices(&self) -> usize {
        self.points.len()
    }

    pub fn resources(&self) -> usize {
        self.points.len() + self.lanes.len()
    }

    pub fn clearance(&self) -> f64 {
        self.clearance
    }

    pub fn point(&self, v: u32) -> Point {
        self.points[v as usize]
    }

    /// Vertex `v` as a route names it: where it is, and its own name if it has one.
    pub fn route_vertex(&self, v: u32) -> RouteVertex {
        let p = self.point(v);
        RouteVertex { v, x: p.x, y: p.y, name: self.names.get(v as usize).cloned().flatten(), release: None }
    }

    /// Vertices a directed edge leads to from `v`.
    pub fn next(&self, v: u32) -> &[u32] {
        &self.out[v as usize]
    }

    /// Whether `v` joins three or more lanes (robots crossing it go different ways).
    pub fn is_junction(&self, v: u32) -> bool {
        self.junction.get(v as usize).copied().unwrap_or(false)
    }

    /// Whether a robot may drive from `a` to `b` (a directed edge).
    pub fn is_edge(&self, a: u32, b: u32) -> bool {
        self.out.get(a as usize).is_some_and(|o| o.contains(&b))
    }

    /// The lane between `a` and `b`, either way.
    pub fn lane(&self, a: u32, b: u32) -> Option<Res> {
        self.lanes_at.get(a as usize)?.iter().find(|&&(o, _)| o == b).map(|&(_, l)| l)
    }

    /// How far along its lane from `u` to `v` a robot must be for `u` to be let go, metres
    /// (none: not before it reaches `v`). A robot then at `u`, or on any other lane of `u`, is
    /// at least the clearance from it: the clearance, or more where another lane leaves `u` at
    /// less than a right angle to this one (the clearance over the sine of that angle), short
    /// of the lane's far end by the clearance.
    pub fn release_after(&self, u: u32, v: u32) -> Option<f64> {
        self.behind.get(&(u, v)).copied()
    }

    /// Whether a robot at `at`, driving the lane from `u` to `v`, is clear of `u`: at least
    /// [`Layout::release_after`] along the lane, more by what it is off the lane's line (over the
    /// sine the release distance was made for), and not yet at `v`.
    pub fn clear_of(&self, u: u32, v: u32, at: Point) -> bool {
        let Some(d) = self.release_after(u, v) else { return false };
        let (pu, pv) = (self.point(u), self.point(v));
        let len = pu.dist(pv);
        let (dx, dy) = ((pv.x - pu.x) / len, (pv.y - pu.y) / len);
        let along = (at.x - pu.x) * dx + (at.y - pu.y) * dy;
        let off = ((at.x - pu.x) * dy - (at.y - pu.y) * dx).abs();
        // d = clearance / sine + margin: a robot `off` the line needs `off / sine` more.
        let sine = self.clearance / (d - RELEASE_MARGIN_M).max(1e-9);
        along >= d + off / sine && along < len
    }

    /// Resources `r` conflicts with (not itself).
    pub fn conflicts(&self, r: Res) -> &[Res] {
        &self.conflicts[r as usize]
    }

    /// Whether a robot holding vertex `v` may stand anywhere on the segment `a` – `b` too: every
    /// resource within the clearance of it is `v`, a lane of `v`, or in conflict with `v` — no
    /// other robot can hold one while this one holds `v`.
    pub fn covered_by(&self, v: u32, a: Point, b: Point) -> bool {
        let Some(conflicts) = self.conflicts.get(v as usize) else { return false };
        (0..self.resources() as Res).all(|r| {
            let (ra, rb) = self.ends(r);
            if ra == v || rb == v || conflicts.contains(&r) {
                return true;
            }
            let (c, d) = self.segment(r);
            segment_distance(a, b, c, d) >= self.clearance
        })
    }

    /// The segment a resource covers (a vertex: a point).
    fn segment(&self, r: Res) -> (Point, Point) {
        let nv = self.points.len() as u32;
        if r < nv {
            (self.points[r as usize], self.points[r as usize])
        } else {
            let (a, b) = self.lanes[(r - nv) as usize];
            (self.points[a as usize], self.points[b as usize])
        }
    }

    /// The vertices a resource touches (a vertex: itself; a lane: its ends).
    fn ends(&self, r: Res) -> (u32, u32) {
        let nv = self.points.len() as u32;
        if r < nv {
            (r, r)
        } else {
            self.lanes[(r - nv) as usize]
        }
    }

    /// Every pair closer than the clearance, found through a grid of buckets: each resource is
    /// filed under the buckets of points sampled along it (half a bucket apart), and looks for
    /// others in the buckets around its own samples. Memory and time grow with the lanes' total
    /// length over the bucket size, which is chosen so that this stays bounded
    /// ([`MAX_SAMPLES`]) however long and diagonal the lanes are.
    fn find_conflicts(&self) -> Vec<Vec<Res>> {
        let n = self.resources() as u32;
        let mut conflicts = vec![Vec::new(); n as usize];
        if self.points.is_empty() || !self.clearance.is_finite() || self.clearance <= 0.0 {
            return conflicts;
        }
        let segments: Vec<(Point, Point)> = (0..n).map(|r| self.segment(r)).collect();
        let grid = Buckets::new(&self.points, &segments, self.clearance);
        let mut cells: HashMap<(i64, i64), Vec<Res>> = HashMap::new();
        for (r, &(a, b)) in segments.iter().enumerate() {
            let mut last = None;
            for cell in grid.samples(a, b) {
                if last != Some(cell) {
                    cells.entry(cell).or_default().push(r as Res);
                    last = Some(cell);
                }
            }
        }
        // A point of one resource is within a quarter bucket of one of its samples: two
        // resources closer than the clearance have samples within clearance + half a bucket.
        let reach = (self.clearance / grid.size).ceil() as i64 + 1;
        for (r, &(a, b)) in segments.iter().enumerate() {
            let r = r as Res;
            let mut near: Vec<Res> = Vec::new();
            for (cx, cy) in grid.samples(a, b) {
                for x in cx - reach..=cx + reach {
                    for y in cy - reach..=cy + reach {
                        if let Some(list) = cells.get(&(x, y)) {
                            near.extend(list.iter().copied().filter(|&o| o != r));
                        }
                    }
                }
            }
            near.sort_unstable();
            near.dedup();
            let (ra, rb) = self.ends(r);
            for o in near {
                let (oa, ob) = self.ends(o);
                if ra == oa || ra == ob || rb == oa || rb == ob {
                    continue;
                }
                let (c, d) = segments[o as usize];
                if segment_distance(a, b, c, d) < self.clearance {
                    conflicts[r as usize].push(o);
                }
            }
        }
        conflicts
    }
}

#[cfg(test)]
impl Layout {
    /// Whether `r` and `o` conflict, by their distance alone (what the buckets must find).
    pub(super) fn brute_conflict(&self, r: Res, o: Res) -> bool {
        let ((ra, rb), (oa, ob)) = (self.ends(r), self.ends(o));
        let shared = ra == oa || ra == ob || rb == oa || rb == ob;
        let ((a, b), (c, d)) = (self.segment(r), self.segment(o));
        !shared && segment_distance(a, b, c, d) < self.clearance
    }

    /// How many samples the buckets took along every resource.
    pub(super) fn samples(&self) -> usize {
        let segments: Vec<(Point, Point)> = (0..self.resources() as Res).map(|r| self.segment(r)).collect();
        let grid = Buckets::new(&self.points, &segments, self.clearance);
        segments.iter().map(|&(a, b)| grid.samples(a, b).count()).sum()
    }
}

/// Square buckets over the graph's extent, at least a clearance wide, and wider on a large map
/// or one of long lanes, so that the samples along every lane stay within [`MAX_SAMPLES`].
struct Buckets {
    origin: Point,
    size: f64,
}

/// At most this many buckets across a map.
const MAX_BUCKETS_ACROSS: f64 = 2048.0;
/// About this many samples along all resources together at most (two per bucket a lane
/// crosses, one per vertex): a 2 km map of long diagonal lanes costs megabytes, not the billions
/// of entries that filing every lane under each bucket of its bounding box cost.
pub const MAX_SAMPLES: f64 = 2_000_000.0;

impl Buckets {
    fn new(points: &[Point], segments: &[(Point, Point)], clearance: f64) -> Buckets {
        let (mut min, mut max) = (points[0], points[0]);
        for p in points {
            min = Point::new(min.x.min(p.x), min.y.min(p.y));
            max = Point::new(max.x.max(p.x), max.y.max(p.y));
        }
        let span = (max.x - min.x).max(max.y - min.y);
        let length: f64 = segments.iter().map(|(a, b)| a.dist(*b)).sum();
        let size = clearance.max(span / MAX_BUCKETS_ACROSS).max(2.0 * length / MAX_SAMPLES);
        Buckets { origin: min, size }
    }

    fn cell(&self, p: Point) -> (i64, i64) {
        (((p.x - self.origin.x) / self.size).floor() as i64, ((p.y - self.origin.y) / self.size).floor() as i64)
    }

    /// The buckets of points along `a`–`b`, half a bucket apart, both ends included.
    fn samples(&self, a: Point, b: Point) -> impl Iterator<Item = (i64, i64)> + '_ {
        let steps = (a.dist(b) / (self.size / 2.0)).ceil().max(1.0) as usize;
        (0..=steps).map(move |k| {
            let t = k as f64 / steps as f64;
            self.cell(Point::new(a.x + t * (b.x - a.x), a.y + t * (b.y - a.y)))
        })
    }
}

/// Distance between segments `a`–`b` and `c`–`d` (zero where they cross).
pub fn segment_distance(a: Point, b: Point, c: Point, d: Point) -> f64 {
    let cross = |o: Point, p: Point, q: Point| (p.x - o.x) * (q.y - o.y) - (p.y - o.y) * (q.x - o.x);
    let (d1, d2, d3, d4) = (cross(c, d, a), cross(c, d, b), cross(a, b, c), cross(a, b, d));
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0)) && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0)) {
        return 0.0;
    }
    point_segment_distance(a, c, d).min(point_segment_distance(b, c, d)).min(point_segment_distance(c, a, b)).min(point_segment_distance(d, a, b))
}
