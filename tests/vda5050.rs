//! VDA 5050 vehicles in the fleet, against vehicles nobody here wrote: vda-5050-lib's virtual
//! AGVs (Siemens, MIT; `tests/vda5050/agvs.js`, run by node) on a real mosquitto broker, through
//! `mrmm vda5050`. `.ci/run` installs node, mosquitto and the npm package.
//!
//! One mission on Open-RMF's office graph with two mrmm robots and two virtual AGVs: every vehicle
//! registers as a robot, the AGVs accept every order and update (no error in their state) and
//! their `lastNodeId` goes along the map's vertices as their plans drive them; the mission paused
//! and resumed, they pause (`startPause`) and go on (`stopPause`); their process
//! killed, the broker's last will drops them from the fleet and the mission replans without them.
//! Besides: `mrmm vda5050-sim`'s vehicles on their embedded broker, and the gateway on mosquitto's
//! TLS listener.

mod common;

use std::collections::HashMap;
use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use anyhow::{bail, Context};
use common::{eventually, start, Scratch};
use mrmm_net::client::Client;
use mrmm_proto::{self as proto, MissionCreate, MissionView, RobotView};
use serde_json::{json, Value};

/// A child process that is not mrmm, killed when dropped.
struct Other(Child);

impl Drop for Other {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn office() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("maps/data/open_rmf/office.nav_graph.yaml")
}

/// Starts mosquitto on a free loopback port (its own config: loopback only, no persistence).
fn mosquitto(dir: &Scratch) -> anyhow::Result<(Other, u16)> {
    let port = common::standin::free_port()?;
    let broker = mosquitto_with(dir, &format!("listener {port} 127.0.0.1\nallow_anonymous true\npersistence false\n"), &[port])?;
    Ok((broker, port))
}

/// Starts mosquitto with config `conf` and waits until it listens on every port of `ports`.
fn mosquitto_with(dir: &Scratch, conf: &str, ports: &[u16]) -> anyhow::Result<Other> {
    let path = dir.path("mosquitto.conf");
    std::fs::write(&path, conf)?;
    let log = std::fs::File::create(dir.path("mosquitto.log"))?;
    let child = Other(Command::new("mosquitto").arg("-c").arg(&path).stdout(Stdio::null()).stderr(log).spawn().context("cannot start mosquitto")?);
    let up = Instant::now();
    for &port in ports {
        while std::net::TcpStream::connect(("127.0.0.1", port)).is_err() {
            anyhow::ensure!(up.elapsed() < Duration::from_secs(10), "mosquitto not listening on {port} after 10 s");
            std::thread::sleep(Duration::from_millis(50));
        }
    }
    Ok(child)
}

/// A CA of its own (`<name>-ca.pem`) and, signed by it, a certificate for a broker on 127.0.0.1
/// (`<name>-broker.pem`, `.key`) and one for a client (`<name>-gateway.pem`, `.key`): ECDSA
/// P-256, PEM, as mosquitto (OpenSSL) and the gateway (rustls) both read them.
fn test_pki(dir: &Scratch, name: &str) -> anyhow::Result<()> {
    use rcgen::{BasicConstraints, CertificateParams, DnType, ExtendedKeyUsagePurpose, IsCa, Issuer, KeyPair, KeyUsagePurpose, SanType};
    let ca_key = KeyPair::generate()?;
    let mut ca = CertificateParams::new(Vec::<String>::new())?;
    ca.is_ca = IsCa::Ca(BasicConstraints::Unconstrained);
    ca.key_usages = vec![KeyUsagePurpose::KeyCertSign, KeyUsagePurpose::CrlSign];
    ca.distinguished_name.push(DnType::CommonName, format!("{name} test CA"));
    std::fs::write(dir.path(&format!("{name}-ca.pem")), ca.self_signed(&ca_key)?.pem())?;
    let issuer = Issuer::new(ca, ca_key);
    for (who, usage) in [("broker", ExtendedKeyUsagePurpose::ServerAuth), ("gateway", ExtendedKeyUsagePurpose::ClientAuth)] {
        let key = KeyPair::generate()?;
        let mut params = CertificateParams::new(if who == "broker" { vec!["localhost".to_string()] } else { vec![] })?;
        if who == "broker" {
            params.subject_alt_names.push(SanType::IpAddress("127.0.0.1".parse()?));
        }
        params.extended_key_usages = vec![usage];
        params.distinguished_name.push(DnType::CommonName, format!("{name} {who}"));
        std::fs::write(dir.path(&format!("{name}-{who}.pem")), params.signed_by(&key, &issuer)?.pem())?;
        std::fs::write(dir.path(&format!("{name}-{who}.key")), key.serialize_pem())?;
    }
    Ok(())
}

/// Starts the virtual AGVs (`serial:x:y:node` each); their state changes come as JSON lines.
fn agvs(dir: &Scratch, modules: &std::path::Path, port: u16, specs: &[String]) -> anyhow::Result<(Other, mpsc::Receiver<Value>)> {
    let here = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/vda5050");
    let log = std::fs::File::create(dir.path("agvs.log"))?;
    let mut child = Command::new("node")
        .current_dir(&here)
        .env("NODE_PATH", modules)
        .arg("agvs.js")
        .args([&port.to_string(), "office", "acme"])
        .args(specs)
        .stdout(Stdio::piped())
        .stderr(log)
        .spawn()
        .context("cannot start node")?;
    let out = child.stdout.take().context("no stdout")?;
    let (tx, rx) = mpsc::channel();
    let (ready_tx, ready_rx) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(out).lines().map_while(Result::ok) {
            if line == "agvs ready" {
                let _ = ready_tx.send(());
            } else if let Ok(v) = serde_json::from_str::<Value>(&line) {
                let _ = tx.send(v);
            }
        }
    });
    let agvs = Other(child);
    if ready_rx.recv_timeout(Duration::from_secs(20)).is_err() {
        bail!("virtual AGVs not ready in 20 s: {}", std::fs::read_to_string(dir.path("agvs.log")).unwrap_or_default());
    }
    Ok((agvs, rx))
}

/// The gateway's config and its vehicles' robot config.
fn gateway_config(dir: &Scratch, port: u16, central: &str) -> anyhow::Result<String> {
    std::fs::write(
        dir.path("agv.json5"),
        format!(
            r#"{{ id: "agv", type: "ground", capabilities: ["camera"], kinematics: {{ max_speed: 1.0, max_turn_rate: 2.0 }}, telemetry_hz: 10,
                 zenoh: {{ listen: ["tcp/127.0.0.1:0"], connect: ["{central}"], lease_ms: 1000 }} }}"#
        ),
    )?;
    let path = dir.path("gateway.json5");
    std::fs::write(&path, format!(r#"{{ broker: "mqtt://127.0.0.1:{port}", map: "office", robot: "agv.json5" }}"#))?;
    Ok(path.display().to_string())
}

/// Publishes what no vehicle should: malformed JSON, a state over the size limit, a battery of
/// 250 %, a state of a vehicle that does not say where it is, names MQTT or the standard do not
/// allow, a master control's topic.
async fn hostile(port: u16) -> anyhow::Result<()> {
    let mut opts = rumqttc::MqttOptions::new("hostile", "127.0.0.1", port);
    opts.set_max_packet_size(1 << 20, 1 << 20);
    let (client, mut events) = rumqttc::AsyncClient::new(opts, 16);
    let big = format!(r#"{{"driving": false, "pad": "{}"}}"#, "x".repeat(300 * 1024));
    let messages: [(&str, Vec<u8>); 6] = [
        ("uagv/v2/acme/agv1/state", b"{not json".to_vec()),
        ("uagv/v2/acme/agv1/state", big.into_bytes()),
        ("uagv/v2/acme/agv2/state", br#"{"batteryState": {"batteryCharge": 250, "charging": false}}"#.to_vec()),
        ("uagv/v2/acme/ghost/state", br#"{"driving": false}"#.to_vec()),
        ("uagv/v2/ac%me/x/state", br#"{"driving": false}"#.to_vec()),
        ("uagv/v2/acme/ghost/order", br#"{"orderId": "forged"}"#.to_vec()),
    ];
    for (topic, payload) in messages {
        client.publish(topic, rumqttc::QoS::AtLeastOnce, false, payload).await?;
    }
    // Until the broker acknowledged all six.
    let mut acked = 0;
    tokio::time::timeout(Duration::from_secs(10), async {
        while acked < 6 {
            if let rumqttc::Event::Incoming(rumqttc::Packet::PubAck(_)) = events.poll().await? {
                acked += 1;
            }
        }
        anyhow::Ok(())
    })
    .await
    .context("the broker did not acknowledge the hostile messages")??;
    client.disconnect().await?;
    Ok(())
}

/// The office graph's vertices: index and position.
fn vertices() -> anyhow::Result<Vec<(usize, f64, f64)>> {
    let g = mrmm_maps::rmf::parse("office", &std::fs::read_to_string(office())?)?;
    Ok(g.vertices.iter().enumerate().map(|(i, v)| (i, v.at.x, v.at.y)).collect())
}

/// `n` vertices at least 2 m from each other.
fn spread(n: usize) -> anyhow::Result<Vec<(usize, f64, f64)>> {
    let mut picked: Vec<(usize, f64, f64)> = Vec::new();
    for (i, x, y) in vertices()? {
        if picked.iter().all(|&(_, a, b)| (x - a).hypot(y - b) >= 2.0) {
            picked.push((i, x, y));
        }
    }
    anyhow::ensure!(picked.len() >= n, "only {} vertices 2 m apart", picked.len());
    Ok(picked.into_iter().take(n).collect())
}

/// Traffic's graph of the office (the map's vertices, and the points its lanes are cut at), laid
/// out, and its vertices by their node ids: the map's names where a vertex has one of its own,
/// else `v<index>`.
fn traffic_nodes() -> anyhow::Result<(mrmm_maps::NavGraph, mrmm_core::traffic::layout::Layout, HashMap<String, usize>)> {
    let map = mrmm_maps::rmf::parse("office", &std::fs::read_to_string(office())?)?;
    let g = mrmm_core::traffic::layout::segmented(&map, mrmm_core::traffic::authority::SEGMENT_M);
    let layout = mrmm_core::traffic::layout::Layout::new(&g, 1.0);
    let index = (0..layout.vertices() as u32).map(|v| (layout.route_vertex(v).node_id(), v as usize)).collect();
    Ok((g, layout, index))
}

fn start_central(dir: &Scratch) -> anyhow::Result<(common::Proc, String)> {
    let (map, state) = (format!("office={}", office().display()), dir.path("central-state").display().to_string());
    let p = start(
        "central",
        &["central", "--listen", "tcp/127.0.0.1:0", "--map", &map, "--state-dir", &state],
        &dir.path("central.log"),
        "central ready",
        Duration::from_secs(20),
    )?;
    let ep = p.field("listening").and_then(|l| l.split(',').next().map(str::to_string)).context("no endpoint")?;
    Ok((p, ep))
}

fn robots_view(v: &[RobotView], id: &str) -> Option<RobotView> {
    v.iter().find(|r| r.id.as_str() == id).cloned()
}

/// The AGVs' state lines so far, per serial: the vertices (`v<k>`) they passed, in order, and any
/// error they reported.
#[derive(Default)]
struct Seen {
    nodes: std::collections::BTreeMap<String, Vec<String>>,
    errors: Vec<Value>,
    /// Most nodes an AGV had yet to pass, released (traffic's grant) and not (the horizon).
    base: u64,
    horizon: u64,
    /// Each AGV's last state line.
    last: std::collections::BTreeMap<String, Value>,
}

impl Seen {
    fn take(&mut self, rx: &mpsc::Receiver<Value>) {
        while let Ok(v) = rx.try_recv() {
            let serial = v["serial"].as_str().unwrap_or_default().to_string();
            if v["errors"].as_array().is_some_and(|e| !e.is_empty()) {
                self.errors.push(v.clone());
            }
            self.base = self.base.max(v["base"].as_u64().unwrap_or(0));
            self.horizon = self.horizon.max(v["horizon"].as_u64().unwrap_or(0));
            let node = v["lastNodeId"].as_str().unwrap_or_default().to_string();
            self.last.insert(serial.clone(), v.clone());
            let passed = self.nodes.entry(serial).or_default();
            if passed.last() != Some(&node) {
                passed.push(node);
            }
        }
    }
}

/// Where vda-5050-lib is installed (`.ci/run`'s copy outside the clone, else beside the script),
/// if it is and mosquitto and node are; without them the test is skipped — and fails under CI.
fn installed() -> anyhow::Result<Option<PathBuf>> {
    let here = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/vda5050");
    let modules = std::env::var_os("MRMM_VDA5050_NODE_MODULES").map_or_else(|| here.join("node_modules"), PathBuf::from);
    let has = |cmd: &str| Command::new(cmd).arg(if cmd == "node" { "--version" } else { "-h" }).stdout(Stdio::null()).stderr(Stdio::null()).status().is_ok();
    let missing: Vec<&str> = [("mosquitto", has("mosquitto")), ("node", has("node")), ("vda-5050-lib", modules.join("vda-5050-lib").is_dir())]
        .into_iter()
        .filter_map(|(what, ok)| (!ok).then_some(what))
        .collect();
    if missing.is_empty() {
        return Ok(Some(modules));
    }
    anyhow::ensure!(std::env::var("CI").as_deref() != Ok("true"), "{missing:?} not installed under CI: .ci/run installs them");
    println!("SKIPPED: {missing:?} not installed (run .ci/run once, or `npm ci --prefix tests/vda5050` and install mosquitto)");
    Ok(None)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn virtual_agvs_join_a_mission_follow_their_plans_and_drop_out_when_killed() -> anyhow::Result<()> {
    let Some(modules) = installed()? else { return Ok(()) };
    let dir = Scratch::new("vda5050");
    let (_broker, port) = mosquitto(&dir)?;
    let (_central, ep) = start_central(&dir)?;
    let spots = spread(4)?;
    let _robots: Vec<common::Proc> = spots[..2]
        .iter()
        .enumerate()
        .map(|(i, &(_, x, y))| common::start_robot_scaled(&dir, &format!("r{}", i + 1), &ep, x, y, 1.0))
        .collect::<Result<_, _>>()?;
    let cfg = gateway_config(&dir, port, &ep)?;
    let mut gateway = start("vda5050", &["vda5050", "--config", &cfg], &dir.path("gateway.log"), "vda5050 ready", Duration::from_secs(20))?;
    let specs: Vec<String> = spots[2..].iter().enumerate().map(|(i, &(v, x, y))| format!("agv{}:{x}:{y}:v{v}", i + 1)).collect();
    let (mut agv_proc, lines) = agvs(&dir, &modules, port, &specs)?;
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await?;

    // Every vehicle a robot of the fleet, where it stands.
    let t0 = Instant::now();
    let view = common::wait_robots(&client, 4).await?;
    println!("4 robots registered {:.2} s after the AGVs started", t0.elapsed().as_secs_f64());
    for (i, &(_, x, y)) in spots[2..].iter().enumerate() {
        let r = robots_view(&view, &format!("acme-agv{}", i + 1)).context("AGV not in the fleet")?;
        let p = r.pose.context("no pose")?;
        anyhow::ensure!((p.x - x).hypot(p.y - y) < 0.2, "{} at {p:?}, its AGV at ({x}, {y})", r.id);
    }

    // Hostile input on the vehicles' topics: logged and dropped, nothing started, nothing stops.
    hostile(port).await?;
    let gateway_log = || std::fs::read_to_string(dir.path("gateway.log")).unwrap_or_default();
    eventually("the gateway's refusals in its log", Duration::from_secs(10), || std::future::ready(gateway_log().contains("VDA 5050: dropped").then_some(())))
        .await?;
    anyhow::ensure!(gateway.child.try_wait()?.is_none(), "the gateway died of hostile input: {}", gateway_log());
    let view = common::wait_robots(&client, 4).await?;
    anyhow::ensure!(view.len() == 4, "hostile input made robots: {:?}", view.iter().map(|r| r.id.to_string()).collect::<Vec<_>>());

    // One patrol of all four on the office graph.
    let m = MissionCreate {
        name: "p".into(),
        recipe: "patrol".into(),
        robots: Some(["r1", "r2", "acme-agv1", "acme-agv2"].iter().map(|r| (*r).into()).collect()),
        params: [("waypoints".to_string(), json!("all"))].into(),
        map: Some("office".into()),
        ..Default::default()
    };
    let created: MissionView = client.query(proto::Key::SystemCmd(proto::SystemCmd::Create), Some(&m)).await?;
    let epoch = created.manager.epoch;
    let mut seen = Seen::default();
    let (g, layout, index) = traffic_nodes()?;
    // Both AGVs drive their plans along the map's vertices: each passes at least three of them.
    eventually("each AGV past 3 of the map's vertices", Duration::from_secs(60), || {
        seen.take(&lines);
        let far = |s: &str| seen.nodes.get(s).map_or(0, |n| n.iter().filter(|id| index.contains_key(*id)).count());
        std::future::ready((far("agv1") >= 3 && far("agv2") >= 3).then_some(()))
    })
    .await?;
    println!("AGVs' vertices: {:?}; at most {} released and {} horizon nodes ahead of one", seen.nodes, seen.base, seen.horizon);
    anyhow::ensure!(seen.errors.is_empty(), "an AGV reported errors (an order or update refused?): {:?}", seen.errors);
    // Orders carry what traffic granted as their base: more than the next vertex (the vehicles
    // drive on through a grant instead of stopping at each vertex). The horizon is checked in
    // the body's unit tests: a patrol's legs here are shorter than a grant.
    anyhow::ensure!(seen.base >= 2, "orders released {} node ahead at most: the vehicles stop at every vertex", seen.base);
    // Their passed vertices are traffic's (the map's, and the points its lanes are cut at), in an
    // order the lanes allow (each next one a neighbour of the one before): the orders follow the
    // lanes traffic granted.
    for (serial, nodes) in &seen.nodes {
        let idx: Vec<usize> = nodes.iter().filter_map(|n| index.get(n).copied()).collect();
        for w in idx.windows(2) {
            let adjacent = g.edges.iter().any(|l| (l.from as usize, l.to as usize) == (w[0], w[1]) || (l.from as usize, l.to as usize) == (w[1], w[0]));
            anyhow::ensure!(adjacent, "{serial} went from v{} to v{}: not a lane of the map ({nodes:?})", w[0], w[1]);
        }
    }
    // The vertices the map names (pantry, patrol_A1, …) are the nodes of those names.
    let named: Vec<&String> = seen.nodes.values().flatten().filter(|n| index.get(*n).is_some_and(|&v| layout.route_vertex(v as u32).name.is_some())).collect();
    anyhow::ensure!(!named.is_empty(), "no AGV passed a vertex by the map's name for it: {:?}", seen.nodes);
    // The mrmm robots of the mission drive too.
    let moving = eventually("the mrmm robots driving", Duration::from_secs(30), || async {
        let v: Vec<RobotView> = client.query(proto::Key::SystemRobots, None::<&()>).await.ok()?;
        let moved = spots[..2]
            .iter()
            .enumerate()
            .filter(|(i, &(_, x, y))| robots_view(&v, &format!("r{}", i + 1)).and_then(|r| r.pose).is_some_and(|p| (p.x - x).hypot(p.y - y) > 1.0));
        (moved.count() == 2).then_some(())
    });
    moving.await?;

    // The mission paused: each AGV is paused (startPause) where it is, or stands at the end of
    // what it was released; resumed, both are not paused and pass vertices again.
    let pause = proto::MissionPause { name: "p".into() };
    let _: Value = client.query(proto::Key::SystemCmd(proto::SystemCmd::Pause), Some(&pause)).await?;
    eventually("both AGVs paused or standing", Duration::from_secs(15), || {
        seen.take(&lines);
        let held = |s: &str| seen.last.get(s).is_some_and(|v| v["paused"] == json!(true) || (v["driving"] == json!(false) && v["base"] == json!(0)));
        std::future::ready((held("agv1") && held("agv2")).then_some(()))
    })
    .await?;
    let paused: Vec<bool> = ["agv1", "agv2"].iter().map(|s| seen.last.get(*s).is_some_and(|v| v["paused"] == json!(true))).collect();
    let passed: Vec<usize> = ["agv1", "agv2"].iter().map(|s| seen.nodes.get(*s).map_or(0, Vec::len)).collect();
    let _: Value = client.query(proto::Key::SystemCmd(proto::SystemCmd::Resume), Some(&pause)).await?;
    eventually("both AGVs driving on", Duration::from_secs(40), || {
        seen.take(&lines);
        let on = |i: usize, s: &str| seen.nodes.get(s).map_or(0, Vec::len) > passed[i] && seen.last.get(s).is_some_and(|v| v["paused"] != json!(true));
        std::future::ready((on(0, "agv1") && on(1, "agv2")).then_some(()))
    })
    .await?;
    println!("paused (startPause) {paused:?}; both resumed");
    anyhow::ensure!(seen.errors.is_empty(), "an AGV reported errors around the pause: {:?}", seen.errors);

    let before: Vec<MissionView> = client.query(proto::Key::SystemMissions, None::<&()>).await?;
    let members: Vec<String> = before.iter().find(|m| m.name.as_str() == "p").context("no mission p")?.robots.iter().map(|r| r.to_string()).collect();
    anyhow::ensure!(members.iter().filter(|r| r.starts_with("acme-")).count() == 2, "the AGVs are not members before the kill: {members:?}");
    let epoch = before.iter().find(|m| m.name.as_str() == "p").map_or(epoch, |m| m.manager.epoch);
    // The AGVs' process killed: the broker's last will (CONNECTIONBROKEN) drops both robots, and
    // the mission goes on with the two mrmm robots.
    agv_proc.0.kill()?;
    let killed = Instant::now();
    let replanned = eventually("the patrol replanned without the AGVs", Duration::from_secs(30), || async {
        let v: Vec<MissionView> = client.query(proto::Key::SystemMissions, None::<&()>).await.ok()?;
        let p = v.into_iter().find(|m| m.name.as_str() == "p")?;
        let members: Vec<String> = p.robots.iter().map(|r| r.to_string()).collect();
        (p.manager.epoch > epoch && !members.iter().any(|r| r.starts_with("acme-"))).then_some(members)
    })
    .await?;
    println!("AGVs killed: mission replanned with {replanned:?} after {:.2} s", killed.elapsed().as_secs_f64());
    Ok(())
}

/// The poses of `ids` in the fleet view, if all have one.
async fn poses(client: &Client, ids: &[&str]) -> Option<Vec<(f64, f64)>> {
    let v: Vec<RobotView> = client.query(proto::Key::SystemRobots, None::<&()>).await.ok()?;
    ids.iter().map(|id| robots_view(&v, id).and_then(|r| r.pose).map(|p| (p.x, p.y))).collect()
}

/// `mrmm vda5050-sim`'s vehicles on its embedded broker (what `mrmm demo --vda5050 N` runs, no
/// broker installed): they join through the gateway, drive a patrol on the office graph with no
/// order refused, stand while the mission is paused and drive on when it resumes, and drop out of
/// the fleet when their process is killed (the broker's last will). Needs neither node nor
/// mosquitto.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn simulated_vehicles_on_the_embedded_broker_drive_a_mission_pause_with_it_and_drop_out_when_killed() -> anyhow::Result<()> {
    let dir = Scratch::new("vda5050-sim");
    let (_central, ep) = start_central(&dir)?;
    let spots = spread(2)?;
    let at: Vec<String> = spots.iter().map(|&(_, x, y)| format!("{x},{y}")).collect();
    let sim_args = ["vda5050-sim", "--vehicles", "2", "--listen", "127.0.0.1:0", "--manufacturer", "sim", "--map-id", "office", "--at", &at[0], "--at", &at[1]];
    let mut sim = start("vda5050-sim", &sim_args, &dir.path("sim.log"), "vda5050-sim ready", Duration::from_secs(20))?;
    let broker = sim.field("broker").context("no broker in the ready line")?;
    let port: u16 = broker.rsplit(':').next().and_then(|p| p.parse().ok()).context("no port")?;
    let cfg = gateway_config(&dir, port, &ep)?;
    let gateway = start("vda5050", &["vda5050", "--config", &cfg], &dir.path("gateway.log"), "vda5050 ready", Duration::from_secs(20))?;
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await?;
    let ids = ["sim-agv1", "sim-agv2"];
    let view = common::wait_robots(&client, 2).await?;
    for (id, &(_, x, y)) in ids.iter().zip(&spots) {
        let p = robots_view(&view, id).and_then(|r| r.pose).with_context(|| format!("{id} not in the fleet"))?;
        anyhow::ensure!((p.x - x).hypot(p.y - y) < 0.2, "{id} at {p:?}, its vehicle at ({x}, {y})");
    }
    let m = MissionCreate {
        name: "p".into(),
        recipe: "patrol".into(),
        robots: Some(ids.iter().map(|r| (*r).into()).collect()),
        params: [("waypoints".to_string(), json!("all"))].into(),
        map: Some("office".into()),
        ..Default::default()
    };
    let _: MissionView = client.query(proto::Key::SystemCmd(proto::SystemCmd::Create), Some(&m)).await?;
    let start_at: Vec<(f64, f64)> = spots.iter().map(|&(_, x, y)| (x, y)).collect();
    let moved = |from: &[(f64, f64)], now: &[(f64, f64)], d: f64| from.iter().zip(now).all(|(a, b)| (a.0 - b.0).hypot(a.1 - b.1) > d);
    eventually("both vehicles driving their plans", Duration::from_secs(30), || async { poses(&client, &ids).await.filter(|p| moved(&start_at, p, 1.0)) })
        .await?;
    // What each vehicle says of itself is in the robots' view: the last node it passed, one of
    // traffic's (by the map's name, or its index), and that it drives.
    let (_, _, index) = traffic_nodes()?;
    let said = |v: &[RobotView]| -> Vec<proto::VehicleState> { ids.iter().filter_map(|id| robots_view(v, id)?.vehicle).collect() };
    eventually("each vehicle's last node and driving in the robots' view", Duration::from_secs(30), || async {
        let v: Vec<RobotView> = client.query(proto::Key::SystemRobots, None::<&()>).await.ok()?;
        let s = said(&v);
        (s.len() == 2 && s.iter().all(|s| index.contains_key(&s.last_node) && s.driving && s.errors.is_empty())).then_some(())
    })
    .await?;

    // Paused: the vehicles are told startPause and stand.
    let pause = proto::MissionPause { name: "p".into() };
    let _: Value = client.query(proto::Key::SystemCmd(proto::SystemCmd::Pause), Some(&pause)).await?;
    let gateway_log = || std::fs::read_to_string(dir.path("gateway.log")).unwrap_or_default();
    let said = |what: &str| gateway_log().lines().filter(|l| l.contains(what)).count();
    let paused_at = eventually("the vehicles standing", Duration::from_secs(15), || async {
        let a = poses(&client, &ids).await?;
        tokio::time::sleep(Duration::from_millis(600)).await;
        let b = poses(&client, &ids).await?;
        (!moved(&a, &b, 0.02) && a.iter().zip(&b).all(|(p, q)| (p.0 - q.0).hypot(p.1 - q.1) < 0.02)).then_some(b)
    })
    .await?;
    // Stopped by a pause (startPause) or, on lanes, by the order cut back to the next vertex
    // (cancelOrder, then an order to it: the robot's hold on a lane ends at its vertex).
    anyhow::ensure!(said("startPause") + said("cancelOrder") >= 2, "held without startPause or cancelOrder: {}", gateway_log());
    // Resumed: they drive on.
    let _: Value = client.query(proto::Key::SystemCmd(proto::SystemCmd::Resume), Some(&pause)).await?;
    eventually("both vehicles driving again", Duration::from_secs(30), || async { poses(&client, &ids).await.filter(|p| moved(&paused_at, p, 0.5)) }).await?;
    anyhow::ensure!(said("stopPause") >= 1 || said("cancelOrder") >= 1, "resumed without stopPause or a new order: {}", gateway_log());
    let v: Vec<RobotView> = client.query(proto::Key::SystemRobots, None::<&()>).await?;
    let stuck: Vec<String> = v.iter().filter_map(|r| r.stuck.as_ref().map(|s| format!("{}: {s}", r.id))).collect();
    anyhow::ensure!(stuck.is_empty(), "a vehicle refused an order: {stuck:?}");

    // The vehicles' process killed: their last will drops both robots.
    sim.child.kill()?;
    eventually("both vehicles lost", Duration::from_secs(20), || async {
        let v: Vec<RobotView> = client.query(proto::Key::SystemRobots, None::<&()>).await.ok()?;
        ids.iter().all(|id| robots_view(&v, id).is_none_or(|r| r.status == proto::RobotStatus::Lost)).then_some(())
    })
    .await?;
    drop(gateway);
    Ok(())
}

/// The gateway reaches its broker over TLS — mosquitto's TLS listener, which asks for the
/// gateway's own certificate — and the vehicles (on the broker's plain listener) join the fleet
/// through it. A gateway that does not trust the broker's CA says why and joins no vehicle; a
/// TLS file that cannot be read stops start-up with one line that names it. Needs mosquitto, not
/// node.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_gateway_reaches_a_tls_broker_with_a_certificate_of_its_own() -> anyhow::Result<()> {
    let dir = Scratch::new("vda5050-tls");
    test_pki(&dir, "fleet")?;
    test_pki(&dir, "other")?;
    let (plain, tls) = (common::standin::free_port()?, common::standin::free_port()?);
    let file = |name: &str| dir.path(name).display().to_string();
    let conf = format!(
        "per_listener_settings true\npersistence false\nlistener {plain} 127.0.0.1\nallow_anonymous true\nlistener {tls} 127.0.0.1\nallow_anonymous true\n\
         cafile {}\ncertfile {}\nkeyfile {}\nrequire_certificate true\n",
        file("fleet-ca.pem"),
        file("fleet-broker.pem"),
        file("fleet-broker.key")
    );
    let _broker = mosquitto_with(&dir, &conf, &[plain, tls])?;
    let (_central, ep) = start_central(&dir)?;
    let spots = spread(2)?;
    let at: Vec<String> = spots.iter().map(|&(_, x, y)| format!("{x},{y}")).collect();
    let on_plain = format!("mqtt://127.0.0.1:{plain}");
    let sim_args = ["vda5050-sim", "--vehicles", "2", "--broker", &on_plain, "--manufacturer", "sim", "--map-id", "office", "--at", &at[0], "--at", &at[1]];
    let _sim = start("vda5050-sim", &sim_args, &dir.path("sim.log"), "vda5050-sim ready", Duration::from_secs(20))?;
    gateway_config(&dir, plain, &ep)?;
    let tls_config = |name: &str, ca: &str| -> anyhow::Result<String> {
        let path = dir.path(name);
        let text = format!(
            r#"{{ broker: "mqtts://127.0.0.1:{tls}", map: "office", robot: "agv.json5", tls: {{ ca: "{ca}", cert: "fleet-gateway.pem", key: "fleet-gateway.key" }} }}"#
        );
        std::fs::write(&path, text)?;
        Ok(path.display().to_string())
    };

    // A TLS file that cannot be read: start-up stops with one line naming the field and file.
    let log = dir.path("missing.log");
    let mut missing = Other(
        Command::new(env!("CARGO_BIN_EXE_mrmm"))
            .args(["vda5050", "--config", &tls_config("missing.json5", "nowhere.pem")?])
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(&log)?)
            .spawn()?,
    );
    let status =
        eventually("the gateway with a missing CA file stopping", Duration::from_secs(20), || std::future::ready(missing.0.try_wait().ok().flatten())).await?;
    let said = std::fs::read_to_string(&log)?;
    anyhow::ensure!(!status.success() && said.contains("tls.ca") && said.contains("nowhere.pem"), "a missing CA file: {said}");

    // A gateway that trusts another CA: it says the broker's certificate is not trusted.
    let log = dir.path("untrusting.log");
    let untrusting = Other(
        Command::new(env!("CARGO_BIN_EXE_mrmm"))
            .args(["vda5050", "--config", &tls_config("untrusting.json5", "other-ca.pem")?])
            .env("RUST_LOG", "info")
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(&log)?)
            .spawn()?,
    );
    eventually("the untrusting gateway saying why", Duration::from_secs(20), || {
        let text = std::fs::read_to_string(&log).unwrap_or_default();
        std::future::ready((text.contains("UnknownIssuer") || text.contains("invalid peer certificate")).then_some(()))
    })
    .await?;
    drop(untrusting);

    // The gateway with the fleet's CA and its own certificate: both vehicles join.
    let cfg = tls_config("gateway-tls.json5", "fleet-ca.pem")?;
    let gateway = start("vda5050", &["vda5050", "--config", &cfg], &dir.path("gateway.log"), "vda5050 ready", Duration::from_secs(20))?;
    anyhow::ensure!(gateway.field("broker").as_deref() == Some(format!("mqtts://127.0.0.1:{tls}").as_str()), "{}", gateway.ready);
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await?;
    let view = common::wait_robots(&client, 2).await?;
    for (id, &(_, x, y)) in ["sim-agv1", "sim-agv2"].iter().zip(&spots) {
        let p = robots_view(&view, id).and_then(|r| r.pose).with_context(|| format!("{id} not in the fleet: {view:?}"))?;
        anyhow::ensure!((p.x - x).hypot(p.y - y) < 0.2, "{id} at {p:?}, its vehicle at ({x}, {y})");
    }
    Ok(())
}
