//! What the system manager shows: the operator's views of robots and missions, and the fleet
//! status.

use super::*;
use mrmm_proto::Time;

impl SystemManager {
    /// A mission as the operator sees it: the head's latest view, with the (live) members this
    /// manager holds; a placeholder while the host is planning.
    pub(super) fn mission_view(&self, name: &str) -> MissionView {
        let robots: Vec<RobotId> = self.assignment.iter().filter(|(id, m)| *m == name && self.fleet.alive(id.as_str())).map(|(r, _)| r.clone()).collect();
        let rec = self.missions.get(name);
        match rec.and_then(|r| r.view.clone()) {
            Some(mut v) => {
                v.robots = robots;
                v.requires = rec.map(|r| r.requires.clone()).unwrap_or_default();
                v
            }
            None => {
                let (planner, host) = (rec.map(|r| r.def.planner.clone()).unwrap_or_default(), rec.map(|r| r.host.clone()).unwrap_or_default());
                let mut v = MissionView::running(name, &planner, host.as_str(), 0, &[]);
                v.recipe = rec.map(|r| r.def.recipe.clone()).unwrap_or_default();
                v.requires = rec.map(|r| r.requires.clone()).unwrap_or_default();
                v.status = MissionStatus::Planning;
                v.robots = robots;
                v.manager.chain_epoch = 0;
                v.map = rec.and_then(|r| r.def.spec.as_ref()).and_then(|s| s.map.clone());
                v
            }
        }
    }

    /// Every mission as the operator sees it, by name.
    pub fn mission_views(&self) -> Vec<MissionView> {
        self.missions.keys().map(|n| self.mission_view(n.as_str())).collect()
    }

    /// Registered robots, sorted by id (naturally: r2 before r10).
    /// What the operator sees of the maps central publishes now (not their former versions).
    pub fn map_infos(&self) -> Vec<mrmm_proto::MapInfo> {
        self.maps.values().map(|h| h.info.clone()).collect()
    }

    pub fn views(&self) -> Vec<RobotView> {
        let mut v: Vec<RobotView> = self.fleet.iter().map(|(id, _)| id).filter_map(|id| self.view(id.as_str())).collect();
        v.sort_by(|a, b| proto::natural_cmp(a.id.as_str(), b.id.as_str()));
        v
    }

    /// The mission each robot is in (lost robots keep theirs).
    pub fn assignment(&self) -> &BTreeMap<RobotId, MissionName> {
        &self.assignment
    }

    /// One registered robot.
    pub fn view(&self, id: &str) -> Option<RobotView> {
        let rec = self.fleet.get(id)?;
        let info = rec.info.as_ref()?;
        let assigned = self.assignment.get(id).cloned();
        let moving = rec.last.as_ref().is_some_and(|t| t.behaviour != proto::Behaviour::Hold);
        let status = if !rec.alive {
            RobotStatus::Lost
        } else if assigned.is_some() || moving {
            RobotStatus::Busy
        } else {
            RobotStatus::Idle
        };
        let behaviour = rec.last.as_ref().map(|t| match &t.progress {
            Some(p) if p.waiting.is_some() => format!("sync {:?}", p.waiting.unwrap_or_default()),
            Some(p) if p.done => "plan done".to_string(),
            Some(p) => format!("step {} {}", p.step, t.behaviour.describe()),
            None => t.behaviour.describe(),
        });
        let (mission, last_mission) = if rec.alive { (assigned, None) } else { (None, assigned) };
        Some(RobotView {
            id: info.id.clone(),
            robot_type: info.robot_type.clone(),
            capabilities: info.capabilities.clone(),
            status,
            mission,
            pose: rec.last.as_ref().map(|t| t.pose),
            behaviour,
            goal: rec.last.as_ref().filter(|_| rec.alive).and_then(|t| t.behaviour.goal()),
            last_mission,
            stuck: rec.last.as_ref().and_then(|t| t.stuck.clone()).filter(|_| rec.alive),
            battery: rec.last.as_ref().and_then(|t| t.battery),
            vehicle: rec.last.as_ref().and_then(|t| t.vehicle.as_deref().cloned()),
        })
    }

    /// Fleet summary.
    pub fn status(&self, now: Time) -> SystemStatus {
        let views = self.views();
        let count = |s| views.iter().filter(|v| v.status == s).count();
        SystemStatus {
            node: self.node.clone(),
            uptime_s: now - self.started,
            robots_total: views.len(),
            idle: count(RobotStatus::Idle),
            busy: count(RobotStatus::Busy),
            lost: count(RobotStatus::Lost),
            missions: self.missions.len(),
            refused: self.edge.refused.clone(),
            proven: self.edge.proven.clone(),
        }
    }
}

/// What the driver refused and took at the node's edge (reported in the system status).
#[derive(Debug, Clone, Default)]
pub(super) struct EdgeCounts {
    /// Messages refused, by reason.
    pub refused: BTreeMap<String, u64>,
    /// Messages taken, by how their sender was proven.
    pub proven: BTreeMap<String, u64>,
}
