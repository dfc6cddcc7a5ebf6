//! The fleet as the console's page sees it: central's robot and mission tables (polled), made
//! live by the robots' own telemetry (their poses between two polls). Pure: no I/O, no clock.

use std::collections::BTreeMap;

use mrmm_proto::traffic::TrafficView;
use mrmm_proto::{Advice, MapInfo, MissionView, Pose, RobotView, Telemetry};
use serde::Serialize;

/// Robots whose telemetry the model keeps between two polls of central's table: a flood of
/// telemetry for made-up robots cannot grow it (only robots central lists are kept at all).
pub const MAX_ROBOTS: usize = 10_000;

/// What the page draws: one JSON document, sent whole at every change.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Snapshot {
    /// +1 per snapshot.
    pub seq: u64,
    /// Central's robot table, sorted by id, each pose the freshest the console has.
    pub robots: Vec<RobotView>,
    /// Central's missions (with the planner's summary: tours, coverage points).
    pub missions: Vec<MissionView>,
    /// The advising agent's standing advice, most urgent first.
    pub advice: Vec<Advice>,
    /// Central's maps; the page fetches each one's layer (`/api/map/<hash>`) once.
    pub maps: Vec<MapInfo>,
    /// Traffic on every graph map: what each robot holds, whom it waits for.
    pub traffic: Vec<TrafficView>,
    pub central: CentralState,
}

/// Whether the console hears central.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct CentralState {
    /// The last poll of central was answered.
    pub reachable: bool,
    /// Why the last poll failed.
    pub error: Option<String>,
}

/// A robot's latest telemetry, as far as the map needs it.
#[derive(Debug, Clone, PartialEq)]
struct Live {
    seq: u64,
    pose: Pose,
    behaviour: String,
}

/// The console's fleet model.
#[derive(Debug, Default)]
pub struct Fleet {
    robots: Vec<RobotView>,
    missions: Vec<MissionView>,
    advice: Vec<Advice>,
    maps: Vec<MapInfo>,
    traffic: Vec<TrafficView>,
    live: BTreeMap<mrmm_proto::RobotId, Live>,
    central: CentralState,
    seq: u64,
    changed: bool,
}

impl Fleet {
    /// Central's maps (asked with the tables; they seldom change).
    pub fn maps(&mut self, maps: Vec<MapInfo>) {
        if self.maps != maps {
            self.maps = maps;
            self.changed = true;
        }
    }

    /// Central's traffic (asked with the tables; none from a central without a traffic
    /// authority).
    pub fn traffic(&mut self, traffic: Vec<TrafficView>) {
        if self.traffic != traffic {
            self.traffic = traffic;
            self.changed = true;
        }
    }

    /// Central answered a poll: its robots, missions and advice replace what was known.
    pub fn polled(&mut self, mut robots: Vec<RobotView>, missions: Vec<MissionView>, advice: Vec<Advice>) {
        robots.sort_by(|a, b| a.id.cmp(&b.id));
        robots.truncate(MAX_ROBOTS);
        // Live poses of robots central no longer lists are forgotten.
        self.live.retain(|id, _| robots.binary_search_by(|r| r.id.as_str().cmp(id.as_str())).is_ok());
        self.robots = robots;
        self.missions = missions;
        self.advice = advice;
        self.central = CentralState { reachable: true, error: None };
        self.changed = true;
    }

    /// A poll of central failed: what was known stays on the map, marked as not current.
    pub fn unreachable(&mut self, why: String) {
        let state = CentralState { reachable: false, error: Some(why) };
        if self.central != state {
            self.central = state;
            self.changed = true;
        }
    }

    /// A robot's telemetry (its sender already proven to be that robot). Kept only for robots
    /// central lists, and only when newer than what is kept.
    pub fn telemetry(&mut self, t: &Telemetry) {
        if self.robots.binary_search_by(|r| r.id.as_str().cmp(t.id.as_str())).is_err() {
            return;
        }
        if !(t.pose.x.is_finite() && t.pose.y.is_finite() && t.pose.theta.is_finite()) {
            return;
        }
        if self.live.get(&t.id).is_some_and(|l| l.seq >= t.seq) {
            return;
        }
        self.live.insert(t.id.clone(), Live { seq: t.seq, pose: t.pose, behaviour: t.behaviour.describe() });
        self.changed = true;
    }

    /// The snapshot to send, if anything changed since the last one.
    pub fn take_snapshot(&mut self) -> Option<Snapshot> {
        if !std::mem::take(&mut self.changed) {
            return None;
        }
        self.seq = self.seq.saturating_add(1);
        let robots = self
            .robots
            .iter()
            .map(|r| {
                let mut r = r.clone();
                if let Some(l) = self.live.get(&r.id) {
                    r.pose = Some(l.pose);
                    r.behaviour = Some(l.behaviour.clone());
                }
                r
            })
            .collect();
        Some(Snapshot {
            seq: self.seq,
            robots,
            missions: self.missions.clone(),
            advice: self.advice.clone(),
            maps: self.maps.clone(),
            traffic: self.traffic.clone(),
            central: self.central.clone(),
        })
    }
}

#[cfg(test)]
mod tests {
    use mrmm_proto::RobotStatus;

    use super::*;

    fn robot(id: &str, x: f64) -> RobotView {
        RobotView {
            id: id.into(),
            robot_type: "ground".into(),
            capabilities: vec![],
            status: RobotStatus::Idle,
            mission: None,
            pose: Some(Pose { x, y: 0.0, theta: 0.0 }),
            behaviour: Some("hold".into()),
            goal: None,
            last_mission: None,
            stuck: None,
            battery: None,
            vehicle: None,
        }
    }

    fn telemetry(id: &str, seq: u64, x: f64) -> Telemetry {
        Telemetry { seq, pose: Pose { x, y: 1.0, theta: 0.5 }, ..Telemetry::resting(id, 0.0) }
    }

    #[test]
    fn telemetry_moves_listed_robots_between_polls_and_only_forward() {
        let mut f = Fleet::default();
        f.polled(vec![robot("r2", 2.0), robot("r1", 1.0)], vec![], vec![]);
        let s = f.take_snapshot().expect("a first snapshot");
        assert_eq!(s.robots.iter().map(|r| r.id.as_str()).collect::<Vec<_>>(), ["r1", "r2"]);
        assert!(f.take_snapshot().is_none(), "nothing changed");
        f.telemetry(&telemetry("r1", 5, 7.0));
        let s = f.take_snapshot().expect("moved");
        assert_eq!(s.robots[0].pose.map(|p| (p.x, p.y)), Some((7.0, 1.0)));
        // An older message (reordered) does not move it back.
        f.telemetry(&telemetry("r1", 4, 3.0));
        assert!(f.take_snapshot().is_none());
        // A robot central does not list is not drawn (and not kept).
        f.telemetry(&telemetry("ghost", 1, 0.0));
        assert!(f.take_snapshot().is_none());
        // Not-a-number poses are dropped.
        f.telemetry(&telemetry("r2", 9, f64::NAN));
        assert!(f.take_snapshot().is_none());
    }

    #[test]
    fn a_robot_central_forgets_is_forgotten_and_an_unreachable_central_is_shown() {
        let mut f = Fleet::default();
        f.polled(vec![robot("r1", 1.0)], vec![], vec![]);
        f.telemetry(&telemetry("r1", 1, 5.0));
        f.polled(vec![], vec![], vec![]);
        f.polled(vec![robot("r1", 1.0)], vec![], vec![]);
        let s = f.take_snapshot().expect("snapshot");
        assert_eq!(s.robots[0].pose.map(|p| p.x), Some(1.0), "its old live pose was forgotten");
        f.unreachable("no answer".into());
        let s = f.take_snapshot().expect("snapshot");
        assert_eq!(s.central, CentralState { reachable: false, error: Some("no answer".into()) });
        assert_eq!(s.robots.len(), 1, "the last known fleet stays on the map");
        f.unreachable("no answer".into());
        assert!(f.take_snapshot().is_none(), "the same failure is not news");
    }
}
