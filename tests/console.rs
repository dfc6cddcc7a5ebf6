//! The browser console against a real secure fleet (central and four robots over mutual TLS),
//! driven in Debian's Chromium by Playwright as an operator would: robots box-selected and
//! clicked on the map, a patrol drawn and created, a robot assigned, one released, the advising
//! agent's suggestion applied — checked through the operator API. And what the console refuses:
//! requests without its token, or that name it by another host (DNS rebinding), or commands it
//! does not forward.
//!
//! Needs Chromium (`/usr/bin/chromium`) and `playwright-core` (`tests/browser/package.json`),
//! both installed by `.ci/run`; without them the test is skipped, except under `CI=true`.

mod common;

use std::path::PathBuf;
use std::time::Duration;

use anyhow::{anyhow, Context};
use common::Scratch;
use mrmm_net::client::Client;
use mrmm_proto::{self as proto, MissionView, RobotStatus, RobotView, SecuritySection};

/// Where `playwright-core` is: `MRMM_NODE_MODULES`, else `.ci/run`'s install.
fn node_modules() -> PathBuf {
    std::env::var_os("MRMM_NODE_MODULES")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(std::env::var_os("HOME").unwrap_or_default()).join(".cache/mrmm/node/node_modules"))
}

/// The browser and its driver, or why they are missing.
fn browser() -> Result<PathBuf, String> {
    let chromium = PathBuf::from(std::env::var_os("MRMM_CHROMIUM").unwrap_or_else(|| "/usr/bin/chromium".into()));
    if !chromium.exists() {
        return Err(format!("no Chromium at {}", chromium.display()));
    }
    if std::process::Command::new("node").arg("--version").output().is_err() {
        return Err("no node on PATH".into());
    }
    let modules = node_modules();
    if !modules.join("playwright-core").exists() {
        return Err(format!("no playwright-core in {}", modules.display()));
    }
    Ok(chromium)
}

/// Chromium and the driver, or `None` to skip (outside CI only: CI must run the browser tests).
fn browser_or_skip() -> anyhow::Result<Option<PathBuf>> {
    match browser() {
        Ok(c) => Ok(Some(c)),
        Err(why) if std::env::var("CI").as_deref() != Ok("true") => {
            eprintln!("skipped: {why} (`bash .ci/run` installs them)");
            Ok(None)
        }
        Err(why) => anyhow::bail!("{why}: .ci/run installs Chromium and playwright-core"),
    }
}

/// The URL (with its token) a console printed.
fn console_url(console: &common::Proc) -> anyhow::Result<String> {
    Ok(console.ready.split_whitespace().find(|w| w.starts_with("http://")).ok_or_else(|| anyhow!("no URL in {:?}", console.ready))?.to_string())
}

/// Runs `tests/browser/<script>.cjs` with `args` in Chromium, within `limit`: the JSON line it
/// printed last.
async fn run_browser(chromium: &std::path::Path, script: &str, args: &[&str], limit: Duration) -> anyhow::Result<serde_json::Value> {
    let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(format!("tests/browser/{script}.cjs"));
    let out = tokio::process::Command::new("node")
        .arg(&script)
        .args(args)
        .env("NODE_PATH", node_modules())
        .env("MRMM_CHROMIUM", chromium)
        .kill_on_drop(true)
        .output();
    let out = tokio::time::timeout(limit, out).await.with_context(|| format!("the browser run took over {} s", limit.as_secs()))??;
    let stdout = String::from_utf8_lossy(&out.stdout);
    anyhow::ensure!(out.status.success(), "browser run failed: {}\n{stdout}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_str(stdout.lines().last().unwrap_or_default()).with_context(|| format!("browser output {stdout:?}"))
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_operator_selects_robots_on_the_map_and_assigns_them_in_a_real_browser() -> anyhow::Result<()> {
    let Some(chromium) = browser_or_skip()? else { return Ok(()) };
    let dir = Scratch::new("console");
    let pki = common::fleet_pki(&dir, 4)?;
    let (_central, ep) = common::start_secure_central(&dir, &pki)?;
    let mut robots = Vec::new();
    for i in 1..=4 {
        robots.push(common::start_secure_robot(&dir, &pki, &format!("r{i}"), &ep, i as f64 * 2.0)?);
    }
    let pki_s = pki.display().to_string();
    let console = common::start(
        "console",
        &["console", "--listen", "127.0.0.1:0", "--connect", &ep, "--pki", &pki_s, "--as", "op"],
        &dir.path("console.log"),
        "mrmm console: http://",
        Duration::from_secs(20),
    )?;
    let url = console_url(&console)?;
    let (base, token) = url.split_once("/#token=").ok_or_else(|| anyhow!("no token in {url}"))?;
    let addr = base.trim_start_matches("http://").to_string();

    // What the console refuses, before the browser comes.
    let (code, _) = common::http(&addr, "GET", "/api/state", &addr, None, "")?;
    assert_eq!(code, 401, "the fleet's state without the token");
    let (code, _) = common::http(&addr, "GET", "/api/state", &addr, Some("0123456789abcdef0123456789abcdef"), "")?;
    assert_eq!(code, 401, "a wrong token");
    let (code, _) = common::http(&addr, "GET", "/api/state", "fleet.evil.example", Some(token), "")?;
    assert_eq!(code, 403, "a request naming the console by another host (DNS rebinding)");
    let (code, _) = common::http(&addr, "POST", "/api/cmd/system/shutdown", &addr, Some(token), "{}")?;
    assert_eq!(code, 404, "a command the operator API does not have");
    let (code, body) = common::http(&addr, "POST", "/api/cmd/mission/create", &addr, Some(token), "{not json")?;
    assert_eq!(code, 400, "{body}");
    let (code, body) =
        common::http(&addr, "POST", "/api/assign", &addr, Some(token), &format!(r#"{{"robots": [{}], "to": null}}"#, vec!["\"r1\""; 1001].join(",")))?;
    assert_eq!(code, 400, "too many robots in one assignment: {body}");
    let (code, body) = common::http(&addr, "GET", "/", &addr, None, "")?;
    assert!(code == 200 && body.contains("/console.js"), "the page is served without the token: {code}");

    // The operator, in Chromium.
    let shot = dir.path("console.png");
    let seen = run_browser(&chromium, "console", &[&url, &shot.display().to_string()], Duration::from_secs(150)).await?;
    assert_eq!(seen["address_without_token"], true, "{seen}");
    assert_eq!(seen["points"], "4 points", "{seen}");
    assert_eq!(seen["tour_drawn"], true, "the patrol's tour is on the map: {seen}");
    assert_eq!(seen["edit_points"], "3 points", "a click on a robot while drawing is a point: {seen}");
    assert_eq!(seen["edited"], serde_json::json!({"tour": 3, "robots": 3}), "p edited on the map, its members kept: {seen}");
    assert!(seen["goto"].as_str().is_some_and(|b| b.starts_with("goto(")), "r4 sent to a point: {seen}");
    assert_eq!((seen["caps_offered"].as_str(), seen["caps_cell"].as_str()), (Some(""), Some("camera, thermal")), "{seen}");
    assert_eq!(seen["caps_message"], "r4: camera, thermal", "{seen}");
    assert!(seen["refused"].as_str().is_some_and(|m| m.contains("exists")), "a second mission p is refused in words: {seen}");
    assert!(std::fs::metadata(&shot).map(|m| m.len() > 10_000).unwrap_or(false), "no screenshot");

    // What central says, independently of the console.
    let operator = SecuritySection::from_dir(&pki, "op");
    let client = Client::connect_with(std::slice::from_ref(&ep), Some(operator), Duration::from_secs(3)).await?;
    let missions: Vec<MissionView> = client.query(proto::Key::SystemMissions, None::<&()>).await?;
    let p = missions.iter().find(|m| m.name == "p").ok_or_else(|| anyhow!("no mission p: {missions:?}"))?;
    // r1 released, then added back by the agent's suggestion (the first idle robot).
    assert_eq!(seen["advice"], serde_json::json!({"robot": "r1", "to": "p"}), "{seen}");
    assert_eq!((p.robots.clone(), p.status), (vec!["r1".into(), "r2".into(), "r3".into()], proto::MissionStatus::Running));
    let fleet: Vec<RobotView> = client.query(proto::Key::SystemRobots, None::<&()>).await?;
    let robot = |id: &str| fleet.iter().find(|r| r.id == id).map(|r| (r.status, r.mission.clone()));
    assert_eq!(robot("r1"), Some((RobotStatus::Busy, Some("p".into()))));
    // r4, in no mission, on the goto the operator clicked (busy on its way, or idle there once it
    // arrived: the browser's last steps may outlast the drive), with the capabilities it was given.
    let r4 = fleet.iter().find(|r| r.id == "r4").ok_or_else(|| anyhow!("no r4: {fleet:?}"))?;
    let there = r4.pose.as_ref().is_some_and(|p| (p.x + 4.0).hypot(p.y + 6.0) < 0.5);
    assert!(r4.mission.is_none() && (r4.status == RobotStatus::Busy || (r4.status == RobotStatus::Idle && there)), "{r4:?}");
    assert_eq!(fleet.iter().find(|r| r.id == "r4").map(|r| r.capabilities.clone()), Some(vec!["camera".to_string(), "thermal".to_string()]));
    client.close().await;
    Ok(())
}

/// The console draws central's map under the fleet: the demo building's walls dark and its
/// corridor light where the page puts them, and the map offered in the Create dialog.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_console_draws_the_building_under_the_fleet() -> anyhow::Result<()> {
    let Some(chromium) = browser_or_skip()? else { return Ok(()) };
    let dir = Scratch::new("console-map");
    let map = format!("building={}", PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("maps/data/building/building.yaml").display());
    let central = common::start(
        "central",
        &["central", "--listen", "tcp/127.0.0.1:0", "--map", &map],
        &dir.path("central.log"),
        "central ready",
        Duration::from_secs(20),
    )?;
    let ep = central.field("listening").and_then(|l| l.split(',').next().map(str::to_string)).ok_or_else(|| anyhow!("no endpoint"))?;
    let _robot = common::start_robot(&dir, "r1", &ep, -10.0, 0.0)?;
    let console = common::start(
        "console",
        &["console", "--listen", "127.0.0.1:0", "--connect", &ep],
        &dir.path("console.log"),
        "mrmm console: http://",
        Duration::from_secs(20),
    )?;
    let url = console_url(&console)?;
    let shot = dir.path("map.png");
    let seen = run_browser(&chromium, "map", &[&url, &shot.display().to_string()], Duration::from_secs(90)).await?;
    assert_eq!(seen["maps"], serde_json::json!(["building"]), "{seen}");
    assert!(seen["wall"].as_f64().is_some_and(|v| v < 120.0), "an office wall is dark: {seen}");
    assert!(seen["corridor"].as_f64().is_some_and(|v| v > 200.0), "the corridor is light: {seen}");
    assert_eq!(seen["options"], serde_json::json!(["", "building"]), "the map is offered for a new mission: {seen}");
    Ok(())
}

/// Traffic in the console: robots of a patrol on Open-RMF's office graph, the lanes each holds
/// drawn in its colour and listed in the Traffic table; a robot killed is listed lost, and its
/// "Take off lanes" button frees what it held (central's traffic authority no longer lists it).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_console_shows_lanes_held_and_takes_a_lost_robot_off_them() -> anyhow::Result<()> {
    let Some(chromium) = browser_or_skip()? else { return Ok(()) };
    let dir = Scratch::new("console-traffic");
    let office = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("maps/data/open_rmf/office.nav_graph.yaml");
    let central = common::start(
        "central",
        &["central", "--listen", "tcp/127.0.0.1:0", "--state-dir", &dir.path("state").display().to_string(), "--map", &format!("office={}", office.display())],
        &dir.path("central.log"),
        "central ready",
        Duration::from_secs(20),
    )?;
    let ep = central.field("listening").and_then(|l| l.split(',').next().map(str::to_string)).ok_or_else(|| anyhow!("no endpoint"))?;
    // Three robots on vertices of the graph 2 m or more apart.
    let g = mrmm_maps::rmf::parse("office", &std::fs::read_to_string(&office)?)?;
    let mut at: Vec<mrmm_maps::Point> = Vec::new();
    for v in &g.vertices {
        if at.len() < 3 && at.iter().all(|p| p.dist(v.at) >= 2.0) {
            at.push(v.at);
        }
    }
    let mut robots: Vec<common::Proc> =
        at.iter().enumerate().map(|(i, p)| common::start_robot(&dir, &format!("r{}", i + 1), &ep, p.x, p.y)).collect::<Result<_, _>>()?;
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await?;
    common::wait_robots(&client, 3).await?;
    let m = proto::MissionCreate {
        name: "p".into(),
        recipe: "patrol".into(),
        robots: Some(["r1", "r2", "r3"].iter().map(|r| (*r).into()).collect()),
        params: [("waypoints".to_string(), serde_json::json!("all"))].into(),
        map: Some("office".into()),
        ..Default::default()
    };
    let _: MissionView = client.query(proto::Key::SystemCmd(proto::SystemCmd::Create), Some(&m)).await?;
    let in_traffic = |v: &[proto::traffic::TrafficView], id: &str| v.iter().any(|t| t.robots.iter().any(|r| r.robot.as_str() == id));
    common::eventually("the three robots in traffic", Duration::from_secs(30), || async {
        let v: Vec<proto::traffic::TrafficView> = client.query(proto::Key::SystemTraffic, None::<&()>).await.ok()?;
        ["r1", "r2", "r3"].iter().all(|id| in_traffic(&v, id)).then_some(())
    })
    .await?;
    robots[2].kill();
    let console = common::start(
        "console",
        &["console", "--listen", "127.0.0.1:0", "--connect", &ep],
        &dir.path("console.log"),
        "mrmm console: http://",
        Duration::from_secs(20),
    )?;
    let url = console_url(&console)?;
    let shot = dir.path("traffic.png");
    let seen = run_browser(&chromium, "traffic", &[&url, &shot.display().to_string(), "r3"], Duration::from_secs(150)).await?;
    assert_eq!(seen["lost_state"], "lost", "{seen}");
    assert!(seen["message"].as_str().is_some_and(|m| m.contains("taken off the lanes")), "{seen}");
    assert!(seen["rows"].as_array().is_some_and(|r| r.len() == 3), "{seen}");
    assert!(seen["rows_after"].as_array().is_some_and(|r| !r.iter().any(|x| x == "r3")), "{seen}");
    let v: Vec<proto::traffic::TrafficView> = client.query(proto::Key::SystemTraffic, None::<&()>).await?;
    assert!(!in_traffic(&v, "r3") && in_traffic(&v, "r1"), "central's traffic: {v:?}");
    // A robot that is there is not taken off: central refuses, the console says why.
    let err = client
        .query::<serde_json::Value>(proto::Key::SystemCmd(proto::SystemCmd::ClearTraffic), Some(&proto::traffic::TrafficClear { robot: "r1".into() }))
        .await;
    assert!(err.as_ref().is_err_and(|e| e.to_string().contains("not lost")), "{err:?}");
    // The same from the command line: one line, and a failing status.
    let out = std::process::Command::new(common::EXE).args(["op", "--connect", &ep, "traffic", "--clear", "r2"]).output()?;
    let said = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && said.contains("robot r2 is not lost") && said.trim().lines().count() == 1, "{said}");
    Ok(())
}
