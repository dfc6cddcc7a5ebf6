//! Zenoh plumbing shared by every mrmm node: session configs that follow the project's network
//! rules (explicit endpoints, no multicast scouting, 1 s lease), one-answer queries, publications
//! and JSON replies.

use std::time::Duration;

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use zenoh::bytes::Encoding;
use zenoh::query::Query;
use zenoh::Session;

use mrmm_proto::codec::{from_json, to_json};
use mrmm_proto::error::ProtoError;
use mrmm_proto::ErrorReply;

/// Default address of the central router.
pub const DEFAULT_CENTRAL: &str = "tcp/127.0.0.1:7447";
/// Default lease: a silent peer is declared gone after this long.
pub const DEFAULT_LEASE_MS: u64 = 1000;
/// Default largest message a node accepts from the network (Zenoh's defragmentation limit; its
/// own default is 1 GiB).
pub const DEFAULT_MAX_MESSAGE_SIZE: usize = 1 << 20;
/// Bounds of a configured `max_message_size`.
pub const MAX_MESSAGE_SIZE_RANGE: (usize, usize) = (64 << 10, 64 << 20);

/// The `zenoh` section of a node config.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ZenohSection {
    /// Endpoints to listen on. Must name an explicit address (gossip advertises these to
    /// other peers so they can link directly); port 0 picks a free port.
    #[serde(default = "default_listen")]
    pub listen: Vec<String>,
    /// Endpoints to connect to (central first, then any known peers).
    #[serde(default = "default_connect")]
    pub connect: Vec<String>,
    /// Link lease in milliseconds.
    #[serde(default = "default_lease")]
    pub lease_ms: u64,
    /// Largest message accepted from the network, bytes.
    #[serde(default = "default_max_message_size")]
    pub max_message_size: usize,
    /// Count messages on the wire per kind, readable through the admin space (experiments
    /// only: it opens the admin space to reads from the mesh).
    #[serde(default)]
    pub wire_stats: bool,
    /// How the robot joins: `peer` (default) or `client` of a router (docs/deployment.md).
    #[serde(default)]
    pub mode: JoinMode,
}

/// How a robot joins the mesh (`zenoh.mode`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum JoinMode {
    /// Links to every robot of its router's region (a clique) and to its `connect` endpoints:
    /// robots of a site keep talking with their router gone.
    #[default]
    Peer,
    /// One link, to the first `connect` endpoint that answers (its site's router); when that link
    /// drops, the others are tried in order (e.g. central). A site of N robots keeps N links
    /// instead of N(N−1)/2, and everything between them goes through the router.
    Client,
}

impl JoinMode {
    /// The Zenoh mode of a node that joins this way.
    pub fn zenoh_mode(self) -> Mode {
        match self {
            JoinMode::Peer => Mode::Peer,
            JoinMode::Client => Mode::Attached,
        }
    }
}

impl Default for ZenohSection {
    fn default() -> Self {
        ZenohSection {
            listen: default_listen(),
            connect: default_connect(),
            lease_ms: DEFAULT_LEASE_MS,
            max_message_size: DEFAULT_MAX_MESSAGE_SIZE,
            wire_stats: false,
            mode: JoinMode::Peer,
        }
    }
}

fn default_max_message_size() -> usize {
    DEFAULT_MAX_MESSAGE_SIZE
}

/// Checks a `max_message_size` (`field` names it in the error).
pub fn validate_max_message_size(field: &str, v: usize) -> Result<(), String> {
    let (lo, hi) = MAX_MESSAGE_SIZE_RANGE;
    if (lo..=hi).contains(&v) {
        Ok(())
    } else {
        Err(format!("{field}: must be in [{lo}, {hi}] bytes (got {v})"))
    }
}

fn default_listen() -> Vec<String> {
    vec!["tcp/127.0.0.1:0".to_string()]
}
fn default_connect() -> Vec<String> {
    vec![DEFAULT_CENTRAL.to_string()]
}
fn default_lease() -> u64 {
    DEFAULT_LEASE_MS
}

/// Role of a node in the Zenoh network.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// The central node: routes for everyone.
    Router,
    /// Robots and managers: link directly to each other (gossip) and to the router.
    Peer,
    /// Short-lived operator tools: one link, fail at once when it cannot be opened.
    Client,
    /// A robot as a client of a router ([`JoinMode::Client`]): one link, to the first of its
    /// connect endpoints that answers, retried in order (not only at start) when it drops.
    Attached,
}

impl Mode {
    fn as_str(self) -> &'static str {
        match self {
            Mode::Router => "router",
            Mode::Peer => "peer",
            Mode::Client | Mode::Attached => "client",
        }
    }
}

/// Checks a list of endpoints: `tcp/<host>:<port>` or `tls/<host>:<port>`, with an explicit
/// host address.
pub fn validate_endpoints(field: &str, eps: &[String]) -> Result<(), String> {
    for (i, ep) in eps.iter().enumerate() {
        validate_endpoint(ep).map_err(|e| format!("{field}[{i}]: {e}"))?;
    }
    Ok(())
}

/// Like [`validate_endpoints`], and every endpoint is `quic/` (or `tls/`) when `secure`, `tcp/`
/// when not.
pub fn validate_endpoints_for(field: &str, eps: &[String], secure: bool) -> Result<(), String> {
    validate_endpoints(field, eps)?;
    for (i, ep) in eps.iter().enumerate() {
        let encrypted = ep.starts_with("tls/") || ep.starts_with("quic/");
        match (secure, encrypted) {
            (true, false) => {
                return Err(format!("{field}[{i}]: {ep:?}: with a `security` section every endpoint is quic/<address>:<port> (or tls/<address>:<port>)"))
            }
            (false, true) => {
                return Err(format!("{field}[{i}]: {ep:?}: a {} endpoint needs a `security` section (certificates)", &ep[..ep.find('/').unwrap_or(0) + 1]))
            }
            _ => {}
        }
    }
    Ok(())
}

/// Checks one endpoint (see [`validate_endpoints`]).
pub fn validate_endpoint(ep: &str) -> Result<(), String> {
    let addr = ep
        .strip_prefix("tcp/")
        .or_else(|| ep.strip_prefix("tls/"))
        .or_else(|| ep.strip_prefix("quic/"))
        .ok_or_else(|| format!("{ep:?}: only tcp/<address>:<port>, tls/<address>:<port> and quic/<address>:<port> endpoints are supported"))?;
    let addr = addr.split('#').next().unwrap_or(addr);
    let (host, port) = addr.rsplit_once(':').ok_or_else(|| format!("{ep:?}: missing :<port>"))?;
    port.parse::<u16>().map_err(|_| format!("{ep:?}: bad port {port:?}"))?;
    let host = host.trim_start_matches('[').trim_end_matches(']');
    if host.is_empty() {
        return Err(format!("{ep:?}: missing address"));
    }
    if let Ok(ip) = host.parse::<std::net::IpAddr>() {
        if ip.is_unspecified() {
            return Err(format!("{ep:?}: a wildcard address cannot be advertised to other peers; name the interface address (e.g. 127.0.0.1)"));
        }
    }
    Ok(())
}

/// Builds a Zenoh config for an insecure node (plain TCP): explicit endpoints, multicast scouting
/// off, gossip on, the given lease on every link, the default message size limit.
pub fn zenoh_config(mode: Mode, listen: &[String], connect: &[String], lease_ms: u64) -> Result<zenoh::Config, ProtoError> {
    zenoh_config_with(mode, listen, connect, lease_ms, DEFAULT_MAX_MESSAGE_SIZE, None, None)
}

/// Keep-alives a node sends per lease on a link that carries nothing else (Zenoh's
/// `transport/link/tx/keep_alive`, 4 by default): 2 from a 2 s lease up, 4 below. The receiver
/// drops the link after the sender's lease without a message; a keep-alive every half lease
/// still leaves a second or more of slack, and halves the idle traffic of a clique, whose links
/// grow with the square of its size: 300 secure robots in 6 sites on 2 cores lost 82 of them at
/// 4 per lease (4 s) and none at 2, at 40 % less CPU (docs/scale.md).
pub fn keep_alives_per_lease(lease_ms: u64) -> u32 {
    if lease_ms >= 2000 {
        2
    } else {
        4
    }
}

/// The files of a node's TLS identity.
#[derive(Debug, Clone, Copy)]
pub struct Tls<'a> {
    pub ca: &'a std::path::Path,
    pub cert: &'a std::path::Path,
    pub key: &'a std::path::Path,
    pub verify_names: bool,
}

/// [`zenoh_config`] with a message size limit, mutual TLS (only `quic` and `tls` links are then
/// opened or accepted) and an `access_control` section.
pub fn zenoh_config_with(
    mode: Mode,
    listen: &[String],
    connect: &[String],
    lease_ms: u64,
    max_message_size: usize,
    tls: Option<&Tls<'_>>,
    acl: Option<&serde_json::Value>,
) -> Result<zenoh::Config, ProtoError> {
    validate_max_message_size("max_message_size", max_message_size).map_err(ProtoError::Config)?;
    let mut c = zenoh::Config::default();
    let set = |c: &mut zenoh::Config, key: &str, value: String| c.insert_json5(key, &value).map_err(|e| ProtoError::Config(format!("zenoh config {key}: {e}")));
    set(&mut c, "mode", json(mode.as_str()))?;
    // A robot attached to a router listens on nothing: no one links to it.
    let listen: &[String] = if mode == Mode::Attached { &[] } else { listen };
    set(&mut c, "listen/endpoints", json(listen))?;
    set(&mut c, "connect/endpoints", json(connect))?;
    set(&mut c, "scouting/multicast/enabled", "false".into())?;
    set(&mut c, "scouting/gossip/enabled", (mode != Mode::Attached).to_string())?;
    set(&mut c, "transport/link/tx/lease", lease_ms.to_string())?;
    set(&mut c, "transport/link/tx/keep_alive", keep_alives_per_lease(lease_ms).to_string())?;
    if matches!(mode, Mode::Peer | Mode::Attached) {
        // Robots keep retrying their connect endpoints (central may be down or restarting).
        set(&mut c, "connect/exit_on_failure", "false".into())?;
    }
    if mode == Mode::Peer {
        // Of two peers that learn of each other by gossip, only one connects: with both
        // connecting, a fleet kept two links per pair (twice the keep-alives of a clique).
        set(&mut c, "scouting/gossip/autoconnect_strategy", r#"{ peer: { to_router: "always", to_peer: "greater-zid" } }"#.into())?;
    }
    set(&mut c, "transport/link/rx/max_message_size", max_message_size.to_string())?;
    if let Some(t) = tls {
        let path = |p: &std::path::Path| json(&p.display().to_string());
        // QUIC (mutual TLS 1.3 over UDP, the same certificates) is the secure transport: Zenoh
        // 1.10's TLS link reads and writes one rustls stream from two threads at once, which
        // closes links under load and can crash the process (docs/zenoh.md). `tls/` still works.
        set(&mut c, "transport/link/protocols", json(&["tls", "quic"]))?;
        if let Some(ep) = listen.iter().chain(connect).find(|e| e.starts_with("tls/")) {
            tracing::warn!(
                endpoint = %ep,
                "a tls/ endpoint: Zenoh 1.10's TLS link has a data race that drops links under load and can crash this process (zenoh#2557); use quic/ endpoints"
            );
        }
        set(&mut c, "transport/link/tls/root_ca_certificate", path(t.ca))?;
        set(&mut c, "transport/link/tls/listen_certificate", path(t.cert))?;
        set(&mut c, "transport/link/tls/listen_private_key", path(t.key))?;
        set(&mut c, "transport/link/tls/connect_certificate", path(t.cert))?;
        set(&mut c, "transport/link/tls/connect_private_key", path(t.key))?;
        set(&mut c, "transport/link/tls/enable_mtls", "true".into())?;
        set(&mut c, "transport/link/tls/verify_name_on_connect", t.verify_names.to_string())?;
    }
    if let Some(acl) = acl {
        set(&mut c, "access_control", acl.to_string())?;
    }
    Ok(c)
}

/// Turns on Zenoh's per-kind message counters ([`mrmm_proto::keys::WIRE_KINDS`]) and a read-only
/// admin space to read them from ([`mrmm_proto::keys::wire_stats_selector`]).
pub fn enable_wire_stats(c: &mut zenoh::Config) -> Result<(), ProtoError> {
    let set = |c: &mut zenoh::Config, key: &str, value: String| c.insert_json5(key, &value).map_err(|e| ProtoError::Config(format!("zenoh config {key}: {e}")));
    set(c, "adminspace/enabled", "true".into())?;
    set(c, "adminspace/permissions/read", "true".into())?;
    set(c, "adminspace/permissions/write", "false".into())?;
    let filters: Vec<serde_json::Value> = mrmm_proto::keys::WIRE_KINDS.iter().map(|(_, key)| serde_json::json!({ "key": key })).collect();
    set(c, "stats/filters", serde_json::Value::from(filters).to_string())
}

/// JSON text of a string or string list (cannot fail for those).
fn json<T: Serialize + ?Sized>(v: &T) -> String {
    serde_json::to_string(v).unwrap_or_else(|_| "null".into())
}

/// Opens a Zenoh session, mapping the error.
pub async fn open(config: zenoh::Config) -> Result<zenoh::Session, ProtoError> {
    zenoh::open(config).await.map_err(ProtoError::zenoh)
}

/// The endpoints this session really listens on (port 0 resolved), as `tcp/…` or `tls/…` strings.
pub async fn listening_endpoints(session: &zenoh::Session) -> Vec<String> {
    session.info().locators().await.iter().map(|l| l.to_string()).collect()
}

/// The Zenoh encoding of a JSON payload as sent: `application/json`, or `application/zstd` when
/// it is packed ([`mrmm_proto::to_json_packed`]).
pub fn encoding_of(payload: &[u8]) -> Encoding {
    if mrmm_proto::codec::is_packed(payload) {
        Encoding::from(mrmm_proto::codec::PACKED)
    } else {
        Encoding::APPLICATION_JSON
    }
}

/// Replies to a query with a JSON value on the query's own key; compressed only when it would
/// come near the message limit ([`mrmm_proto::codec::ANSWER_PACK_OVER`]).
pub async fn reply_json<T: Serialize>(query: &Query, value: &T) {
    match mrmm_proto::codec::to_json_packed_over(value, mrmm_proto::codec::ANSWER_PACK_OVER) {
        Ok(bytes) => {
            let key = query.key_expr().clone();
            let encoding = encoding_of(&bytes);
            if let Err(e) = query.reply(key, bytes).encoding(encoding).await {
                tracing::warn!("reply on {} failed: {e}", query.key_expr());
            }
        }
        Err(e) => reply_error(query, &e.to_string()).await,
    }
}

/// Replies to a query with a reply error `{"error": msg}`.
pub async fn reply_error(query: &Query, msg: &str) {
    reply_err(query, &ErrorReply::from(msg)).await
}

/// Replies to a query with a reply error, its code included (`{"error": …, "code": …}`).
pub async fn reply_err(query: &Query, e: &ErrorReply) {
    let body = to_json(e).unwrap_or_default();
    if let Err(e) = query.reply_err(body).encoding(Encoding::APPLICATION_JSON).await {
        tracing::warn!("error reply on {} failed: {e}", query.key_expr());
    }
}

/// The query's payload bytes (empty when it has none).
pub fn query_payload(query: &Query) -> Vec<u8> {
    query.payload().map(|p| p.to_bytes().into_owned()).unwrap_or_default()
}

pub(crate) use mrmm_proto::QueryError;

/// Whether an error reply is Zenoh's own end of a query nobody answered in time (the asker's
/// session, or a router that forwarded the query, ends it with an error whose payload is
/// `Timeout`): no answer, which asking again may get, not a server's refusal. mrmm's servers
/// answer errors as JSON [`ErrorReply`]s, never this bare word.
pub fn is_zenoh_timeout(bytes: &[u8]) -> bool {
    bytes == b"Timeout"
}

/// A reply error's payload as its server sent it (its first 200 characters, when not JSON).
pub fn error_reply(selector: &str, bytes: &[u8]) -> ErrorReply {
    from_json::<ErrorReply>(selector, bytes).unwrap_or_else(|_| ErrorReply::from(String::from_utf8_lossy(bytes).chars().take(200).collect::<String>()))
}

/// One query expecting one JSON answer: returns at the first reply (not at the timeout). A reply
/// error becomes [`QueryError::Remote`] with the server's message; Zenoh's own timeout
/// ([`is_zenoh_timeout`]) [`QueryError::NoAnswer`].
pub async fn query<T: DeserializeOwned>(session: &Session, selector: &str, body: Option<Vec<u8>>, timeout: Duration) -> Result<T, QueryError> {
    let zerr = |e: zenoh::Error| QueryError::Zenoh { key: selector.to_string(), why: e.to_string() };
    let mut get = session.get(selector).timeout(timeout);
    if let Some(b) = body {
        get = get.payload(b).encoding(Encoding::APPLICATION_JSON);
    }
    let replies = get.await.map_err(zerr)?;
    let reply = replies.recv_async().await.map_err(|_| QueryError::NoAnswer { key: selector.to_string(), ms: timeout.as_millis() })?;
    match reply.result() {
        Ok(sample) => from_json(selector, &sample.payload().to_bytes()).map_err(|e| QueryError::Decode { key: selector.to_string(), why: e.to_string() }),
        Err(err) => {
            let bytes = err.payload().to_bytes();
            if is_zenoh_timeout(&bytes) {
                return Err(QueryError::NoAnswer { key: selector.to_string(), ms: timeout.as_millis() });
            }
            Err(QueryError::Remote(error_reply(selector, &bytes)))
        }
    }
}

/// How long a starting node asks the mesh whether its name is taken.
pub const NAME_CHECK_TIMEOUT: Duration = Duration::from_millis(1000);

/// Whether a liveliness token `key` is alive on the mesh now (another node uses the name). Asked
/// before a node declares its own token; waits at most `timeout` (the whole of it when no router
/// answers).
pub async fn already_alive(session: &Session, key: &str, timeout: Duration) -> Result<bool, ProtoError> {
    let replies = session.liveliness().get(key).timeout(timeout).await.map_err(ProtoError::zenoh)?;
    while let Ok(reply) = replies.recv_async().await {
        if reply.result().is_ok() {
            return Ok(true);
        }
    }
    Ok(false)
}

/// Publishes a JSON value on `key`; failures are logged (a publication has no one to answer).
pub async fn publish_json<T: Serialize>(session: &Session, key: &str, value: &T) {
    match to_json(value) {
        Ok(bytes) => {
            if let Err(e) = session.put(key, bytes).encoding(Encoding::APPLICATION_JSON).await {
                tracing::warn!("publication on {key} failed: {e}");
            }
        }
        Err(e) => tracing::warn!("cannot encode for {key}: {e}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn endpoints() {
        assert!(validate_endpoint("tcp/127.0.0.1:7447").is_ok());
        assert!(validate_endpoint("tcp/127.0.0.1:0").is_ok());
        assert!(validate_endpoint("tcp/[::1]:7447").is_ok());
        assert!(validate_endpoint("udp/127.0.0.1:7447").is_err());
        assert!(validate_endpoint("tcp/127.0.0.1").is_err());
        assert!(validate_endpoint("tcp/127.0.0.1:99999").is_err());
        let unspecified = format!("tcp/{}:1", ["0"; 4].join("."));
        assert!(validate_endpoint(&unspecified).unwrap_err().contains("wildcard"));
        let unspecified_v6 = format!("tcp/[{}]:1", "::");
        assert!(validate_endpoint(&unspecified_v6).is_err());
    }

    #[test]
    fn secure_endpoints_are_tls_or_quic_and_plain_ones_tcp() {
        let eps = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        assert!(validate_endpoints_for("listen", &eps(&["tls/127.0.0.1:0", "quic/127.0.0.1:0"]), true).is_ok());
        assert!(validate_endpoints_for("listen", &eps(&["tcp/127.0.0.1:0"]), false).is_ok());
        let e = validate_endpoints_for("listen", &eps(&["tls/127.0.0.1:0", "tcp/127.0.0.1:0"]), true).expect_err("plain in a secure node");
        assert!(e.starts_with("listen[1]: "), "{e}");
        let e = validate_endpoints_for("connect", &eps(&["quic/127.0.0.1:7447"]), false).expect_err("quic without certificates");
        assert_eq!(e, "connect[0]: \"quic/127.0.0.1:7447\": a quic/ endpoint needs a `security` section (certificates)");
    }

    #[test]
    fn config_has_no_multicast_and_our_lease() {
        let c = zenoh_config(Mode::Peer, &["tcp/127.0.0.1:0".into()], &[DEFAULT_CENTRAL.into()], 1000).expect("config");
        assert_eq!(c.get_json("scouting/multicast/enabled").expect("key"), "false");
        assert_eq!(c.get_json("transport/link/tx/lease").expect("key"), "1000");
        assert_eq!(c.get_json("transport/link/tx/keep_alive").expect("key"), "4");
        let c = zenoh_config(Mode::Peer, &["tcp/127.0.0.1:0".into()], &[DEFAULT_CENTRAL.into()], 4000).expect("config");
        assert_eq!(c.get_json("transport/link/tx/keep_alive").expect("key"), "2", "a keep-alive every 2 s on a 4 s lease");
        assert!(c.get_json("listen/endpoints").expect("key").contains("127.0.0.1:0"));
    }

    #[test]
    fn an_attached_robot_is_a_client_that_keeps_retrying() {
        let c = zenoh_config(JoinMode::Client.zenoh_mode(), &["tcp/127.0.0.1:0".into()], &["tcp/127.0.0.1:7448".into(), DEFAULT_CENTRAL.into()], 4000)
            .expect("config");
        assert_eq!(c.get_json("mode").expect("key"), "\"client\"");
        assert_eq!(c.get_json("listen/endpoints").expect("key"), "[]", "no one links to a client");
        assert_eq!(c.get_json("connect/endpoints").expect("key"), r#"["tcp/127.0.0.1:7448","tcp/127.0.0.1:7447"]"#, "its router first");
        assert_eq!(c.get_json("connect/exit_on_failure").expect("key"), "false");
        assert_eq!(c.get_json("scouting/gossip/enabled").expect("key"), "false");
        assert_eq!(c.get_json("scouting/multicast/enabled").expect("key"), "false");
        // An operator tool is a client too, but fails at once when central is not there.
        let tool = zenoh_config(Mode::Client, &[], &[DEFAULT_CENTRAL.into()], 4000).expect("config");
        assert_ne!(tool.get_json("connect/exit_on_failure").expect("key"), "false");
    }
}
