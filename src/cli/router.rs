//! `mrmm router`: a site router of a multi-site fleet (docs/deployment.md).

use std::path::PathBuf;

use mrmm_manager::site_router::{self, RouterConfig};
use tokio::sync::oneshot;

use super::security::SecurityArgs;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// JSON5 config file (id, listen, connect, lease_ms, security).
    #[arg(long)]
    config: PathBuf,
    /// Endpoint to listen on (repeatable); overrides the config.
    #[arg(long)]
    listen: Vec<String>,
    /// Router or central to connect to (repeatable); overrides the config.
    #[arg(long)]
    connect: Vec<String>,
    #[command(flatten)]
    security: SecurityArgs,
}

pub async fn run(args: Args) -> anyhow::Result<()> {
    let mut cfg = RouterConfig::read(&args.config)?;
    let mut overridden = !args.listen.is_empty() || !args.connect.is_empty();
    if !args.listen.is_empty() {
        cfg.listen = args.listen;
    }
    if !args.connect.is_empty() {
        cfg.connect = args.connect;
    }
    if let Some(sec) = args.security.section(&cfg.id) {
        cfg.security = Some(sec);
        overridden = true;
    }
    let how = if overridden { " (with command-line overrides)" } else { "" };
    cfg.validate().map_err(|e| anyhow::anyhow!("{}{how}: {e}", args.config.display()))?;
    let shutdown = super::shutdown::on_signals()?;
    let (tx, rx) = oneshot::channel();
    let task = tokio::spawn(site_router::run(cfg, shutdown, Some(tx)));
    if let Ok(r) = rx.await {
        // One line on stdout that scripts and tests can wait for.
        println!("router ready zid={} listening={}", r.zid, r.endpoints.join(","));
    }
    task.await??;
    Ok(())
}
