//! Pair keys: one symmetric key for each pair of fleet nodes, derived from their certificates'
//! Ed25519 keys (the same curve in its X25519 form: static Diffie-Hellman, then HKDF-SHA256), so
//! that a message meant for receivers the sender knows carries one 16-byte HMAC tag per receiver
//! instead of a signature every receiver must check (a tag costs about a microsecond, an Ed25519
//! check about fifty). Only the two nodes of a pair can make a tag under its key, so a tag proves
//! the sender to its receiver end to end, however the message travelled.

use std::collections::HashMap;
use std::sync::Mutex;

use curve25519_dalek::edwards::{CompressedEdwardsY, EdwardsPoint};
use ring::{digest, hkdf, hmac};

use super::Sender;

/// Bytes of a tag (HMAC-SHA256, truncated).
pub const TAG_LEN: usize = 16;
/// Bytes naming a receiver's key in a seal.
pub const KEY_ID_LEN: usize = 8;
/// A receiver's key id: the first bytes of SHA-256 of its Ed25519 public key.
pub type KeyId = [u8; KEY_ID_LEN];

const SALT: &[u8] = b"mrmm-pair/1";
const TAG_DOMAIN: &[u8] = b"mrmm-tag/1\0";
/// Pair keys and known peers remembered; beyond this a cache starts over.
const CACHE_MAX: usize = 4096;

/// The key id of `public_key`.
pub fn key_id(public_key: &[u8]) -> KeyId {
    let h = digest::digest(&digest::SHA256, public_key);
    let mut id = [0u8; KEY_ID_LEN];
    id.copy_from_slice(&h.as_ref()[..KEY_ID_LEN]);
    id
}

/// This node's half of every pair: the X25519 form of its Ed25519 key.
#[derive(Clone)]
pub struct PairSecret {
    scalar: [u8; 32],
    public: [u8; 32],
    id: KeyId,
}

impl std::fmt::Debug for PairSecret {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PairSecret").field("id", &self.id).finish_non_exhaustive()
    }
}

impl PairSecret {
    /// From the node's Ed25519 key (PKCS#8 DER, as `mrmm pki issue` writes it) and the public key
    /// of its certificate, which the key must give.
    pub fn from_pkcs8(der: &[u8], public: &[u8]) -> Result<PairSecret, String> {
        // PKCS#8 v1 or v2 of an Ed25519 key: SEQUENCE { INTEGER 0|1, SEQUENCE { OID 1.3.101.112 },
        // OCTET STRING { OCTET STRING (32-byte seed) }, … }: the seed starts at byte 16.
        const ALG_AND_SEED_HEADER: [u8; 11] = [0x30, 0x05, 0x06, 0x03, 0x2b, 0x65, 0x70, 0x04, 0x22, 0x04, 0x20];
        let seed = match der.get(5..16).zip(der.get(16..48)) {
            Some((header, seed)) if der.first() == Some(&0x30) && header == ALG_AND_SEED_HEADER => seed,
            _ => return Err("not an Ed25519 PKCS#8 key".into()),
        };
        let h = digest::digest(&digest::SHA512, seed);
        let mut scalar = [0u8; 32];
        scalar.copy_from_slice(&h.as_ref()[..32]);
        let derived = EdwardsPoint::mul_base_clamped(scalar).compress().to_bytes();
        if derived.as_slice() != public {
            return Err("the key is not the certificate's".into());
        }
        Ok(PairSecret { scalar, public: derived, id: key_id(&derived) })
    }

    pub fn id(&self) -> KeyId {
        self.id
    }

    /// The key this node shares with the owner of `peer_public` (an Ed25519 public key); `None`
    /// for a key that is not a point of the curve or of small order.
    pub fn key_with(&self, peer_public: &[u8]) -> Option<hmac::Key> {
        let bytes: [u8; 32] = peer_public.try_into().ok()?;
        let point = CompressedEdwardsY(bytes).decompress()?;
        if point.is_small_order() {
            return None;
        }
        let shared = point.to_montgomery().mul_clamped(self.scalar).to_bytes();
        if shared == [0u8; 32] {
            return None;
        }
        // Both ends list the two public keys in the same order.
        let (a, b) = if self.public <= bytes { (self.public, bytes) } else { (bytes, self.public) };
        let info = [a.as_slice(), b.as_slice()];
        let prk = hkdf::Salt::new(hkdf::HKDF_SHA256, SALT).extract(&shared);
        let okm = prk.expand(&info, hmac::HMAC_SHA256).ok()?;
        Some(hmac::Key::from(okm))
    }
}

/// The tag of a message (its seal digest) for the receiver `to`, under their pair key.
pub fn tag(key: &hmac::Key, seal_digest: &[u8], to: &KeyId) -> [u8; TAG_LEN] {
    let mut c = hmac::Context::with_key(key);
    c.update(TAG_DOMAIN);
    c.update(seal_digest);
    c.update(to);
    let full = c.sign();
    let mut t = [0u8; TAG_LEN];
    t.copy_from_slice(&full.as_ref()[..TAG_LEN]);
    t
}

/// Compares two tags in constant time.
pub fn same_tag(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

/// This node's pair keys, and the peers it knows (from their proven seals).
#[derive(Debug)]
pub struct Pairs {
    secret: PairSecret,
    keys: Mutex<HashMap<[u8; 32], Option<hmac::Key>>>,
    known: Mutex<HashMap<Sender, [u8; 32]>>,
}

impl Pairs {
    pub fn new(secret: PairSecret) -> Pairs {
        Pairs { secret, keys: Mutex::new(HashMap::new()), known: Mutex::new(HashMap::new()) }
    }

    pub fn my_id(&self) -> KeyId {
        self.secret.id
    }

    /// The pair key with the owner of `peer_public` (cached).
    pub fn key(&self, peer_public: &[u8]) -> Option<hmac::Key> {
        let k: [u8; 32] = peer_public.try_into().ok()?;
        if let Some(hit) = self.keys.lock().ok().and_then(|m| m.get(&k).cloned()) {
            return hit;
        }
        let key = self.secret.key_with(&k);
        if let Ok(mut m) = self.keys.lock() {
            if m.len() >= CACHE_MAX {
                m.clear();
            }
            m.insert(k, key.clone());
        }
        key
    }

    /// Remembers that `sender` proved itself with `public`.
    pub fn learn(&self, sender: &Sender, public: &[u8]) {
        let Ok(k) = <[u8; 32]>::try_from(public) else { return };
        if let Ok(mut m) = self.known.lock() {
            if m.get(sender) == Some(&k) {
                return;
            }
            if m.len() >= CACHE_MAX {
                m.clear();
            }
            m.insert(sender.clone(), k);
        }
    }

    /// The peers this node knows that `pred` accepts (at most [`super::seal::MAX_TAGS`]).
    pub fn known_where(&self, pred: impl Fn(&Sender) -> bool) -> Vec<Sender> {
        self.known.lock().map(|m| m.keys().filter(|s| pred(s)).take(super::seal::MAX_TAGS).cloned().collect()).unwrap_or_default()
    }

    /// Whether this node has learnt `sender`'s key.
    pub fn knows(&self, sender: &Sender) -> bool {
        self.known.lock().map(|m| m.contains_key(sender)).unwrap_or(false)
    }

    /// The (key id, pair key) of each of `to` this node knows, and whether it knows them all.
    pub fn for_receivers(&self, to: &[Sender]) -> (Vec<(KeyId, hmac::Key)>, bool) {
        let publics: Vec<Option<[u8; 32]>> = match self.known.lock() {
            Ok(m) => to.iter().map(|s| m.get(s).copied()).collect(),
            Err(_) => return (vec![], false),
        };
        let mut out = Vec::with_capacity(to.len());
        let mut all = true;
        for p in publics {
            match p.and_then(|p| self.key(&p).map(|k| (key_id(&p), k))) {
                Some(x) => out.push(x),
                None => all = false,
            }
        }
        (out, all)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ring::signature::{Ed25519KeyPair, KeyPair};

    fn node() -> (PairSecret, Vec<u8>, Vec<u8>) {
        let doc = Ed25519KeyPair::generate_pkcs8(&ring::rand::SystemRandom::new()).expect("pkcs8");
        let kp = Ed25519KeyPair::from_pkcs8(doc.as_ref()).expect("key");
        let public = kp.public_key().as_ref().to_vec();
        (PairSecret::from_pkcs8(doc.as_ref(), &public).expect("pair secret"), public, doc.as_ref().to_vec())
    }

    #[test]
    fn both_ends_of_a_pair_share_a_key_no_third_node_has() {
        let ((a, pa, _), (b, pb, _), (c, _, _)) = (node(), node(), node());
        let d = [7u8; 32];
        let ab = a.key_with(&pb).expect("a-b");
        let ba = b.key_with(&pa).expect("b-a");
        assert_eq!(tag(&ab, &d, &b.id()), tag(&ba, &d, &b.id()));
        let cb = c.key_with(&pb).expect("c-b");
        assert_ne!(tag(&cb, &d, &b.id()), tag(&ab, &d, &b.id()), "c cannot tag as a for b");
        let ca = c.key_with(&pa).expect("c-a");
        assert_ne!(tag(&ca, &d, &b.id()), tag(&ab, &d, &b.id()));
        assert!(!same_tag(&tag(&ab, &d, &a.id()), &tag(&ab, &d, &b.id())), "a tag names its receiver");
    }

    #[test]
    fn a_key_not_the_certificates_or_a_bad_point_gives_nothing() {
        let ((a, _, doc), (_, pb, _)) = (node(), node());
        assert!(PairSecret::from_pkcs8(&doc, &pb).is_err());
        assert!(PairSecret::from_pkcs8(b"\x30\x00", &pb).is_err());
        assert!(a.key_with(&[0u8; 31]).is_none());
        // The identity point (small order).
        let mut id = [0u8; 32];
        id[0] = 1;
        assert!(a.key_with(&id).is_none());
    }
}
