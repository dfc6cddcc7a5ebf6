//! A navigation graph laid out for traffic: its vertices and lanes as resources a robot holds,
//! and which resources are too close to be held by two robots at once.
//!
//! A resource is a vertex (`0..vertices`) or an undirected lane (`vertices..`). Two resources
//! **conflict** when robots on them could come closer than the clearance: vertices closer than
//! it, a vertex that close to a lane it is not an end of, lanes that close (crossing included)
//! that share no end. Resources that meet at a vertex do not conflict through it: a robot on a
//! lane holds both its ends, so the shared vertex keeps them apart.

use std::collections::HashMap;

use mrmm_maps::{NavGraph, Point};

/// A resource: a vertex or a lane.
pub type Res = u32;

/// A graph prepared for traffic.
#[derive(Debug, Clone)]
pub struct Layout {
    points: Vec<Point>,
    /// Lanes, each `(a, b)` with `a < b`.
    lanes: Vec<(u32, u32)>,
    lane_of: HashMap<(u32, u32), Res>,
    /// Directed edges out of each vertex.
    out: Vec<Vec<u32>>,
    /// For each resource, the others it conflicts with.
    conflicts: Vec<Vec<Res>>,
    clearance: f64,
    /// Vertices joining three or more lanes.
    junction: Vec<bool>,
}

impl Layout {
    /// Lays `graph` out for robots that must stay `clearance` metres apart (centre to centre).
    pub fn new(graph: &NavGraph, clearance: f64) -> Layout {
        let points: Vec<Point> = graph.vertices.iter().map(|v| v.at).collect();
        let lanes = graph.lanes();
        let nv = points.len() as u32;
        let lane_of = lanes.iter().enumerate().map(|(i, &l)| (l, nv + i as u32)).collect();
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
        let mut layout = Layout { points, lanes, lane_of, out, conflicts: Vec::new(), clearance, junction };
        layout.conflicts = layout.find_conflicts();
        layout
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
        self.lane_of.get(&(a.min(b), a.max(b))).copied()
    }

    /// Resources `r` conflicts with (not itself).
    pub fn conflicts(&self, r: Res) -> &[Res] {
        &self.conflicts[r as usize]
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

    /// Every pair closer than the clearance, found through a grid of buckets.
    fn find_conflicts(&self) -> Vec<Vec<Res>> {
        let n = self.resources() as u32;
        let mut conflicts = vec![Vec::new(); n as usize];
        if self.points.is_empty() || !self.clearance.is_finite() || self.clearance <= 0.0 {
            return conflicts;
        }
        let grid = Buckets::new(&self.points, self.clearance);
        let mut cells: HashMap<(i64, i64), Vec<Res>> = HashMap::new();
        for r in 0..n {
            let (a, b) = self.segment(r);
            for cell in grid.cells(a, b, 0.0) {
                cells.entry(cell).or_default().push(r);
            }
        }
        for r in 0..n {
            let (a, b) = self.segment(r);
            let mut near: Vec<Res> = grid.cells(a, b, self.clearance).filter_map(|c| cells.get(&c)).flatten().copied().filter(|&o| o != r).collect();
            near.sort_unstable();
            near.dedup();
            let (ra, rb) = self.ends(r);
            for o in near {
                let (oa, ob) = self.ends(o);
                if ra == oa || ra == ob || rb == oa || rb == ob {
                    continue;
                }
                let (c, d) = self.segment(o);
                if segment_distance(a, b, c, d) < self.clearance {
                    conflicts[r as usize].push(o);
                }
            }
        }
        conflicts
    }
}

/// Square buckets over the graph's extent, about a clearance wide (wider on a large map, so a
/// long lane covers a bounded number of them).
struct Buckets {
    origin: Point,
    size: f64,
}

/// At most this many buckets across a map.
const MAX_BUCKETS_ACROSS: f64 = 2048.0;

impl Buckets {
    fn new(points: &[Point], clearance: f64) -> Buckets {
        let (mut min, mut max) = (points[0], points[0]);
        for p in points {
            min = Point::new(min.x.min(p.x), min.y.min(p.y));
            max = Point::new(max.x.max(p.x), max.y.max(p.y));
        }
        let span = (max.x - min.x).max(max.y - min.y);
        Buckets { origin: min, size: clearance.max(span / MAX_BUCKETS_ACROSS) }
    }

    fn cell(&self, p: Point) -> (i64, i64) {
        (((p.x - self.origin.x) / self.size).floor() as i64, ((p.y - self.origin.y) / self.size).floor() as i64)
    }

    /// The buckets the box around segment `a`–`b`, grown by `margin`, covers.
    fn cells(&self, a: Point, b: Point, margin: f64) -> impl Iterator<Item = (i64, i64)> {
        let lo = self.cell(Point::new(a.x.min(b.x) - margin, a.y.min(b.y) - margin));
        let hi = self.cell(Point::new(a.x.max(b.x) + margin, a.y.max(b.y) + margin));
        (lo.0..=hi.0).flat_map(move |x| (lo.1..=hi.1).map(move |y| (x, y)))
    }
}

/// Distance from `p` to the segment `a`–`b`.
pub fn point_segment_distance(p: Point, a: Point, b: Point) -> f64 {
    let (dx, dy) = (b.x - a.x, b.y - a.y);
    let len2 = dx * dx + dy * dy;
    if len2 == 0.0 {
        return p.dist(a);
    }
    let t = (((p.x - a.x) * dx + (p.y - a.y) * dy) / len2).clamp(0.0, 1.0);
    p.dist(Point::new(a.x + t * dx, a.y + t * dy))
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
