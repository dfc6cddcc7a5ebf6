//! Missions of hundreds of robots through Zenoh's message limit (1 MiB by default): a real
//! central's planner service answers a mission host asking for a patrol of 500 robots (1.3 MB as
//! plain JSON) compressed, and Python's standard zstd module opens what went on the wire.

mod common;

use std::path::PathBuf;
use std::process::Command;
use std::time::Duration;

use common::standin::python_or_skip;
use common::{start_central, Scratch};
use mrmm_net::mesh::{Mesh, NodeNet};
use mrmm_net::net::{Mode, DEFAULT_LEASE_MS, DEFAULT_MAX_MESSAGE_SIZE};
use mrmm_proto::{self as proto, MissionPlan, PlanRequest, RobotSpec, Role, Sender};

const N: usize = 500;

fn request(n: usize) -> PlanRequest {
    let robots = (0..n)
        .map(|i| RobotSpec {
            id: format!("r{i}").into(),
            robot_type: "ground".into(),
            x: (i % 25) as f64 * 2.0,
            y: (i / 25) as f64 * 2.0,
            speed: 1.0,
            turn_rate: None,
            reach_m: None,
        })
        .collect();
    PlanRequest { recipe: "patrol".into(), params: Default::default(), robots, map: None, capabilities: Default::default(), relax_bounds: false }
}

/// A mission host's session, as `mrmm mission-host` opens it: 1 MiB message limit.
async fn host(ep: &str) -> anyhow::Result<Mesh> {
    let n = NodeNet {
        mode: Mode::Client,
        listen: vec![],
        connect: vec![ep.to_string()],
        lease_ms: DEFAULT_LEASE_MS,
        max_message_size: DEFAULT_MAX_MESSAGE_SIZE,
        security: None,
        me: Some(Sender::new(Role::Host, "h1")),
        wire_stats: false,
    };
    Ok(Mesh::open(&n).await?)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_plan_of_500_robots_reaches_the_host_that_asked() -> anyhow::Result<()> {
    let dir = Scratch::new("large-missions");
    let (_central, ep) = start_central(&dir)?;
    let mesh = host(&ep).await?;
    let key = proto::Key::Planner("patrol".into()).to_string();
    let body = proto::to_json(&request(N))?;
    let (plan, _): (MissionPlan, _) = mesh.query(&key, Some(body.clone()), Duration::from_secs(30), |s| s.role == Role::Central).await?;
    assert_eq!(plan.plans.len(), N);
    assert!(plan.plans.iter().all(|p| p.steps.len() > 10));
    let plain = proto::to_json(&plan)?.len();
    assert!(plain > DEFAULT_MAX_MESSAGE_SIZE, "the plan is {plain} bytes as JSON: within the message limit, proving nothing");

    // What went on the wire: a zstd frame under the limit, tagged as one.
    let replies =
        mesh.session().get(&key).payload(body.clone()).attachment(mesh.seal(&key, &body)).timeout(Duration::from_secs(30)).await.map_err(anyhow::Error::msg)?;
    let reply = replies.recv_async().await.map_err(anyhow::Error::msg)?;
    let sample = reply.result().map_err(|e| anyhow::anyhow!("error reply: {}", String::from_utf8_lossy(&e.payload().to_bytes())))?;
    assert_eq!(sample.encoding().to_string(), "application/zstd");
    let wire = sample.payload().to_bytes().into_owned();
    println!("a plan of {N} robots: {plain} bytes as JSON, {} on the wire", wire.len());
    assert!(wire.len() < DEFAULT_MAX_MESSAGE_SIZE);

    // The ecosystem's own zstd (Python's standard module, its backport before 3.14) opens it.
    let Some(py) = python_or_skip()? else { return Ok(()) };
    let path = dir.path("plan.zst");
    std::fs::write(&path, &wire)?;
    let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/py/unzstd.py");
    let out = Command::new(py).arg(script).arg(&path).output()?;
    anyhow::ensure!(out.status.success(), "python: {}", String::from_utf8_lossy(&out.stderr));
    let opened: MissionPlan = serde_json::from_slice(&out.stdout)?;
    assert_eq!(opened, plan);
    mesh.session().close().await.map_err(anyhow::Error::msg)?;
    Ok(())
}
