//! `mrmm robot`: one robot peer with a simulated body.

use std::path::PathBuf;

use mrmm_peer::config::RobotConfig;
use tokio::sync::{oneshot, watch};

use super::security::SecurityArgs;

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
    /// Override the config's `state_dir`: keep the chain state (vote promises, replicated
    /// mission snapshots) there across restarts.
    #[arg(long)]
    state_dir: Option<PathBuf>,
    /// Override the config's `security` section.
    #[command(flatten)]
    security: SecurityArgs,
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
    if let Some(dir) = args.state_dir {
        cfg.state_dir = Some(dir);
    }
    if let Some(sec) = args.security.section(&cfg.id) {
        cfg.security = Some(sec);
    }
    cfg.validate().map_err(|e| anyhow::anyhow!("{} (with command-line overrides): {e}", args.config.display()))?;
    // The chain state is opened before anything starts: a locked or damaged one stops start-up.
    let stored = match &cfg.state_dir {
        Some(dir) => Some(mrmm_manager::host::store::Store::open(dir).map_err(|e| anyhow::anyhow!("{}: state_dir: {e}", args.config.display()))?),
        None => None,
    };
    let shutdown = super::shutdown::on_signals()?;
    let mesh = mrmm_peer::runtime::open(&cfg).await?;
    let session = mesh.session().clone();
    // Every robot is also a mission host: it replicates the managers of its missions and takes
    // one over when its head dies. It learns its robot's team through `team`.
    let (team_tx, team_rx) = watch::channel(Vec::new());
    let mesh_host = mesh.clone();
    let host = tokio::spawn(mrmm_manager::host::serve(mesh_host, cfg.id.clone(), Some(team_rx), stored, Default::default(), shutdown.clone()));
    let (tx, rx) = oneshot::channel();
    let task = tokio::spawn(mrmm_peer::runtime::run_on(mesh, cfg, shutdown.clone(), Some(tx), Some(team_tx)));
    if let Ok(r) = rx.await {
        println!("robot ready id={} zid={} listening={}", r.id, r.zid, r.endpoints.join(","));
    }
    // A mission host that stops (its chain state cannot be written) stops the robot: it must
    // not go on without keeping its promises.
    let mut task = task;
    let mut host = host;
    let result = tokio::select! {
        r = &mut task => {
            shutdown.cancel();
            if let Ok(Err(e)) = host.await {
                tracing::warn!("mission host: {e}");
            }
            r
        }
        h = &mut host => {
            shutdown.cancel();
            let r = task.await;
            if let Ok(Err(e)) = h {
                anyhow::bail!("mission host stopped: {e}");
            }
            r
        }
    };
    result??;
    let _ = session.close().await;
    Ok(())
}
