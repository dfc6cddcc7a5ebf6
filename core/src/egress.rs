//! A node's edge, outward: what a machine's command means on the network — a key, a payload and
//! whom it is for ([`Out`]) — and what each machine listens to ([`Sub`]). The drivers put an
//! `Out` on Zenoh and declare the `Sub`s there; the simulations deliver an `Out` to every machine
//! whose `Sub`s take its key in. One translation for both, as [`crate::edge`] is inward.

use mrmm_proto::{Key, Sender};

/// A publication, as it goes on the network.
#[derive(Debug, Clone, PartialEq)]
pub struct Out {
    pub key: Key,
    pub payload: Vec<u8>,
    pub to: Audience,
}

/// Whom a publication is for: what its seal says.
#[derive(Debug, Clone, PartialEq)]
pub enum Audience {
    /// Whoever is entitled to hear the key (the seal is a signature anyone can check).
    Fleet,
    /// These receivers (the seal is tagged for them; others refuse it as not theirs).
    Only(Vec<Sender>),
}

impl Out {
    /// `body` as JSON on `key`, for `to`; `None` (logged) if it cannot be encoded, which no type
    /// of the protocol does.
    pub fn json<T: serde::Serialize>(key: Key, body: &T, to: Audience) -> Option<Out> {
        Out::encoded(key, mrmm_proto::to_json(body), to)
    }

    /// `body` as JSON on `key`, compressed when large ([`mrmm_proto::to_json_packed`]): for what
    /// only the fleet reads, as chain messages carrying a mission's plans.
    pub fn packed<T: serde::Serialize>(key: Key, body: &T, to: Audience) -> Option<Out> {
        Out::encoded(key, mrmm_proto::to_json_packed(body), to)
    }

    fn encoded(key: Key, payload: Result<Vec<u8>, mrmm_proto::ProtoError>, to: Audience) -> Option<Out> {
        match payload {
            Ok(payload) => Some(Out { key, payload, to }),
            Err(e) => {
                tracing::warn!("cannot encode for {key}: {e}");
                None
            }
        }
    }
}

pub use mrmm_proto::matching::{heard, Sub};

#[cfg(test)]
mod tests {
    use super::*;
    use mrmm_proto::Pattern;

    #[test]
    fn a_remote_subscription_does_not_hear_its_own_node() {
        let sub = Sub::remote(Pattern::TeamSync("p".into()));
        let key = Key::TeamSync { team: "p".into(), point: 0, round: 1 }.to_string();
        assert!(sub.takes(&key, false));
        assert!(!sub.takes(&key, true));
        assert!(Sub::any(Pattern::TeamSync("p".into())).takes(&key, true));
        assert!(!sub.takes(&Key::TeamSync { team: "p/air".into(), point: 0, round: 1 }.to_string(), false));
    }
}
