//! A navigation graph derived from an occupancy grid's free space, for traffic on maps that
//! have no lanes: the skeleton of the space a robot's centre can reach (obstacles inflated by
//! its radius, thinned to a line one cell wide by Zhang and Suen's algorithm), cut at its
//! junctions and ends into branches, short spurs pruned, each branch simplified to the fewest
//! straight lanes that stay in that space (Douglas–Peucker, split again where a lane would leave
//! it). Lanes run both ways along corridors' middles and through doors; a lane with room for a
//! robot's centre [`Params::passing`] to each side of it all along is marked passing
//! ([`Edge::passing`]): two robots meeting on it pass each other.
//!
//! Pure: a grid in, a [`NavGraph`] out; bounded by the grid's own limits (a grid above
//! [`WORK_CELLS`] is thinned on blocks of cells).

use std::collections::{BTreeMap, VecDeque};

use crate::error::MapError;
use crate::geom::{point_segment_distance, right_of, Point};
use crate::graph::{Edge, NavGraph, Vertex};
use crate::grid::OccupancyGrid;

/// Most cells thinned at once; larger grids are thinned on square blocks of cells, a block free
/// only if all its cells are.
pub const WORK_CELLS: usize = 4_000_000;

/// How the graph is derived.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Params {
    /// Robots' radius, m: lanes keep their centres this far from any cell that is not free.
    pub radius: f64,
    /// Dead-end branches shorter than this are dropped (the skeleton's whiskers into corners), m.
    pub prune: f64,
    /// Lanes stray at most this far from the skeleton they follow, m.
    pub tolerance: f64,
    /// A lane is marked passing where a robot's centre fits this far to either side of it all
    /// along, m (mrmm's traffic lays each way of a passing lane out that far to its right:
    /// `mrmm_core::traffic::layout::PASSING_OFFSET_M`); 0: no lane is.
    pub passing: f64,
}

impl Default for Params {
    fn default() -> Self {
        Params { radius: 0.3, prune: 1.0, tolerance: 0.15, passing: 0.35 }
    }
}

/// The work grid: which cells a robot's centre may be in, `w × h`, each `cell` m wide.
struct Work<'a> {
    grid: &'a OccupancyGrid,
    w: usize,
    h: usize,
    /// Fine cells per work cell, across.
    k: usize,
    open: Vec<bool>,
}

impl Work<'_> {
    fn point(&self, i: usize) -> Point {
        let (c, r) = (i % self.w, i / self.w);
        let k = self.k as f64;
        self.grid.from_cells((c as f64 + 0.5) * k, (r as f64 + 0.5) * k)
    }

    fn cell_m(&self) -> f64 {
        self.grid.resolution * self.k as f64
    }

    /// Whether the straight line a → b stays in open work cells.
    fn clear(&self, a: Point, b: Point) -> bool {
        let k = self.k as f64;
        let ((ua, va), (ub, vb)) = (self.grid.to_cells(a), self.grid.to_cells(b));
        crate::space::cells_on_segment(ua / k, va / k, ub / k, vb / k, |c, r| {
            c >= 0 && r >= 0 && (c as usize) < self.w && (r as usize) < self.h && self.open[r as usize * self.w + c as usize]
        })
    }

    /// The 8 neighbours of cell `i` that are set in `set`, clockwise from north.
    fn ring(&self, set: &[bool], i: usize) -> [bool; 8] {
        let (c, r) = ((i % self.w) as i64, (i / self.w) as i64);
        let mut out = [false; 8];
        for (n, (dc, dr)) in RING.iter().enumerate() {
            let (x, y) = (c + dc, r + dr);
            out[n] = x >= 0 && y >= 0 && (x as usize) < self.w && (y as usize) < self.h && set[y as usize * self.w + x as usize];
        }
        out
    }

    fn neighbours<'s>(&'s self, set: &'s [bool], i: usize) -> impl Iterator<Item = usize> + 's {
        let (c, r) = ((i % self.w) as i64, (i / self.w) as i64);
        let (w, h) = (self.w as i64, self.h as i64);
        RING.iter()
            .filter_map(move |(dc, dr)| {
                let (x, y) = (c + dc, r + dr);
                (x >= 0 && y >= 0 && x < w && y < h).then(|| (y * w + x) as usize)
            })
            .filter(move |&j| set[j])
    }
}

/// Clockwise from north (rows grow upwards): N, NE, E, SE, S, SW, W, NW.
const RING: [(i64, i64); 8] = [(0, 1), (1, 1), (1, 0), (1, -1), (0, -1), (-1, -1), (-1, 0), (-1, 1)];

/// Derives the navigation graph of `grid`'s free space; `file` names the map in errors.
pub fn derive(file: &str, grid: &OccupancyGrid, p: &Params) -> Result<NavGraph, MapError> {
    let finite = [p.radius, p.prune, p.tolerance, p.passing].iter().all(|x| x.is_finite() && *x >= 0.0);
    if !(finite && p.tolerance > 0.0) {
        return Err(MapError::Invalid(format!("{file}: radius, prune, tolerance and passing must be finite, ≥ 0 (tolerance > 0): {p:?}")));
    }
    let work = work_grid(grid, p.radius);
    if !work.open.iter().any(|&o| o) {
        return Err(MapError::Invalid(format!("{file}: no free space a robot of radius {} m fits in: no lanes to derive", p.radius)));
    }
    let skeleton = thin(&work, work.open.clone());
    let mut branches = trace(&work, &skeleton);
    prune(&mut branches, p.prune / work.cell_m());
    let mut graph = lanes(file, &work, &branches, p.tolerance)?;
    if p.passing > 0.0 {
        mark_passing(&work, &mut graph, p.passing);
    }
    if graph.edges.is_empty() {
        return Err(MapError::Invalid(format!("{file}: the free space a robot of radius {} m fits in holds no lane of {} m or more", p.radius, p.prune)));
    }
    graph.checked(file)
}

/// The grid's cells a robot's centre may be in, on blocks of cells when the grid is large.
fn work_grid(grid: &OccupancyGrid, radius: f64) -> Work<'_> {
    let fine = crate::space::grid::inflate(grid, radius);
    let (fw, fh) = (grid.width as usize, grid.height as usize);
    let k = ((fw * fh) as f64 / WORK_CELLS as f64).sqrt().ceil().max(1.0) as usize;
    let (w, h) = (fw.div_ceil(k), fh.div_ceil(k));
    let mut open = vec![true; w * h];
    for r in 0..fh {
        for c in 0..fw {
            if fine[r * fw + c] {
                open[(r / k) * w + c / k] = false;
            }
        }
    }
    // Blocks cut by the grid's edge are not open (their outside is unknown).
    for r in 0..h {
        for c in 0..w {
            if (c + 1) * k > fw || (r + 1) * k > fh {
                open[r * w + c] = false;
            }
        }
    }
    Work { grid, w, h, k, open }
}

/// Zhang–Suen thinning: peels `set`'s border cells in two alternating sub-steps until only a
/// line one cell wide is left, keeping it connected. Only cells next to one peeled are looked at
/// again (inner cells cannot be peeled), so the cost follows the border, not the area.
fn thin(work: &Work, mut set: Vec<bool>) -> Vec<bool> {
    let border = |set: &[bool], i: usize| work.ring(set, i).iter().any(|&x| !x);
    let mut look: Vec<usize> = (0..set.len()).filter(|&i| set[i] && border(&set, i)).collect();
    let mut marked = vec![false; set.len()];
    let (mut pass, mut idle) = (0, 0);
    // Until both sub-steps in a row peel nothing.
    while idle < 2 {
        let peel: Vec<usize> = look
            .iter()
            .copied()
            .filter(|&i| {
                let n = work.ring(&set, i);
                let b = n.iter().filter(|&&x| x).count();
                let a = (0..8).filter(|&j| !n[j] && n[(j + 1) % 8]).count();
                let (n_, e, s, w) = (n[0], n[2], n[4], n[6]);
                // Sub-step one keeps cells whose east and south are set with north or west; two, the
                // mirror.
                let cond = if pass == 0 { !(e && s && (n_ || w)) } else { !(n_ && w && (e || s)) };
                (2..=6).contains(&b) && a == 1 && cond
            })
            .collect();
        for &i in &peel {
            set[i] = false;
        }
        idle = if peel.is_empty() { idle + 1 } else { 0 };
        pass = 1 - pass;
        // Next: the cells still set among those looked at and next to the ones peeled.
        let around: Vec<usize> = peel.iter().flat_map(|&p| work.neighbours(&set, p).collect::<Vec<_>>()).collect();
        let mut next = Vec::with_capacity(look.len());
        for &i in look.iter().chain(&around) {
            if set[i] && !marked[i] {
                marked[i] = true;
                next.push(i);
            }
        }
        for &i in &next {
            marked[i] = false;
        }
        look = next;
    }
    set
}

/// A branch of the skeleton: the cells from one node to another (both ends included).
#[derive(Debug, Clone)]
struct Branch {
    a: usize,
    b: usize,
    cells: Vec<usize>,
}

/// Cuts the skeleton at its nodes (cells with other than two neighbours, adjacent ones merged)
/// into branches; a node is named by its cell nearest its centre.
fn trace(work: &Work, skel: &[bool]) -> Vec<Branch> {
    let mut t = Tracer { work, skel, node: nodes(work, skel), seen: vec![false; skel.len()] };
    let mut branches = Vec::new();
    let starts: Vec<usize> = t.node.keys().copied().collect();
    for &s in &starts {
        for n in work.neighbours(skel, s).collect::<Vec<_>>() {
            if t.node.get(&n) == Some(&t.node[&s]) || t.seen[n] {
                continue;
            }
            branches.extend(t.walk(s, n));
        }
    }
    // Loops without a node: one of their cells becomes one.
    for i in 0..skel.len() {
        if skel[i] && !t.seen[i] && !t.node.contains_key(&i) {
            t.node.insert(i, i);
            if let Some(n) = work.neighbours(skel, i).next() {
                branches.extend(t.walk(i, n));
            }
        }
    }
    branches
}

/// The skeleton's node cells, each mapped to its cluster's name: the cluster's cell nearest
/// its centre.
fn nodes(work: &Work, skel: &[bool]) -> BTreeMap<usize, usize> {
    let degree = |i: usize| work.neighbours(skel, i).count();
    let mut clusters: Vec<Vec<usize>> = Vec::new();
    let mut taken = vec![false; skel.len()];
    for i in (0..skel.len()).filter(|&i| skel[i] && degree(i) != 2) {
        if taken[i] {
            continue;
        }
        taken[i] = true;
        let (mut cells, mut queue) = (vec![i], VecDeque::from([i]));
        while let Some(j) = queue.pop_front() {
            for n in work.neighbours(skel, j).collect::<Vec<_>>() {
                if degree(n) != 2 && !taken[n] {
                    taken[n] = true;
                    cells.push(n);
                    queue.push_back(n);
                }
            }
        }
        clusters.push(cells);
    }
    let mut node = BTreeMap::new();
    for cells in clusters {
        let (sx, sy) = cells.iter().fold((0.0, 0.0), |(x, y), &c| (x + (c % work.w) as f64, y + (c / work.w) as f64));
        let (cx, cy) = (sx / cells.len() as f64, sy / cells.len() as f64);
        let d = |c: usize| ((c % work.w) as f64 - cx).powi(2) + ((c / work.w) as f64 - cy).powi(2);
        let name = cells.iter().copied().min_by(|&a, &b| d(a).total_cmp(&d(b)).then(a.cmp(&b))).unwrap_or(cells[0]);
        node.extend(cells.into_iter().map(|c| (c, name)));
    }
    node
}

/// Walks the skeleton from node to node.
struct Tracer<'a> {
    work: &'a Work<'a>,
    skel: &'a [bool],
    node: BTreeMap<usize, usize>,
    /// Cells between nodes already on a branch.
    seen: Vec<bool>,
}

impl Tracer<'_> {
    /// The branch leaving node cell `start` through `first`, from its node's name to the next
    /// node's (none: walked already from its other end).
    fn walk(&mut self, start: usize, first: usize) -> Option<Branch> {
        let a = self.node[&start];
        let (mut prev, mut cur) = (start, first);
        let mut cells = self.inside(a, start);
        loop {
            if let Some(&b) = self.node.get(&cur) {
                let mut back = self.inside(b, cur);
                back.reverse();
                cells.extend(back);
                return Some(Branch { a, b, cells });
            }
            if self.seen[cur] {
                return None;
            }
            self.seen[cur] = true;
            cells.push(cur);
            match self.work.neighbours(self.skel, cur).find(|&n| n != prev) {
                Some(n) => (prev, cur) = (cur, n),
                None => return Some(Branch { a, b: a, cells }),
            }
        }
    }

    /// The way through a cluster from its named cell `from` to its cell `to`.
    fn inside(&self, from: usize, to: usize) -> Vec<usize> {
        let name = self.node[&from];
        let mut parent: BTreeMap<usize, usize> = BTreeMap::from([(from, from)]);
        let mut queue = VecDeque::from([from]);
        while let Some(c) = queue.pop_front() {
            if c == to {
                break;
            }
            for n in self.work.neighbours(self.skel, c) {
                if self.node.get(&n) == Some(&name) && !parent.contains_key(&n) {
                    parent.insert(n, c);
                    queue.push_back(n);
                }
            }
        }
        let (mut path, mut c) = (vec![to], to);
        while c != from {
            let Some(&p) = parent.get(&c) else { break };
            path.push(p);
            c = p;
        }
        path.reverse();
        path
    }
}

/// Drops dead-end branches shorter than `shortest` cells (again, as pruning makes new dead
/// ends), then joins branches through nodes left with two.
fn prune(branches: &mut Vec<Branch>, shortest: f64) {
    for _ in 0..3 {
        let degree = degrees(branches);
        let before = branches.len();
        branches.retain(|b| {
            let (da, db) = (degree[&b.a], degree[&b.b]);
            let dead_end = (da == 1 && db >= 3) || (db == 1 && da >= 3);
            // A loop back to its own node round less than a robot's turn: the skeleton's knot.
            let stub = b.a == b.b && (b.cells.len() as f64) < shortest.max(8.0);
            !(stub || (dead_end && (b.cells.len() as f64) < shortest))
        });
        if branches.len() == before {
            break;
        }
    }
    // Join through nodes of degree two, in node order (a join changes no other node's degree).
    let through: Vec<usize> = degrees(branches).into_iter().filter(|&(_, d)| d == 2).map(|(n, _)| n).collect();
    for n in through {
        let two: Vec<usize> = (0..branches.len()).filter(|&i| branches[i].a == n || branches[i].b == n).collect();
        let [i, j] = two[..] else { continue };
        if branches[i].a == branches[i].b || branches[j].a == branches[j].b {
            continue; // a loop back to its own node
        }
        let mut x = branches[i].clone();
        let mut y = branches.swap_remove(j);
        if x.b != n {
            x.cells.reverse();
            std::mem::swap(&mut x.a, &mut x.b);
        }
        if y.a != n {
            y.cells.reverse();
            std::mem::swap(&mut y.a, &mut y.b);
        }
        x.cells.extend(y.cells.into_iter().skip(1));
        x.b = y.b;
        branches[i] = x;
    }
}

/// How many branch ends meet at each node.
fn degrees(branches: &[Branch]) -> BTreeMap<usize, usize> {
    let mut d = BTreeMap::new();
    for b in branches {
        *d.entry(b.a).or_insert(0) += 1;
        *d.entry(b.b).or_insert(0) += 1;
    }
    d
}

/// The graph: a vertex per node and per corner of each branch's simplified line, lanes both
/// ways between them.
fn lanes(file: &str, work: &Work, branches: &[Branch], tolerance: f64) -> Result<NavGraph, MapError> {
    let mut g = NavGraph { vertices: Vec::new(), edges: Vec::new() };
    let mut of_node: BTreeMap<usize, u32> = BTreeMap::new();
    let vertex = |g: &mut NavGraph, at: Point, name: String| -> u32 {
        g.vertices.push(Vertex { name, at, charger: false });
        g.vertices.len() as u32 - 1
    };
    for b in branches {
        let pts: Vec<Point> = b.cells.iter().map(|&c| work.point(c)).collect();
        let keep = simplify(work, &pts, tolerance);
        if keep.len() < 2 {
            continue;
        }
        let mut ids = Vec::with_capacity(keep.len());
        for (n, &k) in keep.iter().enumerate() {
            let end = if n == 0 {
                Some(b.a)
            } else if n + 1 == keep.len() {
                Some(b.b)
            } else {
                None
            };
            let id = match end {
                Some(node) => match of_node.get(&node) {
                    Some(&id) => id,
                    None => {
                        let id = vertex(&mut g, work.point(node), String::new());
                        of_node.insert(node, id);
                        id
                    }
                },
                None => vertex(&mut g, pts[k], String::new()),
            };
            ids.push(id);
        }
        ids.dedup();
        for w in ids.windows(2) {
            let length = g.vertices[w[0] as usize].at.dist(g.vertices[w[1] as usize].at);
            g.edges.push(Edge { from: w[0], to: w[1], length, passing: false });
            g.edges.push(Edge { from: w[1], to: w[0], length, passing: false });
        }
    }
    if g.vertices.len() > crate::limits::MAX_VERTICES {
        return Err(MapError::TooLarge {
            file: file.to_string(),
            problem: format!("the derived graph has {} vertices; at most {}", g.vertices.len(), crate::limits::MAX_VERTICES),
        });
    }
    // Names by degree: junctions, ends, points along a corridor.
    let mut degree = vec![0usize; g.vertices.len()];
    for e in &g.edges {
        degree[e.from as usize] += 1;
    }
    for (i, v) in g.vertices.iter_mut().enumerate() {
        let kind = match degree[i] {
            0 | 1 => "end",
            2 => "way",
            _ => "junction",
        };
        v.name = format!("{kind}_{i}");
    }
    Ok(g)
}

/// `graph` (drawn on `grid`'s floor plan, in its frame) with each lane that runs both ways marked
/// passing where the floor has room for it: a robot of `radius` fits `offset` metres to either
/// side of it all along, as [`derive`] marks its own lanes. Lanes are marked as they were drawn
/// (those marked passing already stay so); none is added or moved.
pub fn mark_passing_on(grid: &OccupancyGrid, mut graph: NavGraph, radius: f64, offset: f64) -> NavGraph {
    mark_passing(&work_grid(grid, radius), &mut graph, offset);
    graph
}

/// Marks passing each lane of `g` that runs both ways with room for a robot `offset` metres to
/// either side ([`roomy`]); those marked already stay so.
fn mark_passing(work: &Work, g: &mut NavGraph, offset: f64) {
    let two_way = g.two_way_lanes();
    let points: Vec<Point> = g.vertices.iter().map(|v| v.at).collect();
    for e in &mut g.edges {
        e.passing = e.passing || (two_way.contains(&e.lane()) && roomy(work, points[e.from as usize], points[e.to as usize], offset));
    }
}

/// Whether lane `a`–`b` and its two sides, `offset` metres to either side of its line, stay in
/// open work cells, and so do the lines halfway out: an obstacle, grown by the robot's radius in
/// the work cells, is wider than the gaps between these lines unless that radius is under a
/// quarter of `offset`.
fn roomy(work: &Work, a: Point, b: Point, offset: f64) -> bool {
    if a == b {
        return false;
    }
    let n = right_of(a, b);
    let (nx, ny) = (n.x * offset, n.y * offset);
    let side = |k: f64| work.clear(Point::new(a.x + k * nx, a.y + k * ny), Point::new(b.x + k * nx, b.y + k * ny));
    [0.0, 1.0, -1.0, 0.5, -0.5].into_iter().all(side)
}

/// Douglas–Peucker on `pts`: the positions kept, each straight piece within `tolerance` of the
/// points it replaces and in open cells.
fn simplify(work: &Work, pts: &[Point], tolerance: f64) -> Vec<usize> {
    let mut keep = vec![0, pts.len() - 1];
    let mut stack = vec![(0, pts.len() - 1)];
    while let Some((i, j)) = stack.pop() {
        if j <= i + 1 {
            continue;
        }
        let (far, d) =
            (i + 1..j).map(|k| (k, point_segment_distance(pts[k], pts[i], pts[j]))).fold((i + 1, -1.0), |best, x| if x.1 > best.1 { x } else { best });
        if d > tolerance || !work.clear(pts[i], pts[j]) {
            keep.push(far);
            stack.push((i, far));
            stack.push((far, j));
        }
    }
    keep.sort_unstable();
    keep.dedup();
    // Corners a few centimetres apart (where a branch leaves its junction) are one.
    let mut out: Vec<usize> = vec![keep[0]];
    for (n, &k) in keep.iter().enumerate().skip(1) {
        let last = *out.last().unwrap_or(&0);
        let inner = n + 1 < keep.len();
        if inner && pts[last].dist(pts[k]) < 2.0 * tolerance && work.clear(pts[last], pts[keep[n + 1]]) {
            continue;
        }
        out.push(k);
    }
    out
}

#[cfg(test)]
mod tests;
