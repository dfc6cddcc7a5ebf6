//! `mrmm robot`: one robot peer with a simulated body.

use std::path::PathBuf;

use mrmm_peer::config::RobotConfig;
use mrmm_peer::runtime::Ready;
use tokio::sync::{oneshot, watch};
use tokio::task::JoinSet;
use tokio_util::sync::CancellationToken;

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
    let mut robot = start(cfg, shutdown).await.map_err(|e| anyhow::anyhow!("{}: {e:#}", args.config.display()))?;
    robot.announce();
    robot.finished().await
}

/// A started robot: its peer, its mission host and its traffic deputy on one session.
pub struct Started {
    /// What it reported once on the network (none if it stopped before).
    pub ready: Option<Ready>,
    session: zenoh::Session,
    tasks: JoinSet<Outcome>,
    /// Stops both (cancelled by the caller's shutdown, or when one of them stops).
    stop: CancellationToken,
}

enum Outcome {
    Robot(anyhow::Result<()>),
    Host(anyhow::Result<()>),
    Deputy(anyhow::Result<()>),
}

/// Starts the robot of `cfg` (validated) and its mission host; returns once it is on the network
/// (or has stopped). It runs until `shutdown` is cancelled or it fails.
pub async fn start(cfg: RobotConfig, shutdown: CancellationToken) -> anyhow::Result<Started> {
    // The chain state is opened before anything starts: a locked or damaged one stops start-up.
    let stored = match &cfg.state_dir {
        Some(dir) => Some(mrmm_manager::host::store::Store::open(dir).map_err(|e| anyhow::anyhow!("state_dir: {e}"))?),
        None => None,
    };
    let mesh = mrmm_peer::runtime::open(&cfg, &shutdown).await?;
    let session = mesh.session().clone();
    // Every robot is also a mission host: it replicates the managers of its missions and takes
    // one over when its head dies. It learns its robot's team through `team`.
    let (team_tx, team_rx) = watch::channel(Vec::new());
    let mut tasks = JoinSet::new();
    let stop = shutdown.child_token();
    let (id, host_stop, robot_stop) = (cfg.id.clone(), stop.clone(), stop.clone());
    let mesh_host = mesh.clone();
    let maps = mrmm_manager::maps::MapStore::default();
    let host_maps = maps.clone();
    tasks.spawn(async move { Outcome::Host(mrmm_manager::host::serve(mesh_host, id, Some(team_rx), stored, host_maps, host_stop).await.map_err(Into::into)) });
    // And its map's traffic deputy while the authority names it one (it follows, and takes over
    // when central is away).
    let (deputy_tx, deputy_rx) = watch::channel(None);
    let (mesh_deputy, id, deputy_stop) = (mesh.clone(), cfg.id.clone(), stop.clone());
    tasks.spawn(async move { Outcome::Deputy(mrmm_manager::deputy::serve(mesh_deputy, id, deputy_rx, maps, deputy_stop).await.map_err(Into::into)) });
    let (tx, rx) = oneshot::channel();
    tasks.spawn(async move {
        Outcome::Robot(mrmm_peer::runtime::run_on(mesh, cfg, robot_stop, Some(tx), Some(team_tx), Some(deputy_tx)).await.map_err(Into::into))
    });
    let ready = rx.await.ok();
    Ok(Started { ready, session, tasks, stop })
}

/// Whether the robot stopped because it was ordered to crash.
pub fn crashed(e: &anyhow::Error) -> bool {
    matches!(e.downcast_ref::<mrmm_peer::PeerError>(), Some(mrmm_peer::PeerError::Crashed(_)))
}

impl Started {
    /// Prints the robot's ready line (what scripts and tests wait for), once it is on the network.
    pub fn announce(&self) {
        if let Some(r) = &self.ready {
            println!("robot ready id={} zid={} listening={}", r.id, r.zid, r.endpoints.join(","));
        }
    }

    /// Waits until the robot stops. A mission host that stops (its chain state cannot be
    /// written) stops the robot: it must not go on without keeping its promises.
    pub async fn finished(&mut self) -> anyhow::Result<()> {
        let mut result = Ok(());
        let mut first = true;
        while let Some(done) = self.tasks.join_next().await {
            let done = match done {
                Ok(done) => done,
                // Aborted after a crash order (below): the crash is what is said.
                Err(e) if e.is_cancelled() && result.is_err() => continue,
                Err(e) => return Err(anyhow::anyhow!("robot task: {e}")),
            };
            match done {
                // Crashed on the operator's order: its mission host goes down with it, mid-step,
                // as a crashed computer's would.
                Outcome::Robot(Err(e)) if crashed(&e) => {
                    self.tasks.abort_all();
                    result = Err(e);
                }
                Outcome::Robot(r) => result = result.and(r),
                Outcome::Host(Err(e)) if first => result = Err(anyhow::anyhow!("mission host stopped: {e}")),
                Outcome::Host(Err(e)) => tracing::warn!("mission host: {e}"),
                Outcome::Host(Ok(())) => {}
                Outcome::Deputy(Err(e)) if first => result = Err(anyhow::anyhow!("traffic deputy stopped: {e}")),
                Outcome::Deputy(Err(e)) => tracing::warn!("traffic deputy: {e}"),
                Outcome::Deputy(Ok(())) => {}
            }
            // One stopped: the other follows.
            first = false;
            self.stop.cancel();
        }
        let _ = self.session.close().await;
        result
    }

    /// Stops the robot at once, as a crash would: no task runs on, its session closes (its
    /// links drop and its liveliness tokens go with them).
    pub async fn kill(mut self) {
        self.tasks.abort_all();
        while self.tasks.join_next().await.is_some() {}
        let _ = self.session.close().await;
    }
}
