//! A map as a node holds it: what the operator sees of it, the map itself, the chunks its bundle
//! is served in, and the map prepared for routes. Reading files and serving chunks is the
//! drivers' (`mrmm_manager::maps`).

use std::sync::Arc;

use mrmm_maps::{Bundle, Map, MapSummary};
use mrmm_proto::geom::Point;
use mrmm_proto::map::{Charger, MapChunk};
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
        let mut info = info(name, &hash, encoded.len() as u64, &map.summary(format));
        if let Map::Graph(g) = &map {
            info.chargers = g.chargers().take(mrmm_proto::map::MAX_CHARGERS).map(charger_at).collect();
        }
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

    /// Adds the chargers central's config names for this map: a graph's vertex by name (or by
    /// its position, within [`ON_VERTEX`]), a grid's free point. The error names the entry and
    /// the problem.
    pub fn with_chargers(mut self, specs: &[ChargerSpec]) -> Result<Held, String> {
        for (i, spec) in specs.iter().enumerate() {
            let at = |why: String| format!("[{i}]: {why}");
            let charger = match (spec, self.map.as_ref()) {
                (ChargerSpec::Vertex(name), Map::Graph(g)) => {
                    let v = g.vertices.iter().find(|v| &v.name == name).ok_or_else(|| at(format!("the graph has no vertex {name:?}")))?;
                    charger_at(v)
                }
                (ChargerSpec::Vertex(name), Map::Grid(_)) => return Err(at(format!("{name:?}: a grid map has no vertices: give [x, y]"))),
                (ChargerSpec::At([x, y]), Map::Graph(g)) => {
                    let p = mrmm_maps::Point::new(*x, *y);
                    let v = g
                        .vertices
                        .iter()
                        .find(|v| v.at.dist(p) <= ON_VERTEX)
                        .ok_or_else(|| at(format!("({x}, {y}) is on no vertex of the graph: a charger is a vertex")))?;
                    charger_at(v)
                }
                (ChargerSpec::At([x, y]), Map::Grid(g)) => {
                    if !(x.is_finite() && y.is_finite() && g.is_free(mrmm_maps::Point::new(*x, *y))) {
                        return Err(at(format!("({x}, {y}) is not free space of the map")));
                    }
                    Charger { name: format!("charger-{}", self.info.chargers.len() + 1), at: Point { x: *x, y: *y } }
                }
            };
            if self.info.chargers.iter().any(|c| c.name == charger.name) {
                return Err(at(format!("{} is a charger already", charger.name)));
            }
            if self.info.chargers.len() >= mrmm_proto::map::MAX_CHARGERS {
                return Err(at(format!("more than {} chargers", mrmm_proto::map::MAX_CHARGERS)));
            }
            self.info.chargers.push(charger);
        }
        Ok(self)
    }
}

/// The charger a graph's vertex is.
fn charger_at(v: &mrmm_maps::graph::Vertex) -> Charger {
    Charger { name: v.name.clone(), at: Point { x: v.at.x, y: v.at.y } }
}

/// A point of central's config is a graph's vertex if it is this close to it, metres.
pub const ON_VERTEX: f64 = 0.5;

/// A charger as central's config names it: `[x, y]` or a graph vertex's name.
#[derive(Debug, Clone, PartialEq, serde::Deserialize)]
#[serde(untagged)]
pub enum ChargerSpec {
    At([f64; 2]),
    Vertex(String),
}

/// What the operator sees of a map.
pub fn info(name: &str, hash: &str, bytes: u64, s: &MapSummary) -> MapInfo {
    let size = match (&s.grid, &s.graph) {
        (Some(g), _) => format!("{} × {} cells of {} m, {:.0} m² free", g.width, g.height, g.resolution, g.free_m2),
        (_, Some(g)) if g.passing > 0 => format!("{} vertices, {} edges, {:.0} m of lanes, {} passing", g.vertices, g.edges, g.length_m, g.passing),
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
        chargers: Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn held(file: &str) -> Held {
        let path = format!("{}/../maps/data/{file}", env!("CARGO_MANIFEST_DIR"));
        let bundle = Bundle::collect(&path, |p| std::fs::read(p).map_err(|e| e.to_string())).expect("bundle");
        Held::new("m", &bundle).expect("map")
    }

    /// Open-RMF's office graph brings its two chargers; central's config adds vertices (by name
    /// or position) on a graph and free points on a grid, and names what it cannot take.
    #[test]
    fn chargers_come_from_the_graph_and_from_central_config() {
        let office = held("open_rmf/office.nav_graph.yaml");
        let names = |h: &Held| h.info.chargers.iter().map(|c| c.name.clone()).collect::<Vec<_>>();
        assert_eq!(names(&office), ["tinyRobot1_charger", "tinyRobot2_charger"]);
        let d2 = ChargerSpec::Vertex("patrol_D2".into());
        let near_d2 = ChargerSpec::At([10.3, -3.1]);
        let office = office.with_chargers(std::slice::from_ref(&d2)).expect("a vertex by name");
        assert_eq!(names(&office).last().map(String::as_str), Some("patrol_D2"));
        let e = office.with_chargers(&[near_d2]).map(|_| ()).expect_err("the same vertex twice");
        assert!(e.starts_with("[0]: patrol_D2 is a charger already"), "{e}");
        for (spec, want) in
            [(ChargerSpec::Vertex("nowhere".into()), "the graph has no vertex \"nowhere\""), (ChargerSpec::At([500.0, 500.0]), "is on no vertex")]
        {
            let e = held("open_rmf/office.nav_graph.yaml").with_chargers(&[spec]).map(|_| ()).expect_err("refused");
            assert!(e.contains(want), "{e}");
        }
        let building = held("building/building.yaml");
        assert!(building.info.chargers.is_empty());
        let (lo, hi) = (building.info.min, building.info.max);
        let e = held("building/building.yaml").with_chargers(&[ChargerSpec::At([hi.x + 10.0, hi.y])]).map(|_| ()).expect_err("outside");
        assert!(e.contains("is not free space"), "{e}");
        assert!(held("building/building.yaml").with_chargers(&[ChargerSpec::Vertex("a".into())]).map(|_| ()).expect_err("no vertices").contains("grid"));
        // A free point of the building: the first free cell's centre on its middle row.
        let Map::Grid(g) = building.map.as_ref() else { panic!("a grid") };
        let row = g.height / 2;
        let col = (0..g.width).find(|&c| g.free(c, row)).expect("a free cell");
        let p = g.center(col, row);
        assert!(p.x >= lo.x && p.x <= hi.x);
        let building = building.with_chargers(&[ChargerSpec::At([p.x, p.y])]).expect("a free point");
        assert_eq!(building.info.chargers, [Charger { name: "charger-1".into(), at: Point { x: p.x, y: p.y } }]);
        // The config's JSON5: points and names side by side.
        let specs: Vec<ChargerSpec> = serde_json::from_str(r#"[[1.5, 2], "dock"]"#).expect("specs");
        assert_eq!(specs, [ChargerSpec::At([1.5, 2.0]), ChargerSpec::Vertex("dock".into())]);
    }
}
