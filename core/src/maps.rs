//! A map as a node holds it: what the operator sees of it, the map itself, the chunks its bundle
//! is served in, and the map prepared for routes. Reading files and serving chunks is the
//! drivers' (`mrmm_manager::maps`).

use std::sync::Arc;

use mrmm_maps::{Bundle, Map, MapSummary};
use mrmm_proto::geom::Point;
use mrmm_proto::map::MapChunk;
use mrmm_proto::{MapInfo, MapRef};

/// A map a node holds: what it is, the map itself, and its bundle's chunks as served.
#[derive(Debug)]
pub struct Held {
    pub info: MapInfo,
    pub map: Arc<Map>,
    pub chunks: Vec<Vec<u8>>,
    /// The map prepared for routes (operator gotos), made the first time one is asked.
    space: std::sync::OnceLock<Result<mrmm_maps::Space, String>>,
}

impl Held {
    /// Reads the bundle (the map must load) and chunks it; `name` is the operator's name for it.
    pub fn new(name: &str, bundle: &Bundle) -> Result<Held, mrmm_maps::MapError> {
        let (format, map) = bundle.load()?;
        let encoded = bundle.encode();
        let hash = mrmm_maps::bundle::content_hash(&encoded);
        let info = info(name, &hash, encoded.len() as u64, &map.summary(format));
        let chunks = MapChunk::split(&encoded).iter().filter_map(|c| c.encode().ok()).collect();
        Ok(Held { info, map: Arc::new(map), chunks, space: std::sync::OnceLock::new() })
    }

    /// About how many bytes it takes: its bundle's chunks and the map read from it (a grid's
    /// cells, a graph's vertices and edges; the routing space made on first use is not counted).
    pub fn weight(&self) -> u64 {
        let chunks: usize = self.chunks.iter().map(Vec::len).sum();
        let map = match self.map.as_ref() {
            mrmm_maps::Map::Grid(g) => g.data.len(),
            mrmm_maps::Map::Graph(g) => {
                g.vertices.iter().map(|v| v.name.len() + std::mem::size_of_val(v)).sum::<usize>()
                    + g.edges.len() * std::mem::size_of::<mrmm_maps::graph::Edge>()
            }
        };
        (chunks + map) as u64
    }

    /// The map prepared for robots of the default radius.
    pub fn space(&self) -> Result<&mrmm_maps::Space, String> {
        self.space
            .get_or_init(|| mrmm_maps::Space::new(&self.map, mrmm_planner::recipe::DEFAULT_ROBOT_RADIUS).map_err(|e| e.to_string()))
            .as_ref()
            .map_err(Clone::clone)
    }

    pub fn map_ref(&self) -> MapRef {
        self.info.map_ref()
    }
}

/// What the operator sees of a map.
pub fn info(name: &str, hash: &str, bytes: u64, s: &MapSummary) -> MapInfo {
    let size = match (&s.grid, &s.graph) {
        (Some(g), _) => format!("{} × {} cells of {} m, {:.0} m² free", g.width, g.height, g.resolution, g.free_m2),
        (_, Some(g)) => format!("{} vertices, {} edges, {:.0} m of lanes", g.vertices, g.edges, g.length_m),
        _ => String::new(),
    };
    MapInfo {
        name: name.to_string(),
        format: s.format.as_str().to_string(),
        bytes,
        hash: hash.to_string(),
        size,
        min: Point { x: s.min.x, y: s.min.y },
        max: Point { x: s.max.x, y: s.max.y },
        superseded: false,
    }
}
