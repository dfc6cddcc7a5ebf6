//! The VDA 5050 gateway (`mrmm vda5050`): every vehicle it hears on the MQTT broker becomes a
//! fleet robot of its own (identity, session, liveliness, mission host), run in this process
//! with a [`VdaDrive`](mrmm_core::body::vda::VdaDrive) body — the robot's goals go out as the
//! vehicle's orders, the vehicle's `state` comes back as the robot's pose, speed and battery. A
//! vehicle's `connection` OFFLINE or CONNECTIONBROKEN (its last will) drops its robot as a crash
//! would: the fleet sees it lost and its missions replan.

pub mod broker;
pub mod config;
mod mqtt;
pub mod sim;

use std::collections::BTreeMap;
use std::time::Duration;

use mrmm_peer::config::{BodySection, RobotConfig};
use mrmm_peer::runtime::VdaLink;
use mrmm_vda5050::{Connection, ConnectionState, Factsheet, FromVehicle, State, Subtopic, Topics, VehicleId, Visualization};
use tokio::sync::{mpsc, oneshot};
use tokio::task::JoinSet;
use tokio_util::sync::CancellationToken;

pub use self::config::GatewayConfig;
use crate::NodeError;

/// States waiting for a vehicle's robot, at most (a newer one supersedes them: the rest is
/// dropped while its loop is behind).
const STATES: usize = 8;
/// Messages waiting to go to one vehicle, at most.
const OUTBOX: usize = 64;

/// A vehicle the gateway heard.
struct Vehicle {
    robot: String,
    /// When its last state or visualization came.
    heard: tokio::time::Instant,
    /// Its robot's inbox of states (none until its robot starts, and once it is dropped).
    states: Option<mpsc::Sender<Box<FromVehicle>>>,
    /// Drops its robot as a crash would.
    kill: Option<oneshot::Sender<()>>,
}

/// Input the gateway could not take, counted (logged at powers of two).
#[derive(Default)]
struct Refused {
    count: u64,
}

impl Refused {
    fn note(&mut self, why: &str) {
        self.count += 1;
        if self.count.is_power_of_two() {
            tracing::warn!(count = self.count, "VDA 5050: dropped: {why}");
        }
    }
}

/// The gateway's state.
struct Gateway {
    cfg: GatewayConfig,
    topics: Topics,
    template: RobotConfig,
    client: rumqttc::AsyncClient,
    vehicles: BTreeMap<VehicleId, Vehicle>,
    /// What the vehicles' factsheets say: top speed, type, work (their robots' kinematics,
    /// robot type and capabilities).
    sheets: BTreeMap<VehicleId, Sheet>,
    robots: JoinSet<(VehicleId, Result<(), NodeError>)>,
    shutdown: CancellationToken,
    refused: Refused,
    /// Makes order ids unique across the gateway's starts.
    started_ms: u64,
}

/// Runs the gateway of `cfg` (validated; `template` the robots' config) until `shutdown`.
pub async fn run(cfg: GatewayConfig, template: RobotConfig, shutdown: CancellationToken) -> Result<(), NodeError> {
    let topics = cfg.topics().map_err(NodeError::Gateway)?;
    let broker = cfg.broker().map_err(NodeError::Gateway)?;
    let (client, mut events) = mqtt::connect(&cfg, &broker).map_err(NodeError::Gateway)?;
    let started_ms = mqtt::unix_ms();
    let mut gw = Gateway {
        cfg,
        topics,
        template,
        client,
        vehicles: BTreeMap::new(),
        sheets: BTreeMap::new(),
        robots: JoinSet::new(),
        shutdown: shutdown.clone(),
        refused: Refused::default(),
        started_ms,
    };
    let mut announced = false;
    let mut backoff = Duration::from_millis(250);
    let mut check = tokio::time::interval(Duration::from_secs(1));
    check.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
    loop {
        tokio::select! {
            _ = shutdown.cancelled() => break,
            ev = events.poll() => match ev {
                Ok(rumqttc::Event::Incoming(rumqttc::Packet::ConnAck(_))) => {
                    backoff = Duration::from_millis(250);
                    tracing::info!(broker = %gw.cfg.broker, "VDA 5050: connected to the broker");
                    mqtt::subscribe(&gw.client, &gw.topics).await;
                }
                Ok(rumqttc::Event::Incoming(rumqttc::Packet::SubAck(_))) if !announced => {
                    announced = true;
                    println!("vda5050 ready broker={} interface={}/{}", broker.url(), gw.topics.interface, gw.topics.major);
                }
                Ok(rumqttc::Event::Incoming(rumqttc::Packet::Publish(p))) => gw.heard(&p.topic, &p.payload),
                Ok(_) => {}
                Err(e) => {
                    tracing::warn!(broker = %gw.cfg.broker, "VDA 5050: broker connection: {e}; trying again in {backoff:?}");
                    // Out of reach, the vehicles cannot be driven: their robots drop off the fleet
                    // (and come back with the vehicles' next states once the broker is back).
                    gw.all_gone("the broker connection broke");
                    tokio::select! {
                        _ = shutdown.cancelled() => break,
                        _ = tokio::time::sleep(backoff) => {}
                    }
                    backoff = (backoff * 2).min(Duration::from_secs(5));
                }
            },
            Some(done) = gw.robots.join_next() => gw.robot_stopped(done),
            _ = check.tick() => gw.silent(),
        }
    }
    let _ = gw.client.disconnect().await;
    while gw.robots.join_next().await.is_some() {}
    Ok(())
}

impl Gateway {
    /// A message on one of the vehicles' topics.
    fn heard(&mut self, topic: &str, payload: &[u8]) {
        let (vehicle, sub) = match self.topics.parse(topic) {
            Ok(t) => t,
            Err(e) => return self.refused.note(&e.to_string()),
        };
        match sub {
            Subtopic::State => match mrmm_vda5050::parse::<State>(sub, payload).and_then(|s| s.check().map(|()| s)) {
                Ok(state) => self.state(vehicle, state),
                Err(e) => self.refused.note(&format!("{vehicle}: {e}")),
            },
            Subtopic::Connection => match mrmm_vda5050::parse::<Connection>(sub, payload) {
                Ok(c) if c.connection_state != ConnectionState::Online => self.gone(&vehicle, c.connection_state),
                Ok(_) => tracing::info!(%vehicle, "VDA 5050: vehicle online"),
                Err(e) => self.refused.note(&format!("{vehicle}: {e}")),
            },
            Subtopic::Factsheet => match mrmm_vda5050::parse::<Factsheet>(sub, payload) {
                Ok(f) if self.sheets.len() < self.cfg.max_vehicles || self.sheets.contains_key(&vehicle) => {
                    self.sheets.insert(vehicle, Sheet::of(&f, &self.cfg.types));
                }
                Ok(_) => {}
                Err(e) => self.refused.note(&format!("{vehicle}: {e}")),
            },
            Subtopic::Visualization => match mrmm_vda5050::parse::<Visualization>(sub, payload).and_then(|v| v.check().map(|()| v)) {
                Ok(vis) => {
                    if let Some(v) = self.vehicles.get_mut(&vehicle) {
                        v.heard = tokio::time::Instant::now();
                        if let Some(tx) = &v.states {
                            let _ = tx.try_send(Box::new(FromVehicle::Visualization(vis)));
                        }
                    }
                }
                Err(e) => self.refused.note(&format!("{vehicle}: {e}")),
            },
            Subtopic::Order | Subtopic::InstantActions => self.refused.note(&format!("{topic}: a master control's topic, not a vehicle's")),
        }
    }

    /// Every vehicle's robot drops off the fleet.
    fn all_gone(&mut self, why: &str) {
        let live: Vec<VehicleId> = self.vehicles.iter().filter(|(_, v)| v.states.is_some()).map(|(k, _)| k.clone()).collect();
        if !live.is_empty() {
            tracing::warn!(vehicles = live.len(), "VDA 5050: {why}: every vehicle's robot drops off the fleet");
        }
        for vehicle in live {
            self.gone(&vehicle, ConnectionState::ConnectionBroken);
        }
    }

    /// Vehicles silent longer than the config's `silence_s` are gone (a vehicle states at least
    /// every 30 s as the standard asks; one that stopped without its last will is not heard).
    fn silent(&mut self) {
        let limit = Duration::from_secs_f64(self.cfg.silence_s);
        let now = tokio::time::Instant::now();
        let quiet: Vec<VehicleId> = self.vehicles.iter().filter(|(_, v)| v.states.is_some() && now - v.heard > limit).map(|(k, _)| k.clone()).collect();
        for vehicle in quiet {
            tracing::warn!(%vehicle, "VDA 5050: nothing heard for {} s", self.cfg.silence_s);
            self.gone(&vehicle, ConnectionState::ConnectionBroken);
        }
    }

    /// A vehicle's state: to its robot, which starts (where the vehicle stands) at its first.
    fn state(&mut self, vehicle: VehicleId, state: State) {
        if let Some(v) = self.vehicles.get_mut(&vehicle) {
            v.heard = tokio::time::Instant::now();
            if let Some(tx) = &v.states {
                // Full: its robot is behind; the next state says it all again.
                let _ = tx.try_send(Box::new(FromVehicle::State(Box::new(state))));
            }
            return;
        }
        if self.vehicles.len() >= self.cfg.max_vehicles {
            return self.refused.note(&format!("{vehicle}: the gateway runs its {} vehicles already (max_vehicles)", self.cfg.max_vehicles));
        }
        let Some(p) = state.agv_position.clone().filter(|p| p.position_initialized) else {
            return self.refused.note(&format!("{vehicle}: no initialised agvPosition yet: its robot starts once it knows where it is"));
        };
        let robot = self.cfg.robot_id(&vehicle);
        let mut cfg = self.template.clone();
        cfg.id.clone_from(&robot);
        cfg.start = mrmm_peer::config::StartPose { x: p.x, y: p.y, theta: p.theta };
        cfg.time_scale = 1.0;
        if let Some(sheet) = self.sheets.get(&vehicle) {
            sheet.apply(&mut cfg);
        }
        cfg.battery = None;
        cfg.body = BodySection::Vda5050 { order_prefix: format!("mrmm-{}", self.started_ms), map_id: self.cfg.map.clone() };
        cfg.security = cfg.security.map(|sec| sec.for_name(&robot));
        if let Some(dir) = &self.template.state_dir {
            cfg.state_dir = Some(dir.join(&robot));
        }
        if let Err(e) = cfg.validate() {
            return self.refused.note(&format!("{vehicle}: its robot {robot}: {e}"));
        }
        let (states_tx, states_rx) = mpsc::channel(STATES);
        let (out_tx, out_rx) = mpsc::channel(OUTBOX);
        let (kill_tx, kill_rx) = oneshot::channel();
        let _ = states_tx.try_send(Box::new(FromVehicle::State(Box::new(state))));
        tokio::spawn(mqtt::forward(
            self.client.clone(),
            self.topics.of(&vehicle, Subtopic::Order),
            self.topics.of(&vehicle, Subtopic::InstantActions),
            vehicle.clone(),
            out_rx,
        ));
        let link = VdaLink { states: states_rx, out: out_tx };
        let stop = self.shutdown.child_token();
        let who = vehicle.clone();
        tracing::info!(%vehicle, %robot, "VDA 5050: a new vehicle: starting its robot");
        self.robots.spawn(async move { (who, one(cfg, link, stop, kill_rx).await) });
        self.vehicles.insert(vehicle, Vehicle { robot, heard: tokio::time::Instant::now(), states: Some(states_tx), kill: Some(kill_tx) });
    }

    /// The vehicle left the broker (or its link broke): its robot is dropped as a crash would.
    fn gone(&mut self, vehicle: &VehicleId, how: ConnectionState) {
        let Some(v) = self.vehicles.get_mut(vehicle) else { return };
        tracing::warn!(%vehicle, robot = %v.robot, ?how, "VDA 5050: vehicle gone: its robot drops off the fleet");
        v.states = None;
        if let Some(kill) = v.kill.take() {
            let _ = kill.send(());
        }
    }

    fn robot_stopped(&mut self, done: Result<(VehicleId, Result<(), NodeError>), tokio::task::JoinError>) {
        match done {
            Ok((vehicle, result)) => {
                if let Some(v) = self.vehicles.remove(&vehicle) {
                    match result {
                        Ok(()) => tracing::info!(%vehicle, robot = %v.robot, "VDA 5050: robot stopped"),
                        Err(e) => tracing::warn!(%vehicle, robot = %v.robot, "VDA 5050: robot stopped: {e}"),
                    }
                    println!("vehicle gone robot={}", v.robot);
                }
            }
            Err(e) => tracing::error!("VDA 5050: a robot's task failed: {e}"),
        }
    }
}

/// What a vehicle's factsheet says that its robot takes: its top speed, its type (by the
/// gateway config's `types`), and its work (`pick`, `drop`, …) as capabilities beside the robot
/// config's.
#[derive(Debug, Clone, Default, PartialEq)]
struct Sheet {
    speed: Option<f64>,
    robot_type: Option<String>,
    work: Vec<String>,
}

impl Sheet {
    /// What factsheet `f` says, with `types` the robot types by `agvClass`.
    fn of(f: &Factsheet, types: &BTreeMap<String, String>) -> Sheet {
        let speed = f.physical_parameters.as_ref().and_then(|p| p.speed_max).filter(|s| s.is_finite() && *s > 0.0);
        let robot_type = f.type_specification.as_ref().and_then(|t| types.get(&t.agv_class)).cloned();
        // Those a capability can be named, as many as a robot may have.
        let work = f.work().into_iter().filter(|w| mrmm_proto::validate_capability(w).is_ok()).take(mrmm_proto::MAX_CAPABILITIES).map(str::to_string).collect();
        Sheet { speed: speed.map(|s| s.clamp(mrmm_proto::MIN_SPEED, mrmm_proto::MAX_SPEED)), robot_type, work }
    }

    /// Into the vehicle's robot config: its top speed, its type, and its work added to its
    /// capabilities (up to as many as a robot may have).
    fn apply(&self, cfg: &mut RobotConfig) {
        if let Some(s) = self.speed {
            cfg.kinematics.max_speed = s;
        }
        if let Some(t) = &self.robot_type {
            cfg.robot_type.clone_from(t);
        }
        for w in &self.work {
            if cfg.capabilities.len() < mrmm_proto::MAX_CAPABILITIES && !cfg.capabilities.contains(w) {
                cfg.capabilities.push(w.clone());
            }
        }
    }
}

/// One vehicle's robot, from start until it stops, is killed or the gateway stops.
async fn one(cfg: RobotConfig, link: VdaLink, stop: CancellationToken, kill: oneshot::Receiver<()>) -> Result<(), NodeError> {
    let mut started = crate::robot::start_with(cfg, stop, Some(link)).await?;
    started.announce();
    tokio::select! {
        r = started.finished() => r,
        Ok(()) = kill => {
            started.kill().await;
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A factsheet's top speed and work go into its vehicle's robot: capabilities beside the
    /// config's, each once, never more than a robot may have, none a capability cannot be named.
    #[test]
    fn a_factsheet_gives_the_robot_its_speed_type_and_work_as_capabilities() {
        let f: Factsheet = serde_json::from_str(
            r#"{"typeSpecification": {"agvClass": "FORKLIFT"}, "physicalParameters": {"speedMax": 1.5}, "protocolFeatures": {"agvActions": [{"actionType": "pick"}, {"actionType": "camera"}, {"actionType": "startPause"}, {"actionType": "no way"}]}}"#,
        )
        .unwrap();
        let template: RobotConfig =
            json5::from_str(r#"{ id: "agv", type: "ground", capabilities: ["camera"], kinematics: { max_speed: 1.0, max_turn_rate: 2.0 } }"#).unwrap();
        let mut cfg = template.clone();
        let types: BTreeMap<String, String> = [("FORKLIFT".to_string(), "forklift".to_string())].into();
        Sheet::of(&f, &types).apply(&mut cfg);
        assert_eq!(cfg.capabilities, ["camera", "pick"]);
        assert_eq!((cfg.kinematics.max_speed, cfg.robot_type.as_str()), (1.5, "forklift"));
        let mut cfg = template.clone();
        Sheet::of(&f, &BTreeMap::new()).apply(&mut cfg);
        assert_eq!(cfg.robot_type, "ground", "a class the config does not name: the config's type");
        let many = Sheet { speed: None, robot_type: None, work: (0..40).map(|i| format!("a{i}")).collect() };
        many.apply(&mut cfg);
        assert_eq!(cfg.capabilities.len(), mrmm_proto::MAX_CAPABILITIES);
    }
}
