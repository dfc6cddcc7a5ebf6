//! The gateway's MQTT side: its client (bounded packets, TLS to an `mqtts://` broker, the
//! vehicles' topics subscribed at every connection) and, per vehicle, the task that stamps and publishes what its robot sends.

use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

use rumqttc::{AsyncClient, EventLoop, MqttOptions, QoS, TlsConfiguration, Transport};
use rustls::pki_types::pem::PemObject;
use rustls::pki_types::{CertificateDer, PrivateKeyDer};

use mrmm_core::body::vda::VdaOut;
use mrmm_vda5050::msg::Header;
use mrmm_vda5050::{InstantActions, Subtopic, Topics, VehicleId, MAX_MESSAGE};

use super::config::{Broker, BrokerTls, GatewayConfig};

/// Requests waiting for the client's event loop, at most.
const REQUESTS: usize = 256;
/// Largest MQTT packet taken, bytes (the gateway's client, the simulated vehicles' and the
/// embedded broker): above the largest message parsed ([`MAX_MESSAGE`]), so that one too large
/// is dropped and said; a packet larger still breaks the connection (the client reconnects) —
/// cap the broker's `max_packet_size`.
pub(super) const MAX_PACKET: usize = 4 * MAX_MESSAGE;

/// The client and its event loop (connects at its first poll, reconnects at the next after an
/// error); TLS to an `mqtts://` broker. The error (a TLS file that cannot be read) names the
/// config's field, the file and what is wrong with it.
pub(super) fn connect(cfg: &GatewayConfig, broker: &Broker) -> Result<(AsyncClient, EventLoop), String> {
    let mut opts = MqttOptions::new(format!("mrmm-vda5050-{}", std::process::id()), broker.host.clone(), broker.port);
    opts.set_keep_alive(Duration::from_secs(5));
    opts.set_max_packet_size(MAX_PACKET, MAX_PACKET);
    opts.set_clean_session(true);
    if let Some(user) = &cfg.username {
        opts.set_credentials(user.clone(), cfg.password.clone().unwrap_or_default());
    }
    if let (true, Some(tls)) = (broker.tls, &cfg.tls) {
        let client = tls_client(tls)?;
        opts.set_transport(Transport::tls_with_config(TlsConfiguration::Rustls(Arc::new(client))));
    }
    Ok(AsyncClient::new(opts, REQUESTS))
}

/// The TLS side of the client: the broker's certificate must chain to the config's CAs (and name
/// the broker's host); the gateway shows its own certificate where the config names one.
fn tls_client(tls: &BrokerTls) -> Result<rustls::ClientConfig, String> {
    let mut roots = rustls::RootCertStore::empty();
    for cert in certificates(&tls.ca, "ca")? {
        roots.add(cert).map_err(|e| format!("tls.ca: {}: {e}", tls.ca.display()))?;
    }
    let provider = Arc::new(rustls::crypto::ring::default_provider());
    let config = rustls::ClientConfig::builder_with_provider(provider)
        .with_safe_default_protocol_versions()
        .map_err(|e| format!("tls: {e}"))?
        .with_root_certificates(roots);
    match (&tls.cert, &tls.key) {
        (Some(cert), Some(key)) => {
            let chain = certificates(cert, "cert")?;
            let key = PrivateKeyDer::from_pem_file(key).map_err(|e| format!("tls.key: {}: {e}", key.display()))?;
            config.with_client_auth_cert(chain, key).map_err(|e| format!("tls.cert: {}: {e}", cert.display()))
        }
        _ => Ok(config.with_no_client_auth()),
    }
}

/// The PEM certificates of file `path` (config field `field`): at least one.
fn certificates(path: &Path, field: &str) -> Result<Vec<CertificateDer<'static>>, String> {
    let said = |e: &dyn std::fmt::Display| format!("tls.{field}: {}: {e}", path.display());
    let list = CertificateDer::pem_file_iter(path).map_err(|e| said(&e))?.collect::<Result<Vec<_>, _>>().map_err(|e| said(&e))?;
    if list.is_empty() {
        return Err(said(&"no PEM certificate in it"));
    }
    Ok(list)
}

/// Subscribes to what every vehicle publishes (a clean session forgets subscriptions: done at
/// every connection).
pub(super) async fn subscribe(client: &AsyncClient, topics: &Topics) {
    for sub in Subtopic::FROM_VEHICLES {
        // The standard's QoS: 1 for connection, 0 for the rest.
        let qos = if sub == Subtopic::Connection { QoS::AtLeastOnce } else { QoS::AtMostOnce };
        if let Err(e) = client.subscribe(topics.every(sub), qos).await {
            tracing::warn!("VDA 5050: cannot subscribe to {}: {e}", topics.every(sub));
        }
    }
}

/// Milliseconds since 1970.
pub(super) fn unix_ms() -> u64 {
    std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_millis() as u64)
}

/// Publishes what one vehicle's robot sends, each message with its header (`headerId` +1 per
/// topic), until the robot lets go of its link.
pub(super) async fn forward(client: AsyncClient, order_topic: String, instant_topic: String, vehicle: VehicleId, mut out: tokio::sync::mpsc::Receiver<VdaOut>) {
    let (mut orders, mut instants) = (0u64, 0u64);
    while let Some(msg) = out.recv().await {
        let (topic, payload) = match msg {
            VdaOut::Order(mut o) => {
                o.header = Header::new(orders, unix_ms(), &vehicle);
                orders += 1;
                tracing::info!(%vehicle, order = %o.order_id, update = o.order_update_id, nodes = o.nodes.len(), "VDA 5050: order");
                (&order_topic, serde_json::to_vec(&o))
            }
            VdaOut::Instant(actions) => {
                let msg = InstantActions { header: Header::new(instants, unix_ms(), &vehicle), actions };
                instants += 1;
                tracing::info!(%vehicle, actions = ?msg.actions.iter().map(|a| a.action_type.as_str()).collect::<Vec<_>>(), "VDA 5050: instant actions");
                (&instant_topic, serde_json::to_vec(&msg))
            }
        };
        match payload {
            Ok(bytes) => {
                if let Err(e) = client.publish(topic.clone(), QoS::AtMostOnce, false, bytes).await {
                    tracing::warn!(%vehicle, "VDA 5050: cannot publish on {topic}: {e}");
                }
            }
            Err(e) => tracing::error!(%vehicle, "VDA 5050: a message that does not encode: {e}"),
        }
    }
}
