//! `mrmm demo`: the embedded default. Starts central and a simulated fleet as child processes,
//! runs two concurrent missions on it (a patrol and a blanket coverage), and shows the fleet and
//! the missions live. `--formation` instead drives the robots through a rotating formation.

use std::io::{IsTerminal, Write};
use std::time::{Duration, Instant};

use anyhow::{anyhow, Context};
use mrmm_net::client::Client;
use mrmm_proto::{self as proto, GotoRequest, MissionCreate, MissionView, RobotStatus, RobotView};
use serde_json::json;
use tokio::process::Child;

use super::procs;

mod map;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Number of simulated robots.
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(1..=1000))]
    robots: u32,
    /// Stop after this many seconds (default: run until Ctrl-C).
    #[arg(long)]
    duration: Option<f64>,
    /// Endpoint central listens on; outside clients connect here (default quic/127.0.0.1:7447, or
    /// tcp/127.0.0.1:7447 with --insecure). The robots and site routers listen with its scheme.
    #[arg(long)]
    listen: Option<String>,
    /// Run the fleet over plain TCP with unsigned messages (by default the demo makes a
    /// throw-away CA and certificates and runs everything over mutual TLS 1.3: Zenoh's QUIC link).
    #[arg(long)]
    insecure: bool,
    /// Simulated seconds per wall second for every robot.
    #[arg(long, default_value_t = 1.0)]
    time_scale: f64,
    /// The fleet's link lease in ms (robots, site routers, central): how long a silent robot
    /// takes to be declared lost (default 1000, and 4000 beyond 40 robots: every robot keeps a
    /// link to every robot of its site, and on a small machine the load of a large fleet makes
    /// 1 s leases expire; see docs/scale.md).
    #[arg(long, value_parser = clap::value_parser!(u64).range(200..=60_000))]
    lease_ms: Option<u64>,
    /// Radius of the formation circle, metres.
    #[arg(long, default_value_t = 8.0)]
    radius: f64,
    /// No missions: drive the robots through a rotating formation with plain gotos.
    #[arg(long)]
    formation: bool,
    /// Record the fleet view to this .rrd file (open it with `rerun FILE.rrd`).
    #[arg(long)]
    rrd: Option<std::path::PathBuf>,
    /// Stream the fleet view to a running Rerun viewer, e.g. rerun+http://127.0.0.1:9876/proxy.
    #[arg(long)]
    viewer: Option<String>,
    /// Split the fleet into this many sites (docs/deployment.md): one `mrmm router` per site
    /// beyond central's, linked to central (over QUIC when secure), robot i a peer of site
    /// i mod SITES. Default 1: one clique.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=16))]
    sites: u32,
    /// Keep central's journal here, so the demo's missions survive a restart of it (default: the
    /// demo's scratch directory, removed when the demo ends).
    #[arg(long)]
    state_dir: Option<std::path::PathBuf>,
    /// Where the browser console listens (a loopback address; port 0: a free one). The demo
    /// prints its URL.
    #[arg(long, default_value = "127.0.0.1:0")]
    console: std::net::SocketAddr,
    /// No browser console.
    #[arg(long)]
    no_console: bool,
    /// Run the fleet in this building: a Nav2 map's YAML, a patrolling_sim .graph or an Open-RMF
    /// navigation graph (e.g. maps/data/building/building.yaml). Robots start on free cells, the
    /// missions plan routes along the corridors.
    #[arg(long)]
    map: Option<std::path::PathBuf>,
}

const TYPES: [&str; 2] = ["ground", "aerial"];

pub async fn run(mut args: Args) -> anyhow::Result<()> {
    let listen = args.listen.take().unwrap_or_else(|| if args.insecure { "tcp/127.0.0.1:7447" } else { "quic/127.0.0.1:7447" }.to_string());
    mrmm_net::net::validate_endpoints_for("--listen", std::slice::from_ref(&listen), !args.insecure).map_err(|e| anyhow!("{e}"))?;
    args.listen = Some(listen);
    if let Some(d) = args.duration {
        if !(d.is_finite() && d > 0.0) {
            return Err(anyhow!("--duration: must be a positive number of seconds (got {d})"));
        }
    }
    if args.map.is_some() && args.formation {
        return Err(anyhow!("--formation drives robots in straight lines: it does not go with --map"));
    }
    let shutdown = super::shutdown::on_signals()?;
    let dir = std::env::temp_dir().join(format!("mrmm-demo-{}", std::process::id()));
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let mut children: Vec<Child> = Vec::new();
    let result = drive(&args, &dir, &mut children, &shutdown).await;
    procs::stop_all(&mut children, Duration::from_secs(5)).await;
    if result.is_ok() {
        let _ = std::fs::remove_dir_all(&dir);
    } else {
        eprintln!("logs kept in {}", dir.display());
    }
    result
}

async fn drive(args: &Args, dir: &std::path::Path, children: &mut Vec<Child>, shutdown: &tokio_util::sync::CancellationToken) -> anyhow::Result<()> {
    let started = Instant::now();
    let building = args.map.as_deref().map(map::DemoMap::load).transpose()?;
    let starts = match &building {
        Some(b) => Some(b.starts(args.robots as usize)?),
        None => None,
    };
    let listen = args.listen.clone().unwrap_or_default();
    // Every node of the demo listens with the scheme of central's endpoint (quic, tls or tcp).
    let scheme = listen.split('/').next().unwrap_or("tcp").to_string();
    // A throw-away fleet PKI: the CA, central, the operator (this demo and your tools), each robot.
    let pki = (!args.insecure).then(|| dir.join("pki"));
    if let Some(pki) = &pki {
        use mrmm_net::security::{pki as p, Role};
        p::init(pki)?;
        p::issue(pki, Role::Central, proto::CENTRAL_HOST, &[], 30)?;
        p::issue(pki, Role::Operator, "operator", &[], 30)?;
        for i in 0..args.robots {
            p::issue(pki, Role::Robot, &format!("r{}", i + 1), &[], 30)?;
        }
        for s in 1..args.sites {
            p::issue(pki, Role::Router, &format!("site{s}"), &[], 30)?;
        }
    }
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
        listen.clone(),
        "--state-dir".into(),
        state.display().to_string(),
    ];
    if let Some(b) = &building {
        central_args.extend(["--map".into(), format!("{}={}", map::NAME, b.path.display())]);
    }
    if let Some(pki) = &pki {
        central_args.extend(["--pki".into(), pki.display().to_string(), "--operator".into(), "operator".into()]);
        if args.sites > 1 && scheme != "quic" {
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
    let sites = start_routers(args, dir, children, &endpoint, &uplink, &scheme, pki.as_deref()).await?;

    let n = args.robots as usize;
    start_robots(args, dir, children, &sites, starts.as_deref(), &scheme, pki.as_deref())?;
    let registering = progress(n, "robots registered");

    let operator = pki.as_ref().map(|d| mrmm_proto::SecuritySection::from_dir(d, "operator"));
    let client = Client::connect_with(std::slice::from_ref(&endpoint), operator.clone(), Duration::from_secs(10)).await?;
    // Where operator tools find central and the operator's certificate.
    let tool = dir.join("tool.json5");
    let security = match &operator {
        Some(s) => {
            format!(", security: {{ ca: {:?}, cert: {:?}, key: {:?} }}", s.ca.display().to_string(), s.cert.display().to_string(), s.key.display().to_string())
        }
        None => String::new(),
    };
    std::fs::write(&tool, format!("{{ connect: [{endpoint:?}]{security} }}\n")).with_context(|| format!("cannot write {}", tool.display()))?;
    // The fleet view runs here, on the client's session.
    let viz = if args.rrd.is_some() || args.viewer.is_some() {
        let sink = super::viz::sink(args.viewer.clone(), args.rrd.clone(), false);
        let stop = shutdown.child_token();
        Some((tokio::spawn(mrmm_viz::run(client.mesh().clone(), sink, stop.clone())), stop))
    } else {
        None
    };
    let tty = std::io::stdout().is_terminal();
    let deadline = args.duration.map(|d| started + Duration::from_secs_f64(d));
    let mut ticker = tokio::time::interval(Duration::from_millis(500));
    let mut formation = 0usize;
    let mut last_order: Option<Instant> = None;
    let mut missions_started = false;
    let how = if pki.is_some() { "mutual TLS, throw-away CA" } else { "INSECURE: plain TCP" };
    println!(
        "mrmm demo: central on {endpoint} ({how}); from another terminal: export {}={} and run `mrmm op robots`",
        super::security::TOOL_CONFIG_ENV,
        tool.display()
    );
    let mut banner = format!("tools    export {}={}\n", super::security::TOOL_CONFIG_ENV, tool.display());
    // The browser console, on its own operator session.
    let console = if args.no_console {
        None
    } else {
        anyhow::ensure!(args.console.ip().is_loopback(), "--console {}: the console listens on loopback only", args.console);
        let listener = tokio::net::TcpListener::bind(args.console).await.map_err(|e| anyhow::anyhow!("--console {}: {e}", args.console))?;
        let token = mrmm_console::new_token()?;
        let url = format!("http://{}/#token={token}", listener.local_addr()?);
        println!("mrmm demo: console on {url} (open it in a browser)");
        banner = format!("console  {url}\n{banner}");
        let session = Client::connect_with(std::slice::from_ref(&endpoint), operator.clone(), Duration::from_secs(10)).await?;
        let stop = shutdown.child_token();
        Some((tokio::spawn(mrmm_console::run(session, listener, token, stop.clone())), stop))
    };
    loop {
        tokio::select! {
            _ = shutdown.cancelled() => break,
            _ = ticker.tick() => {}
        }
        if deadline.is_some_and(|d| Instant::now() >= d) {
            break;
        }
        let views: Vec<RobotView> = match client.query(proto::Key::SystemRobots, None::<&()>).await {
            Ok(v) => v,
            Err(e) => {
                eprintln!("fleet query failed: {e}");
                continue;
            }
        };
        let live: Vec<&RobotView> = views.iter().filter(|v| v.status != RobotStatus::Lost).collect();
        let all_in = live.len() == n;
        if !registering.is_finished() {
            registering.set_position(live.len() as u64);
            if all_in {
                registering.finish_and_clear();
                println!("mrmm demo: {n} robots registered {:.1} s after the start", started.elapsed().as_secs_f64());
            } else {
                continue;
            }
        }
        if all_in && !args.formation && !missions_started {
            missions_started = true;
            start_missions(&client, n, building.as_ref()).await;
        }
        let missions: Vec<MissionView> = if args.formation { vec![] } else { client.query(proto::Key::SystemMissions, None::<&()>).await.unwrap_or_default() };
        let all_idle = live.iter().all(|v| v.status == RobotStatus::Idle);
        let settled = last_order.is_none_or(|t| t.elapsed() > Duration::from_secs(1));
        if args.formation && all_in && all_idle && settled {
            formation += 1;
            for (slot, v) in live.iter().enumerate() {
                let (x, y) = circle_point((slot + formation) % n, n, args.radius);
                let req = GotoRequest { robot: v.id.clone(), x, y, map: None };
                if let Err(e) = client.query::<serde_json::Value>(proto::Key::SystemCmd(proto::SystemCmd::Goto), Some(&req)).await {
                    eprintln!("goto {} failed: {e}", v.id);
                }
            }
            last_order = Some(Instant::now());
        }
        show(tty, started, &endpoint, &banner, n, &views, &missions);
    }
    if let Some((task, stop)) = viz {
        stop.cancel();
        match task.await {
            Ok(Ok(())) => {
                if let Some(p) = &args.rrd {
                    println!("mrmm demo: fleet view recorded to {}", p.display());
                }
            }
            Ok(Err(e)) => eprintln!("fleet view: {e}"),
            Err(e) => eprintln!("fleet view: {e}"),
        }
    }
    if let Some((task, stop)) = console {
        stop.cancel();
        match task.await {
            Ok(Ok(())) => {}
            Ok(Err(e)) => eprintln!("console: {e}"),
            Err(e) => eprintln!("console: {e}"),
        }
    }
    client.close().await;
    println!("mrmm demo: stopping");
    Ok(())
}

/// Starts the simulated robots from a config file per robot in `dir` (robot i is on site i mod
/// SITES): a `mrmm robot` process each up to [`LARGE_FLEET`], one `mrmm sim-fleet` per site
/// beyond (hundreds of processes would fill a small machine with their own runtimes).
fn start_robots(
    args: &Args,
    dir: &std::path::Path,
    children: &mut Vec<Child>,
    sites: &[String],
    starts: Option<&[(f64, f64)]>,
    scheme: &str,
    pki: Option<&std::path::Path>,
) -> anyhow::Result<()> {
    let n = args.robots as usize;
    let lease = lease(args);
    let mut per_site: Vec<Vec<std::path::PathBuf>> = vec![Vec::new(); sites.len()];
    for i in 0..n {
        let id = format!("r{}", i + 1);
        let at = starts.map(|s| s[i]);
        let cfg = robot_config(&id, i, n, at, &sites[i % sites.len()], scheme, args.time_scale, lease, pki);
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
    // A large fleet starts gradually, about 6 robots a second in all (one per site at least):
    // every robot's declarations invalidate every route the routers cached, and a faster start
    // loaded this 2-core machine until links expired and robots flapped (docs/scale.md).
    let rate = (START_RATE / sites.len()).max(1);
    for (k, paths) in per_site.iter().enumerate().filter(|(_, p)| !p.is_empty()) {
        let mut argv = vec!["sim-fleet".to_string(), "--rate".into(), rate.to_string()];
        argv.extend(paths.iter().flat_map(|p| ["--config".to_string(), p.display().to_string()]));
        let mut child = procs::spawn(&argv, &dir.join(format!("robots-site{k}.log")))?;
        procs::drain_stdout(&mut child);
        children.push(child);
    }
    Ok(())
}

/// The demo's screen: a header, `banner` (where the console and the tool config are: the screen
/// is redrawn in place on a terminal, so the lines printed at the start would be gone), the robots
/// and the missions.
fn show(tty: bool, started: Instant, endpoint: &str, banner: &str, n: usize, views: &[RobotView], missions: &[MissionView]) {
    let mut out = String::new();
    if tty {
        out.push_str("\x1b[H\x1b[2J");
    }
    out.push_str(&format!(
        "mrmm demo  t={:6.1}s  central {endpoint}  robots {}/{n}  missions {}  (Ctrl-C to stop)\n",
        started.elapsed().as_secs_f64(),
        views.len(),
        missions.len()
    ));
    if tty {
        out.push_str(banner);
    }
    if n <= TABLE_MAX {
        out.push_str(&super::table::robots(views));
    } else {
        out.push_str(&summary(views));
    }
    if !missions.is_empty() {
        out.push('\n');
        out.push_str(&super::op::mission::table(missions));
    }
    out.push('\n');
    let mut stdout = std::io::stdout().lock();
    let _ = stdout.write_all(out.as_bytes());
    let _ = stdout.flush();
}

/// The fleet's link lease, ms: robots, site routers and central.
fn lease(args: &Args) -> u64 {
    args.lease_ms.unwrap_or(if args.robots as usize > LARGE_FLEET { 4000 } else { 1000 })
}

/// Beyond this many robots the demo starts them gradually, with a longer lease.
const LARGE_FLEET: usize = 40;

/// Robots started per second beyond [`LARGE_FLEET`], in all sites together.
const START_RATE: usize = 6;

/// Up to this many robots the demo shows the fleet table; beyond, a summary.
const TABLE_MAX: usize = 16;

/// A progress bar on stderr (hidden when stderr is not a terminal).
fn progress(n: usize, what: &'static str) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(n as u64);
    if let Ok(style) = indicatif::ProgressStyle::with_template("{prefix:>18} [{bar:40}] {pos}/{len} {elapsed}") {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_prefix(what);
    bar
}

/// The fleet in a few lines: robots per status and per mission, and the robots needing attention.
fn summary(views: &[RobotView]) -> String {
    let count = |s: RobotStatus| views.iter().filter(|v| v.status == s).count();
    let mut per_mission: std::collections::BTreeMap<&str, usize> = std::collections::BTreeMap::new();
    for v in views {
        *per_mission.entry(v.mission.as_deref().unwrap_or("(none)")).or_default() += 1;
    }
    let mut out = format!(
        "robots: {} registered — {} busy, {} idle, {} lost\n",
        views.len(),
        count(RobotStatus::Busy),
        count(RobotStatus::Idle),
        count(RobotStatus::Lost)
    );
    let missions: Vec<String> = per_mission.iter().map(|(m, k)| format!("{m} {k}")).collect();
    out.push_str(&format!("by mission: {}\n", missions.join(", ")));
    let lost: Vec<&str> = views.iter().filter(|v| v.status == RobotStatus::Lost).map(|v| v.id.as_str()).collect();
    if !lost.is_empty() {
        let more = if lost.len() > 12 { format!(" and {} more", lost.len() - 12) } else { String::new() };
        out.push_str(&format!("lost: {}{more}\n", lost[..lost.len().min(12)].join(", ")));
    }
    out.push_str("(`mrmm op robots` lists every robot)\n");
    out
}

/// The demo's two missions: a patrol of the north waypoints with half the fleet (rounded up) and
/// a coverage of the southern field with the rest; on a map, of its northern and southern halves.
async fn start_missions(client: &Client, n: usize, building: Option<&map::DemoMap>) {
    let ids: Vec<String> = (1..=n).map(|i| format!("r{i}")).collect();
    let half = n.div_ceil(2);
    let (waypoints, region) = match building.map(map::DemoMap::params) {
        Some(Ok((w, r))) => (w, r),
        Some(Err(e)) => {
            eprintln!("cannot place the missions on the map: {e}");
            return;
        }
        None => (json!([[-15, 4], [-6, 14], [5, 17], [15, 9], [11, 1], [0, 0]]), Some(json!([[-20, -34], [20, -34], [20, -18], [-20, -18]]))),
    };
    let map = building.map(|_| map::NAME.to_string());
    let mut wanted = vec![MissionCreate {
        name: "patrol-1".into(),
        recipe: "patrol".into(),
        robots: Some(ids[..half].to_vec()),
        params: [
            ("waypoints".to_string(), waypoints),
            // The mission's standard: the advising agent speaks up when the patrol misses it.
            ("max_worst_idleness".to_string(), json!(if building.is_some() { 60 } else { 15 })),
        ]
        .into(),
        map: map.clone(),
        ..MissionCreate::default()
    }];
    if n > half {
        wanted.push(MissionCreate {
            name: "coverage-1".into(),
            recipe: "coverage".into(),
            robots: Some(ids[half..].to_vec()),
            params: region.map(|r| [("region".to_string(), r)].into()).unwrap_or_default(),
            map,
            ..MissionCreate::default()
        });
    }
    for m in wanted {
        if let Err(e) = client.query::<serde_json::Value>(proto::Key::SystemCmd(proto::SystemCmd::Create), Some(&m)).await {
            eprintln!("cannot create mission {}: {e}", m.name);
        }
    }
}

/// Slot `k` of `n` on a circle of radius `r` around the origin.
fn circle_point(k: usize, n: usize, r: f64) -> (f64, f64) {
    let a = std::f64::consts::TAU * k as f64 / n.max(1) as f64;
    ((r * a.cos() * 100.0).round() / 100.0, (r * a.sin() * 100.0).round() / 100.0)
}

/// The site routers (`--sites`): their endpoints, central's first. Each links to central's `uplink`.
async fn start_routers(
    args: &Args,
    dir: &std::path::Path,
    children: &mut Vec<Child>,
    central: &str,
    uplink: &str,
    scheme: &str,
    pki: Option<&std::path::Path>,
) -> anyhow::Result<Vec<String>> {
    let mut sites = vec![central.to_string()];
    for s in 1..args.sites {
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
    if args.sites > 1 {
        println!("mrmm demo: {} sites: central and {} routers, robot i in site i mod {}", args.sites, args.sites - 1, args.sites);
    }
    Ok(sites)
}

/// A robot's config; it starts `at` (x, y), or else on a line.
#[allow(clippy::too_many_arguments)]
fn robot_config(
    id: &str,
    i: usize,
    n: usize,
    at: Option<(f64, f64)>,
    central: &str,
    scheme: &str,
    time_scale: f64,
    lease_ms: u64,
    pki: Option<&std::path::Path>,
) -> String {
    let kind = TYPES[i % TYPES.len()];
    let (speed, turn, caps) = if kind == "aerial" { (2.0, 3.0, r#"["camera", "fly"]"#) } else { (1.0, 1.5, r#"["camera", "lidar"]"#) };
    // Rows of at most 20, 1.5 m apart, from y = -12 down (into the coverage region).
    let cols = n.min(20);
    let (x, y) = at.unwrap_or((((i % cols) as f64 - (cols as f64 - 1.0) / 2.0) * 1.5, -12.0 - (i / cols) as f64 * 1.5));
    let security = match pki {
        Some(d) => {
            let f = |name: &str| format!("{:?}", d.join(name).display().to_string());
            format!("  security: {{ ca: {}, cert: {}, key: {} }},\n", f("ca.crt"), f(&format!("{id}.crt")), f(&format!("{id}.key")))
        }
        None => String::new(),
    };
    format!(
        r#"{{
  id: "{id}", type: "{kind}", capabilities: {caps},
  kinematics: {{ max_speed: {speed}, max_turn_rate: {turn} }},
  start: {{ x: {x}, y: {y}, theta: 1.5708 }},
  time_scale: {time_scale}, telemetry_hz: 5,
  zenoh: {{ listen: ["{scheme}/127.0.0.1:0"], connect: ["{central}"], lease_ms: {lease_ms} }},
{security}}}
"#
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn generated_configs_are_valid() {
        for i in 0..4 {
            let text = robot_config(&format!("r{i}"), i, 4, None, "tcp/127.0.0.1:7447", "tcp", 2.0, 1000, None);
            let cfg = mrmm_peer::config::RobotConfig::from_json5("gen", &text).expect("valid");
            assert_eq!(cfg.time_scale, 2.0);
        }
        let text = robot_config("r1", 0, 4, Some((3.5, -2.0)), "quic/127.0.0.1:7447", "quic", 1.0, 1000, Some(std::path::Path::new("/p")));
        let cfg = mrmm_peer::config::RobotConfig::from_json5("gen", &text).expect("valid secure config");
        assert_eq!(cfg.security.map(|s| s.cert), Some(std::path::PathBuf::from("/p/r1.crt")));
        let (x, y) = circle_point(1, 4, 2.0);
        assert!((x - 0.0).abs() < 1e-9 && (y - 2.0).abs() < 1e-9);
    }
}
