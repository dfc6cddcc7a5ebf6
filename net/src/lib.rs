//! mrmm's sessions: everything that touches the network or a key. The wire types and keys these
//! carry are `mrmm-proto`'s (no I/O); the decisions are `mrmm-core`'s.
//!
//! - [`mesh`]: the Zenoh session every node opens (TLS or QUIC with mutual certificates, or plain
//!   TCP for development), sealing what it sends and proving who sent what it receives;
//! - [`security`]: certificates, seals, pair keys and the PKI;
//! - [`net`]: queries, liveliness checks and wire statistics;
//! - [`inbox`]: the bounded queues from Zenoh's callbacks to a node's loop, every node's one
//!   discipline;
//! - [`client`]: the operator's client of central;
//! - [`map`]: map bundles fetched chunk by chunk;
//! - [`clock`]: a live node's clock for its machine.
// Functions outside tests are at most 80 lines (clippy.toml); tests may be longer.
#![cfg_attr(not(test), deny(clippy::too_many_lines))]

pub mod client;
pub mod clock;
pub mod follow;
pub mod inbox;
pub mod map;
pub mod mesh;
pub mod net;
pub mod security;

pub use follow::Following;
pub use mesh::{Mesh, NodeNet};
pub use net::encoding_of;
