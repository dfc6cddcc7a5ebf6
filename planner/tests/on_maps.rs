//! Planners on real maps: routes never cross an occupied cell, tours are no shorter than the
//! geodesic bound, coverage points stand in free space and count distances through doors.

use std::collections::BTreeMap;
use std::path::PathBuf;

use mrmm_maps::{Bundle, Map, Space};
use mrmm_planner::coverage::CoverageParams;
use mrmm_planner::patrol::{self, PatrolParams};
use mrmm_planner::recipe::{self, MissionPlan};
use mrmm_planner::region::Region;
use mrmm_planner::{coverage_map, Point};
use mrmm_proto::plan::{RobotSpec, Step};
use proptest::prelude::*;

fn load(rel: &str) -> Map {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../maps/data").join(rel);
    Bundle::collect(&path.to_string_lossy(), |p| std::fs::read(p).map_err(|e| e.to_string())).expect("bundle").load().expect("map").1
}

fn robot(id: &str, x: f64, y: f64) -> RobotSpec {
    RobotSpec { id: id.into(), robot_type: "ground".into(), x, y, speed: 1.0, turn_rate: None, reach_m: None }
}

/// Eight rooms of patrolling_sim's broughton floor plan (100 × 80 m, 0.1 m cells).
fn rooms() -> Vec<Point> {
    [(44.0, 26.0), (60.0, 27.0), (38.0, 16.0), (57.0, 16.0), (82.0, 45.0), (82.0, 26.0), (62.0, 72.0), (85.0, 72.0)]
        .iter()
        .map(|&(x, y)| Point::new(x, y))
        .collect()
}

/// Every segment of a closed route is free on the map.
fn crosses_no_wall(map: &Map, route: &[Point]) -> Result<(), String> {
    let g = map.grid().expect("grid");
    for k in 0..route.len() {
        let (a, b) = (route[k], route[(k + 1) % route.len()]);
        if !g.segment_free(a, b) {
            return Err(format!("segment {k} ({:.2}, {:.2}) → ({:.2}, {:.2}) crosses an occupied or unknown cell", a.x, a.y, b.x, b.y));
        }
    }
    Ok(())
}

fn navigate_points(steps: &[Step]) -> Vec<Point> {
    steps.iter().filter_map(|s| if let Step::Navigate { x, y, .. } = s { Some(Point::new(*x, *y)) } else { None }).collect()
}

#[test]
fn a_patrol_of_eight_rooms_follows_the_corridors() {
    let map = load("patrolling_sim/broughton.yaml");
    let space = Space::new(&map, 0.25).unwrap();
    let robots = [robot("r1", 45.0, 20.0), robot("r2", 70.0, 20.0), robot("r3", 75.0, 50.0)];
    let on_map = patrol::plan_on(&PatrolParams::new(rooms()), &robots, Some(&space)).expect("plan");
    crosses_no_wall(&map, &on_map.tour).unwrap();
    // Every robot's plan drives only along free segments, from where it stands.
    for (plan, r) in on_map.plans.iter().zip(&robots) {
        let mut pts = vec![Point::new(r.x, r.y)];
        pts.extend(navigate_points(&plan.steps));
        for w in pts.windows(2) {
            assert!(map.grid().unwrap().segment_free(w[0], w[1]), "{}: ({:?}) → ({:?})", plan.robot, w[0], w[1]);
        }
    }
    // The geodesic bound: each leg at least its shortest-path distance on the planning grid
    // (less its cells' slack), the whole tour at least the best tour of the waypoints' straight
    // lines.
    let plane = patrol::plan(&PatrolParams::new(rooms()), &robots).expect("plane plan");
    assert!(on_map.length > 1.3 * plane.length, "map {} vs plane {}", on_map.length, plane.length);
    assert_eq!(on_map.waypoints.len(), 8);
    assert!((on_map.predicted_worst_idleness - on_map.length / 3.0).abs() < 1e-9);
    eprintln!(
        "broughton, 8 rooms, 3 robots: plane {:.0} m (idleness {:.0} s); map {:.0} m (idleness {:.0} s)",
        plane.length, plane.predicted_worst_idleness, on_map.length, on_map.predicted_worst_idleness
    );
}

/// The check above can fail: the tour planned in the plane crosses the walls.
#[test]
fn the_wall_check_fails_on_straight_lines() {
    let map = load("patrolling_sim/broughton.yaml");
    let plane = patrol::plan(&PatrolParams::new(rooms()), &[robot("r1", 45.0, 20.0)]).expect("plan");
    assert!(crosses_no_wall(&map, &plane.tour).is_err(), "straight lines between rooms cross walls");
}

#[test]
fn patrolling_every_vertex_of_a_graph_follows_its_edges() {
    let map = load("patrolling_sim/grid.graph");
    let g = map.graph().unwrap().clone();
    let r = recipe::parse(recipe::bank("patrol").unwrap()).unwrap();
    let params = BTreeMap::from([("waypoints".to_string(), "all".to_string())]);
    let robots = [robot("a", 5.0, 5.0), robot("b", 20.0, 20.0)];
    let MissionPlan::Patrol(p) = recipe::build_on(&r, &params, &robots, Some(&map)).expect("plan") else { panic!("patrol") };
    assert_eq!(p.waypoints.len(), g.vertices.len());
    // Consecutive points of the route are joined by an edge of the graph.
    let at = |p: Point| g.vertices.iter().position(|v| v.at.dist(p) < 1e-9).expect("a vertex");
    for k in 0..p.tour.len() {
        let (a, b) = (at(p.tour[k]), at(p.tour[(k + 1) % p.tour.len()]));
        assert!(g.edges.iter().any(|e| e.from as usize == a && e.to as usize == b), "{a} → {b} is no edge");
    }
    // Without a graph map "all" is refused in words.
    let e = recipe::build_on(&r, &params, &robots, None).unwrap_err().to_string();
    assert!(e.contains("every vertex of a graph map"), "{e}");
}

#[test]
fn waypoints_in_walls_are_refused_with_their_index() {
    let map = load("patrolling_sim/broughton.yaml");
    let space = Space::new(&map, 0.25).unwrap();
    // A cell of the corridor's north wall.
    let g = map.grid().unwrap();
    let wall = (205..230)
        .flat_map(|r| (440..460).map(move |c| (c, r)))
        .map(|(c, r)| g.center(c, r))
        .find(|p| g.at(*p) == Some(100))
        .expect("a wall north of the corridor");
    let mut wps = rooms();
    wps.push(wall);
    let e = patrol::plan_on(&PatrolParams::new(wps), &[robot("r1", 45.0, 20.0)], Some(&space)).unwrap_err().to_string();
    assert!(e.starts_with("waypoint 8 at (44.05, 21.05) is in an occupied cell"), "{e}");
}

#[test]
fn coverage_points_stand_in_free_space_and_distances_go_through_doors() {
    let map = load("patrolling_sim/broughton.yaml");
    let space = Space::new(&map, 0.25).unwrap();
    // The building's main corridor and the rooms either side of it.
    let region = Region { outer: vec![Point::new(30.0, 12.0), Point::new(75.0, 12.0), Point::new(75.0, 32.0), Point::new(30.0, 32.0)], holes: vec![] };
    let robots = [robot("a", 35.0, 20.0), robot("b", 45.0, 20.0), robot("c", 55.0, 20.0), robot("d", 65.0, 20.0)];
    let (plan, routes) = coverage_map::plan_on(&CoverageParams::new(region.clone()), &robots, &space).expect("coverage");
    for p in &plan.points {
        assert!(map.grid().unwrap().is_free(*p) && region.contains(*p), "{p:?}");
    }
    for (route, r) in routes.iter().zip(&robots) {
        let mut pts = vec![Point::new(r.x, r.y)];
        pts.extend(route);
        assert!(pts.windows(2).all(|w| map.grid().unwrap().segment_free(w[0], w[1])), "{pts:?}");
    }
    // Geodesic radius: at least the plane's for the same points.
    let g = map.grid().unwrap();
    let mut plane_r: f64 = 0.0;
    for i in 0..space.nodes() as u32 {
        if let Some(q) = space.node_point(i).filter(|q| region.contains(*q) && g.is_free(*q)) {
            plane_r = plane_r.max(plan.points.iter().map(|c| c.dist(q)).fold(f64::INFINITY, f64::min));
        }
    }
    assert!(plan.coverage_radius + 1e-9 >= plane_r * 0.99, "geodesic {} < straight {}", plan.coverage_radius, plane_r);
    eprintln!("broughton corridor coverage by 4: radius {:.1} m (straight-line radius of the same points {:.1} m)", plan.coverage_radius, plane_r);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 12, ..ProptestConfig::default() })]
    /// Random free waypoints in the main building: the planned route never crosses an occupied
    /// cell, and is at least as long as the straight-line tour through the same points.
    #[test]
    fn routes_never_cross_a_wall(seed in 0u64..1000) {
        use rand::{Rng, SeedableRng};
        let map = load("patrolling_sim/broughton.yaml");
        let space = Space::new(&map, 0.25).unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let mut wps = Vec::new();
        while wps.len() < 6 {
            let p = Point::new(rng.gen_range(32.0..70.0), rng.gen_range(14.0..30.0));
            if space.locate("waypoint", wps.len(), p).is_ok() {
                wps.push(p);
            }
        }
        let robots = [robot("a", 45.0, 20.0), robot("b", 60.0, 20.0)];
        match patrol::plan_on(&PatrolParams::new(wps.clone()), &robots, Some(&space)) {
            Ok(p) => {
                prop_assert!(crosses_no_wall(&map, &p.tour).is_ok(), "{:?}", crosses_no_wall(&map, &p.tour));
                let plane = patrol::plan(&PatrolParams::new(wps), &robots).unwrap();
                prop_assert!(p.length + 1e-6 >= plane.length, "{} < {}", p.length, plane.length);
            }
            Err(e) => prop_assert!(e.to_string().contains("cannot be reached"), "{e}"),
        }
    }
}
