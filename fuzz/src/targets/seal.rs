//! The seal check every node runs on every message: an attachment (role, id, time, certificate,
//! signature) and a payload from anyone, against a fleet CA.

use crate::seal_fixture;

/// One input, as libFuzzer hands it over.
pub fn run(data: &[u8]) {
    let f = seal_fixture();
    // Two bytes of attachment length (little endian), the attachment, the payload.
    let Some((len, rest)) = data.split_first_chunk::<2>() else { return };
    let (att, payload) = rest.split_at(usize::from(u16::from_le_bytes(*len)).min(rest.len()));
    let _ = f.verifier.sender(&f.key, payload, Some(att), f.now_ms);
}
