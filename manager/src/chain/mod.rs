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
//! * **Restarts** lose everything. A node that holds no state refuses to vote as a member of the
//!   candidate's current chain (it lost what it held there; a restarted node is not its former
//!   self), and no node votes during its first `quarantine` seconds, so a vote given before a
//!   crash cannot be given again to another candidate of that epoch.

mod replica;
pub mod sim;
#[cfg(test)]
mod tests;

use serde::{Deserialize, Serialize};

pub use replica::{Replica, Role};

/// A state's version: `(epoch, seq)`, compared lexicographically.
pub type Version = (u64, u64);

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

/// Who holds the mission: `chain[0]` is the head.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Config {
    pub epoch: u64,
    pub chain: Vec<String>,
}

impl Config {
    pub fn head(&self) -> &str {
        self.chain.first().map(String::as_str).unwrap_or("")
    }
    /// The node after `node` in the chain.
    pub fn next(&self, node: &str) -> Option<&str> {
        let i = self.chain.iter().position(|n| n == node)?;
        self.chain.get(i + 1).map(String::as_str)
    }
    pub fn contains(&self, node: &str) -> bool {
        self.chain.iter().any(|n| n == node)
    }
    /// Whether `votes` hold a strict majority of this chain.
    pub fn majority(&self, votes: impl Fn(&str) -> bool) -> bool {
        2 * self.chain.iter().filter(|n| votes(n)).count() > self.chain.len()
    }
}

/// A message between the nodes of a chain.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Msg<S> {
    /// Vote for me as head of `proposal` (epoch `proposal.epoch`); my state is at `last`, my
    /// current chain is `base`.
    Vote { proposal: Config, base: Vec<String>, last: Version },
    Grant { epoch: u64 },
    /// Not granted: I promised `promised`, my state is at `last`.
    Refuse { epoch: u64, promised: u64, last: Version },
    /// The head's state at `(config.epoch, seq)`.
    Update { config: Config, seq: u64, state: S },
    /// The tail holds `(epoch, seq)`.
    Ack { epoch: u64, seq: u64 },
    /// Your update is of an old epoch: I promised `promised`, my state is at `last`.
    Stale { promised: u64, last: Version },
    /// The replicated value ended (the mission was terminated): forget it, forward down the chain.
    End { epoch: u64 },
    /// The tail forgot the value of `epoch`.
    EndAck { epoch: u64 },
}

/// Something that happened to a replica.
#[derive(Debug, Clone, PartialEq)]
pub enum Event<S> {
    /// Time passes (call every few tens of milliseconds).
    Tick,
    Recv { from: String, msg: Msg<S> },
    /// A node's liveliness appeared.
    Alive(String),
    /// A node's liveliness was lost.
    Gone(String),
    /// Create the replicated value with this node as head and `replicas` after it.
    Create { replicas: Vec<String>, state: S },
    /// Head only: replicate a new state.
    Propose(S),
    /// Head only: nodes that may join the chain when one is missing, best first, and how many
    /// replicas the chain should have.
    Pool { nodes: Vec<String>, k: usize },
    /// Head only: end the replicated value on every node of the chain.
    End,
}

/// What the driver must do.
#[derive(Debug, Clone, PartialEq)]
pub enum Command<S> {
    Send { to: String, msg: Msg<S> },
    /// This node now leads `config`, starting from `state` (epoch `config.epoch`, seq 0).
    Lead { config: Config, state: S },
    /// Everything up to `(epoch, seq)` is on every node of the chain.
    Committed { epoch: u64, seq: u64 },
    /// This node no longer leads: stop acting for the mission.
    StepDown,
    /// This node is out of the mission's chain for good and holds nothing: forget it.
    Retired,
}
