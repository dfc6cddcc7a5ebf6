//! `mrmm demo --map FILE`: the demo fleet in a building. Central plans on the map; the robots
//! start side by side on free cells (or vertices) near its middle; the patrol's waypoints are
//! spread over the northern half, the coverage covers the southern half (a graph map: the patrol
//! visits every vertex, the coverage the whole graph).

use std::path::{Path, PathBuf};

use anyhow::{anyhow, Context};
use mrmm_maps::{Map, Point, Space};
use serde_json::{json, Value};

/// The name central knows the demo's map by.
pub const NAME: &str = "demo";

/// The demo's map, ready to place robots and missions on.
pub struct DemoMap {
    /// Absolute path of the map's main file, for central's `--map`.
    pub path: PathBuf,
    /// Absolute path of a graph map's floor plan, for central's `--floor-plan`.
    pub plan: Option<PathBuf>,
    map: Map,
    space: Space,
}

impl DemoMap {
    /// The map at `path`, on the floor plan at `plan` if one is given.
    pub fn load(path: &Path, plan: Option<&Path>) -> anyhow::Result<DemoMap> {
        let path = std::fs::canonicalize(path).with_context(|| format!("--map {}", path.display()))?;
        let plan = plan.map(|p| std::fs::canonicalize(p).with_context(|| format!("--floor-plan {}", p.display()))).transpose()?;
        let (_, map) = super::super::map::bundle_on(&path, plan.as_deref())?.load().map_err(|e| anyhow!("{e}"))?;
        let space = Space::new(&map, mrmm_planner::recipe::DEFAULT_ROBOT_RADIUS).map_err(|e| anyhow!("{e}"))?;
        Ok(DemoMap { path, plan, map, space })
    }

    /// What the floor plan gave a graph map: `on its floor plan P: N of M lanes passing`.
    pub fn plan_line(&self) -> Option<String> {
        let (plan, g) = (self.plan.as_ref()?, self.map.graph()?);
        Some(format!("the map's floor plan {}: {} of {} lanes passing", plan.display(), g.summary().passing, g.lanes().len()))
    }

    fn bounds(&self) -> (Point, Point) {
        match &self.map {
            Map::Grid(g) => g.bounds(),
            Map::Graph(g) => g.bounds(),
        }
    }

    /// Where the fleet gathers: the free point nearest the middle of the map.
    fn middle(&self) -> anyhow::Result<Point> {
        let (lo, hi) = self.bounds();
        let mid = Point::new((lo.x + hi.x) / 2.0, (lo.y + hi.y) / 2.0);
        (0..self.space.nodes() as u32)
            .filter_map(|i| self.space.node_point(i))
            .min_by(|a, b| a.dist(mid).total_cmp(&b.dist(mid)))
            .ok_or_else(|| anyhow!("the map has no free space for a robot"))
    }

    /// Where each of `n` robots starts: on a graph map, vertices spread over it; on a grid map,
    /// the vertices of the lanes traffic derives from it (a robot standing on one holds it from
    /// the first report), else free cells side by side near the middle.
    pub fn starts(&self, n: usize) -> anyhow::Result<Vec<(f64, f64)>> {
        let middle = self.middle()?;
        let pts = match &self.map {
            Map::Grid(_) => match self.on_lanes(middle, n) {
                Some(pts) => Ok(pts),
                None => self.space.spread(middle, n, 0.8),
            },
            Map::Graph(_) => self.space.farthest(middle, n, |_| true),
        }
        .map_err(|e| anyhow!("--map: {e}"))?;
        Ok(pts.iter().map(|p| ((p.x * 100.0).round() / 100.0, (p.y * 100.0).round() / 100.0)).collect())
    }

    /// `n` vertices spread over the lanes derived from a grid map, if it has that many.
    fn on_lanes(&self, middle: Point, n: usize) -> Option<Vec<Point>> {
        let lanes = mrmm_core::traffic::authority::lanes_of(&self.map)?.into_owned();
        let space = Space::new(&Map::Graph(lanes), mrmm_planner::recipe::DEFAULT_ROBOT_RADIUS).ok()?;
        space.farthest(middle, n, |_| true).ok().filter(|p| p.len() == n)
    }

    /// The patrol's and the coverage's parameters on this map.
    pub fn params(&self) -> anyhow::Result<(Value, Option<Value>)> {
        let (lo, hi) = self.bounds();
        let mid_y = (lo.y + hi.y) / 2.0;
        match &self.map {
            Map::Graph(_) => Ok((json!("all"), None)),
            Map::Grid(_) => {
                let wps = self.space.farthest(self.middle()?, 6, |p| p.y > mid_y).map_err(|e| anyhow!("--map: {e}"))?;
                let wps: Vec<[f64; 2]> = wps.iter().map(|p| [(p.x * 100.0).round() / 100.0, (p.y * 100.0).round() / 100.0]).collect();
                let region = json!([[lo.x, lo.y], [hi.x, lo.y], [hi.x, mid_y], [lo.x, mid_y]]);
                Ok((json!(wps), Some(region)))
            }
        }
    }
}
