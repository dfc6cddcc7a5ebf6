//! The fleet PKI in two commands: `mrmm pki init DIR` makes the fleet CA (`DIR/ca.crt`,
//! `DIR/ca.key`); `mrmm pki issue DIR --role R --id NAME` makes a node's certificate and key
//! (`DIR/NAME.crt`, `DIR/NAME.key`), with common name `<role>:<id>`. Ed25519 keys, PEM files,
//! generated with `rcgen`. Keys are written readable by their owner only, as PKCS#8 v1 (RFC 8410's
//! usual form, without the public key), which OpenSSL and Python's `cryptography` read; keys of
//! either version are read.

use std::path::{Path, PathBuf};

use rcgen::{BasicConstraints, CertificateParams, DistinguishedName, DnType, ExtendedKeyUsagePurpose, IsCa, Issuer, KeyPair, KeyUsagePurpose, PKCS_ED25519};

use super::{Role, Sender};
use mrmm_proto::error::ProtoError;
use mrmm_proto::keys::validate_id;

/// Days a CA certificate is valid.
pub const CA_DAYS: u32 = 3650;
/// Days a node certificate is valid by default.
pub const NODE_DAYS: u32 = 730;

fn err(what: impl std::fmt::Display) -> ProtoError {
    ProtoError::Config(what.to_string())
}

fn write_file(path: &Path, text: &str, private: bool) -> Result<(), ProtoError> {
    use std::io::Write;
    let mut opts = std::fs::OpenOptions::new();
    opts.write(true).create_new(true);
    #[cfg(unix)]
    if private {
        use std::os::unix::fs::OpenOptionsExt;
        opts.mode(0o600);
    }
    #[cfg(not(unix))]
    let _ = private;
    let mut f = opts.open(path).map_err(|e| {
        if e.kind() == std::io::ErrorKind::AlreadyExists {
            err(format!("{}: already exists (not overwritten)", path.display()))
        } else {
            err(format!("{}: cannot write: {e}", path.display()))
        }
    })?;
    f.write_all(text.as_bytes()).map_err(|e| err(format!("{}: cannot write: {e}", path.display())))
}

/// `key` as a PEM PKCS#8 **v1** document (RFC 8410, section 7: version 0, the algorithm, the
/// 32-byte seed; no public key). `ring` makes v2 (with the public key), which OpenSSL 3.0
/// (`openssl pkey`: "unsupported") and Python's `cryptography` ("extra data") refuse.
fn ed25519_v1_pem(key: &KeyPair) -> Result<String, ProtoError> {
    /// SEQUENCE (46) { INTEGER 0, SEQUENCE { OID 1.3.101.112 }, OCTET STRING (34) { OCTET STRING (32) … } }.
    const V1_HEADER: [u8; 16] = [0x30, 0x2e, 0x02, 0x01, 0x00, 0x30, 0x05, 0x06, 0x03, 0x2b, 0x65, 0x70, 0x04, 0x22, 0x04, 0x20];
    let der = key.serialized_der();
    // v1 or v2: the algorithm and the seed's header follow the same 5 bytes (sequence, version).
    let seed = match (der.first(), der.get(5..16), der.get(16..48)) {
        (Some(0x30), Some(header), Some(seed)) if header == &V1_HEADER[5..] => seed,
        _ => return Err(err("the generated key is not an Ed25519 PKCS#8 document")),
    };
    let mut v1 = V1_HEADER.to_vec();
    v1.extend_from_slice(seed);
    // rcgen keeps the document it was given and writes it back as PEM.
    let v1 = KeyPair::try_from(v1).map_err(|e| err(format!("cannot re-encode the key as PKCS#8 v1: {e}")))?;
    Ok(v1.serialize_pem())
}

fn validity(params: &mut CertificateParams, days: u32) {
    let now = time::OffsetDateTime::now_utc();
    // A little back-dating tolerates clocks a few minutes apart.
    params.not_before = now - time::Duration::minutes(10);
    params.not_after = now + time::Duration::days(i64::from(days));
}

/// Makes the fleet CA in `dir` (created if missing): `ca.crt` and `ca.key`. Refuses to overwrite.
pub fn init(dir: &Path) -> Result<(PathBuf, PathBuf), ProtoError> {
    std::fs::create_dir_all(dir).map_err(|e| err(format!("{}: cannot create: {e}", dir.display())))?;
    let key = KeyPair::generate_for(&PKCS_ED25519).map_err(|e| err(format!("cannot generate a key: {e}")))?;
    let mut params = CertificateParams::default();
    let mut dn = DistinguishedName::new();
    dn.push(DnType::CommonName, "mrmm fleet CA");
    params.distinguished_name = dn;
    params.is_ca = IsCa::Ca(BasicConstraints::Constrained(0));
    params.key_usages = vec![KeyUsagePurpose::KeyCertSign, KeyUsagePurpose::CrlSign, KeyUsagePurpose::DigitalSignature];
    validity(&mut params, CA_DAYS);
    let cert = params.self_signed(&key).map_err(|e| err(format!("cannot make the CA certificate: {e}")))?;
    let (crt, kp) = (dir.join("ca.crt"), dir.join("ca.key"));
    if crt.exists() || kp.exists() {
        return Err(err(format!("{}: a CA already exists here (not overwritten)", dir.display())));
    }
    write_file(&kp, &ed25519_v1_pem(&key)?, true)?;
    write_file(&crt, &cert.pem(), false)?;
    Ok((crt, kp))
}

/// The CA certificate of `dir`, DER.
pub fn read_ca_der(dir: &Path) -> Result<Vec<u8>, ProtoError> {
    let path = dir.join("ca.crt");
    let text = std::fs::read(&path).map_err(|e| err(format!("{}: cannot read: {e}", path.display())))?;
    let (_, pem) = x509_parser::pem::parse_x509_pem(&text).map_err(|_| err(format!("{}: not a PEM file", path.display())))?;
    Ok(pem.contents)
}

/// Issues the certificate of node `id` in `role`, signed by the CA of `dir`: `dir/ID.crt` and
/// `dir/ID.key`. `sans`: addresses or host names this node is reached at (only needed with
/// `verify_names`). Refuses to overwrite.
pub fn issue(dir: &Path, role: Role, id: &str, sans: &[String], days: u32) -> Result<(PathBuf, PathBuf), ProtoError> {
    validate_id(id)?;
    if !(1..=36_500).contains(&days) {
        return Err(err(format!("--days: must be in [1, 36500] (got {days})")));
    }
    let ca_key_path = dir.join("ca.key");
    let ca_key_pem = std::fs::read_to_string(&ca_key_path).map_err(|e| err(format!("{}: cannot read the CA key: {e}", ca_key_path.display())))?;
    let ca_key = KeyPair::from_pem(&ca_key_pem).map_err(|e| err(format!("{}: not a key: {e}", ca_key_path.display())))?;
    let ca_crt_path = dir.join("ca.crt");
    let ca_pem = std::fs::read_to_string(&ca_crt_path).map_err(|e| err(format!("{}: cannot read: {e}", ca_crt_path.display())))?;
    let issuer = Issuer::from_ca_cert_pem(&ca_pem, ca_key).map_err(|e| err(format!("{}: not a CA certificate: {e}", ca_crt_path.display())))?;

    let key = KeyPair::generate_for(&PKCS_ED25519).map_err(|e| err(format!("cannot generate a key: {e}")))?;
    let mut params = CertificateParams::new(sans.to_vec()).map_err(|e| err(format!("--san: {e}")))?;
    let mut dn = DistinguishedName::new();
    dn.push(DnType::CommonName, Sender::new(role, id).common_name());
    dn.push(DnType::OrganizationalUnitName, role.as_str());
    params.distinguished_name = dn;
    params.is_ca = IsCa::ExplicitNoCa;
    params.key_usages = vec![KeyUsagePurpose::DigitalSignature];
    // Every node is both a TLS server (it listens) and a client (it connects).
    params.extended_key_usages = vec![ExtendedKeyUsagePurpose::ServerAuth, ExtendedKeyUsagePurpose::ClientAuth];
    params.use_authority_key_identifier_extension = true;
    validity(&mut params, days);
    let cert = params.signed_by(&key, &issuer).map_err(|e| err(format!("cannot sign the certificate: {e}")))?;
    let (crt, kp) = (dir.join(format!("{id}.crt")), dir.join(format!("{id}.key")));
    if crt.exists() || kp.exists() {
        return Err(err(format!("{}: {id} already has a certificate here (not overwritten)", dir.display())));
    }
    write_file(&kp, &ed25519_v1_pem(&key)?, true)?;
    write_file(&crt, &cert.pem(), false)?;
    Ok((crt, kp))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::security::{Identity, SecuritySection};

    #[test]
    fn init_then_issue_gives_a_loadable_identity_and_nothing_is_overwritten() {
        let dir = std::env::temp_dir().join(format!("mrmm-pki-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        init(&dir).expect("init");
        assert!(init(&dir).unwrap_err().to_string().contains("already exists"));
        issue(&dir, Role::Robot, "r1", &["127.0.0.1".into()], 10).expect("issue");
        assert!(issue(&dir, Role::Robot, "r1", &[], 10).unwrap_err().to_string().contains("already"));
        assert!(issue(&dir, Role::Robot, "bad/id", &[], 10).is_err());
        let id = Identity::load("security", &SecuritySection::from_dir(&dir, "r1")).expect("load");
        assert_eq!(id.me, Sender::new(Role::Robot, "r1"));
        // A key that is not the certificate's is refused with one line.
        issue(&dir, Role::Operator, "op", &[], 10).expect("issue op");
        let mut mixed = SecuritySection::from_dir(&dir, "r1");
        mixed.key = dir.join("op.key");
        let e = Identity::load("security", &mixed).unwrap_err().to_string();
        assert!(e.starts_with("security.key: ") && e.contains("is not the key of") && !e.contains('\n'), "{e}");
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = std::fs::metadata(dir.join("r1.key")).expect("meta").permissions().mode();
            assert_eq!(mode & 0o077, 0, "keys are private");
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn keys_are_written_as_pkcs8_v1_and_both_versions_are_read() {
        let dir = tempfile_dir("v1");
        init(&dir).expect("init");
        issue(&dir, Role::Robot, "r1", &[], 10).expect("issue");
        for name in ["ca.key", "r1.key"] {
            let text = std::fs::read_to_string(dir.join(name)).expect("key");
            let (_, doc) = x509_parser::pem::parse_x509_pem(text.as_bytes()).expect("pem");
            assert_eq!(doc.label, "PRIVATE KEY");
            // RFC 8410's v1: 48 bytes, version 0, no public key.
            assert_eq!((doc.contents.len(), &doc.contents[..5]), (48, &[0x30, 0x2e, 0x02, 0x01, 0x00][..]), "{name}");
        }
        // The CA key is read back to issue more; a v2 key (as earlier versions wrote) still loads.
        issue(&dir, Role::Operator, "op", &[], 10).expect("issue with a v1 CA key");
        let v2 = ring::signature::Ed25519KeyPair::generate_pkcs8(&ring::rand::SystemRandom::new()).expect("v2");
        assert_eq!(v2.as_ref()[4], 1, "ring writes v2");
        let kp = KeyPair::try_from(v2.as_ref()).expect("v2 key");
        let v1 = ed25519_v1_pem(&kp).expect("v1");
        let back = KeyPair::from_pem(&v1).expect("v1 back");
        assert_eq!(back.public_key_raw(), kp.public_key_raw(), "the same key in both versions");
        assert!(Identity::load("security", &SecuritySection::from_dir(&dir, "r1")).is_ok());
        let _ = std::fs::remove_dir_all(&dir);
    }

    fn tempfile_dir(tag: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("mrmm-pki-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        dir
    }
}
