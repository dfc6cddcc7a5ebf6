//! The demo running: it waits for the fleet to register, starts the two missions (or drives the
//! formation), and redraws the fleet and the missions twice a second until it is stopped.

use std::io::Write;
use std::time::{Duration, Instant};

use mrmm_net::client::Client;
use mrmm_proto::{self as proto, GotoRequest, MissionCreate, MissionView, RobotStatus, RobotView};
use serde_json::json;
use tokio_util::sync::CancellationToken;

use super::{map, Args};

/// Up to this many robots the demo shows the fleet table; beyond, a summary.
const TABLE_MAX: usize = 16;

/// What the running demo keeps between two redraws.
pub(super) struct Watch<'a> {
    pub args: &'a Args,
    pub client: &'a Client,
    pub building: Option<&'a map::DemoMap>,
    pub started: Instant,
    pub endpoint: &'a str,
    /// Where the console and the tool config are (kept on screen).
    pub banner: String,
    pub tty: bool,
}

/// How far the demo got.
#[derive(Default)]
struct Progress {
    missions_started: bool,
    formation: usize,
    last_order: Option<Instant>,
}

impl Watch<'_> {
    /// Runs until `shutdown` or the demo's `--duration`.
    pub(super) async fn run(&self, shutdown: &CancellationToken) {
        let n = super::fleet(self.args);
        let deadline = self.args.duration.map(|d| self.started + Duration::from_secs_f64(d));
        let mut ticker = tokio::time::interval(Duration::from_millis(500));
        let registering = progress(n, "robots registered");
        let mut at = Progress::default();
        loop {
            tokio::select! {
                _ = shutdown.cancelled() => break,
                _ = ticker.tick() => {}
            }
            if deadline.is_some_and(|d| Instant::now() >= d) {
                break;
            }
            let views: Vec<RobotView> = match self.client.query(proto::Key::SystemRobots, None::<&()>).await {
                Ok(v) => v,
                Err(e) => {
                    eprintln!("fleet query failed: {e}");
                    continue;
                }
            };
            let live: Vec<&RobotView> = views.iter().filter(|v| v.status != RobotStatus::Lost).collect();
            let all_in = live.len() == n;
            if !registering.is_finished() {
                registering.set_position(live.len() as u64);
                if !all_in {
                    continue;
                }
                registering.finish_and_clear();
                println!("mrmm demo: {n} robots registered {:.1} s after the start", self.started.elapsed().as_secs_f64());
            }
            self.step(&mut at, all_in, &live).await;
            let missions: Vec<MissionView> =
                if self.args.formation { vec![] } else { self.client.query(proto::Key::SystemMissions, None::<&()>).await.unwrap_or_default() };
            show(self.tty, self.started, self.endpoint, &self.banner, n, &views, &missions);
        }
    }

    /// The demo's next order: its missions once every robot is in, or the formation's next turn
    /// once every robot stands still.
    async fn step(&self, at: &mut Progress, all_in: bool, live: &[&RobotView]) {
        if !self.args.formation {
            if all_in && !at.missions_started {
                at.missions_started = true;
                start_missions(self.client, super::fleet(self.args), self.building).await;
            }
            return;
        }
        let all_idle = live.iter().all(|v| v.status == RobotStatus::Idle);
        let settled = at.last_order.is_none_or(|t| t.elapsed() > Duration::from_secs(1));
        if !(all_in && all_idle && settled) {
            return;
        }
        at.formation += 1;
        let n = live.len();
        for (slot, v) in live.iter().enumerate() {
            let (x, y) = circle_point((slot + at.formation) % n, n, self.args.radius);
            let req = GotoRequest { robot: v.id.clone(), x, y, map: None };
            if let Err(e) = self.client.query::<serde_json::Value>(proto::Key::SystemCmd(proto::SystemCmd::Goto), Some(&req)).await {
                eprintln!("goto {} failed: {e}", v.id);
            }
        }
        at.last_order = Some(Instant::now());
    }
}

/// The demo's screen: a header, `banner` (where the console and the tool config are: the screen
/// is redrawn in place on a terminal, so the lines printed at the start would be gone), the robots
/// and the missions.
fn show(tty: bool, started: Instant, endpoint: &str, banner: &str, n: usize, views: &[RobotView], missions: &[MissionView]) {
    let mut out = String::new();
    if tty {
        out.push_str("\x1b[H\x1b[2J");
    }
    out.push_str(&format!(
        "mrmm demo  t={:6.1}s  central {endpoint}  robots {}/{n}  missions {}  (Ctrl-C to stop)\n",
        started.elapsed().as_secs_f64(),
        views.len(),
        missions.len()
    ));
    if tty {
        out.push_str(banner);
    }
    if n <= TABLE_MAX {
        out.push_str(&crate::cli::table::robots(views));
    } else {
        out.push_str(&summary(views));
    }
    if !missions.is_empty() {
        out.push('\n');
        out.push_str(&crate::cli::op::mission::table(missions));
    }
    out.push('\n');
    let mut stdout = std::io::stdout().lock();
    let _ = stdout.write_all(out.as_bytes());
    let _ = stdout.flush();
}

/// A progress bar on stderr (hidden when stderr is not a terminal).
fn progress(n: usize, what: &'static str) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(n as u64);
    if let Ok(style) = indicatif::ProgressStyle::with_template("{prefix:>18} [{bar:40}] {pos}/{len} {elapsed}") {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_prefix(what);
    bar
}

/// The fleet in a few lines: robots per status and per mission, and the robots needing attention.
fn summary(views: &[RobotView]) -> String {
    let count = |s: RobotStatus| views.iter().filter(|v| v.status == s).count();
    let mut per_mission: std::collections::BTreeMap<&str, usize> = std::collections::BTreeMap::new();
    for v in views {
        *per_mission.entry(v.mission.as_ref().map(|x| x.as_str()).unwrap_or("(none)")).or_default() += 1;
    }
    let mut out = format!(
        "robots: {} registered — {} busy, {} idle, {} lost\n",
        views.len(),
        count(RobotStatus::Busy),
        count(RobotStatus::Idle),
        count(RobotStatus::Lost)
    );
    let missions: Vec<String> = per_mission.iter().map(|(m, k)| format!("{m} {k}")).collect();
    out.push_str(&format!("by mission: {}\n", missions.join(", ")));
    let lost: Vec<&str> = views.iter().filter(|v| v.status == RobotStatus::Lost).map(|v| v.id.as_str()).collect();
    if !lost.is_empty() {
        let more = if lost.len() > 12 { format!(" and {} more", lost.len() - 12) } else { String::new() };
        out.push_str(&format!("lost: {}{more}\n", lost[..lost.len().min(12)].join(", ")));
    }
    out.push_str("(`mrmm op robots` lists every robot)\n");
    out
}

/// The demo's two missions: a patrol of the north waypoints with half the fleet (rounded up) and
/// a coverage of the southern field with the rest; on a map, of its northern and southern halves.
async fn start_missions(client: &Client, n: usize, building: Option<&map::DemoMap>) {
    let half = n.div_ceil(2);
    let (waypoints, region) = match building.map(map::DemoMap::params) {
        Some(Ok((w, r))) => (w, r),
        Some(Err(e)) => {
            eprintln!("cannot place the missions on the map: {e}");
            return;
        }
        None => (json!([[-15, 4], [-6, 14], [5, 17], [15, 9], [11, 1], [0, 0]]), Some(json!([[-20, -34], [20, -34], [20, -18], [-20, -18]]))),
    };
    let map = building.map(|_| map::NAME.to_string());
    let patrol = MissionCreate {
        name: "patrol-1".into(),
        recipe: "patrol".into(),
        params: [
            ("waypoints".to_string(), waypoints),
            // The mission's standard: the advising agent speaks up when the patrol misses it.
            ("max_worst_idleness".to_string(), json!(if building.is_some() { 60 } else { 15 })),
        ]
        .into(),
        map: map.clone(),
        ..MissionCreate::default()
    };
    create(client, patrol, |idle| idle.iter().take(half).cloned().collect()).await;
    if n > half {
        let coverage = MissionCreate {
            name: "coverage-1".into(),
            recipe: "coverage".into(),
            params: region.map(|r| [("region".to_string(), r)].into()).unwrap_or_default(),
            map,
            ..MissionCreate::default()
        };
        create(client, coverage, |idle| idle.to_vec()).await;
    }
}

/// Creates `m` with the robots `pick` chooses among the live robots in no mission (in id order),
/// choosing again if one of them was lost meanwhile: in a fleet of hundreds a robot may be lost
/// between the fleet's answer and the mission's plan. A create whose answer timed out on a
/// loaded machine may still have been carried out: its name taken means it was.
async fn create(client: &Client, mut m: MissionCreate, pick: impl Fn(&[proto::RobotId]) -> Vec<proto::RobotId>) {
    const TRIES: usize = 4;
    for attempt in 1..=TRIES {
        let views: Vec<RobotView> = match client.query(proto::Key::SystemRobots, None::<&()>).await {
            Ok(v) => v,
            Err(e) => {
                eprintln!("fleet query failed: {e}");
                continue;
            }
        };
        let mut idle: Vec<proto::RobotId> = views.iter().filter(|v| v.status != RobotStatus::Lost && v.mission.is_none()).map(|v| v.id.clone()).collect();
        idle.sort_by_key(|id| (id.as_str().len(), id.clone()));
        let robots = pick(&idle);
        if robots.is_empty() {
            eprintln!("cannot create mission {}: no idle robot left", m.name);
            return;
        }
        m.robots = Some(robots);
        match client.query::<serde_json::Value>(proto::Key::SystemCmd(proto::SystemCmd::Create), Some(&m)).await {
            Ok(_) => return,
            Err(e) if attempt > 1 && e.to_string().contains("already exists") => return,
            Err(e) if attempt < TRIES => eprintln!("mission {} not created ({e}): choosing its robots again", m.name),
            Err(e) => eprintln!("cannot create mission {}: {e}", m.name),
        }
    }
}

/// Slot `k` of `n` on a circle of radius `r` around the origin.
pub(super) fn circle_point(k: usize, n: usize, r: f64) -> (f64, f64) {
    let a = std::f64::consts::TAU * k as f64 / n.max(1) as f64;
    ((r * a.cos() * 100.0).round() / 100.0, (r * a.sin() * 100.0).round() / 100.0)
}
