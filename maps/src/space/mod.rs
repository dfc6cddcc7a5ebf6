//! Maps prepared for planning: where a point enters the map, distances from it to everywhere
//! (fields), distance matrices and routes. A grid map is searched on a planning grid of cells
//! about a robot radius wide whose moves are straight segments checked free on the inflated map;
//! a graph map along its edges.

mod graph;
pub(crate) mod grid;

use crate::error::MapError;
use crate::geom::Point;
use crate::Map;

pub use graph::GraphSpace;
pub use grid::GridSpace;

/// A waypoint on a graph map may be this far from the vertex it stands for, metres.
pub const SNAP_M: f64 = 2.0;
/// A robot may stand this far from the map's free space (it drives straight to it), metres.
pub const ROBOT_REACH_M: f64 = 5.0;

/// A point located on the map: where it is, which search node it enters by, and how far that
/// entry is (a straight, free segment).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Node {
    pub at: Point,
    pub entry: u32,
    pub lead: f64,
}

/// Distances from one point (or the nearest of several) to every search node, metres
/// (infinite where it cannot be reached).
#[derive(Debug, Clone)]
pub struct Field {
    pub dist: Vec<f64>,
    /// With several sources: which one is nearest to each node.
    pub owner: Vec<u32>,
}

impl Field {
    /// Distance from the source to `to`.
    pub fn to(&self, to: &Node) -> f64 {
        self.dist[to.entry as usize] + to.lead
    }
}

/// A map ready for planning.
#[derive(Debug, Clone)]
pub enum Space {
    Grid(GridSpace),
    Graph(GraphSpace),
}

impl Space {
    /// Prepares `map` for robots of radius `robot_radius` metres (obstacles are inflated by it on
    /// grid maps).
    pub fn new(map: &Map, robot_radius: f64) -> Result<Space, MapError> {
        if !(robot_radius.is_finite() && (0.0..=10.0).contains(&robot_radius)) {
            return Err(MapError::Invalid(format!("robot radius {robot_radius} m: give 0 to 10")));
        }
        Ok(match map {
            Map::Grid(g) => Space::Grid(GridSpace::new(g, robot_radius)),
            Map::Graph(g) => Space::Graph(GraphSpace::new(g)),
        })
    }

    pub fn is_graph(&self) -> bool {
        matches!(self, Space::Graph(_))
    }

    /// Locates waypoint or point `index` of `what`: refused in an occupied or unknown cell, off
    /// the map, too near walls for a robot, or (graph) too far from every vertex, which it is
    /// moved onto.
    pub fn locate(&self, what: &str, index: usize, p: Point) -> Result<Node, MapError> {
        if !p.is_finite() {
            return Err(MapError::point(what, index, p, "is not a point"));
        }
        match self {
            Space::Grid(g) => g.locate(what, index, p, false),
            Space::Graph(g) => g.locate(what, index, p, SNAP_M),
        }
    }

    /// Locates a robot: it may stand a little off the free space or the graph (it drives
    /// straight onto it), but not beyond [`ROBOT_REACH_M`] (grid maps).
    pub fn locate_robot(&self, id: &str, index: usize, p: Point) -> Result<Node, MapError> {
        if !p.is_finite() {
            return Err(MapError::point(&format!("robot {id}"), index, p, "is not a point"));
        }
        match self {
            Space::Grid(g) => g.locate(&format!("robot {id}"), index, p, true),
            Space::Graph(g) => g.locate(&format!("robot {id}"), index, p, f64::INFINITY),
        }
    }

    /// Distances from `from` to every search node; `targets` (if any) may stop the search once
    /// all of them are settled.
    pub fn field(&self, from: &Node, targets: &[Node]) -> Field {
        match self {
            Space::Grid(g) => g.field(&[*from], targets),
            Space::Graph(g) => g.field(&[*from], targets),
        }
    }

    /// Distances from the nearest of `sources` to every node, and which source is nearest.
    pub fn field_of(&self, sources: &[Node]) -> Field {
        match self {
            Space::Grid(g) => g.field(sources, &[]),
            Space::Graph(g) => g.field(sources, &[]),
        }
    }

    /// `d[i * n + j]`: the shortest distance from node i to node j (infinite if cut off).
    pub fn matrix(&self, nodes: &[Node]) -> Vec<f64> {
        let mut d = self.distances(nodes, nodes);
        for i in 0..nodes.len() {
            d[i * nodes.len() + i] = 0.0;
        }
        d
    }

    /// `d[i * to.len() + j]`: the shortest distance from `from[i]` to `to[j]`, one search per
    /// source, sources spread over the machine's cores (at most 8).
    pub fn distances(&self, from: &[Node], to: &[Node]) -> Vec<f64> {
        let rows = |range: std::ops::Range<usize>| -> Vec<f64> {
            let mut out = Vec::with_capacity(range.len() * to.len());
            for i in range {
                let f = self.field(&from[i], to);
                out.extend(to.iter().map(|t| f.to(t)));
            }
            out
        };
        let n = from.len();
        let threads = std::thread::available_parallelism().map_or(1, |t| t.get()).clamp(1, 8).min(n.max(1));
        if threads <= 1 || n < 4 {
            return rows(0..n);
        }
        let chunk = n.div_ceil(threads);
        std::thread::scope(|s| {
            let handles: Vec<_> = (0..threads).map(|t| (t * chunk).min(n)..((t + 1) * chunk).min(n)).map(|r| s.spawn(move || rows(r))).collect();
            handles.into_iter().flat_map(|h| h.join().unwrap_or_default()).collect()
        })
    }

    /// The route from `a` to `b`: its corner points, `a.at` first and `b.at` last, each
    /// consecutive pair joined by a straight free segment (grid) or an edge (graph). None when
    /// `b` cannot be reached from `a`.
    pub fn route(&self, a: &Node, b: &Node) -> Option<Vec<Point>> {
        self.route_lengths(a, b).map(|(r, _)| r)
    }

    /// [`Space::route`] with the length of each segment on the map's metric (`lengths[i]` from
    /// point i to point i + 1): its straight line on a grid, the edge's length on a graph.
    pub fn route_lengths(&self, a: &Node, b: &Node) -> Option<(Vec<Point>, Vec<f64>)> {
        let (pts, lens) = match self {
            Space::Grid(g) => {
                let r = g.route(a, b)?;
                let lens = r.windows(2).map(|w| w[0].dist(w[1])).collect();
                (r, lens)
            }
            Space::Graph(g) => g.route(a, b)?,
        };
        // Points on the same spot are one (their segment's length joins the next one's).
        let mut out = vec![pts[0]];
        let mut out_lens: Vec<f64> = Vec::with_capacity(lens.len());
        for (p, l) in pts.iter().skip(1).zip(lens) {
            if out.last().is_some_and(|q| q.dist(*p) < 1e-9) {
                if let Some(last) = out_lens.last_mut() {
                    *last += l;
                }
                continue;
            }
            out.push(*p);
            out_lens.push(l);
        }
        if out.len() == 1 {
            out.push(out[0]);
            out_lens.push(0.0);
        }
        Some((out, out_lens))
    }

    /// How many search nodes there are (planning cells with room for a robot, or vertices).
    pub fn nodes(&self) -> usize {
        match self {
            Space::Grid(g) => g.nodes(),
            Space::Graph(g) => g.nodes(),
        }
    }

    /// Where search node `i` is (None for a planning cell without room for a robot).
    pub fn node_point(&self, i: u32) -> Option<Point> {
        match self {
            Space::Grid(g) => g.node_point(i),
            Space::Graph(g) => Some(g.node_point(i)),
        }
    }

    /// The search node a located point stands on, as a node.
    pub fn node_at(&self, i: u32) -> Option<Node> {
        self.node_point(i).map(|at| Node { at, entry: i, lead: 0.0 })
    }

    /// Area each search node stands for, m² (grid: a planning cell; graph: 0).
    pub fn node_area(&self) -> f64 {
        match self {
            Space::Grid(g) => g.cell_area(),
            Space::Graph(_) => 0.0,
        }
    }

    /// `n` points of the map reachable from `from`, nearest first along the map, each at least
    /// `spacing` metres from the others (where robots can stand side by side: a start area).
    pub fn spread(&self, from: Point, n: usize, spacing: f64) -> Result<Vec<Point>, MapError> {
        let start = self.locate_robot("start", 0, from)?;
        let f = self.field(&start, &[]);
        let mut order: Vec<(f64, Point)> =
            (0..self.nodes() as u32).filter_map(|i| Some((f.dist[i as usize], self.node_point(i)?))).filter(|(d, _)| d.is_finite()).collect();
        order.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut out: Vec<Point> = Vec::with_capacity(n);
        for (_, p) in order {
            if out.len() == n {
                break;
            }
            if out.iter().all(|q| q.dist(p) >= spacing) {
                out.push(p);
            }
        }
        if out.len() < n {
            return Err(MapError::Invalid(format!("the map has room for {} points {spacing} m apart around ({}, {}), not {n}", out.len(), from.x, from.y)));
        }
        Ok(out)
    }

    /// `n` points reachable from `from` that `keep` accepts, spread out: each the farthest along
    /// the map from those before (the first, the farthest from `from`).
    pub fn farthest(&self, from: Point, n: usize, keep: impl Fn(Point) -> bool) -> Result<Vec<Point>, MapError> {
        let start = self.locate_robot("start", 0, from)?;
        let reach = self.field(&start, &[]);
        let cands: Vec<Node> =
            (0..self.nodes() as u32).filter_map(|i| self.node_at(i)).filter(|v| reach.dist[v.entry as usize].is_finite() && keep(v.at)).collect();
        let mut best: Vec<f64> = cands.iter().map(|v| reach.dist[v.entry as usize]).collect();
        let mut chosen = vec![false; cands.len()];
        let mut out = Vec::with_capacity(n);
        while out.len() < n {
            let Some(k) = (0..cands.len()).filter(|&k| !chosen[k]).max_by(|&a, &b| best[a].total_cmp(&best[b]).then(b.cmp(&a))) else { break };
            chosen[k] = true;
            out.push(cands[k].at);
            let f = self.field(&cands[k], &[]);
            for (b, v) in best.iter_mut().zip(&cands) {
                *b = b.min(f.dist[v.entry as usize]);
            }
        }
        if out.len() < n {
            return Err(MapError::Invalid(format!("the map has {} distinct points there, not {n}", out.len())));
        }
        Ok(out)
    }

    /// Whether the straight segment a → b crosses no occupied, unknown or off-map cell (grid
    /// maps; always true on graphs, which say nothing of walls).
    pub fn segment_free(&self, a: Point, b: Point) -> bool {
        match self {
            Space::Grid(g) => g.grid().segment_free(a, b),
            Space::Graph(_) => true,
        }
    }
}

/// Calls `ok(col, row)` for every cell the segment (u0, v0) → (u1, v1) (in cell units) touches,
/// in order, both cells at a corner it passes exactly through; false as soon as one says no.
pub fn cells_on_segment(u0: f64, v0: f64, u1: f64, v1: f64, mut ok: impl FnMut(i64, i64) -> bool) -> bool {
    if !(u0.is_finite() && v0.is_finite() && u1.is_finite() && v1.is_finite()) {
        return false;
    }
    let (mut x, mut y) = (u0.floor() as i64, v0.floor() as i64);
    let (ex, ey) = (u1.floor() as i64, v1.floor() as i64);
    if !ok(x, y) {
        return false;
    }
    let (dx, dy) = (u1 - u0, v1 - v0);
    let (sx, sy) = (if dx > 0.0 { 1 } else { -1 }, if dy > 0.0 { 1 } else { -1 });
    let t_delta_x = if dx != 0.0 { 1.0 / dx.abs() } else { f64::INFINITY };
    let t_delta_y = if dy != 0.0 { 1.0 / dy.abs() } else { f64::INFINITY };
    let mut t_max_x = if dx > 0.0 {
        ((u0.floor() + 1.0) - u0) * t_delta_x
    } else if dx < 0.0 {
        (u0 - u0.floor()) * t_delta_x
    } else {
        f64::INFINITY
    };
    let mut t_max_y = if dy > 0.0 {
        ((v0.floor() + 1.0) - v0) * t_delta_y
    } else if dy < 0.0 {
        (v0 - v0.floor()) * t_delta_y
    } else {
        f64::INFINITY
    };
    let steps = (ex - x).abs() + (ey - y).abs() + 2;
    for _ in 0..steps {
        if x == ex && y == ey {
            return true;
        }
        // The segment ends in this cell: rounding (an end on a cell's corner, a diagonal through
        // corners) kept the walk from naming the end's cell, and it would walk on past the end.
        if t_max_x.min(t_max_y) > 1.0 + 1e-9 {
            break;
        }
        if (t_max_x - t_max_y).abs() < 1e-12 {
            if !ok(x + sx, y) || !ok(x, y + sy) {
                return false;
            }
            x += sx;
            y += sy;
            t_max_x += t_delta_x;
            t_max_y += t_delta_y;
        } else if t_max_x < t_max_y {
            x += sx;
            t_max_x += t_delta_x;
        } else {
            y += sy;
            t_max_y += t_delta_y;
        }
        if !ok(x, y) {
            return false;
        }
    }
    ok(ex, ey)
}

#[cfg(test)]
mod tests;
