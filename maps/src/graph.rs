//! Navigation graphs: vertices in the plane joined by directed edges (lanes) of a length; an
//! undirected lane is two edges.

use crate::error::MapError;
use crate::geom::Point;
use crate::{limits, GraphSummary};

/// A vertex: where it is and, where the file gives one, its name.
#[derive(Debug, Clone, PartialEq)]
pub struct Vertex {
    pub name: String,
    pub at: Point,
    /// A robot charges here (Open-RMF's `is_charger`).
    pub charger: bool,
}

/// A directed edge of a length in metres.
#[derive(Debug, Clone, PartialEq)]
pub struct Edge {
    pub from: u32,
    pub to: u32,
    pub length: f64,
    /// The lane is wide enough for two robots side by side: where it runs both ways, robots
    /// meeting on it pass each other, each keeping to its right (the map says so: Open-RMF's
    /// lane property `passing: true`, or a derived roadmap's lane with room on both sides).
    pub passing: bool,
}

impl Edge {
    /// The lane it drives, drawn once: its ends, lower first.
    pub fn lane(&self) -> (u32, u32) {
        (self.from.min(self.to), self.from.max(self.to))
    }
}

/// A navigation graph.
#[derive(Debug, Clone, PartialEq)]
pub struct NavGraph {
    pub vertices: Vec<Vertex>,
    pub edges: Vec<Edge>,
}

impl NavGraph {
    /// The vertices where robots charge.
    pub fn chargers(&self) -> impl Iterator<Item = &Vertex> {
        self.vertices.iter().filter(|v| v.charger)
    }

    /// Checks sizes, coordinates, ends and lengths; `file` names the graph in errors.
    pub fn checked(self, file: &str) -> Result<Self, MapError> {
        if self.vertices.is_empty() {
            return Err(MapError::malformed(file, "vertices", "the graph has no vertex"));
        }
        if self.vertices.len() > limits::MAX_VERTICES {
            return Err(MapError::too_large(file, format!("{} vertices, at most {}", self.vertices.len(), limits::MAX_VERTICES)));
        }
        if self.edges.len() > limits::MAX_EDGES {
            return Err(MapError::too_large(file, format!("{} edges, at most {}", self.edges.len(), limits::MAX_EDGES)));
        }
        for (i, v) in self.vertices.iter().enumerate() {
            if !(v.at.is_finite() && v.at.x.abs() <= limits::MAX_COORDINATE && v.at.y.abs() <= limits::MAX_COORDINATE) {
                return Err(MapError::malformed(
                    file,
                    format!("vertex {i}"),
                    format!("({}, {}) is not a point within {} m of zero", v.at.x, v.at.y, limits::MAX_COORDINATE),
                ));
            }
        }
        let n = self.vertices.len() as u32;
        for e in &self.edges {
            if e.from >= n || e.to >= n {
                return Err(MapError::malformed(file, format!("edge {} → {}", e.from, e.to), format!("names a vertex beyond the {n} the graph has")));
            }
            if !(e.length.is_finite() && e.length >= 0.0) {
                return Err(MapError::malformed(file, format!("edge {} → {}", e.from, e.to), format!("length {} is not a distance", e.length)));
            }
        }
        Ok(self)
    }

    pub fn bounds(&self) -> (Point, Point) {
        let mut min = Point::new(f64::INFINITY, f64::INFINITY);
        let mut max = Point::new(f64::NEG_INFINITY, f64::NEG_INFINITY);
        for v in &self.vertices {
            min = Point::new(min.x.min(v.at.x), min.y.min(v.at.y));
            max = Point::new(max.x.max(v.at.x), max.y.max(v.at.y));
        }
        (min, max)
    }

    /// `self` with every lane at least `min_m` metres long that runs both ways marked passing
    /// ([`Edge::passing`]): for a floor plan whose corridors are known to be wide.
    pub fn with_passing(mut self, min_m: f64) -> NavGraph {
        let two_way = self.two_way_lanes();
        for e in &mut self.edges {
            let long = self.vertices[e.from as usize].at.dist(self.vertices[e.to as usize].at) >= min_m;
            e.passing |= long && two_way.contains(&e.lane());
        }
        self
    }

    /// The lanes ([`Edge::lane`]) driven both ways, between two vertices.
    pub fn two_way_lanes(&self) -> std::collections::HashSet<(u32, u32)> {
        let edges: std::collections::HashSet<(u32, u32)> = self.edges.iter().map(|e| (e.from, e.to)).collect();
        self.edges.iter().filter(|e| e.from != e.to && edges.contains(&(e.to, e.from))).map(Edge::lane).collect()
    }

    /// Lanes drawn once: each pair of vertices joined in either direction, with its ends.
    pub fn lanes(&self) -> Vec<(u32, u32)> {
        let mut out: Vec<(u32, u32)> = self.edges.iter().map(Edge::lane).filter(|(a, b)| a != b).collect();
        out.sort_unstable();
        out.dedup();
        out
    }

    pub fn summary(&self) -> GraphSummary {
        let length_m = self.lanes().iter().map(|&(a, b)| self.vertices[a as usize].at.dist(self.vertices[b as usize].at)).sum();
        let mut passing: Vec<(u32, u32)> = self.edges.iter().filter(|e| e.passing && e.from != e.to).map(Edge::lane).collect();
        passing.sort_unstable();
        passing.dedup();
        let passing = passing.len();
        GraphSummary { vertices: self.vertices.len(), edges: self.edges.len(), length_m, passing }
    }

    /// The vertex nearest to `p` and how far it is.
    pub fn nearest(&self, p: Point) -> (u32, f64) {
        let mut best = (0u32, f64::INFINITY);
        for (i, v) in self.vertices.iter().enumerate() {
            let d = v.at.dist(p);
            if d < best.1 {
                best = (i as u32, d);
            }
        }
        best
    }
}
