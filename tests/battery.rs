//! Batteries with real processes: a robot whose config gives it a battery reports its charge
//! and reach to central (the robots' view, `mrmm op robots`); sent further than its charge
//! takes it, it stops where the battery runs out, says why, and the agent raises it as
//! critical; a robot without a battery shows none.

mod common;

use std::time::Duration;

use common::{eventually, Scratch};
use mrmm_net::client::Client;
use mrmm_proto::{self as proto, GotoRequest, Priority, RobotView};

/// Central with a state dir of its own in the scratch dir, and these arguments; its endpoint.
fn start_central(dir: &Scratch, args: &[&str]) -> anyhow::Result<(common::Proc, String)> {
    let state = dir.path("central-state").display().to_string();
    let mut argv = vec!["central", "--state-dir", &state];
    argv.extend_from_slice(args);
    let central = common::start("central", &argv, &dir.path("central.log"), "central ready", Duration::from_secs(20))?;
    let ep = central
        .field("listening")
        .and_then(|l| l.split(',').next().map(str::to_string))
        .ok_or_else(|| anyhow::anyhow!("no endpoint in {:?}", central.ready))?;
    Ok((central, ep))
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_robot_runs_its_battery_down_and_the_fleet_sees_it() -> anyhow::Result<()> {
    let dir = Scratch::new("battery");
    let (_central, ep) = start_central(&dir, &["--listen", "tcp/127.0.0.1:0"])?;
    // r1: half a battery that drives 40 simulated seconds at 1 m/s when full — about 20 m less
    // what standing still draws; r2: no battery.
    let cfg = common::robot_config(&dir, "r1", std::slice::from_ref(&ep), 0.0, 0.0, 5.0)?;
    let text = std::fs::read_to_string(&cfg)?.replacen("time_scale:", "battery: { life_s: 40, charge: 0.5 }, time_scale:", 1);
    std::fs::write(&cfg, text)?;
    let cfg = cfg.display().to_string();
    let _r1 = common::start("r1", &["robot", "--config", &cfg], &dir.path("r1.log"), "robot ready", Duration::from_secs(20))?;
    let _r2 = common::start_robot(&dir, "r2", &ep, 0.0, 5.0)?;
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(2)).await?;
    let live = client.session().declare_subscriber(proto::Key::AgentAdviceLive.to_string()).await.map_err(|e| anyhow::anyhow!("{e}"))?;
    let views = common::wait_robots(&client, 2).await?;
    let b = views[0].battery.ok_or_else(|| anyhow::anyhow!("r1 shows no battery: {:?}", views[0]))?;
    // It drains standing still too (a fifth of its power): a little less than half by now.
    assert!(b.charge <= 0.5 && b.charge > 0.2 && !b.charging, "{b:?}");
    let reach = b.reach_m.ok_or_else(|| anyhow::anyhow!("no reach: {b:?}"))?;
    assert!((reach - b.charge * 40.0).abs() < 0.01, "a full charge drives 40 s at 1 m/s: {reach} m at {b:?}");
    assert!(views[1].battery.is_none(), "r2 has no battery: {:?}", views[1]);

    // Sent 60 m away, r1 gets as far as its charge takes it and stops there.
    let _: serde_json::Value =
        client.query(proto::Key::SystemCmd(proto::SystemCmd::Goto), Some(&GotoRequest { robot: "r1".into(), x: 60.0, y: 0.0, map: None })).await?;
    let advice = common::wait_raised(&live, "battery/r1/empty", Duration::from_secs(30)).await?;
    assert_eq!(advice.priority, Priority::Critical, "{advice:?}");
    let r1 = eventually("r1 stopped, out of charge", Duration::from_secs(10), || async {
        let v: RobotView = client.query(proto::Key::SystemRobot("r1".into()), None::<&()>).await.ok()?;
        (v.stuck.as_deref() == Some("its battery is empty")).then_some(v)
    })
    .await?;
    let x = r1.pose.map_or(f64::NAN, |p| p.x);
    assert!(x > reach / 2.0 && x < reach + 0.5, "r1 stopped at x = {x}, its reach was {reach} m");
    assert_eq!(r1.battery.map(|b| b.charge), Some(0.0));
    assert!(r1.behaviour.as_deref().is_some_and(|b| b.contains("goto(60.0")), "its goal is kept: {r1:?}");

    // The terminal's fleet table, through the real binary.
    let out = std::process::Command::new(common::EXE).args(["op", "--connect", &ep, "robots"]).output()?;
    anyhow::ensure!(out.status.success(), "mrmm op robots: {}", String::from_utf8_lossy(&out.stderr));
    let table = String::from_utf8_lossy(&out.stdout);
    let row = |id: &str| table.lines().find(|l| l.starts_with(&format!("{id} "))).unwrap_or_default().to_string();
    assert!(table.lines().next().is_some_and(|h| h.contains("BATTERY")), "{table}");
    assert!(row("r1").contains(" 0% 0 m "), "{table}");
    assert!(row("r2").contains(" - "), "{table}");
    client.close().await;
    Ok(())
}

/// Chargers: Open-RMF's office graph brings its own two (`is_charger`); central's config adds a
/// vertex of it by name and a free point of the building's grid; the operator sees them all in
/// `mrmm/system/maps` and `mrmm op maps`. A charger in a wall stops central with one line.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn chargers_come_from_the_map_and_from_centrals_config() -> anyhow::Result<()> {
    let dir = Scratch::new("chargers");
    let data = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("maps/data");
    let (office, building) = (data.join("open_rmf/office.nav_graph.yaml"), data.join("building/building.yaml"));
    let config = |chargers: &str| -> anyhow::Result<String> {
        let path = dir.path("central.json5");
        let text =
            format!("{{ maps: {{ office: {:?}, building: {:?} }}, chargers: {chargers} }}", office.display().to_string(), building.display().to_string());
        std::fs::write(&path, text)?;
        Ok(path.display().to_string())
    };
    let state = dir.path("central-state").display().to_string();
    let cfg = config(r#"{ office: ["patrol_D2"], building: [[-16, 0]] }"#)?;
    let (central, ep) = start_central(&dir, &["--config", &cfg, "--listen", "tcp/127.0.0.1:0"])?;
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(2)).await?;
    let maps: Vec<proto::MapInfo> = client.query(proto::Key::SystemMaps, None::<&()>).await?;
    let chargers = |name: &str| maps.iter().find(|m| m.name == name).map(|m| m.chargers.clone()).unwrap_or_default();
    let names: Vec<String> = chargers("office").into_iter().map(|c| c.name).collect();
    assert_eq!(names, ["tinyRobot1_charger", "tinyRobot2_charger", "patrol_D2"]);
    assert_eq!(chargers("building"), [proto::map::Charger { name: "charger-1".into(), at: proto::geom::Point { x: -16.0, y: 0.0 } }]);
    let out = std::process::Command::new(common::EXE).args(["op", "--connect", &ep, "maps"]).output()?;
    let table = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success() && table.lines().next().is_some_and(|h| h.contains("CHARGERS")), "{table}");
    assert!(table.lines().any(|l| l.starts_with("office ") && l.contains(" 3 ")), "{table}");
    client.close().await;
    drop(central);

    // A charger in a wall: central does not start, and says why in one line.
    let cfg = config(r#"{ building: [[-16, 0], [500, 500]] }"#)?;
    let out = std::process::Command::new(common::EXE).args(["central", "--config", &cfg, "--listen", "tcp/127.0.0.1:0", "--state-dir", &state]).output()?;
    let err = String::from_utf8_lossy(&out.stderr);
    let said: Vec<&str> = err.lines().filter(|l| l.starts_with("mrmm: ")).collect();
    assert!(!out.status.success() && said.len() == 1 && said[0].contains("chargers.building[1]: (500, 500) is not free space"), "{err}");
    Ok(())
}

/// Central (its state in the scratch dir) on Open-RMF's office graph, robots r1 (21 %; a full
/// charge drives 300 s), r2 and r3 (full; `others_life_s`) at vertices far from the chargers,
/// time scale 5, and a patrol of r1 and r2.
async fn patrol_with_a_low_robot(dir: &Scratch, others_life_s: u32) -> anyhow::Result<Patrol> {
    let office = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("maps/data/open_rmf/office.nav_graph.yaml");
    let graph = mrmm_maps::rmf::parse("office", &std::fs::read_to_string(&office)?)?;
    let map = format!("office={}", office.display());
    let (central, ep) = start_central(dir, &["--listen", "tcp/127.0.0.1:0", "--map", &map])?;
    // Three vertices far from the chargers; a full charge drives 300 s, r1 starts at 21 %.
    let chargers: Vec<mrmm_maps::Point> = graph.chargers().map(|v| v.at).collect();
    let starts: Vec<mrmm_maps::Point> =
        graph.vertices.iter().map(|v| v.at).filter(|p| chargers.iter().all(|c| c.dist(*p) > 5.0)).fold(Vec::new(), |mut picked, p| {
            if picked.iter().all(|q: &mrmm_maps::Point| q.dist(p) >= 2.0) {
                picked.push(p);
            }
            picked
        });
    let mut robots = Vec::new();
    for (i, (id, charge)) in [("r1", 0.21), ("r2", 1.0), ("r3", 1.0)].into_iter().enumerate() {
        let cfg = common::robot_config(dir, id, std::slice::from_ref(&ep), starts[i].x, starts[i].y, 5.0)?;
        let life = if id == "r1" { 300 } else { others_life_s };
        let text = std::fs::read_to_string(&cfg)?.replacen("time_scale:", &format!("battery: {{ life_s: {life}, charge: {charge} }}, time_scale:"), 1);
        std::fs::write(&cfg, text)?;
        let cfg = cfg.display().to_string();
        robots.push(common::start(id, &["robot", "--config", &cfg], &dir.path(&format!("{id}.log")), "robot ready", Duration::from_secs(20))?);
    }
    // Creating a patrol of every vertex plans it first: more than a default query's 2 s at times.
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(10)).await?;
    common::wait_robots(&client, 3).await?;
    let patrol = proto::MissionCreate {
        name: "p".into(),
        recipe: "patrol".into(),
        robots: Some(vec!["r1".into(), "r2".into()]),
        params: [("waypoints".to_string(), serde_json::json!("all"))].into(),
        map: Some("office".into()),
        ..Default::default()
    };
    let _: proto::MissionView = client.query(proto::Key::SystemCmd(proto::SystemCmd::Create), Some(&patrol)).await?;
    Ok(Patrol { central, ep, map, _robots: robots, client, chargers })
}

/// Robot `id` as central sees it, if it answers.
async fn robot_view(client: &Client, id: &str) -> Option<RobotView> {
    client.query::<RobotView>(proto::Key::SystemRobot(id.into()), None::<&()>).await.ok()
}

/// What [`patrol_with_a_low_robot`] started.
struct Patrol {
    central: common::Proc,
    ep: String,
    /// Central's `--map` argument.
    map: String,
    _robots: Vec<common::Proc>,
    client: Client,
    chargers: Vec<mrmm_maps::Point>,
}

/// The charging policy with real processes on Open-RMF's office graph: r1 of a patrol of two
/// runs low; central takes it out for the nearest charger the graph marks, moves the idle r3 in
/// (the patrol keeps its two robots), plugs r1 in on arrival and lets it go when charged.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_low_robot_charges_at_a_charger_while_a_spare_takes_its_place() -> anyhow::Result<()> {
    let dir = Scratch::new("charging");
    let Patrol { central: _central, ep, map: _, _robots, client, chargers } = patrol_with_a_low_robot(&dir, 300).await?;
    let robot = |id: &'static str| {
        let client = &client;
        async move { client.query::<RobotView>(proto::Key::SystemRobot(id.into()), None::<&()>).await.ok() }
    };
    // r1 falls below 20 %: out of the patrol, r3 in its place.
    eventually("r3 in the patrol in r1's place", Duration::from_secs(60), || async {
        let m: proto::MissionView = client.query(proto::Key::SystemMission("p".into()), None::<&()>).await.ok()?;
        (m.robots.iter().any(|r| r == "r3") && !m.robots.iter().any(|r| r == "r1")).then_some(())
    })
    .await?;
    // r1 at a charger, charging.
    let plugged = eventually("r1 charging at a charger", Duration::from_secs(90), || async {
        let v = robot("r1").await?;
        v.battery.filter(|b| b.charging).and(v.pose)
    })
    .await?;
    let at = mrmm_maps::Point::new(plugged.x, plugged.y);
    assert!(chargers.iter().any(|c| c.dist(at) <= 0.35), "r1 charges at ({}, {}), chargers at {chargers:?}", at.x, at.y);
    // Charged: unplugged, in the pool (the patrol has its two robots).
    let done = eventually("r1 charged and unplugged", Duration::from_secs(90), || async {
        let v = robot("r1").await?;
        v.battery.filter(|b| !b.charging && b.charge >= 0.98).map(|_| v)
    })
    .await?;
    assert!(done.mission.is_none(), "{done:?}");
    let m: proto::MissionView = client.query(proto::Key::SystemMission("p".into()), None::<&()>).await?;
    assert_eq!(m.robots.len(), 2, "the patrol kept its count: {:?}", m.robots);

    // The operator sends r2 (full) to charge, then releases it, through the terminal.
    let op = |args: &[&str]| std::process::Command::new(common::EXE).args(["op", "--connect", &ep]).args(args).output();
    let out = op(&["charge", "r2"])?;
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success() && said.starts_with("r2: to charger ") && said.contains("of map office"), "{said}{}", String::from_utf8_lossy(&out.stderr));
    eventually("r2 out of the patrol", Duration::from_secs(20), || async { robot("r2").await.filter(|v| v.mission.is_none()).map(|_| ()) }).await?;
    let out = op(&["release", "r2"])?;
    assert!(out.status.success() && String::from_utf8_lossy(&out.stdout).contains("r2: released"), "{out:?}");
    let out = op(&["release", "r2"])?;
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("on no charging errand"), "{out:?}");
    client.close().await;
    Ok(())
}

/// The same errand with central SIGKILLed while r1 drives to its charger and started again on
/// its journal: r1 is plugged in at the charger, let go when charged and drives back to where
/// it was sent from, as the journal's `robot_errand` entry says (a central that only found it
/// charging there would not know where that is, and left it on the charger), and the patrol
/// keeps its two robots.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_charging_errand_goes_on_after_central_is_killed() -> anyhow::Result<()> {
    let dir = Scratch::new("charging-kill");
    // r2 and r3 do not run low meanwhile (a robot just charged is the first spare sent to
    // relieve one: it would not drive back).
    let Patrol { mut central, ep, map, _robots, client, chargers } = patrol_with_a_low_robot(&dir, 3000).await?;
    // Out of the patrol, on its way; the journal says where it was sent from.
    eventually("r1 out of the patrol, on its way to a charger", Duration::from_secs(60), || async {
        robot_view(&client, "r1").await.filter(|v| v.mission.is_none()).map(|_| ())
    })
    .await?;
    let journal = common::journal(&client).await?;
    let from = journal.iter().rev().find_map(|e| match &e.event {
        proto::JournalEvent::RobotErrand { robot, errand: Some(errand) } if robot == "r1" => errand.from,
        _ => None,
    });
    let Some((fx, fy)) = from else { anyhow::bail!("no errand of r1's in the journal: {journal:?}") };
    client.close().await;
    central.kill();
    let state = dir.path("central-state").display().to_string();
    let args = ["central", "--state-dir", &state, "--listen", &ep, "--map", &map];
    let _central = common::start("central", &args, &dir.path("central2.log"), "central ready", Duration::from_secs(20))?;
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(10)).await?;
    let plugged = eventually("r1 charging at a charger", Duration::from_secs(90), || async {
        let v = robot_view(&client, "r1").await?;
        v.battery.filter(|b| b.charging).and(v.pose)
    })
    .await?;
    let at = mrmm_maps::Point::new(plugged.x, plugged.y);
    assert!(chargers.iter().any(|c| c.dist(at) <= 0.35), "r1 charges at ({}, {}), chargers at {chargers:?}", at.x, at.y);
    eventually("r1 charged and unplugged", Duration::from_secs(90), || async {
        robot_view(&client, "r1").await?.battery.filter(|b| !b.charging && b.charge >= 0.95).map(|_| ())
    })
    .await?;
    // (Its battery drains on the way: a full one drives 60 s of this test's time.)
    let back = match eventually("r1 back where it was sent from", Duration::from_secs(90), || async {
        let v = robot_view(&client, "r1").await?;
        let p = v.pose?;
        // On the office's lanes a goal between vertices is reached at the vertex nearest it
        // (lanes cut into segments of at most 3 m).
        ((p.x - fx).hypot(p.y - fy) <= 1.6 && v.battery.is_some_and(|b| !b.charging)).then_some(v)
    })
    .await
    {
        Ok(v) => v,
        Err(e) => anyhow::bail!("{e}: r1 now {:?}, sent from ({fx:.2}, {fy:.2})", robot_view(&client, "r1").await),
    };
    assert!(back.mission.is_none(), "{back:?}");
    let m: proto::MissionView = client.query(proto::Key::SystemMission("p".into()), None::<&()>).await?;
    assert_eq!(m.robots.len(), 2, "the patrol kept its count: {:?}", m.robots);
    client.close().await;
    Ok(())
}

/// A mission's `charging` parameter, through central: with `ask`, a low robot of it stays at
/// work and the agent suggests the order that sends it; the operator turns it to `auto` with
/// `mrmm op mission update` and the policy sends the robot.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_mission_that_charges_on_the_operators_word_keeps_its_low_robot_until_told() -> anyhow::Result<()> {
    let dir = Scratch::new("charging-ask");
    let office = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("maps/data/open_rmf/office.nav_graph.yaml");
    let graph = mrmm_maps::rmf::parse("office", &std::fs::read_to_string(&office)?)?;
    let map = format!("office={}", office.display());
    let (_central, ep) = start_central(&dir, &["--listen", "tcp/127.0.0.1:0", "--map", &map])?;
    // r1 at 25 % on a vertex of the graph, a full charge driving 120 s: standing (a fifth of the
    // power) it stays above 20 % for 30 simulated seconds, patrolling it falls below in 6 (idle
    // and low, the policy would send it before it is in the mission).
    let at = graph.vertices.iter().find(|v| !v.charger).map(|v| v.at).ok_or_else(|| anyhow::anyhow!("no vertex"))?;
    let cfg = common::robot_config(&dir, "r1", std::slice::from_ref(&ep), at.x, at.y, 2.0)?;
    let text = std::fs::read_to_string(&cfg)?.replacen("time_scale:", "battery: { life_s: 120, charge: 0.25 }, time_scale:", 1);
    std::fs::write(&cfg, text)?;
    let cfg = cfg.display().to_string();
    let _r1 = common::start("r1", &["robot", "--config", &cfg], &dir.path("r1.log"), "robot ready", Duration::from_secs(20))?;
    // Creating a patrol of every vertex plans it first: more than a default query's 2 s at times.
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(10)).await?;
    let live = client.session().declare_subscriber(proto::Key::AgentAdviceLive.to_string()).await.map_err(|e| anyhow::anyhow!("{e}"))?;
    common::wait_robots(&client, 1).await?;
    let patrol = proto::MissionCreate {
        name: "p".into(),
        recipe: "patrol".into(),
        robots: Some(vec!["r1".into()]),
        params: [("waypoints".to_string(), serde_json::json!("all")), ("charging".to_string(), serde_json::json!("ask"))].into(),
        map: Some("office".into()),
        ..Default::default()
    };
    let _: proto::MissionView = client.query(proto::Key::SystemCmd(proto::SystemCmd::Create), Some(&patrol)).await?;
    // The agent and the policy look at the same fleet at the same moment: raised, not sent.
    let advice = common::wait_raised(&live, "battery/r1/low", Duration::from_secs(20)).await?;
    assert_eq!(advice.suggestion.as_deref(), Some("mrmm op charge r1"), "{advice:?}");
    assert!(advice.reason.contains("on the operator's word"), "{advice:?}");
    let m: proto::MissionView = client.query(proto::Key::SystemMission("p".into()), None::<&()>).await?;
    assert_eq!(m.robots, ["r1"], "r1 stays at work");
    let out = std::process::Command::new(common::EXE).args(["op", "--connect", &ep, "mission", "update", "p", "--param", "charging=auto"]).output()?;
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    eventually("r1 sent to charge", Duration::from_secs(20), || async {
        let v: RobotView = client.query(proto::Key::SystemRobot("r1".into()), None::<&()>).await.ok()?;
        v.mission.is_none().then_some(())
    })
    .await?;
    client.close().await;
    Ok(())
}

/// Planning by reach with real processes: r1's battery (35 % of a charge that drives 80 s)
/// takes it about 28 m, short of any slot of a patrol of every vertex of the office graph for
/// two (30 m from a slot to the first sync point, turns counted) though above the 20 % threshold. Its manager
/// plans the patrol for r2 alone and holds r1 (the mission's `held`); with `charging: ask` it
/// stays held; turned to `auto`, central sends it to charge before it is low — the idle r3
/// moved in — and it charges at a charger.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_robot_short_of_reach_is_held_out_of_the_plan_and_sent_to_charge() -> anyhow::Result<()> {
    let dir = Scratch::new("reach");
    let office = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("maps/data/open_rmf/office.nav_graph.yaml");
    let graph = mrmm_maps::rmf::parse("office", &std::fs::read_to_string(&office)?)?;
    let chargers: Vec<mrmm_maps::Point> = graph.chargers().map(|v| v.at).collect();
    let map = format!("office={}", office.display());
    let (_central, ep) = start_central(&dir, &["--listen", "tcp/127.0.0.1:0", "--map", &map])?;
    // r1 on the vertex nearest the first charger but not at it (it drives there on its reach);
    // time scale 1: standing, r1 stays above 20 % for 60 s.
    let near =
        graph.vertices.iter().filter(|v| !v.charger && v.at.dist(chargers[0]) > 2.0).min_by(|a, b| a.at.dist(chargers[0]).total_cmp(&b.at.dist(chargers[0])));
    let far = graph.vertices.iter().filter(|v| chargers.iter().all(|c| c.dist(v.at) > 5.0));
    let starts: Vec<mrmm_maps::Point> = near.into_iter().chain(far).map(|v| v.at).collect();
    let mut robots = Vec::new();
    for (i, (id, battery)) in [("r1", "{ life_s: 80, charge: 0.35 }"), ("r2", "{ life_s: 3000 }"), ("r3", "{ life_s: 3000 }")].into_iter().enumerate() {
        let cfg = common::robot_config(&dir, id, std::slice::from_ref(&ep), starts[i * 2].x, starts[i * 2].y, 1.0)?;
        let text = std::fs::read_to_string(&cfg)?.replacen("time_scale:", &format!("battery: {battery}, time_scale:"), 1);
        std::fs::write(&cfg, text)?;
        let cfg = cfg.display().to_string();
        robots.push(common::start(id, &["robot", "--config", &cfg], &dir.path(&format!("{id}.log")), "robot ready", Duration::from_secs(20))?);
    }
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(10)).await?;
    common::wait_robots(&client, 3).await?;
    eventually("central knows r1's reach", Duration::from_secs(10), || async { robot_view(&client, "r1").await?.battery?.reach_m.map(|_| ()) }).await?;
    let patrol = proto::MissionCreate {
        name: "p".into(),
        recipe: "patrol".into(),
        robots: Some(vec!["r1".into(), "r2".into()]),
        params: [("waypoints".to_string(), serde_json::json!("all")), ("charging".to_string(), serde_json::json!("ask"))].into(),
        map: Some("office".into()),
        ..Default::default()
    };
    let _: proto::MissionView = client.query(proto::Key::SystemCmd(proto::SystemCmd::Create), Some(&patrol)).await?;
    let m = eventually("p holds r1 out of its plan", Duration::from_secs(30), || async {
        let m: proto::MissionView = client.query(proto::Key::SystemMission("p".into()), None::<&()>).await.ok()?;
        (m.held == ["r1"]).then_some(m)
    })
    .await?;
    assert_eq!(m.robots, ["r1", "r2"], "held, r1 is still a member");
    let planned: Vec<&str> = m.plans.iter().flatten().map(|p| p.robot.as_str()).collect();
    assert_eq!(planned, ["r2"], "the patrol is r2's alone");
    let b = robot_view(&client, "r1").await.and_then(|v| v.battery).ok_or_else(|| anyhow::anyhow!("r1's battery"))?;
    assert!(b.charge > 0.25 && !b.charging, "{b:?}");
    let out = std::process::Command::new(common::EXE).args(["op", "--connect", &ep, "mission", "update", "p", "--param", "charging=auto"]).output()?;
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    // Sent for its reach, not its charge: out of the patrol while still above 20 %, r3 in.
    let (robots_then, charge) = eventually("r1 out of the patrol and r3 in", Duration::from_secs(20), || async {
        let m: proto::MissionView = client.query(proto::Key::SystemMission("p".into()), None::<&()>).await.ok()?;
        let r1 = robot_view(&client, "r1").await?;
        (r1.mission.is_none() && m.robots.iter().any(|r| r == "r3")).then(|| (m.robots, r1.battery.map_or(0.0, |b| b.charge)))
    })
    .await?;
    assert!(charge > 0.2, "r1 went at {charge}: at the threshold, not for its reach");
    assert!(!robots_then.iter().any(|r| r == "r1"), "{robots_then:?}");
    let at = eventually("r1 charging at a charger", Duration::from_secs(60), || async {
        let v = robot_view(&client, "r1").await?;
        v.battery.filter(|b| b.charging).and(v.pose)
    })
    .await?;
    let at = mrmm_maps::Point::new(at.x, at.y);
    assert!(chargers.iter().any(|c| c.dist(at) <= 0.35), "r1 charges at ({}, {}), chargers at {chargers:?}", at.x, at.y);
    let m: proto::MissionView = client.query(proto::Key::SystemMission("p".into()), None::<&()>).await?;
    assert!(m.held.is_empty(), "r3 has the reach: {:?}", m.held);
    client.close().await;
    Ok(())
}
