//! Robots as clients of their site's router (`zenoh.mode: client`, docs/deployment.md): one
//! started before any router tries its endpoints again until its own answers; each keeps one
//! link, to the router, not one to every robot of its site; central registers and commands them
//! through the router, and their patrol's barriers pass through it. When the router is
//! SIGKILLed, each robot opens its next connect endpoint (central), is registered again, and the
//! patrol goes on with the same three robots.

mod common;

use std::time::Duration;

use anyhow::{anyhow, ensure};
use common::{eventually, start, tcp_peers, Proc, Scratch};
use mrmm_net::client::Client;
use mrmm_proto::{self as proto, MissionView, RobotStatus, RobotView};

/// The `host:port` of a `tcp/host:port` endpoint.
fn addr(ep: &str) -> &str {
    ep.trim_start_matches("tcp/")
}

/// A site router on `listen`, linked to central.
fn router(dir: &Scratch, central: &str, listen: &str) -> anyhow::Result<Proc> {
    let path = dir.path("site1.json5");
    std::fs::write(&path, format!(r#"{{ id: "site1", listen: ["{listen}"], connect: ["{central}"], lease_ms: 1000 }}"#))?;
    start("site1", &["router", "--config", &path.display().to_string()], &dir.path("site1.log"), "router ready", Duration::from_secs(20))
}

/// A robot that is a client of `connect[0]`, falling back to the others.
fn client_robot(dir: &Scratch, id: &str, connect: &[&str], x: f64) -> anyhow::Result<Proc> {
    let cfg = format!(
        r#"{{ id: "{id}", type: "ground", kinematics: {{ max_speed: 1.0, max_turn_rate: 2.0 }},
             start: {{ x: {x}, y: -3 }}, time_scale: 10, telemetry_hz: 10,
             zenoh: {{ mode: "client", connect: {}, lease_ms: 1000 }} }}"#,
        serde_json::to_string(connect)?
    );
    let path = dir.path(&format!("{id}.json5"));
    std::fs::write(&path, cfg)?;
    start(id, &["robot", "--config", &path.display().to_string()], &dir.path(&format!("{id}.log")), "robot ready", Duration::from_secs(20))
}

async fn mission(client: &Client) -> Option<MissionView> {
    client.query(proto::Key::SystemMission("p".into()), None::<&()>).await.ok()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn client_robots_link_to_their_router_only_and_fall_back_to_central() -> anyhow::Result<()> {
    let dir = Scratch::new("clients");
    let free = || -> anyhow::Result<String> { Ok(format!("tcp/{}", std::net::TcpListener::bind("127.0.0.1:0")?.local_addr()?)) };
    let (site_ep, central_ep) = (free()?, free()?);
    // r1 starts before any router is up: it tries its endpoints again until one answers, its
    // site's router; central comes up after that.
    let (mut site, first) = std::thread::scope(|s| -> anyhow::Result<(Proc, Proc)> {
        let first = s.spawn(|| client_robot(&dir, "r1", &[&site_ep, &central_ep], 2.0));
        let retried = || std::fs::read_to_string(dir.path("r1.log")).is_ok_and(|l| l.contains("answers yet; trying again"));
        let t = std::time::Instant::now();
        while !retried() {
            ensure!(t.elapsed() < Duration::from_secs(20) && !first.is_finished(), "r1 never tried its routers again");
            std::thread::sleep(Duration::from_millis(20));
        }
        let site = router(&dir, &central_ep, &site_ep)?;
        Ok((site, first.join().map_err(|_| anyhow!("r1's start panicked"))??))
    })?;
    let state = dir.path("central-state").display().to_string();
    let _central =
        start("central", &["central", "--listen", &central_ep, "--state-dir", &state], &dir.path("central.log"), "central ready", Duration::from_secs(20))?;
    let mut robots = vec![first];
    for i in 2..=3 {
        robots.push(client_robot(&dir, &format!("r{i}"), &[&site_ep, &central_ep], f64::from(i) * 2.0)?);
    }
    let client = Client::connect(std::slice::from_ref(&central_ep), Duration::from_secs(5)).await?;
    common::wait_robots(&client, 3).await?;

    // One link each, to the router: no clique among them, none to central.
    for r in &robots {
        let peers = tcp_peers(None, r.pid())?;
        ensure!(peers == [addr(&site_ep)], "{} links to {peers:?}; a client links to its router {site_ep} only", r.name);
    }
    let _: MissionView = client.query(proto::Key::SystemCmd(proto::SystemCmd::Create), Some(&common::square_patrol(3, None))).await?;
    let before = eventually("the patrol past its first barriers through the router", Duration::from_secs(30), || async {
        mission(&client).await.filter(|m| m.metrics.sync_points_passed >= 2)
    })
    .await?;

    // The router dies: each robot opens its next endpoint, central.
    site.kill();
    for r in &robots {
        eventually(&format!("{} linked to central", r.name), Duration::from_secs(30), || async {
            (tcp_peers(None, r.pid()).ok()? == [addr(&central_ep)]).then_some(())
        })
        .await?;
    }
    eventually("all three robots registered and not lost", Duration::from_secs(30), || async {
        let v: Vec<RobotView> = client.query(proto::Key::SystemRobots, None::<&()>).await.ok()?;
        (v.len() == 3 && v.iter().all(|r| r.status != RobotStatus::Lost)).then_some(())
    })
    .await?;
    let after = eventually("the patrol with its three robots again", Duration::from_secs(40), || async {
        mission(&client).await.filter(|m| m.robots == ["r1", "r2", "r3"] && m.plans.as_ref().is_some_and(|p| p.len() == 3))
    })
    .await?;
    eventually("the patrol passing barriers through central", Duration::from_secs(30), || async {
        mission(&client).await.filter(|m| m.metrics.sync_points_passed >= after.metrics.sync_points_passed.max(before.metrics.sync_points_passed) + 2)
    })
    .await?;
    client.close().await;
    Ok(())
}
