//! A map as fleet data: its files (a Nav2 YAML and its image, or one graph file, with the floor
//! plan it is drawn on if it has one) in one bundle, named by the SHA-256 of their contents,
//! encoded for the wire and read back into a [`Map`].

use std::collections::BTreeMap;

use serde::de::IgnoredAny;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use crate::error::MapError;
use crate::{limits, nav2, patrolling_sim, rmf, roadmap, Map, NavGraph, OccupancyGrid};

/// The formats mrmm reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Format {
    /// Nav2 / ROS map_server: YAML + PGM/PNG occupancy grid.
    Nav2,
    /// patrolling_sim's `.graph` navigation graph.
    PatrollingSim,
    /// Open-RMF's navigation graph YAML.
    OpenRmf,
}

impl Format {
    pub fn as_str(self) -> &'static str {
        match self {
            Format::Nav2 => "nav2",
            Format::PatrollingSim => "patrolling_sim",
            Format::OpenRmf => "open_rmf",
        }
    }
}

/// A map's files: the main one (what the operator named) and what it refers to, by the names it
/// uses for them.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Bundle {
    pub main: String,
    pub files: BTreeMap<String, Vec<u8>>,
}

const MAGIC: &[u8] = b"MRMMMAP1";

/// Where a graph map's floor plan lies in its bundle: its Nav2 YAML under this name, its image
/// under [`FLOOR_PLAN_DIR`] and the name the YAML gives it. A main file's name has no `/`.
pub const FLOOR_PLAN_YAML: &str = "floor_plan/map.yaml";
/// The folder of a floor plan's files in a bundle.
pub const FLOOR_PLAN_DIR: &str = "floor_plan/";

#[derive(Deserialize)]
struct Sniff {
    #[serde(default)]
    levels: Option<IgnoredAny>,
    #[serde(default)]
    image: Option<IgnoredAny>,
}

/// The format of a main file, from its name and content.
pub fn detect(name: &str, bytes: &[u8]) -> Result<Format, MapError> {
    let lower = name.to_ascii_lowercase();
    if lower.ends_with(".graph") {
        return Ok(Format::PatrollingSim);
    }
    let text = std::str::from_utf8(bytes).map_err(|_| {
        MapError::malformed(name, "file", "not a text file: give a Nav2 map's YAML (not its image), a patrolling_sim .graph or an Open-RMF navigation graph")
    })?;
    let s: Sniff = nav2::yaml(name, text)?;
    match (s.levels.is_some(), s.image.is_some()) {
        (true, _) => Ok(Format::OpenRmf),
        (false, true) => Ok(Format::Nav2),
        (false, false) => Err(MapError::malformed(
            name,
            "top level",
            "neither a Nav2 map (an image field) nor an Open-RMF navigation graph (a levels field); patrolling_sim graphs end in .graph",
        )),
    }
}

fn base_name(path: &str) -> &str {
    path.rsplit(['/', '\\']).next().unwrap_or(path)
}

fn dir_of(path: &str) -> &str {
    match path.rfind(['/', '\\']) {
        Some(i) => &path[..=i],
        None => "",
    }
}

impl Bundle {
    /// Collects the files of the map at `path`: `read(p)` returns the bytes of the file at `p`
    /// (the caller does the I/O). A Nav2 YAML's image is read beside it unless its name is
    /// absolute.
    pub fn collect(path: &str, mut read: impl FnMut(&str) -> Result<Vec<u8>, String>) -> Result<Bundle, MapError> {
        let main = base_name(path).to_string();
        let bytes = read(path).map_err(|e| MapError::Missing { file: path.to_string(), problem: e })?;
        if bytes.len() > limits::MAX_TEXT_BYTES {
            return Err(MapError::too_large(path, format!("{} bytes, at most {}", bytes.len(), limits::MAX_TEXT_BYTES)));
        }
        let format = detect(path, &bytes)?;
        let mut files = BTreeMap::new();
        if format == Format::Nav2 {
            let meta = nav2::parse_yaml(path, std::str::from_utf8(&bytes).unwrap_or_default())?;
            let image_path = if meta.image.starts_with('/') { meta.image.clone() } else { format!("{}{}", dir_of(path), meta.image) };
            let image = read(&image_path).map_err(|e| MapError::Missing { file: image_path.clone(), problem: format!("the image {path} names: {e}") })?;
            if image.len() > limits::MAX_IMAGE_BYTES {
                return Err(MapError::too_large(&image_path, format!("{} bytes, at most {}", image.len(), limits::MAX_IMAGE_BYTES)));
            }
            files.insert(meta.image, image);
        }
        files.insert(main.clone(), bytes);
        Ok(Bundle { main, files })
    }

    /// [`Bundle::collect`] for a graph map drawn on a floor plan (a Nav2 map's YAML at `plan`,
    /// in the graph's frame): the plan's files go into the bundle under [`FLOOR_PLAN_DIR`], and
    /// the map loads with its two-way lanes marked passing where the plan has room for two
    /// robots side by side ([`roadmap::mark_passing_on`], [`roadmap::Params`]' defaults).
    /// [`Bundle::load`] checks the plan: every vertex stands in its free space.
    pub fn collect_on_plan(path: &str, plan: &str, mut read: impl FnMut(&str) -> Result<Vec<u8>, String>) -> Result<Bundle, MapError> {
        let mut bundle = Bundle::collect(path, &mut read)?;
        if bundle.format()? == Format::Nav2 {
            return Err(MapError::Invalid(format!("{plan}: a floor plan goes with a navigation graph; {path} is a grid map (its own floor plan)")));
        }
        let p = Bundle::collect(plan, &mut read)?;
        if p.format()? != Format::Nav2 {
            return Err(MapError::Invalid(format!("{plan}: a floor plan is a Nav2 map's YAML (with an image field), not a navigation graph")));
        }
        for (name, bytes) in p.files {
            let key = if name == p.main { FLOOR_PLAN_YAML.to_string() } else { format!("{FLOOR_PLAN_DIR}{name}") };
            if bundle.files.insert(key, bytes).is_some() {
                return Err(MapError::Invalid(format!("{plan}: its image may not be named \"map.yaml\"")));
            }
        }
        Ok(bundle)
    }

    /// The format of the main file.
    pub fn format(&self) -> Result<Format, MapError> {
        detect(&self.main, self.main_bytes()?)
    }

    fn main_bytes(&self) -> Result<&[u8], MapError> {
        self.files.get(&self.main).map(Vec::as_slice).ok_or_else(|| MapError::Missing { file: self.main.clone(), problem: "not in the map's bundle".into() })
    }

    /// Reads the map.
    pub fn load(&self) -> Result<(Format, Map), MapError> {
        let bytes = self.main_bytes()?;
        let format = detect(&self.main, bytes)?;
        let text = std::str::from_utf8(bytes).map_err(|e| MapError::malformed(&self.main, "text", format!("not UTF-8 ({e})")))?;
        let map = match format {
            Format::PatrollingSim => Map::Graph(self.on_plan(patrolling_sim::parse(&self.main, text)?)?),
            Format::OpenRmf => Map::Graph(self.on_plan(rmf::parse(&self.main, text)?)?),
            Format::Nav2 => {
                let meta = nav2::parse_yaml(&self.main, text)?;
                let image = self
                    .files
                    .get(&meta.image)
                    .ok_or_else(|| MapError::Missing { file: meta.image.clone(), problem: format!("the image {} names is not in the bundle", self.main) })?;
                Map::Grid(nav2::grid(&meta, &meta.image, image)?)
            }
        };
        Ok((format, map))
    }

    /// The floor plan a graph map is drawn on, if its bundle has one.
    pub fn floor_plan(&self) -> Result<Option<OccupancyGrid>, MapError> {
        let Some(yaml) = self.files.get(FLOOR_PLAN_YAML) else { return Ok(None) };
        let what = format!("{}'s floor plan", self.main);
        let text = std::str::from_utf8(yaml).map_err(|e| MapError::malformed(&what, "text", format!("not UTF-8 ({e})")))?;
        let meta = nav2::parse_yaml(&what, text)?;
        let key = format!("{FLOOR_PLAN_DIR}{}", meta.image);
        let image = self
            .files
            .get(&key)
            .ok_or_else(|| MapError::Missing { file: meta.image.clone(), problem: format!("the image {what} names is not in the bundle") })?;
        nav2::grid(&meta, &meta.image, image).map(Some)
    }

    /// `graph` with its two-way lanes marked passing where its floor plan has room (those its
    /// file marks stay marked); as it is without a plan. A vertex outside the plan's free space
    /// means the plan is not this graph's (or not in its frame): an error naming the vertex.
    fn on_plan(&self, graph: NavGraph) -> Result<NavGraph, MapError> {
        let Some(grid) = self.floor_plan()? else { return Ok(graph) };
        if let Some(v) = graph.vertices.iter().find(|v| !grid.is_free(v.at)) {
            return Err(MapError::Invalid(format!(
                "{}: vertex {:?} at ({:.2}, {:.2}) is not in free space of its floor plan: is the plan this graph's, in the same frame?",
                self.main, v.name, v.at.x, v.at.y
            )));
        }
        let p = roadmap::Params::default();
        Ok(roadmap::mark_passing_on(&grid, graph, p.radius, p.passing))
    }

    /// Bytes of every file together.
    pub fn size(&self) -> usize {
        self.files.values().map(Vec::len).sum()
    }

    /// The content hash: SHA-256 (hex) of the encoded bundle.
    pub fn hash(&self) -> String {
        content_hash(&self.encode())
    }

    /// The bundle on the wire: magic, the main file's name, then each file's name and bytes,
    /// lengths as little-endian u32 / u64.
    pub fn encode(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(self.size() + 64);
        out.extend_from_slice(MAGIC);
        put_str(&mut out, &self.main);
        out.extend_from_slice(&(self.files.len() as u32).to_le_bytes());
        for (name, bytes) in &self.files {
            put_str(&mut out, name);
            out.extend_from_slice(&(bytes.len() as u64).to_le_bytes());
            out.extend_from_slice(bytes);
        }
        out
    }

    /// Reads an encoded bundle; `what` names it in errors.
    pub fn decode(what: &str, mut b: &[u8]) -> Result<Bundle, MapError> {
        let bad = |p: &str| MapError::malformed(what, "bundle", p.to_string());
        if !b.starts_with(MAGIC) {
            return Err(bad("not a map bundle"));
        }
        b = &b[MAGIC.len()..];
        let main = take_str(&mut b).ok_or_else(|| bad("truncated name"))?;
        let count = take_u32(&mut b).ok_or_else(|| bad("truncated"))? as usize;
        if count == 0 || count > limits::MAX_FILES {
            return Err(bad(&format!("{count} files, 1 to {} expected", limits::MAX_FILES)));
        }
        let mut files = BTreeMap::new();
        for _ in 0..count {
            let name = take_str(&mut b).ok_or_else(|| bad("truncated name"))?;
            let len = take_u64(&mut b).ok_or_else(|| bad("truncated"))?;
            if len > (limits::MAX_IMAGE_BYTES as u64) || len > b.len() as u64 {
                return Err(bad(&format!("file {name:?} of {len} bytes does not fit")));
            }
            let (data, rest) = b.split_at(len as usize);
            b = rest;
            if files.insert(name.clone(), data.to_vec()).is_some() {
                return Err(bad(&format!("file {name:?} twice")));
            }
        }
        if !b.is_empty() {
            return Err(bad("bytes after the last file"));
        }
        if !files.contains_key(&main) {
            return Err(bad(&format!("its main file {main:?} is missing")));
        }
        Ok(Bundle { main, files })
    }
}

/// The content hash of an encoded bundle: SHA-256, lower-case hex.
pub fn content_hash(encoded: &[u8]) -> String {
    hex(&Sha256::digest(encoded))
}

/// Lower-case hexadecimal.
pub fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

fn put_str(out: &mut Vec<u8>, s: &str) {
    out.extend_from_slice(&(s.len() as u32).to_le_bytes());
    out.extend_from_slice(s.as_bytes());
}

fn take_u32(b: &mut &[u8]) -> Option<u32> {
    let (h, t) = b.split_at_checked(4)?;
    *b = t;
    Some(u32::from_le_bytes(h.try_into().ok()?))
}

fn take_u64(b: &mut &[u8]) -> Option<u64> {
    let (h, t) = b.split_at_checked(8)?;
    *b = t;
    Some(u64::from_le_bytes(h.try_into().ok()?))
}

fn take_str(b: &mut &[u8]) -> Option<String> {
    let n = take_u32(b)? as usize;
    if n > 4096 {
        return None;
    }
    let (h, t) = b.split_at_checked(n)?;
    *b = t;
    String::from_utf8(h.to_vec()).ok()
}
