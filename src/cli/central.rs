//! `mrmm central`: the router and system manager.

use std::path::PathBuf;

use mrmm_manager::central::{self, CentralConfig};
use tokio::sync::oneshot;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// JSON5 config file (listen, lease_ms, query_timeout_ms).
    #[arg(long)]
    config: Option<PathBuf>,
    /// Endpoint to listen on (repeatable); overrides the config. Port 0 picks a free port.
    #[arg(long)]
    listen: Vec<String>,
}

pub async fn run(args: Args) -> anyhow::Result<()> {
    let mut cfg = match &args.config {
        Some(p) => CentralConfig::load(p)?,
        None => CentralConfig::default(),
    };
    if !args.listen.is_empty() {
        cfg.listen = args.listen;
    }
    cfg.validate().map_err(|e| anyhow::anyhow!("central config: {e}"))?;
    let shutdown = super::shutdown::on_signals()?;
    let (tx, rx) = oneshot::channel();
    let task = tokio::spawn(central::run(cfg, shutdown, Some(tx)));
    if let Ok(r) = rx.await {
        // One line on stdout that scripts and tests can wait for.
        println!("central ready zid={} listening={}", r.zid, r.endpoints.join(","));
    }
    task.await??;
    Ok(())
}
