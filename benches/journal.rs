//! What central's journal costs and buys, with real `mrmm` processes on loopback:
//!
//! * **command latency**: central (journal in a scratch dir on this machine's disk) and 8 robots;
//!   1 000 moves of robots between two missions, then creates and terminates, one at a time; each
//!   is committed with fsync before its answer. p50/p99 of the operator's round trip.
//! * **recovery**: 8 robots on 3 missions; every process SIGKILLed at once and restarted; the time
//!   from restarting central to all three missions running again with their members.
//!
//! `cargo bench --bench journal [-- --moves N --creates N]`.

#[path = "../tests/common/mod.rs"]
mod common;

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use common::{eventually, start, Proc, Scratch};
use mrmm_net::client::Client;
use mrmm_proto::{self as proto, MissionCreate, MissionTerminate, MissionView, RobotMove, RobotView};

fn arg(name: &str, default: usize) -> usize {
    let args: Vec<String> = std::env::args().collect();
    args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).and_then(|v| v.parse().ok()).unwrap_or(default)
}

fn main() -> anyhow::Result<()> {
    let rt = tokio::runtime::Builder::new_multi_thread().enable_all().build()?;
    rt.block_on(async {
        latency(arg("--moves", 1000), arg("--creates", 200)).await?;
        recovery().await
    })
}

fn free_port() -> anyhow::Result<u16> {
    Ok(std::net::TcpListener::bind("127.0.0.1:0")?.local_addr()?.port())
}

fn central(dir: &Scratch, ep: &str, log: &str) -> anyhow::Result<Proc> {
    let state = dir.path("central-state").display().to_string();
    start("central", &["central", "--listen", ep, "--state-dir", &state], &dir.path(log), "central ready", Duration::from_secs(20))
}

fn patrol(name: &str, robots: &[String]) -> MissionCreate {
    MissionCreate {
        name: name.into(),
        recipe: "patrol".into(),
        robots: Some(robots.iter().map(Into::into).collect()),
        params: [("waypoints".to_string(), serde_json::json!([[0, 0], [12, 0], [12, 12], [0, 12]]))].into(),
        ..MissionCreate::default()
    }
}

fn stats(label: &str, mut ms: Vec<f64>) {
    ms.sort_by(f64::total_cmp);
    let at = |q: f64| ms[((ms.len() - 1) as f64 * q).round() as usize];
    println!("| {label} | {} | {:.2} | {:.2} | {:.2} | {:.2} |", ms.len(), at(0.5), at(0.9), at(0.99), ms[ms.len() - 1]);
}

async fn latency(moves: usize, creates: usize) -> anyhow::Result<()> {
    let dir = Scratch::new("bench-journal");
    let ep = format!("tcp/127.0.0.1:{}", free_port()?);
    let _c = central(&dir, &ep, "central.log")?;
    let _robots = common::start_robots(&dir, &ep, 8)?;
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await?;
    common::wait_robots(&client, 8).await?;
    let cmd = proto::Key::SystemCmd;
    for (name, robot) in [("a", "r1"), ("b", "r2")] {
        let _: MissionView = client.query(cmd(proto::SystemCmd::Create), Some(&patrol(name, &[robot.into()]))).await?;
    }
    println!("| command (fsync before the answer) | n | p50 ms | p90 ms | p99 ms | max ms |\n|---|---|---|---|---|---|");
    let mut ms = Vec::new();
    for i in 0..moves {
        let robot = format!("r{}", 3 + i % 6);
        let to = if (i / 6) % 2 == 0 { "a" } else { "b" };
        let t = Instant::now();
        let _: serde_json::Value =
            client.query(cmd(proto::SystemCmd::Move), Some(&RobotMove { robot: robot.into(), to: Some(to.into()), replaces: None })).await?;
        ms.push(t.elapsed().as_secs_f64() * 1000.0);
    }
    stats("robot move", ms);
    // Creates take free robots: the six movers are freed first.
    for i in 3..=8 {
        let _: serde_json::Value =
            client.query(cmd(proto::SystemCmd::Move), Some(&RobotMove { robot: format!("r{i}").into(), to: None, replaces: None })).await?;
    }
    eventually("six idle robots", Duration::from_secs(20), || async {
        let v: Vec<RobotView> = client.query(proto::Key::SystemRobots, None::<&()>).await.ok()?;
        (v.iter().filter(|r| r.status == proto::RobotStatus::Idle).count() == 6).then_some(())
    })
    .await?;
    let (mut made, mut ended) = (Vec::new(), Vec::new());
    for i in 0..creates {
        let name = format!("x{i}");
        let robot = format!("r{}", 3 + i % 6);
        let t = Instant::now();
        let _: MissionView = client.query(cmd(proto::SystemCmd::Create), Some(&patrol(&name, &[robot]))).await?;
        made.push(t.elapsed().as_secs_f64() * 1000.0);
        let t = Instant::now();
        let _: serde_json::Value = client.query(cmd(proto::SystemCmd::Terminate), Some(&MissionTerminate { name: name.into() })).await?;
        ended.push(t.elapsed().as_secs_f64() * 1000.0);
        // The robot must be idle again before it can be taken.
        let id = format!("r{}", 3 + i % 6);
        eventually("the robot idle again", Duration::from_secs(20), || async {
            let v: RobotView = client.query(proto::Key::SystemRobot(id.clone().into()), None::<&()>).await.ok()?;
            (v.status == proto::RobotStatus::Idle).then_some(())
        })
        .await?;
    }
    stats("mission create (dry run, plan, first plans out)", made);
    stats("mission terminate", ended);
    client.close().await;
    Ok(())
}

async fn recovery() -> anyhow::Result<()> {
    let dir = Scratch::new("bench-recovery");
    let ep = format!("tcp/127.0.0.1:{}", free_port()?);
    let mut c = central(&dir, &ep, "central.log")?;
    let mut robots = common::start_robots(&dir, &ep, 8)?;
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await?;
    common::wait_robots(&client, 8).await?;
    let ids = |r: &[usize]| r.iter().map(|i| format!("r{i}")).collect::<Vec<_>>();
    for (name, members) in [("a", ids(&[1, 2, 3])), ("b", ids(&[4, 5, 6])), ("c", ids(&[7, 8]))] {
        let _: MissionView = client.query(proto::Key::SystemCmd(proto::SystemCmd::Create), Some(&patrol(name, &members))).await?;
    }
    let placed = |v: Vec<RobotView>| v.into_iter().map(|r| (r.id, r.mission)).collect::<BTreeMap<_, _>>();
    let before = placed(client.query(proto::Key::SystemRobots, None::<&()>).await?);
    client.close().await;
    let pids: Vec<String> = robots.iter().chain(std::iter::once(&c)).map(|p| p.pid().to_string()).collect();
    std::process::Command::new("kill").arg("-9").args(&pids).status()?;
    for p in robots.iter_mut() {
        p.kill();
    }
    c.kill();
    let t0 = Instant::now();
    let _c = central(&dir, &ep, "central2.log")?;
    robots = common::start_robots(&dir, &ep, 8)?;
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await?;
    eventually("three missions running again", Duration::from_secs(60), || async {
        let ms: Vec<MissionView> = client.query(proto::Key::SystemMissions, None::<&()>).await.ok()?;
        let now = placed(client.query(proto::Key::SystemRobots, None::<&()>).await.ok()?);
        (ms.iter().filter(|m| m.status == proto::MissionStatus::Running).count() == 3 && now == before).then_some(())
    })
    .await?;
    println!(
        "\nrecovery after a power cycle (8 robots, 3 missions): {:.2} s from restarting central to all three running with their members",
        t0.elapsed().as_secs_f64()
    );
    drop(robots);
    Ok(())
}
