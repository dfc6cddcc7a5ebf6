//! Mission hosts: the runtime that runs mission managers and does their I/O. Any process can host
//! missions (central hosts `central`; `mrmm mission-host --name N` runs one anywhere). A host
//! announces itself with a liveliness token, starts missions on `mrmm/hosts/<node>/start`, and
//! per mission answers `…/ctl`, `…/view` and `…/marginal`, follows its members' telemetry, asks
//! planner services for plans, hands robots their plans and publishes the mission's status.

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use mrmm_peer::net;
use mrmm_peer::proto::{self, CommandAck, CtlAck, Member, MissionCtl, MissionStart, RobotCommand};
use mrmm_planner::recipe::MissionPlan;
use tokio::sync::mpsc;
use tokio_util::sync::CancellationToken;
use zenoh::bytes::Encoding;
use zenoh::query::{Query, Queryable};
use zenoh::sample::Sample;
use zenoh::Session;

use crate::central::ask;
use crate::error::ManagerError;
use crate::mission::{MCommand, MEvent, MissionManager, MissionSpec};

/// How long a planner service may take.
pub const PLAN_TIMEOUT: Duration = Duration::from_secs(20);
/// How long a robot may take to accept a plan.
const ROBOT_TIMEOUT: Duration = Duration::from_secs(3);
/// Seconds between two status publications of each mission.
const STATUS_PERIOD: Duration = Duration::from_secs(1);

enum Input {
    Start(Query),
    Ctl(String, Query),
    View(String, Query),
    Marginal(String, Query),
    Telemetry(Sample),
    Planned { mission: String, epoch: u64, result: Result<Box<MissionPlan>, String> },
}

struct Hosted {
    mm: MissionManager,
    time_scales: BTreeMap<String, f64>,
    /// The start query, answered once the first plans are out.
    start: Option<Query>,
    _queryables: Vec<Queryable<()>>,
}

/// Hosts missions on `session` as `node` until `shutdown`.
pub async fn serve(session: Session, node: String, shutdown: CancellationToken) -> Result<(), ManagerError> {
    proto::validate_id(&node).map_err(|e| ManagerError::Config(format!("mission host name: {e}")))?;
    let (tx, mut rx) = mpsc::unbounded_channel::<Input>();
    let t = tx.clone();
    let _start = session
        .declare_queryable(proto::host_start(&node))
        .callback(move |q| {
            let _ = t.send(Input::Start(q));
        })
        .await
        .map_err(ManagerError::zenoh)?;
    let t = tx.clone();
    let _telemetry = session
        .declare_subscriber(proto::ALL_ROBOTS_TELEMETRY)
        .callback(move |s| {
            let _ = t.send(Input::Telemetry(s));
        })
        .await
        .map_err(ManagerError::zenoh)?;
    let _token = session.liveliness().declare_token(proto::host_alive(&node)).await.map_err(ManagerError::zenoh)?;
    tracing::info!(%node, "mission host up");
    let mut host = Host { session: session.clone(), node, tx, missions: BTreeMap::new(), t0: Instant::now() };
    let mut status = tokio::time::interval(STATUS_PERIOD);
    loop {
        tokio::select! {
            _ = shutdown.cancelled() => break,
            _ = status.tick() => host.publish_all().await,
            i = rx.recv() => match i {
                Some(i) => host.input(i).await,
                None => break,
            },
        }
    }
    Ok(())
}

struct Host {
    session: Session,
    node: String,
    tx: mpsc::UnboundedSender<Input>,
    missions: BTreeMap<String, Hosted>,
    t0: Instant,
}

impl Host {
    async fn input(&mut self, i: Input) {
        match i {
            Input::Start(q) => self.start(q).await,
            Input::Ctl(name, q) => self.ctl(&name, q).await,
            Input::View(name, q) => match self.missions.get(&name) {
                Some(h) => net::reply_json(&q, &h.mm.view(true)).await,
                None => net::reply_error(&q, &format!("unknown mission {name:?}")).await,
            },
            Input::Marginal(name, q) => {
                let add = match q.parameters().get("add") {
                    None => Ok(1),
                    Some(v) => v.parse::<i64>().ok().filter(|a| *a != 0 && a.abs() <= 1000).ok_or_else(|| {
                        format!("add={v}: give a non-zero whole number, e.g. add=1 or add=-1")
                    }),
                };
                let answer = add.and_then(|add| {
                    self.missions.get(&name).ok_or_else(|| format!("unknown mission {name:?}")).and_then(|h| h.mm.marginal(add))
                });
                match answer {
                    Ok(m) => net::reply_json(&q, &m).await,
                    Err(e) => net::reply_error(&q, &e).await,
                }
            }
            Input::Telemetry(s) => {
                let Ok(t) = proto::decode_telemetry(&s.payload().to_bytes()) else {
                    tracing::debug!("dropped payload on {}", s.key_expr());
                    return;
                };
                let wall = self.t0.elapsed().as_secs_f64();
                let name = self.missions.iter().find(|(_, h)| h.mm.has(&t.id)).map(|(n, _)| n.clone());
                if let Some(name) = name {
                    let scale = self.missions.get(&name).and_then(|h| h.time_scales.get(&t.id).copied()).unwrap_or(1.0);
                    self.run(&name, MEvent::Telemetry { now: wall * scale, t: Box::new(t) }).await;
                }
            }
            Input::Planned { mission, epoch, result } => {
                let ev = match result {
                    Ok(plan) => MEvent::PlanReady { epoch, plan },
                    Err(error) => MEvent::PlanFailed { epoch, error },
                };
                self.run(&mission, ev).await;
            }
        }
    }

    async fn start(&mut self, q: Query) {
        let start: MissionStart = match proto::from_json("mission start", &net::query_payload(&q)) {
            Ok(s) => s,
            Err(e) => return net::reply_error(&q, &e.to_string()).await,
        };
        let spec = match MissionSpec::from_wire(start.spec) {
            Ok(s) => s,
            Err(e) => return net::reply_error(&q, &e).await,
        };
        let name = spec.name.clone();
        if self.missions.contains_key(&name) {
            return net::reply_error(&q, &format!("mission {name:?} is already hosted here")).await;
        }
        let queryables = match self.declare(&name).await {
            Ok(qs) => qs,
            Err(e) => return net::reply_error(&q, &e.to_string()).await,
        };
        let time_scales = start.members.iter().map(|m| (m.spec.id.clone(), m.time_scale)).collect();
        let members = start.members.into_iter().map(|m| m.spec).collect();
        let mm = MissionManager::new(spec, self.node.clone(), members);
        tracing::info!(mission = %name, "hosting mission");
        self.missions.insert(name.clone(), Hosted { mm, time_scales, start: Some(q), _queryables: queryables });
        self.run(&name, MEvent::Start).await;
    }

    async fn declare(&self, name: &str) -> Result<Vec<Queryable<()>>, ManagerError> {
        let mut out = Vec::new();
        for (key, kind) in [(proto::mission_ctl(name), 0), (proto::mission_view(name), 1), (proto::mission_marginal(name), 2)] {
            let (tx, n) = (self.tx.clone(), name.to_string());
            let q = self
                .session
                .declare_queryable(key)
                .callback(move |q| {
                    let _ = tx.send(match kind {
                        0 => Input::Ctl(n.clone(), q),
                        1 => Input::View(n.clone(), q),
                        _ => Input::Marginal(n.clone(), q),
                    });
                })
                .await
                .map_err(ManagerError::zenoh)?;
            out.push(q);
        }
        Ok(out)
    }

    async fn ctl(&mut self, name: &str, q: Query) {
        let ctl: MissionCtl = match proto::from_json("mission control", &net::query_payload(&q)) {
            Ok(c) => c,
            Err(e) => return net::reply_error(&q, &e.to_string()).await,
        };
        if !self.missions.contains_key(name) {
            return net::reply_error(&q, &format!("unknown mission {name:?}")).await;
        }
        match ctl {
            MissionCtl::Joined { member: Member { spec, time_scale } } => {
                if let Some(h) = self.missions.get_mut(name) {
                    h.time_scales.insert(spec.id.clone(), time_scale);
                }
                self.run(name, MEvent::Joined(spec)).await;
            }
            MissionCtl::Left { ids } => self.run(name, MEvent::Left { ids }).await,
            MissionCtl::Terminate => {
                if let Some(h) = self.missions.remove(name) {
                    tracing::info!(mission = %name, "mission terminated");
                    if let Some(sq) = h.start {
                        net::reply_error(&sq, &format!("mission {name} was terminated")).await;
                    }
                    return net::reply_json(&q, &CtlAck { ok: true, epoch: h.mm.epoch() }).await;
                }
            }
        }
        let epoch = self.missions.get(name).map_or(0, |h| h.mm.epoch());
        net::reply_json(&q, &CtlAck { ok: true, epoch }).await;
    }

    /// Runs one event of a mission and carries out its commands.
    async fn run(&mut self, name: &str, ev: MEvent) {
        let Some(h) = self.missions.get_mut(name) else { return };
        let publish_now = !matches!(ev, MEvent::Telemetry { .. });
        for c in h.mm.handle(ev) {
            match c {
                MCommand::RequestPlan { epoch, kind, request } => {
                    let (session, tx, mission) = (self.session.clone(), self.tx.clone(), name.to_string());
                    tokio::spawn(async move {
                        let result = match proto::to_json(&request) {
                            Ok(body) => ask::<MissionPlan>(&session, &proto::planner(kind.as_str()), Some(body), PLAN_TIMEOUT).await,
                            Err(e) => Err(e.to_string()),
                        };
                        let _ = tx.send(Input::Planned { mission, epoch, result: result.map(Box::new) });
                    });
                }
                MCommand::SendPlan { robot, assignment } => {
                    let session = self.session.clone();
                    tokio::spawn(async move {
                        let cmd = RobotCommand::Plan(assignment);
                        let result = match proto::to_json(&cmd) {
                            Ok(body) => ask::<CommandAck>(&session, &proto::robot_cmd(&robot), Some(body), ROBOT_TIMEOUT).await,
                            Err(e) => Err(e.to_string()),
                        };
                        if let Err(e) = result {
                            tracing::warn!(%robot, "plan not delivered: {e}");
                        }
                    });
                }
                MCommand::Started => {
                    if let Some(q) = h.start.take() {
                        net::reply_json(&q, &h.mm.view(false)).await;
                    }
                }
                MCommand::Failed { error } => {
                    if let Some(q) = h.start.take() {
                        net::reply_error(&q, &format!("mission {name}: planning failed: {error}")).await;
                    }
                    self.missions.remove(name);
                    return;
                }
            }
        }
        // Publish changes at once (membership, epoch, status), not only once a second.
        if let Some(h) = self.missions.get(name).filter(|_| publish_now) {
            self.publish(&h.mm).await;
        }
    }

    async fn publish_all(&self) {
        for h in self.missions.values() {
            self.publish(&h.mm).await;
        }
    }

    async fn publish(&self, mm: &MissionManager) {
        match serde_json::to_vec(&mm.view(false)) {
            Ok(bytes) => {
                if let Err(e) = self.session.put(proto::mission_status(mm.name()), bytes).encoding(Encoding::APPLICATION_JSON).await {
                    tracing::warn!("status publication failed: {e}");
                }
            }
            Err(e) => tracing::warn!("cannot encode the status of {}: {e}", mm.name()),
        }
    }
}
