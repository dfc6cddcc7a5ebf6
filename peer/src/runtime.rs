//! The robot runtime: the thin async loop that drives a [`Robot`] over Zenoh — it turns queries,
//! publications, liveliness changes and timers into [`Event`]s and carries out the [`Command`]s.

use std::time::{Duration, Instant};

use crate::viewers::{Heard, Viewers, MAX_VIEWERS};
use mrmm_net::net::{self, Mode};
use mrmm_net::security::seal::SignCadence;
use mrmm_net::{Mesh, NodeNet};
use mrmm_proto::{self as proto, BarrierMode, Key, Pattern, Role, Sender};
use tokio::sync::oneshot;
use tokio_util::sync::CancellationToken;
use zenoh::bytes::Encoding;
use zenoh::handlers::{RingChannel, RingChannelHandler};
use zenoh::liveliness::LivelinessToken;
use zenoh::pubsub::Subscriber;
use zenoh::query::Query;
use zenoh::sample::{Sample, SampleKind};
use zenoh::Session;

use crate::config::{BodySection, RobotConfig};
use crate::error::PeerError;
use crate::robot::{Command, Event, Incoming, Refused, Robot};
use mrmm_proto::Velocity;
use mrmm_ros2::msgs::Twist;
use mrmm_ros2::nav2::GoalEvent;
use mrmm_ros2::{Input as RosInput, RosLink};

use crate::nav_goals::NavCommand;

/// Input waiting for the robot's loop, per kind, at most: when the loop falls behind (or is
/// flooded), the oldest is dropped — never Zenoh's receiving thread blocked.
const QUEUE: usize = 256;
/// Physics step period (wall time); a ROS 2 body's control period.
const PHYSICS_PERIOD: Duration = Duration::from_millis(20);
/// How often a ROS 2 body's robot checks that it still has fleet links.
const FLEET_CHECK_PERIOD: Duration = Duration::from_millis(100);

/// What a started robot reports once it is on the network.
#[derive(Debug, Clone)]
pub struct Ready {
    pub id: String,
    pub zid: String,
    pub endpoints: Vec<String>,
}

/// The Zenoh side of team membership: member token, barrier and membership subscriptions.
struct TeamLink {
    team: String,
    mode: BarrierMode,
    /// The other members of the plan: whom this robot's barrier messages are for.
    to: Vec<Sender>,
    _token: LivelinessToken,
    /// Teammates' arrivals: every member's under [`BarrierMode::Mesh`], the leader's only under
    /// [`BarrierMode::Leader`].
    arrivals: Option<Subscriber<RingChannelHandler<Sample>>>,
    /// The leader's releases ([`BarrierMode::Leader`]).
    releases: Option<Subscriber<RingChannelHandler<Sample>>>,
    /// Membership tokens of the widest team the plan has barriers with.
    members: Subscriber<RingChannelHandler<Sample>>,
    /// The wider teams' barriers: each one's path and whom its arrivals are for.
    wide: Vec<(String, Vec<Sender>)>,
    /// Arrivals at the wider teams' barriers, tagged with the team's path (one subscription per
    /// wider team, kept alive here; a full queue drops, as a ring channel would).
    wide_arrivals: Option<tokio::sync::Mutex<tokio::sync::mpsc::Receiver<(String, Sample)>>>,
    _wide_subs: Vec<Subscriber<()>>,
}

/// Subscribes to teammates' samples on `pattern` (not our own: the robot counts its own
/// arrivals before publishing them, which also saves a signature check each).
async fn team_subscriber(session: &Session, pattern: Pattern) -> Result<Subscriber<RingChannelHandler<Sample>>, PeerError> {
    session
        .declare_subscriber(pattern.to_string())
        .allowed_origin(zenoh::sample::Locality::Remote)
        .with(RingChannel::new(QUEUE))
        .await
        .map_err(PeerError::zenoh)
}

impl TeamLink {
    async fn join(
        session: &Session,
        id: &str,
        team: &str,
        subteam: &str,
        mode: BarrierMode,
        plan_members: &[String],
        scopes: &[mrmm_proto::ScopeMembers],
    ) -> Result<Self, PeerError> {
        let member = Key::team_member(subteam, id)?;
        // Wider teams contain the robot's own: the shortest path is the widest.
        let widest = scopes.iter().map(|s| s.team.as_str()).chain([team]).min_by_key(|t| t.len()).unwrap_or(team);
        let members = session
            .liveliness()
            .declare_subscriber(Pattern::TeamMembers(widest.to_string()).to_string())
            .history(true)
            .with(RingChannel::new(QUEUE))
            .await
            .map_err(PeerError::zenoh)?;
        let (arrivals, releases) = match mode {
            BarrierMode::Mesh => (Some(team_subscriber(session, Pattern::TeamSync(team.to_string())).await?), None),
            // Arrivals once the plan says this robot leads (Command::Lead).
            BarrierMode::Leader => (None, Some(team_subscriber(session, Pattern::TeamRelease(team.to_string())).await?)),
        };
        let token = session.liveliness().declare_token(member.to_string()).await.map_err(PeerError::zenoh)?;
        let others = |ms: &[String]| ms.iter().filter(|m| m.as_str() != id).map(|m| Sender::new(Role::Robot, m.clone())).collect::<Vec<_>>();
        let to = others(plan_members);
        let (mut wide, mut subs, mut wide_arrivals) = (Vec::new(), Vec::new(), None);
        if !scopes.is_empty() {
            let (tx, rx) = tokio::sync::mpsc::channel(QUEUE);
            for sc in scopes {
                let (tx, path) = (tx.clone(), sc.team.clone());
                let sub = session
                    .declare_subscriber(Pattern::TeamSync(sc.team.clone()).to_string())
                    .allowed_origin(zenoh::sample::Locality::Remote)
                    .callback(move |s| {
                        let _ = tx.try_send((path.clone(), s));
                    })
                    .await
                    .map_err(PeerError::zenoh)?;
                subs.push(sub);
                wide.push((sc.team.clone(), others(&sc.members)));
            }
            wide_arrivals = Some(tokio::sync::Mutex::new(rx));
        }
        Ok(TeamLink { team: team.to_string(), mode, to, _token: token, arrivals, releases, members, wide, wide_arrivals, _wide_subs: subs })
    }

    /// Starts (`true`) or stops hearing the team's arrivals as its leader.
    async fn lead(&mut self, session: &Session, on: bool) -> Result<(), PeerError> {
        if self.mode != BarrierMode::Leader {
            return Ok(());
        }
        self.arrivals = if on { Some(team_subscriber(session, Pattern::TeamArrive(self.team.clone())).await?) } else { None };
        Ok(())
    }

    /// Where this robot's arrival at (point, round) goes.
    fn arrival_key(&self, point: u32, round: u32) -> Key {
        match self.mode {
            BarrierMode::Mesh => Key::TeamSync { team: self.team.clone(), point, round },
            BarrierMode::Leader => Key::TeamArrive { team: self.team.clone(), point, round },
        }
    }
}

/// Runs a robot peer until `shutdown` is cancelled. `ready` is told once the robot is registered
/// on the network (queryables and liveliness token declared).
pub async fn run(cfg: RobotConfig, shutdown: CancellationToken, ready: Option<oneshot::Sender<Ready>>) -> Result<(), PeerError> {
    let mesh = open(&cfg).await?;
    run_on(mesh, cfg, shutdown, ready, None).await
}

/// The missions the robot is in or admitted to, each with whom it trusts for it (what its
/// mission host needs to know whom to take chain messages from).
pub type LocalTeam = Vec<(String, Vec<String>)>;

/// How the robot of `cfg` joins the mesh.
pub fn node_net(cfg: &RobotConfig) -> NodeNet {
    let z = &cfg.zenoh;
    NodeNet {
        mode: Mode::Peer,
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
pub async fn open(cfg: &RobotConfig) -> Result<Mesh, PeerError> {
    Ok(Mesh::open(&node_net(cfg)).await?)
}

/// Refuses to start a second node under a name the mesh already knows alive: two robots (or two
/// mission hosts) under one name would break the chain's majorities and the team barriers.
pub async fn refuse_taken_name(session: &Session, key: &Key, what: &str, name: &str) -> Result<(), PeerError> {
    if net::already_alive(session, &key.to_string(), net::NAME_CHECK_TIMEOUT).await? {
        return Err(PeerError::NameTaken(format!("{what} {name:?} is already alive on the mesh ({key}); give every {what} its own name")));
    }
    Ok(())
}

/// Runs a robot on an open session (shared with other services of the same process, such as
/// a mission host, told the robot's team on `team`).
pub async fn run_on(
    mesh: Mesh,
    cfg: RobotConfig,
    shutdown: CancellationToken,
    ready: Option<oneshot::Sender<Ready>>,
    team: Option<tokio::sync::watch::Sender<LocalTeam>>,
) -> Result<(), PeerError> {
    let session = mesh.session().clone();
    let id = cfg.id.clone();
    refuse_taken_name(&session, &Key::RobotAlive(id.clone()), "robot", &id).await?;
    let telemetry_hz = cfg.telemetry_hz;
    // A ROS 2 body: its own session to the robot's ROS router, opened before the robot shows up.
    let ros = match &cfg.body {
        BodySection::Ros2(b) => Some(RosLink::open(b, &id).await?),
        BodySection::Sim => None,
    };
    // Capabilities changed before a restart come back (a broken camera stays broken).
    let kept = match &cfg.state_dir {
        Some(dir) => crate::kept::load(dir, &cfg.capabilities)?,
        None => None,
    };
    let state_dir = cfg.state_dir.clone();
    let mut robot = Robot::new(cfg.setup());
    if let Some(now) = kept {
        robot.restore_capabilities(now);
    }
    let endpoints = net::listening_endpoints(&session).await;

    let info_q = session.declare_queryable(Key::RobotInfo(id.clone()).to_string()).with(RingChannel::new(QUEUE)).await.map_err(PeerError::zenoh)?;
    let cmd_q = session.declare_queryable(Key::RobotCmd(id.clone()).to_string()).with(RingChannel::new(QUEUE)).await.map_err(PeerError::zenoh)?;
    let telemetry_pub =
        session.declare_publisher(Key::RobotTelemetry(id.clone()).to_string()).encoding(Encoding::APPLICATION_OCTET_STREAM).await.map_err(PeerError::zenoh)?;
    // Declared last: once others see the token, the queryables answer.
    let token = session.liveliness().declare_token(Key::RobotAlive(id.clone()).to_string()).await.map_err(PeerError::zenoh)?;
    tracing::info!(robot = %id, zid = %session.zid(), ?endpoints, "robot up");
    if let Some(tx) = ready {
        let _ = tx.send(Ready { id: id.clone(), zid: session.zid().to_string(), endpoints: endpoints.clone() });
    }

    // Viewers announcing themselves: the robot's telemetry is tagged for them too.
    let viewers = session.declare_subscriber(Pattern::AllViewers.to_string()).with(RingChannel::new(QUEUE)).await.map_err(PeerError::zenoh)?;
    // Central's liveliness: while it is gone, nobody admits this robot to missions.
    let central = session
        .liveliness()
        .declare_subscriber(Key::HostAlive(proto::CENTRAL_HOST.to_string()).to_string())
        .history(true)
        .with(RingChannel::new(QUEUE))
        .await
        .map_err(PeerError::zenoh)?;
    let mut physics = tokio::time::interval(PHYSICS_PERIOD);
    physics.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut telemetry = tokio::time::interval(Duration::from_secs_f64(1.0 / telemetry_hz));
    telemetry.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let t0 = Instant::now();
    let telemetry_key = Key::RobotTelemetry(id.clone()).to_string();
    let mut io = Io {
        mesh: mesh.clone(),
        id: id.clone(),
        team: None,
        publisher: telemetry_pub,
        telemetry_key,
        telemetry_signs: SignCadence::new(TELEMETRY_SIGN_MS),
        viewers: Viewers::new(proto::VIEWER_HELLO_MS),
        ros,
        state_dir,
    };
    // Whether the robot's session has a link to any other fleet node (a ROS 2 body stops
    // without one); checked a few times a second.
    let mut fleet_check = tokio::time::interval(FLEET_CHECK_PERIOD);
    fleet_check.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut fleet_up = true;
    let mut malformed = 0u64;
    let mut mismatched = 0u64;

    loop {
        let (event, query): (Event, Option<Query>) = tokio::select! {
            _ = shutdown.cancelled() => break,
            _ = physics.tick() => (Event::Tick, None),
            _ = telemetry.tick() => (Event::TelemetryDue, None),
            _ = fleet_check.tick(), if io.ros.is_some() => {
                let info = session.info();
                let up = info.routers_zid().await.next().is_some() || info.peers_zid().await.next().is_some();
                if up == fleet_up {
                    continue;
                }
                fleet_up = up;
                tracing::warn!(robot = %id, up, "fleet link changed");
                (Event::FleetLink(up), None)
            }
            input = recv_ros(&io.ros) => match input {
                RosInput::Odometry { pose, v, omega } => (Event::Odometry { pose: ros_pose(pose), velocity: Velocity { v, omega } }, None),
                RosInput::Pose(pose) => (Event::LocalisedPose(ros_pose(pose)), None),
                RosInput::Nav2Server(up) => {
                    if !up {
                        tracing::warn!(robot = %id, "ROS 2 graph: Nav2's action server left");
                    }
                    (Event::Nav2Server(up), None)
                }
                RosInput::Goal { id: goal, event } => {
                    if matches!(event, GoalEvent::Feedback { .. }) {
                        tracing::debug!(robot = %id, ?event, "Nav2 feedback");
                    } else {
                        tracing::info!(robot = %id, ?event, "Nav2 goal");
                    }
                    (Event::Nav2Goal { id: goal, event }, None)
                }
                RosInput::Mismatch(why) => {
                    mismatched += 1;
                    if mismatched.is_power_of_two() {
                        tracing::warn!(robot = %id, count = mismatched, "ROS 2 graph: {why}");
                    }
                    continue;
                }
                RosInput::Malformed { topic, error } => {
                    malformed += 1;
                    if malformed.is_power_of_two() {
                        tracing::warn!(robot = %id, %topic, count = malformed, "dropped a malformed ROS 2 message: {error}");
                    }
                    continue;
                }
            },
            q = info_q.recv_async() => {
                let Ok(q) = q else { break };
                mesh.reply_json(&q, &robot.info(endpoints.clone())).await;
                continue;
            }
            q = cmd_q.recv_async() => {
                let Ok(q) = q else { break };
                let from = match mesh.try_sender_of_query(&q) {
                    Ok(from) => from,
                    Err(r) => {
                        mesh.refuse_unproven("robot command", &q, &r).await;
                        continue;
                    }
                };
                match robot.ingress(Incoming { key: q.key_expr().as_str(), payload: &net::query_payload(&q), put: true, from: Some(&from) }) {
                    Ok(ev) => (ev, Some(q)),
                    Err(e) => {
                        tracing::warn!(robot = %id, "refused command: {e}");
                        mesh.reply_error(&q, &e.to_string()).await;
                        continue;
                    }
                }
            }
            s = recv_team(&io.team, Sub::Arrivals) => match heard(&mesh, &robot, "barrier arrival", &s) {
                Some(ev) => (ev, None),
                None => continue,
            },
            s = viewers.recv_async() => {
                let Ok(s) = s else { break };
                let Some(from) = mesh.sender_of("viewer announcement", &s) else { continue };
                let now = mrmm_net::mesh::now_ms();
                let new = !io.viewers.is_current(now, &from);
                match io.viewers.heard(now, from.clone()) {
                    // A new viewer has not proven this robot's certificate yet: the next message
                    // carries it (the tagged ones between signatures only name it).
                    Heard::Kept if new => io.telemetry_signs.sign_next(),
                    Heard::Kept => {}
                    Heard::NotAViewer => mesh.refuse("announce a viewer", &from),
                    Heard::Full => tracing::debug!(robot = %id, viewer = %from, "viewer not tagged for: {MAX_VIEWERS} others are current"),
                }
                continue;
            }
            s = central.recv_async() => match s {
                Ok(s) => match liveliness(&robot, &s) {
                    Some(ev) => (ev, None),
                    None => continue,
                },
                Err(_) => break,
            },
            s = recv_team(&io.team, Sub::Releases) => match heard(&mesh, &robot, "barrier release", &s) {
                Some(ev) => (ev, None),
                None => continue,
            },
            (_, s) = recv_wide(&io.team) => match heard(&mesh, &robot, "barrier arrival", &s) {
                Some(ev) => (ev, None),
                None => continue,
            },
            s = recv_team(&io.team, Sub::Members) => match liveliness(&robot, &s) {
                Some(ev) => (ev, None),
                None => continue,
            },
        };
        for c in robot.handle(t0.elapsed().as_secs_f64(), event) {
            io.execute(c, query.as_ref()).await;
        }
        if let Some(tx) = &team {
            let now: LocalTeam = robot.team();
            tx.send_if_modified(|t| {
                let changed = *t != now;
                if changed {
                    *t = now;
                }
                changed
            });
        }
    }
    tracing::info!(robot = %id, "shutting down");
    if let Some(ros) = io.ros.take() {
        ros.close().await;
    }
    drop(io);
    drop(token);
    session.close().await.map_err(PeerError::zenoh)?;
    Ok(())
}

/// A robot's telemetry is signed (as well as tagged for the receivers it knows) once in this
/// many milliseconds: receivers it does not know yet check one message in that time (one in ten
/// at the demo's 5 Hz), and a robot streaming faster pays no more signatures for it.
pub const TELEMETRY_SIGN_MS: u64 = 2000;

/// The I/O half: the session, the team subscriptions and the telemetry publisher.
struct Io {
    mesh: Mesh,
    id: String,
    team: Option<TeamLink>,
    publisher: zenoh::pubsub::Publisher<'static>,
    telemetry_key: String,
    /// Telemetry messages published (which of them are signed).
    telemetry_signs: SignCadence,
    /// Viewers its telemetry is tagged for.
    viewers: Viewers,
    /// A ROS 2 body's link.
    ros: Option<RosLink>,
    /// Where the robot keeps what must survive a restart.
    state_dir: Option<std::path::PathBuf>,
}

impl Io {
    async fn execute(&mut self, c: Command, query: Option<&Query>) {
        match c {
            Command::Reply(result) => match (query, result) {
                (Some(q), Ok(ack)) => self.mesh.reply_json(q, &ack).await,
                (Some(q), Err(e)) => {
                    tracing::warn!(robot = %self.id, "refused command: {e}");
                    self.mesh.reply_error(q, &e).await;
                }
                (None, _) => {}
            },
            Command::Refuse(e) => {
                self.mesh.verifier().refused.record(
                    "robot command",
                    &mrmm_net::security::Refusal::NotEntitled {
                        proven: query.and_then(|q| self.mesh.try_sender_of_query(q).ok()).unwrap_or_else(|| Sender::new(Role::Operator, "unknown")),
                        what: e.clone(),
                    },
                );
                if let Some(q) = query {
                    self.mesh.reply_err(q, &proto::ErrorReply::coded(proto::ErrorCode::Refused, e)).await;
                }
            }
            Command::JoinTeam { team, subteam, barrier, members, scopes } => {
                self.team = None;
                match TeamLink::join(self.mesh.session(), &self.id, &team, &subteam, barrier, &members, &scopes).await {
                    Ok(link) => self.team = Some(link),
                    Err(e) => tracing::warn!(robot = %self.id, "cannot join team {team}: {e}"),
                }
            }
            Command::LeaveTeam => self.team = None,
            Command::Publish(a) => {
                let Some(t) = &self.team else { return };
                let key = t.arrival_key(a.point, a.round).to_string();
                self.mesh.publish_json_for(&key, &a, &t.to).await;
            }
            Command::PublishIn(team, a) => {
                let Some(t) = &self.team else { return };
                let Some((_, to)) = t.wide.iter().find(|(p, _)| *p == team) else { return };
                let key = Key::TeamSync { team, point: a.point, round: a.round }.to_string();
                self.mesh.publish_json_for(&key, &a, to).await;
            }
            Command::Release(r) => {
                let Some(t) = &self.team else { return };
                let key = Key::TeamRelease { team: t.team.clone(), point: r.point, round: r.round }.to_string();
                self.mesh.publish_json_for(&key, &r, &t.to).await;
            }
            Command::Lead(on) => {
                if let Some(t) = self.team.as_mut() {
                    if let Err(e) = t.lead(self.mesh.session(), on).await {
                        tracing::warn!(robot = %self.id, "cannot hear the team's arrivals as its leader: {e}");
                    } else {
                        tracing::info!(robot = %self.id, team = %t.team, on, "leads the team's barriers");
                    }
                }
            }
            Command::Telemetry(t) => match proto::encode_telemetry(&t) {
                Ok(bytes) => {
                    // Tagged for central, mission hosts and teammates (managers of its mission
                    // on robots) it knows and current viewers; one message per TELEMETRY_SIGN_MS
                    // signed as well, for
                    // everyone else (a host that takes its mission over before it knows that host).
                    let team = self.team.as_ref().map(|t| t.to.as_slice()).unwrap_or_default();
                    let now = mrmm_net::mesh::now_ms();
                    let sign = self.telemetry_signs.due(now);
                    let viewers = &self.viewers;
                    let seal = self.mesh.seal_for_known(
                        &self.telemetry_key,
                        &bytes,
                        |s| matches!(s.role, Role::Central | Role::Host) || team.contains(s) || viewers.is_current(now, s),
                        sign,
                    );
                    if let Err(e) = self.publisher.put(bytes).attachment(seal).await {
                        tracing::warn!("telemetry publication failed: {e}");
                    }
                }
                Err(e) => tracing::warn!("telemetry encoding failed: {e}"),
            },
            Command::Nav(NavCommand::Send { id, x, y, yaw }) => {
                if let Some(ros) = &self.ros {
                    tracing::info!(robot = %self.id, x, y, "Nav2 goal sent");
                    ros.send_goal(id, x, y, yaw);
                }
            }
            Command::Nav(NavCommand::Cancel(id)) => {
                if let Some(ros) = &self.ros {
                    ros.cancel_goal(id);
                }
            }
            Command::KeepCapabilities { configured, now } => {
                if let Some(dir) = &self.state_dir {
                    if let Err(e) = crate::kept::save(dir, &configured, &now) {
                        tracing::warn!(robot = %self.id, "capabilities not kept across a restart: {e}");
                    }
                }
            }
            Command::Drive(v) => {
                if let Some(ros) = self.ros.as_mut() {
                    if let Err(e) = ros.send_twist(Twist::planar(v.v, v.omega)).await {
                        tracing::warn!(robot = %self.id, "cmd_vel publication failed: {e}");
                    }
                }
            }
        }
    }
}

/// The next input of a ROS 2 body; pending without one.
async fn recv_ros(ros: &Option<RosLink>) -> RosInput {
    match ros {
        Some(r) => r.recv().await,
        None => std::future::pending().await,
    }
}

fn ros_pose(p: mrmm_ros2::Pose2) -> proto::Pose {
    proto::Pose { x: p.x, y: p.y, theta: p.theta }
}

/// A subscription of the team link.
#[derive(Clone, Copy)]
enum Sub {
    Arrivals,
    Releases,
    Members,
}

/// The next sample of one of the team's subscriptions; pending when not in a team or without it.
async fn recv_team(team: &Option<TeamLink>, which: Sub) -> Sample {
    let sub = team.as_ref().and_then(|t| match which {
        Sub::Arrivals => t.arrivals.as_ref(),
        Sub::Releases => t.releases.as_ref(),
        Sub::Members => Some(&t.members),
    });
    match sub {
        Some(sub) => match sub.recv_async().await {
            Ok(s) => s,
            Err(_) => std::future::pending().await,
        },
        None => std::future::pending().await,
    }
}

/// A sealed team message (an arrival or a release) as the robot's event: its seal proven here,
/// the rest translated by the robot's own ingress (a forged one is refused and recorded, a
/// malformed one dropped).
fn heard(mesh: &Mesh, robot: &Robot, what: &str, s: &Sample) -> Option<Event> {
    let from = mesh.sender_of(what, s)?;
    let payload = s.payload().to_bytes();
    match robot.ingress(Incoming { key: s.key_expr().as_str(), payload: &payload, put: s.kind() == SampleKind::Put, from: Some(&from) }) {
        Ok(ev) => Some(ev),
        Err(Refused::NotEntitled { from, what }) => {
            mesh.refuse(&what, &from);
            None
        }
        Err(e) => {
            tracing::warn!("dropped payload on {}: {e}", s.key_expr());
            None
        }
    }
}

/// A liveliness token (a teammate's, central's) as the robot's event.
fn liveliness(robot: &Robot, s: &Sample) -> Option<Event> {
    match robot.ingress(Incoming { key: s.key_expr().as_str(), payload: &[], put: s.kind() == SampleKind::Put, from: None }) {
        Ok(ev) => Some(ev),
        Err(e) => {
            tracing::warn!("ignored token {}: {e}", s.key_expr());
            None
        }
    }
}

/// The next arrival at a wider team's barrier, with the team's path; pending without any.
async fn recv_wide(team: &Option<TeamLink>) -> (String, Sample) {
    match team.as_ref().and_then(|t| t.wide_arrivals.as_ref()) {
        Some(rx) => match rx.lock().await.recv().await {
            Some(x) => x,
            None => std::future::pending().await,
        },
        None => std::future::pending().await,
    }
}
