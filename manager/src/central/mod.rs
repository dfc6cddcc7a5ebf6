//! The central node: a Zenoh router hosting the system manager, the advising agent, a planner
//! service and the mission host `central`. Every decision is in [`CentralCore`] (`core.rs`);
//! this file is its driver: it decodes Zenoh traffic into [`Event`]s (answering malformed
//! requests itself), holds operator queries under an id, and carries out the [`Command`]s.

mod config;

use std::collections::HashMap;
use std::time::{Duration, Instant};

use mrmm_net::net::{self, Mode};
use mrmm_net::{Mesh, NodeNet};
use mrmm_proto::{self as proto, Key, Pattern, Role, Sender};
use tokio::sync::{mpsc, oneshot};
use tokio_util::sync::CancellationToken;
use zenoh::query::Query;
use zenoh::sample::{Sample, SampleKind};

pub use self::config::CentralConfig;
use crate::error::ManagerError;
use crate::inbox::Inbox;
use crate::journal::{now_ms, Journal};
use crate::system::{self, Req, Request};
pub use mrmm_core::central::{CentralCore, Command, Event, AGENT_PERIOD_S};
use mrmm_core::edge::{Incoming, Refused};

/// Liveliness changes waiting for central's loop, at most.
const LIVELINESS_QUEUE: usize = 65_536;
/// Publications and queries waiting for central's loop, at most.
const NET_QUEUE: usize = 8_192;
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

enum Input {
    Operator(Query),
    Advice(Query),
    Sample(Sample),
    Event(system::Event),
}

/// Runs central until `shutdown` is cancelled.
pub async fn run(cfg: CentralConfig, shutdown: CancellationToken, ready: Option<oneshot::Sender<Ready>>) -> Result<(), ManagerError> {
    cfg.validate().map_err(ManagerError::Config)?;
    let (mut journal, state, chain) = open_state(&cfg)?;
    let maps = load_maps(&cfg)?;
    let mesh = Mesh::open(&node_net(&cfg)).await?;
    let session = mesh.session().clone();
    let endpoints = net::listening_endpoints(&session).await;
    let zid = session.zid().to_string();
    // Our own tasks' answers; and, bounded, what the network sends (liveliness apart: a flood
    // of data must not push out the news that a robot died).
    let (tx, mut rx) = mpsc::unbounded_channel::<Input>();
    let (live, mut live_rx) = Inbox::new("liveliness", LIVELINESS_QUEUE);
    let (net, mut net_rx) = Inbox::new("publications and queries", NET_QUEUE);
    let held = declare_inputs(&session, &live, &net).await?;
    // The default planner service and mission host live here too.
    let planners = tokio::spawn(crate::planner_service::serve(mesh.clone(), maps.clone(), shutdown.child_token()));
    let missions = tokio::spawn(crate::host::serve(mesh.clone(), proto::CENTRAL_HOST.to_string(), None, chain, maps.clone(), shutdown.child_token()));
    tracing::info!(%zid, ?endpoints, "central up");
    if let Some(tx) = ready {
        let _ = tx.send(Ready { zid: zid.clone(), endpoints });
    }

    let t0 = Instant::now();
    let mut core = CentralCore::restore(zid, cfg.agent.clone(), 0.0, state).with_maps(maps.by_name());
    let mut io = Io { mesh: mesh.clone(), timeout: Duration::from_millis(cfg.query_timeout_ms), queries: HashMap::new(), next: 0, tx };
    let mut tick = tokio::time::interval(TICK);
    let mut seals = SealCounts { refused: 0, proofs_at: Instant::now() };
    loop {
        let event = tokio::select! {
            _ = shutdown.cancelled() => break,
            _ = tick.tick() => {
                for e in seals.due(&mesh) {
                    let cmds = core.handle(t0.elapsed().as_secs_f64(), Event::System(e));
                    carry_out(&mut io, journal.as_mut(), cmds).await?;
                }
                Event::System(system::Event::Tick)
            }
            i = async {
                tokio::select! {
                    i = live_rx.recv() => i,
                    i = rx.recv() => i,
                    i = net_rx.recv() => i,
                }
            } => match i {
                Some(Input::Operator(q)) if Key::parse(q.key_expr().as_str()) == Some(Key::SystemJournal) => {
                    answer_journal(&mesh, journal.as_ref(), q).await;
                    continue;
                }
                Some(Input::Operator(q)) => match io.operator(q).await {
                    Some(e) => e,
                    None => continue,
                },
                Some(Input::Advice(q)) => Event::Advice { query: io.hold(q) },
                Some(Input::Sample(s)) => match decode(&mesh, &s) {
                    Some(e) => Event::System(e),
                    None => continue,
                },
                Some(Input::Event(e)) => Event::System(e),
                None => break,
            },
        };
        let cmds = core.handle(t0.elapsed().as_secs_f64(), event);
        carry_out(&mut io, journal.as_mut(), cmds).await?;
    }
    tracing::info!("central shutting down");
    drop(held);
    let _ = planners.await;
    let _ = missions.await;
    session.close().await.map_err(ManagerError::zenoh)?;
    Ok(())
}

/// Carries out one event's commands: its journal entries are committed (fsync) before anything
/// else is done or said. A journal that cannot be written stops central: it restarts from
/// Central's session: the fleet's router, listening where its config says.
fn node_net(cfg: &CentralConfig) -> NodeNet {
    NodeNet {
        mode: Mode::Router,
        listen: cfg.listen.clone(),
        connect: vec![],
        lease_ms: cfg.lease_ms,
        max_message_size: cfg.max_message_size,
        security: cfg.security.clone(),
        me: Some(Sender::new(Role::Central, proto::CENTRAL_HOST)),
        wire_stats: cfg.wire_stats,
    }
}

/// What the seals of central's session counted, reported to the system manager: refusals as
/// soon as there are new ones, proofs once a second.
struct SealCounts {
    refused: u64,
    proofs_at: Instant,
}

impl SealCounts {
    fn due(&mut self, mesh: &Mesh) -> Vec<system::Event> {
        let mut out = Vec::new();
        let total = mesh.verifier().refused.total();
        if total != self.refused {
            self.refused = total;
            out.push(system::Event::Refusals(mesh.verifier().refused.counts()));
        }
        if self.proofs_at.elapsed() >= Duration::from_secs(1) {
            self.proofs_at = Instant::now();
            out.push(system::Event::Proofs(mesh.verifier().proven.counts()));
        }
        out
    }
}

/// The journal (a state dir another central uses, or a damaged one, stops start-up) and the
/// state it replays; beside it, the chain state of central's mission host (`chain.redb`): a
/// mission it leads or replicates comes back through its chain after a restart, as on a robot
/// with a state dir, rather than wait for a vote the host forgot it gave.
type State = (Option<Journal>, system::Durable, Option<crate::host::store::Opened>);

fn open_state(cfg: &CentralConfig) -> Result<State, ManagerError> {
    // The journal first: a state dir another central uses, or a damaged one, stops start-up.
    // Its mission host keeps its chain state beside the journal (`chain.redb`): a mission it
    // leads or replicates comes back through its chain after a restart, as on a robot with a
    // state dir, rather than wait for a vote the host forgot it gave.
    Ok(match &cfg.state_dir {
        Some(dir) => {
            let (j, state) = Journal::open(dir)?;
            tracing::info!(dir = %dir.display(), entries = j.last(), missions = state.missions.len(), robots = state.assignment.len(), "journal replayed");
            let chain = crate::host::store::Store::open(dir)?;
            (Some(j), state, Some(chain))
        }
        None => {
            tracing::warn!("no state dir: central keeps nothing on disk, and a restart forgets every mission");
            (None, system::Durable::default(), None)
        }
    })
}

/// The maps central offers: one that cannot be read stops start-up with one line naming it.
fn load_maps(cfg: &CentralConfig) -> Result<crate::maps::MapStore, ManagerError> {
    let maps = crate::maps::MapStore::default();
    for (name, path) in &cfg.maps {
        let held = tokio::task::block_in_place(|| crate::maps::load_file(name, path))?;
        tracing::info!(map = %name, format = %held.info.format, size = %held.info.size, hash = %held.info.hash, "map loaded");
        maps.insert(held);
    }
    Ok(maps)
}

/// Central's subscriptions and queryables, kept alive while it runs.
#[derive(Default)]
struct Held {
    subs: Vec<zenoh::pubsub::Subscriber<()>>,
    operator: Option<zenoh::query::Queryable<()>>,
    advice: Option<zenoh::query::Queryable<()>>,
}

/// Robots' and hosts' liveliness (on their own inbox: a flood of data must not push out the
/// news that a robot died), telemetry, mission status, the operator API and the advice.
async fn declare_inputs(session: &zenoh::Session, live: &Inbox<Input>, net: &Inbox<Input>) -> Result<Held, ManagerError> {
    let mut held = Held::default();
    for pattern in [Pattern::AllRobotsAlive, Pattern::AllHostsAlive] {
        held.subs.push(live.liveliness(session, pattern.to_string(), Input::Sample).await?);
    }
    for sub in system::subscriptions() {
        held.subs.push(net.subscribe(session, sub.expr, Input::Sample).await?);
    }
    let t = net.clone();
    held.operator = Some(
        session
            .declare_queryable(Pattern::SystemAll.to_string())
            .callback(move |q| {
                t.push(Input::Operator(q));
            })
            .await
            .map_err(ManagerError::zenoh)?,
    );
    let t = net.clone();
    held.advice = Some(
        session
            .declare_queryable(Key::AgentAdvice.to_string())
            .callback(move |q| {
                t.push(Input::Advice(q));
            })
            .await
            .map_err(ManagerError::zenoh)?,
    );
    Ok(held)
}

/// what is on disk rather than say "ok" about what is not.
async fn carry_out(io: &mut Io, journal: Option<&mut Journal>, cmds: Vec<Command>) -> Result<(), ManagerError> {
    let (mut events, mut rest) = (Vec::new(), Vec::new());
    for c in cmds {
        match c {
            Command::System(system::Command::Journal(e)) => events.extend(e),
            c => rest.push(c),
        }
    }
    if let (Some(j), false) = (journal, events.is_empty()) {
        tokio::task::block_in_place(|| j.append(&events, now_ms())).inspect_err(|e| tracing::error!("{e}: central stops"))?;
    }
    for c in rest {
        io.execute(c).await;
    }
    Ok(())
}

/// Answers `mrmm/system/journal?since=SEQ&limit=N` from the database.
async fn answer_journal(mesh: &Mesh, journal: Option<&Journal>, q: Query) {
    let result = match (proto::journal::journal_query(q.parameters().as_str()), journal) {
        (Err(e), _) => Err(e),
        (Ok(_), None) => Err("central runs without a state dir: it keeps no journal".to_string()),
        (Ok((since, limit)), Some(j)) => tokio::task::block_in_place(|| j.page(since, limit)).map_err(|e| e.to_string()),
    };
    match result.and_then(|p| serde_json::to_value(p).map_err(|e| e.to_string())) {
        Ok(v) => mesh.reply_json(&q, &v).await,
        Err(e) => mesh.reply_error(&q, &e).await,
    }
}

/// A publication or liveliness change as the system manager's event, translated by its own
/// ingress once the seal proved its sender; `None` (refusals recorded, the rest logged) otherwise.
fn decode(mesh: &Mesh, s: &Sample) -> Option<system::Event> {
    let key = s.key_expr().as_str();
    let payload = s.payload().to_bytes();
    let from = match system::sealed(key) {
        Some(what) => Some(mesh.sender_of(what, s)?),
        None => None,
    };
    match system::ingress(Incoming { key, payload: &payload, put: s.kind() == SampleKind::Put, from: from.as_ref() }) {
        Ok(ev) => Some(ev),
        Err(Refused::NotEntitled { from, what }) => {
            mesh.refuse(&what, &from);
            None
        }
        Err(e) => {
            tracing::warn!("dropped what came on {key}: {e}");
            None
        }
    }
}

/// The I/O half: operator queries held under ids, and requests to robots and hosts.
struct Io {
    mesh: Mesh,
    timeout: Duration,
    queries: HashMap<u64, Query>,
    next: u64,
    tx: mpsc::UnboundedSender<Input>,
}

impl Io {
    fn hold(&mut self, q: Query) -> u64 {
        let id = self.next;
        self.next += 1;
        self.queries.insert(id, q);
        id
    }

    /// Decodes an operator query into a typed request; unknown keys and malformed payloads are
    /// answered here.
    async fn operator(&mut self, q: Query) -> Option<Event> {
        let payload = net::query_payload(&q);
        let request = Request::decode(q.key_expr().as_str(), &payload);
        match request {
            Ok(request) => Some(Event::System(system::Event::Operator { req: Req::Query(self.hold(q)), request })),
            Err(e) => {
                self.mesh.reply_error(&q, &e).await;
                None
            }
        }
    }

    /// Runs `ask` in the background and hands its answer to the loop as an event.
    fn spawn<F>(&self, ask: F)
    where
        F: std::future::Future<Output = system::Event> + Send + 'static,
    {
        let tx = self.tx.clone();
        tokio::spawn(async move {
            let _ = tx.send(Input::Event(ask.await));
        });
    }

    async fn execute(&mut self, c: Command) {
        if let Some(out) = mrmm_core::central::egress(&c) {
            return crate::edge::publish(&self.mesh, out).await;
        }
        let Command::System(c) = c else { return };
        if let Some(ask) = system::asks::ask(&c) {
            let (mesh, timeout) = (self.mesh.clone(), self.timeout);
            return self.spawn(async move {
                let key = ask.key.to_string();
                let result = crate::edge::answer_of(&mesh, &ask, timeout).await;
                ask.then.answer(&key, result)
            });
        }
        match c {
            system::Command::Reply { req, result } => {
                let Req::Query(id) = req else { return };
                let Some(q) = self.queries.remove(&id) else {
                    return;
                };
                match result {
                    Ok(v) => self.mesh.reply_json(&q, &v).await,
                    Err(e) => self.mesh.reply_error(&q, &e).await,
                }
            }
            system::Command::Refused { from, what } => self.mesh.refuse(&what, &from),
            // Published above.
            system::Command::Chain { .. } => {}
            // Committed by `carry_out` before anything else.
            system::Command::Journal(_) => {}
            system::Command::DryRun(dry) => self.spawn(async move {
                let id = dry.id;
                let run = tokio::task::spawn_blocking(move || dry.run());
                let result = match tokio::time::timeout(DRY_RUN_DEADLINE, run).await {
                    Ok(Ok(r)) => r,
                    Ok(Err(e)) => Err(format!("the dry run failed: {e}")),
                    Err(_) => Err(format!("the dry run took longer than {} s: ask for less", DRY_RUN_DEADLINE.as_secs())),
                };
                system::Event::DryRunDone { id, result }
            }),
            // Asked above.
            system::Command::FetchInfo { .. }
            | system::Command::SendToRobot { .. }
            | system::Command::StartMission { .. }
            | system::Command::Ctl { .. }
            | system::Command::Forward { .. } => {}
        }
    }
}
