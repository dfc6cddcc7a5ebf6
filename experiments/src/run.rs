//! One run of an experiment: a circular patrol of `robots` robots on the fleet, optionally
//! `extract` of them moved to a blanket coverage after the first round (the paper's switch),
//! watched until the patrol team has done its rounds; what the system reports is the result.

use std::time::{Duration, Instant};

use anyhow::{anyhow, bail};
use mrmm_proto::BarrierMode;
use mrmm_proto::{self as proto, MissionCreate, MissionStatus, MissionTerminate, MissionView, RobotMove};
use serde_json::json;

use crate::fleet::{Fleet, SPEED};
use crate::wire::{self, Wire};

/// The patrolled environment at scale 1: a closed loop of eight waypoints around a 16 m × 10 m
/// field (tour ≈ 50 m); the environment experiment multiplies every coordinate.
pub const WAYPOINTS: [(f64, f64); 8] = [(0.0, 0.0), (8.0, -1.0), (16.0, 0.0), (17.0, 5.0), (16.0, 10.0), (8.0, 11.0), (0.0, 10.0), (-1.0, 5.0)];

/// What one run is.
#[derive(Debug, Clone)]
pub struct Spec {
    pub experiment: &'static str,
    pub robots: usize,
    /// Robots moved to a coverage mission after the first round (0: an eventless run).
    pub extract: usize,
    pub env_scale: f64,
    pub rounds: u32,
    pub time_scale: f64,
    pub seed: u64,
    pub barrier: BarrierMode,
    /// Leaf teams the robots are split into (a recipe of teams, each patrolling the tour with
    /// barriers of its own); 1: the bank's patrol.
    pub teams: usize,
}

impl Spec {
    /// The configuration as the figures label it: `10`, `15→10`, or `4×5` (four teams of five).
    pub fn label(&self) -> String {
        if self.teams > 1 {
            format!("{}×{}", self.teams, self.robots / self.teams)
        } else if self.extract > 0 {
            format!("{}→{}", self.robots, self.robots - self.extract)
        } else {
            self.robots.to_string()
        }
    }
}

/// What one run measured. Times are robot seconds (wall × time scale) unless named wall.
#[derive(Debug, Clone)]
pub struct Row {
    pub spec: Spec,
    /// Robots patrolling at the end.
    pub robots_after: usize,
    pub tour_m: f64,
    pub sync_per_round: u32,
    pub wall_s: f64,
    pub avg_idleness_s: f64,
    pub worst_idleness_s: f64,
    /// L / (n · v): the idleness of n robots evenly spread, never stopping.
    pub bound_s: f64,
    pub sync_points: u32,
    /// Seconds a robot waited at barriers per round, averaged over the team (final plan).
    pub sync_wait_per_round_s: f64,
    pub msgs_plan: u64,
    pub msgs_sync: u64,
    /// Messages the fleet's nodes sent on their links during the run, per kind.
    pub wire: Wire,
}

impl Row {
    pub fn msgs_total(&self) -> u64 {
        self.msgs_plan.saturating_add(self.msgs_sync)
    }
}

/// How long every node has to report its wire statistics.
const WIRE_READ: Duration = Duration::from_secs(5);

/// Runs `spec` as mission `name` on `fleet` and leaves the fleet idle again.
pub async fn run(fleet: &Fleet, name: &str, spec: &Spec) -> anyhow::Result<Row> {
    if spec.robots > fleet.ids.len() || spec.extract >= spec.robots {
        bail!("run {name}: {} robots ({} extracted) on a fleet of {}", spec.robots, spec.extract, fleet.ids.len());
    }
    let started = Instant::now();
    let result = measure(fleet, name, spec).await;
    for m in [name.to_string(), format!("{name}-coverage")] {
        let _ = fleet.client.query::<serde_json::Value>(proto::Key::SystemCmd(proto::SystemCmd::Terminate), Some(&MissionTerminate { name: m.into() })).await;
    }
    fleet.settle(Duration::from_secs(60)).await?;
    let mut row = result?;
    row.wall_s = started.elapsed().as_secs_f64();
    Ok(row)
}

async fn measure(fleet: &Fleet, name: &str, spec: &Spec) -> anyhow::Result<Row> {
    let team: Vec<String> = fleet.ids[..spec.robots].to_vec();
    let waypoints: Vec<[f64; 2]> = WAYPOINTS.iter().map(|(x, y)| [x * spec.env_scale, y * spec.env_scale]).collect();
    let create = MissionCreate {
        name: name.into(),
        recipe: if spec.teams > 1 { teams_recipe(spec.teams, spec.robots / spec.teams) } else { "patrol".into() },
        robots: Some(team.iter().map(Into::into).collect()),
        params: [("waypoints".to_string(), json!(waypoints)), ("barrier".to_string(), json!(spec.barrier.as_str()))].into(),
        ..MissionCreate::default()
    };
    let before = wire::read(&fleet.client, WIRE_READ).await?;
    command(fleet, proto::SystemCmd::Create, &create).await?;
    // A round of the tour, in wall seconds, bounds how long anything may take.
    let tour_wall = tour_length(&waypoints) / SPEED / spec.time_scale;
    let patience = Duration::from_secs_f64(60.0 + tour_wall * (f64::from(spec.rounds) + 2.0) * 3.0);
    let deadline = Instant::now() + patience;
    let mut rounds_wanted = spec.rounds;
    if spec.extract > 0 {
        wait_rounds(fleet, name, 1, deadline).await?;
        let out = extracted(&team, spec.extract, spec.seed);
        // The leave flow for each (a create does not take robots from a running mission), then
        // the coverage mission with them.
        for r in &out {
            command(fleet, proto::SystemCmd::Move, &RobotMove { robot: r.clone().into(), to: None, replaces: None }).await?;
        }
        let coverage = MissionCreate {
            name: format!("{name}-coverage").into(),
            recipe: "coverage".into(),
            robots: Some(out.iter().map(Into::into).collect()),
            params: [("region".to_string(), json!([[-30, -30], [-10, -30], [-10, -10], [-30, -10]]))].into(),
            ..MissionCreate::default()
        };
        command(fleet, proto::SystemCmd::Create, &coverage).await?;
        // The patrol replans for those left; its rounds count again from the new plan.
        wait_members(fleet, name, spec.robots - spec.extract, deadline).await?;
        rounds_wanted = spec.rounds.saturating_sub(1).max(1);
    }
    wait_rounds(fleet, name, rounds_wanted, deadline).await?;
    // The wire counters, then the mission's own counts right after (the mission runs on: both
    // are read as close together as they can be).
    let read = Instant::now();
    let after = wire::read(&fleet.client, WIRE_READ).await?;
    tracing::debug!("wire statistics of {} nodes read in {:?}", after.nodes, read.elapsed());
    if after.nodes < fleet.ids.len() + 1 {
        bail!("run {name}: only {} of {} nodes reported their wire statistics", after.nodes, fleet.ids.len() + 1);
    }
    let v = view(fleet, name).await.ok_or_else(|| anyhow!("mission {name} vanished"))?;
    let patrol = v.summary.as_ref().and_then(|s| s.patrol()).ok_or_else(|| anyhow!("mission {name} has no patrol summary"))?;
    let n = v.robots.len();
    let m = &v.metrics;
    let msg = |k: &str| m.messages.get(k).copied().unwrap_or(0);
    Ok(Row {
        spec: spec.clone(),
        robots_after: n,
        tour_m: patrol.length,
        sync_per_round: patrol.sync_per_round,
        wall_s: 0.0,
        avg_idleness_s: m.avg_idleness.unwrap_or(f64::NAN),
        worst_idleness_s: m.worst_idleness.unwrap_or(f64::NAN),
        bound_s: patrol.length / (n.max(1) as f64 * SPEED),
        sync_points: m.sync_points_passed,
        sync_wait_per_round_s: m.sync_wait_s / (n.max(1) as f64 * f64::from(m.rounds.max(1))),
        msgs_plan: msg("plan"),
        msgs_sync: msg("sync"),
        wire: after.since(&before),
    })
}

async fn command<T: serde::Serialize>(fleet: &Fleet, cmd: proto::SystemCmd, body: &T) -> anyhow::Result<()> {
    fleet.client.query::<serde_json::Value>(proto::Key::SystemCmd(cmd), Some(body)).await.map(|_| ()).map_err(|e| anyhow!("{e}"))
}

async fn view(fleet: &Fleet, name: &str) -> Option<MissionView> {
    fleet.client.query(proto::Key::SystemMission(name.into()), None::<&()>).await.ok()
}

/// Waits until the patrol's whole team completed `rounds` rounds of its current plan.
async fn wait_rounds(fleet: &Fleet, name: &str, rounds: u32, deadline: Instant) -> anyhow::Result<MissionView> {
    let mut last = None;
    loop {
        if let Some(v) = view(fleet, name).await {
            if v.status == MissionStatus::Failed {
                bail!("mission {name} failed: {}", v.error.unwrap_or_default());
            }
            if v.status == MissionStatus::Running && v.metrics.rounds >= rounds && v.summary.is_some() {
                return Ok(v);
            }
            last = Some(v.metrics.rounds);
        }
        if Instant::now() > deadline {
            bail!("mission {name}: {last:?} of {rounds} rounds done in time");
        }
        tokio::time::sleep(Duration::from_millis(250)).await;
    }
}

/// Waits until the patrol runs with `n` members.
async fn wait_members(fleet: &Fleet, name: &str, n: usize, deadline: Instant) -> anyhow::Result<()> {
    loop {
        if view(fleet, name).await.is_some_and(|v| v.robots.len() == n) {
            return Ok(());
        }
        if Instant::now() > deadline {
            bail!("mission {name} never ran with {n} members");
        }
        tokio::time::sleep(Duration::from_millis(250)).await;
    }
}

/// The `k` robots of `team` moved out, chosen by `seed` (splitmix64 over the team's indices).
fn extracted(team: &[String], k: usize, seed: u64) -> Vec<String> {
    let mut order: Vec<(u64, &String)> = team
        .iter()
        .enumerate()
        .map(|(i, id)| {
            let mut z = seed.wrapping_add((i as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15));
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            (z ^ (z >> 31), id)
        })
        .collect();
    order.sort();
    order.into_iter().take(k).map(|(_, id)| id.clone()).collect()
}

/// A recipe of `teams` leaf patrol teams of `size` robots each (their `min` and `max`), every one
/// patrolling the mission's waypoints with barriers of its own.
pub fn teams_recipe(teams: usize, size: usize) -> String {
    let behaviour = r#"<behaviour type="*"><stream/><navigate to="slot"/><sync point="start"/><loop><round/></loop></behaviour>"#;
    let leaves: String =
        (1..=teams).map(|t| format!(r#"<team name="t{t}" planner="patrol" min="{size}" max="{size}">{behaviour}</team>"#)).collect::<Vec<_>>().join("\n  ");
    format!("<recipe name=\"teams\">\n  {leaves}\n</recipe>")
}

pub fn tour_length(points: &[[f64; 2]]) -> f64 {
    points.iter().zip(points.iter().cycle().skip(1)).map(|(a, b)| (a[0] - b[0]).hypot(a[1] - b[1])).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn extraction_is_seeded_and_takes_k_distinct_members() {
        let team: Vec<String> = (1..=10).map(|i| format!("r{i}")).collect();
        let a = extracted(&team, 5, 7);
        assert_eq!(a, extracted(&team, 5, 7));
        assert_ne!(a, extracted(&team, 5, 8));
        let mut d = a.clone();
        d.sort();
        d.dedup();
        assert_eq!(d.len(), 5);
    }

    #[test]
    fn the_teams_recipe_splits_the_robots_evenly() {
        let xml = teams_recipe(4, 5);
        let r = mrmm_planner::recipe::parse(&xml).expect("parses");
        let leaves = r.leaves();
        let got: Vec<(String, usize, Option<usize>)> = leaves.iter().map(|l| (l.path().to_string(), l.min, l.max)).collect();
        let want: Vec<(String, usize, Option<usize>)> = (1..=4).map(|t| (format!("t{t}"), 5, Some(5))).collect();
        assert_eq!(got, want);
    }

    #[test]
    fn the_base_environment_is_about_fifty_metres_around() {
        let pts: Vec<[f64; 2]> = WAYPOINTS.iter().map(|(x, y)| [*x, *y]).collect();
        let l = tour_length(&pts);
        assert!((45.0..60.0).contains(&l), "{l}");
    }
}
