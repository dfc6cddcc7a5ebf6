//! Team payloads: barrier arrivals.

use serde::{Deserialize, Serialize};

/// A member's arrival at a barrier, on `mrmm/team/<team>/sync/<point>/<round>` (JSON).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct SyncArrival {
    pub robot: String,
    pub epoch: u64,
    pub point: u32,
    pub round: u32,
}
