//! The VDA 5050 2.0 messages a master control sends (`order`, `instantActions`) and those it
//! reads (`state`, `connection`, `factsheet`, `visualization`), as serde types in the standard's
//! field names. What is sent is exactly what the official schemas allow (tests/schemas.rs); what
//! is read is taken leniently — a field a vehicle leaves out takes its default — and checked by
//! [`State::check`] before anyone acts on it.

use serde::{Deserialize, Serialize};

/// The protocol version mrmm speaks (the `version` field of every message it sends).
pub const VERSION: &str = "2.0.0";

/// The header every message carries.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", default)]
pub struct Header {
    /// Per topic, +1 with each message sent.
    pub header_id: u64,
    /// ISO 8601, UTC.
    pub timestamp: String,
    pub version: String,
    pub manufacturer: String,
    pub serial_number: String,
}

impl Header {
    /// The header of message `header_id` (per topic) to `vehicle`, sent `unix_ms` milliseconds
    /// after 1970 (UTC, ISO 8601 to the millisecond).
    pub fn new(header_id: u64, unix_ms: u64, vehicle: &crate::VehicleId) -> Header {
        let at = std::time::UNIX_EPOCH + std::time::Duration::from_millis(unix_ms);
        Header {
            header_id,
            timestamp: humantime::format_rfc3339_millis(at).to_string(),
            version: VERSION.into(),
            manufacturer: vehicle.manufacturer.clone(),
            serial_number: vehicle.serial_number.clone(),
        }
    }
}

/// `order`: the graph a vehicle is to drive, base (released) then horizon.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct Order {
    #[serde(flatten)]
    pub header: Header,
    pub order_id: String,
    pub order_update_id: u64,
    pub nodes: Vec<Node>,
    pub edges: Vec<Edge>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct Node {
    pub node_id: String,
    /// Even: nodes and edges alternate, 0, 1, 2, … over one order.
    pub sequence_id: u64,
    pub released: bool,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub node_position: Option<NodePosition>,
    pub actions: Vec<Action>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct NodePosition {
    pub x: f64,
    pub y: f64,
    /// Within the deviation of this many metres the node counts as passed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub allowed_deviation_xy: Option<f64>,
    pub map_id: String,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct Edge {
    pub edge_id: String,
    /// Odd: between the sequence ids of its two nodes.
    pub sequence_id: u64,
    pub released: bool,
    pub start_node_id: String,
    pub end_node_id: String,
    /// m/s
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_speed: Option<f64>,
    pub actions: Vec<Action>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "UPPERCASE")]
pub enum BlockingType {
    None,
    Soft,
    Hard,
}

/// An action (of a node, an edge, or instant).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct Action {
    pub action_type: String,
    pub action_id: String,
    pub blocking_type: BlockingType,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub action_parameters: Vec<ActionParameter>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ActionParameter {
    pub key: String,
    pub value: serde_json::Value,
}

/// `instantActions`: actions a vehicle carries out at once (pause, cancel the order, charge).
///
/// VDA 5050 2.0 names the list twice over: its JSON schema (and 2.1) `actions`, its text (and
/// 1.1, and vehicles built to it such as vda-5050-lib's) `instantActions`. Neither schema forbids
/// other fields, so the list is sent under both names and read from either.
#[derive(Debug, Clone, PartialEq)]
pub struct InstantActions {
    pub header: Header,
    pub actions: Vec<Action>,
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct InstantActionsOut<'a> {
    #[serde(flatten)]
    header: &'a Header,
    actions: &'a [Action],
    instant_actions: &'a [Action],
}

#[derive(Deserialize)]
#[serde(rename_all = "camelCase")]
struct InstantActionsIn {
    #[serde(flatten)]
    header: Header,
    #[serde(default)]
    actions: Option<Vec<Action>>,
    #[serde(default)]
    instant_actions: Option<Vec<Action>>,
}

impl Serialize for InstantActions {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        InstantActionsOut { header: &self.header, actions: &self.actions, instant_actions: &self.actions }.serialize(s)
    }
}

impl<'de> Deserialize<'de> for InstantActions {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<InstantActions, D::Error> {
        let m = InstantActionsIn::deserialize(d)?;
        match m.actions.or(m.instant_actions) {
            Some(actions) => Ok(InstantActions { header: m.header, actions }),
            None => Err(serde::de::Error::missing_field("actions")),
        }
    }
}

/// `connection`: ONLINE when a vehicle connects, OFFLINE when it leaves, CONNECTIONBROKEN as its
/// broker-held last will.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct Connection {
    #[serde(flatten)]
    pub header: Header,
    pub connection_state: ConnectionState,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "UPPERCASE")]
pub enum ConnectionState {
    Online,
    Offline,
    #[serde(rename = "CONNECTIONBROKEN")]
    ConnectionBroken,
}

/// `state`: what a vehicle reports (the fields mrmm reads).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", default)]
pub struct State {
    #[serde(flatten)]
    pub header: Header,
    pub order_id: String,
    pub order_update_id: u64,
    pub last_node_id: String,
    pub last_node_sequence_id: u64,
    pub node_states: Vec<NodeState>,
    pub edge_states: Vec<EdgeState>,
    pub driving: bool,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub paused: Option<bool>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub agv_position: Option<AgvPosition>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub velocity: Option<AgvVelocity>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub battery_state: Option<BatteryState>,
    pub operating_mode: String,
    pub errors: Vec<VehicleError>,
    pub action_states: Vec<ActionState>,
    /// Required by the standard in what a vehicle sends; mrmm does not act on it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub safety_state: Option<SafetyState>,
}

/// `safetyState`: the vehicle's emergency stop and protective fields.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", default)]
pub struct SafetyState {
    /// `AUTOACK`, `MANUAL`, `REMOTE` or `NONE`.
    pub e_stop: String,
    pub field_violation: bool,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", default)]
pub struct NodeState {
    pub node_id: String,
    pub sequence_id: u64,
    pub released: bool,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", default)]
pub struct EdgeState {
    pub edge_id: String,
    pub sequence_id: u64,
    pub released: bool,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", default)]
pub struct AgvPosition {
    pub x: f64,
    pub y: f64,
    pub theta: f64,
    pub map_id: String,
    pub position_initialized: bool,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct AgvVelocity {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub vx: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub vy: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub omega: Option<f64>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", default)]
pub struct BatteryState {
    /// Percent, 0–100.
    pub battery_charge: f64,
    pub charging: bool,
    /// Metres the vehicle can still drive, if it says.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reach: Option<f64>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", default)]
pub struct VehicleError {
    pub error_type: String,
    /// `WARNING` or `FATAL`.
    pub error_level: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error_description: Option<String>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", default)]
pub struct ActionState {
    pub action_id: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub action_type: Option<String>,
    /// WAITING, INITIALIZING, RUNNING, PAUSED, FINISHED or FAILED.
    pub action_status: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub result_description: Option<String>,
}

/// `factsheet` (the fields mrmm reads): the vehicle's series, top speed and actions.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", default)]
pub struct Factsheet {
    #[serde(flatten)]
    pub header: Header,
    pub type_specification: Option<TypeSpecification>,
    pub physical_parameters: Option<PhysicalParameters>,
    pub protocol_features: Option<ProtocolFeatures>,
}

/// The standard's actions a master control runs a vehicle by (pause, charge, cancel, ask), not
/// work the vehicle does for a mission.
pub const CONTROL_ACTIONS: [&str; 9] =
    ["startPause", "stopPause", "startCharging", "stopCharging", "initPosition", "stateRequest", "logReport", "cancelOrder", "factsheetRequest"];

impl Factsheet {
    /// The work the vehicle says it does (`pick`, `drop`, `detectObject`, its maker's own
    /// actions): its actions but [`CONTROL_ACTIONS`], in its order, each once.
    pub fn work(&self) -> Vec<&str> {
        let mut work: Vec<&str> = Vec::new();
        for a in self.protocol_features.iter().flat_map(|p| &p.agv_actions) {
            let t = a.action_type.as_str();
            if !t.is_empty() && !CONTROL_ACTIONS.contains(&t) && !work.contains(&t) {
                work.push(t);
            }
        }
        work
    }
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", default)]
pub struct TypeSpecification {
    pub series_name: String,
    pub agv_kinematic: String,
    pub agv_class: String,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", default)]
pub struct PhysicalParameters {
    pub speed_max: Option<f64>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", default)]
pub struct ProtocolFeatures {
    pub agv_actions: Vec<FactsheetAction>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", default)]
pub struct FactsheetAction {
    pub action_type: String,
}

/// `visualization`: where the vehicle is, more often than its state says.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", default)]
pub struct Visualization {
    #[serde(flatten)]
    pub header: Header,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub agv_position: Option<AgvPosition>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub velocity: Option<AgvVelocity>,
}

/// What a vehicle says that its robot takes.
#[derive(Debug, Clone, PartialEq)]
pub enum FromVehicle {
    State(Box<State>),
    Visualization(Visualization),
}
