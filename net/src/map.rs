//! A map bundle fetched from whichever node holds it, chunk by chunk, over Zenoh queries.

use mrmm_proto::map::{content_hash, MapChunk, MapRef, CHUNK_BYTES, CHUNK_TIMEOUT};
use mrmm_proto::Key;

/// The bundle of map `r` from whichever node holds it, chunk by chunk, checked against its
/// hash: no seal is needed, whoever answers.
pub async fn fetch(session: &zenoh::Session, r: &MapRef) -> Result<Vec<u8>, String> {
    r.check().map_err(|e| format!("map {}: {e}", r.name))?;
    let first = chunk(session, &r.hash, 0).await?;
    let total = first.total;
    let mut bytes = Vec::with_capacity(total as usize * CHUNK_BYTES);
    bytes.extend(first.data);
    for i in 1..total {
        let c = chunk(session, &r.hash, i).await?;
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

/// Chunk `index` of map `hash` from the nearest node that holds it; then from anyone.
async fn chunk(session: &zenoh::Session, hash: &str, index: u32) -> Result<MapChunk, String> {
    use zenoh::query::{ConsolidationMode, QueryTarget};
    let key = Key::MapChunk { hash: hash.to_string(), index }.to_string();
    let mut last = format!("no node answered for {key}");
    for target in [QueryTarget::BestMatching, QueryTarget::All] {
        let replies =
            session.get(&key).target(target).consolidation(ConsolidationMode::None).timeout(CHUNK_TIMEOUT).await.map_err(|e| format!("{key}: {e}"))?;
        while let Ok(reply) = replies.recv_async().await {
            match reply.result() {
                Ok(s) => match MapChunk::decode(&s.payload().to_bytes()) {
                    Ok(c) if c.index == index => return Ok(c),
                    Ok(c) => last = format!("{key}: answered with chunk {}", c.index),
                    Err(e) => last = format!("{key}: {e}"),
                },
                Err(e) => last = format!("{key}: {}", String::from_utf8_lossy(&e.payload().to_bytes()).chars().take(200).collect::<String>()),
            }
        }
    }
    Err(last)
}
