//! The simulated vehicle against the orders a master control sends ([`OrderBook`]) and against
//! the standard's rules for refusing them.

use super::*;
use crate::{instant, BlockingType, OrderBook, Waypoint};

fn w(id: &str, x: f64, y: f64) -> Waypoint {
    Waypoint { node_id: id.into(), x, y }
}

fn vehicle() -> SimVehicle {
    SimVehicle::new(VehicleId::new("mrmm", "agv1").unwrap(), "office", (0.0, 0.0, 0.0), 1.0)
}

/// Ticks of 50 ms for `s` seconds from `t` (ms); the last state said.
fn run(v: &mut SimVehicle, t: &mut u64, s: f64) -> Option<State> {
    let mut last = None;
    for _ in 0..(s * 20.0) as usize {
        *t += 50;
        for o in v.handle(*t, SimIn::Tick) {
            if let SimOut::State(st) = o {
                last = Some(*st);
            }
        }
    }
    last
}

fn state_after(v: &mut SimVehicle, t: u64, input: SimIn) -> State {
    v.handle(t, input).into_iter().find_map(|o| if let SimOut::State(s) = o { Some(*s) } else { None }).expect("a change says its state")
}

fn errors(s: &State) -> Vec<&str> {
    s.errors.iter().map(|e| e.error_type.as_str()).collect()
}

#[test]
fn a_vehicle_drives_its_base_stops_before_the_horizon_and_drives_on_when_an_update_releases_more() {
    let mut v = vehicle();
    let mut t = 1_000;
    v.connect(t);
    let mut book = OrderBook::new("gw", "office");
    let o = book.release(&w("start", 0.0, 0.0), &[w("a", 1.0, 0.0)], &[w("b", 2.0, 0.0), w("c", 3.0, 0.0)], None);
    let s = state_after(&mut v, t, SimIn::Order(Box::new(o)));
    assert_eq!((s.last_node_id.as_str(), s.node_states.len(), s.errors.len()), ("start", 3, 0));
    let s = run(&mut v, &mut t, 3.0).expect("states");
    assert_eq!((s.last_node_id.as_str(), s.last_node_sequence_id, s.driving), ("a", 2, false), "it stops at the base's end");
    assert!((v.pose().0 - 1.0).abs() < 1e-9, "not into the horizon: {:?}", v.pose());
    let u = book.release(&w("a", 1.0, 0.0), &[w("b", 2.0, 0.0), w("c", 3.0, 0.0)], &[], None);
    let s = state_after(&mut v, t, SimIn::Order(Box::new(u.clone())));
    assert_eq!((s.order_update_id, errors(&s).len()), (1, 0), "stitched at the last base node: {:?}", s.errors);
    assert!(v.handle(t, SimIn::Order(Box::new(u))).is_empty(), "a duplicate is ignored, nothing changes");
    let s = run(&mut v, &mut t, 3.0).expect("states");
    assert_eq!((s.last_node_id.as_str(), s.last_node_sequence_id, s.node_states.len()), ("c", 6, 0));
    assert!(s.battery_state.is_some_and(|b| b.battery_charge < 100.0), "driving uses the battery");
}

#[test]
fn orders_the_standard_refuses_are_refused_with_its_error_and_change_nothing() {
    let mut v = vehicle();
    let mut book = OrderBook::new("gw", "office");
    let far = book.release(&w("x", 5.0, 5.0), &[w("y", 6.0, 5.0)], &[], None);
    assert_eq!(errors(&state_after(&mut v, 1, SimIn::Order(Box::new(far)))), ["orderError"], "a new order must start where it stands");
    book.forget();
    let o = book.release(&w("s", 0.0, 0.0), &[w("a", 1.0, 0.0)], &[w("b", 2.0, 0.0)], None);
    assert!(errors(&state_after(&mut v, 2, SimIn::Order(Box::new(o.clone())))).is_empty(), "a good order clears the error");
    let good = book.release(&w("a", 1.0, 0.0), &[w("b", 2.0, 0.0)], &[], None);
    let mut off = good.clone();
    off.nodes[0].node_id = "b".into();
    off.edges[0].start_node_id = "b".into();
    assert_eq!(errors(&state_after(&mut v, 3, SimIn::Order(Box::new(off)))), ["orderUpdateError"], "not stitched at the last base node");
    assert!(errors(&state_after(&mut v, 4, SimIn::Order(Box::new(good)))).is_empty());
    assert_eq!(errors(&state_after(&mut v, 4, SimIn::Order(Box::new(o.clone())))), ["orderUpdateError"], "an older update");
    let other = OrderBook::new("other", "office").release(&w("s", 0.0, 0.0), &[w("z", 0.0, 1.0)], &[], None);
    assert_eq!(errors(&state_after(&mut v, 5, SimIn::Order(Box::new(other)))), ["orderUpdateError", "orderError"], "a new order while one is driven");
    let mut broken = o;
    broken.order_id = "gw-9".into();
    broken.edges.pop();
    assert!(errors(&state_after(&mut v, 6, SimIn::Order(Box::new(broken)))).contains(&"validationError"));
    assert_eq!((v.state().order_id.as_str(), v.state().node_states.len()), ("gw-2", 2), "none of them changed the order");
    assert_eq!(v.state().order_update_id, 1);
}

#[test]
fn cancel_pause_and_charging_are_carried_out_and_said_in_the_action_states() {
    let mut v = vehicle();
    let mut t = 0;
    let mut book = OrderBook::new("gw", "office");
    v.handle(t, SimIn::Order(Box::new(book.release(&w("s", 0.0, 0.0), &[w("a", 4.0, 0.0)], &[], None))));
    let act = |ty: &str, id: &str| SimIn::Instant(InstantActions { header: Header::default(), actions: vec![instant(ty, id.into(), BlockingType::Hard)] });
    run(&mut v, &mut t, 1.0);
    let s = state_after(&mut v, t, act("startPause", "p1"));
    assert_eq!((s.paused, s.action_states[0].action_status.as_str()), (Some(true), "FINISHED"));
    let at = v.pose().0;
    run(&mut v, &mut t, 1.0);
    assert_eq!(v.pose().0, at, "paused, it stands");
    v.handle(t, act("stopPause", "p2"));
    let s = state_after(&mut v, t, act("stopPause", "p3"));
    assert_eq!(s.action_states.last().map(|a| a.action_status.as_str()), Some("FAILED"), "not paused: nothing to stop (as vda-5050-lib says)");
    run(&mut v, &mut t, 1.0);
    assert!(v.pose().0 > at + 0.5, "resumed, it drives on");
    let s = state_after(&mut v, t, act("startCharging", "c1"));
    assert_eq!(s.action_states.last().map(|a| a.action_status.as_str()), Some("FAILED"), "no charging while driving");
    let s = state_after(&mut v, t, act("cancelOrder", "k1"));
    assert_eq!((s.node_states.len(), s.driving, s.action_states.last().map(|a| a.action_status.as_str())), (0, false, Some("FINISHED")));
    let stopped = v.pose().0;
    run(&mut v, &mut t, 1.0);
    assert_eq!(v.pose().0, stopped, "cancelled, it stands");
    let s = state_after(&mut v, t, act("cancelOrder", "k2"));
    assert_eq!(s.action_states.last().map(|a| a.action_status.as_str()), Some("FAILED"), "nothing left to cancel");
    assert!(errors(&s).contains(&"noOrderToCancel"));
    v.set_battery(50.0);
    v.handle(t, act("startCharging", "c2"));
    let s = run(&mut v, &mut t, 2.0).expect("states");
    assert!(s.battery_state.as_ref().is_some_and(|b| b.charging && b.battery_charge > 50.5), "{:?}", s.battery_state);
    let out = v.handle(t, act("factsheetRequest", "f1"));
    assert!(out.iter().any(|o| matches!(o, SimOut::Factsheet(_))), "a factsheet asked for is sent");
}

#[test]
fn states_come_once_a_second_and_on_change_visualizations_while_driving() {
    let mut v = vehicle();
    let mut t = 0;
    v.connect(t);
    let count = |v: &mut SimVehicle, t: &mut u64, secs: u64| {
        let (mut states, mut vis) = (0, 0);
        for _ in 0..secs * 20 {
            *t += 50;
            for o in v.handle(*t, SimIn::Tick) {
                match o {
                    SimOut::State(_) => states += 1,
                    SimOut::Visualization(_) => vis += 1,
                    _ => {}
                }
            }
        }
        (states, vis)
    };
    assert_eq!(count(&mut v, &mut t, 5), (5, 0), "standing: a state a second, no visualization");
    let mut book = OrderBook::new("gw", "office");
    v.handle(t, SimIn::Order(Box::new(book.release(&w("s", 0.0, 0.0), &[w("a", 10.0, 0.0)], &[], None))));
    let (states, vis) = count(&mut v, &mut t, 2);
    assert!((2..=4).contains(&states) && (15..=20).contains(&vis), "driving: {states} states, {vis} visualizations");
}

#[test]
fn instant_actions_are_sent_under_both_names_of_2_0_and_read_from_either() {
    let msg = InstantActions { header: Header::default(), actions: vec![instant("startPause", "a1".into(), BlockingType::Hard)] };
    let v = serde_json::to_value(&msg).unwrap();
    assert_eq!(v["actions"], v["instantActions"], "{v}");
    for key in ["actions", "instantActions"] {
        let one = serde_json::json!({ "headerId": 1, key: [{ "actionType": "stopPause", "actionId": "a2", "blockingType": "HARD" }] });
        let read: InstantActions = serde_json::from_value(one).unwrap();
        assert_eq!(read.actions[0].action_type, "stopPause", "{key}");
    }
    assert!(serde_json::from_value::<InstantActions>(serde_json::json!({ "headerId": 1 })).unwrap_err().to_string().contains("missing field `actions`"));
}
