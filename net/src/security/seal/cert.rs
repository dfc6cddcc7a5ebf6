//! The fleet's certificates: its CA, parsed once, and a node's certificate proven to be the
//! fleet's (signed by its CA, valid now, an Ed25519 key, a common name `<role>:<id>`).

use x509_parser::prelude::*;

use super::Sender;

/// A CA parsed once: its public key (SubjectPublicKeyInfo DER).
#[derive(Debug, Clone)]
pub struct Ca {
    spki_der: Vec<u8>,
}

/// Parses the fleet CA certificate (it must be a CA).
pub fn parse_ca(der: &[u8]) -> Result<Ca, String> {
    let (_, cert) = X509Certificate::from_der(der).map_err(|e| format!("not an X.509 certificate: {e}"))?;
    if !cert.is_ca() {
        return Err("not a CA certificate (use the ca.crt of `mrmm pki init`)".into());
    }
    Ok(Ca { spki_der: cert.public_key().raw.to_vec() })
}

/// A certificate proven to be this fleet's.
#[derive(Debug, Clone, PartialEq)]
pub struct Proven {
    pub sender: Sender,
    /// Raw Ed25519 public key.
    pub public_key: Vec<u8>,
    /// Unix seconds after which it is no longer valid.
    pub not_after: i64,
}

/// Checks that `der` is a leaf certificate signed by `ca`, valid at `now_s`, with an Ed25519 key
/// and a common name `<role>:<id>`.
pub fn check_cert(ca: &Ca, der: &[u8], now_s: i64) -> Result<Proven, String> {
    let (_, cert) = X509Certificate::from_der(der).map_err(|e| format!("not an X.509 certificate: {e}"))?;
    let (_, ca_spki) = SubjectPublicKeyInfo::from_der(&ca.spki_der).map_err(|e| format!("CA key: {e}"))?;
    cert.verify_signature(Some(&ca_spki)).map_err(|_| "not signed by this fleet's CA".to_string())?;
    let at = ASN1Time::from_timestamp(now_s).map_err(|e| format!("clock: {e}"))?;
    if !cert.validity().is_valid_at(at) {
        return Err(format!("not valid now (valid from {} to {})", cert.validity().not_before, cert.validity().not_after));
    }
    if cert.is_ca() {
        return Err("a CA certificate cannot be a node's".into());
    }
    let spki = cert.public_key();
    if spki.algorithm.algorithm != x509_parser::oid_registry::OID_SIG_ED25519 {
        return Err("not an Ed25519 key (issue certificates with `mrmm pki issue`)".into());
    }
    let cn = cert.subject().iter_common_name().next().and_then(|a| a.as_str().ok()).ok_or_else(|| "no common name".to_string())?;
    let sender = Sender::from_common_name(cn).ok_or_else(|| format!("common name {cn:?} is not <role>:<id>"))?;
    Ok(Proven { sender, public_key: spki.subject_public_key.data.to_vec(), not_after: cert.validity().not_after.timestamp() })
}
