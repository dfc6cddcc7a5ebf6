//! Seals: the Zenoh attachment every mrmm node puts on what it publishes, queries and replies,
//! naming its sender — signed with the node's key in a secure fleet, a bare claim in an insecure
//! one — and their checking on the receiving side.
//!
//! Attachment layout (all integers little-endian):
//!
//! | bytes | field |
//! |---|---|
//! | 3 | magic `MS1` |
//! | 1 | flags: bit 0 = signed, bit 1 = tagged, bit 2 = certificate by id (tagged, not signed) |
//! | 1 | role (0 operator, 1 central, 2 robot, 3 host, 4 planner) |
//! | 1 + n | id length n (1..=64), id |
//! | 8 | time, Unix milliseconds |
//! | 2 + c | if signed or tagged: certificate length c (1..=4096), certificate (DER) … |
//! | 16 | … or, with bit 2, the certificate's id (the first 16 bytes of its SHA-256) |
//! | 64 | if signed: Ed25519 signature |
//! | 1 + 24 n | if tagged: n (1..=64), then n × (receiver key id (8), tag (16)) |
//!
//! The signature covers SHA-256 of `"mrmm-seal/1\0"`, role, id, time, the key expression and the
//! payload (the seal digest), so a sealed message cannot be moved to another key, changed, or
//! claimed by another node; its time bounds replays to the configured window (epochs and sequence
//! numbers in the payloads order what happens inside it). A tag is an HMAC of the same digest
//! under the key the sender shares with one receiver ([`super::pair`]): it proves the same to that
//! receiver only, at a fraction of the cost. A message for receivers the sender knows (a team's
//! barrier messages, an answer to a query) carries their tags, and a signature as well when the
//! sender does not know them all yet; a receiver with a tag checks the tag, one without checks the
//! signature. A stream whose receivers have its sender's certificate already (a robot's
//! telemetry between its signed messages, which carry it) names the certificate by its id: 16
//! bytes instead of ~400, found in the receiver's cache of proven certificates.

use std::collections::HashMap;
use std::fmt;
use std::sync::atomic::Ordering;
use std::sync::Mutex;

use ring::digest;
use ring::signature::{UnparsedPublicKey, ED25519};

use super::pair::{self, KeyId, Pairs};
use super::{Identity, Role, Sender};

mod cert;
mod counts;

pub use cert::{check_cert, parse_ca, Ca, Proven};
pub use counts::{Proofs, Refused};

const MAGIC: &[u8; 3] = b"MS1";
const DOMAIN: &[u8] = b"mrmm-seal/1\0";
/// Longest certificate a seal may carry.
pub const MAX_CERT: usize = 4096;
const SIG_LEN: usize = 64;
/// Most receivers one seal carries tags for.
pub const MAX_TAGS: usize = 64;
const TAG_ENTRY: usize = pair::KEY_ID_LEN + pair::TAG_LEN;
/// Proven certificates remembered (by id); beyond this the cache starts over.
const CACHE_MAX: usize = 1024;
/// Length of a certificate's id.
pub const CERT_ID_LEN: usize = 16;

/// A certificate's id: the first [`CERT_ID_LEN`] bytes of SHA-256 of its DER.
pub fn cert_id(der: &[u8]) -> [u8; CERT_ID_LEN] {
    let mut id = [0u8; CERT_ID_LEN];
    id.copy_from_slice(&digest::digest(&digest::SHA256, der).as_ref()[..CERT_ID_LEN]);
    id
}

/// Why a message was refused.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Refusal {
    /// No seal at all (a plain Zenoh client, or a foreign node).
    Missing,
    /// The attachment is not a well-formed seal.
    Malformed(&'static str),
    /// A secure fleet needs a signature; this seal only claims.
    Unsigned { claimed: Sender },
    /// Tagged for other receivers only, and not signed: not meant for this node.
    Unaddressed { claimed: Sender },
    /// Names its certificate by id, and this node has not proven that certificate yet (a
    /// receiver that joined a stream: it takes the stream's next message carrying it).
    Unseen { claimed: Sender },
    /// The certificate is not one of this fleet's, or not valid now.
    Certificate { claimed: Sender, why: String },
    /// The certificate proves someone else than the seal claims.
    Mismatch { claimed: Sender, proven: Sender },
    /// The signature does not match the message.
    Signature { claimed: Sender },
    /// Outside the replay window (or a clock far off).
    Stale { claimed: Sender, age_ms: i64 },
    /// A proven sender that may not send this.
    NotEntitled { proven: Sender, what: String },
}

impl Refusal {
    /// A short stable name, for counters.
    pub fn kind(&self) -> &'static str {
        match self {
            Refusal::Missing => "missing",
            Refusal::Malformed(_) => "malformed",
            Refusal::Unsigned { .. } => "unsigned",
            Refusal::Unaddressed { .. } => "unaddressed",
            Refusal::Unseen { .. } => "unseen_certificate",
            Refusal::Certificate { .. } => "certificate",
            Refusal::Mismatch { .. } => "mismatch",
            Refusal::Signature { .. } => "signature",
            Refusal::Stale { .. } => "stale",
            Refusal::NotEntitled { .. } => "not_entitled",
        }
    }
}

impl fmt::Display for Refusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Refusal::Missing => f.write_str("no seal"),
            Refusal::Malformed(why) => write!(f, "malformed seal: {why}"),
            Refusal::Unsigned { claimed } => write!(f, "unsigned seal claiming {claimed}"),
            Refusal::Unaddressed { claimed } => write!(f, "seal of {claimed} tagged for other receivers only"),
            Refusal::Unseen { claimed } => write!(f, "seal of {claimed} names a certificate not seen yet"),
            Refusal::Certificate { claimed, why } => write!(f, "seal claiming {claimed}: certificate refused: {why}"),
            Refusal::Mismatch { claimed, proven } => write!(f, "seal claims {claimed} but its certificate proves {proven}"),
            Refusal::Signature { claimed } => write!(f, "seal claiming {claimed}: bad signature"),
            Refusal::Stale { claimed, age_ms } => write!(f, "seal of {claimed} is {age_ms} ms old (outside the replay window)"),
            Refusal::NotEntitled { proven, what } => write!(f, "{proven} may not {what}"),
        }
    }
}

/// The certificate a seal carries, or names.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CertRef<'a> {
    Der(&'a [u8]),
    Id([u8; CERT_ID_LEN]),
}

/// A decoded seal, borrowing the attachment.
#[derive(Debug, Clone, PartialEq)]
pub struct Seal<'a> {
    pub claimed: Sender,
    pub t_ms: u64,
    /// The certificate, when signed or tagged.
    pub cert: Option<CertRef<'a>>,
    pub signature: Option<&'a [u8]>,
    /// Tag entries (receiver key id, tag), back to back.
    pub tags: &'a [u8],
}

impl Seal<'_> {
    /// The tag for receiver `to`, if the seal carries one.
    pub fn tag_for(&self, to: &KeyId) -> Option<&[u8]> {
        self.tags.chunks_exact(TAG_ENTRY).find(|e| e.get(..pair::KEY_ID_LEN) == Some(to.as_slice())).and_then(|e| e.get(pair::KEY_ID_LEN..))
    }
}

/// Decodes an attachment (never panics, never allocates more than the id).
pub fn decode(att: &[u8]) -> Result<Seal<'_>, Refusal> {
    let mut r = att;
    let mut take = |n: usize, what: &'static str| -> Result<&[u8], Refusal> {
        if r.len() < n {
            return Err(Refusal::Malformed(what));
        }
        let (a, b) = r.split_at(n);
        r = b;
        Ok(a)
    };
    if take(3, "magic")? != MAGIC {
        return Err(Refusal::Malformed("magic"));
    }
    let flags = take(1, "flags")?[0];
    let role = Role::from_code(take(1, "role")?[0]).ok_or(Refusal::Malformed("role"))?;
    let id_len = usize::from(take(1, "id length")?[0]);
    let id = std::str::from_utf8(take(id_len, "id")?).map_err(|_| Refusal::Malformed("id"))?;
    mrmm_proto::keys::validate_id(id).map_err(|_| Refusal::Malformed("id"))?;
    let mut t = [0u8; 8];
    t.copy_from_slice(take(8, "time")?);
    let t_ms = u64::from_le_bytes(t);
    if flags & !7 != 0 {
        return Err(Refusal::Malformed("flags"));
    }
    let (signed, tagged, by_id) = (flags & 1 == 1, flags & 2 == 2, flags & 4 == 4);
    if by_id && (signed || !tagged) {
        return Err(Refusal::Malformed("flags"));
    }
    let cert = if by_id {
        let mut id = [0u8; CERT_ID_LEN];
        id.copy_from_slice(take(CERT_ID_LEN, "certificate id")?);
        Some(CertRef::Id(id))
    } else if signed || tagged {
        let mut l = [0u8; 2];
        l.copy_from_slice(take(2, "certificate length")?);
        let cert_len = usize::from(u16::from_le_bytes(l));
        if cert_len == 0 || cert_len > MAX_CERT {
            return Err(Refusal::Malformed("certificate length"));
        }
        Some(CertRef::Der(take(cert_len, "certificate")?))
    } else {
        None
    };
    let signature = if signed { Some(take(SIG_LEN, "signature")?) } else { None };
    let tags = if tagged {
        let n = usize::from(take(1, "tag count")?[0]);
        if n == 0 || n > MAX_TAGS {
            return Err(Refusal::Malformed("tag count"));
        }
        take(n * TAG_ENTRY, "tags")?
    } else {
        &[]
    };
    if !r.is_empty() {
        return Err(Refusal::Malformed("trailing bytes"));
    }
    Ok(Seal { claimed: Sender { role, id: id.to_string() }, t_ms, cert, signature, tags })
}

fn digest_of(sender: &Sender, t_ms: u64, key: &str, payload: &[u8]) -> digest::Digest {
    let mut c = digest::Context::new(&digest::SHA256);
    c.update(DOMAIN);
    c.update(&[sender.role.code()]);
    c.update(&[sender.id.len() as u8]);
    c.update(sender.id.as_bytes());
    c.update(&t_ms.to_le_bytes());
    c.update(&(key.len() as u64).to_le_bytes());
    c.update(key.as_bytes());
    c.update(payload);
    c.finish()
}

/// Puts seals on what this node sends.
#[derive(Debug)]
pub struct Sealer {
    me: Sender,
    identity: Option<Identity>,
}

impl Sealer {
    /// A secure node: seals are signed with the identity's key and carry its certificate.
    pub fn secure(identity: Identity) -> Sealer {
        Sealer { me: identity.me.clone(), identity: Some(identity) }
    }

    /// An insecure node: seals only claim `me`.
    pub fn insecure(me: Sender) -> Sealer {
        Sealer { me, identity: None }
    }

    pub fn me(&self) -> &Sender {
        &self.me
    }

    pub fn is_secure(&self) -> bool {
        self.identity.is_some()
    }

    pub fn identity(&self) -> Option<&Identity> {
        self.identity.as_ref()
    }

    /// The attachment for `payload` on `key` at `t_ms`, signed (when secure).
    pub fn seal(&self, key: &str, payload: &[u8], t_ms: u64) -> Vec<u8> {
        self.seal_for(key, payload, t_ms, &[], true, false)
    }

    /// The attachment for `payload` on `key` at `t_ms` with a tag for each of `to` (receiver key
    /// id, pair key) and, if `sign`, a signature too. Insecure: a bare claim. Signed anyway when
    /// there is no tag to make, or more receivers than [`MAX_TAGS`] (the first ones get tags,
    /// the others check the signature). `cert_by_id`: a message with tags only names the
    /// certificate by its id (its receivers have proven it already: see [`CertRef`]).
    pub fn seal_for(&self, key: &str, payload: &[u8], t_ms: u64, to: &[(KeyId, ring::hmac::Key)], sign: bool, cert_by_id: bool) -> Vec<u8> {
        let id = self.me.id.as_bytes();
        let sign = sign || to.is_empty() || to.len() > MAX_TAGS;
        let by_id = cert_by_id && !sign;
        let to = &to[..to.len().min(MAX_TAGS)];
        let mut out = Vec::with_capacity(16 + id.len() + self.identity.as_ref().map_or(0, |i| i.cert_der.len() + 67 + to.len() * TAG_ENTRY));
        out.extend_from_slice(MAGIC);
        let flags = match &self.identity {
            None => 0,
            Some(_) => u8::from(sign) | if to.is_empty() { 0 } else { 2 } | if by_id { 4 } else { 0 },
        };
        out.push(flags);
        out.push(self.me.role.code());
        out.push(id.len().min(255) as u8);
        out.extend_from_slice(id);
        out.extend_from_slice(&t_ms.to_le_bytes());
        if let Some(identity) = &self.identity {
            let d = digest_of(&self.me, t_ms, key, payload);
            if by_id {
                out.extend_from_slice(&identity.cert_id);
            } else {
                let cert = &identity.cert_der;
                out.extend_from_slice(&(cert.len().min(usize::from(u16::MAX)) as u16).to_le_bytes());
                out.extend_from_slice(cert);
            }
            if sign {
                out.extend_from_slice(identity.sign(d.as_ref()).as_ref());
            }
            if !to.is_empty() {
                out.push(to.len() as u8);
                for (rid, k) in to {
                    out.extend_from_slice(rid);
                    out.extend_from_slice(&pair::tag(k, d.as_ref(), rid));
                }
            }
        }
        out
    }
}

/// When a stream whose receivers a node does not all know (a robot's telemetry) is signed as
/// well as tagged: its first message, then at most one every `every_ms` — a receiver not known
/// yet can check one message in that time, whatever the stream's rate.
#[derive(Debug, Clone)]
pub struct SignCadence {
    every_ms: u64,
    last_ms: Option<u64>,
}

impl SignCadence {
    pub fn new(every_ms: u64) -> SignCadence {
        SignCadence { every_ms, last_ms: None }
    }

    /// The next message is signed (it carries the certificate: a new receiver proves it at once).
    pub fn sign_next(&mut self) {
        self.last_ms = None;
    }

    /// Whether the message sent at `now_ms` is signed (a clock that went back signs at once).
    pub fn due(&mut self, now_ms: u64) -> bool {
        match self.last_ms {
            Some(t) if now_ms >= t && now_ms - t < self.every_ms => false,
            _ => {
                self.last_ms = Some(now_ms);
                true
            }
        }
    }
}

/// Checks the seals of what this node receives.
#[derive(Debug)]
pub struct Verifier {
    /// `None`: insecure fleet (claims are taken as they are).
    ca: Option<Ca>,
    max_age_ms: i64,
    cache: Mutex<HashMap<[u8; CERT_ID_LEN], Result<Proven, String>>>,
    /// This node's pair keys (a secure node's own): tags for it are checked with them, and the
    /// peers it proves are remembered so that it can tag what it sends them.
    pairs: Option<std::sync::Arc<Pairs>>,
    pub refused: Refused,
    pub proven: Proofs,
}

impl Verifier {
    pub fn secure(ca_der: &[u8], max_age_s: u64) -> Result<Verifier, String> {
        Ok(Verifier {
            ca: Some(parse_ca(ca_der)?),
            max_age_ms: i64::try_from(max_age_s.saturating_mul(1000)).unwrap_or(i64::MAX),
            cache: Mutex::new(HashMap::new()),
            pairs: None,
            refused: Refused::default(),
            proven: Proofs::default(),
        })
    }

    /// With this node's pair keys: tags for it are checked, and peers remembered.
    pub fn with_pairs(mut self, pairs: std::sync::Arc<Pairs>) -> Verifier {
        self.pairs = Some(pairs);
        self
    }

    pub fn pairs(&self) -> Option<&Pairs> {
        self.pairs.as_deref()
    }

    /// Forgets every proven certificate (as when the cache fills up and is cleared).
    #[cfg(test)]
    pub(crate) fn forget_certificates(&self) {
        if let Ok(mut cache) = self.cache.lock() {
            cache.clear();
        }
    }

    pub fn insecure() -> Verifier {
        Verifier { ca: None, max_age_ms: i64::MAX, cache: Mutex::new(HashMap::new()), pairs: None, refused: Refused::default(), proven: Proofs::default() }
    }

    pub fn is_secure(&self) -> bool {
        self.ca.is_some()
    }

    /// The proven certificate `der` (cached).
    fn prove(&self, ca: &Ca, der: &[u8], now_s: i64) -> Result<Proven, String> {
        let key = cert_id(der);
        if let Some(r) = self.cached(&key, now_s) {
            return r;
        }
        let r = check_cert(ca, der, now_s);
        if let Ok(mut cache) = self.cache.lock() {
            if cache.len() >= CACHE_MAX {
                cache.clear();
            }
            cache.insert(key, r.clone());
        }
        r
    }

    /// The cached proof of the certificate with id `id`, if it was seen.
    fn cached(&self, id: &[u8; CERT_ID_LEN], now_s: i64) -> Option<Result<Proven, String>> {
        let cache = self.cache.lock().ok()?;
        Some(match cache.get(id)? {
            Ok(p) if p.not_after < now_s => Err("expired".into()),
            other => other.clone(),
        })
    }

    /// Who sent `payload` on `key` with attachment `att`, at receiver time `now_ms`. Does not
    /// count refusals (see [`Verifier::check`]).
    pub fn sender(&self, key: &str, payload: &[u8], att: Option<&[u8]>, now_ms: u64) -> Result<Sender, Refusal> {
        self.sender_as(key, payload, att, now_ms, false)
    }

    /// [`Verifier::sender`] for a node that only shows what it sees (the viewer): a message tagged
    /// for other receivers only is taken as from the node its certificate proves — which proves
    /// the certificate, *not* that this node sent this message (the certificate is public). Never
    /// for anything a node acts on.
    pub fn observed_sender(&self, key: &str, payload: &[u8], att: Option<&[u8]>, now_ms: u64) -> Result<Sender, Refusal> {
        self.sender_as(key, payload, att, now_ms, true)
    }

    fn sender_as(&self, key: &str, payload: &[u8], att: Option<&[u8]>, now_ms: u64, observer: bool) -> Result<Sender, Refusal> {
        let att = att.ok_or(Refusal::Missing)?;
        let seal = decode(att)?;
        let Some(ca) = &self.ca else {
            return Ok(seal.claimed);
        };
        let Some(cert) = seal.cert else {
            return Err(Refusal::Unsigned { claimed: seal.claimed });
        };
        let age = i64::try_from(now_ms).unwrap_or(i64::MAX).saturating_sub(i64::try_from(seal.t_ms).unwrap_or(i64::MAX));
        if age.saturating_abs() > self.max_age_ms {
            return Err(Refusal::Stale { claimed: seal.claimed, age_ms: age });
        }
        let now_s = i64::try_from(now_ms / 1000).unwrap_or(i64::MAX);
        let proven = match cert {
            CertRef::Der(der) => self.prove(ca, der, now_s),
            CertRef::Id(id) => self.cached(&id, now_s).ok_or_else(|| Refusal::Unseen { claimed: seal.claimed.clone() })?,
        }
        .map_err(|why| Refusal::Certificate { claimed: seal.claimed.clone(), why })?;
        if proven.sender != seal.claimed {
            return Err(Refusal::Mismatch { claimed: seal.claimed, proven: proven.sender });
        }
        let d = digest_of(&seal.claimed, seal.t_ms, key, payload);
        let bad = || Refusal::Signature { claimed: seal.claimed.clone() };
        let mine = self.pairs.as_deref().and_then(|p| seal.tag_for(&p.my_id()).map(|t| (p, t)));
        match (mine, seal.signature) {
            (Some((pairs, t)), _) => {
                let key = pairs.key(&proven.public_key).ok_or_else(bad)?;
                if !pair::same_tag(t, &pair::tag(&key, d.as_ref(), &pairs.my_id())) {
                    return Err(bad());
                }
                pairs.learn(&proven.sender, &proven.public_key);
                self.proven.tag.fetch_add(1, Ordering::Relaxed);
            }
            (None, Some(sig)) => {
                UnparsedPublicKey::new(&ED25519, &proven.public_key).verify(d.as_ref(), sig).map_err(|_| bad())?;
                if let Some(pairs) = self.pairs.as_deref() {
                    pairs.learn(&proven.sender, &proven.public_key);
                }
                self.proven.signature.fetch_add(1, Ordering::Relaxed);
            }
            // Tagged for others only: not meant for this node (a viewer shows it as from the
            // certificate's node).
            (None, None) if observer => {}
            (None, None) => return Err(Refusal::Unaddressed { claimed: seal.claimed }),
        }
        Ok(proven.sender)
    }

    /// [`Verifier::sender`], counting and logging a refusal of `what`.
    pub fn check(&self, what: &str, key: &str, payload: &[u8], att: Option<&[u8]>, now_ms: u64) -> Option<Sender> {
        match self.sender(key, payload, att, now_ms) {
            Ok(s) => Some(s),
            Err(r) => {
                self.refused.record(&format!("{what} on {key}"), &r);
                None
            }
        }
    }
}

#[cfg(test)]
mod tests;
