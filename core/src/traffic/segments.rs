//! Lanes cut for traffic: long lanes into short segments robots follow one another along, and
//! passing lanes into two sides, one each way, that robots meeting on them pass each other on.

use std::collections::{HashMap, HashSet};

use mrmm_maps::geom::right_of;
use mrmm_maps::graph::{Edge, Vertex};
use mrmm_maps::{NavGraph, Point};

/// How far to the right of a passing lane's line each way of it runs, metres: the two ways lie
/// a little more than the clearance apart ([`super::CLEARANCE`]), so robots on them pass.
pub const PASSING_OFFSET_M: f64 = super::CLEARANCE / 2.0 + 0.05;

/// What a robot driving a passing lane's side against its way pays per metre of it (it backs
/// out or steps aside on it; routes take the side of their way).
pub const WRONG_SIDE: f64 = 1.5;

/// Longest segment of a passing lane's side, metres: robots on a side drive one way, so they only
/// follow one another there, and closer the shorter its segments (on a lane driven both ways,
/// segments this short let robots in deeper against oncoming ones, into gridlocks: lanes are cut
/// at what the caller asks).
pub const SIDE_SEGMENT_M: f64 = 1.0;

/// Sharpest bend, as the cosine of half the turn, at which the sides of two passing lanes go on
/// through the vertex between them (120°: the sides' corners stay within twice the offset).
const THROUGH_COS: f64 = 0.5;

/// `graph` with every lane longer than `longest` metres cut into equal segments no longer than
/// that, at vertices added after the graph's own (named `<from>~<to>/<k>`): robots then follow
/// one another along a lane a segment apart instead of one lane apart. A lane and its way back
/// share their cut vertices; lengths are split in proportion.
///
/// A passing lane (one that runs both ways, marked [`Edge::passing`] either way) becomes two
/// sides instead, one per way, each [`PASSING_OFFSET_M`] to the right of the line, cut at
/// `longest` or [`SIDE_SEGMENT_M`], the shorter (cut vertices named `<from>><to>/<k>`): robots
/// meeting on it pass each other; a robot may drive a side against its way at [`WRONG_SIDE`]
/// times the cost. Where a vertex joins two passing lanes and nothing else, each side goes on
/// through a corner of its own beside it (named `<vertex>><next>`), joined to the vertex by a
/// short spoke both ways, so that robots pass there too and still reach the vertex.
pub fn segmented(graph: &NavGraph, longest: f64) -> NavGraph {
    let mut g = NavGraph { vertices: graph.vertices.clone(), edges: Vec::new() };
    let mut sides = Sides::new(graph);
    // The cut vertices of each undirected lane, from its lower end to its higher one.
    let mut cuts: HashMap<(u32, u32), Vec<u32>> = HashMap::new();
    for e in &graph.edges {
        let (pa, pb) = (graph.vertices[e.from as usize].at, graph.vertices[e.to as usize].at);
        let pieces = |longest: f64| if longest > 0.0 && e.from != e.to { (pa.dist(pb) / longest).ceil().max(1.0) as u32 } else { 1 };
        if sides.passing.contains(&e.lane()) {
            sides.side(&mut g, e, pieces(longest.min(SIDE_SEGMENT_M)));
            continue;
        }
        let pieces = pieces(longest);
        let (a, b) = e.lane();
        let inner = cuts.entry((a, b)).or_insert_with(|| cut(graph, &mut g, (a, b), pieces, 0.0, '~'));
        let mut way: Vec<u32> = std::iter::once(a).chain(inner.iter().copied()).chain(std::iter::once(b)).collect();
        if e.from != a {
            way.reverse();
        }
        let piece = e.length / (way.len() - 1) as f64;
        for w in way.windows(2) {
            g.edges.push(Edge { from: w[0], to: w[1], length: piece, passing: false });
        }
    }
    g
}

/// The passing lanes of a graph and the corners their sides go on through.
struct Sides<'a> {
    graph: &'a NavGraph,
    /// Passing lanes, each `(a, b)` with `a < b`.
    passing: HashSet<(u32, u32)>,
    /// Each vertex that joins two passing lanes and nothing else, at a bend of at most 120°: its
    /// two neighbours.
    through: HashMap<u32, (u32, u32)>,
    /// The corner beside vertex `v` of the side heading on to `n`, by `(v, n)`.
    corners: HashMap<(u32, u32), u32>,
}

impl<'a> Sides<'a> {
    fn new(graph: &'a NavGraph) -> Sides<'a> {
        let two_way = graph.two_way_lanes();
        let passing: HashSet<(u32, u32)> = graph
            .edges
            .iter()
            .filter(|e| e.passing && two_way.contains(&e.lane()))
            .filter(|e| graph.vertices[e.from as usize].at.dist(graph.vertices[e.to as usize].at) > 0.0)
            .map(Edge::lane)
            .collect();
        let mut next: HashMap<u32, Vec<(u32, bool)>> = HashMap::new();
        for (a, b) in graph.lanes() {
            let on = passing.contains(&(a, b));
            next.entry(a).or_default().push((b, on));
            next.entry(b).or_default().push((a, on));
        }
        let mut sides = Sides { graph, passing, through: HashMap::new(), corners: HashMap::new() };
        for (v, n) in next {
            if let [(p, true), (q, true)] = n[..] {
                if sides.corner_offset(p, v, q).is_some() {
                    sides.through.insert(v, (p, q));
                }
            }
        }
        sides
    }

    fn at(&self, v: u32) -> Point {
        self.graph.vertices[v as usize].at
    }

    /// Where, from vertex `v`, the side of way `p → v → n` turns: the unit vector to its right
    /// between the two lanes' and how far along it (none: a bend sharper than 120°).
    fn corner_offset(&self, p: u32, v: u32, n: u32) -> Option<(Point, f64)> {
        let (r1, r2) = (right_of(self.at(p), self.at(v)), right_of(self.at(v), self.at(n)));
        let (mx, my) = (r1.x + r2.x, r1.y + r2.y);
        let m = mx.hypot(my);
        if m < 1e-9 {
            return None;
        }
        let unit = Point::new(mx / m, my / m);
        let cos = unit.x * r1.x + unit.y * r1.y;
        (cos >= THROUGH_COS).then_some((unit, PASSING_OFFSET_M / cos))
    }

    /// The end of a side at vertex `v` heading on to `n`: its corner beside `v` where the side
    /// goes on through, else `v` itself.
    fn end(&mut self, g: &mut NavGraph, v: u32, n: u32) -> (u32, bool) {
        let Some(&(p, q)) = self.through.get(&v) else { return (v, false) };
        if let Some(&c) = self.corners.get(&(v, n)) {
            return (c, true);
        }
        let prev = if n == q { p } else { q };
        let Some((unit, d)) = self.corner_offset(prev, v, n) else { return (v, false) };
        let at = self.at(v);
        g.vertices.push(Vertex {
            charger: false,
            name: format!("{}>{}", self.graph.vertices[v as usize].name, self.graph.vertices[n as usize].name),
            at: Point::new(at.x + unit.x * d, at.y + unit.y * d),
        });
        let c = g.vertices.len() as u32 - 1;
        self.corners.insert((v, n), c);
        // The spoke that lets robots reach the vertex from the side and leave it onto it.
        g.edges.push(Edge { from: v, to: c, length: d, passing: false });
        g.edges.push(Edge { from: c, to: v, length: d, passing: false });
        (c, true)
    }

    /// The side of passing lane `e` driven its way, in `pieces` at least (two where it starts or
    /// ends on the lane's own vertex, so that it leaves the line): its way at the lane's length,
    /// and back at [`WRONG_SIDE`] times it.
    fn side(&mut self, g: &mut NavGraph, e: &Edge, pieces: u32) {
        let (start, offset_start) = self.end(g, e.from, e.to);
        let after = self.through.get(&e.to).map(|&(p, q)| if p == e.from { q } else { p });
        let (end, offset_end) = match after {
            Some(n) => self.end(g, e.to, n),
            None => (e.to, false),
        };
        let pieces = if offset_start && offset_end { pieces } else { pieces.max(2) };
        let inner = cut(self.graph, g, (e.from, e.to), pieces, PASSING_OFFSET_M, '>');
        let way: Vec<u32> = std::iter::once(start).chain(inner).chain(std::iter::once(end)).collect();
        let piece = e.length / f64::from(pieces);
        for w in way.windows(2) {
            g.edges.push(Edge { from: w[0], to: w[1], length: piece, passing: false });
            g.edges.push(Edge { from: w[1], to: w[0], length: WRONG_SIDE * piece, passing: false });
        }
    }
}

/// Adds to `g` the `pieces - 1` vertices cutting lane `a → b` of `graph` into equal pieces,
/// `right` metres to the right of its line, named `<a><mark><b>/<k>`; returns them from `a`.
fn cut(graph: &NavGraph, g: &mut NavGraph, (a, b): (u32, u32), pieces: u32, right: f64, mark: char) -> Vec<u32> {
    let (va, vb) = (&graph.vertices[a as usize], &graph.vertices[b as usize]);
    let (pa, pb) = (va.at, vb.at);
    let n = right_of(pa, pb);
    let (nx, ny) = (n.x * right, n.y * right);
    (1..pieces)
        .map(|k| {
            let t = f64::from(k) / f64::from(pieces);
            let at = Point::new(pa.x + t * (pb.x - pa.x) + nx, pa.y + t * (pb.y - pa.y) + ny);
            g.vertices.push(Vertex { charger: false, name: format!("{}{mark}{}/{k}", va.name, vb.name), at });
            g.vertices.len() as u32 - 1
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::traffic::layout::Layout;
    use crate::traffic::CLEARANCE;

    /// A 3 m lane marked passing, both ways, cut at 2 m: each way its own side, [`PASSING_OFFSET_M`]
    /// to its right, of three segments ([`SIDE_SEGMENT_M`] at most; the lane single file would be
    /// two), driven back at [`WRONG_SIDE`] the cost; the
    /// middles of the two sides do not conflict (robots pass there; at the lane's ends they meet
    /// at its vertices).
    #[test]
    fn a_passing_lane_is_two_sides_each_to_the_right_of_its_way() {
        let v = |name: &str, x: f64| Vertex { charger: false, name: name.into(), at: Point::new(x, 0.0) };
        let e = |from: u32, to: u32| Edge { from, to, length: 3.0, passing: true };
        let g = NavGraph { vertices: vec![v("a", 0.0), v("b", 3.0)], edges: vec![e(0, 1), e(1, 0)] };
        let s = segmented(&g, 2.0);
        let names: Vec<&str> = s.vertices.iter().map(|v| v.name.as_str()).collect();
        assert_eq!(names, ["a", "b", "a>b/1", "a>b/2", "b>a/1", "b>a/2"]);
        // a → b drives east: its right is south; b → a's is north.
        for (i, x, y) in [(2, 1.0, -PASSING_OFFSET_M), (3, 2.0, -PASSING_OFFSET_M), (4, 2.0, PASSING_OFFSET_M), (5, 1.0, PASSING_OFFSET_M)] {
            assert!(s.vertices[i].at.dist(Point::new(x, y)) < 1e-9, "{:?}", s.vertices[i]);
        }
        let cost = |from: u32, to: u32| s.edges.iter().find(|e| e.from == from && e.to == to).map(|e| e.length);
        assert_eq!((cost(0, 2), cost(2, 3), cost(3, 1)), (Some(1.0), Some(1.0), Some(1.0)));
        assert_eq!((cost(1, 3), cost(3, 2), cost(2, 0)), (Some(1.5), Some(1.5), Some(1.5)));
        assert_eq!((cost(1, 4), cost(4, 5), cost(5, 0)), (Some(1.0), Some(1.0), Some(1.0)));
        assert_eq!(cost(0, 1), None, "no lane down the middle");
        let layout = Layout::new(&s, CLEARANCE);
        let lane = |a: u32, b: u32| layout.lane(a, b).expect("lane");
        assert!(!layout.conflicts(lane(2, 3)).contains(&lane(4, 5)), "the middles pass");
        assert!(!layout.conflicts(2).contains(&5) && !layout.conflicts(3).contains(&4));
        // A lane marked passing one way only is no passing lane: it is cut down its middle.
        let one_way = NavGraph { edges: vec![e(0, 1)], ..g.clone() };
        assert_eq!(segmented(&one_way, 2.0).vertices[2].name, "a~b/1");
    }

    /// A 5 m lane cut at 2 m is three segments of 5/3 m, its way back through the same two new
    /// vertices (after the graph's own); a short lane stays whole.
    #[test]
    fn long_lanes_are_cut_into_segments_both_ways_through_the_same_vertices() {
        let v = |name: &str, x: f64| Vertex { charger: false, name: name.into(), at: Point::new(x, 0.0) };
        let e = |from: u32, to: u32, length: f64| Edge { from, to, length, passing: false };
        let g = NavGraph { vertices: vec![v("a", 0.0), v("b", 5.0), v("c", 6.0)], edges: vec![e(0, 1, 5.0), e(1, 0, 5.0), e(1, 2, 1.0)] };
        let s = segmented(&g, 2.0);
        assert_eq!(s.vertices.len(), 5, "{:?}", s.vertices);
        assert_eq!(&s.vertices[..3], &g.vertices[..]);
        assert!((s.vertices[3].at.x - 5.0 / 3.0).abs() < 1e-9 && (s.vertices[4].at.x - 10.0 / 3.0).abs() < 1e-9);
        let way = |from: u32| -> Vec<(u32, u32)> {
            let mut at = from;
            let mut hops = Vec::new();
            while let Some(e) = s.edges.iter().find(|e| e.from == at && !hops.iter().any(|&(a, _)| a == e.to) && e.to != 2) {
                hops.push((e.from, e.to));
                at = e.to;
                if at == 0 || at == 1 {
                    break;
                }
            }
            hops
        };
        assert_eq!(way(0), [(0, 3), (3, 4), (4, 1)]);
        assert_eq!(way(1), [(1, 4), (4, 3), (3, 0)]);
        assert!(s.edges.iter().filter(|e| e.from != 2 && e.to != 2).all(|e| (e.length - 5.0 / 3.0).abs() < 1e-9));
        assert!(s.edges.iter().any(|e| e.from == 1 && e.to == 2 && e.length == 1.0), "the short lane stays whole");
    }

    /// Two passing lanes at a right angle, a → b → c, and nothing else at b: each way's side goes
    /// on through a corner of its own beside b (on the outside of the bend for a → c, the inside
    /// for c → a), never through b itself; spokes join b to both corners, so robots still reach
    /// it; the two corners are farther apart than the clearance.
    #[test]
    fn the_sides_of_passing_lanes_go_on_through_a_vertex_between_them() {
        let v = |name: &str, x: f64, y: f64| Vertex { charger: false, name: name.into(), at: Point::new(x, y) };
        let e = |from: u32, to: u32| Edge { from, to, length: 2.0, passing: true };
        let g = NavGraph { vertices: vec![v("a", 0.0, 0.0), v("b", 2.0, 0.0), v("c", 2.0, 2.0)], edges: vec![e(0, 1), e(1, 0), e(1, 2), e(2, 1)] };
        let s = segmented(&g, 2.0);
        let find = |name: &str| s.vertices.iter().position(|v| v.name == name).unwrap_or_else(|| panic!("no {name}: {:?}", s.vertices)) as u32;
        let (out, inside) = (find("b>c"), find("b>a"));
        let o = PASSING_OFFSET_M;
        assert!(s.vertices[out as usize].at.dist(Point::new(2.0 + o, -o)) < 1e-9, "{:?}", s.vertices[out as usize]);
        assert!(s.vertices[inside as usize].at.dist(Point::new(2.0 - o, o)) < 1e-9, "{:?}", s.vertices[inside as usize]);
        let has = |from: u32, to: u32| s.edges.iter().any(|e| e.from == from && e.to == to);
        // a → b's side ends at the corner, b → c's starts there; neither way touches b.
        assert!(has(find("a>b/1"), out) && has(out, find("b>c/1")));
        assert!(has(find("c>b/1"), inside) && has(inside, find("b>a/1")));
        assert!([out, inside].iter().all(|&c| has(1, c) && has(c, 1)), "spokes to b");
        assert_eq!(s.edges.iter().filter(|e| e.from == 1 || e.to == 1).count(), 4, "b is reached by its spokes only");
        let layout = Layout::new(&s, CLEARANCE);
        assert!(!layout.conflicts(out).contains(&inside));
        // A third lane at b: the sides end at b again.
        let mut three = g.clone();
        three.vertices.push(v("d", 4.0, 0.0));
        three.edges.push(Edge { from: 1, to: 3, length: 2.0, passing: false });
        assert!(segmented(&three, 2.0).vertices.iter().all(|v| !v.name.contains("b>c") || v.name.contains('/')));
    }
}
