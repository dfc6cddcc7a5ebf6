//! A small operator client for the system manager's JSON API (what `mrmm op`, the demo and the
//! tests use; any Zenoh client can do the same with plain `get`s). Only central's answers count.

use std::time::Duration;

use serde::de::DeserializeOwned;
use serde::Serialize;
use zenoh::Session;

use crate::mesh::{Mesh, NodeNet};
use crate::net::{self, Mode, QueryError};
use crate::security::{Role, SecuritySection};
use mrmm_proto::codec::to_json;
use mrmm_proto::error::ProtoError;

/// A Zenoh client session talking to central.
pub struct Client {
    mesh: Mesh,
    timeout: Duration,
}

impl Client {
    /// Connects in client mode to the given endpoints (central), insecure (plain TCP).
    pub async fn connect(endpoints: &[String], timeout: Duration) -> Result<Self, ProtoError> {
        Client::connect_with(endpoints, None, timeout).await
    }

    /// Connects with an operator certificate (`security`), or insecure without one.
    pub async fn connect_with(endpoints: &[String], security: Option<SecuritySection>, timeout: Duration) -> Result<Self, ProtoError> {
        let n = NodeNet {
            mode: Mode::Client,
            listen: vec![],
            connect: endpoints.to_vec(),
            lease_ms: net::DEFAULT_LEASE_MS,
            max_message_size: net::DEFAULT_MAX_MESSAGE_SIZE,
            security,
            me: None,
            wire_stats: false,
        };
        let (mut config, sealer, verifier) = crate::mesh::prepare(&n)?;
        // Zenoh's client tries its endpoints once by default: one failed handshake (a busy
        // central, a router still starting) would fail the tool. Retry with back-off for as long
        // as the caller is willing to wait for an answer.
        let ms = u64::try_from(timeout.as_millis()).unwrap_or(u64::MAX).max(1);
        config.insert_json5("connect/timeout_ms", &ms.to_string()).map_err(|e| ProtoError::Config(format!("zenoh config connect/timeout_ms: {e}")))?;
        let session = zenoh::open(config).await.map_err(|source| ProtoError::Unreachable { at: endpoints.join(", "), source })?;
        Ok(Client { mesh: Mesh::from_parts(session, sealer, verifier), timeout })
    }

    pub fn session(&self) -> &Session {
        self.mesh.session()
    }

    pub fn mesh(&self) -> &Mesh {
        &self.mesh
    }

    /// Queries `selector` (with an optional JSON body) and decodes the answer of whom the key
    /// belongs to: central for the system manager's and the agent's keys, a node that hosts
    /// missions for a mission's own keys. A reply error becomes `Err` with the server's message.
    pub async fn query<T: DeserializeOwned>(&self, selector: impl std::fmt::Display, body: Option<&impl Serialize>) -> Result<T, ProtoError> {
        let selector = selector.to_string();
        let key = selector.split('?').next().unwrap_or(&selector);
        let mission_key =
            matches!(mrmm_proto::Key::parse(key), Some(mrmm_proto::Key::MissionView(_) | mrmm_proto::Key::MissionMarginal(_) | mrmm_proto::Key::MissionCtl(_)));
        self.query_from(&selector, body, |s| if mission_key { s.role.hosts_missions() } else { s.role == Role::Central }).await
    }

    /// [`Client::query`], taking only an answer whose proven sender `accept`s.
    pub async fn query_from<T: DeserializeOwned>(
        &self,
        selector: &str,
        body: Option<&impl Serialize>,
        accept: impl Fn(&mrmm_proto::Sender) -> bool,
    ) -> Result<T, ProtoError> {
        let body = body.map(to_json).transpose()?;
        match self.mesh.query(selector, body, self.timeout, accept).await {
            Ok((v, _)) => Ok(v),
            Err(QueryError::NoAnswer { key, ms }) => Err(ProtoError::zenoh(format!("no answer on {key} within {ms} ms: is central running?"))),
            Err(other) => Err(ProtoError::Query(other)),
        }
    }

    pub async fn close(self) {
        self.mesh.close().await;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn free_port() -> u16 {
        std::net::TcpListener::bind("127.0.0.1:0").and_then(|l| l.local_addr()).map(|a| a.port()).expect("a free loopback port")
    }

    /// A tool started a moment before central (or during one failed handshake) still connects:
    /// the client retries until its timeout instead of giving up after one try.
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_client_waits_for_a_central_that_comes_up_within_its_timeout() {
        let ep = format!("tcp/127.0.0.1:{}", free_port());
        let listen = [ep.clone()];
        let router = tokio::spawn(async move {
            tokio::time::sleep(Duration::from_millis(400)).await;
            let c = net::zenoh_config(Mode::Router, &listen, &[], net::DEFAULT_LEASE_MS).expect("router config");
            zenoh::open(c).await.expect("router")
        });
        let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await;
        assert!(client.is_ok(), "gave up before central came up: {:?}", client.err());
        router.await.expect("router task").close().await.expect("close");
        // And one that never comes up still fails, after the timeout.
        let nobody = format!("tcp/127.0.0.1:{}", free_port());
        let t = std::time::Instant::now();
        assert!(Client::connect(std::slice::from_ref(&nobody), Duration::from_millis(300)).await.is_err());
        assert!(t.elapsed() < Duration::from_secs(5));
    }
}
