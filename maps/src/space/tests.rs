use super::*;
use crate::graph::{Edge, NavGraph, Vertex};
use crate::grid::OccupancyGrid;
use crate::Map;

/// A 20 × 10 m room at 0.1 m cells, split by a wall at x = 10 m with a door at y ∈ [7, 9] m.
fn two_rooms() -> OccupancyGrid {
    let (w, h) = (200u32, 100u32);
    let mut data = vec![0i8; (w * h) as usize];
    for r in 0..h {
        for c in 0..w {
            let border = c == 0 || r == 0 || c == w - 1 || r == h - 1;
            let wall = (99..=101).contains(&c) && !(70..90).contains(&r);
            if border || wall {
                data[(r * w + c) as usize] = 100;
            }
        }
    }
    OccupancyGrid { width: w, height: h, resolution: 0.1, origin: [0.0, 0.0, 0.0], data }
}

fn space(g: &OccupancyGrid, radius: f64) -> Space {
    Space::new(&Map::Grid(g.clone()), radius).expect("space")
}

fn free_route(g: &OccupancyGrid, r: &[Point]) -> bool {
    r.windows(2).all(|w| g.segment_free(w[0], w[1]))
}

#[test]
fn a_route_goes_through_the_door_not_the_wall() {
    let g = two_rooms();
    let s = space(&g, 0.3);
    let a = s.locate("waypoint", 0, Point::new(5.0, 2.0)).unwrap();
    let b = s.locate("waypoint", 1, Point::new(15.0, 2.0)).unwrap();
    let r = s.route(&a, &b).expect("route");
    assert_eq!(r[0], a.at);
    assert_eq!(*r.last().unwrap(), b.at);
    assert!(free_route(&g, &r), "{r:?}");
    assert!(r.iter().any(|p| p.y > 6.5 && (9.0..=11.0).contains(&p.x)), "through the door: {r:?}");
    let len = crate::geom::length(&r);
    // Straight line 10 m; through the door at least 2 × hypot(5, 5.3).
    assert!(len > 2.0 * 5f64.hypot(5.0) && len < 17.0, "{len}");
    // The field agrees with the route's length within the planning grid's slack.
    let f = s.field(&a, &[b]);
    assert!((f.to(&b) - len).abs() < 1.5, "field {} route {len}", f.to(&b));
    // Smoothed: a handful of corners, not a staircase of cells.
    assert!(r.len() <= 6, "{r:?}");
}

#[test]
fn waypoints_in_walls_off_the_map_or_without_room_are_refused_by_index() {
    let mut g = two_rooms();
    g.data[(50 * 200 + 50) as usize] = -1;
    let s = space(&g, 0.3);
    let e = s.locate("waypoint", 3, Point::new(10.0, 2.0)).unwrap_err().to_string();
    assert_eq!(e, "waypoint 3 at (10, 2) is in an occupied cell of the map (occupancy 100)");
    let e = s.locate("waypoint", 4, Point::new(5.05, 5.05)).unwrap_err().to_string();
    assert_eq!(e, "waypoint 4 at (5.05, 5.05) is in an unknown cell of the map");
    let e = s.locate("waypoint", 5, Point::new(-3.0, 2.0)).unwrap_err().to_string();
    assert_eq!(e, "waypoint 5 at (-3, 2) is off the map");
    // A free cell between two walls 0.3 m apart: no room for a robot of radius 0.3.
    let mut g2 = two_rooms();
    for r in 0..100u32 {
        for c in [50u32, 54] {
            g2.data[(r * 200 + c) as usize] = 100;
        }
    }
    let e = space(&g2, 0.3).locate("waypoint", 6, Point::new(5.25, 5.0)).unwrap_err().to_string();
    assert!(e.starts_with("waypoint 6 at (5.25, 5) has no room around it"), "{e}");
}

#[test]
fn a_closed_room_is_cut_off() {
    let mut g = two_rooms();
    for r in 70..90u32 {
        for c in 99..=101u32 {
            g.data[(r * 200 + c) as usize] = 100;
        }
    }
    let s = space(&g, 0.3);
    let nodes = [s.locate("waypoint", 0, Point::new(5.0, 2.0)).unwrap(), s.locate("waypoint", 1, Point::new(15.0, 2.0)).unwrap()];
    assert!(s.route(&nodes[0], &nodes[1]).is_none());
    let m = s.matrix(&nodes);
    assert!(m[1].is_infinite() && m[2].is_infinite() && m[0] == 0.0);
}

#[test]
fn a_robot_off_the_free_space_enters_at_the_nearest_free_cell() {
    let g = two_rooms();
    let s = space(&g, 0.3);
    let n = s.locate_robot("r1", 0, Point::new(10.0, 2.0)).expect("robot in the wall still plans");
    assert!(n.lead > 0.3 && n.lead < 1.5, "{n:?}");
    let e = s.locate_robot("r2", 1, Point::new(-20.0, 2.0)).unwrap_err().to_string();
    assert!(e.contains("more than 5 m from the map's free space"), "{e}");
}

#[test]
fn a_rotated_origin_is_honoured() {
    let mut g = two_rooms();
    g.origin = [3.0, -2.0, std::f64::consts::FRAC_PI_2];
    let s = space(&g, 0.3);
    // (5, 2) in the map frame is (3 - 2, -2 + 5) in the world.
    let a = s.locate("waypoint", 0, Point::new(1.0, 3.0)).unwrap();
    let b = s.locate("waypoint", 1, Point::new(1.0, 13.0)).unwrap();
    let r = s.route(&a, &b).unwrap();
    assert!(free_route(&g, &r) && crate::geom::length(&r) > 14.0, "{r:?}");
}

fn square_graph() -> NavGraph {
    // 0 — 1
    // |   |
    // 3 — 2, plus a one-way shortcut 0 → 2.
    let at = [(0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0)];
    let vertices = at.iter().enumerate().map(|(i, &(x, y))| Vertex { charger: false, name: format!("v{i}"), at: Point::new(x, y) }).collect();
    let mut edges = Vec::new();
    for (a, b) in [(0, 1), (1, 2), (2, 3), (3, 0)] {
        edges.push(Edge { from: a, to: b, length: 10.0, passing: false });
        edges.push(Edge { from: b, to: a, length: 10.0, passing: false });
    }
    edges.push(Edge { from: 0, to: 2, length: 14.2, passing: false });
    NavGraph { vertices, edges }
}

#[test]
fn graph_routes_follow_edges_and_their_directions() {
    let s = Space::new(&Map::Graph(square_graph()), 0.3).unwrap();
    let a = s.locate("waypoint", 0, Point::new(0.5, 0.5)).unwrap();
    assert_eq!(a.at, Point::new(0.0, 0.0), "snapped onto its vertex");
    let c = s.locate("waypoint", 1, Point::new(10.0, 10.0)).unwrap();
    assert_eq!(s.route(&a, &c).unwrap(), vec![Point::new(0.0, 0.0), Point::new(10.0, 10.0)]);
    assert_eq!(s.route(&c, &a).unwrap().len(), 3, "back the long way: the shortcut is one way");
    let m = s.matrix(&[a, c]);
    assert_eq!((m[1], m[2]), (14.2, 20.0));
    let e = s.locate("waypoint", 2, Point::new(5.0, 5.0)).unwrap_err().to_string();
    assert!(e.starts_with("waypoint 2 at (5, 5) is 7.1 m from the nearest vertex"), "{e}");
    let r = s.locate_robot("r1", 0, Point::new(5.0, -1.0)).unwrap();
    assert!(r.lead > 5.0);
}

#[test]
fn the_segment_walk_touches_every_crossed_cell() {
    let mut seen = Vec::new();
    cells_on_segment(0.5, 0.5, 3.5, 1.5, |c, r| {
        seen.push((c, r));
        true
    });
    assert_eq!(seen.first(), Some(&(0, 0)));
    assert_eq!(seen.last(), Some(&(3, 1)));
    // Exactly through a corner: both side cells are checked.
    let mut corner = Vec::new();
    cells_on_segment(0.5, 0.5, 2.5, 2.5, |c, r| {
        corner.push((c, r));
        true
    });
    assert!(corner.contains(&(1, 0)) && corner.contains(&(0, 1)), "{corner:?}");
    assert!(!cells_on_segment(0.5, 0.5, 3.5, 0.5, |c, _| c != 2));
    // A diagonal through corners ending on a corner that rounding puts a hair off (9.95, 2.05)
    // → (9.0, 3.0) in 0.1 m cells, as a grid computes them: the walk stops at the end, it does
    // not walk on past it (it once went on into the wall beyond and said the way was blocked).
    let (u0, v0, u1, v1) = (9.950000000000001 / 0.1, 2.0500000000000003 / 0.1, 9.0 / 0.1, 3.0 / 0.1);
    let mut far = Vec::new();
    assert!(cells_on_segment(u0, v0, u1, v1, |c, r| {
        far.push((c, r));
        true
    }));
    assert!(far.iter().all(|&(c, r)| (88..=100).contains(&c) && (20..=31).contains(&r)), "walked past the end: {far:?}");
}
