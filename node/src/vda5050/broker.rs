//! An MQTT broker in the process (rumqttd) for the demo and the benchmarks, where no broker is
//! installed: plain MQTT 3.1.1 on one loopback port, no TLS, no credentials. A deployment points
//! the gateway at its own broker (mosquitto is the common one).

use std::collections::HashMap;
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::time::{Duration, Instant};

use rumqttd::{Broker, Config, ConnectionSettings, RouterConfig, ServerSettings};

use super::mqtt::MAX_PACKET;
use crate::NodeError;

/// Starts a broker on `listen` (a loopback address; port 0 picks a free one) in a thread of its
/// own, and returns once it takes connections: the address it listens on.
pub fn start(listen: SocketAddr) -> Result<SocketAddr, NodeError> {
    if !listen.ip().is_loopback() {
        return Err(NodeError::Gateway(format!("broker: {listen}: the embedded broker listens on loopback only")));
    }
    // rumqttd binds the address it is given and does not say which port it got: a free one is
    // found first (another process could take it in between; the wait below would then fail).
    let listen = if listen.port() == 0 {
        let probe = TcpListener::bind(listen).map_err(|e| NodeError::Gateway(format!("broker: {listen}: {e}")))?;
        probe.local_addr().map_err(|e| NodeError::Gateway(format!("broker: {e}")))?
    } else {
        listen
    };
    let server = ServerSettings {
        name: "mrmm".into(),
        listen,
        tls: None,
        next_connection_delay_ms: 1,
        connections: ConnectionSettings {
            connection_timeout_ms: 10_000,
            max_payload_size: MAX_PACKET,
            max_inflight_count: 100,
            auth: None,
            external_auth: None,
            dynamic_filters: true,
        },
    };
    let config = Config {
        id: 0,
        router: RouterConfig {
            max_connections: 10_000,
            max_outgoing_packet_count: 200,
            max_segment_size: 16 * 1024 * 1024,
            max_segment_count: 4,
            ..RouterConfig::default()
        },
        v4: Some(HashMap::from([("1".to_string(), server)])),
        ..Config::default()
    };
    std::thread::Builder::new()
        .name("mqtt-broker".into())
        .spawn(move || {
            let mut broker = Broker::new(config);
            if let Err(e) = broker.start() {
                tracing::error!("embedded MQTT broker stopped: {e}");
            }
        })
        .map_err(|e| NodeError::Gateway(format!("broker: cannot start its thread: {e}")))?;
    let deadline = Instant::now() + Duration::from_secs(10);
    let mut wait = Duration::from_millis(5);
    loop {
        match TcpStream::connect_timeout(&listen, Duration::from_millis(200)) {
            Ok(_) => return Ok(listen),
            Err(e) if Instant::now() > deadline => return Err(NodeError::Gateway(format!("broker: {listen}: not listening after 10 s: {e}"))),
            Err(_) => {
                std::thread::sleep(wait);
                wait = (wait * 2).min(Duration::from_millis(200));
            }
        }
    }
}
