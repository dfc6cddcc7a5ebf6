//! VDA 5050 at 20 vehicles (issue 54's targets), with real processes on loopback and the
//! simulated vehicles of `mrmm vda5050-sim` on its embedded broker (no node, no mosquitto).
//!
//! 1. **Idle**: central, `vda5050-sim --vehicles N` and the gateway, no mission. The time from the
//!    gateway's start until central registered every vehicle's robot, and the gateway's CPU over
//!    10 s while they stand.
//! 2. **Driving**: `mrmm demo --insecure --robots N --vda5050 N --map <building>`: N robots and N
//!    vehicles, the demo's two missions on the building's lanes. The demo's own registration
//!    time; then for `--run S` seconds (default 30): **grant → order**, from a traffic order
//!    granting a vehicle's robot a vertex it was not granted before (Zenoh,
//!    `mrmm/traffic/*/order/agvK`, heard by this process) to the first order on the wire that
//!    releases that vertex's node to the vehicle (MQTT, `uagv/v2/mrmm/agvK/order`, heard by this
//!    process too: one clock); the gateway's CPU; orders refused (robots stuck).
//!
//! `cargo bench --bench vda5050 -- [--vehicles N] [--run S]` (default 20 and 30).

#[path = "../tests/common/mod.rs"]
mod common;

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use anyhow::{anyhow, Context};
use common::measure::{cpu_s, quantile};
use common::{eventually, start, Scratch};
use mrmm_net::client::Client;
use mrmm_proto::{self as proto, RobotView};

fn building() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("maps/data/building/building.yaml")
}

fn arg<T: std::str::FromStr>(args: &[String], name: &str, default: T) -> T {
    args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)?.parse().ok()).unwrap_or(default)
}

/// The pid of the child of `parent` whose command line holds every word of `words`.
fn child_with(parent: u32, words: &[&str]) -> Option<u32> {
    let children = std::fs::read_to_string(format!("/proc/{parent}/task/{parent}/children")).ok()?;
    children.split_whitespace().filter_map(|p| p.parse::<u32>().ok()).find(|pid| {
        let cmd = std::fs::read(format!("/proc/{pid}/cmdline")).unwrap_or_default();
        let args: Vec<String> = cmd.split(|b| *b == 0).map(|a| String::from_utf8_lossy(a).into_owned()).collect();
        words.iter().all(|w| args.iter().any(|a| a == w))
    })
}

/// Phase 1: registration of `n` vehicles and the gateway's idle CPU.
async fn idle(n: usize) -> anyhow::Result<(f64, f64)> {
    let dir = Scratch::new("bench-vda5050-idle");
    let (_central, ep) = common::start_central(&dir)?;
    let sim = start(
        "sim",
        &["vda5050-sim", "--vehicles", &n.to_string(), "--listen", "127.0.0.1:0"],
        &dir.path("sim.log"),
        "vda5050-sim ready",
        Duration::from_secs(30),
    )?;
    let broker = sim.field("broker").context("no broker")?.to_string();
    std::fs::write(
        dir.path("agv.json5"),
        format!(
            r#"{{ id: "agv", type: "ground", kinematics: {{ max_speed: 1.0, max_turn_rate: 1.5 }}, telemetry_hz: 5,
                 zenoh: {{ mode: "client", connect: ["{ep}"], lease_ms: 1000 }} }}"#
        ),
    )?;
    std::fs::write(dir.path("gw.json5"), format!(r#"{{ broker: "{broker}", map: "mrmm", robot: "agv.json5" }}"#))?;
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await?;
    let t0 = Instant::now();
    let cfg = dir.path("gw.json5").display().to_string();
    let gateway = start("vda5050", &["vda5050", "--config", &cfg], &dir.path("gateway.log"), "vda5050 ready", Duration::from_secs(30))?;
    eventually(&format!("{n} vehicles registered"), Duration::from_secs(60), || async {
        let v: Vec<RobotView> = client.query(proto::Key::SystemRobots, None::<&()>).await.ok()?;
        (v.len() == n).then_some(())
    })
    .await?;
    let registered = t0.elapsed().as_secs_f64();
    // Settled: the vehicles' robots' start-up is not idle.
    tokio::time::sleep(Duration::from_secs(2)).await;
    let pid = gateway.child.id();
    let (c0, t) = (cpu_s(pid), Instant::now());
    tokio::time::sleep(Duration::from_secs(10)).await;
    let cpu = (cpu_s(pid) - c0) / t.elapsed().as_secs_f64() * 100.0;
    client.close().await;
    Ok((registered, cpu))
}

/// What the observer heard in phase 2.
#[derive(Default)]
struct Heard {
    /// (robot, vertex's node id) granted and not yet released to the vehicle: when the grant
    /// came.
    granted: BTreeMap<(String, String), Instant>,
    /// Per robot, the vertices of its last grant (what is new in the next one).
    last_grant: BTreeMap<String, Vec<String>>,
    latencies_ms: Vec<f64>,
    /// The slowest: latency, robot, node.
    slow: Vec<(f64, String, String)>,
    orders: usize,
    /// Grants taken back before their vertex was released (the route changed).
    superseded: usize,
}

impl Heard {
    fn grant(&mut self, robot: &str, order: &proto::TrafficOrder, at: Instant) {
        let proto::TrafficOrder::Route { route, reached, upto, .. } = order else { return };
        let from = reached.map_or(0, |r| r as usize + 1);
        let to = upto.map_or(0, |u| u as usize + 1).min(route.len());
        let now: Vec<String> = route.get(from.min(to)..to).unwrap_or_default().iter().map(proto::traffic::RouteVertex::node_id).collect();
        let before = self.last_grant.insert(robot.to_string(), now.clone()).unwrap_or_default();
        let gone: Vec<(String, String)> = self.granted.keys().filter(|(r, v)| r == robot && !now.contains(v)).cloned().collect();
        self.superseded += gone.len();
        for k in gone {
            self.granted.remove(&k);
        }
        for v in now.into_iter().filter(|v| !before.contains(v)) {
            self.granted.entry((robot.to_string(), v)).or_insert(at);
        }
    }

    fn order(&mut self, robot: &str, order: &mrmm_vda5050::Order, at: Instant) {
        self.orders += 1;
        // The first node is where the vehicle stands (a new order) or the last base node it has
        // (an update): released before, not by this order.
        for n in order.nodes.iter().skip(1).filter(|n| n.released) {
            if let Some(t) = self.granted.remove(&(robot.to_string(), n.node_id.clone())) {
                let ms = at.saturating_duration_since(t).as_secs_f64() * 1000.0;
                self.latencies_ms.push(ms);
                if ms > 100.0 {
                    self.slow.push((ms, robot.to_string(), n.node_id.clone()));
                }
            }
        }
    }
}

/// Phase 2: the demo with `n` robots and `n` vehicles for `run` seconds.
async fn driving(n: usize, run: f64) -> anyhow::Result<()> {
    let dir = Scratch::new("bench-vda5050-demo");
    let map = building().display().to_string();
    let (k, dur) = (n.to_string(), (run + 120.0).to_string());
    let args = ["--insecure", "--robots", &k, "--vda5050", &k, "--map", &map, "--no-console", "--duration", &dur, "--listen", "tcp/127.0.0.1:0"];
    let (demo, ep, _, lines) = common::start_demo_lines(&dir, &args)?;
    let demo_dir = std::env::temp_dir().join(format!("mrmm-demo-{}", demo.pid()));
    let gw_cfg = std::fs::read_to_string(demo_dir.join("vda5050.json5"))?;
    let broker = gw_cfg.split('"').find(|w| w.starts_with("mqtt://")).context("no broker in the gateway's config")?.to_string();
    let port: u16 = broker.rsplit(':').next().and_then(|p| p.parse().ok()).context("no port")?;
    let gateway = child_with(demo.child.id(), &["vda5050", "--config"]).context("no gateway among the demo's children")?;

    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(10)).await?;
    let z = |e: zenoh::Error| anyhow!("{e}");
    // Each grant stamped as it arrives (a callback, not a queue read later).
    let (grant_tx, mut grants) = tokio::sync::mpsc::unbounded_channel();
    let _grants = client
        .session()
        .declare_subscriber(proto::Pattern::AllTrafficOrders.to_string())
        .callback(move |s| {
            let _ = grant_tx.send((Instant::now(), s.key_expr().as_str().to_string(), s.payload().to_bytes().to_vec()));
        })
        .await
        .map_err(z)?;
    let mut opts = rumqttc::MqttOptions::new("bench-observer", "127.0.0.1", port);
    opts.set_max_packet_size(1 << 20, 1 << 20);
    let (mqtt, mut events) = rumqttc::AsyncClient::new(opts, 64);
    mqtt.subscribe("uagv/v2/+/+/order", rumqttc::QoS::AtMostOnce).await?;
    let (tx, mut orders) = tokio::sync::mpsc::unbounded_channel();
    tokio::spawn(async move {
        while let Ok(ev) = events.poll().await {
            if let rumqttc::Event::Incoming(rumqttc::Packet::Publish(p)) = ev {
                let _ = tx.send((Instant::now(), p.topic, p.payload));
            }
        }
    });
    let registered = eventually("the demo's registration line", Duration::from_secs(120), || {
        std::future::ready(lines.try_iter().find_map(|l| l.split(" registered ").nth(1).and_then(|r| r.split(' ').next()?.parse::<f64>().ok())))
    })
    .await?;

    let mut heard = Heard::default();
    let (c0, t0) = (cpu_s(gateway), Instant::now());
    while t0.elapsed() < Duration::from_secs_f64(run) {
        while let Ok((at, key, payload)) = grants.try_recv() {
            let robot = key.rsplit('/').next().unwrap_or_default();
            if robot.starts_with("agv") {
                if let Ok(o) = serde_json::from_slice::<proto::TrafficOrder>(&payload) {
                    heard.grant(robot, &o, at);
                }
            }
        }
        while let Ok((at, topic, payload)) = orders.try_recv() {
            // uagv/v2/mrmm/agvK/order: the demo maps mrmm/agvK to robot agvK.
            let serial = topic.split('/').nth(3).unwrap_or_default().to_string();
            if let Ok(o) = serde_json::from_slice::<mrmm_vda5050::Order>(&payload) {
                heard.order(&serial, &o, at);
            }
        }
        tokio::time::sleep(Duration::from_millis(2)).await;
    }
    let cpu = (cpu_s(gateway) - c0) / t0.elapsed().as_secs_f64() * 100.0;
    let v: Vec<RobotView> = client.query(proto::Key::SystemRobots, None::<&()>).await?;
    let stuck: Vec<String> = v.iter().filter(|r| r.id.as_str().starts_with("agv")).filter_map(|r| r.stuck.as_ref().map(|s| format!("{}: {s}", r.id))).collect();
    let mut lat = std::mem::take(&mut heard.latencies_ms);
    let lat = &mut lat;
    println!(
        "driving ({n} robots + {n} vehicles, two missions on the building's lanes, {run:.0} s): registered {registered:.1} s after the demo's start; \
         {} orders; grant → order on the wire: n={} p50 {:.1} ms p99 {:.1} ms max {:.1} ms ({} grants taken back before an order, {} still waiting); gateway CPU {cpu:.1} % of a core; vehicles stuck (an order refused): {}",
        heard.orders,
        lat.len(),
        quantile(lat, 0.5),
        quantile(lat, 0.99),
        quantile(lat, 1.0),
        heard.superseded,
        heard.granted.len(),
        if stuck.is_empty() { "none".to_string() } else { stuck.join("; ") },
    );
    if !heard.slow.is_empty() {
        println!("over 100 ms: {:?}", heard.slow);
    }
    client.close().await;
    demo.signal("INT")?;
    Ok(())
}

#[tokio::main(flavor = "multi_thread", worker_threads = 2)]
async fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let n: usize = arg(&args, "--vehicles", 20);
    let run: f64 = arg(&args, "--run", 30.0);
    let cores = std::thread::available_parallelism().map_or(1, |c| c.get());
    println!("VDA 5050 bench: {n} vehicles, {cores} cores");
    let (registered, cpu) = idle(n).await?;
    println!("idle ({n} vehicles standing, no mission): all registered {registered:.2} s after the gateway started; gateway CPU {cpu:.1} % of a core");
    driving(n, run).await
}
