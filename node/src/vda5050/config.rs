//! The gateway's config file (JSON5), read first; command-line flags override it.
//!
//! ```json5
//! {
//!   broker: "mqtt://127.0.0.1:1883",      // the vehicles' MQTT broker: mqtt:// or mqtts://
//!   // username: "mrmm", password: "…",   // when the broker asks for them
//!   // tls: { ca: "ca.pem",                // an mqtts:// broker: the CAs its certificate
//!   //        cert: "gw.pem", key: "gw.key" },  // chains to; the gateway's own, if asked
//!   interface: "uagv", version: "v2",      // the topics' first two levels
//!   map: "office",                         // the mapId of every order's nodes
//!   robot: "agv.json5",                    // a robot config: every vehicle's type, capabilities,
//!                                          // top speed, zenoh and security (its id is ignored)
//!   ids: { "acme/0042": "agv-42" },        // fleet ids (default <manufacturer>-<serialNumber>)
//!   types: { FORKLIFT: "forklift" },       // robot types by the factsheet's agvClass (default:
//!                                          // the robot config's type)
//!   max_vehicles: 200,
//!   silence_s: 35,                         // a vehicle not heard for this long is gone
//! }
//! ```

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::Deserialize;

use mrmm_vda5050::{Topics, VehicleId};

/// Seconds without a word from a vehicle before it is taken as gone, unless the config says (the
/// standard has a vehicle state at least every 30 s).
pub const SILENCE_S: f64 = 35.0;

/// Vehicles one gateway takes at most, unless its config says.
pub const MAX_VEHICLES: usize = 200;

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GatewayConfig {
    pub broker: String,
    #[serde(default)]
    pub username: Option<String>,
    #[serde(default)]
    pub password: Option<String>,
    /// TLS to an `mqtts://` broker.
    #[serde(default)]
    pub tls: Option<BrokerTls>,
    #[serde(default = "interface")]
    pub interface: String,
    #[serde(default = "major")]
    pub version: String,
    pub map: String,
    /// The robot config every vehicle's robot starts from (relative to the gateway's config).
    pub robot: PathBuf,
    #[serde(default)]
    pub ids: BTreeMap<String, String>,
    /// Robot types by the factsheet's `typeSpecification.agvClass` (`FORKLIFT`, `CARRIER`, …);
    /// a class not named here (or no factsheet) keeps the robot config's type.
    #[serde(default)]
    pub types: BTreeMap<String, String>,
    #[serde(default = "max_vehicles")]
    pub max_vehicles: usize,
    /// A vehicle heard of for this long (no state, no visualization) is gone, seconds.
    #[serde(default = "silence_s")]
    pub silence_s: f64,
}

/// TLS to the broker: PEM files (relative to the gateway's config).
#[derive(Debug, Clone, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BrokerTls {
    /// The CA certificates the broker's certificate must chain to (a public broker's: the
    /// system's bundle, e.g. `/etc/ssl/certs/ca-certificates.crt`).
    pub ca: PathBuf,
    /// The gateway's own certificate chain and its key, for a broker that asks for one.
    #[serde(default)]
    pub cert: Option<PathBuf>,
    #[serde(default)]
    pub key: Option<PathBuf>,
}

fn silence_s() -> f64 {
    SILENCE_S
}

fn interface() -> String {
    mrmm_vda5050::topic::INTERFACE.into()
}

fn major() -> String {
    mrmm_vda5050::topic::MAJOR.into()
}

fn max_vehicles() -> usize {
    MAX_VEHICLES
}

/// The broker's address, from `mqtt://host:port` or `mqtts://host:port` (TLS), or `host:port`;
/// port 1883 (8883 with TLS) when left out.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Broker {
    pub host: String,
    pub port: u16,
    pub tls: bool,
}

impl Broker {
    /// From `mqtt://host:port`, `mqtts://host:port` or `host:port`; the error is `broker:
    /// problem`.
    pub fn parse(url: &str) -> Result<Broker, String> {
        let (rest, tls) = match url.split_once("://") {
            Some(("mqtt" | "tcp", rest)) => (rest, false),
            Some(("mqtts" | "ssl", rest)) => (rest, true),
            Some((scheme, _)) => return Err(format!("broker: {:?}: give mqtt://host:port, or mqtts://host:port for TLS", format!("{scheme}://"))),
            None => (url, false),
        };
        let (host, port) = match rest.rsplit_once(':') {
            Some((h, p)) => (h, p.parse::<u16>().map_err(|_| format!("broker: {:?}: the port is not a number 1–65535", url))?),
            None => (rest, if tls { 8883 } else { 1883 }),
        };
        if host.is_empty() || port == 0 {
            return Err(format!("broker: {url:?}: give host:port"));
        }
        Ok(Broker { host: host.to_string(), port, tls })
    }

    /// `mqtt://host:port` or `mqtts://host:port`.
    pub fn url(&self) -> String {
        format!("{}://{}:{}", if self.tls { "mqtts" } else { "mqtt" }, self.host, self.port)
    }
}

impl GatewayConfig {
    /// Reads `path`; the robot template's path is taken relative to it.
    pub fn read(path: &Path) -> Result<GatewayConfig, String> {
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
        let mut cfg: GatewayConfig = json5::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))?;
        if let Some(dir) = path.parent() {
            let rel = |p: &mut PathBuf| {
                if p.is_relative() {
                    *p = dir.join(&*p);
                }
            };
            rel(&mut cfg.robot);
            if let Some(tls) = &mut cfg.tls {
                rel(&mut tls.ca);
                tls.cert.as_mut().map(rel);
                tls.key.as_mut().map(rel);
            }
        }
        Ok(cfg)
    }

    /// Checks every value; the error is `field: problem`.
    pub fn validate(&self) -> Result<(), String> {
        self.broker()?;
        self.topics()?;
        if self.map.is_empty() || self.map.len() > 128 {
            return Err(format!("map: 1 to 128 characters (got {:?})", self.map));
        }
        if !(1..=10_000).contains(&self.max_vehicles) {
            return Err(format!("max_vehicles: 1 to 10000 (got {})", self.max_vehicles));
        }
        if !(self.silence_s.is_finite() && (1.0..=3600.0).contains(&self.silence_s)) {
            return Err(format!("silence_s: 1 to 3600 seconds (got {})", self.silence_s));
        }
        if self.username.is_none() && self.password.is_some() {
            return Err("password: given without a username".into());
        }
        match (self.broker()?.tls, &self.tls) {
            (true, None) => return Err("tls: an mqtts:// broker needs tls.ca, the CA certificates (PEM) its certificate chains to".into()),
            (false, Some(_)) => return Err("tls: given for an mqtt:// broker (a TLS broker is mqtts://)".into()),
            (_, Some(t)) if t.cert.is_some() != t.key.is_some() => return Err("tls: cert and key go together".into()),
            _ => {}
        }
        for (class, t) in &self.types {
            mrmm_proto::validate_id(t).map_err(|_| format!("types.{class}: invalid robot type {t:?}: use 1 to 64 characters of A-Z a-z 0-9 _ -"))?;
        }
        for (vehicle, id) in &self.ids {
            let (m, s) = vehicle.split_once('/').ok_or_else(|| format!("ids: {vehicle:?} is not <manufacturer>/<serialNumber>"))?;
            VehicleId::new(m, s).map_err(|e| format!("ids: {e}"))?;
            mrmm_proto::validate_id(id).map_err(|_| format!("ids.{vehicle}: invalid robot id {id:?}: use 1 to 64 characters of A-Z a-z 0-9 _ -"))?;
        }
        Ok(())
    }

    pub fn broker(&self) -> Result<Broker, String> {
        Broker::parse(&self.broker)
    }

    pub fn topics(&self) -> Result<Topics, String> {
        Topics::new(&self.interface, &self.version).map_err(|e| e.to_string())
    }

    /// The fleet id of `vehicle`: the config's, else `<manufacturer>-<serialNumber>` with what a
    /// robot id cannot hold (`.` `:`) made `_`.
    pub fn robot_id(&self, vehicle: &VehicleId) -> String {
        if let Some(id) = self.ids.get(&vehicle.to_string()) {
            return id.clone();
        }
        let raw = format!("{}-{}", vehicle.manufacturer, vehicle.serial_number);
        raw.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' || c == '_' { c } else { '_' }).take(64).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg(text: &str) -> GatewayConfig {
        json5::from_str(text).expect("parses")
    }

    #[test]
    fn a_config_reads_with_defaults_and_names_vehicles() {
        let c = cfg(r#"{ broker: "mqtt://127.0.0.1:1884", map: "office", robot: "agv.json5", ids: { "acme/0042": "agv-42" } }"#);
        c.validate().unwrap();
        assert_eq!(c.broker().unwrap(), Broker { host: "127.0.0.1".into(), port: 1884, tls: false });
        assert_eq!(Broker::parse("mqtts://broker.example").unwrap().url(), "mqtts://broker.example:8883");
        assert_eq!((c.interface.as_str(), c.version.as_str(), c.max_vehicles), ("uagv", "v2", MAX_VEHICLES));
        assert_eq!(c.robot_id(&VehicleId::new("acme", "0042").unwrap()), "agv-42");
        assert_eq!(c.robot_id(&VehicleId::new("acme", "a.b:1").unwrap()), "acme-a_b_1");
    }

    #[test]
    fn a_bad_config_says_which_field_and_why() {
        let bad = |text: &str| cfg(text).validate().unwrap_err();
        assert!(bad(r#"{ broker: "ws://h:1", map: "m", robot: "r" }"#).starts_with("broker: \"ws://\": give mqtt://"));
        assert!(bad(r#"{ broker: "mqtts://h:1", map: "m", robot: "r" }"#).starts_with("tls: an mqtts:// broker needs tls.ca"));
        assert!(bad(r#"{ broker: "mqtt://h:1", map: "m", robot: "r", tls: { ca: "ca.pem" } }"#).starts_with("tls: given for an mqtt://"));
        assert!(bad(r#"{ broker: "mqtts://h", map: "m", robot: "r", tls: { ca: "ca.pem", cert: "c.pem" } }"#).starts_with("tls: cert and key"));
        assert!(bad(r#"{ broker: "h:x", map: "m", robot: "r" }"#).contains("port is not a number"));
        assert!(bad(r#"{ broker: "h", map: "", robot: "r" }"#).starts_with("map:"));
        assert!(bad(r#"{ broker: "h", map: "m", robot: "r", ids: { "acme": "x" } }"#).contains("not <manufacturer>/<serialNumber>"));
        assert!(bad(r#"{ broker: "h", map: "m", robot: "r", ids: { "a/b": "no way" } }"#).contains("invalid robot id"));
        assert!(bad(r#"{ broker: "h", map: "m", robot: "r", types: { FORKLIFT: "fork lift" } }"#).starts_with("types.FORKLIFT: invalid robot type"));
        assert!(bad(r#"{ broker: "h", map: "m", robot: "r", interface: "u/agv" }"#).contains("interface"));
        assert!(json5::from_str::<GatewayConfig>(r#"{ broker: "h", map: "m", robot: "r", brokr: 1 }"#).unwrap_err().to_string().contains("brokr"));
    }
}
