//! The robot peer runtime: a synchronous [`Robot`] (body, behaviour, telemetry) driven by a thin
//! async loop that does the Zenoh I/O.

use std::time::{Duration, Instant};

use tokio::sync::oneshot;
use tokio_util::sync::CancellationToken;
use zenoh::bytes::Encoding;

use crate::body::Body;
use crate::config::RobotConfig;
use crate::error::PeerError;
use crate::net::{self, Mode};
use crate::proto::{self, Behaviour, CommandAck, RobotCommand, RobotInfo, Telemetry};

/// Physics step period (wall time).
const PHYSICS_PERIOD: Duration = Duration::from_millis(20);

/// A robot's state, independent of the network.
#[derive(Debug)]
pub struct Robot {
    cfg: RobotConfig,
    body: Body,
    seq: u64,
    sim_t: f64,
    mission: Option<String>,
}

impl Robot {
    pub fn new(cfg: RobotConfig) -> Self {
        let body = Body::new(cfg.start_pose(), cfg.limits());
        Robot { cfg, body, seq: 0, sim_t: 0.0, mission: None }
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

    /// Applies a command; coordinates must be finite.
    pub fn command(&mut self, cmd: &RobotCommand) -> Result<CommandAck, String> {
        match *cmd {
            RobotCommand::Goto { x, y } => {
                if !(x.is_finite() && y.is_finite()) {
                    return Err(format!("goto: coordinates must be finite (got {x}, {y})"));
                }
                self.body.navigate_to(x, y);
            }
            RobotCommand::Hold => self.body.hold(),
        }
        Ok(CommandAck { ok: true, robot: self.cfg.id.clone(), behaviour: self.behaviour() })
    }

    /// Advances the simulation by `wall_dt` wall-clock seconds (scaled by `time_scale`).
    pub fn advance(&mut self, wall_dt: f64) {
        let dt = wall_dt * self.cfg.time_scale;
        self.sim_t += dt;
        if self.body.step(dt) {
            tracing::info!(robot = %self.cfg.id, "arrived at goal");
        }
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
            mission: self.mission.clone(),
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

/// Runs a robot peer until `shutdown` is cancelled. `ready` is told once the robot is registered
/// on the network (queryables and liveliness token declared).
pub async fn run(
    cfg: RobotConfig,
    shutdown: CancellationToken,
    ready: Option<oneshot::Sender<Ready>>,
) -> Result<(), PeerError> {
    let z = &cfg.zenoh;
    let session = net::open(net::zenoh_config(Mode::Peer, &z.listen, &z.connect, z.lease_ms)?).await?;
    let id = cfg.id.clone();
    let mut robot = Robot::new(cfg.clone());
    let endpoints = net::listening_endpoints(&session).await;

    let info_q = session
        .declare_queryable(proto::robot_info(&id))
        .await
        .map_err(PeerError::zenoh)?;
    let cmd_q = session
        .declare_queryable(proto::robot_cmd(&id))
        .await
        .map_err(PeerError::zenoh)?;
    let telemetry_pub = session
        .declare_publisher(proto::robot_telemetry(&id))
        .encoding(Encoding::APPLICATION_OCTET_STREAM)
        .await
        .map_err(PeerError::zenoh)?;
    // Declared last: once others see the token, the queryables answer.
    let token = session
        .liveliness()
        .declare_token(proto::robot_alive(&id))
        .await
        .map_err(PeerError::zenoh)?;
    tracing::info!(robot = %id, zid = %session.zid(), ?endpoints, "robot up");
    if let Some(tx) = ready {
        let _ = tx.send(Ready { id: id.clone(), zid: session.zid().to_string(), endpoints: endpoints.clone() });
    }

    let mut physics = tokio::time::interval(PHYSICS_PERIOD);
    physics.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut telemetry = tokio::time::interval(Duration::from_secs_f64(1.0 / cfg.telemetry_hz));
    telemetry.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut last = Instant::now();

    loop {
        tokio::select! {
            _ = shutdown.cancelled() => break,
            _ = physics.tick() => {
                let now = Instant::now();
                robot.advance((now - last).as_secs_f64());
                last = now;
            }
            _ = telemetry.tick() => publish(&telemetry_pub, &mut robot).await,
            q = info_q.recv_async() => match q {
                Ok(q) => net::reply_json(&q, &robot.info(endpoints.clone())).await,
                Err(_) => break,
            },
            q = cmd_q.recv_async() => match q {
                Ok(q) => {
                    let bytes = net::query_payload(&q);
                    match proto::from_json::<RobotCommand>("robot command", &bytes) {
                        Ok(cmd) => match robot.command(&cmd) {
                            Ok(ack) => {
                                tracing::info!(robot = %id, ?cmd, "command");
                                net::reply_json(&q, &ack).await;
                                // Tell the fleet at once, not at the next telemetry tick.
                                publish(&telemetry_pub, &mut robot).await;
                            }
                            Err(e) => net::reply_error(&q, &e).await,
                        },
                        Err(e) => {
                            tracing::warn!(robot = %id, "dropped bad command: {e}");
                            net::reply_error(&q, &e.to_string()).await;
                        }
                    }
                }
                Err(_) => break,
            },
        }
    }
    tracing::info!(robot = %id, "shutting down");
    drop(token);
    session.close().await.map_err(PeerError::zenoh)?;
    Ok(())
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

    fn cfg() -> RobotConfig {
        RobotConfig::from_json5(
            "t",
            r#"{ id: "r1", type: "ground", kinematics: { max_speed: 2, max_turn_rate: 3 }, time_scale: 4 }"#,
        )
        .expect("config")
    }

    #[test]
    fn goto_then_arrive_with_time_scale() {
        let mut r = Robot::new(cfg());
        let ack = r.command(&RobotCommand::Goto { x: 8.0, y: 0.0 }).expect("ack");
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
}
