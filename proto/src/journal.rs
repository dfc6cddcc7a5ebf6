//! Central's journal as the operator reads it (`mrmm/system/journal?since=SEQ`): what the system
//! manager committed to disk, in order. State entries (missions defined and removed, robots
//! assigned) are what central replays on start; the others are history (commands accepted,
//! robots lost and back, takeovers, replans).

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::ids::{MissionName, NodeId, RobotId};
use crate::MissionSpecWire;

/// Entries one answer on `mrmm/system/journal` carries at most.
pub const JOURNAL_PAGE: usize = 500;

/// One committed entry.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct JournalEntry {
    /// 1, 2, 3… in commit order.
    pub seq: u64,
    /// Wall-clock time of the commit, milliseconds since the Unix epoch.
    pub at_ms: u64,
    #[serde(flatten)]
    pub event: JournalEvent,
}

/// What happened.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum JournalEvent {
    /// A mission exists from now on, as defined (the recipe XML and parameters it was created
    /// with; `spec` is null for a mission adopted from its head's report, whose recipe central
    /// never saw).
    MissionDefined {
        mission: MissionName,
        host: NodeId,
        recipe: String,
        planner: String,
        spec: Option<Box<MissionSpecWire>>,
        /// How many times central started it anew from this journal (its lineage: see
        /// `mrmm_proto::chain::lineage_of`); 0 until then.
        #[serde(default)]
        lineage: u32,
    },
    /// A mission is gone: terminated (it never comes back) or it never ran.
    MissionRemoved {
        mission: MissionName,
        terminated: bool,
    },
    /// A robot is in `mission` from now on, or in none.
    RobotAssigned {
        robot: RobotId,
        mission: Option<MissionName>,
    },
    /// An operator command (or the agent's, `by: "agent"`) took effect, as it was given.
    Command {
        by: String,
        command: String,
        request: serde_json::Value,
    },
    /// A robot is being let go from `mission` (moved or taken out; its head has not acknowledged
    /// yet): until then it is not free, even across a restart of central. A robot may be let go
    /// by several missions at once (moved on before the first let it go). `None` (written by
    /// older versions) means every mission let it go.
    RobotReleasing {
        robot: RobotId,
        mission: Option<MissionName>,
    },
    /// `mission` let the robot go (its head acknowledged).
    RobotLetGo {
        robot: RobotId,
        mission: MissionName,
    },
    /// A robot is on a charging errand from now on, or on none (`errand` null): what a
    /// restarted central needs to follow it — its charger, the mission it left and the spare
    /// that took its place, where it was sent from.
    RobotErrand {
        robot: RobotId,
        errand: Option<Box<ErrandRecord>>,
    },
    /// A robot's liveliness went away, or came back.
    RobotLost {
        robot: RobotId,
    },
    RobotBack {
        robot: RobotId,
    },
    /// A robot lost and back more often than the journal records one by one
    /// (`FLAP_ENTRIES` in `FLAP_WINDOW_S`, in the system manager): the losses left out, and
    /// whether it was alive when it went quiet.
    RobotFlapping {
        robot: RobotId,
        losses: u32,
        alive: bool,
    },
    /// Another node manages a mission now (a replica took over, or central adopted it).
    ManagerChanged {
        mission: MissionName,
        manager: NodeId,
        chain_epoch: u64,
    },
    /// A mission's head replanned.
    Replanned {
        mission: MissionName,
        plan_epoch: u64,
        robots: Vec<RobotId>,
    },
    /// Central restarted a mission no live manager ran, with these robots.
    MissionRestarted {
        mission: MissionName,
        robots: Vec<RobotId>,
    },
    /// Central started and replayed its journal.
    CentralStarted {
        missions: usize,
        robots: usize,
        terminated: usize,
    },
}

impl JournalEvent {
    /// The robot losses it records: one for a loss, those left out for a flapping robot.
    pub fn losses(&self) -> u64 {
        match self {
            JournalEvent::RobotLost { .. } => 1,
            JournalEvent::RobotFlapping { losses, .. } => u64::from(*losses),
            _ => 0,
        }
    }

    /// Whether central replays it (the others are history only).
    pub fn is_state(&self) -> bool {
        matches!(
            self,
            JournalEvent::MissionDefined { .. }
                | JournalEvent::MissionRemoved { .. }
                | JournalEvent::RobotAssigned { .. }
                | JournalEvent::RobotReleasing { .. }
                | JournalEvent::RobotLetGo { .. }
                | JournalEvent::RobotErrand { .. }
        )
    }
}

/// A charging errand as the journal keeps it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ErrandRecord {
    /// The map (its name) and the charger reserved for the robot.
    pub map: String,
    pub charger: crate::map::Charger,
    /// The mission it left, and how many robots that mission had then.
    pub left: Option<(MissionName, usize)>,
    /// The robot moved into that mission in its place.
    pub spare: Option<RobotId>,
    /// Where it was sent from.
    pub from: Option<(f64, f64)>,
}

/// The answer on `mrmm/system/journal?since=SEQ`: entries after `since`, oldest first, at most
/// [`JOURNAL_PAGE`]; ask again from `next` while `more`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct JournalPage {
    pub entries: Vec<JournalEntry>,
    /// The last sequence number on disk.
    pub last: u64,
    /// `since` for the next page.
    pub next: u64,
    pub more: bool,
}

/// The parameters of a journal query: `since=SEQ` (default 0) and `limit=N` (default and
/// maximum [`JOURNAL_PAGE`]). An unknown parameter or a bad number is an error.
pub fn journal_query(parameters: &str) -> Result<(u64, usize), String> {
    let mut since = 0u64;
    let mut limit = JOURNAL_PAGE;
    let params: BTreeMap<&str, &str> = parameters.split(['&', ';']).filter(|p| !p.is_empty()).map(|p| p.split_once('=').unwrap_or((p, ""))).collect();
    for (k, v) in params {
        match k {
            "since" => since = v.parse().map_err(|_| format!("since={v:?}: give a sequence number (0 for all)"))?,
            "limit" => {
                limit = v.parse().map_err(|_| format!("limit={v:?}: give a number of entries"))?;
                if limit == 0 || limit > JOURNAL_PAGE {
                    return Err(format!("limit={limit}: 1 to {JOURNAL_PAGE}"));
                }
            }
            other => return Err(format!("unknown parameter {other:?}: since=SEQ and limit=N are known")),
        }
    }
    Ok((since, limit))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entries_are_flat_tagged_json() {
        let e = JournalEntry { seq: 3, at_ms: 10, event: JournalEvent::RobotAssigned { robot: "r1".into(), mission: Some("p".into()) } };
        let v = serde_json::to_value(&e).expect("json");
        assert_eq!(v, serde_json::json!({"seq": 3, "at_ms": 10, "kind": "robot_assigned", "robot": "r1", "mission": "p"}));
        let back: JournalEntry = serde_json::from_value(v).expect("back");
        assert_eq!(back, e);
    }

    #[test]
    fn query_parameters_are_checked() {
        assert_eq!(journal_query(""), Ok((0, JOURNAL_PAGE)));
        assert_eq!(journal_query("since=42"), Ok((42, JOURNAL_PAGE)));
        assert_eq!(journal_query("since=4;limit=3"), Ok((4, 3)));
        assert!(journal_query("since=-1").is_err());
        assert!(journal_query("limit=0").is_err());
        assert!(journal_query("limit=100000").is_err());
        assert!(journal_query("until=3").is_err());
    }
}
