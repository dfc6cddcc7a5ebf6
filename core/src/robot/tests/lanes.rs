//! A robot on a map: its goals given to traffic, driven on lanes and off them.

use super::*;
use crate::at;

/// On a map, a plan's goal goes to traffic first; when traffic answers that the map has no lanes
/// (a grid map), the body drives to that goal — the plan does not skip it for the next one (an
/// aerial robot of the demo once flew straight through the building's walls so).
#[test]
fn a_goal_given_to_traffic_is_driven_when_the_map_has_no_lanes() {
    let (mut r, map) = planned_on_map(Some(vec![
        Step::Navigate { x: 4.0, y: 0.0, speed: None },
        Step::Navigate { x: 4.0, y: -4.0, speed: None },
        Step::Hold { seconds: None },
    ]));
    // Traffic has not answered yet: the robot stands, waiting for its word.
    for i in 0..10 {
        r.handle(at(i as f64 * 0.01), Event::Tick);
    }
    assert_eq!(r.body.goal(), None);
    r.handle(at(0.1), Event::Traffic { map: map.hash.clone(), order: mrmm_proto::TrafficOrder::Free, deputy: false });
    r.handle(at(0.11), Event::Tick);
    assert_eq!(r.body.goal(), Some((4.0, 0.0)), "the first goal, not the next one");
    // It gets there, then drives on to the next.
    let mut seen_first = false;
    for i in 12..400 {
        r.handle(at(i as f64 * 0.01), Event::Tick);
        let p = r.body.pose();
        seen_first |= (p.x - 4.0).abs() < 0.2 && p.y.abs() < 0.2;
    }
    assert!(seen_first, "passed by (4, 0)");
    let p = r.body.pose();
    assert!((p.x - 4.0).abs() < 0.1 && (p.y + 4.0).abs() < 0.1, "{p:?}");
}

/// The same for a goto given to traffic before it answered: its route is driven point by point.
#[test]
fn a_goto_given_to_traffic_is_driven_along_its_route_when_the_map_has_no_lanes() {
    let (mut r, map) = planned_on_map(None);
    cmd(&mut r, RobotCommand::Goto { x: 4.0, y: 4.0, via: vec![[4.0, 0.0]], map: None }).0.expect("goto taken");
    r.handle(at(0.0), Event::Tick);
    assert_eq!(r.body.goal(), None, "traffic's word first");
    r.handle(at(0.05), Event::Traffic { map: map.hash.clone(), order: mrmm_proto::TrafficOrder::Free, deputy: false });
    assert_eq!(r.body.goal(), Some((4.0, 0.0)), "the route's first point");
}

/// A robot that never had a plan on the map, given a goto central says is on it, asks the map's
/// traffic for its way before it drives (before, it drove straight, outside traffic); where the
/// map has no lanes it drives the goto's route.
#[test]
fn a_goto_on_a_map_goes_to_its_traffic_without_a_plan_before() {
    let mut r = Robot::new(cfg());
    let map = mrmm_proto::MapRef { name: "office".into(), hash: "cd".repeat(32) };
    cmd(&mut r, RobotCommand::Goto { x: 4.0, y: 4.0, via: vec![[4.0, 0.0]], map: Some(map.clone()) }).0.expect("goto taken");
    let out = r.handle(at(0.0), Event::Tick);
    let asked =
        out.iter().any(|c| matches!(c, Command::TrafficReport { map: m, report } if *m == map.hash && report.goal.is_some_and(|g| (g.x, g.y) == (4.0, 4.0))));
    assert!(asked, "the goal told to the map's traffic: {out:?}");
    assert_eq!(r.body.goal(), None, "traffic's word first");
    r.handle(at(0.05), Event::Traffic { map: map.hash.clone(), order: mrmm_proto::TrafficOrder::Free, deputy: false });
    assert_eq!(r.body.goal(), Some((4.0, 0.0)), "no lanes: the route's first point");
}

/// On a grid map traffic may give a way off the lanes to the goal (`off`): the robot drives the
/// route, then straight to the goal; for its next goal it first drives back to the vertex it
/// left the lanes at, never straight across.
#[test]
fn a_way_off_the_lanes_is_driven_there_and_back_by_the_vertex() {
    use mrmm_proto::traffic::RouteVertex;
    let (mut r, map) = planned_on_map(Some(vec![
        Step::Navigate { x: 3.0, y: 1.0, speed: None },
        Step::Navigate { x: 0.0, y: -1.0, speed: None },
        Step::Hold { seconds: None },
    ]));
    let (v0, v1) = (RouteVertex::at(0, 0.0, 0.0), RouteVertex::at(1, 3.0, 0.0));
    let order = |goal: u64, version: u64, route: Vec<RouteVertex>, off: [f64; 2]| Event::Traffic {
        map: map.hash.clone(),
        order: mrmm_proto::TrafficOrder::Route { goal, incarnation: 1, version, route, reached: Some(0), upto: Some(1), deputies: vec![], off: Some(off) },
        deputy: false,
    };
    r.handle(at(0.0), Event::Tick);
    r.handle(at(0.01), order(1, 1, vec![v0.clone(), v1.clone()], [3.0, 1.0]));
    let (mut t, mut at_goal, mut back, mut second_order) = (0.02, false, false, false);
    while t < 12.0 {
        r.handle(at(t), Event::Tick);
        let p = r.body.pose();
        at_goal |= (p.x - 3.0).abs() < 0.1 && (p.y - 1.0).abs() < 0.1;
        if at_goal && !second_order {
            // The plan went on to its next goal: the robot heads back to (3, 0) before any order.
            back |= (p.x - 3.0).abs() < 0.16 && p.y.abs() < 0.16;
            if back {
                r.handle(at(t), order(2, 2, vec![v1.clone(), v0.clone()], [0.0, -1.0]));
                second_order = true;
            }
        }
        if at_goal {
            // Never across: on the way back (x = 3), then on the lane (y = 0), then down (x = 0).
            assert!((p.x - 3.0).abs() < 0.15 || p.y.abs() < 0.15 || p.x.abs() < 0.15, "off the ways: {p:?}");
        }
        t += 0.01;
    }
    assert!(at_goal && back && second_order, "at the first goal {at_goal}, back at its vertex {back}");
    let p = r.body.pose();
    assert!(p.x.abs() < 0.1 && (p.y + 1.0).abs() < 0.1, "at the second goal: {p:?}");
}

/// A robot the operator took off the lanes while it was away (central's `cleared` order) holds
/// nothing: it stops where it is and asks for its way anew. A deputy's word to that effect is not
/// taken (only central clears).
#[test]
fn a_robot_taken_off_the_lanes_stops_and_asks_anew() {
    use mrmm_proto::traffic::RouteVertex;
    use mrmm_proto::TrafficOrder;
    let (mut r, map) = planned_on_map(Some(vec![Step::Navigate { x: 100.0, y: 0.0, speed: None }, Step::Hold { seconds: None }]));
    let (v0, v1) = (RouteVertex::at(0, 0.0, 0.0), RouteVertex::at(1, 100.0, 0.0));
    let order = |order: TrafficOrder, deputy: bool| Event::Traffic { map: map.hash.clone(), order, deputy };
    r.handle(at(0.0), Event::Tick);
    let route = TrafficOrder::Route {
        goal: 1,
        incarnation: 1,
        version: 1,
        route: vec![v0.clone(), v1.clone()],
        reached: Some(0),
        upto: Some(1),
        deputies: vec![],
        off: None,
    };
    r.handle(at(0.01), order(route, false));
    let mut t = 0.02;
    // Ticks until `until`: whether the robot asked for its way without holding any.
    let mut drive = |r: &mut Robot, until: f64| {
        let mut asked = false;
        while t < until {
            let out = r.handle(at(t), Event::Tick);
            asked |= out.iter().any(|c| matches!(c, Command::TrafficReport { report, .. } if report.held.is_none() && report.goal.is_some()));
            t += 0.01;
        }
        asked
    };
    drive(&mut r, 0.5);
    let x = r.body.pose().x;
    assert!(x > 0.3, "it drives what it was granted: {x}");
    r.handle(at(0.5), order(TrafficOrder::Cleared { incarnation: 1 }, true));
    drive(&mut r, 1.0);
    assert!(r.body.pose().x > x + 0.3, "a deputy cannot clear it: {x} then {}", r.body.pose().x);
    let x = r.body.pose().x;
    r.handle(at(1.0), order(TrafficOrder::Cleared { incarnation: 1 }, false));
    assert!(drive(&mut r, 3.0), "it asks for its way anew");
    assert!(r.body.pose().x < x + 0.5, "it drove on after it was cleared: from {x} to {}", r.body.pose().x);
}

/// A way off the lanes given, and traffic quiet by the time the robot stands at the route's last
/// vertex: it waits there (the goal is not reached, the plan does not go on) until traffic speaks
/// again, then drives off to the goal.
#[test]
fn a_way_off_the_lanes_waits_for_traffic_gone_quiet() {
    use mrmm_proto::traffic::RouteVertex;
    let (mut r, map) = planned_on_map(Some(vec![Step::Navigate { x: 40.0, y: 1.0, speed: None }, Step::Hold { seconds: None }]));
    let order = || Event::Traffic {
        map: map.hash.clone(),
        order: mrmm_proto::TrafficOrder::Route {
            goal: 1,
            incarnation: 1,
            version: 1,
            route: vec![RouteVertex::at(0, 0.0, 0.0), RouteVertex::at(1, 40.0, 0.0)],
            reached: Some(0),
            upto: Some(1),
            deputies: vec![],
            off: Some([40.0, 1.0]),
        },
        deputy: false,
    };
    // 40 m at 8 m/s (2 m/s, time scale 4): at the vertex after traffic's 3 s of quiet.
    r.handle(at(0.0), Event::Tick);
    r.handle(at(0.01), order());
    let mut t = 0.02;
    while t < 10.0 {
        r.handle(at(t), Event::Tick);
        t += 0.01;
    }
    let p = r.body.pose();
    assert!((p.x - 40.0).abs() < 0.1 && p.y.abs() < 0.1, "waits at the vertex: {p:?}");
    assert_eq!(telemetry(&mut r, at(t)).progress.map(|p| p.step), Some(0), "the goal off the lanes is not reached");
    r.handle(at(t), order());
    while t < 13.0 {
        r.handle(at(t), Event::Tick);
        t += 0.01;
    }
    let p = r.body.pose();
    assert!((p.x - 40.0).abs() < 0.1 && (p.y - 1.0).abs() < 0.1, "at the goal once traffic spoke again: {p:?}");
}

/// The plan paused (a hold plan, as a paused mission sends) while the robot drives a lane of a
/// long grant: it stops at the end of that lane and drives no further toward its old goal, and
/// asks traffic for nothing more.
#[test]
fn a_robot_paused_on_the_lanes_stops_at_the_end_of_its_lane() {
    use mrmm_proto::traffic::RouteVertex;
    let (mut r, map) = planned_on_map(Some(vec![Step::Navigate { x: 100.0, y: 0.0, speed: None }, Step::Hold { seconds: None }]));
    let route = vec![RouteVertex::at(0, 0.0, 0.0), RouteVertex::at(1, 2.0, 0.0), RouteVertex::at(2, 4.0, 0.0), RouteVertex::at(3, 100.0, 0.0)];
    let order = mrmm_proto::TrafficOrder::Route { goal: 1, incarnation: 1, version: 1, route, reached: Some(0), upto: Some(3), deputies: vec![], off: None };
    r.handle(at(0.0), Event::Tick);
    let mut t = 0.01;
    let mut asked_after = false;
    let mut paused = false;
    while t < 20.0 {
        // The authority answers every report with the same order.
        let out = r.handle(at(t), Event::Tick);
        if out.iter().any(|c| matches!(c, Command::TrafficReport { .. })) {
            r.handle(at(t), Event::Traffic { map: map.hash.clone(), order: order.clone(), deputy: false });
        }
        asked_after |= paused && out.iter().any(|c| matches!(c, Command::TrafficReport { report, .. } if report.goal.is_some()));
        if !paused && r.body.pose().x > 1.0 {
            let RobotCommand::Plan(mut a) = plan("m", 2) else { unreachable!() };
            a.map = Some(map.clone());
            a.plan.steps = vec![Step::Stream, Step::Hold { seconds: None }];
            cmd(&mut r, RobotCommand::Plan(a)).0.expect("the hold plan taken");
            paused = true;
        }
        t += 0.01;
    }
    let x = r.body.pose().x;
    assert!(paused && (x - 2.0).abs() < 0.1, "stopped at the lane's end (2, 0), not on toward its old goal: x = {x}");
    assert!(!asked_after, "asked traffic for its old goal after the pause");
}

/// A robot plugged in at a charger on the lanes tells traffic it stands docked (a parking spot
/// it does not leave to make way); unplugged by a new goal, it no longer does.
#[test]
fn a_robot_charging_on_the_lanes_reports_itself_docked() {
    use crate::body::battery::{Battery, BatteryModel};
    let r = Robot::new(RobotSetup { battery: Some(Battery::new(BatteryModel::lasting(100.0, 2.0), 0.5)), ..cfg() });
    let (mut r, _) = plan_on_map(r, Some(vec![Step::Hold { seconds: None }]));
    cmd(&mut r, RobotCommand::Hold).0.expect("held");
    cmd(&mut r, RobotCommand::Charge { on: true }).0.expect("plugged");
    let docked = |out: Vec<Command>| out.iter().rev().find_map(|c| if let Command::TrafficReport { report, .. } = c { Some(report.docked) } else { None });
    let mut said = None;
    for k in 0..30 {
        said = docked(r.handle(at(f64::from(k) * 0.1), Event::Tick)).or(said);
    }
    assert_eq!(said, Some(true), "charging, it says it is docked");
    cmd(&mut r, RobotCommand::Goto { x: 10.0, y: 0.0, via: vec![], map: None }).0.expect("goto");
    for k in 30..60 {
        said = docked(r.handle(at(f64::from(k) * 0.1), Event::Tick)).or(said);
    }
    assert_eq!(said, Some(false), "given a goal, it is no longer docked");
}
