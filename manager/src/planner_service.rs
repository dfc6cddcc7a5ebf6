//! Planner services: Zenoh queryables `mrmm/planner/<kind>` wrapping the planner library. They
//! announce themselves with a liveliness token and can run in any process (inside central by
//! default, or `mrmm planner-service`). Planning runs on the blocking pool.

use mrmm_planner::recipe::PlannerKind;
use std::sync::Arc;

use mrmm_net::net;
use mrmm_net::Mesh;
use mrmm_proto::{self as proto, Key, MissionPlan, PlanRequest};
use tokio::sync::Semaphore;
use tokio_util::sync::CancellationToken;
use zenoh::query::Query;

use crate::error::ManagerError;
use crate::maps::MapStore;

/// Every planner kind a service offers.
pub const KINDS: [PlannerKind; 2] = [PlannerKind::Patrol, PlannerKind::Coverage];

/// The planner kind named `name` on the wire.
pub fn kind(name: &str) -> Option<PlannerKind> {
    KINDS.into_iter().find(|k| k.as_str() == name)
}

use mrmm_core::maps::Held;
use mrmm_core::mission::planning::plan_on;

/// Plans `req` off the async runtime, with its map from `maps` (fetched from the fleet if this
/// node does not hold it yet): a mission host planning its own mission.
pub async fn plan_fetching(mesh: &Mesh, maps: &MapStore, kind: PlannerKind, req: PlanRequest) -> Result<MissionPlan, String> {
    let held = match &req.map {
        Some(r) => Some(maps.fetch(mesh, r).await?),
        None => None,
    };
    plan_held(kind, req, held).await
}

/// Plans `req` off the async runtime on `held`, its map.
async fn plan_held(kind: PlannerKind, req: PlanRequest, held: Option<Arc<Held>>) -> Result<MissionPlan, String> {
    tokio::task::spawn_blocking(move || plan_on(kind, &req, held.as_ref().map(|h| h.map.as_ref())))
        .await
        .unwrap_or_else(|e| Err(format!("planner crashed: {e}")))
}

/// Plans a request that came to the service: only on a map central publishes (held here, or
/// listed by central and fetched), never on one the requester names and serves itself.
async fn plan_published(mesh: &Mesh, maps: &MapStore, kind: PlannerKind, req: PlanRequest) -> Result<MissionPlan, String> {
    let held = match &req.map {
        Some(r) => Some(maps.published(mesh, r).await?),
        None => None,
    };
    plan_held(kind, req, held).await
}

/// Plans computed at once at most; a request beyond that (and a waiting line as long) is told
/// the service is busy rather than queued without bound.
fn capacity() -> usize {
    std::thread::available_parallelism().map_or(2, |n| n.get()).max(1)
}

/// Serves planning queries on `mesh` until `shutdown`: only for nodes that host missions. Maps
/// come from `maps` (and are fetched into it).
pub async fn serve(mesh: Mesh, maps: MapStore, shutdown: CancellationToken) -> Result<(), ManagerError> {
    maps.start_serving(&mesh, shutdown.child_token());
    let session = mesh.session().clone();
    let zid = session.zid().to_string();
    let slots = Arc::new(Semaphore::new(2 * capacity()));
    let running = Arc::new(Semaphore::new(capacity()));
    let mut queryables = Vec::new();
    let mut tokens = Vec::new();
    for kind in KINDS {
        let name = kind.as_str().to_string();
        queryables.push((kind, session.declare_queryable(Key::Planner(name.clone()).to_string()).await.map_err(ManagerError::zenoh)?));
        let alive = Key::PlannerAlive { kind: name, zid: zid.clone() };
        tokens.push(session.liveliness().declare_token(alive.to_string()).await.map_err(ManagerError::zenoh)?);
    }
    tracing::info!(%zid, "planner service up");
    let (patrol, coverage) = (&queryables[0].1, &queryables[1].1);
    loop {
        let (kind, q) = tokio::select! {
            _ = shutdown.cancelled() => break,
            q = patrol.recv_async() => (PlannerKind::Patrol, q),
            q = coverage.recv_async() => (PlannerKind::Coverage, q),
        };
        let Ok(q) = q else { break };
        let from = match mesh.try_sender_of_query(&q) {
            Ok(from) => from,
            Err(r) => {
                mesh.refuse_unproven("plan request", &q, &r).await;
                continue;
            }
        };
        if !proto::policy::allows(proto::policy::Act::PlanRequest, from.role, proto::policy::Relation::Stranger) {
            mesh.refuse("ask for plans", &from);
            mesh.reply_error(&q, &format!("refused: {from} may not ask for plans")).await;
            continue;
        }
        let Ok(slot) = slots.clone().try_acquire_owned() else {
            mesh.reply_error(&q, "planner service busy: try again").await;
            continue;
        };
        tokio::spawn(answer(mesh.clone(), maps.clone(), kind, q, slot, running.clone()));
    }
    drop(tokens);
    Ok(())
}

async fn answer(mesh: Mesh, maps: MapStore, kind: PlannerKind, q: Query, _slot: tokio::sync::OwnedSemaphorePermit, running: Arc<Semaphore>) {
    let req: PlanRequest = match proto::from_json("plan request", &net::query_payload(&q)) {
        Ok(r) => r,
        Err(e) => {
            tracing::warn!("dropped plan request: {e}");
            return mesh.reply_error(&q, &e.to_string()).await;
        }
    };
    let Ok(_run) = running.acquire_owned().await else { return };
    let started = std::time::Instant::now();
    let result = plan_published(&mesh, &maps, kind, req).await;
    tracing::info!(kind = kind.as_str(), ms = started.elapsed().as_millis() as u64, ok = result.is_ok(), "planned");
    match result {
        Ok(p) => mesh.reply_packed(&q, &p).await,
        Err(e) => mesh.reply_error(&q, &e).await,
    }
}
