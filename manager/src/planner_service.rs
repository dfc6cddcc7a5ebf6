//! Planner services: Zenoh queryables `mrmm/planner/<kind>` wrapping the planner library. They
//! announce themselves with a liveliness token and can run in any process (inside central by
//! default, or `mrmm planner-service`). Planning runs on the blocking pool.

use mrmm_planner::recipe::{self, PlannerKind};
use mrmm_proto::net;
use mrmm_proto::{self as proto, Key, MissionPlan, PlanRequest};
use tokio_util::sync::CancellationToken;
use zenoh::query::Query;
use zenoh::Session;

use crate::error::ManagerError;
use crate::wire;

/// Every planner kind a service offers.
pub const KINDS: [PlannerKind; 2] = [PlannerKind::Patrol, PlannerKind::Coverage];

/// The planner kind named `name` on the wire.
pub fn kind(name: &str) -> Option<PlannerKind> {
    KINDS.into_iter().find(|k| k.as_str() == name)
}

/// Plans a request with the planner library, checking that the recipe is of `kind`.
pub fn plan(kind: PlannerKind, req: &PlanRequest) -> Result<MissionPlan, String> {
    let xml = recipe::bank(&req.recipe).unwrap_or(&req.recipe);
    let r = recipe::parse(xml).map_err(|e| format!("recipe: {e}"))?;
    if r.planner != kind {
        return Err(format!("this is the {} planner; the recipe needs {}", kind.as_str(), r.planner.as_str()));
    }
    let robots: Vec<_> = req.robots.iter().map(wire::robot_spec).collect();
    let planned = recipe::build(&r, &req.params, &robots).map_err(|e| e.to_string())?;
    Ok(wire::mission_plan(&planned))
}

/// Serves planning queries on `session` until `shutdown`.
pub async fn serve(session: Session, shutdown: CancellationToken) -> Result<(), ManagerError> {
    let zid = session.zid().to_string();
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
        tokio::spawn(answer(kind, q));
    }
    drop(tokens);
    Ok(())
}

async fn answer(kind: PlannerKind, q: Query) {
    let req: PlanRequest = match proto::from_json("plan request", &net::query_payload(&q)) {
        Ok(r) => r,
        Err(e) => {
            tracing::warn!("dropped plan request: {e}");
            return net::reply_error(&q, &e.to_string()).await;
        }
    };
    let started = std::time::Instant::now();
    let result = tokio::task::spawn_blocking(move || plan(kind, &req)).await.unwrap_or_else(|e| Err(format!("planner crashed: {e}")));
    tracing::info!(kind = kind.as_str(), ms = started.elapsed().as_millis() as u64, ok = result.is_ok(), "planned");
    match result {
        Ok(p) => net::reply_json(&q, &p).await,
        Err(e) => net::reply_error(&q, &e).await,
    }
}
