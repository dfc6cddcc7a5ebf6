//! Planning on a map: waypoints located on it, the tour solved on shortest-path distances and
//! laid out as the closed route through the corridors, and robots' distances and routes to
//! points of that route.

use mrmm_maps::{MapError, Node, Space};

use crate::error::PlanError;
use crate::geom::Point;
use crate::polyline::Polyline;
use crate::tsp::{self, Budget, Instance};
use mrmm_proto::plan::RobotSpec;

/// A patrol tour on a map.
#[derive(Debug, Clone)]
pub struct MapTour {
    /// The waypoints in visiting order, where the map put them (graph: their vertices).
    pub waypoints: Vec<Point>,
    /// The closed route: every corner, waypoints among them, the last joined back to the first.
    pub route: Vec<Point>,
    /// The length of each of its segments on the map's metric (`lengths[i]`: from point i to
    /// the next, the last back to the first): a straight line's on a grid, an edge's own length
    /// on a graph (which may be longer than the straight line between its ends).
    pub lengths: Vec<f64>,
}

/// Locates the waypoints (refusing any in a wall, off the map, or cut off from the others),
/// solves the tour on their shortest-path distances and lays it out along the map.
pub fn tour(space: &Space, waypoints: &[Point], budget: &Budget) -> Result<MapTour, PlanError> {
    let nodes = waypoints.iter().enumerate().map(|(i, &p)| space.locate("waypoint", i, p)).collect::<Result<Vec<_>, _>>()?;
    for i in 0..nodes.len() {
        if let Some(j) = (0..i).find(|&j| nodes[j].entry == nodes[i].entry && space.is_graph()) {
            return Err(PlanError::Invalid(format!("waypoints {j} and {i} are both vertex at ({}, {}) of the graph", nodes[i].at.x, nodes[i].at.y)));
        }
    }
    let n = nodes.len();
    let d = space.matrix(&nodes);
    for j in 1..n {
        if !(d[j].is_finite() && d[j * n].is_finite()) {
            let p = waypoints[j];
            return Err(MapError::Point {
                what: "waypoint".into(),
                index: j,
                x: p.x,
                y: p.y,
                problem: "cannot be reached from waypoint 0 and back on the map".into(),
            }
            .into());
        }
    }
    // The solver's metric is symmetric: the mean of both ways; the tour then runs the shorter way.
    let sym: Vec<f64> = (0..n * n).map(|k| 0.5 * (d[k] + d[(k % n) * n + k / n])).collect();
    let order = if n <= 1 {
        (0..n).collect()
    } else {
        let inst = Instance::with_matrix(nodes.iter().map(|v| v.at).collect(), sym)?;
        tsp::solve(&inst, budget)?.0.order
    };
    let forward: f64 = (0..n).map(|k| d[order[k] * n + order[(k + 1) % n]]).sum();
    let backward: f64 = (0..n).map(|k| d[order[(k + 1) % n] * n + order[k]]).sum();
    let order: Vec<usize> = if backward < forward - 1e-9 { std::iter::once(order[0]).chain(order[1..].iter().rev().copied()).collect() } else { order };
    let mut route: Vec<Point> = Vec::new();
    let mut lengths: Vec<f64> = Vec::new();
    for k in 0..n {
        let (a, b) = (&nodes[order[k]], &nodes[order[(k + 1) % n]]);
        let (leg, lens) =
            space.route_lengths(a, b).ok_or_else(|| PlanError::Invalid(format!("no route from waypoint {} to waypoint {}", order[k], order[(k + 1) % n])))?;
        for (p, l) in leg.into_iter().zip(std::iter::once(0.0).chain(lens)) {
            match route.last() {
                None => route.push(p),
                // The same spot again (a leg starts where the last one ended): one point.
                Some(q) if q.dist(p) < 1e-9 => {
                    if let Some(last) = lengths.last_mut() {
                        *last += l;
                    }
                }
                Some(_) => {
                    route.push(p);
                    lengths.push(l);
                }
            }
        }
    }
    // The last point is the first again: the polyline closes itself.
    if route.len() > 1 && route[route.len() - 1].dist(route[0]) < 1e-9 {
        route.pop();
    } else {
        lengths.push(route[route.len() - 1].dist(route[0]));
    }
    if route.len() < 2 {
        return Err(PlanError::TooFewPoints { min: 2, got: route.len() });
    }
    Ok(MapTour { waypoints: order.iter().map(|&i| nodes[i].at).collect(), route, lengths })
}

/// How robots get to points of a closed route: in the plane straight, on a map by the shortest
/// path to the nearer end of the route's segment, then along it.
pub enum Approach<'a> {
    Plane,
    Map {
        space: &'a Space,
        robots: Vec<Node>,
        corners: Vec<Node>,
        /// `d[r * corners + c]`: robot r to corner c.
        d: Vec<f64>,
    },
}

impl<'a> Approach<'a> {
    /// Prepares the distances from every robot to every corner of `path` (one search per robot).
    pub fn new(space: Option<&'a Space>, robots: &[RobotSpec], path: &Polyline) -> Result<Self, PlanError> {
        let Some(space) = space else { return Ok(Approach::Plane) };
        let nodes = robots.iter().enumerate().map(|(i, r)| space.locate_robot(r.id.as_str(), i, Point::new(r.x, r.y))).collect::<Result<Vec<_>, _>>()?;
        let corners = path.points.iter().enumerate().map(|(i, &p)| space.locate_robot("corner", i, p)).collect::<Result<Vec<_>, _>>()?;
        let d = space.distances(&nodes, &corners);
        Ok(Approach::Map { space, robots: nodes, corners, d })
    }

    /// The segment of `path` holding arc `s` (taken modulo the length) and how far along it.
    fn segment(path: &Polyline, s: f64) -> (usize, f64) {
        let s = if path.length > 0.0 { s.rem_euclid(path.length) } else { 0.0 };
        let i = match path.arcs.binary_search_by(|a| a.total_cmp(&s)) {
            Ok(i) => i.min(path.points.len() - 1),
            Err(i) => i - 1,
        };
        (i, s - path.arcs[i])
    }

    /// Distance from robot `r` (at `from`) to the point at arc `s`; which corner it enters the
    /// route by (None: straight).
    pub fn cost(&self, r: usize, from: Point, path: &Polyline, s: f64) -> (f64, Option<usize>) {
        match self {
            Approach::Plane => (from.dist(path.at(s)), None),
            Approach::Map { corners, d, .. } => {
                let m = corners.len();
                let (i, along) = Self::segment(path, s);
                let j = (i + 1) % m;
                let seg = path.arcs[i + 1] - path.arcs[i];
                let (via_i, via_j) = (d[r * m + i] + along, d[r * m + j] + (seg - along).max(0.0));
                if via_i <= via_j {
                    (via_i, Some(i))
                } else {
                    (via_j, Some(j))
                }
            }
        }
    }

    /// The corner points robot `r` drives through to the point at arc `s`, ending there.
    pub fn route(&self, r: usize, from: Point, path: &Polyline, s: f64) -> Vec<Point> {
        let target = path.at(s);
        let (_, via) = self.cost(r, from, path, s);
        match (self, via) {
            (Approach::Map { space, robots, corners, .. }, Some(c)) => {
                let mut pts = space.route(&robots[r], &corners[c]).unwrap_or_else(|| vec![from, corners[c].at]);
                pts.remove(0);
                if pts.last().is_none_or(|p| p.dist(target) > 1e-6) {
                    pts.push(target);
                }
                pts
            }
            _ => vec![target],
        }
    }
}
