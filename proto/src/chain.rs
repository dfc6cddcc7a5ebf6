//! Chain replication on the wire: the messages between the nodes of a mission manager's chain
//! (see `mrmm_manager::chain` for the protocol) and their envelope on `mrmm/hosts/<node>/chain`.

use serde::{Deserialize, Serialize};

use crate::mission::MissionSnapshot;

/// A state's version: `(epoch, seq)`, compared lexicographically.
pub type Version = (u64, u64);

/// A mission's **lineage** is the high 32 bits of its chain and plan epochs. Central starts a
/// mission of its journal anew (no live manager reported it) as the next lineage: every epoch of
/// the new lineage is above every epoch the old one can reach, so wherever the two meet — a node
/// of both chains, a robot given plans by both heads — the new one wins.
pub const LINEAGE_SHIFT: u32 = 32;

/// The lineage of an epoch.
pub fn lineage_of(epoch: u64) -> u32 {
    u32::try_from(epoch >> LINEAGE_SHIFT).unwrap_or(u32::MAX)
}

/// The first epoch of `lineage` (every epoch of it is at least this).
pub fn lineage_floor(lineage: u32) -> u64 {
    u64::from(lineage) << LINEAGE_SHIFT
}

/// Who holds the mission: `chain[0]` is the head.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Config {
    pub epoch: u64,
    pub chain: Vec<crate::ids::NodeId>,
}

impl Config {
    pub fn head(&self) -> &str {
        self.chain.first().map(|n| n.as_str()).unwrap_or("")
    }
    /// The node after `node` in the chain.
    pub fn next(&self, node: &str) -> Option<&str> {
        let i = self.chain.iter().position(|n| n == node)?;
        self.chain.get(i + 1).map(|n| n.as_str())
    }
    pub fn contains(&self, node: &str) -> bool {
        self.chain.iter().any(|n| n == node)
    }
    /// Whether `votes` hold a strict majority of this chain.
    pub fn majority(&self, votes: impl Fn(&str) -> bool) -> bool {
        2 * self.chain.iter().filter(|n| votes(n.as_str())).count() > self.chain.len()
    }
}

/// A message between the nodes of a chain, carrying states of type `S`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Msg<S> {
    /// Vote for me as head of `proposal` (epoch `proposal.epoch`); my state is at `last`, my
    /// current chain is `base`.
    Vote {
        proposal: Config,
        base: Vec<crate::ids::NodeId>,
        last: Version,
    },
    Grant {
        epoch: u64,
    },
    /// Not granted: I promised `promised`, my state is at `last`.
    Refuse {
        epoch: u64,
        promised: u64,
        last: Version,
    },
    /// The head's state at `(config.epoch, seq)`.
    Update {
        config: Config,
        seq: u64,
        state: S,
    },
    /// The head's state is still `(config.epoch, seq)`, which the whole chain has acknowledged:
    /// an [`Msg::Update`] without the state, sent as the heartbeat while nothing changes (a
    /// node that does not hold that state answers [`Msg::Behind`]).
    Beat {
        config: Config,
        seq: u64,
    },
    /// I do not hold the state of your beat of `epoch`: send it again.
    Behind {
        epoch: u64,
    },
    /// The tail holds `(epoch, seq)`.
    Ack {
        epoch: u64,
        seq: u64,
    },
    /// Your update is of an old epoch: I promised `promised`, my state is at `last`.
    Stale {
        promised: u64,
        last: Version,
    },
    /// The replicated value ended (the mission was terminated): forget it, forward down the chain.
    End {
        epoch: u64,
    },
    /// The tail forgot the value of `epoch`.
    EndAck {
        epoch: u64,
    },
    /// I will not replicate this value for you (I do not count you in it): leave me out of the
    /// chain of `epoch`.
    Decline {
        epoch: u64,
    },
}

impl<S> Msg<S> {
    /// The message's kind and epoch, for traces.
    pub fn describe(&self) -> String {
        match self {
            Msg::Vote { proposal, .. } => format!("vote e{}", proposal.epoch),
            Msg::Grant { epoch } => format!("grant e{epoch}"),
            Msg::Refuse { epoch, promised, .. } => format!("refuse e{epoch} p{promised}"),
            Msg::Update { config, seq, .. } => format!("update e{} s{seq}", config.epoch),
            Msg::Beat { config, seq } => format!("beat e{} s{seq}", config.epoch),
            Msg::Behind { epoch } => format!("behind e{epoch}"),
            Msg::Ack { epoch, seq } => format!("ack e{epoch} s{seq}"),
            Msg::Stale { promised, .. } => format!("stale p{promised}"),
            Msg::End { epoch } => format!("end e{epoch}"),
            Msg::EndAck { epoch } => format!("end-ack e{epoch}"),
            Msg::Decline { epoch } => format!("decline e{epoch}"),
        }
    }
}

/// Payload of `mrmm/hosts/<node>/chain` (JSON): one chain message of one mission.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ChainEnvelope {
    pub mission: crate::ids::MissionName,
    pub from: crate::ids::NodeId,
    pub msg: Msg<MissionSnapshot>,
}
