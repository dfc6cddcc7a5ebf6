//! Team payloads: barrier arrivals and releases, and how a team runs its barriers.

use serde::{Deserialize, Serialize};

/// A member's arrival at a barrier, on `mrmm/team/<team>/sync/<point>/<round>` (JSON).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct SyncArrival {
    pub robot: crate::ids::RobotId,
    pub epoch: u64,
    pub point: u32,
    pub round: u32,
}

/// How a team runs its barriers, chosen per mission (patrol parameter `barrier`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum BarrierMode {
    /// Every member publishes its arrival to every other on `mrmm/team/<team>/sync/…` and
    /// decides for itself: n publications, n·(n−1) deliveries per barrier, no leader to lose.
    #[default]
    Mesh,
    /// The paper's scheme: members publish arrivals on `mrmm/team/<team>/arrive/…`, heard only by
    /// the leader (the lowest live member id, by liveliness), which announces on
    /// `mrmm/team/<team>/release/…`: 2·(n−1) deliveries per barrier, one more hop.
    Leader,
}

impl BarrierMode {
    pub fn as_str(self) -> &'static str {
        match self {
            BarrierMode::Mesh => "mesh",
            BarrierMode::Leader => "leader",
        }
    }

    /// Parses `mesh` or `leader`.
    pub fn parse(s: &str) -> Option<BarrierMode> {
        match s.trim() {
            "mesh" => Some(BarrierMode::Mesh),
            "leader" => Some(BarrierMode::Leader),
            _ => None,
        }
    }
}

/// A leader's release of every barrier of epoch `epoch` up to `(round, point)`, on
/// `mrmm/team/<team>/release/<point>/<round>` (JSON).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct SyncRelease {
    pub leader: crate::ids::RobotId,
    pub epoch: u64,
    pub point: u32,
    pub round: u32,
}
