//! Fleet identities: who a node is (role and id, proven by a certificate of the fleet's CA), the
//! `security` section of every config, and what each message needs from its sender.
//!
//! Two layers, both from one key per node (Ed25519, certified by the fleet CA):
//! - **mutual TLS on every link** (Zenoh `transport_tls`, `enable_mtls`): a process without a
//!   certificate of this CA cannot open a session with any node; central's Zenoh access control
//!   lets only the operators' certificates query `mrmm/system/cmd/**` ([`acl`]);
//! - **a seal on every message that matters** ([`seal`]): a Zenoh attachment naming the sender's
//!   role and id, with its certificate and a signature over the key, the payload and the time.
//!   Messages are relayed by routers and peers link directly, so authenticity must hold end to
//!   end, not per link; each receiver checks the seal and then whether the proven sender is
//!   entitled to what it sent ([`entitled`]).
//!
//! Without a `security` section a node runs insecure (plain TCP, unsigned seals carrying claims
//! only) and says so in its log: for development on one machine. See `docs/security.md` for the
//! threat model.

pub mod acl;
pub mod pair;
pub mod pki;
pub mod seal;

use std::fmt;
use std::path::Path;

use mrmm_proto::ProtoError;

pub(crate) use mrmm_proto::security::*;
pub use seal::{Refusal, Sealer, Verifier};

/// This node's proven identity: its certificate (checked against the fleet CA), its key, and the
/// CA that proves everyone else.
pub struct Identity {
    pub me: Sender,
    pub cert_der: Vec<u8>,
    /// [`seal::cert_id`] of `cert_der`.
    pub cert_id: [u8; seal::CERT_ID_LEN],
    pub ca_der: Vec<u8>,
    key: ring::signature::Ed25519KeyPair,
    pair: pair::PairSecret,
    pub section: SecuritySection,
}

impl fmt::Debug for Identity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Identity").field("me", &self.me).finish_non_exhaustive()
    }
}

/// Reads a PEM file holding one block of `label`; errors name the field and the file.
fn read_pem(field: &str, path: &Path, labels: &[&str]) -> Result<Vec<u8>, ProtoError> {
    let text = std::fs::read(path).map_err(|e| ProtoError::Config(format!("{field}: {}: cannot read: {e}", path.display())))?;
    let (_, pem) = x509_parser::pem::parse_x509_pem(&text).map_err(|_| ProtoError::Config(format!("{field}: {}: not a PEM file", path.display())))?;
    if !labels.contains(&pem.label.as_str()) {
        return Err(ProtoError::Config(format!("{field}: {}: holds a {:?}, expected {}", path.display(), pem.label, labels.join(" or "))));
    }
    Ok(pem.contents)
}

/// Seconds since the Unix epoch now.
pub fn unix_now_s() -> i64 {
    std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| i64::try_from(d.as_secs()).unwrap_or(i64::MAX))
}

impl Identity {
    /// Loads and checks the files of `section`: the CA is a CA, the certificate is signed by it,
    /// valid now, Ed25519, names `<role>:<id>`, and the key is the certificate's. `field` names
    /// the config section in errors (one line each).
    pub fn load(field: &str, section: &SecuritySection) -> Result<Identity, ProtoError> {
        section.validate(field).map_err(ProtoError::Config)?;
        let ca_der = read_pem(&format!("{field}.ca"), &section.ca, &["CERTIFICATE"])?;
        let cert_der = read_pem(&format!("{field}.cert"), &section.cert, &["CERTIFICATE"])?;
        let key_der = read_pem(&format!("{field}.key"), &section.key, &["PRIVATE KEY"])?;
        let cfg = |what: &str, path: &Path, why: String| ProtoError::Config(format!("{field}.{what}: {}: {why}", path.display()));
        let ca = seal::parse_ca(&ca_der).map_err(|e| cfg("ca", &section.ca, e))?;
        let proven = seal::check_cert(&ca, &cert_der, unix_now_s()).map_err(|e| cfg("cert", &section.cert, e.to_string()))?;
        let key = ring::signature::Ed25519KeyPair::from_pkcs8_maybe_unchecked(&key_der)
            .map_err(|_| cfg("key", &section.key, "not an Ed25519 PKCS#8 key (issue one with `mrmm pki issue`)".into()))?;
        use ring::signature::KeyPair;
        if key.public_key().as_ref() != proven.public_key.as_slice() {
            return Err(cfg("key", &section.key, format!("is not the key of {}", section.cert.display())));
        }
        let pair = pair::PairSecret::from_pkcs8(&key_der, &proven.public_key).map_err(|e| cfg("key", &section.key, e))?;
        Ok(Identity { me: proven.sender, cert_id: seal::cert_id(&cert_der), cert_der, ca_der, key, pair, section: section.clone() })
    }

    /// This node's half of its pair keys.
    pub fn pair_secret(&self) -> pair::PairSecret {
        self.pair.clone()
    }

    /// Signs a 32-byte digest.
    fn sign(&self, digest: &[u8]) -> ring::signature::Signature {
        self.key.sign(digest)
    }
}
