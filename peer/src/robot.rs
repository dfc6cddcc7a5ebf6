//! The robot peer runtime: a synchronous [`Robot`] (body, behaviour, plan) driven by a thin
//! async loop that does the Zenoh I/O.

use std::time::{Duration, Instant};

use tokio::sync::oneshot;
use tokio_util::sync::CancellationToken;
use zenoh::bytes::Encoding;
use zenoh::handlers::FifoChannelHandler;
use zenoh::liveliness::LivelinessToken;
use zenoh::pubsub::Subscriber;
use zenoh::sample::{Sample, SampleKind};
use zenoh::Session;

use crate::body::Body;
use crate::config::RobotConfig;
use crate::error::PeerError;
use crate::executor::{Action, Executor};
use crate::net::{self, Mode};
use crate::proto::{self, Behaviour, CommandAck, PlanAssignment, RobotCommand, RobotInfo, SyncArrival, Telemetry};

/// Physics step period (wall time).
const PHYSICS_PERIOD: Duration = Duration::from_millis(20);

/// A robot's state, independent of the network.
#[derive(Debug)]
pub struct Robot {
    cfg: RobotConfig,
    body: Body,
    seq: u64,
    sim_t: f64,
    exec: Option<Executor>,
}

/// What changed about the robot's plan after a command (the driver updates its subscriptions).
#[derive(Debug, Clone, PartialEq)]
pub enum PlanChange {
    None,
    /// A new plan: join this team.
    Joined { team: String, subteam: String },
    /// The plan ended by command.
    Left,
}

impl Robot {
    pub fn new(cfg: RobotConfig) -> Self {
        let body = Body::new(cfg.start_pose(), cfg.limits());
        Robot { cfg, body, seq: 0, sim_t: 0.0, exec: None }
    }

    pub fn id(&self) -> &str {
        &self.cfg.id
    }

    /// What the robot is doing now.
    pub fn behaviour(&self) -> Behaviour {
        match self.body.goal() {
            Some((x, y)) => Behaviour::Navigate { x, y },
            None => Behaviour::Hold,
        }
    }

    pub fn executor(&mut self) -> Option<&mut Executor> {
        self.exec.as_mut()
    }

    /// Applies a command. Direct orders (goto, hold) end any plan.
    pub fn command(&mut self, cmd: &RobotCommand) -> Result<(CommandAck, PlanChange), String> {
        let mut change = PlanChange::None;
        match cmd {
            RobotCommand::Goto { x, y } => {
                if !(x.is_finite() && y.is_finite()) {
                    return Err(format!("goto: coordinates must be finite (got {x}, {y})"));
                }
                if self.exec.take().is_some() {
                    change = PlanChange::Left;
                }
                self.body.navigate_to(*x, *y);
            }
            RobotCommand::Hold => {
                if self.exec.take().is_some() {
                    change = PlanChange::Left;
                }
                self.body.hold();
            }
            RobotCommand::Plan(a) => {
                self.check_plan(a)?;
                if let Some(e) = &self.exec {
                    if e.mission() == a.mission && e.epoch() > a.epoch {
                        return Err(format!("stale epoch {} for mission {} (running epoch {})", a.epoch, a.mission, e.epoch()));
                    }
                    if e.assignment == **a {
                        // The same plan again (a new head re-sending after a takeover): go on.
                        return Ok((CommandAck { ok: true, robot: self.cfg.id.clone(), behaviour: self.behaviour() }, change));
                    }
                }
                tracing::info!(robot = %self.cfg.id, mission = %a.mission, epoch = a.epoch, steps = a.plan.steps.len(), "new plan");
                self.body.hold();
                change = PlanChange::Joined { team: a.team.clone(), subteam: a.subteam.clone() };
                self.exec = Some(Executor::new((**a).clone()));
            }
            RobotCommand::Leave { mission, epoch } => {
                let ours = self.exec.as_ref().is_some_and(|e| e.mission() == mission && e.epoch() <= *epoch);
                if ours {
                    tracing::info!(robot = %self.cfg.id, %mission, "left mission");
                    self.exec = None;
                    self.body.hold();
                    change = PlanChange::Left;
                }
            }
        }
        Ok((CommandAck { ok: true, robot: self.cfg.id.clone(), behaviour: self.behaviour() }, change))
    }

    fn check_plan(&self, a: &PlanAssignment) -> Result<(), String> {
        if a.plan.robot != self.cfg.id {
            return Err(format!("plan is for robot {:?}, this is {:?}", a.plan.robot, self.cfg.id));
        }
        for id in [&a.mission, &a.team] {
            proto::validate_id(id).map_err(|e| e.to_string())?;
        }
        if !a.subteam.split('/').all(|c| proto::validate_id(c).is_ok()) {
            return Err(format!("bad sub-team path {:?}", a.subteam));
        }
        if !a.members.contains(&self.cfg.id) {
            return Err("plan's member list does not include this robot".into());
        }
        for s in &a.plan.steps {
            if let mrmm_planner::plan::Step::Navigate { x, y, .. } = s {
                if !(x.is_finite() && y.is_finite()) {
                    return Err("plan has a non-finite navigation target".into());
                }
            }
        }
        Ok(())
    }

    /// Advances the simulation by `wall_dt` wall-clock seconds (scaled by `time_scale`) and the
    /// plan; returns the barrier arrivals to publish.
    pub fn advance(&mut self, wall_dt: f64) -> Vec<SyncArrival> {
        let dt = wall_dt * self.cfg.time_scale;
        self.sim_t += dt;
        self.body.step(dt);
        let mut publish = Vec::new();
        if let Some(e) = self.exec.as_mut() {
            for a in e.tick(self.sim_t, self.body.goal().is_none()) {
                match a {
                    Action::Navigate { x, y, speed } => self.body.navigate_capped(x, y, speed),
                    Action::Hold => self.body.hold(),
                    Action::Publish(s) => publish.push(s),
                }
            }
        }
        publish
    }

    /// The next telemetry message.
    pub fn telemetry(&mut self) -> Telemetry {
        self.seq += 1;
        Telemetry {
            id: self.cfg.id.clone(),
            seq: self.seq,
            t: self.sim_t,
            pose: self.body.pose(),
            velocity: self.body.velocity(),
            behaviour: self.behaviour(),
            mission: self.exec.as_ref().map(|e| e.mission().to_string()),
            progress: self.exec.as_ref().map(Executor::progress),
        }
    }

    /// The registration record.
    pub fn info(&self, endpoints: Vec<String>) -> RobotInfo {
        RobotInfo {
            id: self.cfg.id.clone(),
            robot_type: self.cfg.robot_type.clone(),
            capabilities: self.cfg.capabilities.clone(),
            max_speed: self.cfg.kinematics.max_speed,
            endpoints,
            time_scale: self.cfg.time_scale,
        }
    }
}

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
    _token: LivelinessToken,
    arrivals: Subscriber<FifoChannelHandler<Sample>>,
    members: Subscriber<FifoChannelHandler<Sample>>,
}

impl TeamLink {
    async fn join(session: &Session, id: &str, team: &str, subteam: &str) -> Result<Self, PeerError> {
        let members = session
            .liveliness()
            .declare_subscriber(proto::team_members(team))
            .history(true)
            .await
            .map_err(PeerError::zenoh)?;
        let arrivals = session.declare_subscriber(proto::team_sync_all(team)).await.map_err(PeerError::zenoh)?;
        let token = session
            .liveliness()
            .declare_token(proto::team_member(subteam, id))
            .await
            .map_err(PeerError::zenoh)?;
        Ok(TeamLink { team: team.to_string(), _token: token, arrivals, members })
    }
}

/// Runs a robot peer until `shutdown` is cancelled. `ready` is told once the robot is registered
/// on the network (queryables and liveliness token declared).
pub async fn run(
    cfg: RobotConfig,
    shutdown: CancellationToken,
    ready: Option<oneshot::Sender<Ready>>,
) -> Result<(), PeerError> {
    let session = open(&cfg).await?;
    run_on(session, cfg, shutdown, ready).await
}

/// Opens the robot's Zenoh session as its config says.
pub async fn open(cfg: &RobotConfig) -> Result<Session, PeerError> {
    let z = &cfg.zenoh;
    net::open(net::zenoh_config(Mode::Peer, &z.listen, &z.connect, z.lease_ms)?).await
}

/// Runs a robot on an open session (shared with other services of the same process, such as
/// a mission host).
pub async fn run_on(
    session: Session,
    cfg: RobotConfig,
    shutdown: CancellationToken,
    ready: Option<oneshot::Sender<Ready>>,
) -> Result<(), PeerError> {
    let id = cfg.id.clone();
    let mut robot = Robot::new(cfg.clone());
    let endpoints = net::listening_endpoints(&session).await;

    let info_q = session.declare_queryable(proto::robot_info(&id)).await.map_err(PeerError::zenoh)?;
    let cmd_q = session.declare_queryable(proto::robot_cmd(&id)).await.map_err(PeerError::zenoh)?;
    let telemetry_pub = session
        .declare_publisher(proto::robot_telemetry(&id))
        .encoding(Encoding::APPLICATION_OCTET_STREAM)
        .await
        .map_err(PeerError::zenoh)?;
    // Declared last: once others see the token, the queryables answer.
    let token = session.liveliness().declare_token(proto::robot_alive(&id)).await.map_err(PeerError::zenoh)?;
    tracing::info!(robot = %id, zid = %session.zid(), ?endpoints, "robot up");
    if let Some(tx) = ready {
        let _ = tx.send(Ready { id: id.clone(), zid: session.zid().to_string(), endpoints: endpoints.clone() });
    }

    let mut physics = tokio::time::interval(PHYSICS_PERIOD);
    physics.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut telemetry = tokio::time::interval(Duration::from_secs_f64(1.0 / cfg.telemetry_hz));
    telemetry.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut last = Instant::now();
    let mut team: Option<TeamLink> = None;

    loop {
        tokio::select! {
            _ = shutdown.cancelled() => break,
            _ = physics.tick() => {
                let now = Instant::now();
                let arrivals = robot.advance((now - last).as_secs_f64());
                last = now;
                if let Some(t) = &team {
                    for a in arrivals {
                        publish_arrival(&session, &t.team, &a).await;
                    }
                }
            }
            _ = telemetry.tick() => publish(&telemetry_pub, &mut robot).await,
            q = info_q.recv_async() => match q {
                Ok(q) => net::reply_json(&q, &robot.info(endpoints.clone())).await,
                Err(_) => break,
            },
            q = cmd_q.recv_async() => match q {
                Ok(q) => {
                    let bytes = net::query_payload(&q);
                    let outcome = proto::from_json::<RobotCommand>("robot command", &bytes)
                        .map_err(|e| e.to_string())
                        .and_then(|cmd| robot.command(&cmd));
                    match outcome {
                        Ok((ack, change)) => {
                            match change {
                                PlanChange::None => {}
                                PlanChange::Left => team = None,
                                PlanChange::Joined { team: t, subteam } => {
                                    team = None;
                                    match TeamLink::join(&session, &id, &t, &subteam).await {
                                        Ok(link) => team = Some(link),
                                        Err(e) => tracing::warn!(robot = %id, "cannot join team {t}: {e}"),
                                    }
                                }
                            }
                            net::reply_json(&q, &ack).await;
                            // Tell the fleet at once, not at the next telemetry tick.
                            publish(&telemetry_pub, &mut robot).await;
                        }
                        Err(e) => {
                            tracing::warn!(robot = %id, "refused command: {e}");
                            net::reply_error(&q, &e).await;
                        }
                    }
                }
                Err(_) => break,
            },
            s = recv_team(&team, true) => on_arrival(&mut robot, s),
            s = recv_team(&team, false) => on_member(&mut robot, s),
        }
    }
    tracing::info!(robot = %id, "shutting down");
    drop(team);
    drop(token);
    session.close().await.map_err(PeerError::zenoh)?;
    Ok(())
}

/// The next sample of the team's arrivals (or members) subscription; pending when not in a team.
async fn recv_team(team: &Option<TeamLink>, arrivals: bool) -> Sample {
    match team {
        Some(t) => {
            let sub = if arrivals { &t.arrivals } else { &t.members };
            match sub.recv_async().await {
                Ok(s) => s,
                Err(_) => std::future::pending().await,
            }
        }
        None => std::future::pending().await,
    }
}

fn on_arrival(robot: &mut Robot, s: Sample) {
    match proto::from_json::<SyncArrival>("sync arrival", &s.payload().to_bytes()) {
        Ok(a) => {
            if let Some(e) = robot.executor() {
                e.heard(&a);
            }
        }
        Err(e) => tracing::warn!("dropped payload on {}: {e}", s.key_expr()),
    }
}

fn on_member(robot: &mut Robot, s: Sample) {
    let Some(member) = proto::parse_team_member(s.key_expr().as_str()) else {
        tracing::warn!("ignored token {}", s.key_expr());
        return;
    };
    if let Some(e) = robot.executor() {
        match s.kind() {
            SampleKind::Put => e.barrier.member_alive(member),
            SampleKind::Delete => e.barrier.member_gone(member),
        }
    }
}

async fn publish_arrival(session: &Session, team: &str, a: &SyncArrival) {
    match proto::to_json(a) {
        Ok(bytes) => {
            if let Err(e) = session.put(proto::team_sync(team, a.point, a.round), bytes).encoding(Encoding::APPLICATION_JSON).await {
                tracing::warn!("arrival publication failed: {e}");
            }
        }
        Err(e) => tracing::warn!("arrival encoding failed: {e}"),
    }
}

async fn publish(publisher: &zenoh::pubsub::Publisher<'_>, robot: &mut Robot) {
    match proto::encode_telemetry(&robot.telemetry()) {
        Ok(bytes) => {
            if let Err(e) = publisher.put(bytes).await {
                tracing::warn!("telemetry publication failed: {e}");
            }
        }
        Err(e) => tracing::warn!("telemetry encoding failed: {e}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mrmm_planner::plan::{RobotPlan, Step};

    fn cfg() -> RobotConfig {
        RobotConfig::from_json5(
            "t",
            r#"{ id: "r1", type: "ground", kinematics: { max_speed: 2, max_turn_rate: 3 }, time_scale: 4 }"#,
        )
        .expect("config")
    }

    fn plan(mission: &str, epoch: u64) -> RobotCommand {
        RobotCommand::Plan(Box::new(PlanAssignment {
            mission: mission.into(),
            epoch,
            team: mission.into(),
            subteam: format!("{mission}/ground"),
            members: vec!["r1".into()],
            plan: RobotPlan { robot: "r1".into(), robot_type: "ground".into(), slot: 0, steps: vec![Step::Navigate { x: 4.0, y: 0.0, speed: None }, Step::Hold { seconds: None }] },
        }))
    }

    #[test]
    fn goto_then_arrive_with_time_scale() {
        let mut r = Robot::new(cfg());
        let (ack, _) = r.command(&RobotCommand::Goto { x: 8.0, y: 0.0 }).expect("ack");
        assert_eq!(ack.behaviour, Behaviour::Navigate { x: 8.0, y: 0.0 });
        // 8 m at 2 m/s = 4 simulated s = 1 wall s at time scale 4.
        for _ in 0..110 {
            r.advance(0.01);
        }
        let t = r.telemetry();
        assert_eq!(t.behaviour, Behaviour::Hold);
        assert!((t.pose.x - 8.0).abs() <= crate::body::ARRIVAL_TOLERANCE);
        assert!((t.t - 4.4).abs() < 1e-9);
        assert_eq!(t.seq, 1);
    }

    #[test]
    fn rejects_non_finite_goal() {
        let mut r = Robot::new(cfg());
        assert!(r.command(&RobotCommand::Goto { x: f64::NAN, y: 0.0 }).is_err());
        assert_eq!(r.behaviour(), Behaviour::Hold);
    }

    #[test]
    fn plans_epochs_and_leaving() {
        let mut r = Robot::new(cfg());
        let (_, change) = r.command(&plan("m", 2)).expect("plan");
        assert_eq!(change, PlanChange::Joined { team: "m".into(), subteam: "m/ground".into() });
        r.advance(0.01);
        assert_eq!(r.telemetry().mission.as_deref(), Some("m"));
        assert!(r.command(&plan("m", 1)).unwrap_err().contains("stale epoch"));
        // A leave for an older epoch or another mission is ignored.
        assert_eq!(r.command(&RobotCommand::Leave { mission: "m".into(), epoch: 1 }).expect("ok").1, PlanChange::None);
        assert_eq!(r.command(&RobotCommand::Leave { mission: "x".into(), epoch: 9 }).expect("ok").1, PlanChange::None);
        // Another mission's plan replaces this one (a move).
        assert!(matches!(r.command(&plan("n", 1)).expect("move").1, PlanChange::Joined { .. }));
        assert_eq!(r.command(&RobotCommand::Leave { mission: "n".into(), epoch: 1 }).expect("ok").1, PlanChange::Left);
        assert_eq!(r.telemetry().mission, None);
        // A plan for somebody else is refused.
        let RobotCommand::Plan(mut a) = plan("m", 3) else { unreachable!() };
        a.plan.robot = "r2".into();
        assert!(r.command(&RobotCommand::Plan(a)).is_err());
    }
}
