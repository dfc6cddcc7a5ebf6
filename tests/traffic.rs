//! Traffic with real processes: robots of two missions on Open-RMF's office navigation graph
//! share its lanes through central's traffic authority. An outside client (eclipse-zenoh, the
//! ecosystem's own) samples every robot's pose five times a second and measures every two robots'
//! distance.

mod common;

use std::path::PathBuf;
use std::time::Duration;

use common::{eventually, Scratch};
use mrmm_core::traffic::CLEARANCE;
use mrmm_net::client::Client;
use mrmm_proto::{self as proto, MissionStatus, MissionView};
use serde_json::Value;

/// The poses compared are each robot's latest telemetry (10 Hz) as central holds it, not taken at
/// one instant: two robots driving at 1 m/s may each be up to 0.1 m from where they were shown.
const SAMPLING: f64 = 0.2;

fn office() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("maps/data/open_rmf/office.nav_graph.yaml")
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
    let v = closest(&py, &ep, 45.0)?;
    check(&v, "the demo, 45 s")?;
    anyhow::ensure!(moving(&v) >= 4, "robots did not drive: {v}");
    let p: MissionView = client.query(proto::Key::SystemMission("patrol-1".into()), None::<&()>).await?;
    println!("patrol-1 passed {} sync points", p.metrics.sync_points_passed);
    anyhow::ensure!(p.metrics.sync_points_passed >= 1, "the patrol passed no sync point: {:?}", p.metrics);
    client.close().await;
    Ok(())
}
