//! The seals' checks: what a signature or a tag proves, and to whom; garbage refused.

use super::*;
use crate::security::pki;

fn fleet() -> (tempdir::Dir, Verifier) {
    let d = tempdir::Dir::new();
    pki::init(d.path()).expect("init");
    let v = Verifier::secure(&pki::read_ca_der(d.path()).expect("ca"), 60).expect("verifier");
    (d, v)
}

mod tempdir {
    pub struct Dir(std::path::PathBuf);
    impl Dir {
        pub fn new() -> Dir {
            use std::sync::atomic::{AtomicU32, Ordering};
            static N: AtomicU32 = AtomicU32::new(0);
            let p = std::env::temp_dir().join(format!("mrmm-seal-{}-{}", std::process::id(), N.fetch_add(1, Ordering::Relaxed)));
            let _ = std::fs::remove_dir_all(&p);
            std::fs::create_dir_all(&p).expect("dir");
            Dir(p)
        }
        pub fn path(&self) -> &std::path::Path {
            &self.0
        }
    }
    impl Drop for Dir {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

fn identity(dir: &std::path::Path, role: Role, id: &str) -> Identity {
    pki::issue(dir, role, id, &[], 30).expect("issue");
    Identity::load("security", &crate::security::SecuritySection::from_dir(dir, id)).expect("load")
}

#[test]
fn a_signed_seal_proves_its_sender_and_nothing_else() {
    let (d, v) = fleet();
    let s = Sealer::secure(identity(d.path(), Role::Robot, "r1"));
    let t = crate::mesh::now_ms();
    let (k1, k2) = (mrmm_proto::Key::RobotTelemetry("r1".into()).to_string(), mrmm_proto::Key::RobotTelemetry("r2".into()).to_string());
    let att = s.seal(&k1, b"hello", t);
    assert_eq!(v.sender(&k1, b"hello", Some(&att), t + 10), Ok(Sender::new(Role::Robot, "r1")));
    // Another payload, another key, too late, no seal.
    assert!(matches!(v.sender(&k1, b"hellO", Some(&att), t), Err(Refusal::Signature { .. })));
    assert!(matches!(v.sender(&k2, b"hello", Some(&att), t), Err(Refusal::Signature { .. })));
    assert!(matches!(v.sender(&k1, b"hello", Some(&att), t + 61_000), Err(Refusal::Stale { .. })));
    assert_eq!(v.sender("k", b"", None, t), Err(Refusal::Missing));
    // An unsigned claim is refused by a secure verifier, taken by an insecure one.
    let claim = Sealer::insecure(Sender::new(Role::Operator, "op")).seal("k", b"x", t);
    assert!(matches!(v.sender("k", b"x", Some(&claim), t), Err(Refusal::Unsigned { .. })));
    assert_eq!(Verifier::insecure().sender("k", b"x", Some(&claim), t), Ok(Sender::new(Role::Operator, "op")));
}

#[test]
fn a_seal_claiming_another_id_or_another_ca_is_refused() {
    let (d, v) = fleet();
    let s = Sealer::secure(identity(d.path(), Role::Robot, "r1"));
    let t = crate::mesh::now_ms();
    // Rewrite the claimed id inside a real seal: r1's certificate, r2 claimed.
    let mut att = s.seal("k", b"x", t);
    let at = 3 + 1 + 1 + 1;
    att[at + 1] = b'2';
    assert!(matches!(v.sender("k", b"x", Some(&att), t), Err(Refusal::Mismatch { .. })));
    // A whole other fleet.
    let other = tempdir::Dir::new();
    pki::init(other.path()).expect("init");
    let rogue = Sealer::secure(identity(other.path(), Role::Operator, "op"));
    let att = rogue.seal("k", b"x", t);
    assert!(matches!(v.sender("k", b"x", Some(&att), t), Err(Refusal::Certificate { .. })));
}

#[test]
fn a_tagged_seal_proves_its_sender_to_its_receivers_only() {
    use crate::security::pair::{self, Pairs};
    let (d, _) = fleet();
    let ca = pki::read_ca_der(d.path()).expect("ca");
    let (a, b, c) = (identity(d.path(), Role::Robot, "r1"), identity(d.path(), Role::Robot, "r2"), identity(d.path(), Role::Robot, "r3"));
    let verifier = |i: &Identity| Verifier::secure(&ca, 60).expect("verifier").with_pairs(std::sync::Arc::new(Pairs::new(i.pair_secret())));
    let (va, vb, vc) = (verifier(&a), verifier(&b), verifier(&c));
    let (sa, sb) = (Sealer::secure(a), Sealer::secure(b));
    let (r1, r2) = (Sender::new(Role::Robot, "r1"), Sender::new(Role::Robot, "r2"));
    let pairs = |v: &Verifier| v.pairs().expect("pairs").for_receivers(std::slice::from_ref(&r2));
    let t = crate::mesh::now_ms();
    // r1 has not heard r2 yet: nothing to tag with (its message is signed).
    assert!(pairs(&va).0.is_empty() && !pairs(&va).1);
    // r2's signed message proves it to r1 (and to r3), who learn it.
    let att = sb.seal("k", b"x", t);
    assert_eq!(va.sender("k", b"x", Some(&att), t), Ok(r2.clone()));
    assert_eq!(vc.sender("k", b"x", Some(&att), t), Ok(r2.clone()));
    let (tags, all) = pairs(&va);
    assert!(all && tags.len() == 1);
    let att = sa.seal_for("k", b"hello", t, &tags, false, false);
    assert!(att.len() < sa.seal("k", b"hello", t).len(), "a tag is shorter than a signature");
    assert_eq!(vb.sender("k", b"hello", Some(&att), t), Ok(r1.clone()));
    assert!(matches!(vb.sender("k", b"hellO", Some(&att), t), Err(Refusal::Signature { .. })));
    assert!(matches!(vb.sender("k2", b"hello", Some(&att), t), Err(Refusal::Signature { .. })));
    assert!(matches!(vb.sender("k", b"hello", Some(&att), t + 61_000), Err(Refusal::Stale { .. })));
    // Not for r3: refused, except as what a viewer shows (the certificate's node).
    assert!(matches!(vc.sender("k", b"hello", Some(&att), t), Err(Refusal::Unaddressed { .. })));
    assert_eq!(vc.observed_sender("k", b"hello", Some(&att), t), Ok(r1.clone()));
    // r3 knows r2 too, but its key with r2 is not r1's: a tag it makes as r1 is refused.
    let (tags3, _) = pairs(&vc);
    let seal = decode(&att).expect("decode");
    let forged_tag = pair::tag(&tags3[0].1, digest_of(&r1, t, "k", b"hello").as_ref(), &tags3[0].0);
    let mut forged = att.clone();
    let at = forged.len() - pair::TAG_LEN;
    forged[at..].copy_from_slice(&forged_tag);
    assert_eq!(seal.tag_for(&tags3[0].0).map(<[u8]>::len), Some(pair::TAG_LEN));
    assert!(matches!(vb.sender("k", b"hello", Some(&forged), t), Err(Refusal::Signature { .. })));
    // More receivers than a seal has room for: the first get tags, and it is signed for the rest.
    let many: Vec<_> = std::iter::repeat_n(tags[0].clone(), MAX_TAGS + 1).collect();
    let att = sa.seal_for("k", b"hi", t, &many, false, false);
    assert_eq!(decode(&att).map(|s| (s.signature.is_some(), s.tags.len())), Ok((true, MAX_TAGS * TAG_ENTRY)));
    // Tagged and signed (r1 did not know every receiver): r2 checks its tag, r3 the signature.
    let att = sa.seal_for("k", b"hi", t, &tags, true, false);
    assert_eq!(vb.sender("k", b"hi", Some(&att), t), Ok(r1.clone()));
    assert_eq!(vc.sender("k", b"hi", Some(&att), t), Ok(r1));
}

#[test]
fn a_seal_naming_its_certificate_by_id_proves_it_only_where_that_certificate_was_proven() {
    use crate::security::pair::Pairs;
    let (d, _) = fleet();
    let ca = pki::read_ca_der(d.path()).expect("ca");
    let (a, b) = (identity(d.path(), Role::Robot, "r1"), identity(d.path(), Role::Host, "h1"));
    let vb = Verifier::secure(&ca, 60).expect("verifier").with_pairs(std::sync::Arc::new(Pairs::new(b.pair_secret())));
    let va = Verifier::secure(&ca, 60).expect("verifier").with_pairs(std::sync::Arc::new(Pairs::new(a.pair_secret())));
    let (r1, h1) = (Sender::new(Role::Robot, "r1"), Sender::new(Role::Host, "h1"));
    let (sa, sb) = (Sealer::secure(a), Sealer::secure(b));
    let t = crate::mesh::now_ms();
    // r1 heard h1: it can tag for h1.
    assert_eq!(va.sender("k", b"x", Some(&sb.seal("k", b"x", t)), t), Ok(h1.clone()));
    let (tags, _) = va.pairs().expect("pairs").for_receivers(std::slice::from_ref(&h1));
    let by_id = sa.seal_for("k", b"pose", t, &tags, false, true);
    let full = sa.seal_for("k", b"pose", t, &tags, false, false);
    assert!(by_id.len() + 300 < full.len(), "{} vs {} bytes", by_id.len(), full.len());
    assert!(matches!(decode(&by_id).map(|s| s.cert), Ok(Some(CertRef::Id(_)))));
    // h1 has not proven r1's certificate yet: refused as unseen (not logged), then taken once it
    // has (a message carrying it).
    assert!(matches!(vb.sender("k", b"pose", Some(&by_id), t), Err(Refusal::Unseen { .. })));
    assert_eq!(vb.sender("k", b"pose", Some(&full), t), Ok(r1.clone()));
    assert_eq!(vb.sender("k", b"pose", Some(&by_id), t), Ok(r1.clone()));
    assert!(matches!(vb.sender("k", b"posE", Some(&by_id), t), Err(Refusal::Signature { .. })));
    // The id names the certificate, the claim must still match it.
    let mut claim = by_id.clone();
    claim[3 + 1 + 1 + 1 + 1] = b'2';
    assert!(matches!(vb.sender("k", b"pose", Some(&claim), t), Err(Refusal::Mismatch { .. })));
    // Signed seals always carry the certificate; an id with a signature, or without tags, is
    // malformed.
    let signed = sa.seal_for("k", b"pose", t, &tags, true, true);
    assert!(matches!(decode(&signed).map(|s| s.cert), Ok(Some(CertRef::Der(_)))));
    for bad_flags in [4u8, 5, 7] {
        let mut bad = by_id.clone();
        bad[3] = bad_flags;
        assert_eq!(decode(&bad).err(), Some(Refusal::Malformed("flags")), "flags {bad_flags}");
    }
}

#[test]
fn garbage_attachments_are_refused_without_panic() {
    let v = Verifier::insecure();
    for att in [&b""[..], b"MS1", b"XYZ\0\0\x02r1", b"MS1\x00\x09\x02r1\0\0\0\0\0\0\0\0", b"MS1\x00\x02\x02r1\0\0\0\0\0\0\0\0\0"] {
        assert!(v.sender("k", b"", Some(att), 0).is_err(), "{att:?}");
    }
    let mut ok = Sealer::insecure(Sender::new(Role::Robot, "r1")).seal("k", b"", 5);
    assert!(v.sender("k", b"", Some(&ok), 0).is_ok());
    ok[3] = 1; // claims a signature it does not carry
    assert!(matches!(v.sender("k", b"", Some(&ok), 0), Err(Refusal::Malformed(_))));
}

#[test]
fn a_stream_signs_its_first_message_then_one_per_interval_whatever_its_rate() {
    let mut c = SignCadence::new(2000);
    assert!(c.due(10_000));
    // 1 000 messages within the interval: none signed.
    assert!((1..1000).all(|i| !c.due(10_000 + i)));
    assert!(c.due(12_000));
    assert!(!c.due(12_001));
    // A clock that went back signs at once, then counts from there.
    assert!(c.due(5_000));
    assert!(!c.due(6_999));
    assert!(c.due(7_000));
}
