//! Open-RMF navigation graphs (`nav_graphs/<n>.yaml`, as `rmf_building_map_tools` writes them):
//! `levels.<name>.vertices` `[x, y, {name, …}]` and `levels.<name>.lanes` `[from, to, {…}]`,
//! each lane one direction. mrmm reads graphs of one level, and one lane property of its own:
//! `passing: true` on a lane wide enough for two robots side by side (Open-RMF's tools keep
//! properties they do not know; mrmm ignores theirs).

use std::collections::BTreeMap;

use serde::Deserialize;

use crate::error::MapError;
use crate::geom::Point;
use crate::graph::{Edge, NavGraph, Vertex};
use crate::nav2::yaml;

#[derive(Deserialize)]
struct File {
    levels: BTreeMap<String, Level>,
}

#[derive(Deserialize)]
struct Level {
    #[serde(default)]
    vertices: Vec<(f64, f64, VertexProps)>,
    #[serde(default)]
    lanes: Vec<(u64, u64, LaneProps)>,
}

#[derive(Deserialize, Default)]
struct LaneProps {
    /// Two robots pass each other on the lane ([`Edge::passing`]).
    #[serde(default)]
    passing: bool,
}

#[derive(Deserialize, Default)]
struct VertexProps {
    #[serde(default)]
    name: Option<String>,
    /// A charger (rmf_building_map_tools writes it only where true).
    #[serde(default)]
    is_charger: bool,
}

/// Writes `graph` as an Open-RMF navigation graph of one level named `level` of building
/// `building`: each vertex `[x, y, {name}]` (`is_charger: true` on a charger), each directed
/// edge a lane `[from, to, {}]` (`{passing: true}` on a passing lane) — what [`parse`] reads and
/// `rmf_traffic_editor`'s nav graphs hold.
pub fn write(graph: &NavGraph, building: &str, level: &str) -> String {
    let quote = |s: &str| serde_json::to_string(s).unwrap_or_else(|_| "\"\"".into());
    let mut out = format!("building_name: {}\nlevels:\n  {}:\n    lanes:\n", quote(building), quote(level));
    if graph.edges.is_empty() {
        out.truncate(out.len() - 1);
        out.push_str(" []\n");
    }
    for e in &graph.edges {
        let props = if e.passing { "{passing: true}" } else { "{}" };
        out.push_str(&format!("    - [{}, {}, {props}]\n", e.from, e.to));
    }
    out.push_str("    vertices:\n");
    for v in &graph.vertices {
        let charger = if v.charger { ", is_charger: true" } else { "" };
        out.push_str(&format!("    - [{:?}, {:?}, {{name: {}{charger}}}]\n", v.at.x, v.at.y, quote(&v.name)));
    }
    out
}

/// Reads an Open-RMF navigation graph of one level; `file` names it in errors.
pub fn parse(file: &str, text: &str) -> Result<NavGraph, MapError> {
    let f: File = yaml(file, text)?;
    let mut levels = f.levels.into_iter();
    let (level_name, level) = levels.next().ok_or_else(|| MapError::malformed(file, "field levels", "names no level"))?;
    if let Some((other, _)) = levels.next() {
        return Err(MapError::malformed(file, "field levels", format!("has more than one level ({level_name}, {other}, …): mrmm reads one level's graph")));
    }
    let mut vertices = Vec::with_capacity(level.vertices.len());
    let mut names = std::collections::BTreeSet::new();
    for (i, (x, y, props)) in level.vertices.into_iter().enumerate() {
        let name = props.name.unwrap_or_default();
        if !name.is_empty() && !names.insert(name.clone()) {
            return Err(MapError::malformed(file, format!("levels.{level_name}.vertices[{i}]"), format!("a second vertex named {name:?}")));
        }
        vertices.push(Vertex { charger: props.is_charger, name: if name.is_empty() { i.to_string() } else { name }, at: Point::new(x, y) });
    }
    let n = vertices.len() as u64;
    let mut edges = Vec::with_capacity(level.lanes.len());
    for (i, (from, to, props)) in level.lanes.into_iter().enumerate() {
        if from >= n || to >= n {
            return Err(MapError::malformed(file, format!("levels.{level_name}.lanes[{i}]"), format!("joins {from} and {to}, but the level has {n} vertices")));
        }
        let length = vertices[from as usize].at.dist(vertices[to as usize].at);
        edges.push(Edge { from: from as u32, to: to as u32, length, passing: props.passing });
    }
    NavGraph { vertices, edges }.checked(file)
}
