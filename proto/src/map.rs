//! Maps as fleet data: a map named by its content hash ([`MapRef`]), what the operator sees of
//! it ([`MapInfo`]), and its bundle in chunks on `mrmm/maps/<hash>/<chunk>` ([`MapChunk`],
//! bincode behind `MRMP`): a map may exceed the message limit, and whoever asks checks the
//! whole against the hash.

use serde::{Deserialize, Serialize};

use crate::error::ProtoError;
use crate::geom::Point;

/// Bytes of one chunk of a map bundle.
pub const CHUNK_BYTES: usize = 512 * 1024;
/// Chunks of one map at most (64 MiB).
pub const MAX_CHUNKS: u32 = 128;
const MAGIC: &[u8; 4] = b"MRMP";

/// A map of the fleet: the name the operator gave it and the SHA-256 (hex) of its bundle.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MapRef {
    pub name: String,
    pub hash: String,
}

impl MapRef {
    /// Checks the name (one key chunk) and the hash (64 lower-case hex digits).
    pub fn check(&self) -> Result<(), ProtoError> {
        crate::keys::validate_id(&self.name)?;
        if crate::keys::is_hash(&self.hash) {
            Ok(())
        } else {
            Err(ProtoError::BadId(self.hash.clone()))
        }
    }
}

/// One row of `mrmm/system/maps`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MapInfo {
    pub name: String,
    /// `nav2`, `patrolling_sim` or `open_rmf`.
    pub format: String,
    /// Bytes of its files together.
    pub bytes: u64,
    pub hash: String,
    /// `1000 × 800 cells of 0.1 m, 2 412 m² free` or `163 vertices, 480 edges`.
    pub size: String,
    /// The box it covers, metres.
    pub min: Point,
    pub max: Point,
    /// A former version of a map central publishes under this name (its file changed since): kept
    /// in central's state dir and served for the missions journaled on it; new missions plan on
    /// the current one.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub superseded: bool,
    /// Where robots charge: a graph's vertices marked so (Open-RMF's `is_charger`) and those
    /// central's config names (`chargers`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub chargers: Vec<Charger>,
}

/// Chargers a map may have at most (central's config and the map's own together).
pub const MAX_CHARGERS: usize = 1024;

/// A place on a map where a robot charges.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Charger {
    /// The vertex's name on a graph map; `charger-<n>` for a point of a grid map.
    pub name: String,
    pub at: Point,
}

impl MapInfo {
    pub fn map_ref(&self) -> MapRef {
        MapRef { name: self.name.clone(), hash: self.hash.clone() }
    }
}

/// One chunk of a map bundle, the answer to `mrmm/maps/<hash>/<index>`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MapChunk {
    pub index: u32,
    pub total: u32,
    pub data: Vec<u8>,
}

impl MapChunk {
    pub fn encode(&self) -> Result<Vec<u8>, ProtoError> {
        let mut out = MAGIC.to_vec();
        out.extend(bincode::serde::encode_to_vec(self, bincode::config::standard()).map_err(ProtoError::encode)?);
        Ok(out)
    }

    /// Decodes and checks a chunk: index below total, total at most [`MAX_CHUNKS`], at most
    /// [`CHUNK_BYTES`] of data.
    pub fn decode(bytes: &[u8]) -> Result<Self, ProtoError> {
        let body = bytes.strip_prefix(MAGIC.as_slice()).ok_or_else(|| ProtoError::decode("map chunk", "no MRMP magic"))?;
        if body.len() > CHUNK_BYTES + 64 {
            return Err(ProtoError::decode("map chunk", format!("{} bytes, at most {}", body.len(), CHUNK_BYTES)));
        }
        let cfg = bincode::config::standard().with_limit::<{ CHUNK_BYTES + 64 }>();
        let (c, used): (MapChunk, usize) = bincode::serde::decode_from_slice(body, cfg).map_err(|e| ProtoError::decode("map chunk", e))?;
        if used != body.len() || c.total == 0 || c.total > MAX_CHUNKS || c.index >= c.total || c.data.len() > CHUNK_BYTES {
            return Err(ProtoError::decode("map chunk", format!("chunk {} of {} with {} bytes does not fit", c.index, c.total, c.data.len())));
        }
        Ok(c)
    }

    /// The chunks of `bytes`.
    pub fn split(bytes: &[u8]) -> Vec<MapChunk> {
        let total = bytes.len().div_ceil(CHUNK_BYTES).max(1) as u32;
        (0..total)
            .map(|i| MapChunk {
                index: i,
                total,
                data: bytes[(i as usize * CHUNK_BYTES).min(bytes.len())..((i as usize + 1) * CHUNK_BYTES).min(bytes.len())].to_vec(),
            })
            .collect()
    }
}

/// The answer to `mrmm/maps/<hash>/manifest`, from central only (sealed): the SHA-256 of each
/// chunk's data, in order. With it an asker checks every chunk as it arrives and takes it from
/// another holder when one answers with a bad one.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MapManifest {
    pub hash: String,
    pub chunks: Vec<String>,
}

impl MapManifest {
    /// The manifest of the bundle `bytes` (whose hash is `hash`).
    pub fn of(hash: &str, bytes: &[u8]) -> MapManifest {
        MapManifest { hash: hash.to_string(), chunks: MapChunk::split(bytes).iter().map(|c| content_hash(&c.data)).collect() }
    }

    /// The manifest from its chunks as they travel (each [`MapChunk::encode`]d).
    pub fn of_encoded(hash: &str, chunks: &[Vec<u8>]) -> Result<MapManifest, ProtoError> {
        let chunks = chunks.iter().map(|c| MapChunk::decode(c).map(|c| content_hash(&c.data))).collect::<Result<_, _>>()?;
        Ok(MapManifest { hash: hash.to_string(), chunks })
    }

    /// Whether it can be a manifest of map `hash`: that hash, 1 to [`MAX_CHUNKS`] chunk hashes.
    pub fn check(&self, hash: &str) -> Result<(), String> {
        if self.hash != hash || self.chunks.is_empty() || self.chunks.len() > MAX_CHUNKS as usize || self.chunks.iter().any(|c| c.len() != 64) {
            return Err(format!("not a manifest of map {hash}"));
        }
        Ok(())
    }
}

/// How long one chunk of a map may take to arrive.
pub const CHUNK_TIMEOUT: std::time::Duration = std::time::Duration::from_secs(5);

/// The SHA-256 of `bytes`, lower-case hex (a map bundle's content hash).
pub fn content_hash(bytes: &[u8]) -> String {
    use sha2::Digest;
    sha2::Sha256::digest(bytes).iter().map(|b| format!("{b:02x}")).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chunks_round_trip_and_bad_ones_are_refused() {
        let bytes: Vec<u8> = (0..(CHUNK_BYTES * 2 + 10)).map(|i| (i % 251) as u8).collect();
        let chunks = MapChunk::split(&bytes);
        assert_eq!(chunks.len(), 3);
        let mut back = Vec::new();
        for c in &chunks {
            let d = MapChunk::decode(&c.encode().unwrap()).unwrap();
            assert_eq!(&d, c);
            back.extend(d.data);
        }
        assert_eq!(back, bytes);
        let bad = MapChunk { index: 3, total: 3, data: vec![] }.encode().unwrap();
        assert!(MapChunk::decode(&bad).is_err());
        assert!(MapChunk::decode(b"MRMP\xff\xff\xff\xff\xff").is_err());
        assert!(MapChunk::decode(b"nope").is_err());
        assert!(crate::keys::is_hash(&"ab".repeat(32)) && !crate::keys::is_hash(&"AB".repeat(32)) && !crate::keys::is_hash("ab"));
        // The SHA-256 of "abc" (FIPS 180-2's example).
        assert_eq!(content_hash(b"abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
    }
}
