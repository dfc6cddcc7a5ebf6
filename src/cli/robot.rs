//! `mrmm robot`: one robot peer with a simulated body.

use std::path::PathBuf;

use mrmm_peer::config::RobotConfig;
use tokio::sync::oneshot;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// JSON5 robot config (id, type, capabilities, kinematics, start, time_scale, telemetry_hz, zenoh).
    #[arg(long)]
    config: PathBuf,
    /// Override the robot id.
    #[arg(long)]
    id: Option<String>,
    /// Override the endpoints to connect to (repeatable).
    #[arg(long)]
    connect: Vec<String>,
    /// Override the endpoints to listen on (repeatable).
    #[arg(long)]
    listen: Vec<String>,
}

pub async fn run(args: Args) -> anyhow::Result<()> {
    let mut cfg = RobotConfig::load(&args.config)?;
    if let Some(id) = args.id {
        cfg.id = id;
    }
    if !args.connect.is_empty() {
        cfg.zenoh.connect = args.connect;
    }
    if !args.listen.is_empty() {
        cfg.zenoh.listen = args.listen;
    }
    cfg.validate().map_err(|e| anyhow::anyhow!("{} (with command-line overrides): {e}", args.config.display()))?;
    let shutdown = super::shutdown::on_signals()?;
    let session = mrmm_peer::runtime::open(&cfg).await?;
    // Every robot is also a mission host: it replicates the managers of its missions and takes
    // one over when its head dies.
    let host = tokio::spawn(mrmm_manager::host::serve(session.clone(), cfg.id.clone(), shutdown.clone()));
    let (tx, rx) = oneshot::channel();
    let task = tokio::spawn(mrmm_peer::runtime::run_on(session.clone(), cfg, shutdown.clone(), Some(tx)));
    if let Ok(r) = rx.await {
        println!("robot ready id={} zid={} listening={}", r.id, r.zid, r.endpoints.join(","));
    }
    let result = task.await;
    shutdown.cancel();
    if let Ok(Err(e)) = host.await {
        tracing::warn!("mission host: {e}");
    }
    result??;
    let _ = session.close().await;
    Ok(())
}
