//! Every message mrmm sends a vehicle validates against the official VDA 5050 JSON schemas
//! (committed in `vda5050/schemas/`, see its README): orders new and updated, with and without a
//! horizon, and every instant action the gateway gives.

use mrmm_vda5050::msg::Header;
use mrmm_vda5050::{instant, BlockingType, InstantActions, OrderBook, VehicleId, Waypoint};
use serde_json::Value;

fn schema(version: &str, file: &str) -> jsonschema::Validator {
    let path = format!("{}/schemas/{version}/{file}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let schema: Value = serde_json::from_str(&text).unwrap_or_else(|e| panic!("{path}: {e}"));
    jsonschema::options().should_validate_formats(true).build(&schema).unwrap_or_else(|e| panic!("{path}: {e}"))
}

fn assert_valid(v: &jsonschema::Validator, what: &str, msg: &Value) {
    let errors: Vec<String> = v.iter_errors(msg).map(|e| format!("{} at {}", e, e.instance_path)).collect();
    assert!(errors.is_empty(), "{what} is not valid: {errors:#?}\n{msg:#}");
}

fn w(id: &str, x: f64, y: f64) -> Waypoint {
    Waypoint { node_id: id.into(), x, y }
}

fn vehicle() -> VehicleId {
    VehicleId::new("acme", "agv-7").unwrap()
}

#[test]
fn orders_and_their_updates_validate_against_the_official_schemas() {
    let mut book = OrderBook::new("mrmm-gw", "office");
    let mut orders = Vec::new();
    let mut o = book.release(&w("v3", 1.0, 2.0), &[w("v4", 3.0, 2.0)], &[w("v5", 3.0, 5.0), w("v6", 6.0, 5.0)], Some(0.8));
    o.header = Header::new(1, 1_700_000_000_123, &vehicle());
    orders.push(o);
    let mut u = book.release(&w("v4", 3.0, 2.0), &[w("v5", 3.0, 5.0)], &[w("v6", 6.0, 5.0)], None);
    u.header = Header::new(2, 1_700_000_001_000, &vehicle());
    orders.push(u);
    book.forget();
    let mut n = book.release(&w("v5", 3.0, 5.0), &[w("v6", 6.0, 5.0)], &[], None);
    n.header = Header::new(3, 1_700_000_002_000, &vehicle());
    orders.push(n);
    for version in ["2.0.0", "2.1.0"] {
        let v = schema(version, "order.schema");
        for (i, o) in orders.iter().enumerate() {
            assert_valid(&v, &format!("order {i} under {version}"), &serde_json::to_value(o).unwrap());
        }
    }
}

#[test]
fn instant_actions_validate_against_the_official_schema() {
    let v = schema("2.1.0", "instantActions.schema");
    let actions = ["startPause", "stopPause", "cancelOrder", "startCharging", "stopCharging", "factsheetRequest", "stateRequest"]
        .iter()
        .enumerate()
        .map(|(i, t)| instant(t, format!("mrmm-{i}"), BlockingType::Hard))
        .collect();
    let msg = InstantActions { header: Header::new(9, 1_700_000_000_000, &vehicle()), actions };
    assert_valid(&v, "instantActions", &serde_json::to_value(&msg).unwrap());
}

#[test]
fn the_schema_check_catches_a_message_that_breaks_the_standard() {
    // The test can fail: an order without its edges, or with a node's sequence id negative, is
    // refused by the schemas.
    let mut book = OrderBook::new("mrmm-gw", "office");
    let mut o = serde_json::to_value(book.release(&w("a", 0.0, 0.0), &[w("b", 1.0, 0.0)], &[], None)).unwrap();
    o["edges"] = Value::Null;
    o["nodes"][0]["sequenceId"] = Value::from(-1);
    let v = schema("2.0.0", "order.schema");
    assert!(v.iter_errors(&o).count() >= 2, "{o:#}");
}

#[test]
fn what_the_simulated_vehicle_sends_validates_against_the_official_schemas() {
    use mrmm_vda5050::sim::{SimIn, SimOut, SimVehicle};
    let mut v = SimVehicle::new(vehicle(), "office", (1.0, 2.0, 0.0), 1.2);
    let mut out = v.connect(1_700_000_000_000);
    let mut book = OrderBook::new("mrmm-gw", "office");
    let order = book.release(&w("v3", 1.0, 2.0), &[w("v4", 3.0, 2.0)], &[w("v5", 3.0, 5.0)], Some(0.8));
    out.extend(v.handle(1_700_000_000_050, SimIn::Order(Box::new(order))));
    let cancel = InstantActions {
        header: Header::default(),
        actions: vec![instant("startPause", "a1".into(), BlockingType::Hard), instant("dance", "a2".into(), BlockingType::None)],
    };
    out.extend(v.handle(1_700_000_000_100, SimIn::Instant(cancel)));
    for t in 1..40 {
        out.extend(v.handle(1_700_000_000_100 + t * 50, SimIn::Tick));
    }
    let resume = InstantActions { header: Header::default(), actions: vec![instant("stopPause", "a3".into(), BlockingType::Hard)] };
    out.extend(v.handle(1_700_000_002_100, SimIn::Instant(resume)));
    for t in 1..20 {
        out.extend(v.handle(1_700_000_002_100 + t * 50, SimIn::Tick));
    }
    let kinds: std::collections::BTreeSet<&str> = out
        .iter()
        .map(|o| match o {
            SimOut::State(_) => "state",
            SimOut::Visualization(_) => "visualization",
            SimOut::Connection(_) => "connection",
            SimOut::Factsheet(_) => "factsheet",
        })
        .collect();
    assert_eq!(kinds.len(), 4, "every kind of message is checked: {kinds:?}");
    for version in ["2.0.0", "2.1.0"] {
        let (state, vis, conn) = (schema(version, "state.schema"), schema(version, "visualization.schema"), schema(version, "connection.schema"));
        for (i, o) in out.iter().enumerate() {
            match o {
                SimOut::State(s) => assert_valid(&state, &format!("state {i} under {version}"), &serde_json::to_value(s).unwrap()),
                SimOut::Visualization(m) => assert_valid(&vis, &format!("visualization {i} under {version}"), &serde_json::to_value(m).unwrap()),
                SimOut::Connection(c) => assert_valid(&conn, &format!("connection {i} under {version}"), &serde_json::to_value(c).unwrap()),
                // The factsheet's schema came with 2.1 (2.0.0's factsheet.json is not one).
                SimOut::Factsheet(f) if version == "2.1.0" => assert_valid(&schema(version, "factsheet.schema"), "factsheet", f),
                SimOut::Factsheet(_) => {}
            }
        }
    }
    let errors: Vec<&str> = match out.iter().rev().find_map(|o| if let SimOut::State(s) = o { Some(s) } else { None }) {
        Some(s) => s.errors.iter().map(|e| e.error_type.as_str()).collect(),
        None => Vec::new(),
    };
    assert_eq!(errors, ["actionError"], "the unknown action is reported, and validates");
}
