//! The roadmap derived from grids of corridors and from shipped floor plans.

use super::*;
use crate::Bundle;

/// A grid of `w × h` cells of 5 cm, free where `free(col, row)`.
fn grid(w: u32, h: u32, free: impl Fn(u32, u32) -> bool) -> OccupancyGrid {
    let data = (0..h).flat_map(|r| (0..w).map(move |c| (c, r))).map(|(c, r)| if free(c, r) { 0 } else { 100 }).collect();
    OccupancyGrid { width: w, height: h, resolution: 0.05, origin: [0.0, 0.0, 0.0], data }
}

/// Every lane stays where a robot of `radius` fits, checked on the grid itself at every
/// centimetre.
fn assert_lanes_clear(g: &NavGraph, grid: &OccupancyGrid, radius: f64) {
    let open = crate::space::grid::inflate(grid, radius - grid.resolution);
    for e in &g.edges {
        let (a, b) = (g.vertices[e.from as usize].at, g.vertices[e.to as usize].at);
        let n = (a.dist(b) / 0.01).ceil().max(1.0) as usize;
        for k in 0..=n {
            let t = k as f64 / n as f64;
            let p = Point::new(a.x + t * (b.x - a.x), a.y + t * (b.y - a.y));
            let (c, r) = grid.cell_of(p).unwrap_or_else(|| panic!("lane {e:?} leaves the map at {p:?}"));
            assert!(!open[(r * grid.width + c) as usize], "lane {e:?} passes {p:?}, closer than {radius} m to an obstacle");
        }
    }
}

fn components(g: &NavGraph) -> usize {
    let mut seen = vec![false; g.vertices.len()];
    let mut n = 0;
    for s in 0..g.vertices.len() {
        if seen[s] {
            continue;
        }
        n += 1;
        let mut stack = vec![s as u32];
        seen[s] = true;
        while let Some(v) = stack.pop() {
            for e in g.edges.iter().filter(|e| e.from == v) {
                if !seen[e.to as usize] {
                    seen[e.to as usize] = true;
                    stack.push(e.to);
                }
            }
        }
    }
    n
}

#[test]
fn an_h_of_corridors_gives_two_junctions_and_four_ends() {
    // Two corridors 1 m wide and 8 m long, joined at their middles by one 3 m long.
    let g = grid(100, 180, |c, r| {
        let left = (10..30).contains(&c) && (10..170).contains(&r);
        let right = (70..90).contains(&c) && (10..170).contains(&r);
        let bar = (30..70).contains(&c) && (80..100).contains(&r);
        left || right || bar
    });
    let nav = derive("h", &g, &Params::default()).unwrap();
    assert_lanes_clear(&nav, &g, 0.3);
    assert_eq!(components(&nav), 1, "{nav:?}");
    let names = |k: &str| nav.vertices.iter().filter(|v| v.name.starts_with(k)).count();
    assert_eq!((names("junction"), names("end")), (2, 4), "{nav:?}");
    // Straight corridors need no corner between their junction and end.
    assert_eq!(nav.vertices.len(), 6, "{nav:?}");
    // 1 m wide: no room for two robots side by side.
    assert!(nav.edges.iter().all(|e| !e.passing), "{nav:?}");
}

#[test]
fn a_corridor_wide_enough_for_two_robots_side_by_side_is_passing() {
    // 2 m wide and 8 m long: a robot's centre fits 0.35 m to either side of the middle.
    let g = grid(180, 60, |c, r| (10..170).contains(&c) && (10..50).contains(&r));
    let nav = derive("wide", &g, &Params::default()).unwrap();
    assert!(!nav.edges.is_empty() && nav.edges.iter().all(|e| e.passing), "{nav:?}");
    // Wanting more room to the sides than there is, or none asked: not passing.
    for passing in [0.75, 0.0] {
        let narrow = derive("wide", &g, &Params { passing, ..Params::default() }).unwrap();
        assert!(narrow.edges.iter().all(|e| !e.passing), "{passing}: {narrow:?}");
    }
    // Written as Open-RMF's nav graph, read back: still passing.
    let back = crate::rmf::parse("back", &crate::rmf::write(&nav, "wide", "L1")).unwrap();
    assert!(back.edges.iter().all(|e| e.passing));
}

#[test]
fn a_shipped_nav2_map_gets_one_connected_graph_along_its_free_space() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/data/nav2/");
    let b = Bundle::collect(&format!("{dir}tb3_sandbox.yaml"), |p| std::fs::read(p).map_err(|e| e.to_string())).unwrap();
    let (_, map) = b.load().unwrap();
    let grid = map.grid().unwrap();
    let nav = derive("tb3_sandbox", grid, &Params::default()).unwrap();
    assert_lanes_clear(&nav, grid, 0.3);
    assert_eq!(components(&nav), 1, "{} vertices", nav.vertices.len());
    // Every place a robot fits is near a lane: within 1.5 m of a vertex or lane.
    let open = crate::space::grid::inflate(grid, 0.3);
    let (mut fits, mut near) = (0, 0);
    for r in (0..grid.height).step_by(4) {
        for c in (0..grid.width).step_by(4) {
            if open[(r * grid.width + c) as usize] {
                continue;
            }
            fits += 1;
            let p = grid.center(c, r);
            let d = nav
                .edges
                .iter()
                .map(|e| point_segment_distance(p, nav.vertices[e.from as usize].at, nav.vertices[e.to as usize].at))
                .fold(f64::INFINITY, f64::min);
            near += usize::from(d <= 1.5);
        }
    }
    assert!(near * 100 >= fits * 95, "{near} of {fits} places a robot fits are within 1.5 m of a lane");
    // Written as Open-RMF's nav graph and read back, it is the same graph.
    let text = crate::rmf::write(&nav, "tb3_sandbox", "L1");
    let back = crate::rmf::parse("back", &text).unwrap();
    assert_eq!(back.vertices.len(), nav.vertices.len());
    assert_eq!(back.edges.iter().map(|e| (e.from, e.to)).collect::<Vec<_>>(), nav.edges.iter().map(|e| (e.from, e.to)).collect::<Vec<_>>());
    for (a, b) in back.vertices.iter().zip(&nav.vertices) {
        assert!(a.at.dist(b.at) < 1e-3 && a.name == b.name);
    }
}

#[test]
fn no_room_for_a_robot_is_a_clear_error() {
    let g = grid(40, 40, |c, r| (15..25).contains(&c) && (5..35).contains(&r)); // 0.5 m wide
    let e = derive("narrow", &g, &Params::default()).unwrap_err().to_string();
    assert!(e.contains("narrow") && e.contains("radius 0.3 m"), "{e}");
    let e = derive("bad", &g, &Params { tolerance: 0.0, ..Params::default() }).unwrap_err().to_string();
    assert!(e.contains("tolerance"), "{e}");
}

/// patrolling_sim's broughton: its floor plan (map_server's YAML and PGM) and the graph its
/// authors drew on it by hand.
fn broughton() -> (crate::Map, NavGraph) {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/data/patrolling_sim/");
    let b = Bundle::collect(&format!("{dir}broughton.yaml"), |p| std::fs::read(p).map_err(|e| e.to_string())).unwrap();
    let (_, map) = b.load().unwrap();
    let hand = crate::data::graphs().unwrap().into_iter().find(|(n, _)| *n == "broughton").unwrap().1;
    (map, hand)
}

#[test]
fn the_places_of_a_hand_drawn_graph_of_the_same_floor_plan_reach_the_derived_one() {
    // patrolling_sim's broughton: a floor plan (map_server's YAML and PGM) and the patrol
    // graph its authors drew on it by hand. A robot's goal at any of their 163 places joins
    // the derived graph by a straight free line of 5 m at most.
    let (map, hand) = broughton();
    let grid = map.grid().unwrap();
    let nav = derive("broughton", grid, &Params::default()).unwrap();
    assert_lanes_clear(&nav, grid, 0.3);
    let work = work_grid(grid, 0.3);
    let joined: Vec<bool> = hand.vertices.iter().map(|v| nav.vertices.iter().any(|w| w.at.dist(v.at) <= 5.0 && work.clear(v.at, w.at))).collect();
    let n = joined.iter().filter(|&&j| j).count();
    assert!(n * 100 >= hand.vertices.len() * 98, "{n} of {} places join the derived graph", hand.vertices.len());
}

#[test]
fn a_hand_drawn_graphs_lanes_are_passing_where_its_floor_plan_has_room() {
    // patrolling_sim's broughton graph on the floor plan its authors drew it on: some of its lanes
    // are passing, not all; each passing lane's sides are where a robot fits, checked on the grid
    // itself every centimetre.
    let (map, hand) = broughton();
    let grid = map.grid().unwrap();
    let marked = mark_passing_on(grid, hand.clone(), 0.3, 0.35);
    let passing = marked.edges.iter().filter(|e| e.passing).count();
    assert!(passing > 0 && passing < marked.edges.len(), "{passing} of {} edges passing", marked.edges.len());
    let mut sides = NavGraph { vertices: marked.vertices.clone(), edges: Vec::new() };
    for e in marked.edges.iter().filter(|e| e.passing) {
        assert!(marked.edges.iter().any(|r| r.from == e.to && r.to == e.from && r.passing), "{e:?} passing one way only");
        let (a, b) = (marked.vertices[e.from as usize].at, marked.vertices[e.to as usize].at);
        let (nx, ny) = ((b.y - a.y) / a.dist(b) * 0.35, -(b.x - a.x) / a.dist(b) * 0.35);
        for k in [1.0, -1.0] {
            let n = sides.vertices.len() as u32;
            sides.vertices.push(Vertex { name: String::new(), at: Point::new(a.x + k * nx, a.y + k * ny), charger: false });
            sides.vertices.push(Vertex { name: String::new(), at: Point::new(b.x + k * nx, b.y + k * ny), charger: false });
            sides.edges.push(Edge { from: n, to: n + 1, length: 0.0, passing: false });
        }
    }
    assert_lanes_clear(&sides, grid, 0.3);
    // Unchanged otherwise: the same vertices and lanes.
    assert_eq!(marked.vertices, hand.vertices);
    assert_eq!(marked.edges.iter().map(|e| (e.from, e.to)).collect::<Vec<_>>(), hand.edges.iter().map(|e| (e.from, e.to)).collect::<Vec<_>>());
}
