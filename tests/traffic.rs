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
    println!("patrol-1's robots waited {:.0} s for traffic", p.metrics.traffic_wait_s);
    client.close().await;
    // The operator's view of traffic: every robot on the office graph, with its route.
    let op = |args: &[&str]| std::process::Command::new(common::EXE).args(["op", "--connect", &ep]).args(args).output();
    let out = op(&["--json", "traffic"])?;
    anyhow::ensure!(out.status.success(), "mrmm op traffic: {}", String::from_utf8_lossy(&out.stderr));
    let views: Vec<proto::traffic::TrafficView> = serde_json::from_slice(&out.stdout)?;
    anyhow::ensure!(views.len() == 1 && views[0].robots.len() == 8, "traffic as the operator sees it: {views:?}");
    anyhow::ensure!(views[0].robots.iter().all(|r| !r.holds.is_empty()) && views[0].deputies.len() == 2, "{views:?}");
    // One map, named by the start of its hash.
    let table = op(&["traffic", &views[0].map[..8]])?;
    let text = String::from_utf8_lossy(&table.stdout);
    println!("{text}");
    anyhow::ensure!(
        text.starts_with("map ") && text.lines().filter(|l| l.starts_with('r') && l[1..].starts_with(|c: char| c.is_ascii_digit())).count() == 8,
        "mrmm op traffic: {text}{}",
        String::from_utf8_lossy(&table.stderr)
    );
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

/// A patrol of r1–r3 and a coverage of r4–r6 on the office graph.
async fn two_missions(client: &Client) -> anyhow::Result<()> {
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
    Ok(())
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
    two_missions(&client).await?;
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

/// Central SIGKILLed for good while robots of two missions of a secure fleet drive on the office
/// graph: the robot its traffic authority named first deputy takes over (orders of a new
/// incarnation, sealed by a robot, which the others check and obey), and robots of both missions
/// drive on — never closer than the clearance, as a peer linked to the robots themselves sees
/// their telemetry (central and its API are gone).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn central_killed_for_good_a_deputy_robot_takes_traffic_over() -> anyhow::Result<()> {
    let dir = Scratch::new("traffic-deputy");
    let pki = common::fleet_pki(&dir, 6)?;
    let (map, state, pki_arg) = (format!("office={}", office().display()), dir.path("central-state").display().to_string(), pki.display().to_string());
    let args = ["central", "--listen", "quic/127.0.0.1:0", "--pki", &pki_arg, "--operator", "op", "--map", &map, "--state-dir", &state];
    let mut central = start("central", &args, &dir.path("central.log"), "central ready", Duration::from_secs(20))?;
    let ep = central.field("listening").and_then(|l| l.split(',').next().map(str::to_string)).ok_or_else(|| anyhow::anyhow!("no endpoint"))?;
    let robots: Vec<common::Proc> = starts(6)?
        .iter()
        .enumerate()
        .map(|(i, &at)| common::start_secure_robot_at(&dir, &pki, &format!("r{}", i + 1), &ep, at, 1.0))
        .collect::<Result<_, _>>()?;
    let operator = Some(proto::SecuritySection::from_dir(&pki, "op"));
    let client = Client::connect_with(std::slice::from_ref(&ep), operator, Duration::from_secs(5)).await?;
    common::wait_robots(&client, 6).await?;
    two_missions(&client).await?;
    client.close().await;

    // A peer linked to central and to every robot's own endpoint: their telemetry and the orders
    // on the map (central's while it lives, then a deputy's).
    let mut endpoints: Vec<String> = robots.iter().filter_map(|r| r.field("listening").and_then(|l| l.split(',').next().map(str::to_string))).collect();
    endpoints.push(ep.clone());
    let observer = common::secure_node(&pki, "op", endpoints).await?;
    let observer = observer.session().clone();
    let ring = || zenoh::handlers::RingChannel::new(8192);
    let z = |e: zenoh::Error| anyhow::anyhow!("{e}");
    let telemetry = observer.declare_subscriber(proto::Pattern::AllTelemetry.to_string()).with(ring()).await.map_err(z)?;
    let orders = observer.declare_subscriber(proto::Pattern::AllTrafficOrders.to_string()).with(ring()).await.map_err(z)?;
    // Central's orders name the deputies (its incarnation is the one to be taken over from); they
    // have followed long enough to take over once orders naming them came for a few seconds.
    let named = std::cell::Cell::new(None::<Instant>);
    let (central_incarnation, deputies) = eventually("central's orders naming deputies for a while", Duration::from_secs(40), || async {
        while let Ok(Some(s)) = orders.try_recv() {
            if let Ok(proto::TrafficOrder::Route { incarnation, deputies, .. }) = serde_json::from_slice(&s.payload().to_bytes()) {
                if deputies.len() == proto::traffic::DEPUTIES {
                    let since = named.get().unwrap_or_else(Instant::now);
                    named.set(Some(since));
                    if since.elapsed().as_secs_f64() > mrmm_core::traffic::deputy::FOLLOW_S + 1.0 {
                        return Some((incarnation, deputies));
                    }
                }
            }
        }
        None
    })
    .await?;
    println!("central's traffic incarnation {central_incarnation}, deputies {deputies:?}");

    central.kill();
    let killed = Instant::now();
    let mut took_over = None;
    let mut last: std::collections::BTreeMap<String, (f64, f64)> = Default::default();
    let mut moved: std::collections::BTreeMap<String, f64> = Default::default();
    let mut closest = (f64::INFINITY, String::new());
    while killed.elapsed() < Duration::from_secs(25) {
        while let Ok(Some(s)) = orders.try_recv() {
            if let Ok(proto::TrafficOrder::Route { incarnation, .. }) = serde_json::from_slice(&s.payload().to_bytes()) {
                if incarnation > central_incarnation && took_over.is_none() {
                    took_over = Some((killed.elapsed(), incarnation));
                }
            }
        }
        // Every robot's latest pose, compared pairwise.
        let mut fresh = false;
        while let Ok(Some(s)) = telemetry.try_recv() {
            let Ok(t) = proto::decode_telemetry(&s.payload().to_bytes()) else { continue };
            let p = (t.pose.x, t.pose.y);
            if let Some(q) = last.insert(t.id.to_string(), p) {
                if took_over.is_some() {
                    *moved.entry(t.id.to_string()).or_default() += (p.0 - q.0).hypot(p.1 - q.1);
                }
            }
            fresh = true;
        }
        if fresh {
            let all: Vec<(&String, &(f64, f64))> = last.iter().collect();
            for (i, (a, pa)) in all.iter().enumerate() {
                for (b, pb) in &all[i + 1..] {
                    let d = (pa.0 - pb.0).hypot(pa.1 - pb.1);
                    if d < closest.0 {
                        closest = (d, format!("{a} and {b}"));
                    }
                }
            }
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    let _ = observer.close().await;
    let (after, incarnation) = took_over.ok_or_else(|| anyhow::anyhow!("no deputy gave an order after central died"))?;
    println!(
        "a deputy's orders (incarnation {incarnation}) came {:.2} s after central's kill; closest {:.2} m ({}); moved since {moved:?}",
        after.as_secs_f64(),
        closest.0,
        closest.1
    );
    anyhow::ensure!(closest.0 >= CLEARANCE - SAMPLING, "{} came {:.2} m apart (clearance {CLEARANCE} m)", closest.1, closest.0);
    let went_on = |team: &[&str]| team.iter().any(|r| moved.get(*r).is_some_and(|d| *d >= 1.0));
    anyhow::ensure!(went_on(&["r1", "r2", "r3"]) && went_on(&["r4", "r5", "r6"]), "robots of both missions did not drive on under the deputy: {moved:?}");
    Ok(())
}
