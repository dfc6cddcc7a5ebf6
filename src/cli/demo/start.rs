//! Bringing the demo's fleet up: its throw-away PKI, central, the site routers and the robots,
//! each a child process with its log in the demo's directory.

use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::{anyhow, Context};
use mrmm_proto as proto;
use tokio::process::Child;

use super::{join, lease, map, sites as site_count, start_rate, Args, Join, LARGE_FLEET, TYPES};
use mrmm_node::procs;

/// A throw-away fleet PKI in `pki`: the CA, central, the operator (this demo and your tools),
/// each robot and each site router.
pub(super) fn issue_pki(args: &Args, pki: &Path) -> anyhow::Result<()> {
    use mrmm_net::security::pki as p;
    use mrmm_proto::Role;
    p::init(pki)?;
    p::issue(pki, Role::Central, proto::CENTRAL_HOST, &[], 30)?;
    p::issue(pki, Role::Operator, "operator", &[], 30)?;
    for i in 0..args.robots {
        p::issue(pki, Role::Robot, &format!("r{}", i + 1), &[], 30)?;
    }
    for s in 1..site_count(args) {
        p::issue(pki, Role::Router, &format!("site{s}"), &[], 30)?;
    }
    for i in 0..args.vda5050.unwrap_or(0) {
        p::issue(pki, Role::Robot, &format!("agv{}", i + 1), &[], 30)?;
    }
    Ok(())
}

/// Where central listens: the endpoint clients and robots use (of the demo's scheme), and the one
/// site routers link to (QUIC when secure).
pub(super) struct CentralAt {
    pub endpoint: String,
    pub uplink: String,
}

/// Starts central (with the building's map, the fleet's lease, its own state dir).
pub(super) async fn central(
    args: &Args,
    dir: &Path,
    children: &mut Vec<Child>,
    scheme: &str,
    pki: Option<&Path>,
    building: Option<&map::DemoMap>,
) -> anyhow::Result<CentralAt> {
    let listen = args.listen.clone().unwrap_or_default();
    let log = dir.join("central.log");
    let state = args.state_dir.clone().unwrap_or_else(|| dir.join("central-state"));
    // Central's lease too: under a large fleet's load, a 1 s lease expires the site routers'
    // uplinks (docs/scale.md).
    let central_cfg = dir.join("central.json5");
    std::fs::write(&central_cfg, format!("{{ lease_ms: {} }}\n", lease(args))).with_context(|| format!("cannot write {}", central_cfg.display()))?;
    let mut central_args = vec![
        "central".to_string(),
        "--config".into(),
        central_cfg.display().to_string(),
        "--listen".into(),
        listen,
        "--state-dir".into(),
        state.display().to_string(),
    ];
    if let Some(b) = building {
        central_args.extend(["--map".into(), format!("{}={}", map::NAME, b.path.display())]);
        if let Some(plan) = &b.plan {
            central_args.extend(["--floor-plan".into(), format!("{}={}", map::NAME, plan.display())]);
        }
    }
    if let Some(pki) = pki {
        central_args.extend(["--pki".into(), pki.display().to_string(), "--operator".into(), "operator".into()]);
        if site_count(args) > 1 && scheme != "quic" {
            // The routers' uplinks: QUIC (Zenoh's TLS link closes under heavy load, docs/zenoh.md).
            central_args.extend(["--listen".into(), "quic/127.0.0.1:0".into()]);
        }
    }
    let mut central = procs::spawn(&central_args, &log)?;
    let line = procs::ready_line(&mut central, "central ready", Duration::from_secs(20), &log).await;
    children.push(central);
    let line = line.context("central did not start")?;
    let listening: Vec<String> = procs::field(&line, "listening").map(|l| l.split(',').map(String::from).collect()).unwrap_or_default();
    let endpoint =
        listening.iter().find(|e| e.starts_with(&format!("{scheme}/"))).cloned().ok_or_else(|| anyhow!("central ready line without endpoint: {line}"))?;
    let uplink = listening.iter().find(|e| e.starts_with("quic/")).cloned().unwrap_or_else(|| endpoint.clone());
    Ok(CentralAt { endpoint, uplink })
}

/// Where operator tools find central and the operator's certificate (`MRMM_TOOL_CONFIG`).
pub(super) fn tool_config(dir: &Path, endpoint: &str, operator: Option<&proto::SecuritySection>) -> anyhow::Result<PathBuf> {
    let tool = dir.join("tool.json5");
    let security = match operator {
        Some(s) => {
            format!(", security: {{ ca: {:?}, cert: {:?}, key: {:?} }}", s.ca.display().to_string(), s.cert.display().to_string(), s.key.display().to_string())
        }
        None => String::new(),
    };
    std::fs::write(&tool, format!("{{ connect: [{endpoint:?}]{security} }}\n")).with_context(|| format!("cannot write {}", tool.display()))?;
    Ok(tool)
}

/// The site routers (`--sites`): their endpoints, central's first. Each links to central's `uplink`.
pub(super) async fn routers(
    args: &Args,
    dir: &Path,
    children: &mut Vec<Child>,
    central: &str,
    uplink: &str,
    scheme: &str,
    pki: Option<&Path>,
) -> anyhow::Result<Vec<String>> {
    let mut sites = vec![central.to_string()];
    for s in 1..site_count(args) {
        let id = format!("site{s}");
        let path = dir.join(format!("{id}.json5"));
        std::fs::write(&path, format!("{{ id: {id:?}, listen: [\"{scheme}/127.0.0.1:0\"], connect: [{uplink:?}], lease_ms: {} }}\n", lease(args)))
            .with_context(|| format!("cannot write {}", path.display()))?;
        let mut cmd = vec!["router".to_string(), "--config".into(), path.display().to_string()];
        if let Some(pki) = pki {
            cmd.extend(["--pki".into(), pki.display().to_string()]);
        }
        let log = dir.join(format!("{id}.log"));
        let mut router = procs::spawn(&cmd, &log)?;
        let line = procs::ready_line(&mut router, "router ready", Duration::from_secs(20), &log).await;
        children.push(router);
        let line = line.with_context(|| format!("router {id} did not start"))?;
        let ep = procs::field(&line, "listening").and_then(|l| l.split(',').next()).ok_or_else(|| anyhow!("router ready line without endpoint: {line}"))?;
        sites.push(ep.to_string());
    }
    Ok(sites)
}

/// Starts the simulated robots from a config file per robot in `dir` (robot i is on site i mod
/// SITES): a `mrmm robot` process each up to [`LARGE_FLEET`], one `mrmm sim-fleet` per site
/// beyond (hundreds of processes would fill a small machine with their own runtimes).
pub(super) fn robots(
    args: &Args,
    dir: &Path,
    children: &mut Vec<Child>,
    sites: &[String],
    starts: Option<&[(f64, f64)]>,
    scheme: &str,
    pki: Option<&Path>,
) -> anyhow::Result<()> {
    let n = args.robots as usize;
    let net = Net { scheme, lease_ms: lease(args), join: join(args), pki, battery_life: args.battery_life };
    let mut per_site: Vec<Vec<PathBuf>> = vec![Vec::new(); sites.len()];
    for i in 0..n {
        let id = format!("r{}", i + 1);
        let at = starts.map(|s| s[i]);
        let cfg = robot_config(&id, i, n, at, &connect(sites, i % sites.len(), net.join), args.time_scale, &net);
        let path = dir.join(format!("{id}.json5"));
        std::fs::write(&path, cfg).with_context(|| format!("cannot write {}", path.display()))?;
        per_site[i % sites.len()].push(path);
    }
    if n <= LARGE_FLEET {
        // A process per robot: `pkill -f rN.json5` crashes one, as a robot's computer would.
        for path in per_site.iter().flatten() {
            children.push(procs::spawn(&["robot".to_string(), "--config".into(), path.display().to_string()], &path.with_extension("log"))?);
        }
        return Ok(());
    }
    // A large fleet starts gradually, `--start-rate` robots a second in all (one per site at least):
    // every robot's declarations invalidate every route the routers cached, and a faster start
    // loaded this 2-core machine until links expired and robots flapped (docs/scale.md).
    let rate = (start_rate(args) as usize / sites.len()).max(1);
    for (k, paths) in per_site.iter().enumerate().filter(|(_, p)| !p.is_empty()) {
        let mut argv = vec!["sim-fleet".to_string(), "--rate".into(), rate.to_string()];
        argv.extend(paths.iter().flat_map(|p| ["--config".to_string(), p.display().to_string()]));
        let mut child = procs::spawn(&argv, &dir.join(format!("robots-site{k}.log")))?;
        procs::drain_stdout(&mut child);
        children.push(child);
    }
    Ok(())
}

/// The demo's vehicles' manufacturer (the topics' third level).
const MANUFACTURER: &str = "mrmm";

/// The demo's VDA 5050 vehicles: how many, the map they report on, where they start.
pub(super) struct Vehicles<'a> {
    pub n: usize,
    pub map_id: &'a str,
    pub at: Option<&'a [(f64, f64)]>,
}

/// `--vda5050 N`: N simulated VDA 5050 vehicles on an MQTT broker of their own (`mrmm
/// vda5050-sim`), starting `at` (else in a row below the robots), and the gateway that makes
/// each a robot of the fleet (`mrmm vda5050`), its robots clients of central.
pub(super) async fn vda5050(
    args: &Args,
    dir: &Path,
    children: &mut Vec<Child>,
    central: &str,
    pki: Option<&Path>,
    vehicles: &Vehicles<'_>,
) -> anyhow::Result<()> {
    let Vehicles { n, map_id, at } = *vehicles;
    let mut sim =
        vec!["vda5050-sim".to_string(), "--vehicles".into(), n.to_string(), "--listen".into(), "127.0.0.1:0".into(), "--map-id".into(), map_id.into()];
    // Below the robots' rows (20 a row, 1.5 m apart, from y = -12 down).
    let below = -12.0 - (args.robots as usize).div_ceil(20) as f64 * 1.5 - 1.5;
    for i in 0..n {
        let (x, y) = at.and_then(|a| a.get(i).copied()).unwrap_or(((i as f64 - (n as f64 - 1.0) / 2.0) * 1.5, below));
        sim.push(format!("--at={x},{y}"));
    }
    let log = dir.join("vda5050-sim.log");
    let mut child = procs::spawn(&sim, &log)?;
    let line = procs::ready_line(&mut child, "vda5050-sim ready", Duration::from_secs(20), &log).await;
    children.push(child);
    let line = line.context("the simulated VDA 5050 vehicles did not start")?;
    let broker = procs::field(&line, "broker").ok_or_else(|| anyhow!("vda5050-sim ready line without broker: {line}"))?.to_string();
    let robot = dir.join("agv.json5");
    let scheme = central.split('/').next().unwrap_or("tcp");
    std::fs::write(
        &robot,
        format!(
            r#"{{ id: "agv", type: "ground", capabilities: ["camera", "lidar"], kinematics: {{ max_speed: 1.0, max_turn_rate: 1.5 }}, telemetry_hz: 5,
  zenoh: {{ mode: "client", listen: ["{scheme}/127.0.0.1:0"], connect: [{central:?}], lease_ms: {} }} }}
"#,
            lease(args)
        ),
    )
    .with_context(|| format!("cannot write {}", robot.display()))?;
    // The fleet ids: agvK for the vehicle of serial number agvK.
    let ids: Vec<String> = (1..=n).map(|i| format!("\"{MANUFACTURER}/agv{i}\": \"agv{i}\"")).collect();
    let cfg = dir.join("vda5050.json5");
    std::fs::write(&cfg, format!("{{ broker: {broker:?}, map: {map_id:?}, robot: \"agv.json5\", ids: {{ {} }} }}\n", ids.join(", ")))
        .with_context(|| format!("cannot write {}", cfg.display()))?;
    let mut gw = vec!["vda5050".to_string(), "--config".into(), cfg.display().to_string()];
    if let Some(pki) = pki {
        gw.extend(["--pki".into(), pki.display().to_string()]);
    }
    let log = dir.join("vda5050.log");
    let mut child = procs::spawn(&gw, &log)?;
    let line = procs::ready_line(&mut child, "vda5050 ready", Duration::from_secs(20), &log).await;
    children.push(child);
    line.context("the VDA 5050 gateway did not start")?;
    println!("mrmm demo: {n} VDA 5050 vehicles on {broker} (the demo's own broker), in the fleet through `mrmm vda5050`");
    Ok(())
}

/// How the demo's robots join the mesh.
struct Net<'a> {
    scheme: &'a str,
    lease_ms: u64,
    join: Join,
    pki: Option<&'a Path>,
    /// `--battery-life`: seconds a full charge drives.
    battery_life: Option<f64>,
}

/// Where a robot of site `k` connects: its site's router (central for site 0); a client then
/// the next site's, which it falls back to when its own drops (a peer would link to both).
fn connect(sites: &[String], k: usize, join: Join) -> Vec<String> {
    let mut eps = vec![sites[k].clone()];
    if join == Join::Client && sites.len() > 1 {
        eps.push(sites[(k + 1) % sites.len()].clone());
    }
    eps
}

/// A robot's config; it starts `at` (x, y), or else on a line.
fn robot_config(id: &str, i: usize, n: usize, at: Option<(f64, f64)>, connect: &[String], time_scale: f64, net: &Net<'_>) -> String {
    let Net { scheme, lease_ms, join, pki, battery_life } = *net;
    let kind = TYPES[i % TYPES.len()];
    let (speed, turn, caps) = if kind == "aerial" { (2.0, 3.0, r#"["camera", "fly"]"#) } else { (1.0, 1.5, r#"["camera", "lidar"]"#) };
    // Rows of at most 20, 1.5 m apart, from y = -12 down (into the coverage region).
    let cols = n.min(20);
    let (x, y) = at.unwrap_or((((i % cols) as f64 - (cols as f64 - 1.0) / 2.0) * 1.5, -12.0 - (i / cols) as f64 * 1.5));
    let mode = if join == Join::Client { "client" } else { "peer" };
    let security = match pki {
        Some(d) => {
            let f = |name: &str| format!("{:?}", d.join(name).display().to_string());
            format!("  security: {{ ca: {}, cert: {}, key: {} }},\n", f("ca.crt"), f(&format!("{id}.crt")), f(&format!("{id}.key")))
        }
        None => String::new(),
    };
    // Charges spread from full (r1) down to half, so that they do not all run out at once.
    let battery = match battery_life {
        Some(life) => format!("  battery: {{ life_s: {life}, charge: {:.3} }},\n", 1.0 - 0.5 * i as f64 / n.max(2) as f64),
        None => String::new(),
    };
    format!(
        r#"{{
  id: "{id}", type: "{kind}", capabilities: {caps},
  kinematics: {{ max_speed: {speed}, max_turn_rate: {turn} }},
  start: {{ x: {x}, y: {y}, theta: 1.5708 }},
  time_scale: {time_scale}, telemetry_hz: 5,
  zenoh: {{ mode: "{mode}", listen: ["{scheme}/127.0.0.1:0"], connect: {connect:?}, lease_ms: {lease_ms} }},
{security}{battery}}}
"#
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn generated_configs_are_valid() {
        let plain = Net { scheme: "tcp", lease_ms: 1000, join: Join::Peer, pki: None, battery_life: None };
        for i in 0..4 {
            let text = robot_config(&format!("r{i}"), i, 4, None, &["tcp/127.0.0.1:7447".into()], 2.0, &plain);
            let cfg = mrmm_peer::config::RobotConfig::from_json5("gen", &text).expect("valid");
            assert_eq!((cfg.time_scale, cfg.zenoh.mode), (2.0, mrmm_net::net::JoinMode::Peer));
            assert!(cfg.battery.is_none());
        }
        let batteries = Net { battery_life: Some(90.0), ..plain };
        for i in 0..4 {
            let text = robot_config(&format!("r{i}"), i, 4, None, &["tcp/127.0.0.1:7447".into()], 2.0, &batteries);
            let b = mrmm_peer::config::RobotConfig::from_json5("gen", &text).expect("valid").setup().battery.expect("a battery");
            assert!((b.charge() - (1.0 - 0.5 * i as f64 / 4.0)).abs() < 1e-3, "r{i}: {}", b.charge());
        }
        let sites = ["quic/127.0.0.1:7447".to_string(), "quic/127.0.0.1:7500".into(), "quic/127.0.0.1:7501".into()];
        assert_eq!(connect(&sites, 1, Join::Peer), &sites[1..2], "a peer: its site only");
        assert_eq!(connect(&sites, 2, Join::Client), [sites[2].clone(), sites[0].clone()], "a client: its site, then the next");
        let secure = Net { scheme: "quic", lease_ms: 4000, join: Join::Client, pki: Some(std::path::Path::new("/p")), battery_life: None };
        let text = robot_config("r1", 0, 4, Some((3.5, -2.0)), &connect(&sites, 0, Join::Client), 1.0, &secure);
        let cfg = mrmm_peer::config::RobotConfig::from_json5("gen", &text).expect("valid secure config");
        assert_eq!(cfg.security.map(|s| s.cert), Some(std::path::PathBuf::from("/p/r1.crt")));
        assert_eq!((cfg.zenoh.mode, cfg.zenoh.connect), (mrmm_net::net::JoinMode::Client, sites[..2].to_vec()));
        let (x, y) = super::super::watch::circle_point(1, 4, 2.0);
        assert!((x - 0.0).abs() < 1e-9 && (y - 2.0).abs() < 1e-9);
    }
}
