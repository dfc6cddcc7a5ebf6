//! What the viewer draws in Rerun, and what it has drawn (to draw only changes): robots with
//! their trails coloured by mission, missions' plans, teams and scalars, advice and barrier
//! events, all on one `fleet_time` timeline.

use std::collections::{BTreeMap, VecDeque};
use std::time::Instant;

use mrmm_proto::plan::Point;
use mrmm_proto::{self as proto, AdviceEvent, MissionView, PlanSummary, Priority, SyncArrival, SyncRelease, Telemetry};
use rerun::RecordingStream;

use crate::paths;

/// Positions kept in a robot's trail.
const TRAIL: usize = 60;

/// Points as Rerun positions.
fn xy(points: &[Point]) -> Vec<[f32; 2]> {
    points.iter().map(|p| [p.x as f32, p.y as f32]).collect()
}

/// What has been drawn, to draw only changes.
pub(crate) struct View {
    pub(crate) rec: RecordingStream,
    t0: Instant,
    trails: BTreeMap<proto::RobotId, VecDeque<[f32; 2]>>,
    missions: BTreeMap<proto::MissionName, MissionView>,
    colors: BTreeMap<String, [u8; 3]>,
    teams: BTreeMap<proto::RobotId, String>,
    messages: BTreeMap<proto::MissionName, (f64, u64)>,
}

const PALETTE: [[u8; 3]; 8] = [[230, 159, 0], [86, 180, 233], [0, 158, 115], [240, 228, 66], [0, 114, 178], [213, 94, 0], [204, 121, 167], [160, 160, 160]];
const IDLE: [u8; 3] = [200, 200, 200];

impl View {
    pub(crate) fn new(rec: RecordingStream) -> Self {
        View {
            rec,
            t0: Instant::now(),
            trails: BTreeMap::new(),
            missions: BTreeMap::new(),
            colors: BTreeMap::new(),
            teams: BTreeMap::new(),
            messages: BTreeMap::new(),
        }
    }

    fn now(&self) {
        self.rec.set_duration_secs(paths::TIMELINE, self.t0.elapsed().as_secs_f64());
    }

    fn color(&mut self, mission: Option<&str>) -> [u8; 3] {
        let Some(m) = mission else { return IDLE };
        let n = self.colors.len();
        *self.colors.entry(m.to_string()).or_insert(PALETTE[n % PALETTE.len()])
    }

    fn log(&self, path: &str, what: &impl rerun::AsComponents) {
        if let Err(e) = self.rec.log(path, what) {
            tracing::warn!("rerun log {path}: {e}");
        }
    }

    pub(crate) fn robot(&mut self, t: &Telemetry) {
        self.now();
        let [r, g, b] = self.color(t.mission.as_deref());
        let color = rerun::Color::from_rgb(r, g, b);
        let p = [t.pose.x as f32, t.pose.y as f32];
        let team = self.teams.get(&t.id).cloned();
        let label = match (&t.mission, team) {
            (Some(_), Some(team)) => format!("{} · {team}", t.id),
            (Some(m), None) => format!("{} · {m}", t.id),
            _ => t.id.to_string(),
        };
        self.log(&paths::robot(&t.id), &rerun::Points2D::new([p]).with_colors([color]).with_radii([0.5]).with_labels([label]));
        let dir = [(t.pose.theta.cos() * 1.2) as f32, (t.pose.theta.sin() * 1.2) as f32];
        self.log(&paths::robot_heading(&t.id), &rerun::Arrows2D::from_vectors([dir]).with_origins([p]).with_colors([color]));
        let trail = self.trails.entry(t.id.clone()).or_default();
        trail.push_back(p);
        while trail.len() > TRAIL {
            trail.pop_front();
        }
        let strip: Vec<[f32; 2]> = trail.iter().copied().collect();
        self.log(&paths::robot_trail(&t.id), &rerun::LineStrips2D::new([strip]).with_colors([color]).with_radii([0.08]));
    }

    pub(crate) fn mission(&mut self, m: &MissionView) {
        // A status that leaves out an unchanged summary keeps the one drawn.
        let mut full;
        let m = if m.summary_unchanged {
            full = m.clone();
            full.carry_summary(self.missions.get(&m.name));
            &full
        } else {
            m
        };
        self.now();
        let [r, g, b] = self.color(Some(&m.name));
        let color = rerun::Color::from_rgb(r, g, b);
        let changed = self.missions.get(&m.name).is_none_or(|old| old.summary != m.summary || old.manager != m.manager || old.teams != m.teams);
        if changed {
            match &m.summary {
                Some(PlanSummary::Patrol(p)) if !p.tour.is_empty() => {
                    let tour = xy(&p.tour);
                    let mut closed = tour.clone();
                    closed.push(tour[0]);
                    self.log(
                        &paths::mission_tour(&m.name),
                        &rerun::LineStrips2D::new([closed]).with_colors([color]).with_radii([0.12]).with_labels([m.name.to_string()]),
                    );
                    self.log(&paths::mission_waypoints(&m.name), &rerun::Points2D::new(tour).with_colors([color]).with_radii([0.3]));
                }
                Some(PlanSummary::Coverage(c)) => {
                    let ring = |pts: &[Point]| {
                        let mut r = xy(pts);
                        if let Some(first) = r.first().copied() {
                            r.push(first);
                        }
                        r
                    };
                    let mut rings = vec![ring(&c.region.outer)];
                    rings.extend(c.region.holes.iter().map(|h| ring(h)));
                    rings.retain(|r| r.len() > 2);
                    if !rings.is_empty() {
                        self.log(&paths::mission_region(&m.name), &rerun::LineStrips2D::new(rings).with_colors([color]).with_radii([0.1]));
                    }
                    if !c.points.is_empty() {
                        self.log(
                            &paths::mission_points(&m.name),
                            &rerun::Points2D::new(xy(&c.points)).with_colors([color]).with_radii([0.35]).with_labels([m.name.to_string()]),
                        );
                    }
                }
                _ => {}
            }
            for (team, ids) in &m.teams {
                for id in ids {
                    self.teams.insert(id.clone(), team.clone());
                }
                let text = format!("{team}: {} (manager {} epoch {})", ids.join(", "), m.manager.node, m.manager.epoch);
                self.log(paths::TEAMS_LOG, &rerun::TextLog::new(text).with_level(rerun::TextLogLevel::INFO));
            }
        }
        if let Some(w) = m.metrics.worst_idleness {
            self.log(&paths::metric(&m.name, "worst_idleness"), &rerun::Scalars::new([w]));
        }
        if let Some(a) = m.metrics.avg_idleness {
            self.log(&paths::metric(&m.name, "avg_idleness"), &rerun::Scalars::new([a]));
        }
        let total: u64 = m.metrics.messages.values().sum();
        let now = self.t0.elapsed().as_secs_f64();
        if let Some((t, n)) = self.messages.insert(m.name.clone(), (now, total)) {
            if now > t && total >= n {
                self.log(&paths::metric(&m.name, "coordination_msgs_per_s"), &rerun::Scalars::new([(total - n) as f64 / (now - t)]));
            }
        }
        self.missions.insert(m.name.clone(), m.clone());
    }

    pub(crate) fn advice(&mut self, a: &AdviceEvent) {
        self.now();
        let (text, level) = match a {
            AdviceEvent::Raised(a) => {
                let level = match a.priority {
                    Priority::Critical => rerun::TextLogLevel::CRITICAL,
                    Priority::Warning => rerun::TextLogLevel::WARN,
                    Priority::Info => rerun::TextLogLevel::INFO,
                };
                let text = match &a.suggestion {
                    Some(s) => format!("{} → {s}", a.reason),
                    None => a.reason.clone(),
                };
                (text, level)
            }
            AdviceEvent::Withdrawn { id, reason } => (format!("withdrawn {id}: {reason}"), rerun::TextLogLevel::DEBUG),
        };
        self.log(paths::ADVICE_LOG, &rerun::TextLog::new(text).with_level(level));
    }

    pub(crate) fn release(&mut self, team: &str, r: &SyncRelease) {
        self.now();
        let text = format!("{} released {team} barriers up to {} of round {} (epoch {})", r.leader, r.point, r.round, r.epoch);
        self.log(paths::SYNC_LOG, &rerun::TextLog::new(text).with_level(rerun::TextLogLevel::DEBUG));
    }

    pub(crate) fn sync(&mut self, team: &str, a: &SyncArrival) {
        self.now();
        let text = format!("{} reached {team} barrier {} of round {} (epoch {})", a.robot, a.point, a.round, a.epoch);
        self.log(paths::SYNC_LOG, &rerun::TextLog::new(text).with_level(rerun::TextLogLevel::DEBUG));
    }
}
