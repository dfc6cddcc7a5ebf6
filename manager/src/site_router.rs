//! A site router (`mrmm router`): Zenoh's own router for one site of a multi-site fleet. The
//! site's robots are peers of it (Zenoh puts them in the router's south region and links them to
//! each other directly); routers link to each other and to central explicitly and route between
//! sites with Zenoh's link-state routing. It runs no mrmm logic and has no authority: it only
//! opens its session with this project's network rules and keeps it open (docs/deployment.md).

use std::path::Path;

use mrmm_net::net::{self, Mode, DEFAULT_LEASE_MS, DEFAULT_MAX_MESSAGE_SIZE};
use mrmm_proto::{validate_id, SecuritySection};

use mrmm_net::{Mesh, NodeNet};
use mrmm_proto::{Role, Sender};
use serde::Deserialize;
use tokio::sync::oneshot;
use tokio_util::sync::CancellationToken;

use crate::central::Ready;
use crate::error::ManagerError;

/// Config of `mrmm router` (JSON5).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RouterConfig {
    /// The router's name (its certificate is `router:<id>`).
    pub id: String,
    /// Where the site's robots, and other routers, reach this router. Explicit addresses.
    pub listen: Vec<String>,
    /// Other routers and central (their uplink addresses). Retried for ever while unreachable.
    #[serde(default)]
    pub connect: Vec<String>,
    /// Link lease, ms: an uplink that goes silent this long is declared gone.
    #[serde(default = "default_lease")]
    pub lease_ms: u64,
    /// Largest message accepted from the network, bytes.
    #[serde(default = "default_max_message_size")]
    pub max_message_size: usize,
    /// The router's certificate (`mrmm pki issue DIR --role router --id ID`); without it the
    /// router runs insecure. Relative paths are relative to the config file.
    #[serde(default)]
    pub security: Option<SecuritySection>,
}

fn default_lease() -> u64 {
    DEFAULT_LEASE_MS
}
fn default_max_message_size() -> usize {
    DEFAULT_MAX_MESSAGE_SIZE
}

impl RouterConfig {
    /// Reads and validates a router config file.
    pub fn load(path: &Path) -> Result<Self, ManagerError> {
        let cfg = Self::read(path)?;
        cfg.validate().map_err(|e| ManagerError::Config(format!("{}: {e}", path.display())))?;
        Ok(cfg)
    }

    /// Reads a router config file (relative paths resolved) for overrides to be applied before
    /// [`RouterConfig::validate`].
    pub fn read(path: &Path) -> Result<Self, ManagerError> {
        let mut cfg: RouterConfig = mrmm_proto::config::load_json5(path)?;
        if let (Some(sec), Some(dir)) = (cfg.security.as_mut(), path.parent()) {
            for p in [&mut sec.ca, &mut sec.cert, &mut sec.key] {
                if p.is_relative() {
                    *p = dir.join(&*p);
                }
            }
        }
        Ok(cfg)
    }

    /// Checks every value; the error is `field: problem`.
    pub fn validate(&self) -> Result<(), String> {
        validate_id(&self.id).map_err(|e| format!("id: {e}"))?;
        if self.listen.is_empty() {
            return Err("listen: at least one endpoint is needed".into());
        }
        let secure = self.security.is_some();
        net::validate_endpoints_for("listen", &self.listen, secure)?;
        net::validate_endpoints_for("connect", &self.connect, secure)?;
        net::validate_max_message_size("max_message_size", self.max_message_size)?;
        if let Some(sec) = &self.security {
            sec.validate("security")?;
            if !sec.operators.is_empty() {
                return Err("security.operators: only central's config lists operators (operators command through central)".into());
            }
        }
        if !(100..=60_000).contains(&self.lease_ms) {
            return Err(format!("lease_ms: must be 100..=60000 (got {})", self.lease_ms));
        }
        Ok(())
    }
}

/// Runs the router until `shutdown` is cancelled.
pub async fn run(cfg: RouterConfig, shutdown: CancellationToken, ready: Option<oneshot::Sender<Ready>>) -> Result<(), ManagerError> {
    cfg.validate().map_err(ManagerError::Config)?;
    let node = NodeNet {
        mode: Mode::Router,
        listen: cfg.listen.clone(),
        connect: cfg.connect.clone(),
        lease_ms: cfg.lease_ms,
        max_message_size: cfg.max_message_size,
        security: cfg.security.clone(),
        me: Some(Sender::new(Role::Router, cfg.id.clone())),
        wire_stats: false,
    };
    let mesh = Mesh::open(&node).await?;
    let session = mesh.session();
    let zid = session.zid().to_string();
    let endpoints = net::listening_endpoints(session).await;
    tracing::info!(%zid, id = %cfg.id, listening = %endpoints.join(","), connect = %cfg.connect.join(","), "site router up");
    if let Some(tx) = ready {
        let _ = tx.send(Ready { zid, endpoints });
    }
    shutdown.cancelled().await;
    if let Err(e) = session.close().await {
        tracing::warn!("closing the router session: {e}");
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<RouterConfig, String> {
        let c: RouterConfig = mrmm_proto::config::parse_json5("r.json5", text).map_err(|e| e.to_string())?;
        c.validate().map(|()| c)
    }

    #[test]
    fn config_errors_are_one_line() {
        assert!(parse(r#"{ id: "site-b", listen: ["tcp/127.0.0.1:0"], connect: ["tcp/10.0.0.1:7447"] }"#).is_ok());
        assert_eq!(parse(r#"{ id: "a:b", listen: ["tcp/127.0.0.1:0"] }"#).expect_err("id").split(':').next(), Some("id"));
        assert_eq!(parse(r#"{ id: "b", listen: [] }"#).expect_err("listen"), "listen: at least one endpoint is needed");
        assert!(parse(r#"{ id: "b", listen: ["tcp/0.0.0.0:7447"] }"#).expect_err("wildcard").starts_with("listen[0]: "));
        assert!(parse(r#"{ id: "b", listen: ["tcp/127.0.0.1:0"], connect: ["udp/1.2.3.4:5"] }"#).expect_err("proto").starts_with("connect[0]: "));
        assert_eq!(parse(r#"{ id: "b", listen: ["tcp/127.0.0.1:0"], lease_ms: 5 }"#).expect_err("lease"), "lease_ms: must be 100..=60000 (got 5)");
        let e = parse(r#"{ id: "b", listen: ["tls/127.0.0.1:0"], security: { ca: "c", cert: "c", key: "k", operators: ["alice"] } }"#).expect_err("operators");
        assert!(e.starts_with("security.operators: "), "{e}");
        assert!(parse(r#"{ id: "b", listen: ["tcp/127.0.0.1:0"], colour: 1 }"#).expect_err("unknown").starts_with("r.json5: "));
    }
}
