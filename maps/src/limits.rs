//! Upper bounds on what a map may make a node read, hold or search: each is checked as the input
//! enters, with an error naming the file and the limit.

/// Bytes of a map's YAML or `.graph` text.
pub const MAX_TEXT_BYTES: usize = 16 * 1024 * 1024;
/// Bytes of a map's image file.
pub const MAX_IMAGE_BYTES: usize = 64 * 1024 * 1024;
/// Cells of an occupancy grid (e.g. 8 000 × 6 000).
pub const MAX_CELLS: u64 = 50_000_000;
/// Cells across or up.
pub const MAX_SIDE: u32 = 20_000;
/// Vertices of a navigation graph.
pub const MAX_VERTICES: usize = 20_000;
/// Directed edges of a navigation graph.
pub const MAX_EDGES: usize = 200_000;
/// Neighbours of one patrolling_sim vertex (its format holds eight directions).
pub const MAX_NEIGHBOURS: usize = 8;
/// Files of one map bundle (the YAML and its image).
pub const MAX_FILES: usize = 4;
/// Largest coordinate of a map, metres from the origin.
pub const MAX_COORDINATE: f64 = 1e6;
/// Cells of the planning grid a map is searched on (coarser cells beyond it).
pub const MAX_PLANNING_CELLS: usize = 400_000;
