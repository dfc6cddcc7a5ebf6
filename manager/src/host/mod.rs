//! Mission hosts: the runtime that runs mission managers and replicates them. Every robot runs
//! one (named after the robot), central runs `central`, and `mrmm mission-host --name N` runs one
//! anywhere. Every decision is in [`HostCore`] (`mrmm-core`); this is its driver: what it hears
//! ([`inputs`]), what it does ([`io`]), what its chain keeps on disk ([`store`]), and the loop
//! between them (here).

mod inputs;
mod io;
mod node;
pub mod store;

use std::time::Duration;

use mrmm_net::{Following, Mesh};
use tokio::sync::{mpsc, watch};
use tokio_util::sync::CancellationToken;

use self::inputs::Input;
use self::io::Io;
use self::node::Node;
use crate::error::ManagerError;
use crate::maps::MapStore;
use mrmm_core::mission::chain::Params;
use mrmm_core::mission::host::{Command, Event, HostCore, Question};
use mrmm_net::inbox::{Inbox, Lanes, Latest};
use mrmm_proto::Time;

/// How long a planner service may take.
pub const PLAN_TIMEOUT: Duration = Duration::from_secs(mrmm_core::timeouts::PLAN_S as u64);
/// Seconds between two status publications of each mission.
const STATUS_PERIOD: Duration = Duration::from_secs(1);
/// Liveliness changes waiting for the host's loop, at most.
const LIVELINESS_QUEUE: usize = 65_536;
/// Publications and queries waiting for the host's loop, at most.
const NET_QUEUE: usize = 8_192;
/// Period of the chain replicas' clock.
const CHAIN_TICK: Duration = Duration::from_millis(50);

/// The missions this node's own robot is in or admitted to, each with whom it trusts, as its
/// robot runtime tells the host.
pub type LocalTeam = Vec<(String, Vec<String>)>;

/// Hosts missions on `mesh` as `node` until `shutdown`, with the default chain parameters.
/// `local`: on a robot node, its robot's team. `stored`: the chain state store opened with
/// [`store::Store::open`] (and what it held): keep the chain state there; else in memory only.
pub async fn serve(
    mesh: Mesh,
    node: String,
    local: Option<watch::Receiver<LocalTeam>>,
    stored: Option<store::Opened>,
    maps: MapStore,
    shutdown: CancellationToken,
) -> Result<(), ManagerError> {
    serve_with(mesh, node, Params::default(), local, stored, maps, shutdown).await
}

/// Hosts missions with chain parameters `params` (`params.k` replicas per mission).
pub async fn serve_with(
    mesh: Mesh,
    node: String,
    params: Params,
    local: Option<watch::Receiver<LocalTeam>>,
    stored: Option<store::Opened>,
    maps: MapStore,
    shutdown: CancellationToken,
) -> Result<(), ManagerError> {
    maps.start_serving(&mesh, shutdown.child_token());
    let session = mesh.session().clone();
    inputs::check_name(&session, &node).await?;
    if let Some((store, entries)) = &stored {
        tracing::info!(%node, ?store, missions = entries.len(), "chain state restored from disk");
    }
    // Our own tasks' answers; and, bounded, what the network sends (liveliness apart).
    let (tx, rx) = mpsc::unbounded_channel::<Input>();
    let (live, live_rx) = Inbox::new("host: liveliness", LIVELINESS_QUEUE);
    let (net, net_rx) = Inbox::new("host: publications and queries", NET_QUEUE);
    let (telemetry, telemetry_rx) = Latest::new("host: telemetry", NET_QUEUE);
    let lanes = Lanes { live: live_rx, own: rx, control: net_rx, telemetry: telemetry_rx };
    // Its chain key, the telemetry of the robots the core watches and (robot nodes: they learn
    // their mission's chain from the head's status) the status of the robot's missions: what
    // the core says it listens to, subscribed one by one.
    let n = net.clone();
    let mut follow = Following::new(session.clone(), move |s| mrmm_net::inbox::sort(&n, &telemetry, s, Input::Sample));
    let _held = inputs::declare(&session, &node, &live, &net).await?;
    tracing::info!(%node, "mission host up");
    let clock = mrmm_net::clock::Clock::start();
    let (store, mut core) = match stored {
        Some((store, entries)) => (Some(store), HostCore::restore(&node, params, Time::ZERO, entries.into_iter().map(|(m, d)| (m.into(), d)).collect())),
        None => (None, HostCore::new(&node, params, Time::ZERO)),
    };
    if local.is_some() {
        core = core.with_robot();
    }
    follow.follow(&core.subscriptions()).await;
    let io = Io::new(mesh.clone(), tx, net, maps);
    let status = tokio::time::interval(STATUS_PERIOD);
    let mut tick = tokio::time::interval(CHAIN_TICK);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut node = Node { mesh, io, store, follow, lanes, status, tick, local, shutdown, clock, telemetry: false, status_tick: false };
    mrmm_core::machine::drive(&mut core, &mut node).await
}
