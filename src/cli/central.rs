//! `mrmm central`: the router and system manager.

use std::path::PathBuf;

use mrmm_manager::central::{self, CentralConfig};
use tokio::sync::oneshot;

use super::security::SecurityArgs;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// JSON5 config file (listen, lease_ms, query_timeout_ms).
    #[arg(long)]
    config: Option<PathBuf>,
    /// Endpoint to listen on (repeatable); overrides the config. Port 0 picks a free port.
    #[arg(long)]
    listen: Vec<String>,
    #[command(flatten)]
    security: SecurityArgs,
    /// An operator allowed to command the fleet (the id of an operator certificate; repeatable);
    /// with --pki or --ca, overrides the config's `security.operators`.
    #[arg(long)]
    operator: Vec<String>,
}

pub async fn run(args: Args) -> anyhow::Result<()> {
    let mut cfg = match &args.config {
        Some(p) => CentralConfig::load(p)?,
        None => CentralConfig::default(),
    };
    if !args.listen.is_empty() {
        cfg.listen = args.listen;
    }
    if let Some(mut sec) = args.security.section("central") {
        sec.operators = if args.operator.is_empty() { cfg.security.as_ref().map(|s| s.operators.clone()).unwrap_or_default() } else { args.operator };
        cfg.security = Some(sec);
    } else if !args.operator.is_empty() {
        anyhow::bail!("--operator: needs certificates (--pki DIR, or --ca/--cert/--key, or a `security` section)");
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
