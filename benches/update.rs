//! A running mission updated by the operator, with real `mrmm` processes on loopback: central
//! and 5 robots (telemetry at 50 Hz) on a patrol; 50 updates in a row, each new waypoints. For
//! each, the time from the operator's command to the moment every member's telemetry says it runs
//! the new epoch (the operator's answer, central's check and dry run, the head's replan, the plans
//! out, the robots taking them): p50 and p99.
//!
//! `cargo bench --bench update [-- --updates N]`.

#[path = "../tests/common/mod.rs"]
mod common;

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use common::{eventually, start, start_central, Scratch};
use mrmm_net::client::Client;
use mrmm_proto::{self as proto, Key, MissionCreate, MissionUpdate, MissionView, Pattern};
use serde_json::json;
use zenoh::handlers::RingChannel;

const ROBOTS: usize = 5;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let updates: usize = args.iter().position(|a| a == "--updates").and_then(|i| args.get(i + 1)).and_then(|v| v.parse().ok()).unwrap_or(50);
    let rt = tokio::runtime::Builder::new_multi_thread().enable_all().build()?;
    rt.block_on(run(updates))
}

async fn run(updates: usize) -> anyhow::Result<()> {
    let dir = Scratch::new("bench-update");
    let (_central, ep) = start_central(&dir)?;
    let mut robots = Vec::new();
    for i in 1..=ROBOTS {
        let id = format!("r{i}");
        let cfg = format!(
            r#"{{ id: "{id}", type: "ground", kinematics: {{ max_speed: 1.0, max_turn_rate: 2.0 }},
                 start: {{ x: {x}, y: -3 }}, time_scale: 5, telemetry_hz: 50,
                 zenoh: {{ listen: ["tcp/127.0.0.1:0"], connect: ["{ep}"], lease_ms: 1000 }} }}"#,
            x = i as f64 * 2.0
        );
        let path = dir.path(&format!("{id}.json5"));
        std::fs::write(&path, cfg)?;
        robots.push(start(&id, &["robot", "--config", &path.display().to_string()], &dir.path(&format!("{id}.log")), "robot ready", Duration::from_secs(20))?);
    }
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await?;
    common::wait_robots(&client, ROBOTS).await?;
    let telemetry =
        client.session().declare_subscriber(Pattern::AllTelemetry.to_string()).with(RingChannel::new(16_384)).await.map_err(|e| anyhow::anyhow!("{e}"))?;
    let square = |side: f64| json!([[0, 0], [side, 0], [side, side], [0, side]]);
    let create = MissionCreate {
        name: "p".into(),
        recipe: "patrol".into(),
        count: Some(ROBOTS),
        params: [("waypoints".to_string(), square(10.0))].into(),
        ..Default::default()
    };
    let _: MissionView = client.query(Key::SystemCmd(proto::SystemCmd::Create), Some(&create)).await?;
    eventually("the patrol running", Duration::from_secs(30), || async {
        let v: MissionView = client.query(Key::SystemMission("p".into()), None::<&()>).await.ok()?;
        (v.metrics.sync_points_passed >= 1).then_some(())
    })
    .await?;
    // Each robot's latest epoch of mission p, as its telemetry says.
    let mut epochs: BTreeMap<String, u64> = BTreeMap::new();
    let mut times = Vec::new();
    for u in 0..updates {
        let before = client.query::<MissionView>(Key::SystemMission("p".into()), None::<&()>).await?.manager.epoch;
        let update = MissionUpdate { name: "p".into(), params: [("waypoints".to_string(), square(12.0 + (u % 2) as f64 * 4.0))].into(), ..Default::default() };
        let asked = Instant::now();
        let _: serde_json::Value = client.query(Key::SystemCmd(proto::SystemCmd::Update), Some(&update)).await?;
        let deadline = asked + Duration::from_secs(20);
        loop {
            while let Ok(Some(s)) = telemetry.try_recv() {
                if let Ok(t) = proto::decode_telemetry(&s.payload().to_bytes()) {
                    if let Some(p) = t.progress.filter(|p| p.mission == "p") {
                        epochs.insert(t.id.to_string(), p.epoch);
                    }
                }
            }
            if epochs.len() == ROBOTS && epochs.values().all(|e| *e > before) {
                times.push(asked.elapsed().as_secs_f64() * 1000.0);
                break;
            }
            anyhow::ensure!(Instant::now() < deadline, "update {u}: not every member on the new epoch within 20 s: {epochs:?}");
            tokio::time::sleep(Duration::from_millis(2)).await;
        }
    }
    times.sort_by(f64::total_cmp);
    let at = |q: f64| times[((times.len() - 1) as f64 * q).round() as usize];
    println!("\n### Update → every member on the new plan ({ROBOTS} robots, central, loopback, telemetry 50 Hz)\n");
    println!("| updates | min ms | p50 ms | p99 ms | max ms |");
    println!("|---:|---:|---:|---:|---:|");
    println!("| {} | {:.0} | {:.0} | {:.0} | {:.0} |", times.len(), times[0], at(0.5), at(0.99), times[times.len() - 1]);
    client.close().await;
    drop(robots);
    Ok(())
}
