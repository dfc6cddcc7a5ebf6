//! Maps of the buildings robots work in, and shortest paths on them: Nav2 / ROS map_server
//! occupancy grids (YAML + PGM/PNG), patrolling_sim navigation graphs (`.graph`) and Open-RMF
//! navigation graphs (YAML). Pure code: bytes in, maps and routes out; the caller reads files
//! ([`Bundle::collect`] takes a reader) and every input is bounded ([`limits`]).
//!
//! A [`Map`] is either an [`OccupancyGrid`] or a [`NavGraph`]; a [`Space`] prepares one for
//! planning (obstacles inflated by the robot radius, searches) and answers geodesic distances,
//! distance fields and routes — the corner points of a path, joined by straight free segments or
//! by graph edges.
// Functions outside tests are at most 80 lines (clippy.toml); tests may be longer.
#![cfg_attr(not(test), deny(clippy::too_many_lines))]

pub mod bundle;
pub mod data;
pub mod error;
pub mod geom;
pub mod graph;
pub mod grid;
pub mod limits;
pub mod nav2;
pub mod patrolling_sim;
pub mod rmf;
pub mod roadmap;
pub mod space;

pub use bundle::{Bundle, Format};
pub use error::MapError;
pub use geom::Point;
pub use graph::NavGraph;
pub use grid::OccupancyGrid;
pub use space::{Field, Node, Space};

use serde::{Deserialize, Serialize};

/// A map: an occupancy grid or a navigation graph.
#[derive(Debug, Clone, PartialEq)]
pub enum Map {
    Grid(OccupancyGrid),
    Graph(NavGraph),
}

/// What `mrmm map check` and `mrmm op maps` show of a map.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MapSummary {
    pub format: Format,
    /// Grid maps: cells across and up, metres per cell, free area in m².
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grid: Option<GridSummary>,
    /// Graph maps: vertices and (directed) edges, total length of the undirected lanes in m.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub graph: Option<GraphSummary>,
    /// Lower-left and upper-right corners of what the map covers, metres.
    pub min: Point,
    pub max: Point,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GridSummary {
    pub width: u32,
    pub height: u32,
    pub resolution: f64,
    pub free_m2: f64,
    pub occupied_m2: f64,
    pub unknown_m2: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GraphSummary {
    pub vertices: usize,
    pub edges: usize,
    pub length_m: f64,
    /// Lanes marked passing (robots meeting on them pass each other).
    #[serde(default)]
    pub passing: usize,
}

impl Map {
    /// Size, free area or vertices and edges, and bounds.
    pub fn summary(&self, format: Format) -> MapSummary {
        match self {
            Map::Grid(g) => {
                let (min, max) = g.bounds();
                MapSummary { format, grid: Some(g.summary()), graph: None, min, max }
            }
            Map::Graph(g) => {
                let (min, max) = g.bounds();
                MapSummary { format, grid: None, graph: Some(g.summary()), min, max }
            }
        }
    }

    pub fn grid(&self) -> Option<&OccupancyGrid> {
        match self {
            Map::Grid(g) => Some(g),
            Map::Graph(_) => None,
        }
    }

    pub fn graph(&self) -> Option<&NavGraph> {
        match self {
            Map::Graph(g) => Some(g),
            Map::Grid(_) => None,
        }
    }
}
