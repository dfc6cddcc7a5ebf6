//! Nav2 / ROS map_server maps: a YAML file (`image`, `resolution`, `origin`, `negate`,
//! `occupied_thresh`, `free_thresh`, `mode`) and the image it names, converted to occupancy as
//! `nav2_map_server`'s `map_io` does: a pixel's shade is the mean of its colour channels (in
//! trinary mode with the alpha channel too), its occupancy `1 - shade` (`shade` with `negate`),
//! then the thresholds by mode; image row 0 is the top of the map.

use std::io::Cursor;

use serde::Deserialize;

use crate::error::MapError;
use crate::grid::{OccupancyGrid, UNKNOWN};
use crate::limits;

/// How shades become occupancy (`mode`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    #[default]
    Trinary,
    Scale,
    Raw,
}

/// The YAML of a Nav2 map.
#[derive(Debug, Clone, PartialEq)]
pub struct Nav2Yaml {
    /// The image file, as the YAML names it (relative to the YAML's folder unless absolute).
    pub image: String,
    pub resolution: f64,
    pub origin: [f64; 3],
    pub negate: bool,
    pub occupied_thresh: f64,
    pub free_thresh: f64,
    pub mode: Mode,
}

#[derive(Deserialize)]
struct Raw {
    image: String,
    resolution: f64,
    origin: Vec<f64>,
    #[serde(default)]
    negate: Option<Negate>,
    occupied_thresh: f64,
    free_thresh: f64,
    #[serde(default)]
    mode: Option<Mode>,
}

/// `negate` is an integer or a boolean (map_io reads either).
#[derive(Deserialize)]
#[serde(untagged)]
enum Negate {
    Int(i64),
    Bool(bool),
}

/// Reads a YAML document with the crate's YAML options, naming the line and column of a fault.
pub(crate) fn yaml<T: serde::de::DeserializeOwned>(file: &str, text: &str) -> Result<T, MapError> {
    if text.len() > limits::MAX_TEXT_BYTES {
        return Err(MapError::too_large(file, format!("{} bytes, at most {}", text.len(), limits::MAX_TEXT_BYTES)));
    }
    let options = serde_saphyr::options! { with_snippet: false };
    serde_saphyr::from_str_with_options(text, options).map_err(|e| {
        let at = e.location().map(|l| format!("line {} column {}", l.line(), l.column())).unwrap_or_else(|| "YAML".into());
        let msg = e.without_snippet().to_string();
        let first = msg.lines().next().unwrap_or("not valid YAML").trim();
        let first = first.strip_prefix("error: ").unwrap_or(first);
        let problem = match first.split_once(": ") {
            Some((head, rest)) if head.starts_with("line ") => rest.to_string(),
            _ => first.to_string(),
        };
        MapError::malformed(file, at, problem)
    })
}

/// Reads and checks a Nav2 map YAML.
pub fn parse_yaml(file: &str, text: &str) -> Result<Nav2Yaml, MapError> {
    let raw: Raw = yaml(file, text)?;
    let field = |name: &str, problem: String| MapError::malformed(file, format!("field {name}"), problem);
    if raw.image.trim().is_empty() {
        return Err(field("image", "is empty".into()));
    }
    if !(raw.resolution.is_finite() && raw.resolution > 0.0 && raw.resolution <= 100.0) {
        return Err(field("resolution", format!("{} is not a positive size of a cell in metres (at most 100)", raw.resolution)));
    }
    let origin: [f64; 3] = raw.origin.as_slice().try_into().map_err(|_| field("origin", format!("has {} elements, not 3 (x, y, yaw)", raw.origin.len())))?;
    if origin.iter().any(|v| !v.is_finite() || v.abs() > limits::MAX_COORDINATE) {
        return Err(field("origin", format!("{origin:?} is not a pose within {} m of zero", limits::MAX_COORDINATE)));
    }
    for (name, v) in [("occupied_thresh", raw.occupied_thresh), ("free_thresh", raw.free_thresh)] {
        if !(0.0..=1.0).contains(&v) {
            return Err(field(name, format!("{v} is not in [0, 1]")));
        }
    }
    if raw.free_thresh >= raw.occupied_thresh {
        return Err(field("free_thresh", format!("{} is not below occupied_thresh {}", raw.free_thresh, raw.occupied_thresh)));
    }
    let negate = match raw.negate {
        None => false,
        Some(Negate::Bool(b)) => b,
        Some(Negate::Int(0)) => false,
        Some(Negate::Int(1)) => true,
        Some(Negate::Int(v)) => return Err(field("negate", format!("{v} is neither 0 nor 1"))),
    };
    Ok(Nav2Yaml {
        image: raw.image,
        resolution: raw.resolution,
        origin,
        negate,
        occupied_thresh: raw.occupied_thresh,
        free_thresh: raw.free_thresh,
        mode: raw.mode.unwrap_or_default(),
    })
}

/// Decodes the map's image (PGM or PNG; any format the `image` crate knows by its magic bytes)
/// into an occupancy grid. `file` names the image in errors.
pub fn grid(meta: &Nav2Yaml, file: &str, bytes: &[u8]) -> Result<OccupancyGrid, MapError> {
    if bytes.len() > limits::MAX_IMAGE_BYTES {
        return Err(MapError::too_large(file, format!("{} bytes, at most {}", bytes.len(), limits::MAX_IMAGE_BYTES)));
    }
    let reader = image::ImageReader::new(Cursor::new(bytes)).with_guessed_format().map_err(|e| MapError::malformed(file, "image", e.to_string()))?;
    if reader.format().is_none() {
        return Err(MapError::malformed(file, "image", "not a PGM or PNG image"));
    }
    let (w, h) = reader.into_dimensions().map_err(|e| MapError::malformed(file, "image header", e.to_string()))?;
    if w == 0 || h == 0 || w > limits::MAX_SIDE || h > limits::MAX_SIDE || u64::from(w) * u64::from(h) > limits::MAX_CELLS {
        return Err(MapError::too_large(file, format!("{w} × {h} pixels; at most {} per side and {} in all, none empty", limits::MAX_SIDE, limits::MAX_CELLS)));
    }
    let mut reader = image::ImageReader::new(Cursor::new(bytes)).with_guessed_format().map_err(|e| MapError::malformed(file, "image", e.to_string()))?;
    let mut lim = image::Limits::default();
    lim.max_image_width = Some(limits::MAX_SIDE);
    lim.max_image_height = Some(limits::MAX_SIDE);
    lim.max_alloc = Some(limits::MAX_CELLS * 8);
    reader.limits(lim);
    let img = reader.decode().map_err(|e| MapError::malformed(file, "image data", e.to_string()))?;
    let alpha = img.color().has_alpha();
    let mut data = vec![UNKNOWN; w as usize * h as usize];
    let mut put = |x: u32, y: u32, rgba: [f64; 4]| {
        let row = (h - 1 - y) as usize;
        data[row * w as usize + x as usize] = cell(meta, rgba, alpha);
    };
    use image::DynamicImage as D;
    match &img {
        D::ImageLuma8(b) => b.enumerate_pixels().for_each(|(x, y, p)| put(x, y, gray(f64::from(p.0[0]) / 255.0, 1.0))),
        D::ImageLumaA8(b) => b.enumerate_pixels().for_each(|(x, y, p)| put(x, y, gray(f64::from(p.0[0]) / 255.0, f64::from(p.0[1]) / 255.0))),
        D::ImageLuma16(b) => b.enumerate_pixels().for_each(|(x, y, p)| put(x, y, gray(f64::from(p.0[0]) / 65535.0, 1.0))),
        D::ImageLumaA16(b) => b.enumerate_pixels().for_each(|(x, y, p)| put(x, y, gray(f64::from(p.0[0]) / 65535.0, f64::from(p.0[1]) / 65535.0))),
        D::ImageRgb8(b) => b.enumerate_pixels().for_each(|(x, y, p)| put(x, y, rgb(p.0.map(f64::from), 255.0, 1.0))),
        D::ImageRgba8(b) => {
            b.enumerate_pixels().for_each(|(x, y, p)| put(x, y, rgb([p.0[0], p.0[1], p.0[2]].map(f64::from), 255.0, f64::from(p.0[3]) / 255.0)))
        }
        D::ImageRgb16(b) => b.enumerate_pixels().for_each(|(x, y, p)| put(x, y, rgb(p.0.map(f64::from), 65535.0, 1.0))),
        D::ImageRgba16(b) => {
            b.enumerate_pixels().for_each(|(x, y, p)| put(x, y, rgb([p.0[0], p.0[1], p.0[2]].map(f64::from), 65535.0, f64::from(p.0[3]) / 65535.0)))
        }
        other => {
            let b = other.to_rgba32f();
            b.enumerate_pixels().for_each(|(x, y, p)| put(x, y, p.0.map(f64::from)));
        }
    }
    Ok(OccupancyGrid { width: w, height: h, resolution: meta.resolution, origin: meta.origin, data })
}

fn gray(v: f64, a: f64) -> [f64; 4] {
    [v, v, v, a]
}

fn rgb(c: [f64; 3], max: f64, a: f64) -> [f64; 4] {
    [c[0] / max, c[1] / max, c[2] / max, a]
}

/// One pixel (channels in [0, 1], alpha 1 = opaque) to occupancy, by map_io's rules.
fn cell(meta: &Nav2Yaml, [r, g, b, a]: [f64; 4], has_alpha: bool) -> i8 {
    let shade = if meta.mode == Mode::Trinary && has_alpha { (r + g + b + a) / 4.0 } else { (r + g + b) / 3.0 };
    let occ = if meta.negate { shade } else { 1.0 - shade };
    match meta.mode {
        Mode::Trinary => {
            if meta.occupied_thresh < occ {
                100
            } else if occ < meta.free_thresh {
                0
            } else {
                UNKNOWN
            }
        }
        Mode::Scale => {
            if a < 1.0 {
                UNKNOWN
            } else if meta.occupied_thresh < occ {
                100
            } else if occ < meta.free_thresh {
                0
            } else {
                ((occ - meta.free_thresh) / (meta.occupied_thresh - meta.free_thresh) * 100.0).round_ties_even() as i8
            }
        }
        Mode::Raw => {
            let v = (shade * 255.0).round();
            if (0.0..=100.0).contains(&v) {
                v as i8
            } else {
                UNKNOWN
            }
        }
    }
}
