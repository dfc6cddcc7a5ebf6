//! `mrmm robot`: one robot peer with a simulated body.

use std::path::PathBuf;

use mrmm_peer::config::RobotConfig;

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
    let mut cfg = RobotConfig::read(&args.config)?;
    let mut overridden = args.id.is_some() || !args.connect.is_empty() || !args.listen.is_empty() || args.state_dir.is_some();
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
        overridden = true;
    }
    let how = if overridden { " (with command-line overrides)" } else { "" };
    cfg.validate().map_err(|e| anyhow::anyhow!("{}{how}: {e}", args.config.display()))?;
    let shutdown = super::shutdown::on_signals()?;
    let mut robot = mrmm_node::robot::start(cfg, shutdown).await.map_err(|e| anyhow::anyhow!("{}: {e:#}", args.config.display()))?;
    robot.announce();
    Ok(robot.finished().await?)
}
