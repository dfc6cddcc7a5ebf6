//! What a robot with a `state_dir` keeps there of its own across a restart: its capabilities as
//! changed at runtime (a camera that broke stays broken after a power cycle). The file also holds
//! the config's list they were changed from: once the config says something else (the camera
//! was repaired and the config edited), the config wins.

use std::io::Write;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::PeerError;

/// The file in the state dir.
pub const FILE: &str = "capabilities.json";
/// Largest file read back (a damaged one is refused, never read whole).
const MAX_BYTES: u64 = 64 * 1024;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Kept {
    /// The config's capabilities when they were changed.
    configured: Vec<String>,
    /// The capabilities after the change.
    now: Vec<String>,
}

fn path(dir: &Path) -> PathBuf {
    dir.join(FILE)
}

/// The capabilities kept in `dir`, if they were changed from exactly `configured`.
pub fn load(dir: &Path, configured: &[String]) -> Result<Option<Vec<String>>, PeerError> {
    let p = path(dir);
    let bad = |e: String| PeerError::Config(format!("{}: {e}", p.display()));
    let meta = match std::fs::metadata(&p) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(bad(e.to_string())),
    };
    if meta.len() > MAX_BYTES {
        return Err(bad(format!("{} bytes, more than a capabilities file holds", meta.len())));
    }
    let text = std::fs::read(&p).map_err(|e| bad(e.to_string()))?;
    let kept: Kept = serde_json::from_slice(&text).map_err(|e| bad(e.to_string()))?;
    mrmm_proto::check_capabilities(&kept.now).map_err(bad)?;
    Ok((kept.configured == configured).then_some(kept.now))
}

/// Keeps `now`, changed from the config's `configured`, in `dir` (written whole and synced, then
/// renamed over the old file: a crash leaves the old file or the new one).
pub fn save(dir: &Path, configured: &[String], now: &[String]) -> Result<(), PeerError> {
    let p = path(dir);
    let io = |e: std::io::Error| PeerError::Config(format!("{}: {e}", p.display()));
    let body = serde_json::to_vec_pretty(&Kept { configured: configured.to_vec(), now: now.to_vec() }).map_err(|e| PeerError::Config(e.to_string()))?;
    let tmp = dir.join(format!("{FILE}.tmp"));
    {
        let mut f = std::fs::File::create(&tmp).map_err(io)?;
        f.write_all(&body).map_err(io)?;
        f.sync_all().map_err(io)?;
    }
    std::fs::rename(&tmp, &p).map_err(io)?;
    if let Ok(d) = std::fs::File::open(dir) {
        let _ = d.sync_all();
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(s: &[&str]) -> Vec<String> {
        s.iter().map(|x| x.to_string()).collect()
    }

    #[test]
    fn kept_until_the_config_changes_and_a_damaged_file_is_refused() {
        let dir = std::env::temp_dir().join(format!("mrmm-kept-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        assert_eq!(load(&dir, &v(&["camera"])).expect("none yet"), None);
        save(&dir, &v(&["camera"]), &v(&["lidar"])).expect("save");
        assert_eq!(load(&dir, &v(&["camera"])).expect("load"), Some(v(&["lidar"])));
        assert_eq!(load(&dir, &v(&["camera", "gripper"])).expect("load"), None, "the config changed since: it wins");
        std::fs::write(dir.join(FILE), b"{\"configured\": [], \"now\": [\"a b\"]}").expect("write");
        assert!(load(&dir, &[]).unwrap_err().to_string().contains("bad capability"));
        std::fs::write(dir.join(FILE), b"{ not json").expect("write");
        assert!(load(&dir, &[]).unwrap_err().to_string().contains(FILE));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
