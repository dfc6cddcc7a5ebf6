//! What the viewer draws in Rerun, and what it has drawn (to draw only changes): robots with
//! their trails coloured by mission, missions' plans, teams and scalars, advice and barrier
//! events, all on one `fleet_time` timeline.

use std::collections::{BTreeMap, VecDeque};
use std::time::Instant;

use mrmm_proto::geom::Point;
use mrmm_proto::traffic::TrafficView;
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
    /// Robots drawn in traffic (cleared when they leave it).
    in_traffic: std::collections::BTreeSet<proto::RobotId>,
    /// Each robot's last battery charge, percent, and when the bar chart of them was drawn.
    batteries: BTreeMap<proto::RobotId, f64>,
    bars_at: Option<Instant>,
}

/// The bar chart of every robot's charge is drawn at most this often, seconds (telemetry comes
/// at 5 Hz from each robot).
const BARS_EVERY_S: f64 = 1.0;

const PALETTE: [[u8; 3]; 8] = [[230, 159, 0], [86, 180, 233], [0, 158, 115], [240, 228, 66], [0, 114, 178], [213, 94, 0], [204, 121, 167], [160, 160, 160]];
const IDLE: [u8; 3] = [200, 200, 200];

/// A robot's own colour in traffic: its id hashed to a hue (ids one letter apart far apart).
fn robot_color(id: &str) -> [u8; 3] {
    let h = id.bytes().fold(0u32, |h, c| h.wrapping_mul(31).wrapping_add(u32::from(c)));
    let hue = (f64::from(h) * 137.508) % 360.0;
    // HSL with saturation 0.75, lightness 0.42, as RGB.
    let (s, l) = (0.75, 0.42);
    let c = (1.0 - (2.0 * l - 1.0f64).abs()) * s;
    let x = c * (1.0 - ((hue / 60.0) % 2.0 - 1.0).abs());
    let (r, g, b) = match (hue / 60.0) as u32 {
        0 => (c, x, 0.0),
        1 => (x, c, 0.0),
        2 => (0.0, c, x),
        3 => (0.0, x, c),
        4 => (x, 0.0, c),
        _ => (c, 0.0, x),
    };
    let m = l - c / 2.0;
    let to = |v: f64| ((v + m) * 255.0).round().clamp(0.0, 255.0) as u8;
    [to(r), to(g), to(b)]
}

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
            in_traffic: std::collections::BTreeSet::new(),
            batteries: BTreeMap::new(),
            bars_at: None,
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
        let [r, g, b] = self.color(t.mission.as_ref().map(|x| x.as_str()));
        let color = rerun::Color::from_rgb(r, g, b);
        let p = [t.pose.x as f32, t.pose.y as f32];
        let team = self.teams.get(&t.id).cloned();
        let label = match (&t.mission, team) {
            (Some(_), Some(team)) => format!("{} · {team}", t.id),
            (Some(m), None) => format!("{} · {m}", t.id),
            _ => t.id.to_string(),
        };
        self.log(&paths::robot(t.id.as_str()), &rerun::Points2D::new([p]).with_colors([color]).with_radii([0.5]).with_labels([label]));
        let dir = [(t.pose.theta.cos() * 1.2) as f32, (t.pose.theta.sin() * 1.2) as f32];
        self.log(&paths::robot_heading(t.id.as_str()), &rerun::Arrows2D::from_vectors([dir]).with_origins([p]).with_colors([color]));
        let trail = self.trails.entry(t.id.clone()).or_default();
        trail.push_back(p);
        while trail.len() > TRAIL {
            trail.pop_front();
        }
        let strip: Vec<[f32; 2]> = trail.iter().copied().collect();
        self.log(&paths::robot_trail(t.id.as_str()), &rerun::LineStrips2D::new([strip]).with_colors([color]).with_radii([0.08]));
        if let Some(b) = &t.battery {
            self.battery(t.id.clone(), b);
        }
    }

    /// A robot's charge as a time series, and (at most once a second) every robot's as bars in
    /// id order.
    fn battery(&mut self, id: proto::RobotId, b: &proto::BatteryState) {
        let percent = b.charge * 100.0;
        self.log(&paths::battery(id.as_str()), &rerun::Scalars::new([percent]));
        self.batteries.insert(id, percent);
        if self.bars_at.is_some_and(|t| t.elapsed().as_secs_f64() < BARS_EVERY_S) {
            return;
        }
        self.bars_at = Some(Instant::now());
        let values: Vec<f64> = self.batteries.values().copied().collect();
        self.log(paths::BATTERIES, &rerun::BarChart::new(values.as_slice()));
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
        let [r, g, b] = self.color(Some(m.name.as_str()));
        let color = rerun::Color::from_rgb(r, g, b);
        let changed = self.missions.get(&m.name).is_none_or(|old| old.summary != m.summary || old.manager != m.manager || old.teams != m.teams);
        if changed {
            match &m.summary {
                Some(PlanSummary::Patrol(p)) if !p.tour.is_empty() => {
                    let tour = xy(&p.tour);
                    let mut closed = tour.clone();
                    closed.push(tour[0]);
                    self.log(
                        &paths::mission_tour(m.name.as_str()),
                        &rerun::LineStrips2D::new([closed]).with_colors([color]).with_radii([0.12]).with_labels([m.name.to_string()]),
                    );
                    self.log(&paths::mission_waypoints(m.name.as_str()), &rerun::Points2D::new(tour).with_colors([color]).with_radii([0.3]));
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
                        self.log(&paths::mission_region(m.name.as_str()), &rerun::LineStrips2D::new(rings).with_colors([color]).with_radii([0.1]));
                    }
                    if !c.points.is_empty() {
                        self.log(
                            &paths::mission_points(m.name.as_str()),
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
            self.log(&paths::metric(m.name.as_str(), "worst_idleness"), &rerun::Scalars::new([w]));
        }
        if let Some(a) = m.metrics.avg_idleness {
            self.log(&paths::metric(m.name.as_str(), "avg_idleness"), &rerun::Scalars::new([a]));
        }
        let total: u64 = m.metrics.messages.values().sum();
        let now = self.t0.elapsed().as_secs_f64();
        if let Some((t, n)) = self.messages.insert(m.name.clone(), (now, total)) {
            if now > t && total >= n {
                self.log(&paths::metric(m.name.as_str(), "coordination_msgs_per_s"), &rerun::Scalars::new([(total - n) as f64 / (now - t)]));
            }
        }
        self.missions.insert(m.name.clone(), m.clone());
    }

    /// Traffic on the maps (`graphs`, by hash, for views without points): each robot's lanes held,
    /// the rest of its route, arrows to the robots it waits for; robots gone from traffic are
    /// cleared.
    pub(crate) fn traffic(&mut self, views: &[TrafficView], graphs: &BTreeMap<String, std::sync::Arc<mrmm_maps::NavGraph>>) {
        self.now();
        let mut drawn = std::collections::BTreeSet::new();
        let mut waiting = 0usize;
        for v in views {
            let g = graphs.get(&v.map);
            for r in &v.robots {
                // Where each vertex of its route is (traffic cuts long lanes: not all are the
                // map's own).
                let pts: Vec<Option<[f32; 2]>> = match g {
                    _ if r.points.len() == r.route.len() => r.points.iter().map(|p| Some([p[0] as f32, p[1] as f32])).collect(),
                    Some(g) => r.route.iter().map(|i| g.vertices.get(*i as usize).map(|x| [x.at.x as f32, x.at.y as f32])).collect(),
                    None => continue,
                };
                let [cr, cg, cb] = robot_color(r.robot.as_str());
                let color = rerun::Color::from_rgb(cr, cg, cb);
                let from = r.reached.unwrap_or(0) as usize;
                let held: Vec<[f32; 2]> = r.granted.map(|g| pts.iter().take(g as usize + 1).skip(from).filter_map(|p| *p).collect()).unwrap_or_default();
                let ahead: Vec<[f32; 2]> = pts.iter().skip(r.granted.unwrap_or(0) as usize).filter_map(|p| *p).collect();
                let label = if r.lost { format!("{} (lost)", r.robot) } else { r.robot.to_string() };
                let held = if held.len() == 1 { vec![held[0], held[0]] } else { held };
                self.log(
                    &paths::traffic_held(r.robot.as_str()),
                    &rerun::LineStrips2D::new([held]).with_colors([color]).with_radii([0.25]).with_labels([label]).with_draw_order(5.0),
                );
                self.log(
                    &paths::traffic_ahead(r.robot.as_str()),
                    &rerun::LineStrips2D::new([ahead]).with_colors([color]).with_radii([0.05]).with_draw_order(4.0),
                );
                let by = if r.blocked.is_empty() { &r.waits_for } else { &r.blocked };
                let me = self.trails.get(&r.robot).and_then(|t| t.back().copied());
                let arrows: Vec<([f32; 2], [f32; 2], String)> = by
                    .iter()
                    .filter_map(|b| {
                        let (p, q) = (me?, self.trails.get(b).and_then(|t| t.back().copied())?);
                        let how = if r.blocked.is_empty() { format!("waits {:.0} s", r.waiting_s.unwrap_or(0.0)) } else { "blocked".to_string() };
                        Some((p, [q[0] - p[0], q[1] - p[1]], format!("{} {how} for {b}", r.robot)))
                    })
                    .collect();
                let red = if r.blocked.is_empty() { rerun::Color::from_rgb(217, 119, 6) } else { rerun::Color::from_rgb(180, 35, 24) };
                self.log(
                    &paths::traffic_waits(r.robot.as_str()),
                    &rerun::Arrows2D::from_vectors(arrows.iter().map(|a| a.1))
                        .with_origins(arrows.iter().map(|a| a.0))
                        .with_labels(arrows.iter().map(|a| a.2.clone()))
                        .with_colors([red]),
                );
                waiting += usize::from(r.waiting_s.is_some());
                drawn.insert(r.robot.clone());
            }
        }
        for gone in self.in_traffic.difference(&drawn) {
            if let Err(e) = self.rec.log(paths::traffic(gone.as_str()).as_str(), &rerun::Clear::recursive()) {
                tracing::warn!("rerun clear {gone}: {e}");
            }
        }
        self.in_traffic = drawn;
        self.log(paths::TRAFFIC_WAITING, &rerun::Scalars::new([waiting as f64]));
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
