//! What a mission host does: its commands carried out — what its chain must remember written
//! first, queries held under ids and answered, the led missions' queryables and status
//! publishers, publications and questions as the core translates them.

use std::collections::HashMap;

use mrmm_core::egress::Out;
use mrmm_net::net;
use mrmm_net::Mesh;
use mrmm_proto::{Key, Pattern};
use tokio::sync::mpsc;
use zenoh::bytes::Encoding;
use zenoh::query::{Query, Queryable};

use super::inputs::Input;
use super::{Command, Event, HostCore, Question, PLAN_TIMEOUT};
use crate::error::ManagerError;
use crate::maps::MapStore;
use mrmm_core::Failure;
use mrmm_net::inbox::Inbox;

/// A mission host's runtime for the driver loop ([`mrmm_core::machine::drive`]): what its
/// chains must remember is written and synced before anything of its step leaves the node — a
/// node that cannot keep its promises must not make any (it stops); the rest on the network.
impl mrmm_core::machine::Runtime<HostCore> for super::node::Node {
    type Error = ManagerError;

    async fn persist(&mut self, batch: Vec<Command>) -> Result<(), ManagerError> {
        for c in batch {
            let Command::Persist { mission, disk } = &c else { continue };
            let written = match &self.store {
                Some(store) => tokio::task::block_in_place(|| store.write(mission.as_str(), disk)),
                None => Err(ManagerError::journal("chain state", "no state dir, but the chain asked to persist")),
            };
            if let Err(e) = written {
                tracing::error!("{e}; the mission host stops");
                return Err(e);
            }
        }
        Ok(())
    }

    async fn carry(&mut self, c: Command) -> Result<(), ManagerError> {
        self.io.execute(c).await;
        Ok(())
    }
}

/// The I/O half: queries held under ids, the served mission queryables, requests in flight.
pub(super) struct Io {
    mesh: Mesh,
    tx: mpsc::UnboundedSender<Input>,
    /// Where the mission queryables' callbacks put queries (bounded).
    net: Inbox<Input>,
    queries: HashMap<u64, Query>,
    next: u64,
    served: HashMap<mrmm_proto::MissionName, Served>,
    maps: MapStore,
}

/// What this node declares for a mission it leads: its queryables and its status publisher.
pub(super) struct Served {
    _queryables: Vec<Queryable<()>>,
    status: Option<zenoh::pubsub::Publisher<'static>>,
}

impl Io {
    pub(super) fn new(mesh: Mesh, tx: mpsc::UnboundedSender<Input>, net: Inbox<Input>, maps: MapStore) -> Io {
        Io { mesh, tx, net, queries: HashMap::new(), next: 0, served: HashMap::new(), maps }
    }

    /// Translates a query through the host's ingress and holds it; one whose sender is not
    /// proven (where it must be) or that is malformed is answered here.
    pub(super) async fn query(&mut self, q: Query) -> Option<Event> {
        let key = q.key_expr().as_str();
        let from = match mrmm_core::mission::host::question_sealed(key) {
            Some(what) => match self.mesh.try_sender_of_query(&q) {
                Ok(s) => Some(s),
                Err(r) => {
                    // Counted and answered: its sender is not proven.
                    self.mesh.refuse_unproven(what, &q, &r).await;
                    return None;
                }
            },
            None => self.mesh.try_sender_of_query(&q).ok(),
        };
        let payload = net::query_payload(&q);
        let question = Question { key, params: q.parameters().as_str(), payload: &payload, from: from.as_ref(), query: self.next };
        match mrmm_core::mission::host::question(question) {
            Ok(e) => {
                self.queries.insert(self.next, q);
                self.next += 1;
                Some(e)
            }
            Err(e) => {
                self.mesh.reply_error(&q, &e).await;
                None
            }
        }
    }

    /// Fetches these maps (if not here yet) in the background.
    pub(super) fn prefetch_maps(&self, maps: &[mrmm_proto::MapRef]) {
        for r in maps {
            self.maps.prefetch(&self.mesh, r);
        }
    }

    pub(super) async fn execute(&mut self, c: Command) {
        if let Some(out) = mrmm_core::mission::host::egress(&c) {
            return self.publish(out).await;
        }
        if let Some(ask) = mrmm_core::mission::host::asks::ask(&c) {
            let (mesh, tx) = (self.mesh.clone(), self.tx.clone());
            tokio::spawn(async move {
                let key = ask.key.to_string();
                let result = crate::edge::answer_of(&mesh, &ask, PLAN_TIMEOUT).await;
                if let Err(f) = &result {
                    tracing::debug!("{key}: no answer: {}", f.error);
                }
                let _ = tx.send(Input::Event(ask.then.answer(&key, result)));
            });
            return;
        }
        match c {
            // Published above.
            Command::Chain { .. } | Command::Status(_) => {}
            Command::Reply { query, result } => {
                let Some(q) = self.queries.remove(&query) else { return };
                match result {
                    Ok(v) => self.mesh.reply_json(&q, &v).await,
                    Err(e) => self.mesh.reply_err(&q, &e).await,
                }
            }
            Command::Refused(r) => self.mesh.refused(&r),
            Command::RollCall => {
                let (mesh, tx) = (self.mesh.clone(), self.tx.clone());
                tokio::spawn(async move {
                    let patterns = [Pattern::AllHostsAlive, Pattern::AllRobotsAlive, Pattern::AllPlannersAlive];
                    let result = crate::edge::roll_call(&mesh, &patterns).await;
                    let _ = tx.send(Input::Event(Event::RollCall(result)));
                });
            }
            // Written by the runtime before anything else of its step.
            Command::Persist { .. } => {}
            Command::Drop { query } => {
                self.queries.remove(&query);
            }
            Command::Serve { mission } => {
                let mut qs = Vec::new();
                for key in [Key::MissionCtl(mission.clone()), Key::MissionView(mission.clone()), Key::MissionMarginal(mission.clone())] {
                    let net = self.net.clone();
                    match self
                        .mesh
                        .session()
                        .declare_queryable(key.to_string())
                        .callback(move |q| {
                            net.push(Input::Query(q));
                        })
                        .await
                    {
                        Ok(q) => qs.push(q),
                        Err(e) => tracing::warn!(%mission, "cannot serve {key}: {e}"),
                    }
                }
                let key = Key::MissionStatus(mission.clone());
                let status = match self.mesh.session().declare_publisher(key.to_string()).encoding(Encoding::APPLICATION_JSON).await {
                    Ok(p) => Some(p),
                    Err(e) => {
                        tracing::warn!(%mission, "cannot declare the status publisher: {e}");
                        None
                    }
                };
                self.served.insert(mission, Served { _queryables: qs, status });
            }
            Command::Unserve { mission } => {
                self.served.remove(&mission);
            }
            Command::RequestPlan { mission, epoch, kind, request, local: true } => {
                let (mesh, tx, maps) = (self.mesh.clone(), self.tx.clone(), self.maps.clone());
                tokio::spawn(async move {
                    let result = crate::planner_service::plan_fetching(&mesh, &maps, kind, request).await.map_err(Failure::fatal);
                    let _ = tx.send(Input::Event(Event::Planned { mission, epoch, result: result.map(Box::new) }));
                });
            }
            // Asked above.
            Command::RequestPlan { .. } | Command::SendPlan { .. } => {}
        }
    }

    /// A publication of the core: a mission's status through its publisher while this node
    /// serves the mission, anything else sealed on its key.
    async fn publish(&self, out: Out) {
        let Key::MissionStatus(mission) = &out.key else { return crate::edge::publish(&self.mesh, out).await };
        let Some(publisher) = self.served.get(mission).and_then(|s| s.status.as_ref()) else { return };
        let seal = self.mesh.seal(&out.key.to_string(), &out.payload);
        if let Err(e) = publisher.put(out.payload).attachment(seal).await {
            tracing::warn!(%mission, "status publication failed: {e}");
        }
    }
}
