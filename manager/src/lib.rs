//! mrmm managers' drivers: the system manager with its journal and the advising agent in central,
//! mission hosts, planner services and site routers, each running machines of `mrmm-core` over
//! Zenoh (its inbox, its queries, its durable state).
//!
//! | machine (`mrmm-core`) | driver |
//! |---|---|
//! | `central::CentralCore` (system manager + agent) | [`central`] |
//! | `host::HostCore` (mission managers, chain replicas) | [`host`] |
//! | `planning::plan_on` | [`planner_service`] |
//! | `traffic::deputy::Deputy` (on a robot's node) | [`deputy`] |
// Functions outside tests are at most 80 lines (clippy.toml); tests may be longer.
#![cfg_attr(not(test), deny(clippy::too_many_lines))]

pub mod central;
pub mod deputy;
pub mod edge;
pub mod error;
pub mod host;
pub mod journal;
pub mod load;
pub mod maps;
pub mod planner_service;
pub mod site_router;

pub use error::ManagerError;
