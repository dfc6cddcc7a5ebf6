//! A robot whose body is a VDA 5050 vehicle: what it sends, and driven against the simulated one.

use super::*;
use crate::at;

/// A VDA 5050 vehicle is sent the goal a tick gives it within that tick (a grant is on the wire
/// at once, not a tick later), and the vehicle's state drives the robot on along its goto.
#[test]
fn a_vda_vehicle_is_sent_its_next_goal_in_the_tick_that_gives_it() {
    let mut r = vda_robot();
    let state = |last: &str, seq: u64, x: f64| {
        let mut s = mrmm_vda5050::State { order_id: "gw-1".into(), last_node_id: last.into(), last_node_sequence_id: seq, ..Default::default() };
        s.agv_position = Some(mrmm_vda5050::msg::AgvPosition { x, y: 0.0, theta: 0.0, map_id: "m".into(), position_initialized: true });
        Event::Vda(Box::new(mrmm_vda5050::FromVehicle::State(Box::new(s))))
    };
    r.handle(at(0.0), state("", 0, 0.0));
    cmd(&mut r, RobotCommand::Goto { x: 4.0, y: 4.0, via: vec![[4.0, 0.0]], map: None }).0.expect("goto taken");
    let orders = |out: Vec<Command>| out.into_iter().filter(|c| matches!(c, Command::Vda(crate::body::vda::VdaOut::Order(_)))).count();
    assert_eq!(orders(r.handle(at(0.02), Event::Tick)), 1, "the first corner");
    r.handle(at(0.5), state("gw-p1", 2, 4.0));
    assert_eq!(orders(r.handle(at(0.52), Event::Tick)), 1, "the corner passed: the goal after it goes out in the same tick");
}

/// The fleet's charging policy plugs a VDA 5050 vehicle in by `startCharging` (and out by
/// `stopCharging`), not on a plan.
#[test]
fn a_vda_vehicle_is_charged_by_instant_actions() {
    let mut r = vda_robot();
    let actions = |out: Vec<Command>| -> Vec<String> {
        out.into_iter()
            .filter_map(|c| match c {
                Command::Vda(crate::body::vda::VdaOut::Instant(a)) => Some(a.into_iter().map(|a| a.action_type)),
                _ => None,
            })
            .flatten()
            .collect()
    };
    cmd(&mut r, RobotCommand::Charge { on: true }).0.expect("plugged");
    assert_eq!(actions(r.handle(at(0.02), Event::Tick)), ["startCharging"]);
    cmd(&mut r, RobotCommand::Charge { on: false }).0.expect("unplugged");
    assert_eq!(actions(r.handle(at(0.04), Event::Tick)), ["stopCharging"]);
}

/// A VDA 5050 vehicle driving back from a goal off the lanes to the vertex it left them at is
/// sent its next route from that vertex in the tick traffic grants it, as an update of the order
/// it drives back by: it drives on through that vertex (the ~1 s grant → order waits the bench
/// found were vehicles sent their next route only once back), never across, no order refused.
/// Driven against the simulated vehicle of `mrmm-vda5050`.
#[test]
fn a_vda_vehicle_driving_back_to_the_lanes_is_sent_its_next_grant_on_the_way() {
    use crate::body::vda::VdaOut;
    use mrmm_proto::traffic::RouteVertex;
    use mrmm_vda5050::sim::{SimIn, SimOut, SimVehicle};
    use mrmm_vda5050::{FromVehicle, InstantActions, VehicleId};
    let (mut r, map) = plan_on_map(
        vda_robot(),
        Some(vec![Step::Navigate { x: 3.0, y: 1.0, speed: None }, Step::Navigate { x: 0.0, y: -1.0, speed: None }, Step::Hold { seconds: None }]),
    );
    let mut vehicle = SimVehicle::new(VehicleId::new("mrmm", "agv1").unwrap(), "m", (0.0, 0.0, 0.0), 1.0);
    let (v0, v1) = (RouteVertex::at(0, 0.0, 0.0), RouteVertex::at(1, 3.0, 0.0));
    let order = |goal: u64, route: Vec<RouteVertex>, off: [f64; 2]| Event::Traffic {
        map: map.hash.clone(),
        order: mrmm_proto::TrafficOrder::Route {
            goal,
            incarnation: 1,
            version: goal,
            route,
            reached: Some(0),
            upto: Some(1),
            deputies: vec![],
            off: Some(off),
        },
        deputy: false,
    };
    let mut to_robot: Vec<SimOut> = vehicle.connect(0);
    // The authority's order, which it sends again in answer to every report.
    let mut current = (1, vec![v0.clone(), v1.clone()], [3.0, 1.0]);
    r.handle(at(0.0), Event::Tick);
    r.handle(at(0.0), order(current.0, current.1.clone(), current.2));
    let (mut at_goal, mut granted, mut released, mut cancels) = (false, None, None, 0);
    for k in 1..1500u64 {
        let t = k as f64 * 0.01;
        for out in to_robot.drain(..) {
            let msg = match out {
                SimOut::State(s) => {
                    assert!(s.errors.is_empty(), "the vehicle refused: {:?}", s.errors);
                    FromVehicle::State(s)
                }
                SimOut::Visualization(v) => FromVehicle::Visualization(v),
                _ => continue,
            };
            r.handle(at(t), Event::Vda(Box::new(msg)));
        }
        let p = r.body.pose();
        at_goal |= (p.x - 3.0).abs() < 0.1 && (p.y - 1.0).abs() < 0.1;
        if at_goal && granted.is_none() && p.y < 0.6 {
            // On its way back to (3, 0): traffic grants the next route, from there.
            current = (2, vec![v1.clone(), v0.clone()], [0.0, -1.0]);
            r.handle(at(t), order(current.0, current.1.clone(), current.2));
            granted = Some(t);
        }
        if at_goal {
            assert!((p.x - 3.0).abs() < 0.15 || p.y.abs() < 0.15 || p.x.abs() < 0.15, "off the ways: {p:?}");
        }
        for c in r.handle(at(t), Event::Tick) {
            let input = match c {
                Command::TrafficReport { .. } => {
                    r.handle(at(t), order(current.0, current.1.clone(), current.2));
                    continue;
                }
                Command::Vda(VdaOut::Order(o)) => {
                    if granted.is_some() && released.is_none() && o.nodes.iter().any(|n| n.released && n.node_id == "v0") {
                        released = Some(t);
                    }
                    SimIn::Order(o)
                }
                Command::Vda(VdaOut::Instant(actions)) => {
                    cancels += actions.iter().filter(|a| a.action_type == "cancelOrder").count();
                    SimIn::Instant(InstantActions { header: Default::default(), actions })
                }
                _ => continue,
            };
            to_robot.extend(vehicle.handle(k * 10, input));
        }
        to_robot.extend(vehicle.handle(k * 10, SimIn::Tick));
    }
    let (granted, released) = (granted.expect("back from the goal off the lanes"), released.expect("the next route released"));
    assert!(released - granted < 0.02, "the grant at {granted:.2} s went out at {released:.2} s");
    assert_eq!(cancels, 0, "no order cancelled");
    let p = r.body.pose();
    assert!(p.x.abs() < 0.1 && (p.y + 1.0).abs() < 0.1, "at the second goal: {p:?}");
}

/// A VDA 5050 vehicle (against the simulated one) paused on a lane (a hold plan) is told
/// `startPause` and stands where it is, with its order kept — no `cancelOrder`.
#[test]
fn a_vda_vehicle_paused_on_the_lanes_is_paused_where_it_is() {
    use crate::body::vda::VdaOut;
    use mrmm_proto::traffic::RouteVertex;
    use mrmm_vda5050::sim::{SimIn, SimOut, SimVehicle};
    use mrmm_vda5050::{FromVehicle, InstantActions, VehicleId};
    let (mut r, map) = plan_on_map(vda_robot(), Some(vec![Step::Navigate { x: 100.0, y: 0.0, speed: None }, Step::Hold { seconds: None }]));
    let mut vehicle = SimVehicle::new(VehicleId::new("mrmm", "agv1").unwrap(), "m", (0.0, 0.0, 0.0), 1.0);
    let route = vec![RouteVertex::at(0, 0.0, 0.0), RouteVertex::at(1, 2.0, 0.0), RouteVertex::at(2, 4.0, 0.0), RouteVertex::at(3, 100.0, 0.0)];
    let order = mrmm_proto::TrafficOrder::Route { goal: 1, incarnation: 1, version: 1, route, reached: Some(0), upto: Some(3), deputies: vec![], off: None };
    let mut to_robot: Vec<SimOut> = vehicle.connect(0);
    r.handle(at(0.0), Event::Tick);
    let (mut paused, mut sent) = (None, Vec::new());
    for k in 1..1000u64 {
        let t = k as f64 * 0.01;
        for out in to_robot.drain(..) {
            let msg = match out {
                SimOut::State(s) => FromVehicle::State(s),
                SimOut::Visualization(v) => FromVehicle::Visualization(v),
                _ => continue,
            };
            r.handle(at(t), Event::Vda(Box::new(msg)));
        }
        if paused.is_none() && r.body.pose().x > 1.0 {
            let RobotCommand::Plan(mut a) = plan("m", 2) else { unreachable!() };
            a.map = Some(map.clone());
            a.plan.steps = vec![Step::Stream, Step::Hold { seconds: None }];
            cmd(&mut r, RobotCommand::Plan(a)).0.expect("the hold plan taken");
            paused = Some(r.body.pose().x);
        }
        for c in r.handle(at(t), Event::Tick) {
            let input = match c {
                Command::TrafficReport { .. } => {
                    r.handle(at(t), Event::Traffic { map: map.hash.clone(), order: order.clone(), deputy: false });
                    continue;
                }
                Command::Vda(VdaOut::Order(o)) => SimIn::Order(o),
                Command::Vda(VdaOut::Instant(actions)) => {
                    sent.extend(actions.iter().map(|a| a.action_type.clone()));
                    SimIn::Instant(InstantActions { header: Default::default(), actions })
                }
                _ => continue,
            };
            to_robot.extend(vehicle.handle(k * 10, input));
        }
        to_robot.extend(vehicle.handle(k * 10, SimIn::Tick));
    }
    let (at, x) = (paused.expect("paused on the lane"), vehicle.pose().0);
    assert_eq!(sent, ["startPause"], "paused, its order kept");
    assert!(x < 2.0 && x - at < 0.3, "stands where it was paused ({at:.2}), on the lane: x = {x:.2}");
    assert!(vehicle.state().paused == Some(true));
}
