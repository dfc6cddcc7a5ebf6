//! The operator layer's scripted run: `mrmm demo --robots 6 --rrd` (central, 6 robots, a patrol
//! held to a standard and a coverage), one robot killed, garbage published on the viewer's keys.
//! Through the public API: a critical "robot lost" advice, a "below standard" advice with the
//! marginal-benefit numbers; and a Rerun recording (decoded with Rerun's own decoder) whose
//! entities include every robot, the missions' map and scalars, and the advice log.

mod common;

use std::collections::BTreeMap;
use std::process::Command;
use std::time::{Duration, Instant};

use common::{eventually, Scratch};
use mrmm_net::client::Client;
use mrmm_proto::{self as proto, Advice, MissionView, Priority, RobotView};
use rerun::external::re_log_encoding::DecoderApp;
use rerun::log::{Chunk, LogMsg};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn scripted_run_advice_and_recording() -> anyhow::Result<()> {
    let dir = Scratch::new("rrd");
    let rrd = dir.path("fleet.rrd");
    let rrd_s = rrd.display().to_string();
    let started = Instant::now();
    let (mut demo, ep, operator) = common::start_demo(
        &dir,
        &["--robots", "6", "--duration", "40", "--listen", "quic/127.0.0.1:0", "--time-scale", "5", "--rrd", &rrd_s, "--battery-life", "900"],
    )?;
    let client = Client::connect_with(std::slice::from_ref(&ep), operator, Duration::from_secs(5)).await?;
    let live = client.session().declare_subscriber(proto::Key::AgentAdviceLive.to_string()).await.map_err(|e| anyhow::anyhow!("{e}"))?;
    eventually("two running missions", Duration::from_secs(20), || async {
        let m: Vec<MissionView> = client.query(proto::Key::SystemMissions, None::<&()>).await.ok()?;
        (m.len() == 2 && m.iter().all(|m| m.manager.epoch >= 1)).then_some(())
    })
    .await?;
    // Garbage on the keys the viewer bridge and the system manager listen to.
    for key in [
        proto::Key::RobotTelemetry("r3".into()).to_string(),
        proto::Key::AgentAdviceLive.to_string(),
        proto::Key::MissionStatus("patrol-1".into()).to_string(),
        proto::Key::TeamSync { team: "patrol-1".into(), point: 1, round: 0 }.to_string(),
    ] {
        client.session().put(key, b"\x00\xffgarbage".to_vec()).await.map_err(|e| anyhow::anyhow!("{e}"))?;
    }

    // Kill robot r2 (a patrol robot; its config lives in the demo's scratch directory).
    while live.try_recv().ok().flatten().is_some() {}
    let pattern = format!("mrmm-demo-{}/r2.json5", demo.pid());
    anyhow::ensure!(Command::new("pkill").args(["-9", "-f", &pattern]).status()?.success(), "could not kill r2");
    let killed = Instant::now();
    let lost = common::wait_raised(&live, "lost/r2", Duration::from_secs(10)).await?;
    println!("robot SIGKILL → critical advice published: {:?}", killed.elapsed());
    assert_eq!(lost.priority, Priority::Critical);
    assert!(lost.reason.starts_with("robot r2 lost; mission patrol-1 replanned for its 2 remaining robots"), "{}", lost.reason);
    let below = match eventually("below-standard advice", Duration::from_secs(30), || async {
        let a: Vec<Advice> = client.query(proto::Key::AgentAdvice, None::<&()>).await.ok()?;
        a.into_iter().find(|a| a.id == "standard/patrol-1")
    })
    .await
    {
        Ok(b) => b,
        Err(e) => {
            // What the agent saw: the missions and the advice standing.
            let m: Result<Vec<MissionView>, _> = client.query(proto::Key::SystemMissions, None::<&()>).await;
            let a: Result<Vec<Advice>, _> = client.query(proto::Key::AgentAdvice, None::<&()>).await;
            let r: Result<Vec<RobotView>, _> = client.query(proto::Key::SystemRobots, None::<&()>).await;
            // The robots' own telemetry (plan epochs, admissions), a second of it.
            let mut progress = BTreeMap::new();
            if let Ok(sub) = client.session().declare_subscriber(proto::Pattern::AllTelemetry.to_string()).await {
                let until = Instant::now() + Duration::from_secs(1);
                while let Ok(Ok(s)) = tokio::time::timeout(until.saturating_duration_since(Instant::now()), sub.recv_async()).await {
                    if let Ok(t) = proto::decode_telemetry(&s.payload().to_bytes()) {
                        progress.insert(t.id.clone(), format!("{:?} admitted {:?}", t.progress, t.admitted));
                    }
                }
            }
            return Err(e.context(format!(
                "telemetry: {progress:?}\nmissions: {}\nrobots: {}\nadvice: {a:?}",
                serde_json::to_string(&m.ok()).unwrap_or_default(),
                serde_json::to_string(&r.ok()).unwrap_or_default()
            )));
        }
    };
    assert!(below.reason.contains("to patrol-1: predicted worst idleness"), "{}", below.reason);
    assert!(below.evidence["predicted_with_one_more"].as_f64().is_some_and(|p| p < below.evidence["predicted"].as_f64().unwrap_or(0.0)));
    println!("advice: {} / {}", lost.reason, below.reason);
    client.close().await;

    demo.signal("INT")?;
    let ran_s = started.elapsed().as_secs_f64();
    let status = common::wait_exit(&mut demo, Duration::from_secs(20)).await?;
    assert!(status.success(), "demo exit status {status}");

    let rows = entity_rows(&rrd)?;
    let has = |p: &str| rows.get(p).copied().unwrap_or(0);
    let keys = || rows.keys().cloned().collect::<Vec<_>>();
    for r in 1..=6 {
        assert!(has(&format!("/fleet/robots/r{r}")) > 0, "robot r{r} missing: {:?}", keys());
        assert!(has(&format!("/fleet/robots/r{r}/heading")) > 0 && has(&format!("/fleet/robots/r{r}/trail")) > 0);
    }
    // Every robot's telemetry is drawn (5 Hz), not only its signed messages (one per
    // TELEMETRY_SIGN_MS): the robots tag it for the viewer, which announces itself.
    for r in [1, 3, 4, 5, 6] {
        let n = has(&format!("/fleet/robots/r{r}"));
        assert!(n as f64 >= 2.0 * ran_s, "robot r{r}: {n} positions drawn in {ran_s:.1} s (only the signed ones?)");
    }
    assert!(has("/fleet/missions/patrol-1/tour") > 0 && has("/fleet/missions/coverage-1/points") > 0, "{:?}", keys());
    assert!(has("/fleet/missions/coverage-1/region") > 0, "{:?}", keys());
    assert!(has("/advice") >= 2, "advice log: {:?}", keys());
    assert!(has("/events/teams") > 0 && has("/events/sync") > 0);
    assert!(has("/metrics/patrol-1/worst_idleness") > 0, "{:?}", keys());
    // Batteries (`--battery-life`): each robot's charge over time, and all of them as bars.
    for r in 1..=6 {
        let n = has(&format!("/batteries/robots/r{r}"));
        assert!(n > 0 && (r == 2 || n as f64 >= 2.0 * ran_s), "r{r}'s battery: {n} rows in {ran_s:.1} s, {:?}", keys());
    }
    assert!(has("/batteries/all") as f64 >= ran_s / 2.0, "the bars, about once a second: {:?}", keys());
    Ok(())
}

/// The demo on Open-RMF's office graph, recorded (secure fleet): traffic is in the recording —
/// each robot's lanes held, its route ahead and its waits under `fleet/traffic/<id>`, and the
/// count of robots waiting over time — read back with Rerun's own decoder.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_recording_shows_traffic_on_a_graph_map() -> anyhow::Result<()> {
    let dir = Scratch::new("rrd-traffic");
    let rrd = dir.path("fleet.rrd");
    let rrd_s = rrd.display().to_string();
    let office = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("maps/data/open_rmf/office.nav_graph.yaml").display().to_string();
    let (mut demo, ep, operator) =
        common::start_demo(&dir, &["--robots", "4", "--map", &office, "--duration", "60", "--listen", "quic/127.0.0.1:0", "--no-console", "--rrd", &rrd_s])?;
    let client = Client::connect_with(std::slice::from_ref(&ep), operator, Duration::from_secs(5)).await?;
    eventually("four robots in traffic for a few seconds", Duration::from_secs(40), || async {
        let v: Vec<proto::traffic::TrafficView> = client.query(proto::Key::SystemTraffic, None::<&()>).await.ok()?;
        v.iter().any(|m| m.robots.len() == 4).then_some(())
    })
    .await?;
    tokio::time::sleep(Duration::from_secs(3)).await;
    client.close().await;
    demo.signal("INT")?;
    let status = common::wait_exit(&mut demo, Duration::from_secs(20)).await?;
    assert!(status.success(), "demo exit status {status}");
    let rows = entity_rows(&rrd)?;
    let keys = || rows.keys().cloned().collect::<Vec<_>>();
    let held = rows.keys().filter(|k| k.starts_with("/fleet/traffic/") && k.ends_with("/held")).count();
    assert_eq!(held, 4, "lanes held of every robot: {:?}", keys());
    assert!(rows.keys().filter(|k| k.starts_with("/fleet/traffic/") && k.ends_with("/ahead")).count() == 4, "{:?}", keys());
    assert!(rows.get("/metrics/traffic/waiting").copied().unwrap_or(0) >= 2, "{:?}", keys());
    assert!(rows.keys().any(|k| k.starts_with("/fleet/map/")), "{:?}", keys());
    // The office's two chargers, drawn with the map.
    assert!(rows.keys().any(|k| k.starts_with("/fleet/map/") && k.ends_with("/chargers")), "{:?}", keys());
    Ok(())
}

#[test]
fn viz_without_a_viewer_says_so_and_keeps_going() -> anyhow::Result<()> {
    let port = std::net::TcpListener::bind("127.0.0.1:0")?.local_addr()?.port();
    let url = format!("rerun+http://127.0.0.1:{port}/proxy");
    let out = Command::new(common::EXE).args(["viz", "--connect", &url, "--central", "tcp/127.0.0.1:1", "--duration", "2"]).output()?;
    assert!(out.status.success(), "{out:?}");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("no Rerun viewer at 127.0.0.1:"), "{err}");
    let bad = Command::new(common::EXE).args(["viz", "--connect", "not-a-url", "--duration", "1"]).output()?;
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("viewer URL"));
    Ok(())
}

/// Rows logged per entity path in recording `rrd`, read with Rerun's own decoder.
fn entity_rows(rrd: &std::path::Path) -> anyhow::Result<BTreeMap<String, usize>> {
    let file = std::io::BufReader::new(std::fs::File::open(rrd)?);
    let mut rows: BTreeMap<String, usize> = BTreeMap::new();
    for msg in DecoderApp::decode_lazy(file) {
        if let LogMsg::ArrowMsg(_, arrow) = msg? {
            let chunk = Chunk::from_arrow_msg(&arrow)?;
            *rows.entry(chunk.entity_path().to_string()).or_default() += chunk.num_rows();
        }
    }
    Ok(rows)
}
