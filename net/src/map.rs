//! A map bundle fetched from whichever node holds it, chunk by chunk, over Zenoh queries.
//!
//! With central up, the fetch first asks central for the map's manifest (the hash of every
//! chunk, sealed by central): each chunk is then checked as it arrives, and a holder answering
//! with a bad chunk is passed over for another. Without central (a takeover while it is down), any
//! holder's chunks are taken and the whole bundle is checked against its hash at the end.

use std::time::Duration;

use mrmm_proto::map::{content_hash, MapChunk, MapManifest, MapRef, CHUNK_BYTES, CHUNK_TIMEOUT};
use mrmm_proto::{Key, Role};

use crate::Mesh;

/// How long a fetch waits for central's manifest.
const MANIFEST_TIMEOUT: Duration = Duration::from_secs(2);

/// The bundle of map `r` from whichever node holds it, chunk by chunk, checked against its
/// hash: no seal is needed on the chunks, whoever answers.
pub async fn fetch(mesh: &Mesh, r: &MapRef) -> Result<Vec<u8>, String> {
    r.check().map_err(|e| format!("map {}: {e}", r.name))?;
    let manifest = manifest(mesh, &r.hash).await;
    let session = mesh.session();
    let want = |i: u32| manifest.as_ref().and_then(|m| m.chunks.get(i as usize)).map(String::as_str);
    let first = chunk(session, &r.hash, 0, want(0)).await?;
    let total = first.total;
    if let Some(m) = &manifest {
        if m.chunks.len() != total as usize {
            return Err(format!("map {}: {total} chunks, central's manifest says {}", r.name, m.chunks.len()));
        }
    }
    let mut bytes = Vec::with_capacity(total as usize * CHUNK_BYTES);
    bytes.extend(first.data);
    for i in 1..total {
        let c = chunk(session, &r.hash, i, want(i)).await?;
        if c.total != total {
            return Err(format!("map {}: chunk {i} says {} chunks, chunk 0 said {total}", r.name, c.total));
        }
        bytes.extend(c.data);
    }
    let got = content_hash(&bytes);
    if got != r.hash {
        return Err(format!("map {}: what arrived hashes to {got}, not {}", r.name, r.hash));
    }
    Ok(bytes)
}

/// Central's manifest of map `hash`, if central answers (sealed by it) in time.
async fn manifest(mesh: &Mesh, hash: &str) -> Option<MapManifest> {
    let key = Key::MapManifest { hash: hash.to_string() }.to_string();
    match mesh.query::<MapManifest>(&key, None, MANIFEST_TIMEOUT, |s| s.role == Role::Central).await {
        Ok((m, _)) if m.check(hash).is_ok() => Some(m),
        Ok(_) => {
            tracing::warn!(%key, "central's manifest does not fit its map: chunks checked at the end only");
            None
        }
        Err(e) => {
            tracing::debug!(%key, "no manifest from central ({e}): chunks checked at the end only");
            None
        }
    }
}

/// Chunk `index` of map `hash` from the nearest node that holds it; then from anyone. With the
/// chunk's hash (`want`), an answer whose data does not hash to it is dropped and the next
/// holder's taken.
async fn chunk(session: &zenoh::Session, hash: &str, index: u32, want: Option<&str>) -> Result<MapChunk, String> {
    use zenoh::query::{ConsolidationMode, QueryTarget};
    let key = Key::MapChunk { hash: hash.to_string(), index }.to_string();
    let mut last = format!("no node answered for {key}");
    for target in [QueryTarget::BestMatching, QueryTarget::All] {
        let replies =
            session.get(&key).target(target).consolidation(ConsolidationMode::None).timeout(CHUNK_TIMEOUT).await.map_err(|e| format!("{key}: {e}"))?;
        while let Ok(reply) = replies.recv_async().await {
            match reply.result() {
                Ok(s) => match MapChunk::decode(&s.payload().to_bytes()) {
                    Ok(c) if c.index == index && want.is_none_or(|w| content_hash(&c.data) == w) => return Ok(c),
                    Ok(c) if c.index == index => {
                        tracing::warn!(%key, "a chunk that does not hash as central's manifest says: dropped, asking another holder");
                        last = format!("{key}: a chunk that does not hash as central's manifest says");
                    }
                    Ok(c) => last = format!("{key}: answered with chunk {}", c.index),
                    Err(e) => last = format!("{key}: {e}"),
                },
                Err(e) => last = format!("{key}: {}", String::from_utf8_lossy(&e.payload().to_bytes()).chars().take(200).collect::<String>()),
            }
        }
    }
    Err(last)
}
