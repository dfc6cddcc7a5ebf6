//! The maps as the page draws them: a grid map as a PNG (free white, occupied black, unknown
//! grey; the image's top row is the map's top) with where it lies in metres, a graph map as its
//! lanes and vertices. Made once per map, from the bundle fetched from the fleet by its hash.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use mrmm_maps::{Map, OccupancyGrid};
use serde::Serialize;
use serde_json::{json, Value};

/// One map's layer: what `/api/map/<hash>` answers, and the image `/api/map/<hash>/png` serves.
#[derive(Debug, Clone)]
pub struct Layer {
    pub json: Value,
    pub png: Option<Arc<Vec<u8>>>,
}

/// The layers made so far, by hash, shared with the HTTP side.
pub type Layers = Arc<Mutex<HashMap<String, Layer>>>;

#[derive(Serialize)]
struct GridPlace {
    /// Cells across and up, metres per cell, pose of the lower-left corner (x, y, yaw).
    width: u32,
    height: u32,
    resolution: f64,
    origin: [f64; 3],
}

/// The layer of `map` (`name`, `hash`), or why it cannot be drawn.
pub fn layer(name: &str, hash: &str, map: &Map) -> Result<Layer, String> {
    match map {
        Map::Grid(g) => Ok(Layer {
            json: json!({ "name": name, "hash": hash, "kind": "grid", "grid": GridPlace { width: g.width, height: g.height, resolution: g.resolution, origin: g.origin } }),
            png: Some(Arc::new(png(g)?)),
        }),
        Map::Graph(g) => {
            let at = |i: u32| {
                let p = g.vertices[i as usize].at;
                [p.x, p.y]
            };
            let lanes: Vec<[f64; 4]> = g.lanes().iter().map(|&(a, b)| [at(a)[0], at(a)[1], at(b)[0], at(b)[1]]).collect();
            let vertices: Vec<[f64; 2]> = (0..g.vertices.len() as u32).map(at).collect();
            Ok(Layer { json: json!({ "name": name, "hash": hash, "kind": "graph", "lanes": lanes, "vertices": vertices }), png: None })
        }
    }
}

/// The occupancy grid as a grey PNG, top row first.
fn png(g: &OccupancyGrid) -> Result<Vec<u8>, String> {
    let (w, h) = (g.width as usize, g.height as usize);
    let mut pixels = vec![0u8; w * h];
    for row in 0..h {
        let from = &g.data[row * w..(row + 1) * w];
        let to = &mut pixels[(h - 1 - row) * w..(h - row) * w];
        for (p, &v) in to.iter_mut().zip(from) {
            *p = if v < 0 { 205 } else { 255 - (v.clamp(0, 100) as u16 * 255 / 100) as u8 };
        }
    }
    let mut out = Vec::new();
    image::ImageEncoder::write_image(image::codecs::png::PngEncoder::new(&mut out), &pixels, g.width, g.height, image::ExtendedColorType::L8)
        .map_err(|e| format!("cannot draw the map: {e}"))?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_grid_is_a_png_with_its_top_row_first() {
        let g = OccupancyGrid { width: 2, height: 2, resolution: 0.5, origin: [1.0, 2.0, 0.0], data: vec![0, 100, -1, 0] };
        let l = layer("m", "h", &Map::Grid(g)).expect("layer");
        assert_eq!(l.json["grid"]["resolution"], 0.5);
        let img = image::load_from_memory(l.png.as_deref().expect("png")).expect("a PNG").to_luma8();
        // Map row 0 (free, occupied) is the image's bottom row; row 1 (unknown, free) its top.
        assert_eq!(img.as_raw(), &vec![205, 255, 255, 0]);
    }
}
