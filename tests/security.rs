//! The fleet over mutual TLS (Zenoh's QUIC link) with signed messages, with real processes on
//! loopback: strangers (no certificate, or one of another CA) cannot open a session with central
//! (on its QUIC and its TLS endpoint) or with a robot; a
//! rogue holding a valid *robot* certificate tries every attack — operator commands, a plan with
//! a huge epoch, forged telemetry and barrier arrivals of another robot, forged chain messages
//! (End, Stale with a huge promise, a vote), a fake planner service answering first — and each is
//! refused while the fleet's mission goes on; the refusals show in central's status and in the
//! logs; the operator's certificate commands everything.

mod common;

use std::time::{Duration, Instant};

use common::{eventually, fleet_pki, start_secure_central, start_secure_robot, Scratch};
use mrmm_net::client::Client;
use mrmm_proto::chain::{Config, Msg};
use mrmm_proto::{
    self as proto, ChainEnvelope, Key, MissionCreate, MissionView, PlanRequest, RobotCommand, RobotView, SecuritySection, SyncArrival, SystemStatus,
};
use serde_json::json;
use zenoh::bytes::Encoding;

/// Opening a client session to `ep` with a hand-made TLS config (`cert`: the client's own
/// certificate and key, if any) fails.
async fn cannot_open(ep: &str, ca: &std::path::Path, cert: Option<(&std::path::Path, &std::path::Path)>) -> bool {
    let mut c = zenoh::Config::default();
    let mut set = |k: &str, v: String| c.insert_json5(k, &v).is_ok();
    let ok = set("mode", "\"client\"".into())
        && set("connect/endpoints", serde_json::to_string(&[ep]).unwrap_or_default())
        && set("scouting/multicast/enabled", "false".into())
        && set("transport/link/tls/root_ca_certificate", format!("{:?}", ca.display().to_string()))
        && set("transport/link/tls/verify_name_on_connect", "false".into());
    let ok = ok
        && match cert {
            Some((crt, key)) => {
                set("transport/link/tls/connect_certificate", format!("{:?}", crt.display().to_string()))
                    && set("transport/link/tls/connect_private_key", format!("{:?}", key.display().to_string()))
                    && set("transport/link/tls/enable_mtls", "true".into())
            }
            None => true,
        };
    assert!(ok, "test config");
    match tokio::time::timeout(Duration::from_secs(10), zenoh::open(c)).await {
        Ok(Ok(s)) => {
            let _ = s.close().await;
            false
        }
        _ => true,
    }
}

fn log(dir: &Scratch, name: &str) -> String {
    std::fs::read_to_string(dir.path(&format!("{name}.log"))).unwrap_or_default()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn strangers_cannot_connect_and_a_rogue_robot_cannot_act() -> anyhow::Result<()> {
    let dir = Scratch::new("security");
    let pki = fleet_pki(&dir, 4)?;
    // Central listens on QUIC (the fleet's links) and on TLS: strangers are refused on both.
    let p = pki.display().to_string();
    let central = common::start(
        "central",
        &["central", "--listen", "quic/127.0.0.1:0", "--listen", "tls/127.0.0.1:0", "--pki", &p, "--operator", "op"],
        &dir.path("central.log"),
        "central ready",
        Duration::from_secs(20),
    )?;
    let listening: Vec<String> = central.field("listening").map(|l| l.split(',').map(String::from).collect()).unwrap_or_default();
    let ep = listening.iter().find(|e| e.starts_with("quic/")).cloned().ok_or_else(|| anyhow::anyhow!("central: {listening:?}"))?;
    let tls_ep = listening.iter().find(|e| e.starts_with("tls/")).cloned().ok_or_else(|| anyhow::anyhow!("central: {listening:?}"))?;
    let robots: Vec<common::Proc> = (1..=4).map(|i| start_secure_robot(&dir, &pki, &format!("r{i}"), &ep, i as f64 * 2.0)).collect::<Result<_, _>>()?;
    let eps: Vec<String> = robots.iter().filter_map(|r| r.field("listening")).collect();
    let op = Client::connect_with(std::slice::from_ref(&ep), Some(SecuritySection::from_dir(&pki, "op")), Duration::from_secs(5)).await?;
    common::wait_robots(&op, 4).await?;
    // p is r1..r3 by name (r4 stays idle for q); retried while a robot's liveliness flaps under load.
    let mut pc = common::square_patrol(3, None);
    (pc.count, pc.robots) = (None, Some(vec!["r1".into(), "r2".into(), "r3".into()]));
    // An answer that never arrives (seen about one run in three when this fleet ran over Zenoh's
    // TLS link, whose race drops links: docs/zenoh.md) leaves p created: a retry that finds it
    // takes its view.
    let m: MissionView = eventually("p created with r1..r3", Duration::from_secs(10), || async {
        match op.query(Key::SystemCmd(proto::SystemCmd::Create), Some(&pc)).await {
            Ok(m) => Some(m),
            Err(e) if e.to_string().contains("already exists") => {
                // Once started (its head reported).
                op.query::<MissionView>(Key::SystemMission("p".into()), None::<&()>).await.ok().filter(|m| m.manager.chain_epoch > 0)
            }
            Err(e) => {
                println!("create p: {e}");
                None
            }
        }
    })
    .await?;
    let (epoch, chain_epoch) = (m.manager.epoch, m.manager.chain_epoch);
    // (A progress wait: under a loaded CI machine the robots of a secure fleet take longer to reach
    // the first sync point; 20 s was missed once with a release build running beside the tests.)
    eventually("the patrol past a barrier", Duration::from_secs(60), || async {
        let m: MissionView = op.query(Key::SystemMission("p".into()), None::<&()>).await.ok()?;
        (m.metrics.sync_points_passed >= 1).then_some(())
    })
    .await?;

    // 1. Strangers cannot open a session, with central or with a robot.
    let ca = pki.join("ca.crt");
    assert!(cannot_open(&ep, &ca, None).await, "a client without a certificate reached central");
    assert!(cannot_open(&tls_ep, &ca, None).await, "a client without a certificate reached central over TLS");
    assert!(cannot_open(&eps[0], &ca, None).await, "a client without a certificate reached r1");
    let plain = tls_ep.replacen("tls/", "tcp/", 1);
    assert!(Client::connect(std::slice::from_ref(&plain), Duration::from_millis(500)).await.is_err(), "plain TCP reached central");
    let other = dir.path("other-pki");
    mrmm_net::security::pki::init(&other)?;
    mrmm_net::security::pki::issue(&other, proto::Role::Operator, "op", &[], 2)?;
    for target in [&ep, &tls_ep, &eps[0]] {
        assert!(
            cannot_open(target, &other.join("ca.crt"), Some((&other.join("op.crt"), &other.join("op.key")))).await,
            "an operator of another CA reached {target}"
        );
    }
    // The same way in with this fleet's operator certificate works (the check can fail).
    for target in [&ep, &tls_ep] {
        assert!(!cannot_open(target, &ca, Some((&pki.join("op.crt"), &pki.join("op.key")))).await, "the fleet's own operator was refused at {target}");
    }

    // 2. A rogue with a valid robot certificate (r9, in no mission).
    let mut links = eps.clone();
    links.insert(0, ep.clone());
    let rogue = common::secure_node(&pki, "r9", links).await?;
    let any = |_: &proto::Sender| true;
    let t = Duration::from_secs(2);
    // a. Operator commands: dropped by central's access control (no answer).
    let mv = json!({"robot": "r1", "to": null}).to_string().into_bytes();
    let term = json!({"name": "p"}).to_string().into_bytes();
    let create = serde_json::to_vec(&MissionCreate { name: "evil".into(), recipe: "patrol".into(), count: Some(1), ..Default::default() })?;
    for (cmd, body) in [(proto::SystemCmd::Move, mv), (proto::SystemCmd::Terminate, term), (proto::SystemCmd::Create, create)] {
        let r = rogue.query::<serde_json::Value>(&Key::SystemCmd(cmd).to_string(), Some(body), t, any).await;
        assert!(r.is_err(), "a robot certificate commanded the fleet ({cmd:?}): {r:?}");
    }
    // b. A plan with a huge epoch for r1: refused by r1 (r9 is not a manager of p).
    let mut bogus = proto::PlanAssignment {
        handover: None,
        mission: "p".into(),
        epoch: u64::MAX,
        team: "p".into(),
        subteam: "p/ground".into(),
        members: vec!["r1".into(), "r9".into()],
        plan: proto::RobotPlan {
            robot: "r1".into(),
            robot_type: "ground".into(),
            slot: 0,
            steps: vec![proto::Step::Hold { seconds: None }],
            team: String::new(),
        },
        managers: vec!["r9".into()],
        barrier: proto::BarrierMode::Mesh,
        scopes: vec![],
        map: None,
    };
    let r = rogue
        .query::<serde_json::Value>(&Key::RobotCmd("r1".into()).to_string(), Some(serde_json::to_vec(&RobotCommand::Plan(Box::new(bogus.clone())))?), t, any)
        .await;
    assert!(r.as_ref().is_err_and(|e| e.to_string().contains("refused")), "r1 took a rogue's plan: {r:?}");
    bogus.mission = "q".into();
    let r = rogue
        .query::<serde_json::Value>(&Key::RobotCmd("r4".into()).to_string(), Some(serde_json::to_vec(&RobotCommand::Plan(Box::new(bogus)))?), t, any)
        .await;
    assert!(r.is_err(), "idle r4 took a rogue's plan while central is up: {r:?}");
    let goto = serde_json::to_vec(&RobotCommand::Goto { x: 99.0, y: 99.0, via: vec![], map: None })?;
    assert!(rogue.query::<serde_json::Value>(&Key::RobotCmd("r2".into()).to_string(), Some(goto), t, any).await.is_err(), "r2 obeyed a robot's goto");
    // c. Forged telemetry and arrivals of r2.
    let forged = proto::Telemetry {
        id: "r2".into(),
        seq: u64::MAX,
        t: 0.0,
        pose: proto::Pose { x: 1000.0, y: 1000.0, theta: 0.0 },
        velocity: proto::Velocity::default(),
        behaviour: proto::Behaviour::Hold,
        mission: None,
        progress: None,
        admitted: vec![],
        stuck: None,
        info_rev: 0,
        battery: None,
        vehicle: None,
    };
    rogue.put(&Key::RobotTelemetry("r2".into()).to_string(), proto::encode_telemetry(&forged)?, Encoding::APPLICATION_OCTET_STREAM).await;
    rogue.session().put(Key::RobotTelemetry("r2".into()).to_string(), proto::encode_telemetry(&forged)?).await.map_err(|e| anyhow::anyhow!("{e}"))?;
    let arrival = SyncArrival { robot: "r2".into(), epoch, point: 99, round: 99 };
    rogue.publish_json(&Key::TeamSync { team: "p".into(), point: 99, round: 99 }.to_string(), &arrival).await;
    // d. Chain forgeries for p, to every robot's host: an end, a huge promise, a vote.
    let forgeries = [
        ("r9", Msg::End { epoch: u64::MAX }),
        ("central", Msg::Stale { promised: u64::MAX, last: (u64::MAX, u64::MAX) }),
        (
            "r9",
            Msg::Vote {
                proposal: Config { epoch: u64::MAX - 1, chain: vec!["r9".into(), "r1".into(), "r2".into()] },
                base: vec!["r9".into(), "r1".into()],
                last: (u64::MAX, u64::MAX),
            },
        ),
    ];
    for id in ["r1", "r2", "r3", "central"] {
        for (from, msg) in &forgeries {
            let env = ChainEnvelope { mission: "p".into(), from: (*from).into(), msg: msg.clone() };
            rogue.publish_json(&Key::HostChain(id.into()).to_string(), &env).await;
        }
    }
    // e. A fake planner service, answering at once with a plan that moves nobody.
    let fake = rogue.session().declare_queryable(Key::Planner("patrol".into()).to_string()).await.map_err(|e| anyhow::anyhow!("{e}"))?;
    let _fake_token = rogue
        .session()
        .liveliness()
        .declare_token(Key::PlannerAlive { kind: "patrol".into(), zid: "fake".into() }.to_string())
        .await
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let fake_mesh = rogue.clone();
    let answered = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let count = answered.clone();
    let faker = tokio::spawn(async move {
        while let Ok(q) = fake.recv_async().await {
            let Ok(mut req) = proto::from_json::<PlanRequest>("plan request", &mrmm_net::net::query_payload(&q)) else { continue };
            req.params.insert("max_kicks".into(), "0".into());
            if let Ok(mut plan) = mrmm_core::mission::planning::plan(mrmm_planner::recipe::PlannerKind::Patrol, &req) {
                plan.plans.clear();
                fake_mesh.reply_json(&q, &plan).await;
                count.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
            }
        }
    });
    // The operator creates a patrol with r4; the real planner takes a while (many kicks), the
    // fake answers first.
    let q = MissionCreate {
        name: "q".into(),
        recipe: "patrol".into(),
        robots: Some(vec!["r4".into()]),
        // 60 waypoints and many kicks: the real planner takes a second or so.
        params: [
            (
                "waypoints".to_string(),
                json!((0..60).map(|i| [f64::from(i % 10) * 3.0 + f64::from(i / 10) * 0.37, f64::from(i / 10) * 4.0]).collect::<Vec<_>>()),
            ),
            ("max_kicks".to_string(), json!(300000)),
        ]
        .into(),
        ..Default::default()
    };
    let started = Instant::now();
    let qv: MissionView = op.query(Key::SystemCmd(proto::SystemCmd::Create), Some(&q)).await?;
    let qv: MissionView = op.query(Key::SystemMission(qv.name.clone()), None::<&()>).await?;
    let plans = qv.plans.clone().unwrap_or_default();
    assert!(plans.len() == 1 && plans[0].steps.iter().any(|s| matches!(s, proto::Step::Navigate { .. })), "mission q runs the fake planner's plan: {plans:?}");
    let fakes = answered.load(std::sync::atomic::Ordering::SeqCst);
    println!("mission q planned by the real planner in {:?} while a fake answered {fakes} time(s) first", started.elapsed());
    assert!(fakes >= 1, "the fake planner never answered: the test proves nothing");
    assert!(log(&dir, "central").contains("may not answer"), "central did not log refusing the fake planner");

    // The fleet goes on: p keeps its manager, epochs and members, and passes more barriers.
    let before: MissionView = op.query(Key::SystemMission("p".into()), None::<&()>).await?;
    let m = eventually("p passing two more barriers after the attacks", Duration::from_secs(30), || async {
        let m: MissionView = op.query(Key::SystemMission("p".into()), None::<&()>).await.ok()?;
        (m.metrics.sync_points_passed >= before.metrics.sync_points_passed + 2).then_some(m)
    })
    .await?;
    // The attacks leave p's manager, members and epochs as they were. A member's liveliness
    // flapping under CI load is a legitimate reason for a replan (lost, then back: two epochs);
    // the journal says whether that happened, and the forgeries' epochs (u64::MAX) stay out.
    let flaps: Vec<String> = common::journal(&op)
        .await?
        .into_iter()
        .filter_map(|e| match e.event {
            proto::JournalEvent::RobotLost { robot } if ["r1", "r2", "r3"].contains(&robot.as_str()) => Some(robot.to_string()),
            _ => None,
        })
        .collect();
    let explained = |now: u64, then: u64| now == then || (!flaps.is_empty() && now > then && now - then <= 2 * flaps.len() as u64);
    anyhow::ensure!(
        m.manager.node == "central" && m.robots.len() == 3 && explained(m.manager.epoch, epoch) && explained(m.manager.chain_epoch, chain_epoch),
        "the attacks changed p: {:?} robots {:?} (was epoch {epoch}, chain epoch {chain_epoch}; members lost meanwhile: {flaps:?})",
        m.manager,
        m.robots
    );
    if !flaps.is_empty() {
        println!("p's members flapped under load ({flaps:?}): epoch {epoch} -> {}", m.manager.epoch);
    }
    // r2's real telemetry still counts (the forged seq = u64::MAX did not pin it), far from the
    // forged pose.
    let r2 = |v: Vec<RobotView>| v.into_iter().find(|r| r.id == "r2").and_then(|r| r.pose);
    let p1 = r2(op.query(Key::SystemRobots, None::<&()>).await?).ok_or_else(|| anyhow::anyhow!("no pose of r2"))?;
    anyhow::ensure!(p1.x.abs() < 100.0, "central took the forged telemetry: {p1:?}");
    eventually("r2's pose to change", Duration::from_secs(10), || async {
        let p2 = r2(op.query(Key::SystemRobots, None::<&()>).await.ok()?)?;
        ((p2.x - p1.x).abs() + (p2.y - p1.y).abs() > 1e-6).then_some(())
    })
    .await?;
    // The refusals show: in central's status, and in the robots' logs.
    let status: SystemStatus = op.query(Key::SystemStatus, None::<&()>).await?;
    println!("central refused: {:?}", status.refused);
    assert!(status.refused.values().sum::<u64>() >= 3, "central counted the refusals: {:?}", status.refused);
    // The fleet's own messages reach central mostly tagged (robots' telemetry, once they heard
    // central), some signed.
    println!("central took: {:?}", status.proven);
    let proven = |k: &str| status.proven.get(k).copied().unwrap_or(0);
    assert!(proven("tag") > 0 && proven("signature") > 0, "central proves by tags and signatures: {:?}", status.proven);
    for id in ["r1", "r2"] {
        assert!(log(&dir, id).contains("refused"), "{id} logs no refusal:\n{}", log(&dir, id));
    }
    faker.abort();

    // 3. The operator's certificate can do everything the API offers.
    let _: serde_json::Value = op.query(Key::SystemCmd(proto::SystemCmd::Move), Some(&json!({"robot": "r4", "to": null}))).await?;
    let _: serde_json::Value = op.query(Key::SystemCmd(proto::SystemCmd::Goto), Some(&json!({"robot": "r4", "x": 3.0, "y": -6.0}))).await?;
    let _: serde_json::Value = op.query(Key::SystemCmd(proto::SystemCmd::Terminate), Some(&json!({"name": "q"}))).await?;
    let _: proto::Marginal = op.query(proto::keys::marginal_selector("p", 1), None::<&()>).await?;
    let _: Vec<proto::Advice> = op.query(Key::AgentAdvice, None::<&()>).await?;
    op.close().await;
    rogue.close().await;
    Ok(())
}

/// A site router (`mrmm router`) in a secure fleet, over QUIC: it needs a
/// router certificate of the fleet's CA (a robot's is refused at start-up); a robot
/// that knows only the router joins the fleet through it; an operator tool linked to the router
/// reads the fleet, but cannot command it there — operator authority is checked by central on
/// its own links, and the router's link is not an operator's.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_site_router_carries_the_fleet_but_no_commands() -> anyhow::Result<()> {
    use mrmm_net::security::pki;
    let dir = Scratch::new("security-router");
    let pki_dir = fleet_pki(&dir, 1)?;
    pki::issue(&pki_dir, proto::Role::Router, "site-b", &[], 2)?;
    // Central's one QUIC endpoint serves the operator and the router's uplink.
    let (_central, ep) = start_secure_central(&dir, &pki_dir)?;
    let cfg = dir.path("router.json5");
    std::fs::write(&cfg, format!(r#"{{ id: "site-b", listen: ["quic/127.0.0.1:0"], connect: ["{ep}"] }}"#))?;
    let (cfg_s, pki_s) = (cfg.display().to_string(), pki_dir.display().to_string());
    // A robot's certificate is not a router's.
    let out = std::process::Command::new(common::EXE).args(["router", "--config", &cfg_s, "--pki", &pki_s, "--as", "r1"]).output()?;
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("names robot:r1 but this node is router:site-b"), "router with a robot certificate: {err}");
    let router = common::start("router", &["router", "--config", &cfg_s, "--pki", &pki_s], &dir.path("router.log"), "router ready", Duration::from_secs(20))?;
    let rep = router
        .field("listening")
        .and_then(|l| l.split(',').next().map(str::to_string))
        .ok_or_else(|| anyhow::anyhow!("router: {:?}", router.field("listening")))?;
    // A stranger cannot link to the router.
    assert!(cannot_open(&rep, &pki_dir.join("ca.crt"), None).await, "a client without a certificate reached the router");
    let _r1 = start_secure_robot(&dir, &pki_dir, "r1", &rep, 2.0)?;
    let op = Client::connect_with(std::slice::from_ref(&ep), Some(SecuritySection::from_dir(&pki_dir, "op")), Duration::from_secs(5)).await?;
    common::wait_robots(&op, 1).await?;
    // The operator's certificate, linked to the router only: reads pass, commands do not.
    let via_router = Client::connect_with(std::slice::from_ref(&rep), Some(SecuritySection::from_dir(&pki_dir, "op")), Duration::from_secs(5)).await?;
    let robots: Vec<RobotView> = via_router.query(Key::SystemRobots, None::<&()>).await?;
    assert_eq!(robots.len(), 1, "the fleet read through the router");
    let mut pc = common::square_patrol(1, None);
    pc.name = "through-router".into();
    let r = via_router.query::<MissionView>(Key::SystemCmd(proto::SystemCmd::Create), Some(&pc)).await;
    assert!(r.is_err(), "a command through a site router was obeyed: {r:?}");
    // The same command linked to central works (the check can fail).
    let m: MissionView = op.query(Key::SystemCmd(proto::SystemCmd::Create), Some(&pc)).await?;
    assert_eq!(m.robots, ["r1"]);
    Ok(())
}
