//! The console's Zenoh side: polls central's robot, mission and advice tables once a second,
//! follows the robots' telemetry (announcing itself as a viewer, so that a secure fleet's robots
//! tag their telemetry for it), and publishes a snapshot to the page at most 10 times a second.

use std::sync::Arc;
use std::time::Duration;

use mrmm_proto::client::Client;
use mrmm_proto::{self as proto, Advice, Key, MissionView, Pattern, RobotView, Role};
use tokio::sync::watch;
use tokio_util::sync::CancellationToken;
use zenoh::handlers::RingChannel;

use crate::model::{Fleet, Snapshot};
use crate::ConsoleError;

/// How often central's tables are asked for.
pub const POLL: Duration = Duration::from_secs(1);
/// How often a changed fleet is sent to the page.
pub const PUBLISH: Duration = Duration::from_millis(100);
/// Telemetry samples kept while the loop is busy (the oldest go first).
const TELEMETRY_QUEUE: usize = 1024;

/// Feeds `tx` until `shutdown`.
pub async fn run(client: Arc<Client>, tx: watch::Sender<Arc<Snapshot>>, shutdown: CancellationToken) -> Result<(), ConsoleError> {
    let mesh = client.mesh().clone();
    let telemetry = client
        .session()
        .declare_subscriber(Pattern::AllTelemetry.to_string())
        .with(RingChannel::new(TELEMETRY_QUEUE))
        .await
        .map_err(|e| ConsoleError::Zenoh(e.to_string()))?;
    let mut fleet = Fleet::default();
    let mut poll = tokio::time::interval(POLL);
    let mut publish = tokio::time::interval(PUBLISH);
    let mut hello = tokio::time::interval(Duration::from_millis(proto::VIEWER_HELLO_MS));
    let hello_key = Key::Viewer(mesh.me().id.clone()).to_string();
    // One poll at a time, off the loop: a slow central does not hold the telemetry back.
    let mut polling: tokio::task::JoinSet<Polled> = tokio::task::JoinSet::new();
    loop {
        tokio::select! {
            _ = shutdown.cancelled() => break,
            _ = hello.tick(), if mesh.is_secure() => mesh.put(&hello_key, b"{}".to_vec(), zenoh::bytes::Encoding::APPLICATION_JSON).await,
            _ = poll.tick(), if polling.is_empty() => {
                let c = client.clone();
                polling.spawn(async move { poll_central(&c).await });
            }
            Some(done) = polling.join_next(), if !polling.is_empty() => match done {
                Ok(Ok((robots, missions, advice))) => fleet.polled(robots, missions, advice),
                Ok(Err(why)) => fleet.unreachable(why),
                Err(e) => fleet.unreachable(format!("poll failed: {e}")),
            },
            s = telemetry.recv_async() => {
                let Ok(s) = s else { break };
                let Some(from) = mesh.sender_of("telemetry", &s) else { continue };
                match proto::decode_telemetry(&s.payload().to_bytes()) {
                    Ok(t) if from.is(Role::Robot, &t.id) => fleet.telemetry(&t),
                    Ok(t) => mesh.refuse(&format!("publish the telemetry of {}", t.id), &from),
                    Err(e) => tracing::debug!("dropped payload on {}: {e}", s.key_expr()),
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

type Polled = Result<(Vec<RobotView>, Vec<MissionView>, Vec<Advice>), String>;

/// Central's three tables, asked together.
async fn poll_central(client: &Client) -> Polled {
    let none = None::<&()>;
    let (robots, missions, advice) = tokio::join!(
        client.query::<Vec<RobotView>>(Key::SystemRobots, none),
        client.query::<Vec<MissionView>>(Key::SystemMissions, none),
        client.query::<Vec<Advice>>(Key::AgentAdvice, none),
    );
    Ok((robots.map_err(|e| e.to_string())?, missions.map_err(|e| e.to_string())?, advice.map_err(|e| e.to_string())?))
}
