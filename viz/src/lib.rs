//! mrmm fleet view: subscribes to the fleet over Zenoh and streams it to Rerun — the map (patrol
//! tours, waypoints, coverage points), each robot's pose, heading and trail coloured by mission,
//! team membership, barrier events, the advising agent's advice, per-mission scalars, and traffic
//! on graph maps (lanes held, who waits for whom), all on one `fleet_time` timeline. Only this crate depends on rerun.
// Functions outside tests are at most 80 lines (clippy.toml); tests may be longer.
#![cfg_attr(not(test), deny(clippy::too_many_lines))]

pub mod bridge;
pub mod map;
pub mod paths;
mod view;

use thiserror::Error;

pub use bridge::{run, Sink};

/// Everything that can go wrong in the viewer bridge.
#[derive(Debug, Error)]
pub enum VizError {
    #[error("rerun: {0}")]
    Rerun(#[source] mrmm_proto::BoxError),
    #[error("zenoh: {0}")]
    Zenoh(#[source] mrmm_proto::BoxError),
    #[error("{0}")]
    Config(String),
}
