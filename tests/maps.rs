//! A fleet in a building: central holds the demo building's map (a Nav2 map), a patrol of four
//! offices and a coverage of the southern rooms plan on it, and every pose the robots report is
//! checked against the map — never in an occupied or unknown cell. Then, with central SIGKILLed,
//! the mission's head is killed too: its replica takes over, replans for the robots left on the
//! map it fetched from the fleet, and the new tour still runs through the doors.

mod common;

use std::collections::BTreeSet;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use common::{eventually, start, Scratch};
use mrmm_maps::{Bundle, Map, OccupancyGrid, Point};
use mrmm_net::client::Client;
use mrmm_net::net::{self, Mode};
use mrmm_proto::{self as proto, MapInfo, MissionCreate, MissionView, PlanSummary, Step};
use serde_json::json;

fn building() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("maps/data/building/building.yaml")
}

fn grid() -> anyhow::Result<(Bundle, OccupancyGrid)> {
    let b = Bundle::collect(&building().to_string_lossy(), |p| std::fs::read(p).map_err(|e| e.to_string())).map_err(|e| anyhow::anyhow!("{e}"))?;
    match b.load().map_err(|e| anyhow::anyhow!("{e}"))?.1 {
        Map::Grid(g) => Ok((b, g)),
        Map::Graph(_) => anyhow::bail!("the building is a grid map"),
    }
}

/// Four offices north of the corridor, one waypoint in each.
fn offices() -> serde_json::Value {
    json!([[-16, 8], [-8, 8], [0, 8], [8, 8]])
}

fn start_central(dir: &Scratch) -> anyhow::Result<(common::Proc, String)> {
    let map = format!("building={}", building().display());
    let p = start("central", &["central", "--listen", "tcp/127.0.0.1:0", "--map", &map], &dir.path("central.log"), "central ready", Duration::from_secs(20))?;
    let ep = p.field("listening").and_then(|l| l.split(',').next().map(str::to_string)).ok_or_else(|| anyhow::anyhow!("no endpoint"))?;
    Ok((p, ep))
}

/// Whether every segment of the closed route is free on the map.
fn free_route(g: &OccupancyGrid, tour: &[proto::geom::Point]) -> bool {
    (0..tour.len()).all(|k| {
        let (a, b) = (tour[k], tour[(k + 1) % tour.len()]);
        g.segment_free(Point::new(a.x, a.y), Point::new(b.x, b.y))
    })
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn robots_on_a_map_never_enter_a_wall() -> anyhow::Result<()> {
    let (bundle, g) = grid()?;
    let dir = Scratch::new("maps");
    let (_central, ep) = start_central(&dir)?;
    let _robots: Vec<_> = [(-16.0, 0.0), (-12.0, 0.5), (-8.0, 0.0), (-4.0, 0.5)]
        .iter()
        .enumerate()
        .map(|(i, &(x, y))| common::start_robot_scaled(&dir, &format!("r{}", i + 1), &ep, x, y, 10.0))
        .collect::<Result<_, _>>()?;
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await?;
    common::wait_robots(&client, 4).await?;
    let maps: Vec<MapInfo> = client.query(proto::Key::SystemMaps, None::<&()>).await?;
    assert_eq!(maps.len(), 1);
    assert_eq!((maps[0].name.as_str(), maps[0].format.as_str(), maps[0].hash.clone()), ("building", "nav2", bundle.hash()));

    // Telemetry from here on, every pose checked.
    let telemetry = client
        .session()
        .declare_subscriber(proto::Pattern::AllTelemetry.to_string())
        .with(zenoh::handlers::RingChannel::new(8192))
        .await
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let patrol = MissionCreate {
        name: "p".into(),
        recipe: "patrol".into(),
        robots: Some(vec!["r1".into(), "r2".into(), "r3".into()]),
        params: [("waypoints".to_string(), offices())].into(),
        map: Some("building".into()),
        ..Default::default()
    };
    let created: MissionView = client.query(proto::Key::SystemCmd(proto::SystemCmd::Create), Some(&patrol)).await?;
    assert_eq!(created.robots.len(), 3);
    let coverage = MissionCreate {
        name: "c".into(),
        recipe: "coverage".into(),
        robots: Some(vec!["r4".into()]),
        params: [("region".to_string(), json!([[-20, -12], [0, -12], [0, -1.5], [-20, -1.5]]))].into(),
        map: Some("building".into()),
        ..Default::default()
    };
    let _: MissionView = client.query(proto::Key::SystemCmd(proto::SystemCmd::Create), Some(&coverage)).await?;
    // An unknown map is refused in words.
    let mut bad = patrol.clone();
    bad.name = "q".into();
    bad.map = Some("nowhere".into());
    let e = client.query::<MissionView>(proto::Key::SystemCmd(proto::SystemCmd::Create), Some(&bad)).await.expect_err("unknown map");
    assert!(e.to_string().contains("no map \"nowhere\" (maps: building)"), "{e}");

    // The tour is planned on the map: it runs through the doors, not through the office walls.
    let view: MissionView = client.query(proto::Key::SystemMission("p".into()), None::<&()>).await?;
    let Some(PlanSummary::Patrol(s)) = &view.summary else { anyhow::bail!("a patrol summary: {:?}", view.summary) };
    assert!(free_route(&g, &s.tour), "the tour crosses a wall: {:?}", s.tour);
    assert_eq!(s.waypoints.len(), 4);
    assert!(s.tour.len() > 4, "corners between the offices: {:?}", s.tour);

    // A round of the patrol, with every pose of every robot in a free cell.
    let rounds_done =
        |m: &MissionView| m.metrics.sync_points_passed >= m.summary.as_ref().and_then(PlanSummary::patrol).map_or(u32::MAX, |p| p.sync_per_round + 1);
    let deadline = Instant::now() + Duration::from_secs(90);
    let (mut poses, mut robots) = (0u64, BTreeSet::new());
    loop {
        while let Ok(Some(sample)) = telemetry.try_recv() {
            let Ok(t) = proto::decode_telemetry(&sample.payload().to_bytes()) else { continue };
            let at = Point::new(t.pose.x, t.pose.y);
            let v = g.at(at);
            assert!(matches!(v, Some(0..=49)), "{} at ({:.2}, {:.2}) is in a cell of occupancy {v:?}", t.id, at.x, at.y);
            poses += 1;
            robots.insert(t.id);
        }
        let m: MissionView = client.query(proto::Key::SystemMission("p".into()), None::<&()>).await?;
        if rounds_done(&m) && poses > 400 {
            println!("a round of the patrol on the map: {poses} poses of {} robots, all in free cells", robots.len());
            break;
        }
        anyhow::ensure!(Instant::now() < deadline, "no round within 90 s ({} barriers, {poses} poses)", m.metrics.sync_points_passed);
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
    assert_eq!(robots.len(), 4);
    // The coverage robot stands in the hall, south of the corridor.
    let r4: proto::RobotView = client.query(proto::Key::SystemRobot("r4".into()), None::<&()>).await?;
    let p = r4.pose.expect("pose");
    assert!(p.y < -1.5 && p.x < 0.0, "r4 covers the hall: {p:?}");
    client.close().await;
    Ok(())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_takeover_with_central_gone_replans_on_the_map() -> anyhow::Result<()> {
    let (_, g) = grid()?;
    let dir = Scratch::new("maps-takeover");
    let (mut central, ep) = start_central(&dir)?;
    let mut robots: Vec<_> = [(-16.0, 0.0), (-12.0, 0.5), (-8.0, 0.0)]
        .iter()
        .enumerate()
        .map(|(i, &(x, y))| common::start_robot_scaled(&dir, &format!("r{}", i + 1), &ep, x, y, 10.0))
        .collect::<Result<_, _>>()?;
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await?;
    common::wait_robots(&client, 3).await?;
    let patrol = MissionCreate {
        name: "p".into(),
        recipe: "patrol".into(),
        robots: Some(vec!["r1".into(), "r2".into(), "r3".into()]),
        host: Some("r1".into()),
        params: [("waypoints".to_string(), offices())].into(),
        map: Some("building".into()),
        ..Default::default()
    };
    let _: MissionView = client.query(proto::Key::SystemCmd(proto::SystemCmd::Create), Some(&patrol)).await?;
    let before = eventually("the patrol past its first barriers, replicated on r2 and r3", Duration::from_secs(30), || async {
        let m: MissionView = client.query(proto::Key::SystemMission("p".into()), None::<&()>).await.ok()?;
        (m.metrics.sync_points_passed >= 2 && m.manager.chain.len() == 3).then_some(m)
    })
    .await?;
    assert_eq!(before.manager.chain[0], "r1");
    let successor = before.manager.chain[1].clone();
    // The replicas hold the map before anything happens to central (they fetch it at once).
    let log = dir.path(&format!("{successor}.log"));
    eventually("the successor holding the map", Duration::from_secs(15), || async {
        std::fs::read_to_string(&log).ok().filter(|l| l.contains("map fetched from the fleet")).map(|_| ())
    })
    .await?;
    client.close().await;

    // An observer attached to the robot that stays a member (neither the head nor the successor).
    let stay = ["r1", "r2", "r3"].iter().position(|r| *r != "r1" && *r != successor).expect("a third robot");
    let observer_at = robots[stay].field("listening").ok_or_else(|| anyhow::anyhow!("no endpoint"))?;
    let observer = net::open(net::zenoh_config(Mode::Peer, &["tcp/127.0.0.1:0".into()], &[observer_at], 1000)?).await?;
    central.kill();
    robots[0].kill();
    let killed = Instant::now();
    let key = proto::Key::MissionView("p".into()).to_string();
    let after = eventually("the successor leading a new epoch planned without r1", Duration::from_secs(40), || async {
        let m: MissionView = net::query(&observer, &key, None, Duration::from_secs(2)).await.ok()?;
        (m.manager.node == successor && m.manager.epoch > before.manager.epoch && m.plans.as_ref().is_some_and(|p| p.len() == 2)).then_some(m)
    })
    .await?;
    println!("central and the head SIGKILLed: {successor} replanned on the map within {:?}", killed.elapsed());
    let Some(PlanSummary::Patrol(s)) = &after.summary else { anyhow::bail!("a patrol summary") };
    assert!(free_route(&g, &s.tour), "the new tour crosses a wall: it was not planned on the map: {:?}", s.tour);
    // Each robot's plan drives only along free segments.
    for plan in after.plans.iter().flatten() {
        let pts: Vec<Point> = plan.steps.iter().filter_map(|s| if let Step::Navigate { x, y, .. } = s { Some(Point::new(*x, *y)) } else { None }).collect();
        assert!(pts.windows(2).all(|w| g.segment_free(w[0], w[1])), "{}: {pts:?}", plan.robot);
    }
    let _ = observer.close().await;
    Ok(())
}

/// `mrmm demo --map` on a grid map: its robots drive lanes traffic derives from the building's
/// free space (the traffic table lists them all on the map), never into a wall and never closer
/// to each other than the clearance (every pose an outside client hears, against the others'
/// last within 0.3 s); the recording (read with Rerun's own decoder) holds the building under
/// the fleet and the layout the viewer opens on.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_demo_on_a_map_records_the_building_and_its_layout() -> anyhow::Result<()> {
    use rerun::external::re_log_encoding::DecoderApp;
    use rerun::log::{Chunk, LogMsg};
    let dir = Scratch::new("maps-rrd");
    let rrd = dir.path("fleet.rrd");
    let map = building().display().to_string();
    let rrd_s = rrd.display().to_string();
    let (mut demo, ep, _) = common::start_demo(
        &dir,
        &[
            "--insecure",
            "--robots",
            "8",
            "--duration",
            "60",
            "--listen",
            "tcp/127.0.0.1:0",
            "--time-scale",
            "5",
            "--no-console",
            "--map",
            &map,
            "--rrd",
            &rrd_s,
        ],
    )?;
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await?;
    let telemetry = client
        .session()
        .declare_subscriber(proto::Pattern::AllTelemetry.to_string())
        .with(zenoh::handlers::RingChannel::new(8192))
        .await
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    eventually("both missions running on the map", Duration::from_secs(40), || async {
        let m: Vec<MissionView> = client.query(proto::Key::SystemMissions, None::<&()>).await.ok()?;
        (m.len() == 2 && m.iter().all(|m| m.map.as_ref().is_some_and(|r| r.name == "demo") && m.manager.epoch >= 1)).then_some(())
    })
    .await?;
    let robots: Vec<proto::RobotView> = client.query(proto::Key::SystemRobots, None::<&()>).await?;
    let (_, g) = grid()?;
    for r in &robots {
        let p = r.pose.expect("pose");
        assert!(g.is_free(Point::new(p.x, p.y)), "{} starts in a free cell: {p:?}", r.id);
    }
    // The demo fleet drives for a while (the viewer bridge meanwhile fetches and draws the map):
    // every pose it reports is in a free cell of the building, none too near another robot.
    let (mut poses, until) = (0u64, Instant::now() + Duration::from_secs(12));
    let mut last: std::collections::BTreeMap<String, (Point, Instant)> = Default::default();
    let mut closest = (f64::INFINITY, String::new());
    while Instant::now() < until {
        match tokio::time::timeout(Duration::from_millis(500), telemetry.recv_async()).await {
            Ok(Ok(s)) => {
                let Ok(t) = proto::decode_telemetry(&s.payload().to_bytes()) else { continue };
                let (p, now) = (Point::new(t.pose.x, t.pose.y), Instant::now());
                let v = g.at(p);
                assert!(matches!(v, Some(0..=49)), "{} at ({:.2}, {:.2}): occupancy {v:?}", t.id, t.pose.x, t.pose.y);
                for (other, (q, at)) in &last {
                    if other.as_str() != t.id.as_str() && now.duration_since(*at) < Duration::from_millis(300) && p.dist(*q) < closest.0 {
                        closest = (p.dist(*q), format!("{} at {p:?}, {other} at {q:?}", t.id));
                    }
                }
                last.insert(t.id.to_string(), (p, now));
                poses += 1;
            }
            _ => continue,
        }
    }
    assert!(closest.0 >= mrmm_core::traffic::CLEARANCE, "robots {:.2} m apart: {}", closest.0, closest.1);
    let traffic: Vec<proto::traffic::TrafficView> = client.query(proto::Key::SystemTraffic, None::<&()>).await?;
    let on_lanes = traffic.first().map_or(0, |v| v.robots.len());
    assert_eq!(on_lanes, 8, "every robot on the building's lanes: {traffic:?}");
    assert!(poses > 100, "{poses} poses checked");
    client.close().await;
    demo.signal("INT")?;
    let status = common::wait_exit(&mut demo, Duration::from_secs(20)).await?;
    assert!(status.success(), "demo exit status {status}");
    let (mut rows, mut blueprint) = (std::collections::BTreeMap::<String, usize>::new(), false);
    for msg in DecoderApp::decode_lazy(std::io::BufReader::new(std::fs::File::open(&rrd)?)) {
        match msg? {
            LogMsg::ArrowMsg(_, arrow) => {
                let chunk = Chunk::from_arrow_msg(&arrow)?;
                *rows.entry(chunk.entity_path().to_string()).or_default() += chunk.num_rows();
            }
            LogMsg::BlueprintActivationCommand(_) => blueprint = true,
            _ => {}
        }
    }
    assert!(rows.get("/fleet/map/demo").copied().unwrap_or(0) > 0, "the map is drawn: {:?}", rows.keys().collect::<Vec<_>>());
    assert!(blueprint, "the recording carries the viewer's layout");
    Ok(())
}

/// Offline: `mrmm plan --map` prints plans whose tour follows the corridors; `mrmm map check`
/// says what a map is, and refuses a broken one in one line.
#[test]
fn plan_and_check_from_the_command_line() -> anyhow::Result<()> {
    let (_, g) = grid()?;
    let dir = Scratch::new("maps-cli");
    let robots = dir.path("robots.json");
    std::fs::write(&robots, r#"[{"id": "a", "type": "ground", "x": -16, "y": 0, "speed": 1}, {"id": "b", "type": "ground", "x": 4, "y": 0, "speed": 1}]"#)?;
    let map = building().display().to_string();
    let out = std::process::Command::new(common::EXE)
        .args(["plan", "patrol", "--robots", &robots.display().to_string(), "--map", &map, "--param", "waypoints=[[-16,8],[-8,8],[0,8],[8,8]]"])
        .output()?;
    anyhow::ensure!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let plan: serde_json::Value = serde_json::from_slice(&out.stdout)?;
    let tour: Vec<proto::geom::Point> = serde_json::from_value(plan["tour"].clone())?;
    assert!(tour.len() > 4 && free_route(&g, &tour), "{tour:?}");
    assert!(plan["length"].as_f64().is_some_and(|l| l > 60.0), "{}", plan["length"]);

    let out = std::process::Command::new(common::EXE).args(["map", "check", &map]).output()?;
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success() && text.contains("nav2 map") && text.contains("420 × 260 cells of 0.1 m"), "{text}");
    let bad = dir.path("bad.yaml");
    std::fs::write(&bad, "image: building.pgm\nresolution: 0.1\norigin: [0, 0]\noccupied_thresh: 0.65\nfree_thresh: 0.2\n")?;
    let out = std::process::Command::new(common::EXE).args(["map", "check", &bad.display().to_string()]).output()?;
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.trim().lines().count() == 1 && err.contains("bad.yaml: field origin: has 2 elements"), "{err}");
    // Central refuses to start with a map it cannot read, in one line.
    let out = std::process::Command::new(common::EXE)
        .args(["central", "--listen", "tcp/127.0.0.1:0", "--state-dir", &dir.path("state").display().to_string(), "--map", &format!("b={}", bad.display())])
        .output()?;
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("map b: ") && err.contains("field origin"), "{err}");
    Ok(())
}

/// Reads an Open-RMF nav graph as its own tools do (ruamel.yaml, networkx for its shape) and
/// checks it: one connected graph of two-way lanes, passing both ways or neither, some passing
/// and some not; prints the level's name, vertices, edges and passing edges.
const STOCK_READER: &str = r#"
import sys, networkx
from ruamel.yaml import YAML
doc = YAML(typ="safe").load(open(sys.argv[1]))
(name, level), = doc["levels"].items()
g = networkx.DiGraph()
for i, (x, y, props) in enumerate(level["vertices"]):
    assert isinstance(x, float) and isinstance(y, float) and props["name"], (i, x, y, props)
    g.add_node(i)
for a, b, props in level["lanes"]:
    assert props in ({}, {"passing": True}), props
    g.add_edge(a, b, passing=props.get("passing", False))
assert all(g.has_edge(b, a) for a, b in g.edges), "a lane one way only"
assert all(g.edges[a, b]["passing"] == g.edges[b, a]["passing"] for a, b in g.edges), "passing one way only"
assert networkx.is_strongly_connected(g), "not connected"
passing = sum(1 for a, b in g.edges if g.edges[a, b]["passing"])
assert 0 < passing < g.number_of_edges(), passing
print(name, g.number_of_nodes(), g.number_of_edges(), passing)
"#;

/// `mrmm map graph` derives lanes from the demo's floor plan and writes an Open-RMF nav graph:
/// `mrmm map check` reads it, and so does a stock YAML reader (ruamel.yaml, with networkx for its
/// shape): one connected graph of two-way lanes, every lane in free space a robot fits, the lanes
/// of the building's wide corridors marked passing both ways (`passing: true`).
#[test]
fn a_grid_maps_lanes_derived_from_the_command_line() -> anyhow::Result<()> {
    let (_, g) = grid()?;
    let dir = Scratch::new("maps-graph");
    let out_file = dir.path("building.nav_graph.yaml");
    let out =
        std::process::Command::new(common::EXE).args(["map", "graph", &building().display().to_string(), "--out", &out_file.display().to_string()]).output()?;
    let text = String::from_utf8_lossy(&out.stdout);
    anyhow::ensure!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(text.contains("junctions") && text.contains("lanes both ways") && text.contains("passing)"), "{text}");
    let out = std::process::Command::new(common::EXE).args(["map", "check", &out_file.display().to_string()]).output()?;
    let check = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success() && check.contains("open_rmf map"), "{check}");
    let b = Bundle::collect(&out_file.display().to_string(), |p| std::fs::read(p).map_err(|e| e.to_string())).map_err(|e| anyhow::anyhow!("{e}"))?;
    let Map::Graph(nav) = b.load().map_err(|e| anyhow::anyhow!("{e}"))?.1 else { anyhow::bail!("not a graph") };
    assert!(nav.edges.iter().any(|e| e.passing) && nav.edges.iter().any(|e| !e.passing), "{:?}", nav.edges);
    for e in &nav.edges {
        let (a, b) = (nav.vertices[e.from as usize].at, nav.vertices[e.to as usize].at);
        assert!(free_route(&g, &[proto::geom::Point { x: a.x, y: a.y }, proto::geom::Point { x: b.x, y: b.y }]), "lane {e:?} leaves free space");
    }
    // A grid map file as input only: a graph is refused in one line.
    let out = std::process::Command::new(common::EXE).args(["map", "graph", &out_file.display().to_string(), "--out", "/dev/null"]).output()?;
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.trim().lines().count() == 1 && err.contains("a navigation graph already"), "{err}");

    let Some(py) = common::standin::python_or_skip()? else { return Ok(()) };
    let script = STOCK_READER;
    let out = std::process::Command::new(py).args(["-c", script, &out_file.display().to_string()]).output()?;
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success() && said.starts_with("L1 "), "{said}{}", String::from_utf8_lossy(&out.stderr));
    Ok(())
}

/// A graph map drawn on a floor plan (patrolling_sim's ctcv, its plan shipped beside it): `mrmm
/// map graph --floor-plan` writes it with lanes passing where the plan has room (a stock reader
/// sees them, both ways); central publishes the graph with its plan, and a node that fetches it
/// from the fleet, as a deputy does, reads the same passing lanes; another map's plan stops
/// central in one line naming a vertex off its free space.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_graph_on_its_floor_plan_passes_where_the_plan_has_room() -> anyhow::Result<()> {
    let data = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("maps/data/patrolling_sim");
    let (graph, plan) = (data.join("ctcv.graph").display().to_string(), data.join("ctcv.yaml").display().to_string());
    let dir = Scratch::new("maps-floor");
    let expect = Bundle::collect_on_plan(&graph, &plan, |p| std::fs::read(p).map_err(|e| e.to_string())).map_err(|e| anyhow::anyhow!("{e}"))?;
    let Map::Graph(expect) = expect.load().map_err(|e| anyhow::anyhow!("{e}"))?.1 else { anyhow::bail!("not a graph") };
    let passing = expect.summary().passing;
    assert!(passing > 0 && passing < expect.lanes().len(), "{passing} of {} lanes passing", expect.lanes().len());

    let out_file = dir.path("ctcv.nav_graph.yaml").display().to_string();
    let out = std::process::Command::new(common::EXE).args(["map", "graph", &graph, "--floor-plan", &plan, "--out", &out_file]).output()?;
    let text = String::from_utf8_lossy(&out.stdout);
    anyhow::ensure!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(text.contains(&format!("({passing} passing)")), "{text}");
    let b = Bundle::collect(&out_file, |p| std::fs::read(p).map_err(|e| e.to_string())).map_err(|e| anyhow::anyhow!("{e}"))?;
    let Map::Graph(written) = b.load().map_err(|e| anyhow::anyhow!("{e}"))?.1 else { anyhow::bail!("not a graph") };
    let lanes = |g: &mrmm_maps::NavGraph| g.edges.iter().map(|e| (e.from, e.to, e.passing)).collect::<Vec<_>>();
    assert_eq!(lanes(&written), lanes(&expect), "the written graph's lanes are the graph's, marked as on its plan");
    let out = std::process::Command::new(common::EXE).args(["map", "check", &graph, "--floor-plan", &plan]).output()?;
    let check = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success() && check.contains(&format!("{passing} passing")), "{check}");

    // Another map's plan: central does not start, and says why in one line.
    let wrong = data.join("1r5.yaml").display().to_string();
    let state = dir.path("refused").display().to_string();
    let out = std::process::Command::new(common::EXE)
        .args(["central", "--listen", "tcp/127.0.0.1:0", "--state-dir", &state, "--map", &format!("c={graph}"), "--floor-plan", &format!("c={wrong}")])
        .output()?;
    let err = String::from_utf8_lossy(&out.stderr);
    let said = err.trim().lines().filter(|l| l.starts_with("mrmm: ")).collect::<Vec<_>>();
    assert!(
        !out.status.success() && said.len() == 1 && said[0].contains("map c: ctcv.graph: vertex") && said[0].contains("is not in free space of its floor plan"),
        "{err}"
    );

    let args = ["central", "--listen", "tcp/127.0.0.1:0", "--map", &format!("ctcv={graph}"), "--floor-plan", &format!("ctcv={plan}")];
    let central = start("central", &args, &dir.path("central.log"), "central ready", Duration::from_secs(20))?;
    let ep = central.field("listening").and_then(|l| l.split(',').next().map(str::to_string)).ok_or_else(|| anyhow::anyhow!("no endpoint"))?;
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await?;
    let maps: Vec<MapInfo> = client.query(proto::Key::SystemMaps, None::<&()>).await?;
    let info = maps.iter().find(|m| m.name == "ctcv").ok_or_else(|| anyhow::anyhow!("ctcv not published: {maps:?}"))?;
    assert!(info.size.ends_with(&format!(", {passing} passing")), "{}", info.size);
    let fetched = mrmm_manager::maps::MapStore::with_budget(64 << 20).fetch(client.mesh(), &info.map_ref()).await.map_err(|e| anyhow::anyhow!("{e}"))?;
    assert_eq!(fetched.map.graph(), Some(&expect), "a node fetching the map reads the lanes central lays out");
    client.close().await;

    let Some(py) = common::standin::python_or_skip()? else { return Ok(()) };
    let out = std::process::Command::new(py).args(["-c", STOCK_READER, &out_file]).output()?;
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success() && said.starts_with("L1 ") && said.trim().ends_with(&format!(" {}", 2 * passing)),
        "{said}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    Ok(())
}
