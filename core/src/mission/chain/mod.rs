//! Chain replication of a mission manager's state, as a pure state machine generic over the
//! replicated value. No I/O, no clock: [`Replica::handle`] takes the time and an [`Event`] and
//! returns [`Command`]s.
//!
//! # Protocol
//! A mission's **configuration** is `(epoch, chain)`: `chain[0]` is the head (the node running the
//! mission manager), the rest are its replicas in order (`k` of them, default 2). The chain's nodes
//! are also the configuration's **voters**.
//!
//! * **Updates** flow head → tail: the head sends `Update { config, seq, state }` (the whole
//!   state) to `chain[1]`, each node stores it and forwards its own (newest) state, the tail
//!   acknowledges to the head. Version `(epoch, seq)` orders states. An update is **committed**
//!   once the tail acknowledges it: it is then on every node of the chain. The head acts on the
//!   outside world (plans to robots, answers) only for committed state. The head re-sends its
//!   newest state every `beat`: that is also the heartbeat.
//! * **Configuration changes** (a takeover, a repair after a middle or tail failure, the initial
//!   chain) are elections: a candidate asks for votes for `epoch + 1` with its proposed chain. A
//!   node grants at most one candidate per epoch, never an epoch below one it promised, and only
//!   to a candidate whose state version is at least its own (Raft's up-to-date rule). A candidate
//!   wins with a majority of its current chain **and** a majority of the proposed chain (joint
//!   majorities make any change safe), and the proposed chain must keep a majority of the current
//!   one. Since a commit needs every node of the chain, and every majority of an older chain meets
//!   a node of the newer one (which then refuses a candidate with an older state), the up-to-date
//!   rule puts every committed update in the winner.
//! * **Takeover**: when the head's liveliness is lost, the first live successor stands at once;
//!   the others stand after `silence` without hearing from a head (staggered by position).
//! * **Fencing**: a node that promised epoch `e` refuses updates of older epochs and answers
//!   `Stale`; an old head cannot commit anything once a majority of its chain moved on, so it can
//!   never act again. A head told of a newer state steps down; one told only of a higher promise
//!   re-elects itself.
//! * **Restarts** of a node without storage lose everything. A node that holds no state refuses
//!   to vote as a member of the candidate's current chain (it lost what it held there; a
//!   restarted node is not its former self) — unless that chain has two nodes and the candidate
//!   is its head: every change of a two-node chain needs both votes, so no newer configuration
//!   exists without that head — and no node votes during its first `quarantine` seconds, so a
//!   vote given before a crash cannot be given again to another candidate of that epoch.
//! * **Restarts with storage** lose nothing that counts: a [`Registry`] made `durable` puts a
//!   [`Command::Persist`] of a value's promise, vote, configuration and state *before* any
//!   command its change leads to (a grant, an ack, a forwarded update), so the driver writes it
//!   to disk before anything leaves the node (Raft's rule for `currentTerm`, `votedFor` and the
//!   log). [`Registry::restore`] brings the replicas back as followers that vote at once (no
//!   quarantine: the promise and the vote are on disk) and count as the members they were; one
//!   that was the head stands again after its chain was silent for `silence` times its length.
//!   A durable replica keeps its state when a newer chain passes it over (it may be in a newer
//!   chain whose head has not reached it yet), but each time it stands and learns of a newer
//!   chain it waits twice as long before standing again (up to 2^[`PASSED_OVER_MAX`] times), until
//!   a head is heard.
//!
//! A node holds one replica per mission in a [`Registry`], which also remembers, for missions it
//! no longer replicates, the promise it made and whether the mission ended (so stragglers are told).
//! The messages and configurations are wire types: `mrmm_proto::chain`.

mod registry;
mod replica;
#[cfg(test)]
mod tests;

pub use mrmm_proto::chain::{Config, Msg, Version};
use mrmm_proto::NodeId;
pub use registry::{Disk, Registry, Tomb};
pub use replica::{Replica, Role, PASSED_OVER_MAX};

/// Timing and size of a chain.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Params {
    /// Replicas after the head.
    pub k: usize,
    /// Seconds between two re-sends of the head's state (the heartbeat).
    pub beat: f64,
    /// A candidate gives up an epoch after this many seconds and tries the next.
    pub vote_timeout: f64,
    /// A replica stands after this many seconds without a head (times its position in the chain).
    pub silence: f64,
    /// A freshly started node does not vote for this long.
    pub quarantine: f64,
}

impl Default for Params {
    fn default() -> Self {
        Params { k: 2, beat: 0.25, vote_timeout: 0.5, silence: 3.0, quarantine: 2.0 }
    }
}

/// Something that happened to a replica.
#[derive(Debug, Clone, PartialEq)]
pub enum Event<S> {
    /// Time passes (call every few tens of milliseconds).
    Tick,
    Recv {
        from: NodeId,
        msg: Msg<S>,
    },
    /// A node's liveliness appeared.
    Alive(NodeId),
    /// A node's liveliness was lost.
    Gone(NodeId),
    /// Create the replicated value with this node as head and `replicas` after it, its first
    /// epoch at least `floor` (a new lineage: `mrmm_proto::chain::lineage_floor`).
    Create {
        replicas: Vec<NodeId>,
        state: S,
        floor: u64,
    },
    /// Head only: replicate a new state.
    Propose(S),
    /// Head only: nodes that may join the chain when one is missing, best first, and how many
    /// replicas the chain should have.
    Pool {
        nodes: Vec<NodeId>,
        k: usize,
    },
    /// Head only: end the replicated value on every node of the chain.
    End,
}

/// What the driver must do.
#[derive(Debug, Clone, PartialEq)]
pub enum Command<S> {
    Send {
        to: NodeId,
        msg: Msg<S>,
    },
    /// This node now leads `config`, starting from `state` (epoch `config.epoch`, seq 0).
    Lead {
        config: Config,
        state: S,
    },
    /// Everything up to `(epoch, seq)` is on every node of the chain.
    Committed {
        epoch: u64,
        seq: u64,
    },
    /// This node no longer leads: stop acting for the mission.
    StepDown,
    /// This node is out of the mission's chain for good and holds nothing: forget it.
    Retired,
    /// Durable registries only, always before the commands the change leads to: write what this
    /// node must remember of the value across a restart (and sync it) before going on.
    Persist(Disk<S>),
}

/// What a replica must keep across a restart: its promise and vote, its configuration and its
/// newest state (committed or not: it may have acknowledged it).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Stored<S> {
    pub promised: u64,
    pub voted_for: Option<NodeId>,
    pub config: Option<Config>,
    pub state: Option<(Version, S)>,
    /// The value is being ended: brought back as a tomb that tells stragglers so.
    #[serde(default)]
    pub ended: bool,
}
