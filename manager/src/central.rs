//! The central node: a Zenoh router hosting the system manager. This is the thin async driver that
//! turns Zenoh traffic into [`Event`]s and carries out the [`Command`]s of [`SystemManager`].

use std::collections::HashMap;
use std::path::Path;
use std::time::{Duration, Instant};

use mrmm_peer::net::{self, Mode, DEFAULT_CENTRAL, DEFAULT_LEASE_MS};
use mrmm_peer::proto::{self, CommandAck, CtlAck, ErrorReply, MissionView, RobotInfo, SystemKey};
use serde::Deserialize;
use tokio::sync::{mpsc, oneshot};
use tokio_util::sync::CancellationToken;
use zenoh::bytes::Encoding;
use zenoh::query::Query;
use zenoh::sample::SampleKind;
use zenoh::Session;

use crate::agent::{Agent, AgentCommand, AgentConfig, AgentEvent};
use crate::error::ManagerError;
use crate::system::{Command, Event, Request, SystemManager};

/// Period of the manager's housekeeping tick.
const TICK: Duration = Duration::from_millis(250);
/// The agent looks at the fleet every this many ticks (1 s).
const AGENT_EVERY: u64 = 4;
/// How long a mission host may take to plan a new mission.
const START_TIMEOUT: Duration = Duration::from_secs(25);

/// Config of `mrmm central` (JSON5).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CentralConfig {
    /// Router endpoints; robots connect here.
    #[serde(default = "default_listen")]
    pub listen: Vec<String>,
    /// Link lease, ms.
    #[serde(default = "default_lease")]
    pub lease_ms: u64,
    /// How long to wait for a robot's answer, ms.
    #[serde(default = "default_query_timeout")]
    pub query_timeout_ms: u64,
    /// The advising agent.
    #[serde(default)]
    pub agent: AgentConfig,
}

fn default_listen() -> Vec<String> {
    vec![DEFAULT_CENTRAL.to_string()]
}
fn default_lease() -> u64 {
    DEFAULT_LEASE_MS
}
fn default_query_timeout() -> u64 {
    2000
}

impl Default for CentralConfig {
    fn default() -> Self {
        CentralConfig {
            listen: default_listen(),
            lease_ms: default_lease(),
            query_timeout_ms: default_query_timeout(),
            agent: AgentConfig::default(),
        }
    }
}

impl CentralConfig {
    /// Reads and validates a central config file.
    pub fn load(path: &Path) -> Result<Self, ManagerError> {
        let cfg: CentralConfig = mrmm_peer::config::load_json5(path)?;
        cfg.validate().map_err(|e| ManagerError::Config(format!("{}: {e}", path.display())))?;
        Ok(cfg)
    }

    /// Checks every value; the error is `field: problem`.
    pub fn validate(&self) -> Result<(), String> {
        if self.listen.is_empty() {
            return Err("listen: at least one endpoint is needed".into());
        }
        net::validate_endpoints("listen", &self.listen)?;
        if !(100..=60_000).contains(&self.lease_ms) {
            return Err(format!("lease_ms: must be 100..=60000 (got {})", self.lease_ms));
        }
        if !(10..=60_000).contains(&self.query_timeout_ms) {
            return Err(format!("query_timeout_ms: must be 10..=60000 (got {})", self.query_timeout_ms));
        }
        self.agent.validate()
    }
}

/// What central reports once it is serving.
#[derive(Debug, Clone)]
pub struct Ready {
    pub zid: String,
    pub endpoints: Vec<String>,
}

/// Runs central until `shutdown` is cancelled.
pub async fn run(
    cfg: CentralConfig,
    shutdown: CancellationToken,
    ready: Option<oneshot::Sender<Ready>>,
) -> Result<(), ManagerError> {
    cfg.validate().map_err(ManagerError::Config)?;
    let session = net::open(net::zenoh_config(Mode::Router, &cfg.listen, &[], cfg.lease_ms)?).await?;
    let endpoints = net::listening_endpoints(&session).await;
    let zid = session.zid().to_string();
    let alive = session
        .liveliness()
        .declare_subscriber(proto::ALL_ROBOTS_ALIVE)
        .history(true)
        .await
        .map_err(ManagerError::zenoh)?;
    let telemetry = session
        .declare_subscriber(proto::ALL_ROBOTS_TELEMETRY)
        .await
        .map_err(ManagerError::zenoh)?;
    let operator = session
        .declare_queryable(proto::SYSTEM_ALL)
        .await
        .map_err(ManagerError::zenoh)?;
    let statuses = session.declare_subscriber(proto::ALL_MISSIONS_STATUS).await.map_err(ManagerError::zenoh)?;
    let advice = session.declare_queryable(proto::AGENT_ADVICE).await.map_err(ManagerError::zenoh)?;
    let hosts = session
        .liveliness()
        .declare_subscriber(proto::ALL_HOSTS_ALIVE)
        .history(true)
        .await
        .map_err(ManagerError::zenoh)?;
    // The default planner service and mission host live here too.
    let planners = tokio::spawn(crate::planner_service::serve(session.clone(), shutdown.child_token()));
    let missions = tokio::spawn(crate::host::serve(session.clone(), proto::CENTRAL_HOST.to_string(), shutdown.child_token()));
    tracing::info!(%zid, ?endpoints, "central up");
    if let Some(tx) = ready {
        let _ = tx.send(Ready { zid: zid.clone(), endpoints });
    }

    let t0 = Instant::now();
    let now = || t0.elapsed().as_secs_f64();
    let mut sm = SystemManager::new(zid, now());
    let (ev_tx, mut ev_rx) = mpsc::unbounded_channel();
    let mut driver = Driver {
        session: session.clone(),
        timeout: Duration::from_millis(cfg.query_timeout_ms),
        pending: HashMap::new(),
        next_req: 0,
        events: ev_tx,
    };
    let mut tick = tokio::time::interval(TICK);
    let mut agent = Agent::new(cfg.agent.clone());
    let mut ticks = 0u64;

    loop {
        let event = tokio::select! {
            _ = shutdown.cancelled() => break,
            _ = tick.tick() => {
                ticks += 1;
                if ticks % AGENT_EVERY == 0 {
                    let snapshot = AgentEvent::Snapshot { robots: sm.views(), missions: sm.mission_views() };
                    for c in agent.handle(now(), snapshot) {
                        match c {
                            AgentCommand::Publish(ev) => driver.publish(proto::AGENT_ADVICE_LIVE, &ev).await,
                            AgentCommand::Move(mv) => {
                                tracing::info!(robot = %mv.robot, to = ?mv.to, "agent acts");
                                let req = driver.internal_req();
                                let bytes = proto::to_json(&mv).unwrap_or_default();
                                for cmd in sm.handle(now(), Event::Operator { req, request: Request::Move(bytes) }) {
                                    driver.execute(cmd).await;
                                }
                            }
                        }
                    }
                }
                Event::Tick
            }
            q = advice.recv_async() => {
                let Ok(q) = q else { break };
                net::reply_json(&q, &agent.advice()).await;
                continue;
            }
            s = alive.recv_async() => {
                let Ok(s) = s else { break };
                match proto::parse_robot_key(s.key_expr().as_str()) {
                    Some((id, proto::RobotTopic::Alive)) => match s.kind() {
                        SampleKind::Put => Event::RobotAlive { id: id.to_string() },
                        SampleKind::Delete => Event::RobotGone { id: id.to_string() },
                    },
                    _ => {
                        tracing::warn!("ignored liveliness token {}", s.key_expr());
                        continue;
                    }
                }
            }
            s = telemetry.recv_async() => {
                let Ok(s) = s else { break };
                match proto::decode_telemetry(&s.payload().to_bytes()) {
                    Ok(t) if proto::parse_robot_key(s.key_expr().as_str()).map(|k| k.0) == Some(t.id.as_str()) => {
                        Event::Telemetry(Box::new(t))
                    }
                    Ok(t) => {
                        tracing::warn!("dropped telemetry of {:?} published on {}", t.id, s.key_expr());
                        continue;
                    }
                    Err(e) => {
                        tracing::warn!("dropped payload on {}: {e}", s.key_expr());
                        continue;
                    }
                }
            }
            q = operator.recv_async() => {
                let Ok(q) = q else { break };
                match driver.accept(q).await {
                    Some(e) => {
                        if let Event::Operator { request: Request::Goto(_) | Request::Move(_) | Request::Create(_) | Request::Terminate(_), .. } = &e {
                            agent.handle(now(), AgentEvent::OperatorCommand);
                        }
                        e
                    }
                    None => continue,
                }
            }
            s = statuses.recv_async() => {
                let Ok(s) = s else { break };
                match proto::from_json::<MissionView>("mission status", &s.payload().to_bytes()) {
                    Ok(v) => Event::MissionStatus(Box::new(v)),
                    Err(e) => {
                        tracing::warn!("dropped payload on {}: {e}", s.key_expr());
                        continue;
                    }
                }
            }
            s = hosts.recv_async() => {
                let Ok(s) = s else { break };
                match proto::parse_host_alive(s.key_expr().as_str()) {
                    Some(node) => match s.kind() {
                        SampleKind::Put => Event::HostAlive { node: node.to_string() },
                        SampleKind::Delete => Event::HostGone { node: node.to_string() },
                    },
                    None => continue,
                }
            }
            Some(e) = ev_rx.recv() => e,
        };
        for cmd in sm.handle(now(), event) {
            driver.execute(cmd).await;
        }
    }
    tracing::info!("central shutting down");
    drop((alive, telemetry, operator, statuses, hosts, advice));
    let _ = planners.await;
    let _ = missions.await;
    session.close().await.map_err(ManagerError::zenoh)?;
    Ok(())
}

/// The I/O half: pending operator queries and asynchronous requests to robots.
struct Driver {
    session: Session,
    timeout: Duration,
    pending: HashMap<u64, Query>,
    next_req: u64,
    events: mpsc::UnboundedSender<Event>,
}

impl Driver {
    /// Routes an operator query; unknown keys are answered here.
    async fn accept(&mut self, q: Query) -> Option<Event> {
        let request = match proto::parse_system_key(q.key_expr().as_str()) {
            Some(SystemKey::Status) => Request::Status,
            Some(SystemKey::Robots) => Request::Robots,
            Some(SystemKey::Robot(id)) => Request::Robot(id),
            Some(SystemKey::Missions) => Request::Missions,
            Some(SystemKey::Mission(name)) => Request::Mission(name),
            Some(SystemKey::CmdGoto) => Request::Goto(net::query_payload(&q)),
            Some(SystemKey::CmdMove) => Request::Move(net::query_payload(&q)),
            Some(SystemKey::CmdCreate) => Request::Create(net::query_payload(&q)),
            Some(SystemKey::CmdTerminate) => Request::Terminate(net::query_payload(&q)),
            None => {
                net::reply_error(&q, &format!("unknown key {}", q.key_expr())).await;
                return None;
            }
        };
        Some(self.pend(q, request))
    }

    /// A request id for the manager's own commands: nobody waits for its reply.
    fn internal_req(&mut self) -> u64 {
        self.next_req += 1;
        self.next_req - 1
    }

    async fn publish<T: serde::Serialize>(&self, key: &str, value: &T) {
        match proto::to_json(value) {
            Ok(bytes) => {
                if let Err(e) = self.session.put(key, bytes).encoding(Encoding::APPLICATION_JSON).await {
                    tracing::warn!("publication on {key} failed: {e}");
                }
            }
            Err(e) => tracing::warn!("cannot encode for {key}: {e}"),
        }
    }

    fn pend(&mut self, q: Query, request: Request) -> Event {
        let req = self.next_req;
        self.next_req += 1;
        self.pending.insert(req, q);
        Event::Operator { req, request }
    }

    async fn execute(&mut self, cmd: Command) {
        match cmd {
            Command::Reply { req, result } => {
                let Some(q) = self.pending.remove(&req) else { return };
                match result {
                    Ok(v) => net::reply_json(&q, &v).await,
                    Err(e) => net::reply_error(&q, &e).await,
                }
            }
            Command::FetchInfo { id } => {
                let (session, tx, timeout) = (self.session.clone(), self.events.clone(), self.timeout);
                tokio::spawn(async move {
                    let event = match ask::<RobotInfo>(&session, &proto::robot_info(&id), None, timeout).await {
                        Ok(info) if info.id == id => Event::RobotRegistered(info),
                        Ok(info) => Event::InfoFailed { id, reason: format!("answered as {:?}", info.id) },
                        Err(reason) => Event::InfoFailed { id, reason },
                    };
                    let _ = tx.send(event);
                });
            }
            Command::SendToRobot { req, robot, cmd } => {
                let (session, tx, timeout) = (self.session.clone(), self.events.clone(), self.timeout);
                tokio::spawn(async move {
                    let result = match proto::to_json(&cmd) {
                        Ok(body) => ask::<CommandAck>(&session, &proto::robot_cmd(&robot), Some(body), timeout).await,
                        Err(e) => Err(e.to_string()),
                    };
                    let _ = tx.send(Event::RobotCommandDone { req, robot, result });
                });
            }
            Command::StartMission { host, start } => {
                let (session, tx) = (self.session.clone(), self.events.clone());
                tokio::spawn(async move {
                    let mission = start.spec.name.clone();
                    let result = match proto::to_json(&start) {
                        Ok(body) => ask::<MissionView>(&session, &proto::host_start(&host), Some(body), START_TIMEOUT).await,
                        Err(e) => Err(e.to_string()),
                    };
                    let _ = tx.send(Event::MissionStarted { mission, result: result.map(Box::new) });
                });
            }
            Command::Ctl { mission, ctl } => {
                let (session, timeout) = (self.session.clone(), self.timeout);
                tokio::spawn(async move {
                    let result = match proto::to_json(&ctl) {
                        Ok(body) => ask::<CtlAck>(&session, &proto::mission_ctl(&mission), Some(body), timeout).await,
                        Err(e) => Err(e.to_string()),
                    };
                    if let Err(e) = result {
                        tracing::warn!(%mission, "mission control {ctl:?} failed: {e}");
                    }
                });
            }
            Command::Forward { req, key } => {
                let Some(q) = self.pending.remove(&req) else { return };
                let (session, timeout) = (self.session.clone(), self.timeout);
                tokio::spawn(async move {
                    match ask::<serde_json::Value>(&session, &key, None, timeout).await {
                        Ok(v) => net::reply_json(&q, &v).await,
                        Err(e) => net::reply_error(&q, &e).await,
                    }
                });
            }
        }
    }
}

/// One query expecting one JSON answer: returns at the first reply (not at the timeout).
pub async fn ask<T: serde::de::DeserializeOwned>(
    session: &Session,
    key: &str,
    body: Option<Vec<u8>>,
    timeout: Duration,
) -> Result<T, String> {
    let mut get = session.get(key).timeout(timeout);
    if let Some(b) = body {
        get = get.payload(b).encoding(Encoding::APPLICATION_JSON);
    }
    let replies = get.await.map_err(|e| format!("query {key}: {e}"))?;
    let reply = replies
        .recv_async()
        .await
        .map_err(|_| format!("no answer on {key} within {} ms", timeout.as_millis()))?;
    match reply.result() {
        Ok(sample) => proto::from_json(key, &sample.payload().to_bytes()).map_err(|e| e.to_string()),
        Err(err) => Err(proto::from_json::<ErrorReply>(key, &err.payload().to_bytes())
            .map(|e| e.error)
            .unwrap_or_else(|_| format!("error reply on {key}"))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn config_errors_are_one_line() {
        let c: CentralConfig = mrmm_peer::config::parse_json5("c.json5", "{ lease_ms: 5 }").expect("parse");
        assert_eq!(c.validate().expect_err("lease"), "lease_ms: must be 100..=60000 (got 5)");
        let e = mrmm_peer::config::parse_json5::<CentralConfig>("c.json5", "{ listen: 7 }").expect_err("type");
        assert!(e.to_string().starts_with("c.json5: listen: "), "{e}");
        assert!(CentralConfig::default().validate().is_ok());
    }
}
