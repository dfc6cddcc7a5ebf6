//! The VDA 5050 body's unit tests: orders, updates, cancels, pauses, what the vehicle says.

use super::*;
use mrmm_vda5050::msg::AgvPosition;

fn v(v: u32, x: f64) -> RouteVertex {
    RouteVertex::at(v, x, 0.0)
}

fn drive() -> VdaDrive {
    VdaDrive::new(Pose { x: 0.0, y: 0.0, theta: 0.0 }, Limits { max_speed: 1.0, max_turn_rate: 1.0 }, "gw", "m")
}

fn state(order: &str, last: &str, seq: u64, driving: bool, x: f64) -> State {
    State {
        order_id: order.into(),
        last_node_id: last.into(),
        last_node_sequence_id: seq,
        driving,
        agv_position: Some(AgvPosition { x, y: 0.0, theta: 0.0, map_id: "m".into(), position_initialized: true }),
        ..State::default()
    }
}

fn orders(out: Vec<VdaOut>) -> Vec<(String, u64, Vec<String>)> {
    out.into_iter()
        .filter_map(|o| match o {
            VdaOut::Order(o) => Some((o.order_id, o.order_update_id, o.nodes.into_iter().map(|n| n.node_id).collect())),
            VdaOut::Instant(_) => None,
        })
        .collect()
}

#[test]
fn goals_become_an_order_then_updates_stitched_at_the_node_reached() {
    let mut d = drive();
    d.on_state(&state("", "v0", 0, false, 0.0));
    d.navigate_lane(&v(1, 1.0), &[], &[], Some(5.0));
    assert_eq!(orders(d.take()), [("gw-1".to_string(), 0, vec!["v0".to_string(), "v1".to_string()])]);
    d.on_state(&state("gw-1", "v0", 0, true, 0.5));
    assert_eq!(d.goal(), Some((1.0, 0.0)), "still driving");
    d.on_state(&state("gw-1", "v1", 2, false, 1.0));
    assert_eq!(d.goal(), None, "the goal's node passed and the vehicle stopped: idle");
    d.navigate_lane(&v(2, 2.0), &[], &[], None);
    assert_eq!(orders(d.take()), [("gw-1".to_string(), 1, vec!["v1".to_string(), "v2".to_string()])]);
}

fn nodes(out: Vec<VdaOut>) -> Vec<(String, u64, bool)> {
    out.into_iter()
        .flat_map(|o| match o {
            VdaOut::Order(o) => o.nodes.into_iter().map(|n| (n.node_id, n.sequence_id, n.released)).collect(),
            VdaOut::Instant(_) => Vec::new(),
        })
        .collect()
}

fn n(id: &str, seq: u64, released: bool) -> (String, u64, bool) {
    (id.to_string(), seq, released)
}

#[test]
fn on_lanes_the_grant_is_the_base_the_route_the_horizon_and_a_growing_grant_an_update() {
    let mut d = drive();
    d.on_state(&state("", "v0", 0, false, 0.0));
    d.navigate_lane(&v(1, 1.0), &[v(2, 2.0)], &[v(3, 3.0), v(4, 4.0)], None);
    assert_eq!(nodes(d.take()), [n("v0", 0, true), n("v1", 2, true), n("v2", 4, true), n("v3", 6, false), n("v4", 8, false)]);
    d.navigate_lane(&v(1, 1.0), &[v(2, 2.0)], &[v(3, 3.0), v(4, 4.0)], None);
    assert!(d.take().is_empty(), "the same grant again: nothing to send");
    d.navigate_lane(&v(1, 1.0), &[v(2, 2.0), v(3, 3.0)], &[v(4, 4.0)], None);
    assert_eq!(nodes(d.take()), [n("v2", 4, true), n("v3", 6, true), n("v4", 8, false)], "the grant grew: an update stitched at v2");
    // The vehicle passes v1 and drives on: the goal is reached, the vehicle never stopped.
    d.on_state(&state("gw-1", "v1", 2, true, 1.0));
    assert_eq!(d.goal(), None);
    assert!(d.passed(&v(1, 1.0)));
    d.navigate_lane(&v(2, 2.0), &[v(3, 3.0)], &[v(4, 4.0)], None);
    assert!(d.take().is_empty(), "v2 and v3 were released already");
    assert_eq!(d.goal(), Some((2.0, 0.0)));
    // It passes v2 and v3 between two states, and stands at v3, the grant's end.
    d.on_state(&state("gw-1", "v3", 6, false, 3.0));
    assert_eq!(d.goal(), None, "v2 passed");
    d.navigate_lane(&v(3, 3.0), &[], &[v(4, 4.0)], None);
    assert_eq!(d.goal(), None, "v3 passed already");
    assert!(d.take().is_empty());
    d.navigate_lane(&v(4, 4.0), &[], &[], None);
    assert_eq!(nodes(d.take()), [n("v3", 6, true), n("v4", 8, true)]);
}

/// What the vehicle's state says goes to telemetry cut to its bounds: FATAL errors first,
/// actions not yet ended first, no more than telemetry carries.
#[test]
fn the_vehicles_own_word_is_kept_within_telemetrys_bounds() {
    use mrmm_vda5050::msg::{ActionState, VehicleError};
    let mut d = drive();
    let mut s = state("gw-1", "pantry", 2, true, 1.0);
    s.paused = Some(true);
    let error = |level: &str, text: String| VehicleError { error_type: "noRouteError".into(), error_level: level.into(), error_description: Some(text) };
    s.errors = (0..20).map(|_| error("WARNING", "w".into())).chain([error("FATAL", "x".repeat(1000))]).collect();
    let action = |id: &str, status: &str| ActionState {
        action_id: id.into(),
        action_type: Some("startPause".into()),
        action_status: status.into(),
        ..Default::default()
    };
    s.action_states = (0..10).map(|i| action(&format!("a{i}"), "FINISHED")).chain([action(&"b".repeat(100), "RUNNING")]).collect();
    d.on_state(&s);
    let said = d.said().expect("said").clone();
    assert_eq!((said.last_node.as_str(), said.driving, said.paused), ("pantry", true, true));
    assert_eq!((said.errors.len(), said.errors[0].level.as_str()), (MAX_VEHICLE_ITEMS, "FATAL"));
    assert_eq!(said.errors[0].description.as_ref().map(|d| d.len()), Some(MAX_VEHICLE_TEXT));
    assert_eq!((said.actions.len(), said.actions[0].status.as_str(), said.actions[0].id.len()), (MAX_VEHICLE_ITEMS, "RUNNING", MAX_VEHICLE_WORD));
    said.check().expect("within telemetry's bounds");
}

/// A vertex the map names alone is the node of that name; the others go by index.
#[test]
fn a_named_vertex_is_the_node_of_its_name() {
    let mut d = drive();
    d.on_state(&state("", "v0", 0, false, 0.0));
    let named = |v: u32, x: f64, name: &str| RouteVertex { name: Some(name.into()), ..RouteVertex::at(v, x, 0.0) };
    d.navigate_lane(&named(1, 1.0, "dock-1"), &[v(2, 2.0)], &[named(3, 3.0, "N3")], None);
    assert_eq!(nodes(d.take()), [n("v0", 0, true), n("dock-1", 2, true), n("v2", 4, true), n("N3", 6, false)]);
    d.on_state(&state("gw-1", "dock-1", 2, true, 1.0));
    assert!(d.passed(&named(1, 1.0, "dock-1")) && !d.passed(&v(1, 1.0)));
}

#[test]
fn a_way_off_the_base_released_is_a_cancel_then_a_new_order() {
    let mut d = drive();
    d.on_state(&state("", "v0", 0, false, 0.0));
    d.navigate_lane(&v(1, 1.0), &[v(2, 2.0)], &[], None);
    d.take();
    d.navigate_lane(&v(5, 0.0), &[], &[], None);
    let out = d.take();
    assert!(matches!(out.as_slice(), [VdaOut::Instant(a)] if a[0].action_type == "cancelOrder"), "{out:?}");
}

/// A state of `order` with action `id` ended as `status`.
fn ended(order: &str, last: &str, seq: u64, x: f64, id: &str, status: &str) -> State {
    let mut s = state(order, last, seq, false, x);
    s.action_states.push(mrmm_vda5050::msg::ActionState { action_id: id.into(), action_status: status.into(), ..Default::default() });
    s
}

/// [`ended`] FINISHED, the vehicle saying it is paused.
fn paused(order: &str, last: &str, seq: u64, x: f64, id: &str) -> State {
    State { paused: Some(true), ..ended(order, last, seq, x, id, "FINISHED") }
}

#[test]
fn a_hold_pauses_the_vehicle_and_the_next_goal_resumes_it_on_its_order_or_cancels_it_first() {
    let pause_of = |out: &[VdaOut]| out.iter().any(|o| matches!(o, VdaOut::Instant(a) if a[0].action_type == "startPause"));
    let mut d = drive();
    d.on_state(&state("", "v0", 0, false, 0.0));
    d.hold();
    assert!(d.take().is_empty(), "a vehicle with nothing released ahead is left as it stands");
    d.navigate_lane(&v(1, 1.0), &[v(2, 2.0)], &[v(3, 3.0)], None);
    d.take();
    // A hold and a goal in the same tick (a new plan's first): no pause.
    d.hold();
    d.navigate_lane(&v(1, 1.0), &[v(2, 2.0)], &[v(3, 3.0)], None);
    assert!(d.take().is_empty(), "the same way again: nothing to send");
    d.hold();
    let out = d.take();
    assert!(pause_of(&out) && d.paused() && d.goal().is_none(), "{out:?}");
    d.hold();
    assert!(d.take().is_empty(), "paused once");
    // Resumed on the way released: nothing until the vehicle said it paused; then stopPause,
    // and the order goes on (an update).
    d.navigate_lane(&v(1, 1.0), &[v(2, 2.0), v(3, 3.0)], &[], None);
    assert!(d.take().is_empty(), "no stopPause before the vehicle paused (it would refuse it)");
    d.on_state(&paused("gw-1", "v0", 0, 0.2, "gw-a1"));
    let out = d.take();
    assert!(matches!(&out[0], VdaOut::Instant(a) if a[0].action_type == "stopPause"), "{out:?}");
    assert_eq!(orders(out[1..].to_vec()), [("gw-1".to_string(), 1, vec!["v2".to_string(), "v3".to_string()])]);
    d.hold();
    assert!(d.take().is_empty(), "no startPause before the vehicle said it drives again");
    d.on_state(&ended("gw-1", "v0", 0, 0.3, "gw-a2", "FINISHED"));
    assert!(pause_of(&d.take()), "now the hold pauses it");
    // Paused, then sent elsewhere: cancel, then (still paused) stopPause and a new order once
    // the cancel ended.
    d.on_state(&paused("gw-1", "v0", 0, 0.4, "gw-a3"));
    d.navigate(3.0, 5.0, None);
    let out = d.take();
    assert!(matches!(out.as_slice(), [VdaOut::Instant(a)] if a.len() == 1 && a[0].action_type == "cancelOrder"), "{out:?}");
    d.on_state(&state("gw-1", "v1", 2, false, 1.4));
    assert!(d.take().is_empty(), "no new order while the vehicle still cancels the old one");
    d.on_state(&paused("gw-1", "v1", 2, 1.4, "gw-a4"));
    let out = d.take();
    assert!(matches!(&out[0], VdaOut::Instant(a) if a[0].action_type == "stopPause"), "{out:?}");
    let o = orders(out[1..].to_vec());
    assert_eq!((o[0].0.as_str(), o[0].2[0].as_str()), ("gw-2", "v1"), "a new order from the vehicle's last node: {o:?}");
}

#[test]
fn a_pause_the_vehicle_refused_needs_no_stop_pause() {
    let mut d = drive();
    d.on_state(&state("", "v0", 0, false, 0.0));
    d.navigate_lane(&v(1, 1.0), &[v(2, 2.0)], &[], None);
    d.take();
    d.hold();
    d.take();
    d.navigate_lane(&v(1, 1.0), &[v(2, 2.0)], &[], None);
    d.on_state(&ended("gw-1", "v0", 0, 0.2, "gw-a1", "FAILED"));
    let out = d.take();
    assert!(!d.paused() && out.iter().all(|o| !matches!(o, VdaOut::Instant(_))), "{out:?}");
}

#[test]
fn a_vehicle_that_drops_the_order_is_given_the_goal_again_and_its_refusal_is_reported() {
    let mut d = drive();
    d.on_state(&state("", "v0", 0, false, 0.0));
    d.navigate_lane(&v(1, 1.0), &[], &[], None);
    d.take();
    d.on_state(&state("gw-0", "v0", 0, false, 0.0));
    assert!(d.take().is_empty(), "a late state of an earlier order of ours changes nothing");
    d.on_state(&state("theirs", "v0", 0, false, 0.0));
    let o = orders(d.take());
    assert_eq!(o.len(), 1, "{o:?}");
    assert_eq!((o[0].0.as_str(), o[0].2[1].as_str()), ("gw-2", "v1"));
    let mut s = state("gw-2", "v0", 0, false, 0.0);
    s.errors.push(mrmm_vda5050::msg::VehicleError {
        error_type: "noRouteError".into(),
        error_level: "WARNING".into(),
        error_description: Some("blocked".into()),
    });
    d.on_state(&s);
    assert_eq!(d.stuck(), Some("noRouteError: blocked"));
}
