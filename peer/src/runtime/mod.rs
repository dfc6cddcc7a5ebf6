//! The robot runtime: the thin async loop that drives a [`Robot`] over Zenoh — its inputs
//! ([`inputs`]: queries, publications, liveliness, timers) become [`Event`]s through the robot's
//! own ingress, and its [`Command`]s are carried out ([`io`]; the team's side in [`team`]).
//!
//! [`Event`]: mrmm_core::robot::Event
//! [`Command`]: mrmm_core::robot::Command

mod inputs;
mod io;
mod node;
mod ros;
mod team;
mod vda;

use std::time::Duration;

use mrmm_net::net;
use mrmm_net::security::seal::SignCadence;
use mrmm_net::{Mesh, NodeNet};
use mrmm_proto::{self as proto, Key, Role, Sender};
use mrmm_ros2::RosLink;
use tokio::sync::oneshot;
use tokio_util::sync::CancellationToken;
use zenoh::bytes::Encoding;
use zenoh::Session;

use self::inputs::Inputs;
use self::io::Io;
use self::node::Node;
use crate::config::{BodySection, RobotConfig};
use crate::error::PeerError;
use mrmm_core::robot::viewers::Viewers;
use mrmm_core::robot::Robot;

pub use self::io::TELEMETRY_SIGN_MS;
pub use self::vda::VdaLink;

/// Input waiting for the robot's loop, per kind, at most: when the loop falls behind (or is
/// flooded), the oldest is dropped — never Zenoh's receiving thread blocked.
const QUEUE: usize = 256;
/// Physics step period (wall time); a ROS 2 body's control period.
const PHYSICS_PERIOD: Duration = Duration::from_millis(20);
/// A VDA 5050 vehicle's robot's tick period: the vehicle drives itself, and the robot ticks at
/// once after every event that may change what the vehicle is to do (see `Node::next`).
const VDA_PERIOD: Duration = Duration::from_millis(100);
/// How often a ROS 2 body's robot checks that it still has fleet links.
const FLEET_CHECK_PERIOD: Duration = Duration::from_millis(100);

/// What a started robot reports once it is on the network.
#[derive(Debug, Clone)]
pub struct Ready {
    pub id: String,
    pub zid: String,
    pub endpoints: Vec<String>,
}

/// Runs a robot peer until `shutdown` is cancelled. `ready` is told once the robot is registered
/// on the network (queryables and liveliness token declared).
pub async fn run(cfg: RobotConfig, shutdown: CancellationToken, ready: Option<oneshot::Sender<Ready>>) -> Result<(), PeerError> {
    let mesh = open(&cfg, &shutdown).await?;
    run_on(mesh, cfg, shutdown, ready, Services::default()).await
}

/// The missions the robot is in or admitted to, each with whom it trusts for it (what its
/// mission host needs to know whom to take chain messages from).
pub type LocalTeam = Vec<(String, Vec<String>)>;

/// How the robot of `cfg` joins the mesh.
pub fn node_net(cfg: &RobotConfig) -> NodeNet {
    let z = &cfg.zenoh;
    NodeNet {
        mode: z.mode.zenoh_mode(),
        listen: z.listen.clone(),
        connect: z.connect.clone(),
        lease_ms: z.lease_ms,
        max_message_size: z.max_message_size,
        wire_stats: z.wire_stats,
        security: cfg.security.clone(),
        me: Some(Sender::new(Role::Robot, cfg.id.clone())),
    }
}

/// Opens the robot's session as its config says (secure with a `security` section).
///
/// A client ([`net::JoinMode::Client`]) opens a link to the first of its `connect` endpoints that
/// answers, and while none does it tries them again, in order, until one does or `shutdown`
/// (Zenoh alone would either fail at once or wait for the first endpoint only).
pub async fn open(cfg: &RobotConfig, shutdown: &CancellationToken) -> Result<Mesh, PeerError> {
    let node = node_net(cfg);
    if cfg.zenoh.mode != net::JoinMode::Client {
        return Ok(Mesh::open(&node).await?);
    }
    tracing::info!(robot = %cfg.id, connect = ?cfg.zenoh.connect, "a client: waiting for the first of its routers that answers");
    let mut wait = CLIENT_RETRY_FIRST;
    loop {
        match Mesh::open(&node).await {
            Ok(mesh) => return Ok(mesh),
            Err(e) if unreachable(&e) => tracing::warn!(robot = %cfg.id, "none of {:?} answers yet; trying again in {wait:?}", cfg.zenoh.connect),
            Err(e) => return Err(e.into()),
        }
        tokio::select! {
            _ = shutdown.cancelled() => return Err(PeerError::Stopped(format!("robot {}: stopped before any of {:?} answered", cfg.id, cfg.zenoh.connect))),
            _ = tokio::time::sleep(wait) => {}
        }
        wait = (wait * 2).min(CLIENT_RETRY_MAX);
    }
}

/// A client's first wait between two rounds of its connect endpoints, and the longest.
const CLIENT_RETRY_FIRST: std::time::Duration = std::time::Duration::from_millis(250);
const CLIENT_RETRY_MAX: std::time::Duration = std::time::Duration::from_secs(2);

/// Whether opening a session failed because no connect endpoint answered (Zenoh 1.10's words;
/// any other failure, such as a certificate Zenoh cannot read, stops start-up).
fn unreachable(e: &mrmm_proto::ProtoError) -> bool {
    matches!(e, mrmm_proto::ProtoError::Zenoh(_)) && e.to_string().contains("Unable to connect to any of")
}

/// Refuses to start a second node under a name the mesh already knows alive: two robots (or two
/// mission hosts) under one name would break the chain's majorities and the team barriers.
pub async fn refuse_taken_name(session: &Session, key: &Key, what: &str, name: &str) -> Result<(), PeerError> {
    if net::already_alive(session, &key.to_string(), net::NAME_CHECK_TIMEOUT).await? {
        return Err(PeerError::NameTaken(format!("{what} {name:?} is already alive on the mesh ({key}); give every {what} its own name")));
    }
    Ok(())
}

/// The other services of the robot's process, and a body's link that is not in its config.
#[derive(Default)]
pub struct Services {
    /// Its mission host, told the robot's team.
    pub team: Option<tokio::sync::watch::Sender<LocalTeam>>,
    /// Its traffic deputy, told the map whose authority names the robot its deputy.
    pub deputy: Option<tokio::sync::watch::Sender<Option<proto::MapRef>>>,
    /// A VDA 5050 vehicle's link to the gateway (`body: Vda5050`).
    pub vda: Option<VdaLink>,
}

/// Runs a robot on an open session (shared with the other services of the same process).
pub async fn run_on(
    mesh: Mesh,
    cfg: RobotConfig,
    shutdown: CancellationToken,
    ready: Option<oneshot::Sender<Ready>>,
    services: Services,
) -> Result<(), PeerError> {
    let Services { team, deputy, vda } = services;
    if matches!(cfg.body, BodySection::Vda5050 { .. }) != vda.is_some() {
        return Err(PeerError::Stopped(format!("robot {}: a VDA 5050 body needs its gateway's link, and only it has one", cfg.id)));
    }
    let session = mesh.session().clone();
    let id = cfg.id.clone();
    refuse_taken_name(&session, &Key::RobotAlive(id.as_str().into()), "robot", &id).await?;
    // A ROS 2 body: its own session to the robot's ROS router, opened before the robot shows up.
    let ros = match &cfg.body {
        BodySection::Ros2(b) => Some(RosLink::open(b, &id).await?),
        BodySection::Sim | BodySection::Vda5050 { .. } => None,
    };
    // Capabilities changed before a restart come back (a broken camera stays broken).
    let kept = match &cfg.state_dir {
        Some(dir) => crate::kept::load(dir, &cfg.capabilities)?,
        None => None,
    };
    let mut robot = Robot::new(cfg.setup());
    if let Some(now) = kept {
        robot.restore_capabilities(now);
    }
    let endpoints = net::listening_endpoints(&session).await;
    let period = if vda.is_some() { VDA_PERIOD } else { PHYSICS_PERIOD };
    let inputs = Inputs::declare(&mesh, &id, (period, cfg.telemetry_hz), endpoints.clone(), shutdown).await?;
    let telemetry_key = Key::RobotTelemetry(id.as_str().into()).to_string();
    let publisher = session.declare_publisher(telemetry_key.clone()).encoding(Encoding::APPLICATION_OCTET_STREAM).await.map_err(PeerError::zenoh)?;
    // Declared last: once others see the token, the queryables answer.
    let token = session.liveliness().declare_token(Key::RobotAlive(id.as_str().into()).to_string()).await.map_err(PeerError::zenoh)?;
    tracing::info!(robot = %id, zid = %session.zid(), ?endpoints, "robot up");
    if let Some(tx) = ready {
        let _ = tx.send(Ready { id: id.clone(), zid: session.zid().to_string(), endpoints });
    }
    let io = Io {
        mesh: mesh.clone(),
        id: id.clone(),
        links: mrmm_core::robot::Links::new(&id),
        team: None,
        publisher,
        telemetry_key,
        telemetry_signs: SignCadence::new(TELEMETRY_SIGN_MS),
        viewers: Viewers::new(proto::VIEWER_HELLO_MS),
        ros,
        vda,
        state_dir: cfg.state_dir.clone(),
        crashed: false,
    };
    let mut node = Node { inputs, io, query: None, clock: mrmm_net::clock::Clock::start(), team, deputy, tick_now: false };
    let driven = mrmm_core::machine::drive(&mut robot, &mut node).await;
    let Node { inputs, mut io, .. } = node;
    driven?;
    tracing::info!(robot = %id, "shutting down");
    if let Some(ros) = io.ros.take() {
        ros.close().await;
    }
    drop((io, inputs, token));
    session.close().await.map_err(PeerError::zenoh)?;
    Ok(())
}
