//! Lanes on a grid map: derived from its free space, entered (and left for a goal) at the vertex
//! in sight, and the ways off them to goals that only the robot holding their vertex can come
//! near.

use std::borrow::Cow;

use mrmm_maps::graph::NavGraph;
use mrmm_maps::space::GraphSpace;
use mrmm_maps::{Map, OccupancyGrid, Point};

use super::Layout;
use crate::traffic::layout::PASSING_OFFSET_M;

/// On a grid map a goal farther than this from its route's last vertex (metres) is driven to off
/// the lanes, when the way there is clear ([`leg_off`]); nearer, the vertex is the goal.
pub const OFF_NEAR: f64 = 0.15;
/// A goal farther than this from every vertex it sees (metres) is reached at the vertex.
pub const OFF_FAR: f64 = 6.0;
/// Room for the robot's body on each side of a way off the lanes (metres from its centre line).
pub const OFF_MARGIN: f64 = 0.2;

/// A way off the lanes: from vertex `v`, at `from`, straight to a goal at `to`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Leg {
    pub(super) v: u32,
    pub(super) from: Point,
    pub(super) to: Point,
}

/// The lanes robots on `map` drive: a graph map's own; a grid map's derived from its free space
/// along its corridors and through its doors ([`mrmm_maps::roadmap`], its defaults: lanes keep
/// 0.3 m from anything not free; lanes with room for a robot [`PASSING_OFFSET_M`] to each side
/// passing), the same on central and on every deputy. None: no lanes (a
/// grid with no room for a robot).
pub fn lanes_of(map: &Map) -> Option<Cow<'_, NavGraph>> {
    match map {
        Map::Graph(g) => Some(Cow::Borrowed(g)),
        Map::Grid(g) => match mrmm_maps::roadmap::derive("grid map", g, &mrmm_maps::roadmap::Params { passing: PASSING_OFFSET_M, ..Default::default() }) {
            Ok(lanes) if !lanes.vertices.is_empty() => Some(Cow::Owned(lanes)),
            Ok(_) => None,
            Err(e) => {
                tracing::warn!(error = %e, "no lanes derived: robots on this map drive without traffic");
                None
            }
        },
    }
}

/// The vertex a robot at `p` enters the lanes at, or a goal at `p` is reached at: the nearest
/// one, on a grid map the nearest one in sight (the straight way there crosses no cell that is
/// not free), else the nearest.
pub(super) fn vertex_for(space: &GraphSpace, grid: Option<&OccupancyGrid>, p: Point) -> Option<u32> {
    let g = space.graph();
    if g.vertices.is_empty() {
        return None;
    }
    let nearest = g.nearest(p).0;
    let Some(grid) = grid else { return Some(nearest) };
    let mut by_distance: Vec<(f64, u32)> = g.vertices.iter().enumerate().map(|(i, v)| (v.at.dist(p), i as u32)).collect();
    by_distance.sort_by(|a, b| a.0.total_cmp(&b.0));
    Some(by_distance.iter().take(SIGHT_TRIES).find(|(_, v)| grid.segment_free(p, g.vertices[*v as usize].at)).map_or(nearest, |&(_, v)| v))
}

/// The way off the lanes from vertex `v` to `goal` on a grid map, if a robot may drive it: the
/// goal is farther than [`OFF_NEAR`] and nearer than [`OFF_FAR`]; the way and [`OFF_MARGIN`] on
/// each side of it cross only free cells; every lane and vertex within the clearance of it is in
/// conflict with `v` (no other robot can be there while this one holds `v`); and it keeps the
/// clearance from the other robots' ways off the lanes.
pub(super) fn leg_off(layout: &Layout, grid: &OccupancyGrid, v: u32, goal: Point, others: &[Leg]) -> Option<Leg> {
    let from = layout.point(v);
    let d = from.dist(goal);
    if !(d > OFF_NEAR && d <= OFF_FAR) {
        return None;
    }
    let (nx, ny) = (-(goal.y - from.y) / d * OFF_MARGIN, (goal.x - from.x) / d * OFF_MARGIN);
    let side = |s: f64| grid.segment_free(Point::new(from.x + s * nx, from.y + s * ny), Point::new(goal.x + s * nx, goal.y + s * ny));
    if !(grid.segment_free(from, goal) && side(1.0) && side(-1.0) && layout.covered_by(v, from, goal)) {
        return None;
    }
    if others.iter().any(|o| crate::traffic::layout::segment_distance(from, goal, o.from, o.to) < layout.clearance()) {
        return None;
    }
    Some(Leg { v, from, to: goal })
}

/// Vertices, nearest first, tried for one in sight ([`vertex_for`]).
const SIGHT_TRIES: usize = 64;
