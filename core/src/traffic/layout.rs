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
