//! Simulated VDA 5050 vehicles on an MQTT broker (`mrmm vda5050-sim`, and the demo's
//! `--vda5050 N`): each is a [`SimVehicle`] with an MQTT client of its own, as a real vehicle
//! would have — it says `connection` ONLINE (retained, QoS 1) with CONNECTIONBROKEN as its last
//! will, its factsheet and its state, takes `order` and `instantActions`, and ticks every 50 ms.
//! A message it cannot read is logged and dropped.

use std::time::Duration;

use mrmm_vda5050::sim::{SimIn, SimOut, SimVehicle};
use mrmm_vda5050::{ConnectionState, InstantActions, Order, Subtopic, Topics, VehicleId};
use rumqttc::{AsyncClient, Event, LastWill, MqttOptions, Packet, QoS};
use tokio::sync::mpsc;
use tokio::task::JoinSet;
use tokio_util::sync::CancellationToken;

use super::config::Broker;
use super::mqtt::{unix_ms, MAX_PACKET};
use crate::NodeError;

/// How often a vehicle moves and reports.
pub const TICK: Duration = Duration::from_millis(50);
/// Requests waiting for a vehicle's client, at most (a state a tick at most).
const REQUESTS: usize = 64;

/// One simulated vehicle: who, where it starts, how fast it drives.
#[derive(Debug, Clone, PartialEq)]
pub struct SimSpec {
    pub vehicle: VehicleId,
    pub start: (f64, f64, f64),
    pub speed_max: f64,
}

/// The vehicles of one `mrmm vda5050-sim`.
#[derive(Debug, Clone)]
pub struct SimFleet {
    pub broker: Broker,
    pub topics: Topics,
    pub map_id: String,
    pub vehicles: Vec<SimSpec>,
}

/// Runs every vehicle until `shutdown` (each says OFFLINE as it leaves); prints
/// `vda5050-sim ready` once all of them are connected.
pub async fn run(fleet: SimFleet, shutdown: CancellationToken) -> Result<(), NodeError> {
    let (ready_tx, mut ready_rx) = mpsc::channel(fleet.vehicles.len().max(1));
    let mut tasks = JoinSet::new();
    for spec in fleet.vehicles.clone() {
        let vehicle = SimVehicle::new(spec.vehicle.clone(), &fleet.map_id, spec.start, spec.speed_max);
        tasks.spawn(one(vehicle, fleet.broker.clone(), fleet.topics.clone(), ready_tx.clone(), shutdown.clone()));
    }
    drop(ready_tx);
    let mut ready = 0;
    let mut announced = false;
    loop {
        tokio::select! {
            Some(()) = ready_rx.recv(), if !announced => {
                ready += 1;
                if ready == fleet.vehicles.len() {
                    announced = true;
                    println!("vda5050-sim ready broker=mqtt://{}:{} vehicles={ready}", fleet.broker.host, fleet.broker.port);
                }
            }
            done = tasks.join_next() => match done {
                Some(Err(e)) => tracing::error!("VDA 5050 sim: a vehicle's task failed: {e}"),
                Some(Ok(())) => {}
                None => return Ok(()),
            },
        }
    }
}

/// What a vehicle's client hears.
enum Heard {
    Connected,
    Message(String, Vec<u8>),
}

/// One vehicle, from its first connection until `shutdown`.
async fn one(mut v: SimVehicle, broker: Broker, topics: Topics, ready: mpsc::Sender<()>, shutdown: CancellationToken) {
    let id = v.id().clone();
    let topic = |sub| topics.of(&id, sub);
    let start = unix_ms();
    let will = serde_json::to_vec(&v.connection_message(ConnectionState::ConnectionBroken)).unwrap_or_default();
    let mut opts = MqttOptions::new(format!("mrmm-sim-{}-{}", id.manufacturer, id.serial_number), broker.host.clone(), broker.port);
    opts.set_keep_alive(Duration::from_secs(5));
    opts.set_clean_session(true);
    opts.set_max_packet_size(MAX_PACKET, MAX_PACKET);
    opts.set_last_will(LastWill::new(topic(Subtopic::Connection), will, QoS::AtLeastOnce, true));
    let (client, mut events) = AsyncClient::new(opts, REQUESTS);
    let (heard_tx, mut heard) = mpsc::channel(REQUESTS);
    let stop = shutdown.clone();
    let poller = tokio::spawn(async move {
        let mut backoff = Duration::from_millis(100);
        loop {
            let heard = tokio::select! {
                _ = stop.cancelled() => return,
                ev = events.poll() => ev,
            };
            let msg = match heard {
                Ok(Event::Incoming(Packet::ConnAck(_))) => {
                    backoff = Duration::from_millis(100);
                    Heard::Connected
                }
                Ok(Event::Incoming(Packet::Publish(p))) => Heard::Message(p.topic, p.payload.to_vec()),
                Ok(_) => continue,
                Err(e) => {
                    tracing::debug!("VDA 5050 sim: broker connection: {e}; trying again in {backoff:?}");
                    tokio::select! {
                        _ = stop.cancelled() => return,
                        _ = tokio::time::sleep(backoff) => {}
                    }
                    backoff = (backoff * 2).min(Duration::from_secs(2));
                    continue;
                }
            };
            // Full: the vehicle's loop is behind; an order lost is sent again by the gateway.
            let _ = heard_tx.try_send(msg);
        }
    });
    let mut tick = tokio::time::interval(TICK);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
    let mut connected = false;
    loop {
        let out = tokio::select! {
            _ = shutdown.cancelled() => break,
            _ = tick.tick(), if connected => v.handle(unix_ms().max(start), SimIn::Tick),
            h = heard.recv() => match h {
                None => break,
                Some(Heard::Connected) => {
                    for sub in [Subtopic::Order, Subtopic::InstantActions] {
                        let _ = client.try_subscribe(topic(sub), QoS::AtMostOnce);
                    }
                    if !connected {
                        let _ = ready.try_send(());
                    }
                    connected = true;
                    v.connect(unix_ms())
                }
                Some(Heard::Message(t, payload)) => match read(&topics, &t, &payload) {
                    Ok(input) => v.handle(unix_ms(), input),
                    Err(e) => {
                        tracing::warn!(vehicle = %id, "VDA 5050 sim: dropped: {e}");
                        continue;
                    }
                },
            },
        };
        for o in out {
            publish(&client, &topics, &id, o);
        }
    }
    let offline = v.connection_message(ConnectionState::Offline);
    publish(&client, &topics, &id, SimOut::Connection(offline));
    let _ = client.try_disconnect();
    // The disconnect and the OFFLINE go out on the event loop's last polls.
    let _ = tokio::time::timeout(Duration::from_millis(500), poller).await;
}

/// An order or instant actions from the master control, bounded and checked.
fn read(topics: &Topics, topic: &str, payload: &[u8]) -> Result<SimIn, String> {
    let (_, sub) = topics.parse(topic).map_err(|e| e.to_string())?;
    match sub {
        Subtopic::Order => mrmm_vda5050::parse::<Order>(sub, payload).map(|o| SimIn::Order(Box::new(o))).map_err(|e| e.to_string()),
        Subtopic::InstantActions => mrmm_vda5050::parse::<InstantActions>(sub, payload).map(SimIn::Instant).map_err(|e| e.to_string()),
        other => Err(format!("{topic}: a vehicle does not read {}", other.as_str())),
    }
}

/// Publishes what the vehicle says; a message the client cannot queue now is dropped (the next
/// state says it all again).
fn publish(client: &AsyncClient, topics: &Topics, id: &VehicleId, out: SimOut) {
    let (sub, bytes) = match &out {
        SimOut::State(s) => (Subtopic::State, serde_json::to_vec(s)),
        SimOut::Visualization(m) => (Subtopic::Visualization, serde_json::to_vec(m)),
        SimOut::Connection(c) => (Subtopic::Connection, serde_json::to_vec(c)),
        SimOut::Factsheet(f) => (Subtopic::Factsheet, serde_json::to_vec(f)),
    };
    let Ok(bytes) = bytes else { return };
    // The standard: connection retained at QoS 1, factsheet retained; the rest QoS 0.
    let (qos, retain) = match sub {
        Subtopic::Connection => (QoS::AtLeastOnce, true),
        Subtopic::Factsheet => (QoS::AtMostOnce, true),
        _ => (QoS::AtMostOnce, false),
    };
    if let Err(e) = client.try_publish(topics.of(id, sub), qos, retain, bytes) {
        tracing::debug!(vehicle = %id, "VDA 5050 sim: not sent: {e}");
    }
}
