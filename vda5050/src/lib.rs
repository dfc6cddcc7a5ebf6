//! VDA 5050 for mrmm, without I/O: the messages ([`msg`]), the topics ([`topic`]) and the orders a
//! master control gives a vehicle ([`order`]). The gateway (`mrmm vda5050`) carries them over
//! MQTT; a vehicle is a fleet robot whose body is driven through them.
// Functions outside tests are at most 80 lines (clippy.toml); tests may be longer.
#![cfg_attr(not(test), deny(clippy::too_many_lines))]

pub mod msg;
pub mod order;
pub mod sim;
pub mod topic;

pub use msg::{Action, BlockingType, Connection, ConnectionState, Factsheet, FromVehicle, InstantActions, Order, State, Visualization};
pub use order::{OrderBook, Waypoint};
pub use topic::{Subtopic, Topics, VehicleId};

/// Largest message taken from a vehicle, bytes (a state of a long order is a few tens of KiB).
pub const MAX_MESSAGE: usize = 256 * 1024;
/// Most node or edge states, errors or action states a state may list.
pub const MAX_LIST: usize = 4096;

/// What can be wrong with what a vehicle sent, or with a name.
#[derive(Debug, thiserror::Error)]
pub enum Vda5050Error {
    #[error("topic: {0}")]
    Topic(String),
    #[error("{topic}: {bytes} bytes, over the {MAX_MESSAGE}-byte limit")]
    TooLarge { topic: &'static str, bytes: usize },
    #[error("{topic}: {source}")]
    Json {
        topic: &'static str,
        #[source]
        source: serde_json::Error,
    },
    #[error("state: {0}")]
    State(String),
}

/// A message of `topic` from its bytes: bounded, and its JSON's first error named.
pub fn parse<T: serde::de::DeserializeOwned>(topic: Subtopic, bytes: &[u8]) -> Result<T, Vda5050Error> {
    let name = topic.as_str();
    if bytes.len() > MAX_MESSAGE {
        return Err(Vda5050Error::TooLarge { topic: name, bytes: bytes.len() });
    }
    serde_json::from_slice(bytes).map_err(|source| Vda5050Error::Json { topic: name, source })
}

impl msg::FromVehicle {
    /// Whether it can be acted on ([`State::check`], [`Visualization::check`]).
    pub fn check(&self) -> Result<(), Vda5050Error> {
        match self {
            msg::FromVehicle::State(s) => s.check(),
            msg::FromVehicle::Visualization(v) => v.check(),
        }
    }
}

impl Visualization {
    /// Whether it can be acted on: numbers finite.
    pub fn check(&self) -> Result<(), Vda5050Error> {
        check_motion(self.agv_position.as_ref(), self.velocity.as_ref())
    }
}

fn check_motion(p: Option<&msg::AgvPosition>, v: Option<&msg::AgvVelocity>) -> Result<(), Vda5050Error> {
    if p.is_some_and(|p| ![p.x, p.y, p.theta].iter().all(|v| v.is_finite())) {
        return Err(Vda5050Error::State("agvPosition: not finite".into()));
    }
    if v.is_some_and(|v| ![v.vx, v.vy, v.omega].iter().flatten().all(|v| v.is_finite())) {
        return Err(Vda5050Error::State("velocity: not finite".into()));
    }
    Ok(())
}

impl State {
    /// Whether the state can be acted on: lists bounded, numbers finite, charge 0–100.
    pub fn check(&self) -> Result<(), Vda5050Error> {
        let lists = [
            ("nodeStates", self.node_states.len()),
            ("edgeStates", self.edge_states.len()),
            ("errors", self.errors.len()),
            ("actionStates", self.action_states.len()),
        ];
        if let Some((what, n)) = lists.iter().find(|(_, n)| *n > MAX_LIST) {
            return Err(Vda5050Error::State(format!("{what}: {n} entries, over {MAX_LIST}")));
        }
        check_motion(self.agv_position.as_ref(), self.velocity.as_ref())?;
        if let Some(b) = &self.battery_state {
            if !(0.0..=100.0).contains(&b.battery_charge) {
                return Err(Vda5050Error::State(format!("batteryState.batteryCharge: {} is not a percentage", b.battery_charge)));
            }
        }
        Ok(())
    }

    /// The first FATAL error's words, if the vehicle reports one (it cannot drive on).
    pub fn fatal(&self) -> Option<String> {
        self.errors.iter().find(|e| e.error_level == "FATAL").map(|e| match &e.error_description {
            Some(d) => format!("{}: {d}", e.error_type),
            None => e.error_type.clone(),
        })
    }

    /// The vehicle refused an order: its `orderError`, `orderUpdateError` or `noRouteError`.
    pub fn order_refused(&self) -> Option<String> {
        self.errors
            .iter()
            .find(|e| matches!(e.error_type.as_str(), "orderError" | "orderUpdateError" | "noRouteError" | "validationError"))
            .map(|e| format!("{}: {}", e.error_type, e.error_description.as_deref().unwrap_or("no description")))
    }
}

/// An instant action of `action_type` with id `id`, no parameters.
pub fn instant(action_type: &str, id: String, blocking: BlockingType) -> Action {
    Action { action_type: action_type.to_string(), action_id: id, blocking_type: blocking, action_parameters: Vec::new() }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A factsheet's actions but the master control's are the vehicle's work.
    #[test]
    fn a_factsheets_work_is_its_actions_but_those_of_control() {
        let f: Factsheet = parse(
            Subtopic::Factsheet,
            br#"{"protocolFeatures": {"agvActions": [{"actionType": "startPause"}, {"actionType": "pick"}, {"actionType": "drop"}, {"actionType": "pick"}, {"actionType": "cancelOrder"}, {"actionType": "acmeLift"}]}}"#,
        )
        .unwrap();
        assert_eq!(f.work(), ["pick", "drop", "acmeLift"]);
        assert!(Factsheet::default().work().is_empty());
    }

    #[test]
    fn a_hostile_state_is_refused_with_the_reason_not_acted_on() {
        let big = vec![b' '; MAX_MESSAGE + 1];
        assert!(matches!(parse::<State>(Subtopic::State, &big), Err(Vda5050Error::TooLarge { .. })));
        let e = parse::<State>(Subtopic::State, br#"{"driving": "yes"}"#).unwrap_err().to_string();
        assert!(e.starts_with("state: invalid type"), "{e}");
        let s: State = parse(Subtopic::State, br#"{"batteryState": {"batteryCharge": 250, "charging": false}}"#).unwrap();
        assert!(s.check().unwrap_err().to_string().contains("250 is not a percentage"));
        let s: State = parse(Subtopic::State, br#"{"errors": [{"errorType": "orderUpdateError", "errorLevel": "WARNING"}]}"#).unwrap();
        assert_eq!(s.order_refused().as_deref(), Some("orderUpdateError: no description"));
        assert_eq!(s.fatal(), None);
    }
}
