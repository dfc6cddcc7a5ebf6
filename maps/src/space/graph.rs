//! Navigation graphs prepared for planning: shortest paths along their directed edges
//! (petgraph's Dijkstra and A*).

use petgraph::graph::{DiGraph, NodeIndex};

use crate::error::MapError;
use crate::geom::Point;
use crate::graph::NavGraph;
use crate::space::{Field, Node};

/// What a path through a vertex to avoid costs beyond its length, metres: longer than any way
/// round on a floor plan.
pub const AVOIDED_M: f64 = 1.0e6;

/// A graph map ready for planning.
#[derive(Debug, Clone)]
pub struct GraphSpace {
    map: NavGraph,
    g: DiGraph<Point, f64, u32>,
}

impl GraphSpace {
    pub fn new(map: &NavGraph) -> Self {
        let mut g = DiGraph::with_capacity(map.vertices.len(), map.edges.len());
        for v in &map.vertices {
            g.add_node(v.at);
        }
        for e in &map.edges {
            g.add_edge(NodeIndex::new(e.from as usize), NodeIndex::new(e.to as usize), e.length);
        }
        GraphSpace { map: map.clone(), g }
    }

    pub fn graph(&self) -> &NavGraph {
        &self.map
    }

    pub fn nodes(&self) -> usize {
        self.map.vertices.len()
    }

    pub fn node_point(&self, i: u32) -> Point {
        self.map.vertices[i as usize].at
    }

    /// The vertex nearest to `p`, if within `snap` metres: a waypoint becomes that vertex; a
    /// robot (any distance) enters the graph there.
    pub fn locate(&self, what: &str, index: usize, p: Point, snap: f64) -> Result<Node, MapError> {
        let (v, d) = self.map.nearest(p);
        if snap.is_infinite() {
            return Ok(Node { at: p, entry: v, lead: d });
        }
        if d > snap {
            let vx = &self.map.vertices[v as usize];
            return Err(MapError::point(
                what,
                index,
                p,
                format!("is {d:.1} m from the nearest vertex ({} at ({:.2}, {:.2})); on a graph map waypoints are its vertices", vx.name, vx.at.x, vx.at.y),
            ));
        }
        Ok(Node { at: self.node_point(v), entry: v, lead: 0.0 })
    }

    /// Distances along the edges from the nearest of `sources` (each entering at its vertex
    /// after its lead) to every vertex.
    pub fn field(&self, sources: &[Node], _targets: &[Node]) -> Field {
        let n = self.nodes();
        let mut dist = vec![f64::INFINITY; n];
        let mut owner = vec![u32::MAX; n];
        for (s, src) in sources.iter().enumerate() {
            let from = NodeIndex::new(src.entry as usize);
            for (v, d) in petgraph::algo::dijkstra(&self.g, from, None, |e| *e.weight()) {
                let d = d + src.lead;
                if d < dist[v.index()] {
                    dist[v.index()] = d;
                    owner[v.index()] = s as u32;
                }
            }
        }
        Field { dist, owner }
    }

    /// The shortest path along the directed edges from vertex `a` to vertex `b`, as vertices
    /// (both ends included), or none if `b` cannot be reached.
    pub fn vertex_path(&self, a: u32, b: u32) -> Option<Vec<u32>> {
        self.vertex_path_avoiding(a, b, |_| false)
    }

    /// [`GraphSpace::vertex_path`], through no vertex `avoid` names (but `b`) where another way
    /// exists: each such vertex costs [`AVOIDED_M`] more.
    pub fn vertex_path_avoiding(&self, a: u32, b: u32, avoid: impl Fn(u32) -> bool) -> Option<Vec<u32>> {
        use petgraph::visit::EdgeRef;
        let n = self.nodes() as u32;
        if a >= n || b >= n {
            return None;
        }
        let to = NodeIndex::new(b as usize);
        let cost = |e: petgraph::graph::EdgeReference<'_, f64>| {
            let v = e.target().index() as u32;
            *e.weight() + if v != b && avoid(v) { AVOIDED_M } else { 0.0 }
        };
        let (_, path) = petgraph::algo::astar(&self.g, NodeIndex::new(a as usize), |x| x == to, cost, |_| 0.0)?;
        Some(path.iter().map(|x| x.index() as u32).collect())
    }

    /// The shortest path along the edges: a's point, the vertices, b's point; with the length of
    /// each segment (an edge's own length, the leads' straight lines).
    pub fn route(&self, a: &Node, b: &Node) -> Option<(Vec<Point>, Vec<f64>)> {
        let (from, to) = (NodeIndex::new(a.entry as usize), NodeIndex::new(b.entry as usize));
        let (_, path) = petgraph::algo::astar(&self.g, from, |n| n == to, |e| *e.weight(), |_| 0.0)?;
        let mut out = Vec::with_capacity(path.len() + 2);
        let mut lengths = Vec::with_capacity(path.len() + 1);
        out.push(a.at);
        out.extend(path.iter().map(|n| self.g[*n]));
        out.push(b.at);
        lengths.push(a.lead);
        for w in path.windows(2) {
            let edge = self.g.edges_connecting(w[0], w[1]).map(|e| *e.weight()).fold(f64::INFINITY, f64::min);
            lengths.push(edge);
        }
        lengths.push(b.lead);
        Some((out, lengths))
    }
}
