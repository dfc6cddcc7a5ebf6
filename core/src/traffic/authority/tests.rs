//! The authority's unit tests: maps, rebuilds, lost robots, grid maps.

use super::*;
use crate::at;

fn office() -> Arc<Map> {
    let (name, text) = mrmm_maps::data::OPEN_RMF[0];
    Arc::new(Map::Graph(mrmm_maps::rmf::parse(name, text).expect("office graph")))
}

/// Two rooms of 6 × 4 m side by side, a wall between them with a door 1.2 m wide, 0.1 m cells.
fn two_rooms() -> Arc<Map> {
    let (w, h) = (120u32, 40u32);
    let mut data = vec![0i8; (w * h) as usize];
    for row in 0..h {
        for col in 0..w {
            let edge = row < 2 || row >= h - 2 || col < 2 || col >= w - 2;
            let wall = (59..61).contains(&col) && !(14..26).contains(&row);
            if edge || wall {
                data[(row * w + col) as usize] = 100;
            }
        }
    }
    Arc::new(Map::Grid(OccupancyGrid { width: w, height: h, resolution: 0.1, origin: [0.0, 0.0, 0.0], data }))
}

/// A grid map has lanes derived from its free space: a goal in the other room is routed along
/// them through the door, from a vertex the robot sees to one the goal sees; a map named
/// without lanes is answered free.
#[test]
fn a_grid_maps_robots_are_routed_on_lanes_derived_from_its_free_space() {
    let map = two_rooms();
    let Map::Grid(grid) = map.as_ref() else { unreachable!() };
    let hash = "g".repeat(64);
    let mut a = Authority::new(at(-10.0), 1, [(hash.clone(), map.clone())]);
    let (here, there) = (Point::new(1.0, 0.6), Point::new(11.0, 3.4));
    let report = TrafficReport {
        robot: "r1".into(),
        seq: 1,
        x: here.x,
        y: here.y,
        goal: Some(TrafficGoal { id: 1, x: there.x, y: there.y }),
        held: None,
        docked: false,
    };
    let out = a.handle(at(0.0), Event::Report { map: hash.clone(), report: report.clone() });
    let route = out
        .iter()
        .find_map(|c| match c {
            Command::Order { order: TrafficOrder::Route { route, .. }, .. } => Some(route.clone()),
            _ => None,
        })
        .unwrap_or_else(|| panic!("a route on the derived lanes: {out:?}"));
    let (first, last) = (&route[0], &route[route.len() - 1]);
    assert!(grid.segment_free(here, Point::new(first.x, first.y)), "entered at a vertex in sight: {first:?}");
    assert!(grid.segment_free(there, Point::new(last.x, last.y)), "left at a vertex in sight: {last:?}");
    assert!(first.x < 6.0 && last.x > 6.0, "from one room to the other (every lane in free cells: through the door): {route:?}");
    for w in route.windows(2) {
        assert!(grid.segment_free(Point::new(w[0].x, w[0].y), Point::new(w[1].x, w[1].y)), "a lane through a wall: {w:?}");
    }
    let mut free = Authority::new(at(-10.0), 1, [(hash.clone(), map.clone())]);
    free.without_lanes([hash.clone()]);
    let out = free.handle(at(0.0), Event::Report { map: hash.clone(), report });
    assert!(matches!(out.as_slice(), [Command::Order { order: TrafficOrder::Free, .. }]), "{out:?}");
}

/// On a grid map a goal off the lanes in open space is given as the order's `off`, the way
/// there clear of every lane and vertex another robot could hold; a second robot's goal whose
/// way would come within the clearance of the first one's is not (it stops at its vertex).
#[test]
fn a_goal_off_the_lanes_is_given_a_way_there_only_where_no_other_robot_can_come() {
    let map = two_rooms();
    let hash = "g".repeat(64);
    let mut a = Authority::new(at(-10.0), 1, [(hash.clone(), map.clone())]);
    let off_of = |out: &[Command], robot: &str| {
        out.iter().find_map(|c| match c {
            Command::Order { robot: r, order: TrafficOrder::Route { off, .. }, .. } if r.as_str() == robot => Some(*off),
            _ => None,
        })
    };
    let report = |robot: &str, at: Point, goal: Point| TrafficReport {
        robot: robot.into(),
        seq: 1,
        x: at.x,
        y: at.y,
        goal: Some(TrafficGoal { id: 1, x: goal.x, y: goal.y }),
        held: None,
        docked: false,
    };
    let goal = Point::new(9.0, 3.0);
    let out = a.handle(at(0.0), Event::Report { map: hash.clone(), report: report("r1", Point::new(1.0, 0.6), goal) });
    assert_eq!(off_of(&out, "r1"), Some(Some([goal.x, goal.y])), "a way to the goal in the room: {out:?}");
    let out = a.handle(at(0.1), Event::Report { map: hash.clone(), report: report("r2", Point::new(1.0, 3.4), Point::new(9.3, 3.2)) });
    assert_eq!(off_of(&out, "r2"), Some(None), "no way next to r1's: {out:?}");
}

/// A robot whose session is new (it restarted: its reports count from 1 again) is heard: its
/// goal is routed, where before its first reports were dropped as older than the last.
#[test]
fn a_restarted_robots_reports_count_from_its_first() {
    let map = office();
    let Map::Graph(g) = map.as_ref() else { unreachable!() };
    let hash = "h".repeat(64);
    let mut a = Authority::new(at(-10.0), 1, [(hash.clone(), map.clone())]);
    let here = g.vertices[0].at;
    let far = g.vertices[g.vertices.len() - 1].at;
    let report = |seq: u64, goal: Option<TrafficGoal>| TrafficReport { robot: "r1".into(), seq, x: here.x, y: here.y, goal, held: None, docked: false };
    a.handle(at(0.0), Event::Report { map: hash.clone(), report: report(40, None) });
    a.handle(at(2.0), Event::Gone("r1".into()));
    a.handle(at(3.0), Event::Alive("r1".into()));
    let out = a.handle(at(3.1), Event::Report { map: hash.clone(), report: report(1, Some(TrafficGoal { id: 1, x: far.x, y: far.y })) });
    assert!(out.iter().any(|c| matches!(c, Command::Order { order: TrafficOrder::Route { .. }, .. })), "the restarted robot's report was dropped: {out:?}");
}

/// A lost robot standing on a vertex another robot's route runs through: the other waits
/// until the operator takes the lost one off the lanes, then goes on. A robot still alive
/// is not cleared.
#[test]
fn a_lost_robot_taken_off_the_lanes_frees_the_way() {
    let map = office();
    let Map::Graph(g) = map.as_ref() else { unreachable!() };
    let hash = "h".repeat(64);
    let mut a = Authority::new(at(-10.0), 1, [(hash.clone(), map.clone())]);
    // r2's way from vertex 0 to the vertex farthest from it, and r1 standing on its middle.
    let space = GraphSpace::new(g);
    let far = (0..g.vertices.len() as u32)
        .max_by(|&x, &y| g.vertices[x as usize].at.dist(g.vertices[0].at).total_cmp(&g.vertices[y as usize].at.dist(g.vertices[0].at)))
        .unwrap();
    let way = space.vertex_path(0, far).expect("a way across the office");
    let mid = g.vertices[way[way.len() / 2] as usize].at;
    let (start, end) = (g.vertices[0].at, g.vertices[far as usize].at);
    let report = |robot: &str, seq: u64, at: Point, goal: Option<TrafficGoal>| TrafficReport {
        robot: robot.into(),
        seq,
        x: at.x,
        y: at.y,
        goal,
        held: None,
        docked: false,
    };
    a.handle(at(0.0), Event::Report { map: hash.clone(), report: report("r1", 1, mid, None) });
    let out = a.handle(at(0.1), Event::Report { map: hash.clone(), report: report("r2", 1, start, Some(TrafficGoal { id: 1, x: end.x, y: end.y })) });
    assert!(out.iter().any(|c| matches!(c, Command::Order { robot, order: TrafficOrder::Route { .. }, .. } if robot.as_str() == "r2")), "{out:?}");
    let err = a.clear(at(0.2), &"r1".into()).unwrap_err();
    assert!(err.error.contains("not lost"), "{err}");
    assert!(a.clear(at(0.2), &"r9".into()).unwrap_err().error.contains("holds nothing"));
    a.handle(at(1.0), Event::Gone("r1".into()));
    a.handle(at(1.0 + LOST_GRACE_S + 0.1), Event::Tick);
    let t = a.traffic(&hash).expect("lanes");
    assert!(!t.held(&"r1".into()).is_empty(), "a lost robot keeps where it stood");
    let (cleared, out) = a.clear(at(20.0), &"r1".into()).expect("cleared");
    assert_eq!((cleared.maps.len(), cleared.vertices), (1, 1), "{cleared:?}");
    let t = a.traffic(&hash).expect("lanes");
    assert!(t.held(&"r1".into()).is_empty() && t.state(&"r1".into()).is_none());
    assert!(t.holder(way[way.len() / 2]).is_none_or(|h| h.as_str() == "r2"), "r1's vertex is free");
    // r2 was waiting for r1's vertex or had not got so far: either way nothing of r1's is
    // held, and r2 is told its order again if it was granted on; r1's deputies hear it cleared.
    let cleared = |c: &Command| matches!(c, Command::Order { robot, order: TrafficOrder::Cleared { incarnation: 1 }, .. } if robot.as_str() == "r1");
    assert_eq!(out.iter().filter(|c| cleared(c)).count(), 1, "{out:?}");
    assert!(out.iter().all(|c| cleared(c) || matches!(c, Command::Order { robot, .. } if robot.as_str() == "r2")), "{out:?}");
}

/// A robot's first report on a map counts it among the deputies its own order names: it has
/// just spoken. (Before, the deputies were named before the report was taken in, so the first
/// order of the second robot on a map named only the first: one deputy where two were due, and
/// none at all for the first robot's first order.)
#[test]
fn a_robots_first_order_names_it_among_the_deputies() {
    let map = office();
    let Map::Graph(g) = map.as_ref() else { unreachable!() };
    let hash = "h".repeat(64);
    let mut a = Authority::new(at(-10.0), 1, [(hash.clone(), map.clone())]);
    let (here, there) = (g.vertices[0].at, g.vertices[3].at);
    let far = g.vertices[g.vertices.len() - 1].at;
    let report = |robot: &str, at: Point| TrafficReport {
        robot: robot.into(),
        seq: 1,
        x: at.x,
        y: at.y,
        goal: Some(TrafficGoal { id: 1, x: far.x, y: far.y }),
        held: None,
        docked: false,
    };
    let deputies = |out: &[Command], robot: &str| -> Vec<String> {
        out.iter()
            .find_map(|c| match c {
                Command::Order { robot: r, order: TrafficOrder::Route { deputies, .. }, .. } if r.as_str() == robot => {
                    Some(deputies.iter().map(|d| d.to_string()).collect())
                }
                _ => None,
            })
            .unwrap_or_else(|| panic!("no route for {robot}: {out:?}"))
    };
    let out = a.handle(at(0.0), Event::Report { map: hash.clone(), report: report("r1", here) });
    assert_eq!(deputies(&out, "r1"), ["r1"]);
    let out = a.handle(at(0.1), Event::Report { map: hash.clone(), report: report("r2", there) });
    assert_eq!(deputies(&out, "r2"), ["r1", "r2"]);
}

/// Routes go round a robot docked at a charger where there is a way round: from 0 to 2 the
/// short way is through 1, where r1 charges; r2 is routed through 3. Undocked, r1 is driven
/// past (it makes way when asked).
#[test]
fn routes_go_round_a_robot_docked_at_a_charger() {
    use mrmm_maps::graph::{Edge, Vertex};
    let points = [(0.0, 0.0), (3.0, 0.0), (6.0, 0.0), (3.0, 4.0)];
    let vertices = points.iter().enumerate().map(|(i, &(x, y))| Vertex { charger: i == 1, name: format!("v{i}"), at: Point::new(x, y) }).collect();
    let mut edges = Vec::new();
    for (a, b) in [(0u32, 1u32), (1, 2), (0, 3), (3, 2)] {
        let length = Point::new(points[a as usize].0, points[a as usize].1).dist(Point::new(points[b as usize].0, points[b as usize].1));
        edges.push(Edge { from: a, to: b, length, passing: false });
        edges.push(Edge { from: b, to: a, length, passing: false });
    }
    let map = Arc::new(Map::Graph(mrmm_maps::NavGraph { vertices, edges }));
    let hash = "h".repeat(64);
    let route_of = |docked: bool| {
        let mut a = Authority::new(at(-10.0), 1, [(hash.clone(), map.clone())]);
        let charging = TrafficReport { robot: "r1".into(), seq: 1, x: 3.0, y: 0.0, goal: None, held: None, docked };
        a.handle(at(0.0), Event::Report { map: hash.clone(), report: charging });
        let goal = Some(TrafficGoal { id: 1, x: 6.0, y: 0.0 });
        let out = a.handle(
            at(0.1),
            Event::Report { map: hash.clone(), report: TrafficReport { robot: "r2".into(), seq: 1, x: 0.0, y: 0.0, goal, held: None, docked: false } },
        );
        out.iter()
            .find_map(|c| match c {
                Command::Order { robot, order: TrafficOrder::Route { route, .. }, .. } if robot.as_str() == "r2" => {
                    Some(route.iter().map(|v| v.v).collect::<Vec<u32>>())
                }
                _ => None,
            })
            .expect("r2 routed")
    };
    let round = route_of(true);
    assert!(!round.contains(&1) && round.contains(&3) && round.last() == Some(&2), "{round:?}");
    let through = route_of(false);
    assert!(through.contains(&1), "{through:?}");
}

/// A robot driving on from a vertex lets it go once its report puts it clear of it (the
/// clearance and the margin along the lane, more when it is off the lane's line): the robot
/// behind it is granted that vertex then, not before.
#[test]
fn a_robots_report_clear_of_the_vertex_behind_lets_the_one_following_close_up() {
    // A corridor of three 1.4 m lanes (shorter than SEGMENT_M: not cut into segments).
    let vertex = |i: usize| mrmm_maps::graph::Vertex { charger: false, name: format!("v{i}"), at: Point::new(1.4 * i as f64, 0.0) };
    let mut edges = Vec::new();
    for i in 0..3u32 {
        edges.push(mrmm_maps::graph::Edge { from: i, to: i + 1, length: 1.4, passing: false });
        edges.push(mrmm_maps::graph::Edge { from: i + 1, to: i, length: 1.4, passing: false });
    }
    let map = Arc::new(Map::Graph(mrmm_maps::NavGraph { vertices: (0..4).map(vertex).collect(), edges }));
    let hash = "c".repeat(64);
    let mut a = Authority::new(at(-10.0), 1, [(hash.clone(), map)]);
    let goal = Some(TrafficGoal { id: 1, x: 4.2, y: 0.0 });
    let report = |robot: &str, seq: u64, x: f64, y: f64, held: Option<TrafficHeld>| TrafficReport { robot: robot.into(), seq, x, y, goal, held, docked: false };
    let route_of = |out: &[Command], robot: &str| {
        out.iter().find_map(|c| match c {
            Command::Order { robot: r, order: TrafficOrder::Route { version, route, upto, .. }, .. } if r.as_str() == robot => {
                Some((*version, route.iter().map(|v| v.v).collect::<Vec<u32>>(), *upto))
            }
            _ => None,
        })
    };
    a.handle(at(0.0), Event::Report { map: hash.clone(), report: report("a", 1, 1.4, 0.0, None) });
    a.handle(at(0.0), Event::Report { map: hash.clone(), report: report("b", 1, 0.0, 0.0, None) });
    let (version, route, upto) =
        route_of(&a.handle(at(0.1), Event::Report { map: hash.clone(), report: report("a", 2, 1.4, 0.0, None) }), "a").expect("a routed");
    assert_eq!((route.as_slice(), upto), ([1, 2, 3].as_slice(), Some(2)));
    let (_, b_route, b_upto) =
        route_of(&a.handle(at(0.2), Event::Report { map: hash.clone(), report: report("b", 2, 0.0, 0.0, None) }), "b").expect("b routed");
    assert_eq!((b_route.as_slice(), b_upto), ([0, 1, 2, 3].as_slice(), Some(0)), "a stands on 1");
    let held = Some(TrafficHeld { incarnation: 1, version, route: route.clone(), reached: Some(0), upto: Some(2) });
    let b_upto = |out: &[Command]| route_of(out, "b").and_then(|(_, _, upto)| upto);
    // 0.5 m along: not clear (0.65 m needed); 0.7 m along but 0.2 m off the line: not clear.
    for (seq, x, y) in [(3, 1.9, 0.0), (4, 2.1, 0.2)] {
        let out = a.handle(at(0.3), Event::Report { map: hash.clone(), report: report("a", seq, x, y, held.clone()) });
        assert!(b_upto(&out).is_none_or(|u| u == 0), "b granted 1 with a {:.1} m along: {out:?}", x - 1.4);
        assert!(a.traffic(&hash).is_some_and(|t| t.holder(1).is_some()), "vertex 1 let go too early");
    }
    let out = a.handle(at(0.4), Event::Report { map: hash.clone(), report: report("a", 5, 2.1, 0.0, held) });
    let b = a.handle(at(0.5), Event::Report { map: hash.clone(), report: report("b", 3, 0.0, 0.0, None) });
    assert_eq!(b_upto(&out).or(b_upto(&b)), Some(1), "b closes up to vertex 1, not onto a's lane: {out:?} {b:?}");
}
