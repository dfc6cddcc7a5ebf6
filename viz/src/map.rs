//! Drawing a map under the fleet, and the viewer's layout.

use mrmm_maps::{Map, NavGraph, OccupancyGrid};
use rerun::RecordingStream;

use crate::paths;

/// The viewer's layout: one large fleet map, and beside it the text logs (advice, teams,
/// barriers) above the missions' time series, the batteries' and a bar of each robot's charge.
pub fn blueprint() -> rerun::blueprint::Blueprint {
    use rerun::blueprint::{BarChartView, Blueprint, Horizontal, Spatial2DView, TextLogView, TimeSeriesView, Vertical};
    let fleet = Spatial2DView::new("fleet").with_origin(format!("/{}", paths::FLEET));
    let logs = TextLogView::new("advice and events").with_contents([format!("/{}", paths::ADVICE_LOG), format!("/{}/**", paths::EVENTS)]);
    let series = TimeSeriesView::new("missions").with_origin(format!("/{}", paths::METRICS));
    let charges = TimeSeriesView::new("batteries").with_origin(format!("/{}/robots", paths::BATTERY_ROOT));
    let bars = BarChartView::new("charge per robot").with_origin(format!("/{}", paths::BATTERIES));
    let side = Vertical::new([logs.into(), series.into(), charges.into(), bars.into()]).with_row_shares([1.0, 1.0, 1.0, 0.6]);
    Blueprint::new(Horizontal::new([fleet.into(), side.into()]).with_column_shares([3.0, 1.0])).with_auto_views(false)
}

/// Logs `map` (static) under `fleet/map/<name>`: a grid as a grey image placed in metres (free
/// white, occupied black, unknown grey), a graph as its lanes and vertices.
pub fn log(rec: &RecordingStream, name: &str, map: &Map) -> Result<(), rerun::RecordingStreamError> {
    match map {
        Map::Grid(g) => grid(rec, name, g),
        Map::Graph(g) => graph(rec, name, g),
    }
}

fn grid(rec: &RecordingStream, name: &str, g: &OccupancyGrid) -> Result<(), rerun::RecordingStreamError> {
    // Row r of the image is row r of the map from the bottom: placed with a scale of one cell and
    // the origin's pose, it lies under the robots' positions.
    let shades: Vec<u8> = g.data.iter().map(|&v| if v < 0 { 128 } else { 255 - (v.clamp(0, 100) as u16 * 255 / 100) as u8 }).collect();
    let path = paths::map(name);
    let res = g.resolution as f32;
    let place = rerun::Transform3D::from_translation_rotation_scale(
        [g.origin[0] as f32, g.origin[1] as f32, 0.0],
        rerun::RotationAxisAngle::new([0.0, 0.0, 1.0], rerun::Angle::from_radians(g.origin[2] as f32)),
        [res, res, 1.0],
    );
    rec.log_static(path.as_str(), &place)?;
    rec.log_static(path.as_str(), &rerun::Image::from_l8(shades, [g.width, g.height]).with_draw_order(-10.0))
}

fn graph(rec: &RecordingStream, name: &str, g: &NavGraph) -> Result<(), rerun::RecordingStreamError> {
    let at = |i: u32| {
        let p = g.vertices[i as usize].at;
        [p.x as f32, p.y as f32]
    };
    let lanes: Vec<Vec<[f32; 2]>> = g.lanes().iter().map(|&(a, b)| vec![at(a), at(b)]).collect();
    let grey = rerun::Color::from_rgb(150, 150, 150);
    rec.log_static(paths::map(name).as_str(), &rerun::LineStrips2D::new(lanes).with_colors([grey]).with_radii([0.05]).with_draw_order(-10.0))?;
    let vertices: Vec<[f32; 2]> = (0..g.vertices.len() as u32).map(at).collect();
    rec.log_static(paths::map_vertices(name).as_str(), &rerun::Points2D::new(vertices).with_colors([grey]).with_radii([0.12]).with_draw_order(-9.0))?;
    let (points, labels): (Vec<[f32; 2]>, Vec<String>) = g.chargers().map(|v| ([v.at.x as f32, v.at.y as f32], v.name.clone())).unzip();
    if points.is_empty() {
        return Ok(());
    }
    let green = rerun::Color::from_rgb(26, 127, 55);
    rec.log_static(
        paths::map_chargers(name).as_str(),
        &rerun::Points2D::new(points).with_colors([green]).with_radii([0.3]).with_labels(labels).with_draw_order(-8.0),
    )
}
