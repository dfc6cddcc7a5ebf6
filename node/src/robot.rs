//! A robot's node: the robot's driver, its mission host (it replicates the managers of its
//! missions and takes one over when its head dies) and its map's traffic deputy, on one session.
//! A mission host that stops stops the robot: it must not go on without keeping its promises.

use mrmm_peer::config::RobotConfig;
use mrmm_peer::runtime::Ready;
use tokio::sync::{oneshot, watch};
use tokio::task::JoinSet;
use tokio_util::sync::CancellationToken;

use crate::NodeError;

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
    Robot(Result<(), mrmm_peer::PeerError>),
    Host(Result<(), mrmm_manager::ManagerError>),
    Deputy(Result<(), mrmm_manager::ManagerError>),
}

/// Starts the robot of `cfg` (validated) and its mission host; returns once it is on the network
/// (or has stopped). It runs until `shutdown` is cancelled or it fails.
pub async fn start(cfg: RobotConfig, shutdown: CancellationToken) -> Result<Started, NodeError> {
    start_with(cfg, shutdown, None).await
}

/// [`start`], for a robot whose body is a VDA 5050 vehicle: `vda` is its link to the gateway.
pub async fn start_with(cfg: RobotConfig, shutdown: CancellationToken, vda: Option<mrmm_peer::runtime::VdaLink>) -> Result<Started, NodeError> {
    // The chain state is opened before anything starts: a locked or damaged one stops start-up.
    let stored = match &cfg.state_dir {
        Some(dir) => Some(mrmm_manager::host::store::Store::open(dir).map_err(NodeError::StateDir)?),
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
    tasks.spawn(async move { Outcome::Host(mrmm_manager::host::serve(mesh_host, id, Some(team_rx), stored, host_maps, host_stop).await) });
    // And its map's traffic deputy while the authority names it one (it follows, and takes over
    // when central is away).
    let (deputy_tx, deputy_rx) = watch::channel(None);
    let (mesh_deputy, id, deputy_stop) = (mesh.clone(), cfg.id.clone(), stop.clone());
    tasks.spawn(async move { Outcome::Deputy(mrmm_manager::deputy::serve(mesh_deputy, id, deputy_rx, maps, deputy_stop).await) });
    let (tx, rx) = oneshot::channel();
    let services = mrmm_peer::runtime::Services { team: Some(team_tx), deputy: Some(deputy_tx), vda };
    tasks.spawn(async move { Outcome::Robot(mrmm_peer::runtime::run_on(mesh, cfg, robot_stop, Some(tx), services).await) });
    let ready = rx.await.ok();
    Ok(Started { ready, session, tasks, stop })
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
    pub async fn finished(&mut self) -> Result<(), NodeError> {
        let mut result = Ok(());
        let mut first = true;
        while let Some(done) = self.tasks.join_next().await {
            let done = match done {
                Ok(done) => done,
                // Aborted after a crash order (below): the crash is what is said.
                Err(e) if e.is_cancelled() && result.is_err() => continue,
                Err(e) => return Err(NodeError::Task(e)),
            };
            match done {
                // Crashed on the operator's order: its mission host goes down with it, mid-step,
                // as a crashed computer's would.
                Outcome::Robot(Err(e @ mrmm_peer::PeerError::Crashed(_))) => {
                    self.tasks.abort_all();
                    result = Err(e.into());
                }
                Outcome::Robot(r) => result = result.and(r.map_err(NodeError::from)),
                Outcome::Host(Err(e)) if first => result = Err(NodeError::Host(e)),
                Outcome::Host(Err(e)) => tracing::warn!("mission host: {e}"),
                Outcome::Host(Ok(())) => {}
                Outcome::Deputy(Err(e)) if first => result = Err(NodeError::Deputy(e)),
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
