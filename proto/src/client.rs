//! A small operator client for the system manager's JSON API (what `mrmm op`, the demo and the
//! tests use; any Zenoh client can do the same with plain `get`s).

use std::time::Duration;

use serde::de::DeserializeOwned;
use serde::Serialize;
use zenoh::Session;

use crate::codec::to_json;
use crate::error::ProtoError;
use crate::net::{self, Mode, QueryError};

/// A Zenoh client session talking to central.
pub struct Client {
    session: Session,
    timeout: Duration,
}

impl Client {
    /// Connects in client mode to the given endpoints (central).
    pub async fn connect(endpoints: &[String], timeout: Duration) -> Result<Self, ProtoError> {
        net::validate_endpoints("connect", endpoints).map_err(ProtoError::Config)?;
        let cfg = net::zenoh_config(Mode::Client, &[], endpoints, net::DEFAULT_LEASE_MS)?;
        let session = zenoh::open(cfg)
            .await
            .map_err(|e| ProtoError::Zenoh(format!("cannot reach central at {}: {e}", endpoints.join(", "))))?;
        Ok(Client { session, timeout })
    }

    pub fn session(&self) -> &Session {
        &self.session
    }

    /// Queries `selector` (with an optional JSON body) and decodes the first answer.
    /// A reply error becomes `Err` with the server's message.
    pub async fn query<T: DeserializeOwned>(&self, selector: impl std::fmt::Display, body: Option<&impl Serialize>) -> Result<T, ProtoError> {
        let body = body.map(to_json).transpose()?;
        net::query(&self.session, &selector.to_string(), body, self.timeout).await.map_err(|e| match e {
            QueryError::NoAnswer { key, ms } => ProtoError::Zenoh(format!("no answer on {key} within {ms} ms: is central running?")),
            other => ProtoError::Query(other),
        })
    }

    pub async fn close(self) {
        let _ = self.session.close().await;
    }
}
