//! mrmm planning core: patrol tours, optimal assignment, blanket coverage and XML recipes.
//! Plain data in, plain data out: no I/O, no clock, seeded randomness.
// Functions outside tests are at most 80 lines (clippy.toml); tests may be longer.
#![cfg_attr(not(test), deny(clippy::too_many_lines))]

pub mod assign;
pub mod corner;
pub mod coverage;
pub mod coverage_map;
pub mod error;
pub mod geom;
pub mod limits;
pub mod onmap;
pub mod patrol;
pub mod plan;
pub mod polyline;
pub mod recipe;
pub mod region;
pub mod tsp;
pub mod tsplib;

pub use error::PlanError;
pub use geom::Point;
pub use mrmm_maps as maps;
