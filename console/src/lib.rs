//! mrmm browser console: the operator's map of the fleet (robots, mission tours and coverage
//! points, advice), on which robots are selected — clicked or boxed — and assigned to missions,
//! released, or given to a new mission drawn on the map. A small HTTP server on loopback serves
//! one page and a JSON API that forwards to the system manager's operator API over Zenoh; the
//! page follows the fleet through server-sent events.
//!
//! Layers: [`model`] (the fleet as the page sees it, pure), [`feed`] (the Zenoh side: operator
//! queries, live telemetry), [`http`] (routes, the access token, the page).
// Functions outside tests are at most 80 lines (clippy.toml); tests may be longer.
#![cfg_attr(not(test), deny(clippy::too_many_lines))]

pub mod feed;
pub mod http;
pub mod layers;
pub mod model;

use std::sync::Arc;

use mrmm_net::client::Client;
use thiserror::Error;
use tokio::net::TcpListener;
use tokio_util::sync::CancellationToken;

/// Everything that can go wrong in the console.
#[derive(Debug, Error)]
pub enum ConsoleError {
    #[error("{0}")]
    Config(String),
    #[error("console listener: {0}")]
    Io(#[from] std::io::Error),
    #[error("zenoh: {0}")]
    Zenoh(#[source] mrmm_proto::BoxError),
    #[error("the console's feed stopped: {0}")]
    Feed(#[source] tokio::task::JoinError),
}

/// A fresh access token: 128 random bits, hex. The page's URL carries it (after `#`, so it is
/// never sent in a request line or logged); every API call must present it.
pub fn new_token() -> Result<String, ConsoleError> {
    use ring::rand::SecureRandom;
    let mut b = [0u8; 16];
    ring::rand::SystemRandom::new().fill(&mut b).map_err(|_| ConsoleError::Config("no randomness for the console's token".into()))?;
    Ok(b.iter().map(|x| format!("{x:02x}")).collect())
}

/// Serves the console on `listener` (a loopback address) for the operator session `client`
/// until `shutdown`.
pub async fn run(client: Client, listener: TcpListener, token: String, shutdown: CancellationToken) -> Result<(), ConsoleError> {
    let addr = listener.local_addr()?;
    if !addr.ip().is_loopback() {
        return Err(ConsoleError::Config(format!("console listen address {addr}: must be a loopback address (127.0.0.1 or ::1)")));
    }
    let client = Arc::new(client);
    let (tx, rx) = tokio::sync::watch::channel(Arc::new(model::Snapshot::default()));
    // A feed that fails (its subscription refused) stops the console rather than serve a map
    // that never fills.
    let stop = shutdown.clone();
    let fed_client = client.clone();
    let maps = layers::Layers::default();
    let fed_maps = maps.clone();
    let feed = tokio::spawn(async move {
        let r = feed::run(fed_client, tx, fed_maps, stop.clone()).await;
        stop.cancel();
        r
    });
    let app = http::router(http::AppState { client, snapshots: rx, token: Arc::from(token.as_str()), port: addr.port(), maps });
    let stop = shutdown.clone();
    let served = axum::serve(listener, app).with_graceful_shutdown(async move { stop.cancelled().await }).await;
    shutdown.cancel();
    let fed = feed.await.map_err(ConsoleError::Feed)?;
    served?;
    fed
}
