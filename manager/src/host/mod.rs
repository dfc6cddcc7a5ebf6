//! Mission hosts: the runtime that runs mission managers and replicates them. Every robot runs
//! one (named after the robot), central runs `central`, and `mrmm mission-host --name N` runs one
//! anywhere. Every decision is in [`HostCore`] (`core.rs`, with the led missions in `head.rs`);
//! this file is its driver: it turns Zenoh traffic into [`Event`]s, holds queries under an id,
//! and carries out the [`Command`]s.

pub mod store;

use std::collections::HashMap;
use std::time::{Duration, Instant};

use mrmm_core::egress::Out;
use mrmm_net::net;
use mrmm_net::{Following, Mesh};
use mrmm_proto::{self as proto, Key, Pattern};
use tokio::sync::{mpsc, watch};
use tokio_util::sync::CancellationToken;
use zenoh::bytes::Encoding;
use zenoh::query::{Query, Queryable};
use zenoh::sample::{Sample, SampleKind};

use crate::chain::Params;
use crate::error::ManagerError;
use crate::inbox::Inbox;
use crate::maps::MapStore;
use crate::Failure;
use mrmm_core::edge::{Incoming, Refused};
pub use mrmm_core::host::{Command, Event, HostCore, Question, PLAN_RETRIES, REDELIVER_S, UNJUDGED_S};

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

/// What the Zenoh callbacks and spawned tasks hand the loop.
enum Input {
    /// A query on one of our queryables.
    Query(Query),
    Sample(Sample),
    Event(Event),
}

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
    mut local: Option<watch::Receiver<LocalTeam>>,
    stored: Option<store::Opened>,
    maps: MapStore,
    shutdown: CancellationToken,
) -> Result<(), ManagerError> {
    maps.start_serving(&mesh, shutdown.child_token());
    let session = mesh.session().clone();
    proto::validate_id(&node).map_err(|e| ManagerError::Config(format!("mission host name: {e}")))?;
    if net::already_alive(&session, &Key::HostAlive(node.clone()).to_string(), net::NAME_CHECK_TIMEOUT).await? {
        return Err(ManagerError::NameTaken(format!("mission host {node:?} is already alive on the mesh; give every host and robot its own name")));
    }
    if let Some((store, entries)) = &stored {
        tracing::info!(%node, ?store, missions = entries.len(), "chain state restored from disk");
    }
    // Our own tasks' answers; and, bounded, what the network sends (liveliness apart).
    let (tx, mut rx) = mpsc::unbounded_channel::<Input>();
    let (live, mut live_rx) = Inbox::new("liveliness", LIVELINESS_QUEUE);
    let (net, mut net_rx) = Inbox::new("publications and queries", NET_QUEUE);
    let t = net.clone();
    let _start = session
        .declare_queryable(Key::HostStart(node.clone()).to_string())
        .callback(move |q| {
            t.push(Input::Query(q));
        })
        .await
        .map_err(ManagerError::zenoh)?;
    let mut subs = Vec::new();
    // Its chain key, the telemetry of the robots the core watches and (robot nodes: they learn
    // their mission's chain from the head's status) the status of the robot's missions: what
    // the core says it listens to, subscribed one by one.
    let n = net.clone();
    let mut follow = Following::new(session.clone(), move |s| n.push(Input::Sample(s)));
    for pattern in [Pattern::AllHostsAlive, Pattern::AllRobotsAlive, Pattern::AllPlannersAlive] {
        subs.push(live.liveliness(&session, pattern.to_string(), Input::Sample).await?);
    }
    let _token = session.liveliness().declare_token(Key::HostAlive(node.clone()).to_string()).await.map_err(ManagerError::zenoh)?;
    tracing::info!(%node, "mission host up");
    let t0 = Instant::now();
    let (store, mut core) = match stored {
        Some((store, entries)) => (Some(store), HostCore::restore(&node, params, 0.0, entries)),
        None => (None, HostCore::new(&node, params, 0.0)),
    };
    if local.is_some() {
        core = core.with_robot();
    }
    follow.follow(&core.subscriptions()).await;
    let mut io = Io { mesh: mesh.clone(), tx, net, queries: HashMap::new(), next: 0, served: HashMap::new(), maps };
    let mut status = tokio::time::interval(STATUS_PERIOD);
    let mut tick = tokio::time::interval(CHAIN_TICK);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    loop {
        let event = tokio::select! {
            _ = shutdown.cancelled() => break,
            _ = status.tick() => Event::StatusTick,
            _ = tick.tick() => Event::Tick,
            changed = local_changed(&mut local) => match changed {
                Some(team) => Event::LocalTeam(team),
                None => {
                    local = None;
                    continue;
                }
            },
            i = async {
                tokio::select! {
                    i = live_rx.recv() => i,
                    i = rx.recv() => i,
                    i = net_rx.recv() => i,
                }
            } => match i {
                Some(Input::Query(q)) => match io.query(q).await {
                    Some(e) => e,
                    None => continue,
                },
                Some(Input::Sample(s)) => match decode(&mesh, &s) {
                    Some(e) => e,
                    None => continue,
                },
                Some(Input::Event(e)) => e,
                None => break,
            },
        };
        // Telemetry does not change what the core listens to; everything else may.
        let telemetry = matches!(event, Event::Telemetry(_));
        let status_tick = matches!(event, Event::StatusTick);
        let commands = core.handle(t0.elapsed().as_secs_f64(), event);
        if status_tick {
            // Every mission this node leads or replicates has its map here before a takeover
            // needs it (central may be gone by then).
            for r in core.maps() {
                io.maps.prefetch(&mesh, &r);
            }
        }
        if !telemetry {
            follow.follow(&core.subscriptions()).await;
        }
        for c in commands {
            if let Command::Persist { mission, disk } = &c {
                // On disk before anything this change leads to leaves the node; a node that
                // cannot keep its promises must not make any.
                let written = match &store {
                    Some(store) => tokio::task::block_in_place(|| store.write(mission, disk)),
                    None => Err(ManagerError::Journal("no state dir, but the chain asked to persist".into())),
                };
                if let Err(e) = written {
                    tracing::error!("{e}; the mission host stops");
                    return Err(e);
                }
                continue;
            }
            io.execute(c).await;
        }
    }
    Ok(())
}

/// The next team of this node's robot; `None` once the robot runtime is gone (or there is none).
async fn local_changed(local: &mut Option<watch::Receiver<LocalTeam>>) -> Option<LocalTeam> {
    match local {
        Some(rx) => match rx.changed().await {
            Ok(()) => Some(rx.borrow_and_update().clone()),
            Err(_) => None,
        },
        None => std::future::pending().await,
    }
}

/// A publication or liveliness change as the core's event, translated by the host's own ingress
/// once the seal proved its sender; `None` (refusals recorded, the rest logged) otherwise.
fn decode(mesh: &Mesh, s: &Sample) -> Option<Event> {
    let key = s.key_expr().as_str();
    let payload = s.payload().to_bytes();
    let from = match mrmm_core::host::sealed(key) {
        Some(what) => Some(mesh.sender_of(what, s)?),
        None => None,
    };
    match mrmm_core::host::ingress(Incoming { key, payload: &payload, put: s.kind() == SampleKind::Put, from: from.as_ref() }) {
        Ok(ev) => Some(ev),
        Err(Refused::NotEntitled { from, what }) => {
            mesh.refuse(&what, &from);
            None
        }
        Err(e) => {
            tracing::debug!("dropped what came on {key}: {e}");
            None
        }
    }
}

/// The I/O half: queries held under ids, the served mission queryables, requests in flight.
struct Io {
    mesh: Mesh,
    tx: mpsc::UnboundedSender<Input>,
    /// Where the mission queryables' callbacks put queries (bounded).
    net: Inbox<Input>,
    queries: HashMap<u64, Query>,
    next: u64,
    served: HashMap<String, Served>,
    maps: MapStore,
}

/// What this node declares for a mission it leads: its queryables and its status publisher.
struct Served {
    _queryables: Vec<Queryable<()>>,
    status: Option<zenoh::pubsub::Publisher<'static>>,
}

impl Io {
    /// Decodes a query into the core's event and holds it; malformed ones are answered here.
    /// Translates a query through the host's ingress and holds it; one whose sender is not
    /// proven (where it must be) or that is malformed is answered here.
    async fn query(&mut self, q: Query) -> Option<Event> {
        let key = q.key_expr().as_str();
        let from = match mrmm_core::host::question_sealed(key) {
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
        match mrmm_core::host::question(question) {
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

    async fn execute(&mut self, c: Command) {
        if let Some(out) = mrmm_core::host::egress(&c) {
            return self.publish(out).await;
        }
        if let Some(ask) = mrmm_core::host::asks::ask(&c) {
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
            Command::Refused { from, what } => self.mesh.refuse(&what, &from),
            // Carried out by the loop, before this.
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
