//! Occupancy grids prepared for planning. Obstacles (occupied and unknown cells) are inflated by
//! the robot radius; the map is then searched on a planning grid of `k × k` blocks (about a
//! robot radius wide, so a 2 000 × 1 000 map is searched fast), each block standing at its free
//! cell nearest its centre, neighbouring blocks joined when the straight segment between those
//! cells is free on the inflated map. Routes are smoothed to the fewest straight free segments.
//!
//! The distance fields are a Dijkstra over flat arrays rather than a generic search crate's: a
//! field settles every planning cell of the map, and a map keyed by node costs several times
//! more there; single routes use `pathfinding`'s A*.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use crate::error::MapError;
use crate::geom::Point;
use crate::grid::{OccupancyGrid, UNKNOWN};
use crate::limits;
use crate::space::{cells_on_segment, Field, Node, ROBOT_REACH_M};

const NONE: u32 = u32::MAX;
const DIRS: [(i64, i64); 8] = [(1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1)];

/// A grid map ready for planning.
#[derive(Debug, Clone)]
pub struct GridSpace {
    grid: OccupancyGrid,
    radius: f64,
    /// Fine cells with no room for a robot's centre (occupied, unknown, or within the radius).
    blocked: Vec<bool>,
    k: u32,
    cw: u32,
    ch: u32,
    /// Per planning cell: its representative fine cell, or [`NONE`].
    rep: Vec<u32>,
    /// Per planning cell: the length of the move to each of its 8 neighbours (infinite: none).
    moves: Vec<[f32; 8]>,
}

impl GridSpace {
    pub fn new(grid: &OccupancyGrid, radius: f64) -> Self {
        let (w, h) = (grid.width, grid.height);
        let blocked = inflate(grid, radius);
        let cells = w as usize * h as usize;
        let by_radius = (radius / grid.resolution).round().max(1.0) as u32;
        let by_size = ((cells as f64 / limits::MAX_PLANNING_CELLS as f64).sqrt().ceil() as u32).max(1);
        let k = by_radius.max(by_size).min(w.max(h)).max(1);
        let (cw, ch) = (w.div_ceil(k), h.div_ceil(k));
        let mut rep = vec![NONE; cw as usize * ch as usize];
        for br in 0..ch {
            for bc in 0..cw {
                let (c0, r0) = (bc * k, br * k);
                let (c1, r1) = ((c0 + k).min(w), (r0 + k).min(h));
                let (mc, mr) = ((c0 + c1) as f64 / 2.0, (r0 + r1) as f64 / 2.0);
                let mut best = (f64::INFINITY, NONE);
                for r in r0..r1 {
                    for c in c0..c1 {
                        let i = r as usize * w as usize + c as usize;
                        if !blocked[i] {
                            let d = (c as f64 + 0.5 - mc).powi(2) + (r as f64 + 0.5 - mr).powi(2);
                            if d < best.0 {
                                best = (d, i as u32);
                            }
                        }
                    }
                }
                rep[(br * cw + bc) as usize] = best.1;
            }
        }
        let mut space = GridSpace { grid: grid.clone(), radius, blocked, k, cw, ch, rep, moves: Vec::new() };
        space.moves = space.join();
        space
    }

    /// The moves between neighbouring planning cells whose representatives see each other.
    fn join(&self) -> Vec<[f32; 8]> {
        let n = self.rep.len();
        let mut moves = vec![[f32::INFINITY; 8]; n];
        for i in 0..n {
            if self.rep[i] == NONE {
                continue;
            }
            let (bc, br) = ((i as u32 % self.cw) as i64, (i as u32 / self.cw) as i64);
            let a = self.fine_center(self.rep[i]);
            for (d, &(dx, dy)) in DIRS.iter().enumerate().take(4) {
                let (nc, nr) = (bc + dx, br + dy);
                if nc < 0 || nr < 0 || nc >= self.cw as i64 || nr >= self.ch as i64 {
                    continue;
                }
                let j = (nr * self.cw as i64 + nc) as usize;
                if self.rep[j] == NONE {
                    continue;
                }
                let b = self.fine_center(self.rep[j]);
                if self.clear(a, b) {
                    let len = a.dist(b) as f32;
                    moves[i][d] = len;
                    moves[j][d + 4] = len;
                }
            }
        }
        moves
    }

    pub fn grid(&self) -> &OccupancyGrid {
        &self.grid
    }

    pub fn nodes(&self) -> usize {
        self.rep.len()
    }

    pub fn node_point(&self, i: u32) -> Option<Point> {
        self.rep.get(i as usize).filter(|&&r| r != NONE).map(|&r| self.fine_center(r))
    }

    pub fn cell_area(&self) -> f64 {
        (self.k as f64 * self.grid.resolution).powi(2)
    }

    fn fine_center(&self, i: u32) -> Point {
        self.grid.center(i % self.grid.width, i / self.grid.width)
    }

    /// Whether the segment a → b stays clear of the inflated obstacles.
    fn clear(&self, a: Point, b: Point) -> bool {
        let (ua, va) = self.grid.to_cells(a);
        let (ub, vb) = self.grid.to_cells(b);
        let (w, h) = (self.grid.width as i64, self.grid.height as i64);
        cells_on_segment(ua, va, ub, vb, |c, r| c >= 0 && r >= 0 && c < w && r < h && !self.blocked[(r * w + c) as usize])
    }

    /// See [`crate::Space::locate`]; `robot`: lenient (off the free space up to
    /// [`ROBOT_REACH_M`]).
    pub fn locate(&self, what: &str, index: usize, p: Point, robot: bool) -> Result<Node, MapError> {
        if !robot {
            match self.grid.at(p) {
                None => return Err(MapError::point(what, index, p, "is off the map")),
                Some(UNKNOWN) => return Err(MapError::point(what, index, p, "is in an unknown cell of the map")),
                Some(v) if !(0..crate::grid::FREE_BELOW).contains(&v) => {
                    return Err(MapError::point(what, index, p, format!("is in an occupied cell of the map (occupancy {v})")))
                }
                Some(_) => {}
            }
        }
        let block = self.k as f64 * self.grid.resolution;
        let reach = if robot { ROBOT_REACH_M } else { self.radius + 2.0 * block };
        let (u, v) = self.grid.to_cells(p);
        let (bc, br) = ((u / self.k as f64).floor() as i64, (v / self.k as f64).floor() as i64);
        let rings = (reach / block).ceil() as i64 + 1;
        // Nearest representative that a straight free segment reaches; for a robot, failing that,
        // the nearest one at all (it stands where the map says it cannot: it drives out).
        let mut best: Option<(f64, u32)> = None;
        let mut any: Option<(f64, u32)> = None;
        for ring in 0..=rings {
            if best.is_some_and(|(d, _)| (ring - 1) as f64 * block > d) {
                break;
            }
            for (c, r) in ring_cells(bc, br, ring) {
                if c < 0 || r < 0 || c >= self.cw as i64 || r >= self.ch as i64 {
                    continue;
                }
                let i = (r * self.cw as i64 + c) as u32;
                let Some(q) = self.node_point(i) else { continue };
                let d = p.dist(q);
                if d > reach {
                    continue;
                }
                if best.is_none_or(|(bd, _)| d < bd) && self.grid.segment_free(p, q) {
                    best = Some((d, i));
                }
                if any.is_none_or(|(ad, _)| d < ad) {
                    any = Some((d, i));
                }
            }
        }
        match (best, any, robot) {
            (Some((lead, entry)), _, _) | (None, Some((lead, entry)), true) => Ok(Node { at: p, entry, lead }),
            (None, _, true) => Err(MapError::point(what, index, p, format!("is more than {ROBOT_REACH_M} m from the map's free space"))),
            (None, _, false) => Err(MapError::point(what, index, p, format!("has no room around it for a robot of radius {} m", self.radius))),
        }
    }

    /// Dijkstra from `sources` over the planning cells; stops once every target is settled.
    pub fn field(&self, sources: &[Node], targets: &[Node]) -> Field {
        let n = self.rep.len();
        let mut dist = vec![f32::INFINITY; n];
        let mut owner = vec![NONE; n];
        let mut heap = BinaryHeap::new();
        for (s, node) in sources.iter().enumerate() {
            let e = node.entry as usize;
            let d = node.lead as f32;
            if e < n && d < dist[e] {
                dist[e] = d;
                owner[e] = s as u32;
                heap.push(Reverse((d.to_bits(), node.entry)));
            }
        }
        let mut wanted = vec![false; if targets.is_empty() { 0 } else { n }];
        let mut left = 0usize;
        for t in targets {
            if let Some(w) = wanted.get_mut(t.entry as usize) {
                if !*w {
                    *w = true;
                    left += 1;
                }
            }
        }
        let cw = self.cw as i64;
        while let Some(Reverse((bits, i))) = heap.pop() {
            let d = f32::from_bits(bits);
            let i = i as usize;
            if d > dist[i] {
                continue;
            }
            if !wanted.is_empty() && std::mem::replace(&mut wanted[i], false) {
                left -= 1;
                if left == 0 {
                    break;
                }
            }
            let (c, r) = ((i as i64) % cw, (i as i64) / cw);
            for (dir, &len) in self.moves[i].iter().enumerate() {
                if len.is_infinite() {
                    continue;
                }
                let j = ((r + DIRS[dir].1) * cw + c + DIRS[dir].0) as usize;
                let nd = d + len;
                if nd < dist[j] {
                    dist[j] = nd;
                    owner[j] = owner[i];
                    heap.push(Reverse((nd.to_bits(), j as u32)));
                }
            }
        }
        Field { dist: dist.into_iter().map(f64::from).collect(), owner }
    }

    /// A* from a to b over the planning cells, then the fewest straight segments clear of the
    /// inflated obstacles (the first and last, to and from the exact points, were checked free
    /// when they were located).
    pub fn route(&self, a: &Node, b: &Node) -> Option<Vec<Point>> {
        let goal = b.entry;
        let goal_at = self.node_point(goal)?;
        let cw = self.cw as i64;
        let mm = |v: f32| (f64::from(v) * 1000.0).ceil() as u64;
        let (cells, _) = pathfinding::directed::astar::astar(
            &a.entry,
            |&i| {
                let (c, r) = ((i as i64) % cw, (i as i64) / cw);
                self.moves[i as usize]
                    .iter()
                    .enumerate()
                    .filter(|(_, l)| l.is_finite())
                    .map(move |(d, &l)| ((((r + DIRS[d].1) * cw) + c + DIRS[d].0) as u32, mm(l)))
                    .collect::<Vec<_>>()
            },
            |&i| self.node_point(i).map_or(0, |p| (p.dist(goal_at) * 1000.0).floor() as u64),
            |&i| i == goal,
        )?;
        let mut pts = Vec::with_capacity(cells.len() + 2);
        pts.push(a.at);
        pts.extend(cells.iter().filter_map(|&i| self.node_point(i)));
        pts.push(b.at);
        Some(self.smooth(&pts))
    }

    fn smooth(&self, pts: &[Point]) -> Vec<Point> {
        let n = pts.len();
        if n <= 2 {
            return pts.to_vec();
        }
        let sees = |i: usize, j: usize| (i == 0 && j == 1) || (i == n - 2 && j == n - 1) || self.clear(pts[i], pts[j]);
        let mut out = vec![pts[0]];
        let mut i = 0;
        while i < n - 1 {
            let mut j = i + 1;
            while j + 1 < n && sees(i, j + 1) {
                j += 1;
            }
            out.push(pts[j]);
            i = j;
        }
        out
    }
}

/// Fine cells with no room for a robot's centre: not free, or within `radius` of a cell that is
/// not (a disk stamped around each obstacle cell at the edge of free space).
pub(crate) fn inflate(grid: &OccupancyGrid, radius: f64) -> Vec<bool> {
    let (w, h) = (grid.width as i64, grid.height as i64);
    let mut blocked: Vec<bool> = grid.data.iter().map(|&v| !(0..crate::grid::FREE_BELOW).contains(&v)).collect();
    let rc = (radius / grid.resolution).ceil() as i64;
    if rc <= 0 {
        return blocked;
    }
    let disk: Vec<(i64, i64)> = (-rc..=rc).flat_map(|dy| (-rc..=rc).map(move |dx| (dx, dy))).filter(|&(dx, dy)| dx * dx + dy * dy <= rc * rc).collect();
    let base = blocked.clone();
    for r in 0..h {
        for c in 0..w {
            if !base[(r * w + c) as usize] {
                continue;
            }
            let edge = [(1, 0), (-1, 0), (0, 1), (0, -1)].iter().any(|&(dx, dy)| {
                let (x, y) = (c + dx, r + dy);
                x >= 0 && y >= 0 && x < w && y < h && !base[(y * w + x) as usize]
            });
            if !edge {
                continue;
            }
            for &(dx, dy) in &disk {
                let (x, y) = (c + dx, r + dy);
                if x >= 0 && y >= 0 && x < w && y < h {
                    blocked[(y * w + x) as usize] = true;
                }
            }
        }
    }
    blocked
}

/// The cells at Chebyshev distance `ring` from (c, r).
fn ring_cells(c: i64, r: i64, ring: i64) -> Vec<(i64, i64)> {
    if ring == 0 {
        return vec![(c, r)];
    }
    let mut out = Vec::with_capacity(8 * ring as usize);
    for d in -ring..=ring {
        out.push((c + d, r - ring));
        out.push((c + d, r + ring));
    }
    for d in (-ring + 1)..ring {
        out.push((c - ring, r + d));
        out.push((c + ring, r + d));
    }
    out
}
