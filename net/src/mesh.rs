//! A node on the mesh: its Zenoh session with its seal. Everything a node sends goes out sealed
//! (see [`crate::security::seal`]); everything it receives is taken only with the proven sender,
//! which the node then checks against what the sender may do.

use std::sync::Arc;
use std::time::Duration;

use serde::de::DeserializeOwned;
use serde::Serialize;
use zenoh::bytes::Encoding;
use zenoh::query::{ConsolidationMode, Query, QueryTarget};
use zenoh::sample::{Sample, SampleKind};
use zenoh::Session;

use crate::net::{self, Mode, QueryError};
use crate::security::{acl, Identity, Refusal, Sealer, SecuritySection, Sender, Verifier};
use mrmm_proto::codec::{from_json, to_json, to_json_packed, to_json_packed_over, ANSWER_PACK_OVER};
use mrmm_proto::edge::{Incoming, Proof, Refused};
use mrmm_proto::error::ProtoError;
use mrmm_proto::{ErrorCode, ErrorReply};

/// How one round of a query ended without an accepted answer.
enum Asked {
    /// A server answered [`ErrorCode::Unproven`] to a query that was not signed: worth asking
    /// again, signed.
    Unproven(QueryError),
    Failed(QueryError),
}

/// Unix milliseconds now.
pub fn now_ms() -> u64 {
    std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| u64::try_from(d.as_millis()).unwrap_or(u64::MAX))
}

/// How a node joins the mesh.
#[derive(Debug, Clone)]
pub struct NodeNet {
    pub mode: Mode,
    pub listen: Vec<String>,
    pub connect: Vec<String>,
    pub lease_ms: u64,
    /// Largest message accepted from the network (Zenoh's defragmentation limit).
    pub max_message_size: usize,
    /// `None`: insecure (plain TCP, unsigned seals).
    pub security: Option<SecuritySection>,
    /// Who this node is: checked against its certificate when secure, claimed when not. `None`
    /// (tools): whoever the certificate names, or `operator:op` when insecure.
    pub me: Option<Sender>,
    /// Count messages on the wire per kind ([`mrmm_proto::keys::WIRE_KINDS`]) in Zenoh's stats,
    /// readable by anyone on the mesh through the admin space (experiments only).
    pub wire_stats: bool,
}

/// A node's session with its seal and its verifier.
#[derive(Clone)]
pub struct Mesh {
    session: Session,
    sealer: Arc<Sealer>,
    verifier: Arc<Verifier>,
}

impl std::fmt::Debug for Mesh {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Mesh").field("me", self.sealer.me()).field("secure", &self.sealer.is_secure()).finish()
    }
}

/// The identity and Zenoh config of a node (checks the certificate against `me` and the
/// endpoints against the mode: `tls/` when secure, `tcp/` when not).
pub fn prepare(n: &NodeNet) -> Result<(zenoh::Config, Sealer, Verifier), ProtoError> {
    let secure = n.security.is_some();
    net::validate_endpoints_for("listen", &n.listen, secure).map_err(ProtoError::Config)?;
    net::validate_endpoints_for("connect", &n.connect, secure).map_err(ProtoError::Config)?;
    match &n.security {
        Some(section) => {
            let identity = Identity::load("security", section)?;
            if let Some(me) = n.me.as_ref().filter(|me| **me != identity.me) {
                return Err(ProtoError::Config(format!(
                    "security.cert: {}: names {} but this node is {me} (issue it with `mrmm pki issue DIR --role {} --id {}`)",
                    section.cert.display(),
                    identity.me,
                    me.role,
                    me.id
                )));
            }
            if !section.operators.is_empty() && identity.me.role != crate::security::Role::Central {
                return Err(ProtoError::Config("security.operators: only central's config lists operators".into()));
            }
            let pairs = Arc::new(crate::security::pair::Pairs::new(identity.pair_secret()));
            let verifier = Verifier::secure(&identity.ca_der, section.max_age_s).map_err(ProtoError::Config)?.with_pairs(pairs);
            let tls = net::Tls { ca: &section.ca, cert: &section.cert, key: &section.key, verify_names: section.verify_names };
            let acl = (identity.me.role == crate::security::Role::Central).then(|| acl::central_acl(&section.operators));
            let config = net::zenoh_config_with(n.mode, &n.listen, &n.connect, n.lease_ms, n.max_message_size, Some(&tls), acl.as_ref())?;
            Ok((config, Sealer::secure(identity), verifier))
        }
        None => {
            let config = net::zenoh_config_with(n.mode, &n.listen, &n.connect, n.lease_ms, n.max_message_size, None, None)?;
            let me = n.me.clone().unwrap_or_else(|| Sender::new(crate::security::Role::Operator, "op"));
            Ok((config, Sealer::insecure(me), Verifier::insecure()))
        }
    }
}

impl Mesh {
    /// Opens the node's session (see [`prepare`]); logs a warning when it runs insecure.
    pub async fn open(n: &NodeNet) -> Result<Mesh, ProtoError> {
        let (mut config, sealer, verifier) = prepare(n)?;
        if n.wire_stats {
            net::enable_wire_stats(&mut config)?;
            tracing::warn!(node = %sealer.me(), "wire statistics on: the admin space is readable by the mesh (experiments only)");
        }
        if !sealer.is_secure() {
            tracing::warn!(node = %sealer.me(), "running INSECURE: no `security` section, plain TCP and unsigned messages (development only)");
        }
        let session = net::open(config).await?;
        Ok(Mesh { session, sealer: Arc::new(sealer), verifier: Arc::new(verifier) })
    }

    /// A mesh over an open session (tests and tools).
    pub fn from_parts(session: Session, sealer: Sealer, verifier: Verifier) -> Mesh {
        Mesh { session, sealer: Arc::new(sealer), verifier: Arc::new(verifier) }
    }

    pub fn session(&self) -> &Session {
        &self.session
    }

    pub fn me(&self) -> &Sender {
        self.sealer.me()
    }

    pub fn is_secure(&self) -> bool {
        self.sealer.is_secure()
    }

    pub fn verifier(&self) -> &Verifier {
        &self.verifier
    }

    /// The seal of `payload` on `key`, now.
    pub fn seal(&self, key: &str, payload: &[u8]) -> Vec<u8> {
        self.sealer.seal(key, payload, now_ms())
    }

    /// Publishes `bytes` on `key`, sealed; failures are logged.
    pub async fn put(&self, key: &str, bytes: Vec<u8>, encoding: Encoding) {
        let att = self.seal(key, &bytes);
        if let Err(e) = self.session.put(key, bytes).encoding(encoding).attachment(att).await {
            tracing::warn!("publication on {key} failed: {e}");
        }
    }

    /// The seal of `payload` on `key` for a stream with many receivers, some of them known (a
    /// robot's telemetry: central and its mission's managers): tagged for the known peers `pred`
    /// accepts, who check their tag; signed as well when `sign` or when it knows none of them,
    /// for everyone else (the others take only the signed messages of the stream).
    ///
    /// Its unsigned messages name the certificate by id (the signed ones carry it, and every
    /// receiver it tags has proven it: it learnt their keys from their messages, and they take
    /// the stream's next signed message): 16 bytes instead of ~400.
    pub fn seal_for_known(&self, key: &str, payload: &[u8], pred: impl Fn(&Sender) -> bool, sign: bool) -> Vec<u8> {
        let to = self.verifier.pairs().map(|p| p.known_where(pred)).unwrap_or_default();
        self.seal_tagged_as(key, payload, &to, sign, true)
    }

    /// The seal of `payload` on `key` tagged for those of `to` this node knows, and signed as
    /// well when `sign` or when it does not know them all (an insecure node: a bare claim).
    fn seal_tagged(&self, key: &str, payload: &[u8], to: &[Sender], sign: bool) -> Vec<u8> {
        self.seal_tagged_as(key, payload, to, sign, false)
    }

    /// [`Mesh::seal_tagged`], naming the certificate by id if `cert_by_id` and not signed.
    fn seal_tagged_as(&self, key: &str, payload: &[u8], to: &[Sender], sign: bool, cert_by_id: bool) -> Vec<u8> {
        match self.verifier.pairs() {
            Some(pairs) => {
                let (tags, all) = pairs.for_receivers(to);
                self.sealer.seal_for(key, payload, now_ms(), &tags, sign || !all, cert_by_id)
            }
            None => self.seal(key, payload),
        }
    }

    /// Publishes `bytes` on `key` for the receivers `to`: tagged for each of them this node
    /// knows (see [`crate::security::seal`]), and signed as well while it does not know them all
    /// (or `to` is empty). Other subscribers refuse it as not meant for them.
    pub async fn put_for(&self, key: &str, bytes: Vec<u8>, encoding: Encoding, to: &[Sender]) {
        let att = self.seal_tagged(key, &bytes, to, false);
        if let Err(e) = self.session.put(key, bytes).encoding(encoding).attachment(att).await {
            tracing::warn!("publication on {key} failed: {e}");
        }
    }

    /// Publishes a JSON value on `key` for the receivers `to` (see [`Mesh::put_for`]).
    pub async fn publish_json_for<T: Serialize>(&self, key: &str, value: &T, to: &[Sender]) {
        match to_json(value) {
            Ok(bytes) => self.put_for(key, bytes, Encoding::APPLICATION_JSON, to).await,
            Err(e) => tracing::warn!("cannot encode for {key}: {e}"),
        }
    }

    /// Publishes a JSON value on `key`, sealed.
    pub async fn publish_json<T: Serialize>(&self, key: &str, value: &T) {
        match to_json(value) {
            Ok(bytes) => self.put(key, bytes, Encoding::APPLICATION_JSON).await,
            Err(e) => tracing::warn!("cannot encode for {key}: {e}"),
        }
    }

    /// The sender of a sample for a node that only shows it (the viewer): see
    /// [`crate::security::seal::Verifier::observed_sender`]. A refusal is counted and `None`.
    pub fn observed_sender_of(&self, what: &str, s: &Sample) -> Option<Sender> {
        let bytes = s.payload().to_bytes();
        let att = s.attachment().map(|a| a.to_bytes());
        match self.verifier.observed_sender(s.key_expr().as_str(), &bytes, att.as_deref(), now_ms()) {
            Ok(sender) => Some(sender),
            Err(r) => {
                self.verifier.refused.record(&format!("{what} on {}", s.key_expr()), &r);
                None
            }
        }
    }

    /// The proven sender of a sample; a refusal is counted, logged (rate-limited) and `None`.
    pub fn sender_of(&self, what: &str, s: &Sample) -> Option<Sender> {
        let bytes = s.payload().to_bytes();
        let att = s.attachment().map(|a| a.to_bytes());
        self.verifier.check(what, s.key_expr().as_str(), &bytes, att.as_deref(), now_ms())
    }

    /// A sample as its machine's event: its sender proven as `proof` says (`None`: a liveliness
    /// token, which carries no seal; a seal that does not prove it is refused and counted), then
    /// translated by the machine's own `ingress`. What its sender may not send is refused and
    /// counted; anything else that does not translate is logged and dropped.
    pub fn hear<T>(&self, s: &Sample, proof: Option<(&str, Proof)>, ingress: impl FnOnce(Incoming<'_>) -> Result<T, Refused>) -> Option<T> {
        let key = s.key_expr().as_str();
        let from = match proof {
            None => None,
            Some((what, Proof::Own)) => Some(self.sender_of(what, s)?),
            Some((what, Proof::Observed)) => Some(self.observed_sender_of(what, s)?),
        };
        let payload = s.payload().to_bytes();
        match ingress(Incoming { key, payload: &payload, put: s.kind() == SampleKind::Put, from: from.as_ref() }) {
            Ok(v) => Some(v),
            Err(Refused::NotEntitled { from, what }) => {
                self.refuse(&what, &from);
                None
            }
            Err(e) => {
                tracing::debug!("dropped what came on {key}: {e}");
                None
            }
        }
    }

    /// The proven sender of a query (`None` when its seal is refused; counted and logged).
    pub fn sender_of_query(&self, what: &str, q: &Query) -> Option<Sender> {
        let payload = net::query_payload(q);
        let att = q.attachment().map(|a| a.to_bytes());
        self.verifier.check(what, q.key_expr().as_str(), &payload, att.as_deref(), now_ms())
    }

    /// The proven sender of a query, or the refusal (not counted).
    pub fn try_sender_of_query(&self, q: &Query) -> Result<Sender, Refusal> {
        let payload = net::query_payload(q);
        let att = q.attachment().map(|a| a.to_bytes());
        self.verifier.sender(q.key_expr().as_str(), &payload, att.as_deref(), now_ms())
    }

    /// Counts and logs a proven sender that may not do `what`.
    pub fn refuse(&self, what: &str, proven: &Sender) {
        self.verifier.refused.record(what, &Refusal::NotEntitled { proven: proven.clone(), what: what.to_string() });
    }

    /// What a machine refused ([`Refused`]): a proven sender that may not do what it did is
    /// counted and logged as [`Mesh::refuse`] does; anything else is dropped with a debug line.
    pub fn refused(&self, r: &Refused) {
        match r {
            Refused::NotEntitled { from, what } => self.refuse(what, from),
            other => tracing::debug!("dropped: {other}"),
        }
    }

    /// Asks `selector` (optional JSON body, sealed) every server of it, and returns the first
    /// answer whose proven sender `accept`s — not merely the first answer: a stranger answering
    /// first is refused and the wait goes on. A reply error (which carries no seal) is returned
    /// only when no accepted answer came.
    ///
    /// The query is tagged for the servers it would accept that this node knows (they check
    /// their tag), and signed only when it knows none of them. A server that cannot prove it (its
    /// certificate was re-issued since, or it is one this node has not heard yet) answers
    /// [`ErrorCode::Unproven`]: the query is then asked once more, signed, within the same `timeout`.
    pub async fn query<T: DeserializeOwned>(
        &self,
        selector: &str,
        body: Option<Vec<u8>>,
        timeout: Duration,
        accept: impl Fn(&Sender) -> bool,
    ) -> Result<(T, Sender), QueryError> {
        let deadline = std::time::Instant::now() + timeout;
        let payload = body.unwrap_or_default();
        match self.ask(selector, &payload, timeout, &accept, false).await {
            Err(Asked::Unproven(e)) => {
                let left = deadline.saturating_duration_since(std::time::Instant::now());
                match self.ask(selector, &payload, left, &accept, true).await {
                    Ok(v) => Ok(v),
                    Err(Asked::Unproven(_)) => Err(e),
                    Err(Asked::Failed(e)) => Err(e),
                }
            }
            Err(Asked::Failed(e)) => Err(e),
            Ok(v) => Ok(v),
        }
    }

    /// One round of [`Mesh::query`], signed if `sign` (or if no accepted server is known).
    async fn ask<T: DeserializeOwned>(
        &self,
        selector: &str,
        payload: &[u8],
        timeout: Duration,
        accept: &impl Fn(&Sender) -> bool,
        sign: bool,
    ) -> Result<(T, Sender), Asked> {
        let key = selector.split('?').next().unwrap_or(selector);
        let known = self.verifier.pairs().map(|p| p.known_where(accept)).unwrap_or_default();
        let signed = sign || known.is_empty() || !self.is_secure();
        let att = self.seal_tagged(key, payload, &known, sign);
        let zerr = |e: zenoh::Error| Asked::Failed(QueryError::Zenoh { key: selector.to_string(), why: e.to_string() });
        let mut get = self.session.get(selector).timeout(timeout).consolidation(ConsolidationMode::None).target(QueryTarget::All).attachment(att);
        if !payload.is_empty() {
            get = get.payload(payload.to_vec()).encoding(Encoding::APPLICATION_JSON);
        }
        let replies = get.await.map_err(zerr)?;
        let mut failed: Option<QueryError> = None;
        let mut unproven = false;
        while let Ok(reply) = replies.recv_async().await {
            match reply.result() {
                Ok(sample) => {
                    let bytes = sample.payload().to_bytes();
                    let att = sample.attachment().map(|a| a.to_bytes());
                    let sender = match self.verifier.sender(sample.key_expr().as_str(), &bytes, att.as_deref(), now_ms()) {
                        Ok(s) => s,
                        Err(r) => {
                            // An answer naming a certificate this node no longer holds (its
                            // cache was cleared): asked again, signed, it comes with it.
                            unproven |= matches!(r, Refusal::Unseen { .. });
                            self.verifier.refused.record(&format!("answer on {}", sample.key_expr()), &r);
                            continue;
                        }
                    };
                    if !accept(&sender) {
                        self.refuse(&format!("answer {selector}"), &sender);
                        continue;
                    }
                    match from_json(selector, &bytes) {
                        Ok(v) => return Ok((v, sender)),
                        Err(e) => {
                            failed.get_or_insert(QueryError::Decode { key: selector.to_string(), why: e.to_string() });
                        }
                    }
                }
                Err(err) => {
                    let bytes = err.payload().to_bytes();
                    if net::is_zenoh_timeout(&bytes) {
                        continue;
                    }
                    let e = net::error_reply(selector, &bytes);
                    unproven |= e.is(ErrorCode::Unproven);
                    failed.get_or_insert(QueryError::Remote(e));
                }
            }
        }
        let e = failed.unwrap_or(QueryError::NoAnswer { key: selector.to_string(), ms: timeout.as_millis() });
        Err(if unproven && !signed { Asked::Unproven(e) } else { Asked::Failed(e) })
    }

    /// Refuses a query whose seal does not prove its sender: counted, logged (rate-limited) and
    /// answered with [`ErrorCode::Unproven`], so that an asker whose tag was for an older
    /// certificate of this node asks again, signed.
    pub async fn refuse_unproven(&self, what: &str, q: &Query, r: &Refusal) {
        self.verifier.refused.record(&format!("{what} on {}", q.key_expr()), r);
        net::reply_err(q, &ErrorReply::coded(ErrorCode::Unproven, format!("refused: unproven seal: {r}"))).await;
    }

    /// The seal of a reply: tagged for the node that asked when this node knows it — a server
    /// that did not check the query's seal (central's operator API, whose authority is the
    /// link's certificate) checks it here the first time, to learn the asker's key — signed
    /// otherwise.
    ///
    /// When the query was tagged for this node and not signed, the asker holds this node's
    /// certificate (it learnt the key it tagged for from a message that carried it): the reply
    /// names the certificate by id, ~400 bytes less (an operator's 1 KB answer then fits one
    /// QUIC packet). An asker that no longer holds it refuses the answer as `unseen` and asks
    /// again, signed, and the answer to a signed query carries the certificate.
    fn seal_reply(&self, query: &Query, key: &str, bytes: &[u8]) -> Vec<u8> {
        let att = query.attachment().map(|a| a.to_bytes());
        let seal = att.as_deref().and_then(|a| crate::security::seal::decode(a).ok());
        let asker = seal.as_ref().map(|s| s.claimed.clone());
        let mut by_id = false;
        if let (Some(seal), Some(pairs)) = (&seal, self.verifier.pairs()) {
            if !pairs.knows(&seal.claimed) {
                // Learns the asker's key if its seal proves it; refusals are not this reply's business.
                let _ = self.try_sender_of_query(query);
            }
            by_id = seal.signature.is_none() && seal.tag_for(&pairs.my_id()).is_some();
        }
        self.seal_tagged_as(key, bytes, asker.as_slice(), false, by_id)
    }

    /// Replies to a query with a JSON value on the query's own key, sealed; compressed only when
    /// it would come near the message limit ([`ANSWER_PACK_OVER`]: a mission's plans of hundreds
    /// of robots).
    pub async fn reply_json<T: Serialize>(&self, query: &Query, value: &T) {
        self.reply_encoded(query, to_json_packed_over(value, ANSWER_PACK_OVER)).await
    }

    /// Replies to a query with a JSON value, compressed when large
    /// ([`mrmm_proto::to_json_packed`]): a planner's answer, a plan of hundreds of robots.
    pub async fn reply_packed<T: Serialize>(&self, query: &Query, value: &T) {
        self.reply_encoded(query, to_json_packed(value)).await
    }

    async fn reply_encoded(&self, query: &Query, payload: Result<Vec<u8>, ProtoError>) {
        match payload {
            Ok(bytes) => {
                let key = query.key_expr().clone();
                let att = self.seal_reply(query, key.as_str(), &bytes);
                let encoding = net::encoding_of(&bytes);
                if let Err(e) = query.reply(key, bytes).encoding(encoding).attachment(att).await {
                    tracing::warn!("reply on {} failed: {e}", query.key_expr());
                }
            }
            Err(e) => net::reply_error(query, &e.to_string()).await,
        }
    }

    /// Replies to a query with a reply error `{"error": msg}` (Zenoh reply errors carry no seal).
    pub async fn reply_error(&self, query: &Query, msg: &str) {
        net::reply_error(query, msg).await;
    }

    /// Replies with an error and its code.
    pub async fn reply_err(&self, query: &Query, e: &ErrorReply) {
        net::reply_err(query, e).await;
    }

    pub async fn close(&self) {
        let _ = self.session.close().await;
    }
}

#[cfg(test)]
mod tests;
