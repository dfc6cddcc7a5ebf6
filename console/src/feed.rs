//! The console's Zenoh side: polls central's robot, mission, advice and traffic tables once a second,
//! follows the robots' telemetry (announcing itself as a viewer, so that a secure fleet's robots
//! tag their telemetry for it), and publishes a snapshot to the page at most 10 times a second.

use std::sync::Arc;
use std::time::Duration;

use mrmm_core::edge::Proof;
use mrmm_core::observer::{self, Seen};
use mrmm_net::client::Client;
use mrmm_proto::traffic::TrafficView;
use mrmm_proto::{self as proto, Advice, Key, MapInfo, MapRef, MissionView, Pattern, RobotView};
use tokio::sync::watch;
use tokio_util::sync::CancellationToken;
use zenoh::handlers::RingChannel;

use crate::layers::{self, Layers};
use crate::model::{Fleet, Snapshot};
use crate::ConsoleError;

/// How often central's tables are asked for.
pub const POLL: Duration = Duration::from_secs(1);
/// How often a changed fleet is sent to the page.
pub const PUBLISH: Duration = Duration::from_millis(100);
/// Telemetry samples kept while the loop is busy (the oldest go first).
const TELEMETRY_QUEUE: usize = 1024;

/// Feeds `tx` until `shutdown`.
pub async fn run(client: Arc<Client>, tx: watch::Sender<Arc<Snapshot>>, maps: Layers, shutdown: CancellationToken) -> Result<(), ConsoleError> {
    let mesh = client.mesh().clone();
    let telemetry =
        client.session().declare_subscriber(Pattern::AllTelemetry.to_string()).with(RingChannel::new(TELEMETRY_QUEUE)).await.map_err(ConsoleError::Zenoh)?;
    let mut fleet = Fleet::default();
    let mut poll = tokio::time::interval(POLL);
    let mut publish = tokio::time::interval(PUBLISH);
    let mut hello = tokio::time::interval(Duration::from_millis(proto::VIEWER_HELLO_MS));
    let hello_key = Key::Viewer(mesh.me().id.clone()).to_string();
    // One poll at a time, off the loop: a slow central does not hold the telemetry back.
    let mut polling: tokio::task::JoinSet<Polled> = tokio::task::JoinSet::new();
    // Maps being fetched (by hash): each is drawn once.
    let asked = Arc::new(std::sync::Mutex::new(std::collections::BTreeSet::new()));
    loop {
        tokio::select! {
            _ = shutdown.cancelled() => break,
            _ = hello.tick(), if mesh.is_secure() => mesh.put(&hello_key, b"{}".to_vec(), zenoh::bytes::Encoding::APPLICATION_JSON).await,
            _ = poll.tick(), if polling.is_empty() => {
                let c = client.clone();
                polling.spawn(async move { poll_central(&c).await });
            }
            Some(done) = polling.join_next(), if !polling.is_empty() => match done {
                Ok(Ok((robots, missions, advice, known, traffic))) => {
                    fleet.polled(robots, missions, advice);
                    fleet.traffic(traffic);
                    for m in &known {
                        if asked.lock().map(|mut a| a.insert(m.hash.clone())).unwrap_or(false) {
                            tokio::spawn(fetch_layer(client.clone(), m.map_ref(), maps.clone(), asked.clone()));
                        }
                    }
                    fleet.maps(known);
                }
                Ok(Err(why)) => fleet.unreachable(why),
                Err(e) => fleet.unreachable(format!("poll failed: {e}")),
            },
            s = telemetry.recv_async() => {
                let Ok(s) = s else { break };
                if let Some(t) = telemetry_of(&mesh, &s) {
                    fleet.telemetry(&t);
                }
            }
            _ = publish.tick() => {
                if let Some(s) = fleet.take_snapshot() {
                    tx.send_replace(Arc::new(s));
                }
            }
        }
    }
    polling.abort_all();
    Ok(())
}

/// A robot's telemetry, its sender proven and entitled by the one policy (as the viewer's,
/// through the observer's ingress); refusals recorded, the rest logged.
fn telemetry_of(mesh: &mrmm_net::Mesh, s: &zenoh::sample::Sample) -> Option<Box<proto::Telemetry>> {
    match mesh.hear(s, Some(("telemetry", Proof::Own)), observer::observe)? {
        Seen::Telemetry(t) => Some(t),
        _ => None,
    }
}

type Polled = Result<(Vec<RobotView>, Vec<MissionView>, Vec<Advice>, Vec<MapInfo>, Vec<TrafficView>), String>;

/// Central's tables, asked together (its maps and traffic: none from a central that has no such
/// key).
async fn poll_central(client: &Client) -> Polled {
    let none = None::<&()>;
    let (robots, missions, advice, maps, traffic) = tokio::join!(
        client.query::<Vec<RobotView>>(Key::SystemRobots, none),
        client.query::<Vec<MissionView>>(Key::SystemMissions, none),
        client.query::<Vec<Advice>>(Key::AgentAdvice, none),
        client.query::<Vec<MapInfo>>(Key::SystemMaps, none),
        client.query::<Vec<TrafficView>>(Key::SystemTraffic, none),
    );
    Ok((
        robots.map_err(|e| e.to_string())?,
        missions.map_err(|e| e.to_string())?,
        advice.map_err(|e| e.to_string())?,
        maps.unwrap_or_default(),
        traffic.unwrap_or_default(),
    ))
}

/// Fetches map `r` from the fleet and makes its layer; on failure it is asked again at a later
/// poll.
async fn fetch_layer(client: Arc<Client>, r: MapRef, maps: Layers, asked: Arc<std::sync::Mutex<std::collections::BTreeSet<String>>>) {
    let made = match mrmm_net::map::fetch(client.mesh(), &r).await {
        Ok(bytes) => {
            mrmm_maps::Bundle::decode(&r.name, &bytes).and_then(|b| b.load()).map_err(|e| e.to_string()).and_then(|(_, m)| layers::layer(&r.name, &r.hash, &m))
        }
        Err(e) => Err(e),
    };
    match made {
        Ok(l) => {
            if let Ok(mut m) = maps.lock() {
                m.insert(r.hash.clone(), l);
            }
        }
        Err(e) => {
            tracing::warn!(map = %r.name, "cannot draw the map yet: {e}");
            if let Ok(mut a) = asked.lock() {
                a.remove(&r.hash);
            }
        }
    }
}
