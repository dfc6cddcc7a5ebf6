//! The Zenoh → Rerun bridge.

use std::collections::{BTreeMap, VecDeque};
use std::net::ToSocketAddrs;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use mrmm_core::observer::{self, Seen};
use mrmm_net::{Following, Mesh};
use mrmm_proto::plan::Point;
use mrmm_proto::{self as proto, AdviceEvent, Key, MissionView, PlanSummary, Priority, SyncArrival, SyncRelease, Telemetry};
use rerun::RecordingStream;
use tokio_util::sync::CancellationToken;
use zenoh::sample::Sample;

use crate::{paths, VizError};

/// Positions kept in a robot's trail.
const TRAIL: usize = 60;
/// Messages waiting for the bridge's loop, at most (a flood drops what comes).
const QUEUE: usize = 4096;
/// How often to check that a viewer is reachable (`--connect`).
const PROBE_EVERY: Duration = Duration::from_secs(5);

/// Where the recording goes.
#[derive(Debug, Clone, PartialEq)]
pub enum Sink {
    /// A running viewer, e.g. `rerun+http://127.0.0.1:9876/proxy`.
    Connect(String),
    /// An `.rrd` file.
    Save(PathBuf),
    /// Spawn a viewer (needs `rerun` on PATH).
    Spawn,
}

fn rr(e: impl std::fmt::Display) -> VizError {
    VizError::Rerun(e.to_string())
}

/// Streams the fleet seen on `mesh` to `sink` until `shutdown`; flushes before returning. Only
/// what its proven sender may publish is drawn.
pub async fn run(mesh: Mesh, sink: Sink, shutdown: CancellationToken) -> Result<(), VizError> {
    let session = mesh.session().clone();
    let mut probe = match &sink {
        Sink::Connect(url) => Some(Probe { addr: viewer_addr(url)?, reachable: None }),
        _ => None,
    };
    let builder = rerun::RecordingStreamBuilder::new("mrmm_fleet");
    let rec = match &sink {
        Sink::Save(p) => builder.save(p).map_err(rr)?,
        Sink::Spawn => builder.spawn().map_err(rr)?,
        Sink::Connect(url) => builder.connect_grpc_opts(url.clone()).map_err(|e| VizError::Config(format!("viewer URL {url:?}: {e}")))?,
    };
    // What an observer hears (telemetry, missions' status, advice, barriers), in one queue.
    let (tx, mut heard) = tokio::sync::mpsc::channel::<Sample>(QUEUE);
    let mut follow = Following::new(session.clone(), move |s| {
        let _ = tx.try_send(s);
    });
    follow.follow(&observer::subscriptions()).await;
    if let Err(e) = crate::map::blueprint().send(&rec, rerun::blueprint::BlueprintActivation::default()) {
        tracing::warn!("the viewer's layout was not sent: {e}");
    }
    let mut view = View::new(rec.clone());
    // Maps arrive from the fleet (fetched by hash in the background), each drawn once.
    let (maps_tx, mut maps_rx) = tokio::sync::mpsc::unbounded_channel::<(proto::MapRef, Result<mrmm_maps::Map, String>)>();
    let mut maps_asked = std::collections::BTreeSet::new();
    // Announces itself to the robots, which tag their telemetry for it (otherwise it could
    // check only their signed messages: one per `TELEMETRY_SIGN_MS`).
    let mut hello = tokio::time::interval(Duration::from_millis(proto::VIEWER_HELLO_MS));
    let hello_key = Key::Viewer(mesh.me().id.clone()).to_string();
    let mut probe_tick = tokio::time::interval(PROBE_EVERY);
    loop {
        tokio::select! {
            _ = shutdown.cancelled() => break,
            _ = hello.tick(), if mesh.is_secure() => mesh.put(&hello_key, b"{}".to_vec(), zenoh::bytes::Encoding::APPLICATION_JSON).await,
            _ = probe_tick.tick(), if probe.is_some() => {
                if let Some(p) = probe.as_mut() {
                    p.check().await;
                }
            }
            Some((r, map)) = maps_rx.recv() => match map {
                Ok(map) => {
                    if let Err(e) = crate::map::log(&view.rec, &r.name, &map) {
                        tracing::warn!("rerun log of map {}: {e}", r.name);
                    }
                }
                Err(e) => {
                    // Asked again at the mission's next status.
                    tracing::warn!(map = %r.name, "cannot draw the map yet: {e}");
                    maps_asked.remove(&r.hash);
                }
            },
            s = heard.recv() => {
                let Some(s) = s else { break };
                match seen(&mesh, &s) {
                    Some(Seen::Telemetry(t)) => view.robot(&t),
                    Some(Seen::Mission(m)) => {
                        if let Some(r) = m.map.clone().filter(|r| maps_asked.insert(r.hash.clone())) {
                            fetch_map(session.clone(), r, maps_tx.clone());
                        }
                        view.mission(&m)
                    }
                    Some(Seen::Advice(a)) => view.advice(&a),
                    Some(Seen::Arrival { team, arrival }) => view.sync(&team, &arrival),
                    Some(Seen::Release { team, release }) => view.release(&team, &release),
                    None => {}
                }
            }
        }
    }
    match (rec.flush_blocking(), &sink) {
        (Ok(()), _) => Ok(()),
        // A viewer that never came: say so, it is not a failure of the bridge.
        (Err(e), Sink::Connect(url)) => {
            tracing::warn!("the fleet view was not delivered to {url}: {e}");
            eprintln!("mrmm viz: no Rerun viewer took the recording at {url}");
            Ok(())
        }
        (Err(e), _) => Err(rr(e)),
    }
}

/// What the viewer heard, its sender proven as an observer can (only the signed messages of a
/// team's barrier stream), translated with the one policy; refusals recorded, the rest logged.
fn seen(mesh: &Mesh, s: &Sample) -> Option<Seen> {
    let proof = observer::proof(s.key_expr().as_str())?;
    mesh.hear(s, Some(proof), observer::observe)
}

/// Fetches map `r` from the fleet and hands it to the loop.
fn fetch_map(session: zenoh::Session, r: proto::MapRef, to: tokio::sync::mpsc::UnboundedSender<(proto::MapRef, Result<mrmm_maps::Map, String>)>) {
    tokio::spawn(async move {
        let loaded = match mrmm_net::map::fetch(&session, &r).await {
            Ok(bytes) => mrmm_maps::Bundle::decode(&r.name, &bytes).and_then(|b| b.load()).map(|(_, m)| m).map_err(|e| e.to_string()),
            Err(e) => Err(e),
        };
        let _ = to.send((r, loaded));
    });
}

/// Whether the viewer the bridge connects to is there, said when it changes.
struct Probe {
    addr: String,
    reachable: Option<bool>,
}

impl Probe {
    async fn check(&mut self) {
        let addr = &self.addr;
        let ok = tokio::time::timeout(Duration::from_secs(1), tokio::net::TcpStream::connect(addr)).await.is_ok_and(|r| r.is_ok());
        if self.reachable != Some(ok) {
            if ok {
                tracing::info!("Rerun viewer reachable at {addr}");
            } else {
                tracing::warn!("no Rerun viewer at {addr} yet; buffering and retrying (start one with `rerun`)");
                eprintln!("mrmm viz: no Rerun viewer at {addr} yet; retrying every {} s", PROBE_EVERY.as_secs());
            }
            self.reachable = Some(ok);
        }
    }
}

/// `host:port` of a `rerun+http://host:port/proxy` URL, checked to resolve.
fn viewer_addr(url: &str) -> Result<String, VizError> {
    let rest = url.split("://").nth(1).ok_or_else(|| VizError::Config(format!("viewer URL {url:?}: expected rerun+http://HOST:PORT/proxy")))?;
    let addr = rest.split('/').next().unwrap_or(rest).to_string();
    addr.to_socket_addrs().map_err(|e| VizError::Config(format!("viewer URL {url:?}: {e}")))?;
    Ok(addr)
}

/// Points as Rerun positions.
fn xy(points: &[Point]) -> Vec<[f32; 2]> {
    points.iter().map(|p| [p.x as f32, p.y as f32]).collect()
}

/// What has been drawn, to draw only changes.
struct View {
    rec: RecordingStream,
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
    fn new(rec: RecordingStream) -> Self {
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

    fn robot(&mut self, t: &Telemetry) {
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

    fn mission(&mut self, m: &MissionView) {
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

    fn advice(&mut self, a: &AdviceEvent) {
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

    fn release(&mut self, team: &str, r: &SyncRelease) {
        self.now();
        let text = format!("{} released {team} barriers up to {} of round {} (epoch {})", r.leader, r.point, r.round, r.epoch);
        self.log(paths::SYNC_LOG, &rerun::TextLog::new(text).with_level(rerun::TextLogLevel::DEBUG));
    }

    fn sync(&mut self, team: &str, a: &SyncArrival) {
        self.now();
        let text = format!("{} reached {team} barrier {} of round {} (epoch {})", a.robot, a.point, a.round, a.epoch);
        self.log(paths::SYNC_LOG, &rerun::TextLog::new(text).with_level(rerun::TextLogLevel::DEBUG));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn viewer_urls() {
        assert_eq!(viewer_addr("rerun+http://127.0.0.1:9876/proxy").expect("ok"), "127.0.0.1:9876");
        assert!(viewer_addr("127.0.0.1:9876").is_err());
    }
}
