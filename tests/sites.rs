//! Three sites joined by their routers (docs/deployment.md, "Several sites"), in network
//! namespaces made by the test: a WAN namespace holds a bridge; sites A, B and C each hang on it
//! by a veth (10.200.0.1, .2, .3). Site A runs central (a router) and r_a; B a site router
//! (`mrmm router`) and r_b1, r_b2; C a site router and r_c1, r_c2, r_c3. Inside a site every
//! process listens on 127.0.0.1 only; only the routers listen on the WAN.
//!
//! Checked: robots link only inside their site (their TCP connections, read with `ss`, never
//! leave it) while central sees and commands all of them through the router mesh, and an operator
//! tool in site C reaches central through C's router; a mission inside site C (`local`, led by
//! r_c1) and one spanning B and C (`span`, led by central) both pass barriers. Then C's uplink is
//! cut (no process dies): `local` keeps passing barriers, seen from inside C; `span` goes on with
//! r_b1 and r_b2 (central replans without r_c3, which is reported lost), while r_c3, alone in C,
//! keeps its plan and passes its barriers alone (they count live members). When the link returns,
//! every robot is back, `span` has its three robots again and passes barriers with them, and
//! `local` never left C.
//!
//! Needs root (CAP_NET_ADMIN) for `ip netns`; elsewhere it says so and skips — except under
//! `CI=true`, where a skip is a failure (CI runs as root).

mod common;

use std::collections::BTreeSet;
use std::time::{Duration, Instant};

use anyhow::ensure;
use common::netns::{drain, eventually, ip, namespaces, op, start_tap, tap_until};
use common::{start_wrapped, tcp_peers, Proc, Scratch};
use mrmm_proto::{Key, MissionView, RobotStatus, RobotView};
use serde_json::Value;

/// The WAN address of site `i` (0 = A).
fn wan_ip(i: usize) -> String {
    format!("10.200.0.{}", i + 1)
}

/// Where everything in a site connects: its router (central in A) on the site's loopback.
const SITE_ROUTER: &str = "tcp/127.0.0.1:7447";

/// The WAN namespace with its bridge and three site namespaces; deleted on drop.
struct Sites {
    wan: String,
    sites: [String; 3],
    /// Each site's end of its uplink (inside the site).
    uplinks: [String; 3],
}

impl Sites {
    fn new() -> anyhow::Result<Sites> {
        let id = std::process::id() % 100_000;
        let s = Sites {
            wan: format!("mrmm{id}w"),
            sites: ["a", "b", "c"].map(|n| format!("mrmm{id}s{n}")),
            uplinks: ["a", "b", "c"].map(|n| format!("mu{id}{n}")),
        };
        ip(&["netns", "add", &s.wan])?;
        ip(&["-n", &s.wan, "link", "add", "br0", "type", "bridge"])?;
        ip(&["-n", &s.wan, "link", "set", "br0", "up"])?;
        for (i, (ns, up)) in s.sites.iter().zip(&s.uplinks).enumerate() {
            ip(&["netns", "add", ns])?;
            let wan_end = format!("{up}w");
            ip(&["link", "add", up, "netns", ns, "type", "veth", "peer", "name", &wan_end, "netns", &s.wan])?;
            ip(&["-n", &s.wan, "link", "set", &wan_end, "master", "br0"])?;
            ip(&["-n", &s.wan, "link", "set", &wan_end, "up"])?;
            ip(&["-n", ns, "addr", "add", &format!("{}/24", wan_ip(i)), "dev", up])?;
            ip(&["-n", ns, "link", "set", up, "up"])?;
            ip(&["-n", ns, "link", "set", "lo", "up"])?;
        }
        Ok(s)
    }

    /// Site `i`'s uplink up or down (from inside the site: nothing is killed).
    fn uplink(&self, i: usize, up: bool) -> anyhow::Result<()> {
        ip(&["-n", &self.sites[i], "link", "set", &self.uplinks[i], if up { "up" } else { "down" }])
    }
}

impl Drop for Sites {
    fn drop(&mut self) {
        for ns in self.sites.iter().chain([&self.wan]) {
            let _ = ip(&["netns", "del", ns]);
        }
    }
}

/// Every robot's site: (id, site index, start x).
const ROBOTS: [(&str, usize, f64); 6] = [("r_a", 0, 0.0), ("r_b1", 1, 2.0), ("r_b2", 1, 4.0), ("r_c1", 2, 6.0), ("r_c2", 2, 8.0), ("r_c3", 2, 10.0)];

fn robot(dir: &Scratch, ns: &str, id: &str, x: f64) -> anyhow::Result<Proc> {
    let cfg = format!(
        r#"{{ id: "{id}", type: "ground", kinematics: {{ max_speed: 1.0, max_turn_rate: 2.0 }},
             start: {{ x: {x}, y: -3 }}, time_scale: 10, telemetry_hz: 10,
             zenoh: {{ listen: ["tcp/127.0.0.1:0"], connect: ["{SITE_ROUTER}"], lease_ms: 1000 }} }}"#
    );
    let path = dir.path(&format!("{id}.json5"));
    std::fs::write(&path, cfg)?;
    let path = path.display().to_string();
    start_wrapped(&["ip", "netns", "exec", ns], id, &["robot", "--config", &path], &dir.path(&format!("{id}.log")), "robot ready", Duration::from_secs(20))
}

/// Site `i`'s router (B, C): on the site's loopback and the WAN, linked to central and to the
/// routers of the sites before it.
fn router(dir: &Scratch, ns: &str, i: usize) -> anyhow::Result<Proc> {
    let connect: Vec<String> = (0..i).map(|j| format!("\"tcp/{}:7447\"", wan_ip(j))).collect();
    let cfg = format!(r#"{{ id: "site-{i}", listen: ["{SITE_ROUTER}", "tcp/{}:7447"], connect: [{}] }}"#, wan_ip(i), connect.join(", "));
    let path = dir.path(&format!("router{i}.json5"));
    std::fs::write(&path, cfg)?;
    let path = path.display().to_string();
    start_wrapped(
        &["ip", "netns", "exec", ns],
        &format!("router{i}"),
        &["router", "--config", &path],
        &dir.path(&format!("router{i}.log")),
        "router ready",
        Duration::from_secs(20),
    )
}

/// Sync points passed by mission `m` according to a status line of the tap, with its head.
fn status_syncs(v: &Value, m: &str) -> Option<(u64, String)> {
    let key = Key::parse(v["key"].as_str()?)?;
    (key == Key::MissionStatus(m.into())).then_some(())?;
    Some((v["payload"]["metrics"]["sync_points_passed"].as_u64()?, v["payload"]["manager"]["node"].as_str()?.to_string()))
}

#[test]
fn three_sites_one_cut_off_and_back() -> anyhow::Result<()> {
    let Some(sites) = namespaces("three_sites_one_cut_off_and_back", Sites::new)? else { return Ok(()) };
    let dir = Scratch::new("sites");
    let result = scenario(&sites, &dir);
    if let Err(e) = &result {
        for n in ["central", "router1", "router2", "r_b1", "r_c1", "r_c3"] {
            let log = std::fs::read_to_string(dir.path(&format!("{n}.log"))).unwrap_or_default();
            let lines: Vec<&str> = log.lines().filter(|l| !l.contains("zenoh")).collect();
            eprintln!("== {n} (last lines)\n{}", lines[lines.len().saturating_sub(25)..].join("\n"));
        }
        eprintln!("sites test failed: {e}");
    }
    result
}

fn scenario(sites: &Sites, dir: &Scratch) -> anyhow::Result<()> {
    let [a, b, c] = &sites.sites;
    let state = dir.path("central-state").display().to_string();
    let _central = start_wrapped(
        &["ip", "netns", "exec", a],
        "central",
        &["central", "--listen", SITE_ROUTER, "--listen", &format!("tcp/{}:7447", wan_ip(0)), "--state-dir", &state],
        &dir.path("central.log"),
        "central ready",
        Duration::from_secs(20),
    )?;
    let routers = [router(dir, b, 1)?, router(dir, c, 2)?];
    let mut robots = Vec::new();
    for (id, site, x) in ROBOTS {
        robots.push((id, site, robot(dir, &sites.sites[site], id, x)?));
    }
    let all: Vec<&str> = ROBOTS.iter().map(|r| r.0).collect();
    eventually("every robot of every site registered with central", Duration::from_secs(30), || {
        let v: Vec<RobotView> = op(a, SITE_ROUTER, &["robots"]).ok()?;
        (v.iter().map(|r| r.id.as_str()).collect::<Vec<_>>() == all && v.iter().all(|r| r.pose.is_some())).then_some(())
    })?;
    // Central through the router mesh, from an operator tool in site C.
    let v: Vec<RobotView> = op(c, SITE_ROUTER, &["robots"])?;
    ensure!(v.len() == 6, "an operator in site C sees {} robots through its router", v.len());
    // Robots link inside their site only: every TCP connection of a robot is on its site's
    // loopback; only the routers hold the WAN links.
    for (id, site, proc) in &robots {
        let remote = tcp_peers(Some(&sites.sites[*site]), proc.pid())?;
        ensure!(!remote.is_empty(), "{id}: no links at all");
        ensure!(remote.iter().all(|r| r.starts_with("127.0.0.1:")), "{id} links outside its site: {remote:?}");
    }
    for (i, r) in routers.iter().enumerate() {
        let remote = tcp_peers(Some(&sites.sites[i + 1]), r.pid())?;
        ensure!(remote.iter().any(|r| r.starts_with("10.200.0.")), "router of site {} has no WAN link: {remote:?}", i + 1);
    }

    let local: MissionView = op(
        a,
        SITE_ROUTER,
        &["mission", "create", "local", "--recipe", "patrol", "--robots", "r_c1,r_c2", "--host", "r_c1", "--waypoints", "[[0,0],[8,0],[8,8],[0,8]]"],
    )?;
    ensure!(local.manager.node == "r_c1", "local is led inside site C: {:?}", local.manager);
    let span: MissionView =
        op(a, SITE_ROUTER, &["mission", "create", "span", "--recipe", "patrol", "--robots", "r_b1,r_b2,r_c3", "--waypoints", "[[0,0],[10,0],[10,10],[0,10]]"])?;
    ensure!(span.manager.node == "central", "span is led by central: {:?}", span.manager);
    for m in ["local", "span"] {
        eventually(&format!("{m} past its first barriers"), Duration::from_secs(40), || {
            let v: MissionView = op(a, SITE_ROUTER, &["mission", "show", m]).ok()?;
            (v.metrics.sync_points_passed >= 2).then_some(())
        })?;
    }
    // A tap inside C, on C's router: what site C does while cut off.
    let (_tap_c, tap) = start_tap(dir, c, "127.0.0.1", &[SITE_ROUTER.to_string()], "tap-c")?;
    tap_until(&tap, "local's status inside C", Duration::from_secs(10), |v| status_syncs(v, "local").is_some())?;

    // Cut site C off.
    sites.uplink(2, false)?;
    let cut = Instant::now();
    drain(&tap);
    // Inside C, local's barriers go on, led by r_c1 with both its robots.
    let mut first = None::<u64>;
    tap_until(&tap, "local passing two more barriers inside C while cut off", Duration::from_secs(40), |v| match status_syncs(v, "local") {
        Some((n, head)) if head == "r_c1" => n >= *first.get_or_insert(n) + 2,
        _ => false,
    })?;
    println!("cut: local passed two barriers inside C within {:?}", cut.elapsed());
    // r_c3, cut off from its teammates and its manager, keeps its plan of span: its barriers
    // count live members only, so it passes them alone and goes on patrolling.
    let (mut xs, mut ys, mut missions) = (Vec::new(), Vec::new(), BTreeSet::new());
    tap_until(&tap, "r_c3 heard inside C for 4 s", Duration::from_secs(20), |v| {
        if v["key"].as_str().and_then(Key::parse) == Some(Key::RobotTelemetry("r_c3".into())) {
            xs.push(v["payload"]["pose"]["x"].as_f64().unwrap_or(f64::NAN));
            ys.push(v["payload"]["pose"]["y"].as_f64().unwrap_or(f64::NAN));
            missions.insert(v["payload"]["mission"].as_str().unwrap_or("-").to_string());
        }
        xs.len() >= 40
    })?;
    let spread = |v: &[f64]| v.iter().copied().fold(f64::NEG_INFINITY, f64::max) - v.iter().copied().fold(f64::INFINITY, f64::min);
    ensure!(missions == BTreeSet::from(["span".to_string()]), "r_c3 while cut off: missions {missions:?}");
    ensure!(spread(&xs) + spread(&ys) > 2.0, "r_c3 stopped while cut off: x {:.1} m, y {:.1} m of travel", spread(&xs), spread(&ys));
    // On the other side, span goes on with B's robots; central reports C's robots lost.
    let split = eventually("span replanned without r_c3", Duration::from_secs(30), || {
        let m: MissionView = op(a, SITE_ROUTER, &["mission", "show", "span"]).ok()?;
        (m.robots == ["r_b1", "r_b2"]).then_some(m)
    })?;
    eventually("span passing barriers with B's robots", Duration::from_secs(30), || {
        let m: MissionView = op(a, SITE_ROUTER, &["mission", "show", "span"]).ok()?;
        (m.metrics.sync_points_passed > split.metrics.sync_points_passed).then_some(())
    })?;
    let v: Vec<RobotView> = op(a, SITE_ROUTER, &["robots"])?;
    let lost: BTreeSet<&str> = v.iter().filter(|r| r.status == RobotStatus::Lost).map(|r| r.id.as_str()).collect();
    ensure!(lost == BTreeSet::from(["r_c1", "r_c2", "r_c3"]), "central sees lost: {lost:?}");
    println!("cut: span runs {:?} at epoch {}, central sees {lost:?} lost", split.robots, split.manager.epoch);

    // The uplink returns.
    sites.uplink(2, true)?;
    let healed = Instant::now();
    eventually("every robot back", Duration::from_secs(30), || {
        let v: Vec<RobotView> = op(a, SITE_ROUTER, &["robots"]).ok()?;
        (v.len() == 6 && v.iter().all(|r| r.status != RobotStatus::Lost)).then_some(())
    })?;
    let m = eventually("span with its three robots again", Duration::from_secs(40), || {
        let m: MissionView = op(a, SITE_ROUTER, &["mission", "show", "span"]).ok()?;
        (m.robots == ["r_b1", "r_b2", "r_c3"] && m.plans.as_ref().is_some_and(|p| p.len() == 3)).then_some(m)
    })?;
    println!("healed: span has its three robots again after {:?}, plan epoch {}", healed.elapsed(), m.manager.epoch);
    eventually("span passing barriers with all three", Duration::from_secs(30), || {
        let v: MissionView = op(a, SITE_ROUTER, &["mission", "show", "span"]).ok()?;
        (v.metrics.sync_points_passed > m.metrics.sync_points_passed && v.manager.epoch == m.manager.epoch).then_some(())
    })?;
    let l: MissionView = op(a, SITE_ROUTER, &["mission", "show", "local"])?;
    ensure!(l.robots == ["r_c1", "r_c2"], "local after the heal: {:?}", l.robots);
    let v: Vec<RobotView> = op(a, SITE_ROUTER, &["robots"])?;
    for r in &v {
        let want = match r.id.as_str() {
            "r_c1" | "r_c2" => Some("local"),
            "r_a" => None,
            _ => Some("span"),
        };
        ensure!(r.mission.as_ref().map(|x| x.as_str()) == want, "{} is in {:?} after the heal, not {want:?}", r.id, r.mission);
    }
    Ok(())
}
