//! Mission hosts: the runtime that runs mission managers, replicates them and does their I/O.
//! Every robot runs one (named after the robot), central runs `central`, and
//! `mrmm mission-host --name N` runs one anywhere. A host announces itself with a liveliness
//! token, starts missions on `mrmm/hosts/<node>/start`, and holds chain replicas of mission
//! managers ([`crate::chain`]): chain messages arrive on `mrmm/hosts/<node>/chain`. The head of a
//! mission's chain runs its [`MissionManager`] (see `head.rs`): it answers `…/ctl`, `…/view` and
//! `…/marginal`, follows its members' telemetry and liveliness, asks planner services for plans
//! (or plans itself when none is alive), and acts only on state its chain has committed.

mod head;

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::time::{Duration, Instant};

use mrmm_peer::proto;
use mrmm_planner::recipe::MissionPlan;
use serde::{Deserialize, Serialize};
use tokio::sync::mpsc;
use tokio_util::sync::CancellationToken;
use zenoh::bytes::Encoding;
use zenoh::query::Query;
use zenoh::sample::{Sample, SampleKind};
use zenoh::Session;

use crate::chain::{self, Msg, Params, Replica};
use crate::error::ManagerError;
use crate::mission::MissionSnapshot;

use head::Head;

/// How long a planner service may take.
pub const PLAN_TIMEOUT: Duration = Duration::from_secs(20);
/// Seconds between two status publications of each mission.
const STATUS_PERIOD: Duration = Duration::from_secs(1);
/// Period of the chain replicas' clock.
const CHAIN_TICK: Duration = Duration::from_millis(50);
/// Liveliness of every planner service.
const ALL_PLANNERS_ALIVE: &str = "mrmm/planner/*/alive/*";

/// Payload of `mrmm/hosts/<node>/chain` (JSON): one chain message of one mission.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ChainEnvelope {
    pub mission: String,
    pub from: String,
    pub msg: Msg<MissionSnapshot>,
}

type ChainCmd = chain::Command<MissionSnapshot>;

/// A chain message's kind and epoch, for traces.
fn msg_kind(m: &Msg<MissionSnapshot>) -> String {
    match m {
        Msg::Vote { proposal, .. } => format!("vote e{}", proposal.epoch),
        Msg::Grant { epoch } => format!("grant e{epoch}"),
        Msg::Refuse { epoch, promised, .. } => format!("refuse e{epoch} p{promised}"),
        Msg::Update { config, seq, .. } => format!("update e{} s{seq}", config.epoch),
        Msg::Ack { epoch, seq } => format!("ack e{epoch} s{seq}"),
        Msg::Stale { promised, .. } => format!("stale p{promised}"),
        Msg::End { epoch } => format!("end e{epoch}"),
        Msg::EndAck { epoch } => format!("end-ack e{epoch}"),
    }
}

enum Input {
    Start(Query),
    Ctl(String, Query),
    View(String, Query),
    Marginal(String, Query),
    Telemetry(Sample),
    Planned { mission: String, epoch: u64, result: Result<Box<MissionPlan>, String> },
    Chain(Sample),
    HostLive(Sample),
    RobotLive(Sample),
    PlannerLive(Sample),
}

/// What a host remembers of a mission it no longer replicates.
#[derive(Debug, Clone, Copy, Default)]
struct Tomb {
    promised: u64,
    ended: bool,
}

/// Hosts missions on `session` as `node` until `shutdown`, with the default chain parameters.
pub async fn serve(session: Session, node: String, shutdown: CancellationToken) -> Result<(), ManagerError> {
    serve_with(session, node, Params::default(), shutdown).await
}

/// Hosts missions with chain parameters `params` (`params.k` replicas per mission).
pub async fn serve_with(session: Session, node: String, params: Params, shutdown: CancellationToken) -> Result<(), ManagerError> {
    proto::validate_id(&node).map_err(|e| ManagerError::Config(format!("mission host name: {e}")))?;
    let (tx, mut rx) = mpsc::unbounded_channel::<Input>();
    let sub = |key: String, f: fn(Sample) -> Input| {
        let t = tx.clone();
        let session = session.clone();
        async move {
            session
                .declare_subscriber(key)
                .callback(move |s| {
                    let _ = t.send(f(s));
                })
                .await
                .map_err(ManagerError::zenoh)
        }
    };
    let live = |key: &'static str, f: fn(Sample) -> Input| {
        let t = tx.clone();
        let session = session.clone();
        async move {
            session
                .liveliness()
                .declare_subscriber(key)
                .history(true)
                .callback(move |s| {
                    let _ = t.send(f(s));
                })
                .await
                .map_err(ManagerError::zenoh)
        }
    };
    let t = tx.clone();
    let _start = session
        .declare_queryable(proto::host_start(&node))
        .callback(move |q| {
            let _ = t.send(Input::Start(q));
        })
        .await
        .map_err(ManagerError::zenoh)?;
    let _telemetry = sub(proto::ALL_ROBOTS_TELEMETRY.to_string(), Input::Telemetry).await?;
    let _chain = sub(proto::host_chain(&node), Input::Chain).await?;
    let _hosts = live(proto::ALL_HOSTS_ALIVE, Input::HostLive).await?;
    let _robots = live(proto::ALL_ROBOTS_ALIVE, Input::RobotLive).await?;
    let _planners = live(ALL_PLANNERS_ALIVE, Input::PlannerLive).await?;
    let _token = session.liveliness().declare_token(proto::host_alive(&node)).await.map_err(ManagerError::zenoh)?;
    tracing::info!(%node, "mission host up");
    let mut host = Host {
        session: session.clone(),
        node,
        tx,
        t0: Instant::now(),
        params,
        heads: BTreeMap::new(),
        replicas: BTreeMap::new(),
        tombs: BTreeMap::new(),
        hosts: BTreeSet::new(),
        robots: BTreeSet::new(),
        planners: BTreeSet::new(),
    };
    let mut status = tokio::time::interval(STATUS_PERIOD);
    let mut tick = tokio::time::interval(CHAIN_TICK);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    loop {
        tokio::select! {
            _ = shutdown.cancelled() => break,
            _ = status.tick() => host.status_tick().await,
            _ = tick.tick() => host.chain_tick().await,
            i = rx.recv() => match i {
                Some(i) => host.input(i).await,
                None => break,
            },
        }
    }
    Ok(())
}

pub(crate) struct Host {
    session: Session,
    node: String,
    tx: mpsc::UnboundedSender<Input>,
    t0: Instant,
    params: Params,
    /// Missions this node leads.
    heads: BTreeMap<String, Head>,
    /// This node's chain replica of each mission it is in.
    replicas: BTreeMap<String, Replica<MissionSnapshot>>,
    tombs: BTreeMap<String, Tomb>,
    /// Hosts alive (robots included).
    hosts: BTreeSet<String>,
    robots: BTreeSet<String>,
    /// Liveliness keys of the planner services alive.
    planners: BTreeSet<String>,
}

impl Host {
    fn now(&self) -> f64 {
        self.t0.elapsed().as_secs_f64()
    }

    async fn input(&mut self, i: Input) {
        match i {
            Input::Start(q) => self.start(q).await,
            Input::Ctl(name, q) => self.ctl(&name, q).await,
            Input::View(name, q) => self.answer_view(&name, q).await,
            Input::Marginal(name, q) => self.answer_marginal(&name, q).await,
            Input::Telemetry(s) => self.telemetry(s).await,
            Input::Planned { mission, epoch, result } => self.planned(&mission, epoch, result).await,
            Input::Chain(s) => self.chain_in(s).await,
            Input::HostLive(s) => {
                let Some(node) = proto::parse_host_alive(s.key_expr().as_str()).map(str::to_string) else { return };
                if node == self.node {
                    return;
                }
                let up = s.kind() == SampleKind::Put;
                if up {
                    self.hosts.insert(node.clone());
                } else {
                    self.hosts.remove(&node);
                }
                let now = self.now();
                let names: Vec<String> = self.replicas.keys().cloned().collect();
                for name in names {
                    let ev = if up { chain::Event::Alive(node.clone()) } else { chain::Event::Gone(node.clone()) };
                    let cmds = self.replicas.get_mut(&name).map(|r| r.handle(now, ev)).unwrap_or_default();
                    self.apply(&name, cmds).await;
                }
            }
            Input::RobotLive(s) => {
                let Some((id, proto::RobotTopic::Alive)) = proto::parse_robot_key(s.key_expr().as_str()) else { return };
                let id = id.to_string();
                let up = s.kind() == SampleKind::Put;
                if up {
                    self.robots.insert(id.clone());
                } else {
                    self.robots.remove(&id);
                }
                self.robot_liveliness(&id, up).await;
            }
            Input::PlannerLive(s) => {
                let key = s.key_expr().to_string();
                match s.kind() {
                    SampleKind::Put => self.planners.insert(key),
                    SampleKind::Delete => self.planners.remove(&key),
                };
            }
        }
    }

    /// The replica of `name`, created on first use with what this process remembers of it.
    fn replica(&mut self, name: &str) -> &mut Replica<MissionSnapshot> {
        let now = self.now();
        let promised = self.tombs.get(name).map_or(0, |t| t.promised);
        let (me, p, hosts) = (&self.node, self.params, &self.hosts);
        self.replicas.entry(name.to_string()).or_insert_with(|| {
            let mut r = Replica::new(me, p, 0.0, now, promised);
            for h in hosts {
                let _ = r.handle(now, chain::Event::Alive(h.clone()));
            }
            r
        })
    }

    async fn chain_in(&mut self, s: Sample) {
        let env: ChainEnvelope = match serde_json::from_slice(&s.payload().to_bytes()) {
            Ok(e) => e,
            Err(e) => {
                tracing::debug!("dropped chain message on {}: {e}", s.key_expr());
                return;
            }
        };
        if proto::validate_id(&env.mission).is_err() || proto::validate_id(&env.from).is_err() {
            tracing::debug!("dropped chain message with a bad mission or node name");
            return;
        }
        let name = env.mission.clone();
        tracing::trace!(mission = %name, from = %env.from, msg = msg_kind(&env.msg), "chain: received");
        if !self.replicas.contains_key(&name) {
            match (&env.msg, self.tombs.get(&name)) {
                // A replica that missed the end of its mission is told again.
                (Msg::Vote { .. }, Some(t)) if t.ended => {
                    self.send(&name, &env.from, Msg::End { epoch: u64::MAX }).await;
                    return;
                }
                // A head replicating to us: we are (again) in its chain.
                (Msg::Update { .. }, Some(_)) => {
                    self.tombs.remove(&name);
                }
                (Msg::Vote { .. } | Msg::Update { .. }, _) => {}
                // Anything else is for a replica we no longer have.
                _ => return,
            }
        }
        let now = self.now();
        let cmds = self.replica(&name).handle(now, chain::Event::Recv { from: env.from, msg: env.msg });
        self.apply(&name, cmds).await;
    }

    async fn send(&self, mission: &str, to: &str, msg: Msg<MissionSnapshot>) {
        tracing::trace!(%mission, %to, msg = msg_kind(&msg), "chain: sending");
        let env = ChainEnvelope { mission: mission.to_string(), from: self.node.clone(), msg };
        match serde_json::to_vec(&env) {
            Ok(bytes) => {
                if let Err(e) = self.session.put(proto::host_chain(to), bytes).encoding(Encoding::APPLICATION_JSON).await {
                    tracing::warn!(%to, "chain message not sent: {e}");
                }
            }
            Err(e) => tracing::warn!("cannot encode a chain message: {e}"),
        }
    }

    /// Carries out a replica's commands (and those they lead to).
    async fn apply(&mut self, name: &str, cmds: Vec<ChainCmd>) {
        let mut queue: VecDeque<ChainCmd> = cmds.into();
        while let Some(c) = queue.pop_front() {
            match c {
                chain::Command::Send { to, msg } => self.send(name, &to, msg).await,
                chain::Command::Lead { config, state } => {
                    let more = self.lead(name, config, state).await;
                    queue.extend(more);
                }
                chain::Command::Committed { .. } => {
                    let more = self.flush(name).await;
                    queue.extend(more);
                }
                chain::Command::StepDown => self.step_down(name, "a newer manager took over").await,
                chain::Command::Retired => {
                    if let Some(r) = self.replicas.remove(name) {
                        let t = self.tombs.entry(name.to_string()).or_default();
                        t.promised = t.promised.max(r.promised());
                        // Retired by an end: remember it, so stragglers are told.
                        t.ended |= r.ended();
                    }
                    self.step_down(name, "this node left the mission's chain").await;
                }
            }
        }
    }

    async fn chain_tick(&mut self) {
        let now = self.now();
        let names: Vec<String> = self.replicas.keys().cloned().collect();
        for name in names {
            let cmds = self.replicas.get_mut(&name).map(|r| r.handle(now, chain::Event::Tick)).unwrap_or_default();
            if !cmds.is_empty() {
                self.apply(&name, cmds).await;
            }
        }
    }
}
