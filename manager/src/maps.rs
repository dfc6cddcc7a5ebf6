//! Maps as fleet data on a node: the maps it holds (read from files by central, fetched from the
//! fleet by everyone else), served in chunks to any node that asks by hash, and fetched the same
//! way. A map is named by the SHA-256 of its bundle, so whoever answers, the asker checks what it
//! got: no seal is needed, and a takeover with central gone gets the map from any node that has
//! it.
//!
//! Maps are the fleet's, not anyone's: a planner service plans only on a map central publishes
//! (central's own store fetches nothing; another node's asks central's list first), fetches run
//! a few at a time and are decoded off the async workers, and fetched maps live in a cache with a
//! memory budget ([`CACHE_BUDGET`], least recently used evicted, fetched again when needed).

use std::collections::{BTreeMap, HashMap, HashSet};
use std::path::Path;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use mrmm_maps::Bundle;
use mrmm_net::Mesh;
use mrmm_proto::{Key, MapRef};
use tokio_util::sync::CancellationToken;
use zenoh::query::Queryable;

use crate::error::ManagerError;

use mrmm_core::maps::Held;

/// Reads the map at `path` for the fleet under `name`: one readable line if it cannot be.
pub fn load_file(name: &str, path: &Path) -> Result<Held, ManagerError> {
    load_file_bundle(name, path, None).map(|(held, _)| held)
}

/// [`load_file`] (a graph map on the floor plan at `plan`, if one is given: see
/// [`Bundle::collect_on_plan`]), and the bundle's bytes (what its hash names).
fn load_file_bundle(name: &str, path: &Path, plan: Option<&Path>) -> Result<(Held, Vec<u8>), ManagerError> {
    mrmm_proto::validate_id(name).map_err(|_| ManagerError::Config(format!("map name {name:?}: use 1 to 64 characters of A-Z a-z 0-9 _ -")))?;
    let read = |p: &str| std::fs::read(p).map_err(|e| e.to_string());
    let bundle = match plan {
        Some(plan) => Bundle::collect_on_plan(&path.to_string_lossy(), &plan.to_string_lossy(), read),
        None => Bundle::collect(&path.to_string_lossy(), read),
    }
    .map_err(|e| ManagerError::Config(format!("map {name}: {e}")))?;
    let held = Held::new(name, &bundle).map_err(|e| ManagerError::Config(format!("map {name}: {e}")))?;
    Ok((held, bundle.encode()))
}

/// Central's maps kept by content in its state dir (`maps/<hash>`, each a bundle as it travels):
/// every map central published stays there, so a restart after a map file changed (or went)
/// still serves the maps of the missions journaled on it.
#[derive(Debug, Clone)]
pub struct MapArchive {
    dir: std::path::PathBuf,
}

impl MapArchive {
    /// The archive in `state_dir` (created when first written).
    pub fn new(state_dir: &Path) -> MapArchive {
        MapArchive { dir: state_dir.join("maps") }
    }

    /// Keeps `bytes` (a bundle hashing to `hash`) unless it is there already; written to a
    /// temporary file and renamed, so a crash never leaves half a map under its hash.
    pub fn keep(&self, hash: &str, bytes: &[u8]) -> Result<(), ManagerError> {
        let path = self.dir.join(hash);
        if path.exists() {
            return Ok(());
        }
        let err = |e: std::io::Error| ManagerError::Config(format!("map archive {}: {e}", self.dir.display()));
        std::fs::create_dir_all(&self.dir).map_err(err)?;
        let tmp = self.dir.join(format!(".{hash}.tmp"));
        std::fs::write(&tmp, bytes).map_err(err)?;
        std::fs::rename(&tmp, &path).map_err(err)
    }

    /// The map `r` from the archive, checked against its hash; `None` if it is not there.
    pub fn load(&self, r: &MapRef) -> Result<Option<Held>, ManagerError> {
        let path = self.dir.join(&r.hash);
        if r.check().is_err() || !path.exists() {
            return Ok(None);
        }
        let bytes = std::fs::read(&path).map_err(|e| ManagerError::Config(format!("map archive {}: {e}", path.display())))?;
        let bad = |why: String| ManagerError::Config(format!("map archive {}: {why}", path.display()));
        if mrmm_maps::bundle::content_hash(&bytes) != r.hash {
            return Err(bad("its bytes do not hash to its name".into()));
        }
        let bundle = Bundle::decode(&r.name, &bytes).map_err(|e| bad(e.to_string()))?;
        Held::new(&r.name, &bundle).map(Some).map_err(|e| bad(e.to_string()))
    }
}

/// Central's maps: those its config names (checked, graph maps with the floor plans `plans`
/// gives them, and kept in `archive` when it has a state dir), then former versions of them that missions of its journal plan on (`mission_maps`),
/// from the archive. A map of the config that cannot be read stops start-up with one line; a
/// journaled mission's map found nowhere is reported and left out (its mission's host may still
/// fetch it from a node that holds it).
pub fn load_central(
    maps: &BTreeMap<String, std::path::PathBuf>,
    plans: &BTreeMap<String, std::path::PathBuf>,
    chargers: &BTreeMap<String, Vec<mrmm_core::maps::ChargerSpec>>,
    archive: Option<&MapArchive>,
    mission_maps: &[MapRef],
) -> Result<MapStore, ManagerError> {
    let store = MapStore::publisher();
    for (name, path) in maps {
        let (held, bytes) = load_file_bundle(name, path, plans.get(name).map(|p| p.as_path()))?;
        let held = match chargers.get(name) {
            Some(specs) => held.with_chargers(specs).map_err(|e| ManagerError::Config(format!("chargers.{name}{e}")))?,
            None => held,
        };
        tracing::info!(map = %name, format = %held.info.format, size = %held.info.size, hash = %held.info.hash, "map loaded");
        if let Some(a) = archive {
            a.keep(&held.info.hash, &bytes)?;
        }
        store.publish(held);
    }
    for r in mission_maps {
        if store.get(&r.hash).is_some() {
            continue;
        }
        match archive.map(|a| a.load(r)).transpose()?.flatten() {
            Some(held) => {
                tracing::warn!(map = %r.name, hash = %r.hash, "a journaled mission plans on a former version of this map: served from the state dir");
                store.insert(held);
            }
            None => tracing::warn!(map = %r.name, hash = %r.hash, "a journaled mission's map is neither in the config nor in the state dir"),
        }
    }
    Ok(store)
}

/// Bytes of fetched maps a node keeps at most (their bundles and decoded forms, as
/// [`Held::weight`] counts them); beyond, the least recently used are evicted. Central's own
/// maps are never evicted.
pub const CACHE_BUDGET: u64 = 512 << 20;
/// Map fetches a node runs at once at most; others wait their turn.
pub const FETCHES_AT_ONCE: usize = 2;
/// How long a node waits for central's list of the maps it publishes.
const LIST_TIMEOUT: Duration = Duration::from_secs(5);

/// A map held, and when it was last used (a counter).
struct Entry {
    held: Arc<Held>,
    used: u64,
    /// Central's own (read from its config): never evicted.
    pinned: bool,
}

/// The maps of a node, by hash, shared by its tasks (system manager, planner service, mission
/// host); it serves every one it holds.
#[derive(Clone)]
pub struct MapStore {
    held: Arc<Mutex<HashMap<String, Entry>>>,
    clock: Arc<std::sync::atomic::AtomicU64>,
    fetching: Arc<Mutex<HashSet<String>>>,
    fetches: Arc<tokio::sync::Semaphore>,
    /// Central's store: its maps are the ones it publishes; it fetches none for planning.
    publisher: bool,
    /// Central's current maps, name → hash (its config's).
    current: Arc<Mutex<BTreeMap<String, String>>>,
    budget: u64,
    /// Where newly held maps go to be served.
    serve_tx: Arc<Mutex<Option<tokio::sync::mpsc::UnboundedSender<Arc<Held>>>>>,
}

impl Default for MapStore {
    fn default() -> Self {
        MapStore {
            held: Arc::default(),
            clock: Arc::default(),
            fetching: Arc::default(),
            fetches: Arc::new(tokio::sync::Semaphore::new(FETCHES_AT_ONCE)),
            publisher: false,
            current: Arc::default(),
            budget: CACHE_BUDGET,
            serve_tx: Arc::default(),
        }
    }
}

impl std::fmt::Debug for MapStore {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MapStore").field("held", &self.held.lock().map(|h| h.len()).unwrap_or(0)).finish()
    }
}

impl MapStore {
    /// Central's store: the maps it holds are those it publishes (`mrmm/system/maps`); its
    /// planner service plans on no other.
    pub fn publisher() -> MapStore {
        MapStore { publisher: true, ..MapStore::default() }
    }

    /// A store that keeps fetched maps of at most `budget` bytes.
    pub fn with_budget(budget: u64) -> MapStore {
        MapStore { budget, ..MapStore::default() }
    }

    pub fn get(&self, hash: &str) -> Option<Arc<Held>> {
        let used = self.clock.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let mut m = self.held.lock().ok()?;
        let e = m.get_mut(hash)?;
        e.used = used;
        Some(e.held.clone())
    }

    /// Holds `held` (and serves it, once [`MapStore::serve`] runs). On central, a map of its
    /// config: never evicted.
    pub fn insert(&self, held: Held) -> Arc<Held> {
        self.hold(held, self.publisher)
    }

    fn hold(&self, held: Held, pinned: bool) -> Arc<Held> {
        let held = Arc::new(held);
        let used = self.clock.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        if let Ok(mut m) = self.held.lock() {
            m.entry(held.info.hash.clone()).or_insert_with(|| Entry { held: held.clone(), used, pinned });
            evict(&mut m, self.budget);
        }
        if let Some(tx) = self.serve_tx.lock().ok().and_then(|t| t.clone()) {
            let _ = tx.send(held.clone());
        }
        held
    }

    /// Holds `held` as the current map of its name (central's config).
    pub fn publish(&self, held: Held) -> Arc<Held> {
        if let Ok(mut c) = self.current.lock() {
            c.insert(held.info.name.clone(), held.info.hash.clone());
        }
        self.hold(held, true)
    }

    /// The current maps by name (central's, from its config).
    pub fn by_name(&self) -> BTreeMap<String, Arc<Held>> {
        let current = self.current.lock().map(|c| c.clone()).unwrap_or_default();
        current.into_iter().filter_map(|(name, hash)| self.get(&hash).map(|h| (name, h))).collect()
    }

    /// Maps held for central that are not current: former versions journaled missions plan on.
    pub fn superseded(&self) -> Vec<Arc<Held>> {
        let current: HashSet<String> = self.current.lock().map(|c| c.values().cloned().collect()).unwrap_or_default();
        self.held.lock().map(|m| m.values().filter(|e| e.pinned && !current.contains(&e.held.info.hash)).map(|e| e.held.clone()).collect()).unwrap_or_default()
    }

    /// Bytes of the maps held (as [`Held::weight`] counts them).
    pub fn weight(&self) -> u64 {
        self.held.lock().map(|m| m.values().map(|e| e.held.weight()).sum()).unwrap_or(0)
    }

    /// The map `r`: held, or fetched from the fleet by its hash (chunk by chunk, checked
    /// against the hash, then read off the async workers), at most [`FETCHES_AT_ONCE`] at once.
    pub async fn fetch(&self, mesh: &Mesh, r: &MapRef) -> Result<Arc<Held>, String> {
        if let Some(h) = self.get(&r.hash) {
            return Ok(h);
        }
        let _turn = self.fetches.acquire().await.map_err(|e| e.to_string())?;
        if let Some(h) = self.get(&r.hash) {
            return Ok(h);
        }
        let bytes = mrmm_net::map::fetch(mesh, r).await?;
        let name = r.name.clone();
        let held = tokio::task::spawn_blocking(move || {
            let bundle = Bundle::decode(&name, &bytes).map_err(|e| e.to_string())?;
            Held::new(&name, &bundle).map_err(|e| e.to_string())
        })
        .await
        .map_err(|e| format!("map {}: reading it failed: {e}", r.name))??;
        tracing::info!(map = %r.name, hash = %r.hash, bytes = held.info.bytes, "map fetched from the fleet");
        Ok(self.hold(held, false))
    }

    /// The map `r` for a plan: one this node holds, or — on a node other than central — one
    /// central lists among the maps it publishes (asked then), fetched. Central's own store
    /// fetches nothing: a planner service never fetches a map a requester names, whoever serves
    /// it.
    pub async fn published(&self, mesh: &Mesh, r: &MapRef) -> Result<Arc<Held>, String> {
        if let Some(h) = self.get(&r.hash) {
            return Ok(h);
        }
        if self.publisher {
            return Err(format!("map {} ({}) is not one central publishes", r.name, short(&r.hash)));
        }
        let key = Key::SystemMaps.to_string();
        let from_central = |s: &mrmm_proto::Sender| s.role == mrmm_proto::Role::Central;
        let (list, _): (Vec<mrmm_proto::MapInfo>, _) =
            mesh.query(&key, None, LIST_TIMEOUT, from_central).await.map_err(|e| format!("map {}: central's list of maps: {e}", r.name))?;
        if !list.iter().any(|m| m.hash == r.hash) {
            return Err(format!("map {} ({}) is not one central publishes", r.name, short(&r.hash)));
        }
        self.fetch(mesh, r).await
    }

    /// Fetches `r` in the background if it is neither held nor on its way (a node that may take
    /// a mission over holds its map before it needs it).
    pub fn prefetch(&self, mesh: &Mesh, r: &MapRef) {
        if self.get(&r.hash).is_some() || !self.fetching.lock().map(|mut f| f.insert(r.hash.clone())).unwrap_or(false) {
            return;
        }
        let (store, mesh, r) = (self.clone(), mesh.clone(), r.clone());
        tokio::spawn(async move {
            if let Err(e) = store.fetch(&mesh, &r).await {
                tracing::warn!(map = %r.name, "cannot fetch the map yet: {e}");
            }
            if let Ok(mut f) = store.fetching.lock() {
                f.remove(&r.hash);
            }
        });
    }

    /// Serves every map held now or later on `mrmm/maps/<hash>/*` until `shutdown`, in the
    /// background; a second call (the node's planner service and mission host share the store)
    /// does nothing.
    pub fn start_serving(&self, mesh: &Mesh, shutdown: CancellationToken) {
        if self.serve_tx.lock().map(|t| t.is_some()).unwrap_or(true) {
            return;
        }
        let (store, mesh) = (self.clone(), mesh.clone());
        let (tx, rx) = tokio::sync::mpsc::unbounded_channel();
        if let Ok(mut t) = self.serve_tx.lock() {
            *t = Some(tx.clone());
        }
        for h in self.held.lock().map(|m| m.values().map(|e| e.held.clone()).collect::<Vec<_>>()).unwrap_or_default() {
            let _ = tx.send(h);
        }
        tokio::spawn(async move {
            if let Err(e) = store.serve(mesh, rx, shutdown).await {
                tracing::warn!("maps are not served: {e}");
            }
        });
    }

    async fn serve(&self, mesh: Mesh, mut rx: tokio::sync::mpsc::UnboundedReceiver<Arc<Held>>, shutdown: CancellationToken) -> Result<(), ManagerError> {
        let mut served: HashMap<String, Queryable<()>> = HashMap::new();
        loop {
            let held = tokio::select! {
                _ = shutdown.cancelled() => break,
                h = rx.recv() => match h { Some(h) => h, None => break },
            };
            if served.contains_key(&held.info.hash) {
                continue;
            }
            let key = mrmm_proto::Pattern::MapChunks(held.info.hash.clone()).to_string();
            // Central answers for a map it publishes with its manifest too (sealed): askers check
            // each chunk against it.
            let manifest = match self.publisher {
                true => {
                    Some(Arc::new(mrmm_proto::map::MapManifest::of_encoded(&held.info.hash, &held.chunks).map_err(|e| ManagerError::Config(e.to_string()))?))
                }
                false => None,
            };
            let (h, answerer) = (held.clone(), mesh.clone());
            let q = mesh
                .session()
                .declare_queryable(key)
                .complete(true)
                .callback(move |q| {
                    let index = match Key::parse(q.key_expr().as_str()) {
                        Some(Key::MapChunk { index, .. }) => index as usize,
                        Some(Key::MapManifest { .. }) => {
                            if let Some(m) = manifest.clone() {
                                let mesh = answerer.clone();
                                tokio::spawn(async move { mesh.reply_json(&q, m.as_ref()).await });
                            }
                            return;
                        }
                        _ => return,
                    };
                    let Some(bytes) = h.chunks.get(index).cloned() else { return };
                    tokio::spawn(async move {
                        if let Err(e) = q.reply(q.key_expr().clone(), bytes).await {
                            tracing::debug!("map chunk reply failed: {e}");
                        }
                    });
                })
                .await
                .map_err(ManagerError::zenoh)?;
            served.insert(held.info.hash.clone(), q);
        }
        Ok(())
    }
}

/// The first characters of a hash, for messages.
fn short(hash: &str) -> &str {
    hash.get(..12).unwrap_or(hash)
}

/// Evicts the least recently used maps that are not pinned until those held weigh at most
/// `budget` (a map just held stays, even alone over the budget).
fn evict(m: &mut HashMap<String, Entry>, budget: u64) {
    let mut total: u64 = m.values().map(|e| e.held.weight()).sum();
    while total > budget {
        let newest = m.values().map(|e| e.used).max().unwrap_or(0);
        let Some((hash, w)) = m.iter().filter(|(_, e)| !e.pinned && e.used != newest).min_by_key(|(_, e)| e.used).map(|(h, e)| (h.clone(), e.held.weight()))
        else {
            break;
        };
        tracing::info!(hash = %short(&hash), bytes = w, "map evicted from the cache (fetched again when needed)");
        m.remove(&hash);
        total = total.saturating_sub(w);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A two-vertex patrolling_sim graph named `name`.
    fn graph_map(name: &str) -> Held {
        let text = "2 100 100 0.1 0 0\n0 10 10 1 1 E 10\n1 20 10 1 0 W 10\n";
        let bundle = Bundle::collect(&format!("{name}.graph"), |_| Ok(text.as_bytes().to_vec())).expect("bundle");
        Held::new(name, &bundle).expect("map")
    }

    /// Issue 50: central's maps lived only in its config files; a restart with a changed file
    /// broke every mission journaled on the old hash. The old version is now served from the
    /// state dir, the new one is current.
    #[test]
    fn a_changed_map_file_keeps_serving_the_version_journaled_missions_plan_on() {
        let dir = std::env::temp_dir().join(format!("mrmm-map-archive-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("dir");
        let file = dir.join("floor.graph");
        std::fs::write(&file, "2 100 100 0.1 0 0\n0 10 10 1 1 E 10\n1 20 10 1 0 W 10\n").expect("v1");
        let archive = MapArchive::new(&dir.join("state"));
        let config = BTreeMap::from([("floor".to_string(), file.clone())]);
        let v1 = load_central(&config, &BTreeMap::new(), &BTreeMap::new(), Some(&archive), &[]).expect("load").by_name()["floor"].info.map_ref();
        // The file changes; a mission journaled on v1 still plans on it.
        std::fs::write(&file, "2 100 100 0.1 0 0\n0 10 10 1 1 E 30\n1 40 10 1 0 W 30\n").expect("v2");
        let store = load_central(&config, &BTreeMap::new(), &BTreeMap::new(), Some(&archive), std::slice::from_ref(&v1)).expect("load");
        let v2 = store.by_name()["floor"].info.map_ref();
        assert_ne!(v1.hash, v2.hash);
        assert!(store.get(&v1.hash).is_some(), "the journaled version is held");
        let superseded: Vec<String> = store.superseded().iter().map(|h| h.info.hash.clone()).collect();
        assert_eq!(superseded, std::slice::from_ref(&v1.hash));
        // The file gone from the config, both versions still come from the archive.
        let store = load_central(&BTreeMap::new(), &BTreeMap::new(), &BTreeMap::new(), Some(&archive), &[v1.clone(), v2.clone()]).expect("load");
        assert!(store.get(&v1.hash).is_some() && store.get(&v2.hash).is_some() && store.by_name().is_empty());
        // A damaged archive entry is a readable error, not a wrong map.
        std::fs::write(dir.join("state/maps").join(&v1.hash), b"not the map").expect("damage");
        let e = load_central(&BTreeMap::new(), &BTreeMap::new(), &BTreeMap::new(), Some(&archive), &[v1]).map(|_| ()).expect_err("damaged");
        assert!(e.to_string().contains("do not hash to its name"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn fetched_maps_beyond_the_budget_are_evicted_least_recently_used_first_and_pinned_ones_never() {
        let a = graph_map("a");
        let w = a.weight();
        let store = MapStore { budget: 2 * w + w / 2, ..MapStore::default() };
        let (ha, hb, hc) = (a.info.hash.clone(), graph_map("b").info.hash, graph_map("c").info.hash);
        store.hold(a, false);
        store.hold(graph_map("b"), false);
        assert!(store.get(&ha).is_some(), "a used after b");
        store.hold(graph_map("c"), false);
        assert!(store.get(&hb).is_none() && store.get(&ha).is_some() && store.get(&hc).is_some(), "b, least recently used, evicted");
        let central = MapStore { budget: 0, ..MapStore::publisher() };
        central.publish(graph_map("d"));
        central.insert(graph_map("e"));
        assert_eq!((central.by_name().len(), central.superseded().len()), (1, 1), "central's own maps are never evicted");
    }
}
