//! Traffic with real processes: robots of two missions on Open-RMF's office navigation graph
//! share its lanes through central's traffic authority. An outside client (eclipse-zenoh, the
//! ecosystem's own) samples every robot's pose five times a second and measures every two robots'
//! distance.

mod common;

use std::path::PathBuf;
use std::time::{Duration, Instant};

use common::{eventually, start, Scratch};
use mrmm_core::traffic::CLEARANCE;
use mrmm_net::client::Client;
use mrmm_proto::{self as proto, MissionCreate, MissionStatus, MissionView, RobotView};
use serde_json::{json, Value};

/// The poses compared are each robot's latest telemetry (10 Hz) as central holds it, not taken at
/// one instant: two robots driving at 1 m/s may each be up to 0.1 m from where they were shown.
const SAMPLING: f64 = 0.2;

fn office() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("maps/data/open_rmf/office.nav_graph.yaml")
}

/// `n` vertices of the office graph at least 2 m from each other, in the graph's order.
fn starts(n: usize) -> anyhow::Result<Vec<(f64, f64)>> {
    let g = mrmm_maps::rmf::parse("office", &std::fs::read_to_string(office())?)?;
    let mut picked: Vec<mrmm_maps::Point> = Vec::new();
    for v in &g.vertices {
        if picked.iter().all(|p| p.dist(v.at) >= 2.0) {
            picked.push(v.at);
        }
    }
    anyhow::ensure!(picked.len() >= n, "only {} vertices 2 m apart", picked.len());
    Ok(picked.iter().take(n).map(|p| (p.x, p.y)).collect())
}

/// How close the robots came in `seconds`, as the outside client measured it.
fn closest(py: &std::path::Path, ep: &str, seconds: f64) -> anyhow::Result<Value> {
    let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/py/closest_robots.py");
    let out = std::process::Command::new(py).arg(script).args([ep, &seconds.to_string()]).output()?;
    anyhow::ensure!(out.status.success(), "sampler: {}", String::from_utf8_lossy(&out.stderr));
    Ok(serde_json::from_str(String::from_utf8_lossy(&out.stdout).trim())?)
}

/// Robots that drove at least 1 m in a sampler's run.
fn moving(v: &Value) -> usize {
    v["moved"].as_object().map_or(0, |m| m.values().filter(|d| d.as_f64().unwrap_or(0.0) >= 1.0).count())
}

fn check(v: &Value, when: &str) -> anyhow::Result<()> {
    let c = v["closest"].as_f64().unwrap_or(0.0);
    println!("{when}: {} samples, closest {c:.2} m ({}), {} robots moved", v["samples"], v["pair"], moving(v));
    anyhow::ensure!(v["samples"].as_u64().unwrap_or(0) >= 20, "{when}: too few samples: {v}");
    anyhow::ensure!(c >= CLEARANCE - SAMPLING, "{when}: {} came {c:.2} m apart (clearance {CLEARANCE} m): {v}", v["pair"]);
    Ok(())
}

/// `mrmm demo --map` on a graph map with 8 robots on two missions: never closer than the
/// clearance, and both missions go on (the patrol passes its sync points).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_demo_on_a_graph_map_keeps_its_robots_apart() -> anyhow::Result<()> {
    let Some(py) = common::standin::python_or_skip()? else { return Ok(()) };
    let dir = Scratch::new("traffic-demo");
    let map = office().display().to_string();
    let (_demo, ep, _) = common::start_demo(&dir, &["--insecure", "--robots", "8", "--map", &map, "--duration", "120", "--no-console"])?;
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await?;
    eventually("two running missions", Duration::from_secs(30), || async {
        let m: Vec<MissionView> = client.query(proto::Key::SystemMissions, None::<&()>).await.ok()?;
        (m.len() == 2 && m.iter().all(|m| m.status == MissionStatus::Running)).then_some(())
    })
    .await?;
    let v = closest(&py, &ep, 30.0)?;
    check(&v, "the demo, 30 s")?;
    anyhow::ensure!(moving(&v) >= 4, "robots did not drive: {v}");
    let p: MissionView = client.query(proto::Key::SystemMission("patrol-1".into()), None::<&()>).await?;
    println!("patrol-1 passed {} sync points", p.metrics.sync_points_passed);
    anyhow::ensure!(p.metrics.sync_points_passed >= 1, "the patrol passed no sync point: {:?}", p.metrics);
    client.close().await;
    Ok(())
}

fn start_central(dir: &Scratch, listen: &str, log: &str) -> anyhow::Result<(common::Proc, String)> {
    let (map, state) = (format!("office={}", office().display()), dir.path("central-state").display().to_string());
    let p = start("central", &["central", "--listen", listen, "--map", &map, "--state-dir", &state], &dir.path(log), "central ready", Duration::from_secs(20))?;
    let ep = p.field("listening").and_then(|l| l.split(',').next().map(str::to_string)).ok_or_else(|| anyhow::anyhow!("no endpoint"))?;
    Ok((p, ep))
}

/// Where every robot is, by id.
async fn poses(client: &Client) -> Option<Vec<(String, f64, f64)>> {
    let v: Vec<RobotView> = client.query(proto::Key::SystemRobots, None::<&()>).await.ok()?;
    Some(v.iter().filter_map(|r| r.pose.map(|p| (r.id.to_string(), p.x, p.y))).collect())
}

/// Central SIGKILLed while robots of two missions drive on the office graph: they stop at the
/// ends of their grants, and after central's restart its new traffic authority rebuilds what each
/// holds from their reports and lets them go on — never closer than the clearance throughout.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn robots_go_on_after_centrals_restart_and_never_meet() -> anyhow::Result<()> {
    let Some(py) = common::standin::python_or_skip()? else { return Ok(()) };
    let dir = Scratch::new("traffic-restart");
    let (mut central, ep) = start_central(&dir, "tcp/127.0.0.1:0", "central.log")?;
    let _robots: Vec<common::Proc> =
        starts(6)?.iter().enumerate().map(|(i, &(x, y))| common::start_robot_scaled(&dir, &format!("r{}", i + 1), &ep, x, y, 1.0)).collect::<Result<_, _>>()?;
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await?;
    common::wait_robots(&client, 6).await?;
    for (name, recipe, robots, params) in
        [("p", "patrol", ["r1", "r2", "r3"], [("waypoints".to_string(), json!("all"))].into()), ("c", "coverage", ["r4", "r5", "r6"], Default::default())]
    {
        let m = MissionCreate {
            name: name.into(),
            recipe: recipe.into(),
            robots: Some(robots.iter().map(|r| (*r).into()).collect()),
            params,
            map: Some("office".into()),
            ..Default::default()
        };
        let _: MissionView = client.query(proto::Key::SystemCmd(proto::SystemCmd::Create), Some(&m)).await?;
    }
    let before = closest(&py, &ep, 15.0)?;
    check(&before, "before central's kill")?;
    anyhow::ensure!(moving(&before) >= 3, "robots did not drive: {before}");
    client.close().await;

    central.kill();
    tokio::time::sleep(Duration::from_secs(4)).await; // robots left without orders for longer than QUIET_S
    let t0 = Instant::now();
    let (_central, _) = start_central(&dir, &ep, "central2.log")?;
    let ready = t0.elapsed();
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await?;
    let first = eventually("robots after central's restart", Duration::from_secs(15), || async { poses(&client).await.filter(|p| p.len() == 6) }).await?;
    let heard = t0.elapsed();
    let moved = eventually("a robot driving again", Duration::from_secs(20), || async {
        let now = poses(&client).await?;
        now.iter().any(|(id, x, y)| first.iter().any(|(i, a, b)| i == id && (x - a).hypot(y - b) > 0.3)).then_some(())
    })
    .await;
    println!(
        "central ready {:.2} s after its start; a robot drove again {:.2} s after that (robots heard again after {:.2} s)",
        ready.as_secs_f64(),
        (t0.elapsed() - ready).as_secs_f64(),
        (heard - ready).as_secs_f64()
    );
    if moved.is_err() {
        let v: Vec<RobotView> = client.query(proto::Key::SystemRobots, None::<&()>).await?;
        for r in v {
            println!("{}: {:?} {:?} {:?}", r.id, r.behaviour, r.pose, r.mission);
        }
    }
    moved?;
    let after = closest(&py, &ep, 15.0)?;
    check(&after, "after central's restart")?;
    anyhow::ensure!(moving(&after) >= 3, "robots did not go on: {after}");
    client.close().await;
    Ok(())
}
