//! A node's edge, as every driver and the simulations see it: a message as it was received
//! ([`Incoming`]), why one did not become an event of its machine ([`Refused`]), and how its
//! sender is proven before it is translated ([`Proof`]). The translations themselves are the
//! machines' (`mrmm_core`); the proofs are the sessions' (`mrmm_net`).

use std::fmt;

use crate::security::Sender;

/// Why a message did not become an event.
#[derive(Debug, Clone, PartialEq)]
pub enum Refused {
    /// The message needs a proven sender and has none (no seal, or one that does not verify).
    Unproven { what: &'static str },
    /// Its proven sender may not send it (a robot speaking for another, …).
    NotEntitled { from: Sender, what: String },
    /// Its payload is not what its key promises (`why` names it).
    Malformed { what: &'static str, why: String },
    /// Nothing this robot listens to is on that key.
    Unexpected { key: String },
}

impl fmt::Display for Refused {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Refused::Unproven { what } => write!(f, "{what} without a proven sender"),
            Refused::NotEntitled { from, what } => write!(f, "{from} may not {what}"),
            Refused::Malformed { why, .. } => f.write_str(why),
            Refused::Unexpected { key } => write!(f, "nothing is expected on {key}"),
        }
    }
}

/// A message as the driver received it.
#[derive(Debug, Clone, Copy)]
pub struct Incoming<'a> {
    pub key: &'a str,
    pub payload: &'a [u8],
    /// A put (or a liveliness token appearing) rather than a delete (a token gone).
    pub put: bool,
    /// The sender its seal proves (liveliness tokens carry none).
    pub from: Option<&'a Sender>,
}

/// How a receiver proves the sender of a message before its machine translates it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Proof {
    /// Tagged for it, or signed: as any receiver the message is for.
    Own,
    /// Tagged for others (a team it is not in): only the signed messages count.
    Observed,
}
