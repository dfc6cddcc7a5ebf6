//! A mission's metrics from its members' telemetry: visits and idleness of patrol waypoints,
//! rounds and barriers passed by the whole team, coordination messages.

use std::collections::{BTreeMap, BTreeSet};

use mrmm_proto::geom::Point;
use mrmm_proto::{MetricsTally, MissionMetrics, Progress, Telemetry};
use mrmm_proto::{RobotId, Time};

/// A waypoint counts as visited by a robot passing within this distance, metres.
pub const VISIT_RADIUS: f64 = 1.5;
/// Two robots arriving at a waypoint closer in time than this are one visit, seconds. A robot
/// at a waypoint it has not left since its arrival is still on that visit, however long it
/// lingers (waiting at a barrier) and however sparse its samples, and whichever robots came
/// after it. Idleness is the time between two visits' arrivals, as in the patrolling literature
/// and the bound L / (n · v).
pub const VISIT_DEBOUNCE_S: f64 = 1.0;

/// What the metrics remember.
#[derive(Debug, Clone, Default)]
pub struct Metrics {
    last_visit: Vec<Option<(Time, RobotId)>>,
    /// The robots at each waypoint (seen within reach of it, not seen away since).
    present: Vec<BTreeSet<RobotId>>,
    visits: Vec<u32>,
    sum: f64,
    count: u64,
    worst: f64,
    /// Latest robot time seen.
    last_now: Time,
    /// Each member's progress on the current epoch.
    progress: BTreeMap<RobotId, Progress>,
    /// Ages of the last visits a predecessor checkpointed, placed on this clock at the next
    /// telemetry.
    ages: Option<Vec<Option<f64>>>,
}

impl Metrics {
    /// Starts counting visits of `waypoints` afresh (a new tour, or a new head).
    pub fn reset_tour(&mut self, waypoints: usize) {
        if self.visits.len() != waypoints {
            *self = Metrics { progress: std::mem::take(&mut self.progress), last_now: self.last_now, ..Metrics::default() };
            self.last_visit = vec![None; waypoints];
            self.visits = vec![0; waypoints];
        }
    }

    /// After a pause: the next visit of each waypoint starts a new gap (the pause is no one's
    /// idleness); what was counted stays.
    pub fn restart_clocks(&mut self) {
        self.last_visit.iter_mut().for_each(|v| *v = None);
        self.present.iter_mut().for_each(std::collections::BTreeSet::clear);
        self.ages = None;
    }

    /// What the visit metrics accumulated, as ages on no particular clock (for the chain).
    pub fn tally(&self) -> MetricsTally {
        MetricsTally {
            visits: self.visits.clone(),
            since_visit: self.last_visit.iter().map(|v| v.as_ref().map(|(when, _)| (self.last_now - *when).max(0.0))).collect(),
            gap_sum: self.sum,
            gaps: self.count,
            worst_gap: self.worst,
        }
    }

    /// Goes on from a predecessor's tally of the same tour (one that does not fit is ignored:
    /// counting starts afresh). The last visits' times are placed at the next telemetry.
    pub fn restore(&mut self, t: &MetricsTally) {
        if !t.fits(self.visits.len()) {
            return;
        }
        self.visits.clone_from(&t.visits);
        self.sum = t.gap_sum;
        self.count = t.gaps;
        self.worst = t.worst_gap;
        self.ages = Some(t.since_visit.clone());
    }

    /// A member's progress as it last reported it.
    pub fn progress_of(&self, id: &str) -> Option<&Progress> {
        self.progress.get(id)
    }

    /// A member left: its progress is no longer part of the team's.
    pub fn forget(&mut self, id: &str) -> Option<Progress> {
        for p in &mut self.present {
            p.remove(id);
        }
        self.progress.remove(id)
    }

    /// Telemetry of member `t.id` at robot time `now`; `epoch` is the mission's current one and
    /// `tour` the patrol's waypoints (empty for other missions). Returns the barrier messages
    /// the member had sent under an earlier plan, now replaced by its progress on this one (the
    /// caller keeps them: the mission's count must not fall with a replan).
    pub fn telemetry(&mut self, mission: &str, epoch: u64, tour: &[Point], now: Time, t: &Telemetry) -> u64 {
        let mut carried = 0;
        if let Some(ages) = self.ages.take() {
            self.last_visit = ages.into_iter().map(|a| a.map(|a| (now - a, RobotId::default()))).collect();
        }
        self.last_now = self.last_now.max(now);
        if let Some(p) = &t.progress {
            if p.mission == mission && p.epoch == epoch {
                if let Some(old) = self.progress.insert(t.id.clone(), p.clone()) {
                    if old.epoch < p.epoch {
                        carried = u64::from(old.sync_msgs);
                    }
                }
            }
        }
        // Only robots on their round count: the way to the slot is not patrolling.
        let patrolling = t.progress.as_ref().is_some_and(|p| p.mission == mission && p.syncs_passed > 0);
        if !patrolling {
            return carried;
        }
        let here = Point { x: t.pose.x, y: t.pose.y };
        if self.present.len() != self.last_visit.len() {
            self.present = vec![BTreeSet::new(); self.last_visit.len()];
        }
        for (i, wp) in tour.iter().enumerate().take(self.last_visit.len()) {
            if wp.dist(here) > VISIT_RADIUS {
                self.present[i].remove(&t.id);
                continue;
            }
            // A robot seen at a waypoint it has not left since it came is still on that visit,
            // however long it lingers (waiting at a barrier) and however sparse its samples.
            if !self.present[i].insert(t.id.clone()) {
                continue;
            }
            match &self.last_visit[i] {
                // Another robot came at the same instant: one visit.
                Some((when, _)) if now - *when < VISIT_DEBOUNCE_S => {}
                Some((when, _)) => {
                    let gap = now - *when;
                    self.sum += gap;
                    self.count += 1;
                    self.worst = self.worst.max(gap);
                    self.visits[i] += 1;
                    self.last_visit[i] = Some((now, t.id.clone()));
                }
                None => {
                    self.visits[i] += 1;
                    self.last_visit[i] = Some((now, t.id.clone()));
                }
            }
        }
        carried
    }

    /// Barriers every one of `members` has passed under the current plan (0 until each has
    /// reported on it).
    pub fn syncs_passed(&self, members: &[RobotId]) -> u32 {
        let current: Vec<u32> = members.iter().filter_map(|id| self.progress.get(id)).map(|p| p.syncs_passed).collect();
        if current.len() == members.len() {
            current.into_iter().min().unwrap_or(0)
        } else {
            0
        }
    }

    /// The metrics for `members`; `plan_msgs` and `sync_msgs_left` come from the replicated state.
    pub fn view<'a>(&self, members: impl Iterator<Item = &'a RobotId>, plan_msgs: u64, sync_msgs_left: u64) -> MissionMetrics {
        // Waypoints waiting right now count too: the worst idleness is never below the current wait.
        // (Not those a robot is at: they are being visited.)
        let open = self
            .last_visit
            .iter()
            .enumerate()
            .filter(|(i, _)| self.present.get(*i).is_none_or(BTreeSet::is_empty))
            .filter_map(|(_, v)| v.as_ref())
            .map(|(w, _)| self.last_now - *w)
            .fold(0.0, f64::max);
        let any = self.visits.iter().any(|&v| v > 0);
        let members: Vec<&RobotId> = members.collect();
        let current: Vec<&Progress> = members.iter().filter_map(|id| self.progress.get(*id)).collect();
        let full = current.len() == members.len() && !current.is_empty();
        let sync_msgs: u64 = sync_msgs_left + self.progress.values().map(|p| u64::from(p.sync_msgs)).sum::<u64>();
        MissionMetrics {
            rounds: if full { current.iter().map(|p| p.round).min().unwrap_or(0) } else { 0 },
            avg_idleness: (self.count > 0).then(|| self.sum / self.count as f64),
            worst_idleness: any.then(|| self.worst.max(open)),
            visits: self.visits.clone(),
            sync_points_passed: if full { current.iter().map(|p| p.syncs_passed).min().unwrap_or(0) } else { 0 },
            messages: BTreeMap::from([("plan".to_string(), plan_msgs), ("sync".to_string(), sync_msgs)]),
            // A wild value from one robot must not make the sum unrepresentable in JSON.
            sync_wait_s: current.iter().map(|p| p.sync_wait_s).filter(|w| (0.0..=1e9).contains(w)).sum(),
            traffic_wait_s: current.iter().map(|p| p.traffic_wait_s).filter(|w| (0.0..=1e9).contains(w)).sum(),
        }
    }
}
