//! A small operator client for the system manager's JSON API (what `mrmm op` and the demo use;
//! any Zenoh client can do the same with plain `get`s).

use std::time::Duration;

use mrmm_peer::net::{self, Mode};
use mrmm_peer::proto::{self, ErrorReply};
use serde::de::DeserializeOwned;
use serde::Serialize;
use zenoh::bytes::Encoding;
use zenoh::Session;

use crate::error::ManagerError;

/// A Zenoh client session talking to central.
pub struct Client {
    session: Session,
    timeout: Duration,
}

impl Client {
    /// Connects in client mode to the given endpoints (central).
    pub async fn connect(endpoints: &[String], timeout: Duration) -> Result<Self, ManagerError> {
        net::validate_endpoints("connect", endpoints).map_err(ManagerError::Config)?;
        let cfg = net::zenoh_config(Mode::Client, &[], endpoints, net::DEFAULT_LEASE_MS)?;
        let session = zenoh::open(cfg)
            .await
            .map_err(|e| ManagerError::Zenoh(format!("cannot reach central at {}: {e}", endpoints.join(", "))))?;
        Ok(Client { session, timeout })
    }

    pub fn session(&self) -> &Session {
        &self.session
    }

    /// Queries `key` (with an optional JSON body) and decodes the first answer.
    /// A reply error becomes `Err` with the server's message.
    pub async fn query<T: DeserializeOwned>(
        &self,
        key: &str,
        body: Option<&impl Serialize>,
    ) -> Result<T, ManagerError> {
        let mut get = self.session.get(key).timeout(self.timeout);
        if let Some(b) = body {
            get = get.payload(proto::to_json(b)?).encoding(Encoding::APPLICATION_JSON);
        }
        let replies = get.await.map_err(ManagerError::zenoh)?;
        let reply = replies.recv_async().await.map_err(|_| {
            ManagerError::Zenoh(format!("no answer on {key} within {} ms: is central running?", self.timeout.as_millis()))
        })?;
        match reply.result() {
            Ok(sample) => Ok(proto::from_json(key, &sample.payload().to_bytes())?),
            Err(err) => {
                let msg = proto::from_json::<ErrorReply>(key, &err.payload().to_bytes())
                    .map(|e| e.error)
                    .unwrap_or_else(|_| String::from_utf8_lossy(&err.payload().to_bytes()).into_owned());
                Err(ManagerError::Remote(msg))
            }
        }
    }

    pub async fn close(self) {
        let _ = self.session.close().await;
    }
}
