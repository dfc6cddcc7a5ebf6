//! Central's config file (JSON5): where it listens, its lease, how long it waits for answers,
//! and the advising agent's settings.

use std::path::Path;

use mrmm_proto::net::{self, DEFAULT_CENTRAL, DEFAULT_LEASE_MS};
use serde::Deserialize;

use crate::agent::AgentConfig;
use crate::error::ManagerError;

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
}

fn default_listen() -> Vec<String> {
    vec![DEFAULT_CENTRAL.to_string()]
}
fn default_lease() -> u64 {
    DEFAULT_LEASE_MS
}
fn default_query_timeout() -> u64 {
    2000
}

impl Default for CentralConfig {
    fn default() -> Self {
        CentralConfig { listen: default_listen(), lease_ms: default_lease(), query_timeout_ms: default_query_timeout(), agent: AgentConfig::default() }
    }
}

impl CentralConfig {
    /// Reads and validates a central config file.
    pub fn load(path: &Path) -> Result<Self, ManagerError> {
        let cfg: CentralConfig = mrmm_proto::config::load_json5(path)?;
        cfg.validate().map_err(|e| ManagerError::Config(format!("{}: {e}", path.display())))?;
        Ok(cfg)
    }

    /// Checks every value; the error is `field: problem`.
    pub fn validate(&self) -> Result<(), String> {
        if self.listen.is_empty() {
            return Err("listen: at least one endpoint is needed".into());
        }
        net::validate_endpoints("listen", &self.listen)?;
        if !(100..=60_000).contains(&self.lease_ms) {
            return Err(format!("lease_ms: must be 100..=60000 (got {})", self.lease_ms));
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
    }
}
