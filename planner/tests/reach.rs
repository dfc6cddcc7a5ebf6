//! Planning by reach: a robot whose battery says how far it takes it (`RobotSpec::reach_m`) is
//! given no leg longer than that — the way to its patrol slot and on to the round's first sync
//! point, the way to its coverage point — and one that fits none is left out of the plan
//! (`held`), the plan made for the others.

use std::collections::BTreeMap;
use std::path::PathBuf;

use mrmm_maps::{Bundle, Map, Space};
use mrmm_planner::coverage::{self, CoverageParams};
use mrmm_planner::patrol::{self, PatrolParams};
use mrmm_planner::recipe;
use mrmm_planner::region::Region;
use mrmm_planner::Point;
use mrmm_proto::plan::RobotSpec;
use mrmm_proto::RobotId;

fn robot(id: &str, x: f64, y: f64, reach_m: Option<f64>) -> RobotSpec {
    RobotSpec { id: id.into(), robot_type: "ground".into(), x, y, speed: 1.0, turn_rate: None, reach_m }
}

/// A 40 m square: a 160 m tour.
fn square() -> PatrolParams {
    PatrolParams::new(vec![Point::new(0.0, 0.0), Point::new(40.0, 0.0), Point::new(40.0, 40.0), Point::new(0.0, 40.0)])
}

fn ids(v: &[&str]) -> Vec<RobotId> {
    v.iter().map(|&s| RobotId::from(s)).collect()
}

/// The way to its slot (straight, in the plane) and on to the first sync point of its round.
fn leg(p: &patrol::PatrolPlan, robot: &RobotSpec) -> f64 {
    let a = p.assignments.iter().find(|a| a.robot == robot.id.as_str()).expect("assigned");
    let mut at = Point::new(robot.x, robot.y);
    let mut d = 0.0;
    for q in &a.approach {
        d += at.dist(*q);
        at = *q;
    }
    d + p.length / f64::from(p.sync_per_round)
}

#[test]
fn a_robot_too_low_for_any_slot_is_left_out_and_the_patrol_planned_for_the_others() {
    let robots = [robot("r1", 0.0, -1.0, None), robot("r2", 40.0, -1.0, Some(300.0)), robot("r3", 20.0, 60.0, Some(5.0))];
    let p = patrol::plan(&square(), &robots).expect("plan");
    assert_eq!(p.held, ids(&["r3"]));
    let planned: Vec<&str> = p.plans.iter().map(|r| r.robot.as_str()).collect();
    assert_eq!(planned, ["r1", "r2"]);
    // The figures are the two's: two slots 80 m apart.
    assert!((p.spacing - 80.0).abs() < 1e-6, "spacing {}", p.spacing);
    assert!((p.predicted_worst_idleness - 80.0).abs() < 1e-6, "{}", p.predicted_worst_idleness);
    assert!(leg(&p, &robots[1]) <= 300.0);
}

#[test]
fn a_low_robot_gets_the_slot_within_its_reach() {
    // Two robots on one spot at the square's corner: slots at the corner and 80 m on. Either
    // assignment is as good by time; only the low one's reach (the near slot and its 40 m first
    // leg, not the far one) tells them apart.
    let robots = [robot("full", 0.0, 0.0, None), robot("low", 0.0, 0.0, Some(41.0))];
    let p = patrol::plan(&square(), &robots).expect("plan");
    assert!(p.held.is_empty(), "held {:?}", p.held);
    assert_eq!(p.sync_per_round, 4);
    let low = p.assignments.iter().find(|a| a.robot == "low").expect("low planned");
    assert!(low.start.dist(Point::new(0.0, 0.0)) < 1e-6, "low starts at ({}, {})", low.start.x, low.start.y);
    assert!(leg(&p, &robots[1]) <= 41.0 + 1e-9, "leg {}", leg(&p, &robots[1]));
}

#[test]
fn a_robot_without_a_battery_or_with_reach_enough_is_planned_as_before() {
    let plain = [robot("r1", 0.0, -1.0, None), robot("r2", 40.0, -1.0, None)];
    let far = [robot("r1", 0.0, -1.0, Some(1e5)), robot("r2", 40.0, -1.0, Some(1e5))];
    let (a, b) = (patrol::plan(&square(), &plain).expect("plain"), patrol::plan(&square(), &far).expect("far"));
    assert_eq!(a.plans, b.plans);
    assert_eq!(a.formation_time, b.formation_time);
}

#[test]
fn when_no_robot_has_the_reach_every_robot_holds() {
    let robots = [robot("r1", 0.0, -1.0, Some(1.0)), robot("r2", 40.0, -1.0, Some(2.0))];
    let p = patrol::plan(&square(), &robots).expect("plan");
    assert_eq!(p.held, ids(&["r1", "r2"]));
    assert!(p.plans.is_empty());
    // Through the recipe, the mission's wire plan says so too.
    let r = recipe::parse(recipe::bank("patrol").expect("bank")).expect("recipe");
    let params = BTreeMap::from([("waypoints".to_string(), "[[0,0],[40,0],[40,40],[0,40]]".to_string())]);
    let wire = recipe::build(&r, &params, &robots).expect("build").to_wire();
    assert!(wire.plans.is_empty());
    assert_eq!(wire.held, ids(&["r1", "r2"]));
}

#[test]
fn a_reach_that_is_not_a_distance_is_refused_with_the_robot_named() {
    for bad in [f64::NAN, -1.0, f64::INFINITY] {
        let robots = [robot("r1", 0.0, -1.0, None), robot("r7", 40.0, -1.0, Some(bad))];
        let e = patrol::plan(&square(), &robots).expect_err("refused").to_string();
        assert!(e.contains("r7") && e.contains("reach_m"), "{e}");
    }
}

#[test]
fn coverage_leaves_out_a_robot_whose_reach_takes_it_to_no_point() {
    let region = Region::new(vec![Point::new(0.0, 0.0), Point::new(30.0, 0.0), Point::new(30.0, 30.0), Point::new(0.0, 30.0)], vec![]).expect("region");
    let robots = [robot("r1", 0.0, -1.0, None), robot("r2", 30.0, -1.0, Some(100.0)), robot("r3", 15.0, -200.0, Some(10.0))];
    let p = coverage::plan(&CoverageParams::new(region), &robots).expect("plan");
    assert_eq!(p.held, ids(&["r3"]));
    assert_eq!(p.points.len(), 2);
    assert_eq!(p.plans.len(), 2);
    for plan in &p.plans {
        let r = robots.iter().find(|r| r.id == plan.robot).expect("robot");
        let d = p.points[plan.slot].dist(Point::new(r.x, r.y));
        assert!(r.reach_m.is_none_or(|m| d <= m), "{} drives {d} m on a reach of {:?}", r.id, r.reach_m);
    }
}

#[test]
fn on_a_graph_map_a_robot_short_of_reach_is_left_out_too() {
    // Open-RMF's office graph: the first leg runs along the lanes.
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../maps/data/open_rmf/office.nav_graph.yaml");
    let map: Map = Bundle::collect(&path.to_string_lossy(), |p| std::fs::read(p).map_err(|e| e.to_string())).expect("bundle").load().expect("map").1;
    let Map::Graph(g) = &map else { panic!("a graph") };
    let space = Space::new(&map, 0.25).expect("space");
    let wps: Vec<Point> = g.vertices.iter().map(|v| v.at).take(6).collect();
    let v0 = g.vertices[0].at;
    let robots = [robot("near", v0.x, v0.y, None), robot("low", v0.x, v0.y, Some(0.5))];
    let p = patrol::plan_on(&PatrolParams::new(wps), &robots, Some(&space)).expect("plan");
    assert_eq!(p.held, ids(&["low"]));
    assert_eq!(p.plans.len(), 1);
}
