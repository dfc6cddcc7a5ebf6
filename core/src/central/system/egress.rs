//! What the system manager puts on the network and listens to (see [`crate::egress`]).

use mrmm_proto::Pattern;

use super::Command;
use crate::egress::{Out, Sub};

/// What command `c` publishes, if anything: a chain message telling a replaced head to step
/// down (requests, replies and the journal are the driver's).
pub fn egress(c: &Command) -> Option<Out> {
    match c {
        Command::Chain { to, envelope } => crate::mission::host::egress::chain(to.as_str(), envelope),
        _ => None,
    }
}

/// What the system manager listens to: every robot's telemetry and every mission's status
/// (liveliness apart).
pub fn subscriptions() -> Vec<Sub> {
    vec![Sub::any(Pattern::AllTelemetry), Sub::any(Pattern::AllMissionStatus)]
}
