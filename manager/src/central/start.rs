//! What central opens at start-up: its session's settings, its journal and the chain state of its
//! mission host, the maps it offers. Anything that cannot be opened stops start-up with one line.

use mrmm_net::net::Mode;
use mrmm_net::NodeNet;
use mrmm_proto::{self as proto, Role, Sender};

use super::CentralConfig;
use crate::error::ManagerError;
use crate::journal::Journal;
use mrmm_core::central::system;

/// Central's session: the fleet's router, listening where its config says.
pub(super) fn node_net(cfg: &CentralConfig) -> NodeNet {
    NodeNet {
        mode: Mode::Router,
        listen: cfg.listen.clone(),
        connect: vec![],
        lease_ms: cfg.lease_ms,
        max_message_size: cfg.max_message_size,
        security: cfg.security.clone(),
        me: Some(Sender::new(Role::Central, proto::CENTRAL_HOST)),
        wire_stats: cfg.wire_stats,
    }
}

/// The journal (a state dir another central uses, or a damaged one, stops start-up) and the
/// state it replays; beside it, the chain state of central's mission host (`chain.redb`): a
/// mission it leads or replicates comes back through its chain after a restart, as on a robot
/// with a state dir, rather than wait for a vote the host forgot it gave.
pub(super) type State = (Option<Journal>, system::Durable, Option<crate::host::store::Opened>);

pub(super) fn open_state(cfg: &CentralConfig) -> Result<State, ManagerError> {
    // The journal first: a state dir another central uses, or a damaged one, stops start-up.
    // Its mission host keeps its chain state beside the journal (`chain.redb`): a mission it
    // leads or replicates comes back through its chain after a restart, as on a robot with a
    // state dir, rather than wait for a vote the host forgot it gave.
    Ok(match &cfg.state_dir {
        Some(dir) => {
            let (j, state) = Journal::open(dir)?;
            tracing::info!(dir = %dir.display(), entries = j.last(), missions = state.missions.len(), robots = state.assignment.len(), "journal replayed");
            let chain = crate::host::store::Store::open(dir)?;
            (Some(j), state, Some(chain))
        }
        None => {
            tracing::warn!("no state dir: central keeps nothing on disk, and a restart forgets every mission");
            (None, system::Durable::default(), None)
        }
    })
}

/// The maps central offers (its config's, kept in its state dir by content), and the former
/// versions of them that missions of its journal plan on: one that cannot be read stops start-up
/// with one line naming it.
pub(super) fn load_maps(cfg: &CentralConfig, state: &system::Durable) -> Result<crate::maps::MapStore, ManagerError> {
    let archive = cfg.state_dir.as_deref().map(crate::maps::MapArchive::new);
    let journaled: Vec<proto::MapRef> = state.missions.values().filter_map(|d| d.spec.as_ref().and_then(|s| s.map.clone())).collect();
    tokio::task::block_in_place(|| crate::maps::load_central(&cfg.maps, &cfg.floor_plans, &cfg.chargers, archive.as_ref(), &journaled))
}
