//! `mrmm demo`: the embedded default. Starts central and a simulated fleet as child processes,
//! runs two concurrent missions on it (a patrol and a blanket coverage), and shows the fleet and
//! the missions live. `--formation` instead drives the robots through a rotating formation.

use std::io::IsTerminal;
use std::time::{Duration, Instant};

use anyhow::{anyhow, Context};
use mrmm_net::client::Client;
use tokio::process::Child;

use mrmm_node::procs;

mod map;
mod start;
mod watch;

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
    /// Robots started per second beyond 40 robots, in all sites together (default: 30 when they
    /// join as clients, 6 as peers). On a 2-core machine 300 robots start at 30 a second as
    /// clients; as peers, faster than 6 made every robot flap (docs/scale.md).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1000))]
    start_rate: Option<u32>,
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
    /// beyond central's, linked to central (over QUIC when secure), robot i in site i mod SITES.
    /// Default: one site up to 40 robots; beyond, a site per 50 robots (2 to 10), which holds on
    /// a 2-core machine (docs/scale.md). The demo says which layout it chose.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=16))]
    sites: Option<u32>,
    /// How each robot joins the mesh: `peer` (a link to every robot of its site, which goes on
    /// without its router) or `client` (one link, to its site's router, then central or another
    /// site's router if that drops). Default: `client` beyond 40 robots in several sites, `peer`
    /// otherwise (docs/deployment.md).
    #[arg(long, value_enum)]
    join: Option<Join>,
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
    /// The floor plan a graph --map is drawn on (a Nav2 map's YAML in its frame, e.g.
    /// maps/data/patrolling_sim/DIAG_floor1.yaml beside DIAG_floor1.graph): robots pass each
    /// other on lanes where it has room for two side by side.
    #[arg(long, requires = "map")]
    floor_plan: Option<std::path::PathBuf>,
    /// Give every robot a battery that a full charge lets drive this many simulated seconds at
    /// its top speed (they start between half and fully charged), to watch batteries run down in
    /// minutes (docs/operating.md).
    #[arg(long, value_parser = positive_seconds)]
    battery_life: Option<f64>,
    /// Add N simulated VDA 5050 vehicles (agv1 … agvN) beside the robots: an MQTT broker of the
    /// demo's own (nothing to install), the vehicles on it, and the VDA 5050 gateway that makes
    /// each a fleet robot; they take part in the same missions (docs/vda5050.md).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=200))]
    vda5050: Option<u32>,
}

/// Robots and VDA 5050 vehicles together.
fn fleet(args: &Args) -> usize {
    args.robots as usize + args.vda5050.unwrap_or(0) as usize
}

/// A positive, finite number of seconds.
fn positive_seconds(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 && v <= 1e7 => Ok(v),
        Ok(v) => Err(format!("{v} is not a number of seconds within (0, 10000000]")),
        Err(e) => Err(format!("{s:?} is not a number: {e}")),
    }
}

const TYPES: [&str; 2] = ["ground", "aerial"];

/// `--join`: how the robots join the mesh (a robot config's `zenoh.mode`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Join {
    Peer,
    Client,
}

/// Robots started per second in a large fleet: as asked, or as fast as this 2-core machine took
/// 300 of them joining that way.
fn start_rate(args: &Args) -> u32 {
    args.start_rate.unwrap_or(if join(args) == Join::Client { 30 } else { 6 })
}

/// How the demo's robots join: as asked, or clients of their site's router in a large fleet of
/// several sites (a site of 50 peers keeps 1 225 links; 50 clients, 50).
fn join(args: &Args) -> Join {
    args.join.unwrap_or(if args.robots as usize > LARGE_FLEET && sites(args) > 1 { Join::Client } else { Join::Peer })
}

/// Robots per site the demo plans for beyond [`LARGE_FLEET`] robots.
const ROBOTS_PER_SITE: usize = 50;
/// The most sites the demo chooses by itself (`--sites` goes to 16).
const MAX_AUTO_SITES: usize = 10;

/// How many sites the fleet runs in: as asked, or one up to [`LARGE_FLEET`] robots and a site
/// per [`ROBOTS_PER_SITE`] beyond (2 to [`MAX_AUTO_SITES`]). One site of 100 peers on a 2-core
/// machine flapped lost/back and its creates timed out; 300 robots in six sites as clients hold
/// with no robot lost (docs/scale.md).
fn sites(args: &Args) -> u32 {
    args.sites.unwrap_or_else(|| auto_sites(args.robots as usize))
}

fn auto_sites(robots: usize) -> u32 {
    if robots <= LARGE_FLEET {
        1
    } else {
        robots.div_ceil(ROBOTS_PER_SITE).clamp(2, MAX_AUTO_SITES) as u32
    }
}

/// The layout chosen, in one line: what `--sites`, `--join`, `--start-rate` and `--lease-ms`
/// came to.
fn layout_line(args: &Args) -> String {
    let n = args.robots as usize;
    let k = sites(args);
    let place = if k == 1 { "one site (central's)".to_string() } else { format!("{k} sites (central and {} routers)", k - 1) };
    let how = match join(args) {
        Join::Client => "each a client of its site's router",
        Join::Peer if k == 1 => "peers of one clique",
        Join::Peer => "peers of their site's clique",
    };
    let procs = if n > LARGE_FLEET { format!(", a sim-fleet process per site starting {} a second", start_rate(args)) } else { ", a process each".to_string() };
    let chosen = if args.sites.is_none() && k > 1 { " (chosen for the fleet's size; --sites N to change)" } else { "" };
    let mut line = format!("mrmm demo: {n} robots in {place}, {how}{procs}, lease {} ms{chosen}", lease(args));
    let cores = std::thread::available_parallelism().map_or(1, |c| c.get());
    if n > ROBOTS_PER_CORE * cores {
        line.push_str(&format!(
            "\nmrmm demo: more than this {cores}-core machine is known to hold ({} robots: {ROBOTS_PER_CORE} a core, docs/scale.md); robots may be lost",
            ROBOTS_PER_CORE * cores
        ));
    }
    line
}

/// Simulated robots (with central, routers and two missions) a core was seen to hold: 300 in six
/// sites on 2 cores with no robot lost; 1 000 in ten sites on 16 cores did not hold (central's
/// router, docs/scale.md).
const ROBOTS_PER_CORE: usize = 150;

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
    let building = args.map.as_deref().map(|m| map::DemoMap::load(m, args.floor_plan.as_deref())).transpose()?;
    let starts = match &building {
        Some(b) => Some(b.starts(fleet(args))?),
        None => None,
    };
    // Every node of the demo listens with the scheme of central's endpoint (quic, tls or tcp).
    let scheme = args.listen.as_deref().and_then(|l| l.split('/').next()).unwrap_or("tcp").to_string();
    println!("{}", layout_line(args));
    if let Some(line) = building.as_ref().and_then(map::DemoMap::plan_line) {
        println!("mrmm demo: {line}");
    }
    let pki = (!args.insecure).then(|| dir.join("pki"));
    if let Some(pki) = &pki {
        start::issue_pki(args, pki)?;
    }
    let at = start::central(args, dir, children, &scheme, pki.as_deref(), building.as_ref()).await?;
    let sites = start::routers(args, dir, children, &at.endpoint, &at.uplink, &scheme, pki.as_deref()).await?;
    start::robots(args, dir, children, &sites, starts.as_deref(), &scheme, pki.as_deref())?;
    if let Some(n) = args.vda5050 {
        let spots = starts.as_ref().map(|s| s[args.robots as usize..].to_vec());
        let vehicles = start::Vehicles { n: n as usize, map_id: if building.is_some() { map::NAME } else { "demo" }, at: spots.as_deref() };
        start::vda5050(args, dir, children, &at.endpoint, pki.as_deref(), &vehicles).await?;
    }

    let operator = pki.as_ref().map(|d| mrmm_proto::SecuritySection::from_dir(d, "operator"));
    let client = Client::connect_with(std::slice::from_ref(&at.endpoint), operator.clone(), Duration::from_secs(10)).await?;
    let tool = start::tool_config(dir, &at.endpoint, operator.as_ref())?;
    let how = if pki.is_some() { "mutual TLS, throw-away CA" } else { "INSECURE: plain TCP" };
    let tools = format!("export {}={}", super::security::TOOL_CONFIG_ENV, tool.display());
    println!("mrmm demo: central on {} ({how}); from another terminal: {tools} and run `mrmm op robots`", at.endpoint);
    let views = Views::start(args, &client, &at.endpoint, operator, shutdown).await?;
    let banner = match &views.console_url {
        Some(url) => format!("console  {url}\ntools    {tools}\n"),
        None => format!("tools    {tools}\n"),
    };
    let watch =
        watch::Watch { args, client: &client, building: building.as_ref(), started, endpoint: &at.endpoint, banner, tty: std::io::stdout().is_terminal() };
    watch.run(shutdown).await;
    views.stop(args).await;
    client.close().await;
    println!("mrmm demo: stopping");
    Ok(())
}

/// What shows the fleet besides the demo's screen: the fleet view (Rerun) on the demo's session,
/// the browser console on its own.
struct Views {
    viz: Option<Task>,
    console: Option<Task>,
    console_url: Option<String>,
}

type Task = (tokio::task::JoinHandle<anyhow::Result<()>>, tokio_util::sync::CancellationToken);

impl Views {
    async fn start(
        args: &Args,
        client: &Client,
        endpoint: &str,
        operator: Option<mrmm_proto::SecuritySection>,
        shutdown: &tokio_util::sync::CancellationToken,
    ) -> anyhow::Result<Views> {
        let viz = (args.rrd.is_some() || args.viewer.is_some()).then(|| {
            let sink = super::viz::sink(args.viewer.clone(), args.rrd.clone(), false);
            let stop = shutdown.child_token();
            let mesh = client.mesh().clone();
            let run = mrmm_viz::run(mesh, sink, stop.clone());
            (tokio::spawn(async move { run.await.map_err(anyhow::Error::from) }), stop)
        });
        if args.no_console {
            return Ok(Views { viz, console: None, console_url: None });
        }
        anyhow::ensure!(args.console.ip().is_loopback(), "--console {}: the console listens on loopback only", args.console);
        let listener = tokio::net::TcpListener::bind(args.console).await.map_err(|e| anyhow!("--console {}: {e}", args.console))?;
        let token = mrmm_console::new_token()?;
        let url = format!("http://{}/#token={token}", listener.local_addr()?);
        println!("mrmm demo: console on {url} (open it in a browser)");
        let session = Client::connect_with(&[endpoint.to_string()], operator, Duration::from_secs(10)).await?;
        let stop = shutdown.child_token();
        let run = mrmm_console::run(session, listener, token, stop.clone());
        let console = (tokio::spawn(async move { run.await.map_err(anyhow::Error::from) }), stop);
        Ok(Views { viz, console: Some(console), console_url: Some(url) })
    }

    /// Stops both and says how they ended.
    async fn stop(self, args: &Args) {
        for (what, task) in [("fleet view", self.viz), ("console", self.console)] {
            let Some((task, stop)) = task else { continue };
            stop.cancel();
            match task.await {
                Ok(Ok(())) if what == "fleet view" => {
                    if let Some(p) = &args.rrd {
                        println!("mrmm demo: fleet view recorded to {}", p.display());
                    }
                }
                Ok(Ok(())) => {}
                Ok(Err(e)) => eprintln!("{what}: {e}"),
                Err(e) => eprintln!("{what}: {e}"),
            }
        }
    }
}

/// The fleet's link lease, ms: robots, site routers and central.
fn lease(args: &Args) -> u64 {
    args.lease_ms.unwrap_or(if args.robots as usize > LARGE_FLEET { 4000 } else { 1000 })
}

/// Beyond this many robots the demo starts them gradually, with a longer lease.
const LARGE_FLEET: usize = 40;
