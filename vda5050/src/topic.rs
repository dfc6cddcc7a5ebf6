//! VDA 5050 topics: `<interface>/<major>/<manufacturer>/<serialNumber>/<subtopic>`, e.g.
//! `uagv/v2/acme/0042/state`; built and parsed here only.

use crate::Vda5050Error;

/// The standard's default interface name.
pub const INTERFACE: &str = "uagv";
/// The major version in topics of VDA 5050 2.x.
pub const MAJOR: &str = "v2";
/// Longest manufacturer or serial number taken, characters.
pub const MAX_NAME: usize = 128;

/// The last level of a topic: what the message is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Subtopic {
    Order,
    InstantActions,
    State,
    Visualization,
    Connection,
    Factsheet,
}

impl Subtopic {
    pub fn as_str(self) -> &'static str {
        match self {
            Subtopic::Order => "order",
            Subtopic::InstantActions => "instantActions",
            Subtopic::State => "state",
            Subtopic::Visualization => "visualization",
            Subtopic::Connection => "connection",
            Subtopic::Factsheet => "factsheet",
        }
    }

    fn parse(s: &str) -> Option<Subtopic> {
        [Subtopic::Order, Subtopic::InstantActions, Subtopic::State, Subtopic::Visualization, Subtopic::Connection, Subtopic::Factsheet]
            .into_iter()
            .find(|t| t.as_str() == s)
    }

    /// What vehicles publish (a master control subscribes to these).
    pub const FROM_VEHICLES: [Subtopic; 4] = [Subtopic::Connection, Subtopic::State, Subtopic::Factsheet, Subtopic::Visualization];
}

/// Who a vehicle is: the pair the standard identifies it by.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct VehicleId {
    pub manufacturer: String,
    pub serial_number: String,
}

impl VehicleId {
    /// Checked: both 1..=[`MAX_NAME`] characters of `A-Z a-z 0-9 _ . : -` (what the standard
    /// allows in a serial number; MQTT's wildcards and level separator are not among them).
    pub fn new(manufacturer: &str, serial_number: &str) -> Result<VehicleId, Vda5050Error> {
        for (what, s) in [("manufacturer", manufacturer), ("serialNumber", serial_number)] {
            let ok = !s.is_empty() && s.len() <= MAX_NAME && s.chars().all(|c| c.is_ascii_alphanumeric() || "_.:-".contains(c));
            if !ok {
                return Err(Vda5050Error::Topic(format!("{what} {s:?}: 1 to {MAX_NAME} characters of A-Z a-z 0-9 _ . : -")));
            }
        }
        Ok(VehicleId { manufacturer: manufacturer.to_string(), serial_number: serial_number.to_string() })
    }
}

impl std::fmt::Display for VehicleId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.manufacturer, self.serial_number)
    }
}

/// The topics of one interface (`uagv`) and major version (`v2`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Topics {
    pub interface: String,
    pub major: String,
}

impl Default for Topics {
    fn default() -> Self {
        Topics { interface: INTERFACE.into(), major: MAJOR.into() }
    }
}

impl Topics {
    /// Checked: each one level of 1..=64 characters, no wildcard or separator.
    pub fn new(interface: &str, major: &str) -> Result<Topics, Vda5050Error> {
        for (what, s) in [("interface", interface), ("version", major)] {
            if s.is_empty() || s.len() > 64 || s.contains(['/', '+', '#']) {
                return Err(Vda5050Error::Topic(format!("{what} {s:?}: one topic level of 1 to 64 characters, without / + #")));
            }
        }
        Ok(Topics { interface: interface.into(), major: major.into() })
    }

    /// The topic of `sub` for `vehicle`.
    pub fn of(&self, vehicle: &VehicleId, sub: Subtopic) -> String {
        format!("{}/{}/{}/{}/{}", self.interface, self.major, vehicle.manufacturer, vehicle.serial_number, sub.as_str())
    }

    /// The filter of `sub` for every vehicle.
    pub fn every(&self, sub: Subtopic) -> String {
        format!("{}/{}/+/+/{}", self.interface, self.major, sub.as_str())
    }

    /// The vehicle and subtopic of a topic of this interface.
    pub fn parse(&self, topic: &str) -> Result<(VehicleId, Subtopic), Vda5050Error> {
        let parts: Vec<&str> = topic.split('/').collect();
        let [i, m, manufacturer, serial, sub] = parts.as_slice() else {
            return Err(Vda5050Error::Topic(format!("{topic:?}: not <interface>/<version>/<manufacturer>/<serialNumber>/<topic>")));
        };
        if *i != self.interface || *m != self.major {
            return Err(Vda5050Error::Topic(format!("{topic:?}: not of {}/{}", self.interface, self.major)));
        }
        let sub = Subtopic::parse(sub).ok_or_else(|| Vda5050Error::Topic(format!("{topic:?}: unknown topic {sub:?}")))?;
        Ok((VehicleId::new(manufacturer, serial)?, sub))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn topics_are_built_and_parsed_from_one_declaration() {
        let t = Topics::default();
        let v = VehicleId::new("acme", "0042").unwrap();
        let s = t.of(&v, Subtopic::InstantActions);
        assert_eq!(s, "uagv/v2/acme/0042/instantActions");
        assert_eq!(t.parse(&s).unwrap(), (v, Subtopic::InstantActions));
        assert_eq!(t.every(Subtopic::State), "uagv/v2/+/+/state");
    }

    #[test]
    fn bad_topics_and_names_are_refused_with_the_reason() {
        let t = Topics::default();
        assert!(t.parse("uagv/v2/acme/0042").unwrap_err().to_string().contains("not <interface>"));
        assert!(t.parse("uagv/v1/acme/0042/state").unwrap_err().to_string().contains("not of uagv/v2"));
        assert!(t.parse("uagv/v2/acme/0042/orders").unwrap_err().to_string().contains("unknown topic"));
        assert!(t.parse("uagv/v2/ac me/0042/state").is_err());
        assert!(VehicleId::new("acme", &"9".repeat(MAX_NAME + 1)).is_err());
        assert!(VehicleId::new("", "1").is_err());
        assert!(Topics::new("uagv/x", "v2").is_err());
    }
}
