//! Maps as fleet data on a node: the maps it holds (read from files by central, fetched from the
//! fleet by everyone else), served in chunks to any node that asks by hash, and fetched the same
//! way. A map is named by the SHA-256 of its bundle, so whoever answers, the asker checks what it
//! got: no seal is needed, and a takeover with central gone gets the map from any node that has
//! it.

use std::collections::{BTreeMap, HashMap, HashSet};
use std::path::Path;
use std::sync::{Arc, Mutex};

use mrmm_maps::Bundle;
use mrmm_net::Mesh;
use mrmm_proto::{Key, MapRef};
use tokio_util::sync::CancellationToken;
use zenoh::query::Queryable;

use crate::error::ManagerError;

pub use mrmm_core::maps::{info, Held};

/// Reads the map at `path` for the fleet under `name`: one readable line if it cannot be.
pub fn load_file(name: &str, path: &Path) -> Result<Held, ManagerError> {
    mrmm_proto::validate_id(name).map_err(|_| ManagerError::Config(format!("map name {name:?}: use 1 to 64 characters of A-Z a-z 0-9 _ -")))?;
    let bundle = Bundle::collect(&path.to_string_lossy(), |p| std::fs::read(p).map_err(|e| e.to_string()))
        .map_err(|e| ManagerError::Config(format!("map {name}: {e}")))?;
    Held::new(name, &bundle).map_err(|e| ManagerError::Config(format!("map {name}: {e}")))
}

/// The maps of a node, by hash, shared by its tasks (system manager, planner service, mission
/// host); it serves every one it holds.
#[derive(Clone, Default)]
pub struct MapStore {
    held: Arc<Mutex<HashMap<String, Arc<Held>>>>,
    fetching: Arc<Mutex<HashSet<String>>>,
    /// Where newly held maps go to be served.
    serve_tx: Arc<Mutex<Option<tokio::sync::mpsc::UnboundedSender<Arc<Held>>>>>,
}

impl std::fmt::Debug for MapStore {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MapStore").field("held", &self.held.lock().map(|h| h.len()).unwrap_or(0)).finish()
    }
}

impl MapStore {
    pub fn get(&self, hash: &str) -> Option<Arc<Held>> {
        self.held.lock().ok()?.get(hash).cloned()
    }

    /// Holds `held` (and serves it, once [`MapStore::serve`] runs).
    pub fn insert(&self, held: Held) -> Arc<Held> {
        let held = Arc::new(held);
        if let Ok(mut m) = self.held.lock() {
            m.entry(held.info.hash.clone()).or_insert_with(|| held.clone());
        }
        if let Some(tx) = self.serve_tx.lock().ok().and_then(|t| t.clone()) {
            let _ = tx.send(held.clone());
        }
        held
    }

    /// The maps held by name (central's, from its config).
    pub fn by_name(&self) -> BTreeMap<String, Arc<Held>> {
        self.held.lock().map(|m| m.values().map(|h| (h.info.name.clone(), h.clone())).collect()).unwrap_or_default()
    }

    /// The map `r`: held, or fetched from the fleet by its hash (chunk by chunk, checked
    /// against the hash, then read).
    pub async fn fetch(&self, mesh: &Mesh, r: &MapRef) -> Result<Arc<Held>, String> {
        if let Some(h) = self.get(&r.hash) {
            return Ok(h);
        }
        let bytes = mrmm_net::map::fetch(mesh.session(), r).await?;
        let bundle = Bundle::decode(&r.name, &bytes).map_err(|e| e.to_string())?;
        let held = Held::new(&r.name, &bundle).map_err(|e| e.to_string())?;
        tracing::info!(map = %r.name, hash = %r.hash, bytes = bytes.len(), "map fetched from the fleet");
        Ok(self.insert(held))
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
        for h in self.held.lock().map(|m| m.values().cloned().collect::<Vec<_>>()).unwrap_or_default() {
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
            let key = format!("{}/*", Key::MapChunk { hash: held.info.hash.clone(), index: 0 }.to_string().trim_end_matches("/0"));
            let h = held.clone();
            let q = mesh
                .session()
                .declare_queryable(key)
                .complete(true)
                .callback(move |q| {
                    let index = match Key::parse(q.key_expr().as_str()) {
                        Some(Key::MapChunk { index, .. }) => index as usize,
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
