//! Central's config file (JSON5): where it listens, its lease, how long it waits for answers,
//! and the advising agent's settings.

use std::path::{Path, PathBuf};

use mrmm_net::net::{self, DEFAULT_CENTRAL, DEFAULT_LEASE_MS, DEFAULT_MAX_MESSAGE_SIZE};
use mrmm_proto::SecuritySection;
use serde::Deserialize;

use crate::error::ManagerError;
use mrmm_core::central::agent::AgentConfig;

/// Config of `mrmm central` (JSON5).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CentralConfig {
    /// Router endpoints; robots connect here.
    #[serde(default = "default_listen")]
    pub listen: Vec<String>,
    /// Link lease, ms.
    #[serde(default = "default_lease")]
    pub lease_ms: u64,
    /// How long to wait for a robot's or a head's answer, ms.
    #[serde(default = "default_query_timeout")]
    pub query_timeout_ms: u64,
    /// The advising agent.
    #[serde(default)]
    pub agent: AgentConfig,
    /// Largest message accepted from the network, bytes.
    #[serde(default = "default_max_message_size")]
    pub max_message_size: usize,
    /// Central's certificate and the operators allowed to command
    /// (`{ ca, cert, key, operators: ["alice"] }`); without it central runs insecure. Relative
    /// paths are relative to the config file.
    #[serde(default)]
    pub security: Option<SecuritySection>,
    /// Where central keeps its journal (`journal.redb`): every mission, membership change and
    /// command it said "ok" to. Relative to the config file. Without it (and without
    /// `--state-dir`), `mrmm central` uses the per-user data directory.
    #[serde(default)]
    pub state_dir: Option<PathBuf>,
    /// Count messages on the wire per kind, readable through the admin space (experiments only).
    #[serde(default)]
    pub wire_stats: bool,
    /// The maps missions may plan on: `{ NAME: "path/to/map.yaml" }` (a Nav2 map's YAML, a
    /// patrolling_sim `.graph` or an Open-RMF navigation graph). Relative to the config file.
    #[serde(default)]
    pub maps: std::collections::BTreeMap<String, PathBuf>,
    /// Grid maps of `maps` whose robots drive their plans as they are, without traffic: no lanes
    /// are derived from them (by default a grid map's robots drive lanes derived from its free
    /// space, as a graph map's drive its lanes).
    #[serde(default)]
    pub no_lanes: Vec<String>,
    /// The floor plans graph maps of `maps` are drawn on: `{ NAME: "path/to/plan.yaml" }` (a
    /// Nav2 map's YAML, in the graph's frame). The plan travels with the map; its two-way lanes
    /// are marked passing where the plan has room for two robots side by side. Relative to the
    /// config file.
    #[serde(default)]
    pub floor_plans: std::collections::BTreeMap<String, PathBuf>,
    /// Chargers of `maps` besides those a graph marks (Open-RMF's `is_charger`):
    /// `{ NAME: [[x, y], "vertex name", …] }`: on a graph, its vertices; on a grid, free points.
    #[serde(default)]
    pub chargers: std::collections::BTreeMap<String, Vec<mrmm_core::maps::ChargerSpec>>,
    /// A robot lost this long (seconds) and in no mission leaves the registry (it registers
    /// again if it comes back). Default a day; 60 to 31 536 000.
    #[serde(default = "default_forget_lost")]
    pub forget_lost_s: f64,
}

fn default_forget_lost() -> f64 {
    mrmm_core::central::system::FORGET_LOST_S
}

fn default_max_message_size() -> usize {
    DEFAULT_MAX_MESSAGE_SIZE
}

fn default_listen() -> Vec<String> {
    vec![DEFAULT_CENTRAL.to_string()]
}
fn default_lease() -> u64 {
    DEFAULT_LEASE_MS
}
fn default_query_timeout() -> u64 {
    (mrmm_core::timeouts::QUERY_S * 1000.0) as u64
}

impl Default for CentralConfig {
    fn default() -> Self {
        CentralConfig {
            listen: default_listen(),
            lease_ms: default_lease(),
            query_timeout_ms: default_query_timeout(),
            agent: AgentConfig::default(),
            max_message_size: DEFAULT_MAX_MESSAGE_SIZE,
            security: None,
            state_dir: None,
            wire_stats: false,
            maps: Default::default(),
            no_lanes: Vec::new(),
            floor_plans: Default::default(),
            chargers: Default::default(),
            forget_lost_s: default_forget_lost(),
        }
    }
}

impl CentralConfig {
    /// Reads and validates a central config file.
    pub fn load(path: &Path) -> Result<Self, ManagerError> {
        let mut cfg: CentralConfig = mrmm_proto::config::load_json5(path)?;
        if let (Some(sec), Some(dir)) = (cfg.security.as_mut(), path.parent()) {
            for p in [&mut sec.ca, &mut sec.cert, &mut sec.key] {
                if p.is_relative() {
                    *p = dir.join(&*p);
                }
            }
        }
        if let (Some(sd), Some(dir)) = (cfg.state_dir.as_mut(), path.parent()) {
            if sd.is_relative() {
                *sd = dir.join(&*sd);
            }
        }
        if let Some(dir) = path.parent() {
            for p in cfg.maps.values_mut().chain(cfg.floor_plans.values_mut()) {
                if p.is_relative() {
                    *p = dir.join(&*p);
                }
            }
        }
        cfg.validate().map_err(|e| ManagerError::Config(format!("{}: {e}", path.display())))?;
        Ok(cfg)
    }

    /// Checks every value; the error is `field: problem`.
    pub fn validate(&self) -> Result<(), String> {
        if self.listen.is_empty() {
            return Err("listen: at least one endpoint is needed".into());
        }
        net::validate_endpoints_for("listen", &self.listen, self.security.is_some())?;
        net::validate_max_message_size("max_message_size", self.max_message_size)?;
        if let Some(sec) = &self.security {
            sec.validate("security")?;
        }
        if let Some(d) = &self.state_dir {
            if d.as_os_str().is_empty() {
                return Err("state_dir: give a directory".into());
            }
            if d.exists() && !d.is_dir() {
                return Err(format!("state_dir: {} is not a directory", d.display()));
            }
        }
        for name in self.maps.keys() {
            mrmm_proto::validate_id(name).map_err(|_| format!("maps: map name {name:?}: use 1 to 64 characters of A-Z a-z 0-9 _ -"))?;
        }
        if let Some(n) = self.no_lanes.iter().find(|n| !self.maps.contains_key(*n)) {
            return Err(format!("no_lanes: {n:?} is not one of the maps"));
        }
        if let Some(n) = self.floor_plans.keys().find(|n| !self.maps.contains_key(*n)) {
            return Err(format!("floor_plans: {n:?} is not one of the maps"));
        }
        if let Some(n) = self.chargers.keys().find(|n| !self.maps.contains_key(*n)) {
            return Err(format!("chargers: {n:?} is not one of the maps"));
        }
        if let Some((n, c)) = self.chargers.iter().find(|(_, c)| c.len() > mrmm_proto::map::MAX_CHARGERS) {
            return Err(format!("chargers.{n}: {} chargers, at most {}", c.len(), mrmm_proto::map::MAX_CHARGERS));
        }
        if !(100..=60_000).contains(&self.lease_ms) {
            return Err(format!("lease_ms: must be 100..=60000 (got {})", self.lease_ms));
        }
        if !(self.forget_lost_s.is_finite() && (60.0..=31_536_000.0).contains(&self.forget_lost_s)) {
            return Err(format!("forget_lost_s: must be 60..=31536000 seconds (got {})", self.forget_lost_s));
        }
        if !(10..=60_000).contains(&self.query_timeout_ms) {
            return Err(format!("query_timeout_ms: must be 10..=60000 (got {})", self.query_timeout_ms));
        }
        self.agent.validate()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn config_errors_are_one_line() {
        let c: CentralConfig = mrmm_proto::config::parse_json5("c.json5", "{ lease_ms: 5 }").expect("parse");
        assert_eq!(c.validate().expect_err("lease"), "lease_ms: must be 100..=60000 (got 5)");
        let e = mrmm_proto::config::parse_json5::<CentralConfig>("c.json5", "{ listen: 7 }").expect_err("type");
        assert!(e.to_string().starts_with("c.json5: listen: "), "{e}");
        assert!(CentralConfig::default().validate().is_ok());
        let c: CentralConfig = mrmm_proto::config::parse_json5("c.json5", "{ maps: { b: 'b.yaml' }, no_lanes: ['a'] }").expect("parse");
        assert_eq!(c.validate().expect_err("no_lanes"), "no_lanes: \"a\" is not one of the maps");
        let c: CentralConfig = mrmm_proto::config::parse_json5("c.json5", "{ maps: { b: 'b.graph' }, floor_plans: { a: 'a.yaml' } }").expect("parse");
        assert_eq!(c.validate().expect_err("floor_plans"), "floor_plans: \"a\" is not one of the maps");
        let c: CentralConfig = mrmm_proto::config::parse_json5("c.json5", "{ maps: { b: 'b.yaml' }, no_lanes: ['b'] }").expect("parse");
        assert!(c.validate().is_ok());
        let c: CentralConfig = mrmm_proto::config::parse_json5("c.json5", "{ maps: { b: 'b.yaml' }, chargers: { a: [[1, 2]] } }").expect("parse");
        assert_eq!(c.validate().expect_err("chargers"), "chargers: \"a\" is not one of the maps");
        let c: CentralConfig = mrmm_proto::config::parse_json5("c.json5", "{ maps: { b: 'b.yaml' }, chargers: { b: [[1, 2], 'dock'] } }").expect("parse");
        assert!(c.validate().is_ok());
        let e = mrmm_proto::config::parse_json5::<CentralConfig>("c.json5", "{ chargers: { b: [[1, 2, 3]] } }").expect_err("three numbers");
        assert!(e.to_string().starts_with("c.json5: chargers"), "{e}");
    }
}
