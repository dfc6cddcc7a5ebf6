//! mrmm's nodes composed from their drivers, so that each `mrmm` subcommand only reads its
//! arguments and config (tokio's mini-redis: `server::run(listener, shutdown)`). Central, mission
//! hosts and site routers are one driver each (`mrmm_manager::central::run`,
//! `mrmm_manager::host::serve`, `mrmm_manager::site_router`); a robot's node is three on one
//! session ([`robot`]); the VDA 5050 gateway runs one robot per vehicle ([`vda5050`]). [`procs`] starts nodes as child processes (the demo's, the experiments').
// Functions outside tests are at most 80 lines (clippy.toml); tests may be longer.
#![cfg_attr(not(test), deny(clippy::too_many_lines))]

pub mod error;
pub mod procs;
pub mod robot;
pub mod vda5050;

pub use error::{NodeError, ProcError};
