//! A simulated VDA 5050 vehicle, without I/O: it takes orders and instant actions as the
//! standard says a vehicle must (a new order where it stands, updates stitched at the last base
//! node, lower update ids refused, duplicates ignored, a base never driven past its last released
//! node), drives its released base at its top speed or the edge's, pauses, charges, and reports
//! `state` (on every change and once a second), `visualization` (ten times a second while it
//! drives), `connection` and `factsheet`. `mrmm vda5050-sim` runs it over MQTT for the demo and
//! the benchmarks; the tests of the gateway drive a vehicle nobody here wrote instead.

use std::collections::VecDeque;

use serde_json::{json, Value};

use crate::msg::{
    ActionState, AgvPosition, AgvVelocity, BatteryState, Connection, ConnectionState, Edge, EdgeState, Header, InstantActions, Node, NodeState, Order,
    SafetyState, State, VehicleError, Visualization,
};
use crate::VehicleId;

/// A state at least this often, ms, even when nothing changed.
pub const STATE_EVERY_MS: u64 = 1000;
/// A visualization this often while driving, ms.
pub const VISUALIZATION_EVERY_MS: u64 = 100;
/// A new order's first node counts as where the vehicle stands within this many metres (when the
/// node gives no `allowedDeviationXY`).
pub const DEVIATION_M: f64 = 0.5;
/// Action states kept in the state, at most (the oldest ended ones go first).
const ACTION_STATES: usize = 32;
/// Battery used per metre driven, percent (a full charge drives 5 km).
const DRAIN_PER_M: f64 = 0.02;
/// Battery gained per second of charging, percent.
const CHARGE_PER_S: f64 = 0.5;
/// The instant actions the vehicle carries out (its factsheet's).
pub const ACTIONS: [&str; 7] = ["cancelOrder", "startPause", "stopPause", "startCharging", "stopCharging", "stateRequest", "factsheetRequest"];

/// What reaches the vehicle.
#[derive(Debug, Clone, PartialEq)]
pub enum SimIn {
    Order(Box<Order>),
    Instant(InstantActions),
    /// Time passes (drive, charge, report).
    Tick,
}

/// What the vehicle publishes (headers filled).
#[derive(Debug, Clone, PartialEq)]
pub enum SimOut {
    State(Box<State>),
    Visualization(Visualization),
    Connection(Connection),
    Factsheet(Box<Value>),
}

/// Per topic, the next header id.
#[derive(Debug, Clone, Default)]
struct Headers {
    state: u64,
    visualization: u64,
    connection: u64,
    factsheet: u64,
}

/// A simulated vehicle.
#[derive(Debug, Clone)]
pub struct SimVehicle {
    id: VehicleId,
    map_id: String,
    x: f64,
    y: f64,
    theta: f64,
    speed_max: f64,
    speed: f64,
    order_id: String,
    order_update_id: u64,
    last_node_id: String,
    last_node_seq: u64,
    /// The order's nodes not yet reached and the edges to them, in order.
    nodes: VecDeque<Node>,
    edges: VecDeque<Edge>,
    paused: bool,
    charging: bool,
    battery: f64,
    errors: Vec<VehicleError>,
    actions: VecDeque<ActionState>,
    headers: Headers,
    now_ms: u64,
    last_state_ms: Option<u64>,
    last_vis_ms: u64,
    changed: bool,
}

impl SimVehicle {
    /// A vehicle standing at (`x`, `y`, `theta`) on map `map_id`, driving at most `speed_max` m/s.
    pub fn new(id: VehicleId, map_id: &str, (x, y, theta): (f64, f64, f64), speed_max: f64) -> SimVehicle {
        SimVehicle {
            id,
            map_id: map_id.to_string(),
            x,
            y,
            theta,
            speed_max,
            speed: 0.0,
            order_id: String::new(),
            order_update_id: 0,
            last_node_id: String::new(),
            last_node_seq: 0,
            nodes: VecDeque::new(),
            edges: VecDeque::new(),
            paused: false,
            charging: false,
            battery: 100.0,
            errors: Vec::new(),
            actions: VecDeque::new(),
            headers: Headers::default(),
            now_ms: 0,
            last_state_ms: None,
            last_vis_ms: 0,
            changed: true,
        }
    }

    pub fn id(&self) -> &VehicleId {
        &self.id
    }

    /// Where it is: x, y, heading.
    pub fn pose(&self) -> (f64, f64, f64) {
        (self.x, self.y, self.theta)
    }

    pub fn set_battery(&mut self, percent: f64) {
        self.battery = percent.clamp(0.0, 100.0);
    }

    /// What it says on connecting: online, its factsheet, its state.
    pub fn connect(&mut self, now_ms: u64) -> Vec<SimOut> {
        self.now_ms = now_ms;
        let online = self.connection(ConnectionState::Online);
        vec![online, self.factsheet(), self.state_now()]
    }

    /// Its `connection` message of `how` (OFFLINE when it leaves; CONNECTIONBROKEN is the last
    /// will the broker holds for it).
    pub fn connection_message(&mut self, how: ConnectionState) -> Connection {
        match self.connection(how) {
            SimOut::Connection(c) => c,
            _ => unreachable!("connection() makes a connection"),
        }
    }

    fn connection(&mut self, how: ConnectionState) -> SimOut {
        let header = self.header(|h| &mut h.connection);
        SimOut::Connection(Connection { header, connection_state: how })
    }

    fn header(&mut self, which: impl Fn(&mut Headers) -> &mut u64) -> Header {
        let id = which(&mut self.headers);
        let h = *id;
        *id += 1;
        Header::new(h, self.now_ms, &self.id)
    }

    /// What happens at `now_ms` (ms since 1970; never earlier than the last call).
    pub fn handle(&mut self, now_ms: u64, input: SimIn) -> Vec<SimOut> {
        let dt = now_ms.saturating_sub(self.now_ms) as f64 / 1000.0;
        self.now_ms = self.now_ms.max(now_ms);
        let mut out = Vec::new();
        match input {
            SimIn::Order(o) => self.order(*o),
            SimIn::Instant(i) => {
                for a in i.actions {
                    if let Some(f) = self.instant(&a.action_type, &a.action_id) {
                        out.push(f);
                    }
                }
            }
            SimIn::Tick => self.advance(dt),
        }
        let moving = self.speed > 0.0;
        let due = self.last_state_ms.is_none_or(|t| self.now_ms >= t + STATE_EVERY_MS);
        if self.changed || due {
            out.push(self.state_now());
        } else if moving && self.now_ms >= self.last_vis_ms + VISUALIZATION_EVERY_MS {
            self.last_vis_ms = self.now_ms;
            let header = self.header(|h| &mut h.visualization);
            out.push(SimOut::Visualization(Visualization { header, agv_position: Some(self.position()), velocity: Some(self.velocity()) }));
        }
        out
    }

    /// Takes an order or an update, or refuses it with the error the standard names.
    fn order(&mut self, o: Order) {
        if let Err(why) = well_formed(&o) {
            return self.refuse("validationError", &why);
        }
        if o.order_id == self.order_id {
            if o.order_update_id < self.order_update_id {
                return self.refuse("orderUpdateError", &format!("update {} is older than {}", o.order_update_id, self.order_update_id));
            }
            if o.order_update_id == self.order_update_id {
                return; // a duplicate: ignored
            }
            let (stitch_id, stitch_seq) = self.last_base();
            if o.nodes[0].node_id != stitch_id || o.nodes[0].sequence_id != stitch_seq {
                let why = format!("update starts at {}/{}, the last base node is {stitch_id}/{stitch_seq}", o.nodes[0].node_id, o.nodes[0].sequence_id);
                return self.refuse("orderUpdateError", &why);
            }
            self.nodes.retain(|n| n.released);
            self.edges.retain(|e| e.released);
        } else {
            if !self.nodes.is_empty() {
                return self.refuse("orderError", &format!("order {} is still being driven", self.order_id));
            }
            let first = &o.nodes[0];
            if let Some(p) = &first.node_position {
                let within = p.allowed_deviation_xy.unwrap_or(DEVIATION_M);
                if (p.x - self.x).hypot(p.y - self.y) > within {
                    return self.refuse("orderError", &format!("the first node {} is not where the vehicle stands", first.node_id));
                }
            }
            self.last_node_id.clone_from(&first.node_id);
            self.last_node_seq = first.sequence_id;
        }
        self.changed = true;
        self.errors.retain(|e| !matches!(e.error_type.as_str(), "orderError" | "orderUpdateError" | "validationError"));
        self.order_id = o.order_id;
        self.order_update_id = o.order_update_id;
        self.nodes.extend(o.nodes.into_iter().skip(1));
        self.edges.extend(o.edges);
    }

    /// The last released node of the order: reached already, or ahead.
    fn last_base(&self) -> (String, u64) {
        match self.nodes.iter().rev().find(|n| n.released) {
            Some(n) => (n.node_id.clone(), n.sequence_id),
            None => (self.last_node_id.clone(), self.last_node_seq),
        }
    }

    fn refuse(&mut self, error_type: &str, why: &str) {
        self.changed = true;
        self.errors.retain(|e| e.error_type != error_type);
        self.errors.push(VehicleError { error_type: error_type.into(), error_level: "WARNING".into(), error_description: Some(why.to_string()) });
    }

    /// Carries out one instant action; a factsheet asked for is returned.
    fn instant(&mut self, action_type: &str, action_id: &str) -> Option<SimOut> {
        self.changed = true;
        let done = match action_type {
            "cancelOrder" if self.nodes.is_empty() && self.speed == 0.0 => Err("noOrderToCancel: no order is being driven"),
            "cancelOrder" => {
                self.nodes.clear();
                self.edges.clear();
                self.speed = 0.0;
                Ok(())
            }
            "startPause" if self.paused => Err("already paused"),
            "startPause" => {
                self.paused = true;
                self.speed = 0.0;
                Ok(())
            }
            "stopPause" if !self.paused => Err("not paused"),
            "stopPause" => {
                self.paused = false;
                Ok(())
            }
            "startCharging" if self.speed > 0.0 => Err("the vehicle is driving"),
            "startCharging" => {
                self.charging = true;
                Ok(())
            }
            "stopCharging" => {
                self.charging = false;
                Ok(())
            }
            "stateRequest" => Ok(()),
            "factsheetRequest" => {
                self.finish(action_id, action_type, None);
                return Some(self.factsheet());
            }
            _ => Err("not an action this vehicle carries out"),
        };
        match done {
            Ok(()) => self.finish(action_id, action_type, None),
            Err(why) => {
                self.finish(action_id, action_type, Some(why));
                let error_type = if action_type == "cancelOrder" { "noOrderToCancel" } else { "actionError" };
                self.refuse(error_type, &format!("{action_type} {action_id}: {why}"));
            }
        }
        None
    }

    fn finish(&mut self, action_id: &str, action_type: &str, failed: Option<&str>) {
        self.actions.push_back(ActionState {
            action_id: action_id.to_string(),
            action_type: Some(action_type.to_string()),
            action_status: if failed.is_some() { "FAILED" } else { "FINISHED" }.into(),
            result_description: failed.map(String::from),
        });
        while self.actions.len() > ACTION_STATES {
            self.actions.pop_front();
        }
    }

    /// Drives `dt` seconds along the released base (or charges).
    fn advance(&mut self, dt: f64) {
        if self.charging {
            self.battery = (self.battery + CHARGE_PER_S * dt).min(100.0);
        }
        let was = self.speed;
        self.speed = 0.0;
        let mut budget = dt;
        while budget > 0.0 && !self.paused && !self.charging && self.battery > 0.0 {
            let Some(next) = self.nodes.front().filter(|n| n.released) else { break };
            let Some(p) = next.node_position.as_ref().map(|p| (p.x, p.y)) else {
                // A node without a position: where it is, the vehicle knows (it is reached).
                self.reach();
                continue;
            };
            let limit = self.edges.front().and_then(|e| e.max_speed).unwrap_or(self.speed_max).min(self.speed_max);
            let (dx, dy) = (p.0 - self.x, p.1 - self.y);
            let d = dx.hypot(dy);
            let step = limit * budget;
            if d > 1e-9 {
                self.theta = dy.atan2(dx);
            }
            let run = step.min(d);
            if d > 1e-9 {
                self.x += dx / d * run;
                self.y += dy / d * run;
            }
            self.battery = (self.battery - DRAIN_PER_M * run).max(0.0);
            self.speed = limit;
            if step >= d {
                budget -= if limit > 0.0 { d / limit } else { budget };
                self.reach();
            } else {
                budget = 0.0;
            }
        }
        if (self.speed > 0.0) != (was > 0.0) {
            self.changed = true;
        }
    }

    /// The next node is reached: it is the last node, it and its edge leave the order.
    fn reach(&mut self) {
        if let Some(n) = self.nodes.pop_front() {
            self.last_node_id = n.node_id;
            self.last_node_seq = n.sequence_id;
            self.edges.pop_front();
            self.changed = true;
        }
    }

    fn position(&self) -> AgvPosition {
        AgvPosition { x: self.x, y: self.y, theta: self.theta, map_id: self.map_id.clone(), position_initialized: true }
    }

    fn velocity(&self) -> AgvVelocity {
        AgvVelocity { vx: Some(self.speed * self.theta.cos()), vy: Some(self.speed * self.theta.sin()), omega: Some(0.0) }
    }

    /// Its state now.
    pub fn state(&self) -> State {
        State {
            header: Header::default(),
            order_id: self.order_id.clone(),
            order_update_id: self.order_update_id,
            last_node_id: self.last_node_id.clone(),
            last_node_sequence_id: self.last_node_seq,
            node_states: self.nodes.iter().map(|n| NodeState { node_id: n.node_id.clone(), sequence_id: n.sequence_id, released: n.released }).collect(),
            edge_states: self.edges.iter().map(|e| EdgeState { edge_id: e.edge_id.clone(), sequence_id: e.sequence_id, released: e.released }).collect(),
            driving: self.speed > 0.0,
            paused: Some(self.paused),
            agv_position: Some(self.position()),
            velocity: Some(self.velocity()),
            battery_state: Some(BatteryState { battery_charge: self.battery, charging: self.charging, reach: Some((self.battery / DRAIN_PER_M).floor()) }),
            operating_mode: "AUTOMATIC".into(),
            errors: self.errors.clone(),
            action_states: self.actions.iter().cloned().collect(),
            safety_state: Some(SafetyState { e_stop: "NONE".into(), field_violation: false }),
        }
    }

    fn state_now(&mut self) -> SimOut {
        self.changed = false;
        self.last_state_ms = Some(self.now_ms);
        self.last_vis_ms = self.now_ms;
        let mut s = self.state();
        s.header = self.header(|h| &mut h.state);
        SimOut::State(Box::new(s))
    }

    /// Its factsheet: a small differential-drive carrier.
    fn factsheet(&mut self) -> SimOut {
        let h = self.header(|h| &mut h.factsheet);
        let actions: Vec<Value> = ACTIONS.iter().map(|a| json!({ "actionType": a, "actionScopes": ["INSTANT"] })).collect();
        SimOut::Factsheet(Box::new(json!({
            "headerId": h.header_id, "timestamp": h.timestamp, "version": h.version,
            "manufacturer": h.manufacturer, "serialNumber": h.serial_number,
            "typeSpecification": {
                "seriesName": "mrmm-sim", "agvKinematic": "DIFF", "agvClass": "CARRIER", "maxLoadMass": 0,
                "localizationTypes": ["NATURAL"], "navigationTypes": ["AUTONOMOUS"]
            },
            "physicalParameters": {
                "speedMin": 0.0, "speedMax": self.speed_max, "accelerationMax": 1.0, "decelerationMax": 1.0,
                "heightMax": 0.5, "width": 0.6, "length": 0.8
            },
            "protocolLimits": { "maxStringLens": {}, "maxArrayLens": {}, "timing": { "minOrderInterval": 0.0, "minStateInterval": 0.1 } },
            "protocolFeatures": { "optionalParameters": [], "agvActions": actions },
            "agvGeometry": {},
            "loadSpecification": {}
        })))
    }
}

/// Whether an order is one the standard allows: nodes and edges alternate (one edge fewer),
/// sequence ids even and odd and rising, each edge between its neighbours, the base before the
/// horizon.
fn well_formed(o: &Order) -> Result<(), String> {
    if o.nodes.is_empty() || o.edges.len() + 1 != o.nodes.len() {
        return Err(format!("{} nodes and {} edges: an order has one edge fewer than nodes", o.nodes.len(), o.edges.len()));
    }
    if !o.nodes[0].released {
        return Err("the first node is not released".into());
    }
    for (i, e) in o.edges.iter().enumerate() {
        let (a, b) = (&o.nodes[i], &o.nodes[i + 1]);
        if a.sequence_id % 2 != 0 || e.sequence_id != a.sequence_id + 1 || b.sequence_id != e.sequence_id + 1 {
            return Err(format!("sequence ids {}, {}, {} do not alternate even/odd", a.sequence_id, e.sequence_id, b.sequence_id));
        }
        if e.start_node_id != a.node_id || e.end_node_id != b.node_id {
            return Err(format!("edge {} does not join {} and {}", e.edge_id, a.node_id, b.node_id));
        }
        if (e.released && !a.released) || (b.released && !e.released) {
            return Err(format!("edge {}: the base is not before the horizon", e.edge_id));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests;
