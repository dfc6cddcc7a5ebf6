//! The central node: a Zenoh router hosting the system manager, the advising agent, a planner
//! service and the mission host `central`. Every decision is in [`CentralCore`] (`mrmm-core`);
//! this is its driver: what it opens at start-up ([`start`]), what it hears ([`inputs`]), what it
//! does ([`io`]), and the loop between them (here).

mod config;
mod inputs;
mod io;
mod node;
mod start;

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use mrmm_net::net;
use mrmm_net::Mesh;
use mrmm_proto as proto;
use tokio::sync::{mpsc, oneshot};
use tokio_util::sync::CancellationToken;

pub use self::config::CentralConfig;
use self::inputs::{declare_inputs, Inboxes, Input, SealCounts};
use self::io::Io;
use self::node::Node;
use self::start::{load_maps, node_net, open_state};
use crate::error::ManagerError;
use mrmm_core::central::{CentralCore, Command, Event};
use mrmm_core::machine;
use mrmm_net::inbox::{Inbox, Lanes, Latest};

/// Liveliness changes waiting for central's loop, at most.
const LIVELINESS_QUEUE: usize = 65_536;
/// Publications (but telemetry) and queries waiting for central's loop, at most.
const NET_QUEUE: usize = 8_192;
/// Robots whose latest telemetry sample may wait for central's loop, at most.
const TELEMETRY_QUEUE: usize = 8_192;
/// Period of the manager's housekeeping tick.
const TICK: Duration = Duration::from_millis(250);
/// How long a create's dry-run plan may take (the planner's limits keep it far shorter).
const DRY_RUN_DEADLINE: Duration = Duration::from_secs(10);

/// What central reports once it is serving.
#[derive(Debug, Clone)]
pub struct Ready {
    pub zid: String,
    pub endpoints: Vec<String>,
}

/// Runs central until `shutdown` is cancelled.
pub async fn run(cfg: CentralConfig, shutdown: CancellationToken, ready: Option<oneshot::Sender<Ready>>) -> Result<(), ManagerError> {
    cfg.validate().map_err(ManagerError::Config)?;
    let (journal, state, chain) = open_state(&cfg)?;
    let maps = load_maps(&cfg, &state)?;
    let mesh = Mesh::open(&node_net(&cfg)).await?;
    let session = mesh.session().clone();
    let endpoints = net::listening_endpoints(&session).await;
    let zid = session.zid().to_string();
    // Our own tasks' answers; and, bounded, what the network sends (liveliness apart: a flood
    // of data must not push out the news that a robot died; telemetry apart: shed first).
    let (tx, rx) = mpsc::unbounded_channel::<Input>();
    let (live, live_rx) = Inbox::new("central: liveliness", LIVELINESS_QUEUE);
    let (control, control_rx) = Inbox::new("central: publications and queries", NET_QUEUE);
    let (telemetry, telemetry_rx) = Latest::new("central: telemetry", TELEMETRY_QUEUE);
    let held = declare_inputs(&session, &Inboxes { live, control, telemetry }).await?;
    let lanes = Lanes { live: live_rx, own: rx, control: control_rx, telemetry: telemetry_rx };
    // The default planner service and mission host live here too.
    let planners = tokio::spawn(crate::planner_service::serve(mesh.clone(), maps.clone(), shutdown.child_token()));
    let missions = tokio::spawn(crate::host::serve(mesh.clone(), proto::CENTRAL_HOST.to_string(), None, chain, maps.clone(), shutdown.child_token()));
    tracing::info!(%zid, ?endpoints, "central up");
    if let Some(tx) = ready {
        let _ = tx.send(Ready { zid: zid.clone(), endpoints });
    }

    let clock = mrmm_net::clock::Clock::start();
    let by_name = maps.by_name();
    let no_lanes: Vec<String> = cfg.no_lanes.iter().filter_map(|n| by_name.get(n).map(|h| h.info.hash.clone())).collect();
    let mut core = CentralCore::restore(zid.into(), cfg.agent.clone(), proto::Time::ZERO, state)
        .with_maps(by_name)
        .without_lanes(no_lanes)
        .with_superseded(maps.superseded())
        .forgetting_lost_after(cfg.forget_lost_s)
        .with_traffic_incarnation(mrmm_net::mesh::now_ms());
    let io = Io::new(mesh.clone(), Duration::from_millis(cfg.query_timeout_ms), tx);
    let seals = SealCounts { refused: 0, proofs_at: Instant::now() };
    let load = crate::load::LoopLoad::new(proto::CENTRAL_HOST);
    let tick = tokio::time::interval(TICK);
    let mut node = Node { mesh: mesh.clone(), io, journal, lanes, tick, seals, load, shutdown, clock, due: VecDeque::new(), step: None };
    machine::drive(&mut core, &mut node).await?;
    tracing::info!("central shutting down");
    drop(held);
    let _ = planners.await;
    let _ = missions.await;
    session.close().await.map_err(ManagerError::zenoh)?;
    Ok(())
}
