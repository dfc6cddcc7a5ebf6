//! Resilience figures with real `mrmm` processes on loopback (lease 1000 ms):
//!
//! * **takeover**: a mission's manager runs on `mrmm mission-host`, replicated on two of its four
//!   robots; the host is SIGKILLed (or SIGSTOPped: then only the lease reveals it) and we time
//!   from the signal to the first status published by the successor.
//! * **stall**: four robots patrol (time scale 5) under a manager on central; central is
//!   SIGKILLed. For each robot, the longest time it stood still (moved < 1 cm between two
//!   telemetry samples, 10 Hz) in the 15 s before and the 15 s after the kill, and the longest
//!   gap between two of its barrier arrivals, before and after.
//!
//! `cargo bench --bench resilience [-- --trials N]` (default 10 takeover trials per signal).

#[path = "../tests/common/mod.rs"]
mod common;

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use anyhow::anyhow;
use common::{eventually, start_central, Scratch};
use mrmm_net::client::Client;
use mrmm_net::net::{self, Mode};
use mrmm_proto::{self as proto, MissionCreate, MissionTerminate, MissionView, SyncArrival};

/// Simulated seconds per wall second in the stall run (a barrier every 2 s of wall time).
const SCALE: f64 = 5.0;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let trials: usize = args.iter().position(|a| a == "--trials").and_then(|i| args.get(i + 1)).and_then(|v| v.parse().ok()).unwrap_or(10);
    let rt = tokio::runtime::Builder::new_multi_thread().enable_all().build()?;
    rt.block_on(async {
        takeover(trials).await?;
        stall().await
    })
}

fn square(name: &str, host: &str) -> MissionCreate {
    MissionCreate {
        name: name.into(),
        recipe: "patrol".into(),
        count: Some(4),
        host: Some(host.into()),
        params: [("waypoints".to_string(), serde_json::json!([[0, 0], [10, 0], [10, 10], [0, 10]]))].into(),
        ..Default::default()
    }
}

fn stats(label: &str, mut ms: Vec<f64>) {
    ms.sort_by(f64::total_cmp);
    let at = |q: f64| ms[((ms.len() - 1) as f64 * q).round() as usize];
    println!("| {label} | {} | {:.1} | {:.1} | {:.1} | {:.1} |", ms.len(), ms[0], at(0.5), at(0.9), ms[ms.len() - 1]);
}

async fn takeover(trials: usize) -> anyhow::Result<()> {
    let dir = Scratch::new("bench-takeover");
    let (_central, ep) = start_central(&dir)?;
    let _robots = common::start_robots(&dir, &ep, 4)?;
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await?;
    common::wait_robots(&client, 4).await?;
    // Robots do not vote during their first 2 s (a restarted node must not vote twice).
    tokio::time::sleep(Duration::from_secs(2)).await;
    println!("\n### Mission-manager takeover (head on a mission host, 2 robot replicas, 4 robots)\n");
    println!("| head | trials | min ms | p50 ms | p90 ms | max ms |");
    println!("|---|---:|---:|---:|---:|---:|");
    for signal in ["KILL", "STOP"] {
        let mut times = Vec::new();
        for t in 0..trials {
            let host_name = format!("h{signal}{t}").to_lowercase();
            let mut host = common::start_host(&dir, &host_name, &ep)?;
            let name = format!("m{}{t}", signal.to_lowercase());
            let create = square(&name, &host_name);
            eventually("the mission on its host", Duration::from_secs(20), || async {
                client.query::<MissionView>(proto::Key::SystemCmd(proto::SystemCmd::Create), Some(&create)).await.ok()
            })
            .await?;
            // A fresh host may start the chain short (it has not heard of every robot's host
            // yet); it fills it up within a vote.
            eventually("a chain of three", Duration::from_secs(10), || async {
                let m: MissionView = client.query(proto::Key::SystemMission(name.as_str().into()), None::<&()>).await.ok()?;
                (m.manager.chain.len() == 3 && m.manager.node == host_name).then_some(())
            })
            .await?;
            let statuses =
                client.session().declare_subscriber(proto::Key::MissionStatus(name.as_str().into()).to_string()).await.map_err(|e| anyhow!("{e}"))?;
            host.signal(signal)?;
            let t0 = Instant::now();
            let took = tokio::time::timeout(Duration::from_secs(10), async {
                loop {
                    let s = statuses.recv_async().await.ok()?;
                    let v: MissionView = serde_json::from_slice(&s.payload().to_bytes()).ok()?;
                    if v.manager.node != host_name {
                        return Some(t0.elapsed());
                    }
                }
            })
            .await
            .ok()
            .flatten()
            .ok_or_else(|| anyhow!("no takeover after SIG{signal}"))?;
            times.push(took.as_secs_f64() * 1e3);
            host.kill();
            let _: serde_json::Value =
                client.query(proto::Key::SystemCmd(proto::SystemCmd::Terminate), Some(&MissionTerminate { name: name.as_str().into() })).await?;
        }
        stats(&format!("SIG{signal}"), times);
    }
    client.close().await;
    Ok(())
}

async fn stall() -> anyhow::Result<()> {
    let dir = Scratch::new("bench-stall");
    let (mut central, ep) = start_central(&dir)?;
    let robots: Vec<_> =
        (1..=4).map(|i| common::start_robot_scaled(&dir, &format!("r{i}"), &ep, i as f64 * 2.0, -3.0, SCALE)).collect::<anyhow::Result<_>>()?;
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await?;
    common::wait_robots(&client, 4).await?;
    tokio::time::sleep(Duration::from_secs(2)).await;
    let _: MissionView = client.query(proto::Key::SystemCmd(proto::SystemCmd::Create), Some(&square("p", "central"))).await?;
    eventually("the patrol on its rounds", Duration::from_secs(60), || async {
        let m: MissionView = client.query(proto::Key::SystemMission("p".into()), None::<&()>).await.ok()?;
        (m.metrics.sync_points_passed >= 2).then_some(())
    })
    .await?;
    client.close().await;
    let peers: Vec<String> = robots.iter().filter_map(|r| r.field("listening")).collect();
    let observer = net::open(net::zenoh_config(Mode::Peer, &["tcp/127.0.0.1:0".into()], &peers, 1000)?).await?;
    let telemetry = observer.declare_subscriber(proto::Pattern::AllTelemetry.to_string()).await.map_err(|e| anyhow!("{e}"))?;
    let arrivals = observer.declare_subscriber(proto::Pattern::TeamSync("p".to_string()).to_string()).await.map_err(|e| anyhow!("{e}"))?;
    let window = Duration::from_secs(15);
    let t0 = Instant::now();
    let mut killed: Option<f64> = None;
    let mut poses: BTreeMap<String, Vec<(f64, f64, f64)>> = BTreeMap::new();
    let mut syncs: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    while t0.elapsed() < 2 * window {
        if killed.is_none() && t0.elapsed() >= window {
            central.kill();
            killed = Some(t0.elapsed().as_secs_f64());
        }
        tokio::select! {
            s = telemetry.recv_async() => {
                let Ok(s) = s else { break };
                if let Ok(t) = proto::decode_telemetry(&s.payload().to_bytes()) {
                    poses.entry(t.id.to_string()).or_default().push((t0.elapsed().as_secs_f64(), t.pose.x, t.pose.y));
                }
            }
            s = arrivals.recv_async() => {
                let Ok(s) = s else { break };
                if let Ok(a) = proto::from_json::<SyncArrival>("arrival", &s.payload().to_bytes()) {
                    syncs.entry(a.robot.to_string()).or_default().push(t0.elapsed().as_secs_f64());
                }
            }
            _ = tokio::time::sleep(Duration::from_millis(50)) => {}
        }
    }
    let k = killed.unwrap_or(window.as_secs_f64());
    println!("\n### Patrol disturbance when central (router + system manager + mission manager) is SIGKILLed\n");
    println!("Four robots, time scale {SCALE}, 10 m square; windows of {} s (wall) before and after the kill.\n", window.as_secs());
    println!("| robot | longest standstill before s | after s | barriers before | after | longest gap between barriers before s | after s |");
    println!("|---|---:|---:|---:|---:|---:|---:|");
    for (id, ps) in &poses {
        let standstill = |from: f64, to: f64| {
            let mut longest: f64 = 0.0;
            let mut since: Option<f64> = None;
            for w in ps.windows(2) {
                let (t, moved) = (w[1].0, (w[1].1 - w[0].1).hypot(w[1].2 - w[0].2));
                if t < from || t > to {
                    continue;
                }
                if moved < 0.01 {
                    let s = *since.get_or_insert(w[0].0.max(from));
                    longest = longest.max(t - s);
                } else {
                    since = None;
                }
            }
            longest
        };
        let gap = |from: f64, to: f64| {
            let ts: Vec<f64> = syncs.get(id).map(|v| v.iter().copied().filter(|t| *t >= from && *t <= to).collect()).unwrap_or_default();
            ts.windows(2).map(|w| w[1] - w[0]).fold(0.0, f64::max)
        };
        let end = 2.0 * window.as_secs_f64();
        let count = |from: f64, to: f64| syncs.get(id).map_or(0, |v| v.iter().filter(|t| **t >= from && **t <= to).count());
        println!(
            "| {id} | {:.2} | {:.2} | {} | {} | {:.2} | {:.2} |",
            standstill(0.0, k),
            standstill(k, end),
            count(0.0, k),
            count(k, end),
            gap(0.0, k),
            gap(k, end)
        );
    }
    let _ = observer.close().await;
    Ok(())
}
