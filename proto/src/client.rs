//! A small operator client for the system manager's JSON API (what `mrmm op`, the demo and the
//! tests use; any Zenoh client can do the same with plain `get`s). Only central's answers count.

use std::time::Duration;

use serde::de::DeserializeOwned;
use serde::Serialize;
use zenoh::Session;

use crate::codec::to_json;
use crate::error::ProtoError;
use crate::mesh::{Mesh, NodeNet};
use crate::net::{self, Mode, QueryError};
use crate::security::{Role, SecuritySection};

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
        };
        let (config, sealer, verifier) = crate::mesh::prepare(&n)?;
        let session = zenoh::open(config).await.map_err(|e| ProtoError::Zenoh(format!("cannot reach central at {}: {e}", endpoints.join(", "))))?;
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
        let mission_key = matches!(crate::Key::parse(key), Some(crate::Key::MissionView(_) | crate::Key::MissionMarginal(_) | crate::Key::MissionCtl(_)));
        self.query_from(&selector, body, |s| if mission_key { s.role.hosts_missions() } else { s.role == Role::Central }).await
    }

    /// [`Client::query`], taking only an answer whose proven sender `accept`s.
    pub async fn query_from<T: DeserializeOwned>(
        &self,
        selector: &str,
        body: Option<&impl Serialize>,
        accept: impl Fn(&crate::Sender) -> bool,
    ) -> Result<T, ProtoError> {
        let body = body.map(to_json).transpose()?;
        match self.mesh.query(selector, body, self.timeout, accept).await {
            Ok((v, _)) => Ok(v),
            Err(QueryError::NoAnswer { key, ms }) => Err(ProtoError::Zenoh(format!("no answer on {key} within {ms} ms: is central running?"))),
            Err(other) => Err(ProtoError::Query(other)),
        }
    }

    pub async fn close(self) {
        self.mesh.close().await;
    }
}
