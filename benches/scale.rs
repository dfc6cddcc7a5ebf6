//! What a fleet of N robots costs on this machine, one `mrmm robot` process per robot, as
//! deployed and as `mrmm demo` runs them: mutual TLS, signed messages, telemetry at 5 Hz (bodies
//! simulated 5× faster than real time, for more barriers in the measured window), lease
//! 1000 ms, every robot connecting to central only (the robots find each other by gossip and form
//! a clique).
//!
//! For each N: the time until every process is up (ready line) and until central has registered
//! them all; memory (RSS) per robot process and of central; CPU of the whole fleet while idle
//! (no mission) over 10 s; the number of Zenoh links (established loopback TCP connections
//! between the fleet's processes) and loopback packets per second while idle (keep-alives,
//! telemetry, liveliness); the latency from a mission create of N/2 robots to every one of them
//! moving (seen in their telemetry, 5 Hz: ±200 ms); operator query round trips while that mission
//! runs; barrier release latency in that mission (each member logs the instant it releases; the
//! last member to arrive releases at once, in the tick it publishes its arrival, so every other
//! member's latency is its release minus that first release — one machine's clock, 20 ms ticks);
//! and the time from a member's SIGKILL to the mission's new plan without it. Two missions run
//! (a patrol and a coverage, N/2 robots each; `--patrol K`: K robots in the patrol, the rest in
//! the coverage); "create→all moving" is from the first create to every member of both moving;
//! the patrol's barriers are measured; then the fleet runs for `--run S` seconds (default 20; the
//! issue's "2-minute run" is `--run 120`) and the robots lost meanwhile are counted from central's
//! journal, before any crash.
//!
//! With `--sites K`, the multi-site layout (docs/deployment.md): K − 1 site routers
//! (`mrmm router`, linked to central), robot i a peer of site i mod K (site 0 is central's); the
//! routers count with the fleet (CPU, links).
//!
//! With `--insecure`: plain TCP and unsigned messages (what security costs at scale). `BENCH_LOG`
//! replaces the processes' `RUST_LOG` (their logs are in the run's scratch directory).
//!
//! Secure links are QUIC (mutual TLS 1.3 over UDP), as a secure fleet runs. With `--tls`: Zenoh's
//! TLS link instead (it races under load, docs/zenoh.md), and with `--tls --quic-uplinks` the
//! routers link to central over QUIC, the robots' links staying TLS.
//!
//! With `--sim-fleet`: the robots of each site in one `mrmm sim-fleet` process (memory per robot
//! is the process's over its robots; a member is crashed in its process instead of SIGKILLed).
//!
//! With `--clients`: every robot a client of its site's router (`zenoh.mode: client`, the next
//! site's router as fallback) instead of a peer of its site's clique.
//!
//! `cargo bench --bench scale -- 25 50 100 [--lease MS] [--rate R] [--sites K] [--run S] [--insecure] [--tls [--quic-uplinks]] [--sim-fleet] [--clients]` (sizes, default
//! 10 25; the robots' lease, default as `mrmm demo` sets it: 1000 ms, 4000 ms beyond 40 robots;
//! robots started R per second, default 20 as the demo does, 0 = all at once; default 1 site).

#[path = "../tests/common/mod.rs"]
mod common;

use std::collections::BTreeSet;
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use anyhow::{anyhow, Context};
use common::measure::{cpu_ticks, quantile, USER_HZ};
use common::{eventually, Scratch};
use mrmm_net::client::Client;
use mrmm_proto::{self as proto, MissionCreate, MissionView, RobotStatus, RobotView};

/// A child killed on drop.
struct Kid(Child);

impl Drop for Kid {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// `--patrol K`: the patrol's robots (the coverage gets the rest); N/2 by default.
fn patrol_size(n: usize) -> usize {
    let args: Vec<String> = std::env::args().collect();
    args.windows(2).find(|w| w[0] == "--patrol").and_then(|w| w[1].parse().ok()).unwrap_or(n / 2).min(n)
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let opt = |name: &str| args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).and_then(|v| v.parse::<u64>().ok());
    let lease = opt("--lease");
    let rate = opt("--rate").unwrap_or(20);
    let sites = opt("--sites").unwrap_or(1).max(1) as usize;
    let insecure = args.iter().any(|a| a == "--insecure");
    let quic = args.iter().any(|a| a == "--quic-uplinks");
    let mut sizes: Vec<usize> = args
        .iter()
        .enumerate()
        .filter(|(i, _)| *i == 0 || !args[i - 1].starts_with("--"))
        .filter_map(|(_, a)| a.parse().ok())
        .filter(|&n: &usize| n >= 2)
        .collect();
    if sizes.is_empty() {
        sizes = vec![10, 25];
    }
    let rt = tokio::runtime::Builder::new_multi_thread().worker_threads(2).enable_all().build()?;
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| s.lines().find(|l| l.starts_with("model name")).and_then(|l| l.split(':').nth(1)).map(|s| s.trim().to_string()))
        .unwrap_or_default();
    println!(
        "\n### Scale: {} ({cpu}, {} cores; {}; lease {}; robots started {}{})\n",
        if sim_fleet() { "one sim-fleet process per site" } else { "one process per robot" },
        std::thread::available_parallelism().map_or(0, |n| n.get()),
        match (sites, clients()) {
            (1, false) => "one clique".to_string(),
            (1, true) => "robots clients of central".to_string(),
            (k, false) => format!("{k} sites"),
            (k, true) => format!("{k} sites, robots clients of their router"),
        },
        lease.map_or("as the demo: 1000 ms, 4000 ms beyond 40 robots".to_string(), |l| format!("{l} ms")),
        if rate == 0 { "at once".to_string() } else { format!("{rate} per second") },
        if insecure {
            "; INSECURE: plain TCP, unsigned"
        } else if args_tls() && quic {
            "; TLS links, routers linked to central over QUIC"
        } else if args_tls() {
            "; TLS links"
        } else {
            "; QUIC links"
        }
    );
    println!("| N | lease ms | all up s | all registered s | RSS/robot MiB (mean/max) | RSS central MiB | idle CPU % of a core (central) | links | idle loopback pkt/s | create→all moving s | query p50/p99 ms | barrier release p50/p99 ms | lost in the run | SIGKILL→replanned s | 10 % at once → replans, s |");
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for n in sizes {
        rt.block_on(run(n, lease.unwrap_or(if n > 40 { 4000 } else { 1000 }), rate, sites, insecure, quic))?;
    }
    Ok(())
}

fn spawn(args: &[&str], log: &Path) -> anyhow::Result<Child> {
    spawn_with(args, log, Stdio::null())
}

fn spawn_with(args: &[&str], log: &Path, stdin: Stdio) -> anyhow::Result<Child> {
    Command::new(common::EXE)
        .args(args)
        .env("RUST_LOG", std::env::var("BENCH_LOG").unwrap_or("info,zenoh=warn,mrmm_peer::barrier=debug".into()))
        .env("NO_COLOR", "1")
        .env("XDG_DATA_HOME", log.parent().unwrap_or(Path::new(".")).join("data"))
        .stdin(stdin)
        .stdout(Stdio::piped())
        .stderr(std::fs::File::create(log)?)
        .spawn()
        .context("spawn mrmm")
}

/// Waits for each child's line starting with `prefix`; returns the lines.
fn ready_lines(kids: &mut [Kid], prefix: &str, timeout: Duration) -> anyhow::Result<Vec<String>> {
    let (tx, rx) = std::sync::mpsc::channel();
    for (i, k) in kids.iter_mut().enumerate() {
        let out = k.0.stdout.take().ok_or_else(|| anyhow!("no stdout"))?;
        let (tx, prefix) = (tx.clone(), prefix.to_string());
        std::thread::spawn(move || {
            for line in BufReader::new(out).lines().map_while(Result::ok) {
                if line.starts_with(&prefix) {
                    let _ = tx.send((i, line));
                }
            }
        });
    }
    let mut lines = vec![String::new(); kids.len()];
    let deadline = Instant::now() + timeout;
    for _ in 0..kids.len() {
        let (i, l) =
            rx.recv_timeout(deadline.saturating_duration_since(Instant::now())).map_err(|_| anyhow!("not every process was ready within {timeout:?}"))?;
        lines[i] = l;
    }
    Ok(lines)
}

fn rss_mib(pid: u32) -> f64 {
    let s = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap_or_default();
    s.lines().find_map(|l| l.strip_prefix("VmRSS:")).and_then(|v| v.split_whitespace().next()?.parse::<f64>().ok()).unwrap_or(0.0) / 1024.0
}

fn lo_packets() -> u64 {
    std::fs::read_to_string("/sys/class/net/lo/statistics/tx_packets").ok().and_then(|s| s.trim().parse().ok()).unwrap_or(0)
}

/// Established TCP connections between two of `pids`: Zenoh links (each has two ends here).
fn links(pids: &[u32]) -> usize {
    let mut inodes = BTreeSet::new();
    for pid in pids {
        let Ok(fds) = std::fs::read_dir(format!("/proc/{pid}/fd")) else { continue };
        for fd in fds.flatten() {
            if let Ok(t) = std::fs::read_link(fd.path()) {
                if let Some(i) = t.to_str().and_then(|s| s.strip_prefix("socket:[")).and_then(|s| s.strip_suffix(']')) {
                    inodes.insert(i.to_string());
                }
            }
        }
    }
    let tcp = std::fs::read_to_string("/proc/net/tcp").unwrap_or_default();
    let ends = tcp
        .lines()
        .skip(1)
        .filter(|l| {
            let f: Vec<&str> = l.split_whitespace().collect();
            f.get(3) == Some(&"01") && f.get(9).is_some_and(|i| inodes.contains(*i))
        })
        .count();
    ends / 2
}

/// Crashes `victims` at once: SIGKILL of their processes, or one `kill` line to each site's
/// `sim-fleet` (robot `rK` is on site K mod `sites`).
fn crash(robots: &mut [Kid], sites: usize, victims: &[String]) -> anyhow::Result<()> {
    use std::io::Write;
    let index = |id: &String| id.trim_start_matches('r').parse::<usize>().context("robot id");
    if !sim_fleet() {
        for v in victims {
            let _ = robots[index(v)? - 1].0.kill();
        }
        return Ok(());
    }
    let mut per_site = vec![Vec::new(); sites];
    for v in victims {
        per_site[index(v)? % sites].push(v.as_str());
    }
    for (s, ids) in per_site.iter().enumerate().filter(|(_, ids)| !ids.is_empty()) {
        if let Some(stdin) = robots[s].0.stdin.as_mut() {
            writeln!(stdin, "kill {}", ids.join(" "))?;
        }
    }
    Ok(())
}

/// Seconds from `since` until the mission's status shows it running a plan of an epoch after
/// `epoch` without any of `victims` (within 30 s), and the last status seen 3 s later (more
/// replans for the same losses would show there).
async fn replanned_without(
    status: &zenoh::pubsub::Subscriber<zenoh::handlers::RingChannelHandler<zenoh::sample::Sample>>,
    victims: &[String],
    epoch: u64,
    since: Instant,
) -> (Option<f64>, Option<MissionView>) {
    let next = |timeout: Duration| async move {
        let s = tokio::time::timeout(timeout, status.recv_async()).await.ok()?.ok()?;
        proto::from_json::<MissionView>("status", &s.payload().to_bytes()).ok()
    };
    let deadline = since + Duration::from_secs(30);
    while Instant::now() < deadline {
        let Some(v) = next(Duration::from_secs(1)).await else { continue };
        if v.manager.epoch > epoch && victims.iter().all(|id| !v.robots.iter().any(|r| r == id)) && v.status == proto::MissionStatus::Running {
            let at = since.elapsed().as_secs_f64();
            let settle = Instant::now() + Duration::from_secs(3);
            let mut last = v;
            while let Some(v) = next(settle.saturating_duration_since(Instant::now())).await {
                last = v;
            }
            return (Some(at), Some(last));
        }
    }
    (None, None)
}

/// `--run S`: how long the missions run before the crashes, seconds (default 20).
fn run_secs() -> u64 {
    let args: Vec<String> = std::env::args().collect();
    args.iter().position(|a| a == "--run").and_then(|i| args.get(i + 1)).and_then(|v| v.parse().ok()).unwrap_or(20)
}

/// Robots central's journal records as lost so far.
async fn lost_so_far(client: &Client) -> anyhow::Result<usize> {
    let entries = common::journal(client).await?;
    Ok(entries.iter().map(|e| e.event.losses() as usize).sum())
}

/// `--sim-fleet`: the robots of a site in one `mrmm sim-fleet` process (each still its own
/// peer), instead of one process per robot.
fn sim_fleet() -> bool {
    std::env::args().any(|a| a == "--sim-fleet")
}

/// `--clients`: robots are clients of their site's router (one link each), not peers.
fn clients() -> bool {
    std::env::args().any(|a| a == "--clients")
}

/// `--tls`: the secure links over Zenoh's TLS link (TLS over TCP) instead of QUIC (mutual TLS
/// 1.3 over UDP, what a secure fleet uses: the TLS link races under load, docs/zenoh.md).
fn args_tls() -> bool {
    std::env::args().any(|a| a == "--tls")
}

/// Seconds since midnight (UTC) of a log line's timestamp (`2026-11-24T19:45:12.123456Z …`).
fn log_time(line: &str) -> Option<f64> {
    let clean: String = {
        // Strip ANSI colour codes, should the log have them.
        let mut out = String::new();
        let mut esc = false;
        for c in line.chars() {
            match (esc, c) {
                (false, '\u{1b}') => esc = true,
                (true, 'm') => esc = false,
                (true, _) => {}
                (false, c) => out.push(c),
            }
        }
        out
    };
    let ts = clean.split_whitespace().next()?;
    let time = ts.split_once('T')?.1.trim_end_matches('Z');
    let mut parts = time.split(':');
    let (h, m, s) = (parts.next()?.parse::<f64>().ok()?, parts.next()?.parse::<f64>().ok()?, parts.next()?.parse::<f64>().ok()?);
    Some(h * 3600.0 + m * 60.0 + s)
}

/// Barrier release latencies (ms) of mission `mission` at plan epoch `epoch`, from the robots'
/// logs: per barrier, every member's release minus the first release (the last arriver's).
fn barrier_latencies(logs: &[std::path::PathBuf], mission: &str, epoch: u64) -> Vec<f64> {
    let mut by_barrier: std::collections::BTreeMap<(u64, u64), Vec<f64>> = Default::default();
    let (m, e) = (format!("mission={mission}"), format!("epoch={epoch}"));
    let field = |line: &str, k: &str| line.split_whitespace().find_map(|w| w.strip_prefix(k)).and_then(|v| v.parse::<u64>().ok());
    for log in logs {
        for line in std::fs::read_to_string(log).unwrap_or_default().lines() {
            if !(line.contains("released") && line.contains(&m) && line.split_whitespace().any(|w| w == e)) {
                continue;
            }
            if let (Some(t), Some(p), Some(r)) = (log_time(line), field(line, "point="), field(line, "round=")) {
                by_barrier.entry((r, p)).or_default().push(t);
            }
        }
    }
    let mut out = Vec::new();
    for times in by_barrier.values_mut() {
        times.sort_by(f64::total_cmp);
        if let Some((first, rest)) = times.split_first() {
            out.extend(rest.iter().map(|t| (t - first) * 1e3));
        }
    }
    out
}

async fn run(n: usize, lease: u64, rate: u64, sites: usize, insecure: bool, quic: bool) -> anyhow::Result<()> {
    let dir = Scratch::new(&format!("bench-scale-{n}"));
    let pki = dir.path("pki");
    {
        use mrmm_net::security::pki as p;
        use mrmm_proto::Role;
        p::init(&pki)?;
        p::issue(&pki, Role::Central, "central", &[], 2)?;
        p::issue(&pki, Role::Operator, "op", &[], 2)?;
        for i in 1..=n {
            p::issue(&pki, Role::Robot, &format!("r{i}"), &[], 2)?;
        }
        for s in 1..sites {
            p::issue(&pki, Role::Router, &format!("site{s}"), &[], 2)?;
        }
    }
    let p = pki.display().to_string();
    let proto_ = if insecure {
        "tcp"
    } else if args_tls() {
        "tls"
    } else {
        "quic"
    };
    let listen = format!("{proto_}/127.0.0.1:0");
    // Certificates on the command line (`--pki DIR [--operator op]`), unless insecure.
    let pki_args = |extra: &[&'static str]| -> Vec<String> {
        if insecure {
            vec![]
        } else {
            ["--pki", p.as_str()].iter().chain(extra).map(|s| s.to_string()).collect()
        }
    };
    let quic_listen = if quic && !insecure { vec!["--listen".to_string(), "quic/127.0.0.1:0".to_string()] } else { vec![] };
    // Central's lease is the fleet's too: a 1 s lease expires busy routers' uplinks.
    let central_cfg = dir.path("central.json5");
    std::fs::write(&central_cfg, format!("{{ lease_ms: {lease} }}"))?;
    let central_cfg = central_cfg.display().to_string();
    let central_args: Vec<String> = ["central", "--config", &central_cfg, "--listen", &listen]
        .iter()
        .map(|s| s.to_string())
        .chain(quic_listen)
        .chain(pki_args(&["--operator", "op"]))
        .collect();
    let central_args: Vec<&str> = central_args.iter().map(String::as_str).collect();
    let mut central = vec![Kid(spawn(&central_args, &dir.path("central.log"))?)];
    let line = ready_lines(&mut central, "central ready", Duration::from_secs(30))?.remove(0);
    let ep = line
        .split_whitespace()
        .find_map(|w| w.strip_prefix("listening="))
        .and_then(|l| l.split(',').next())
        .ok_or_else(|| anyhow!("no endpoint in {line}"))?
        .to_string();
    // Where routers link to central: its QUIC endpoint with --quic-uplinks.
    let uplink = line
        .split_whitespace()
        .find_map(|w| w.strip_prefix("listening="))
        .and_then(|l| l.split(',').find(|e| e.starts_with("quic/")))
        .map_or(ep.clone(), str::to_string);
    // Site routers: robots of site s > 0 connect to router s, which links to central.
    let mut routers = Vec::new();
    for s in 1..sites {
        let cfg = dir.path(&format!("site{s}.json5"));
        std::fs::write(&cfg, format!(r#"{{ id: "site{s}", listen: ["{listen}"], connect: ["{uplink}"], lease_ms: {lease} }}"#))?;
        let args: Vec<String> = ["router".to_string(), "--config".into(), cfg.display().to_string()].into_iter().chain(pki_args(&[])).collect();
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        routers.push(Kid(spawn(&args, &dir.path(&format!("site{s}.log")))?));
    }
    let mut site_eps = vec![ep.clone()];
    for line in ready_lines(&mut routers, "router ready", Duration::from_secs(30))? {
        let rep = line.split_whitespace().find_map(|w| w.strip_prefix("listening=")).and_then(|l| l.split(',').next()).ok_or_else(|| anyhow!("{line}"))?;
        site_eps.push(rep.to_string());
    }
    let t0 = Instant::now();
    let mut robots = Vec::new();
    let mut per_site: Vec<Vec<String>> = vec![Vec::new(); sites];
    for i in 1..=n {
        let id = format!("r{i}");
        let f = |name: &str| serde_json::to_string(&pki.join(name).display().to_string()).unwrap_or_default();
        let security = if insecure {
            String::new()
        } else {
            format!("security: {{ ca: {}, cert: {}, key: {} }},", f("ca.crt"), f(&format!("{id}.crt")), f(&format!("{id}.key")))
        };
        let cfg = format!(
            r#"{{ id: "{id}", type: "ground", capabilities: ["camera"], kinematics: {{ max_speed: 1.0, max_turn_rate: 1.5 }},
                 start: {{ x: {x}, y: {y}, theta: 1.5708 }}, time_scale: 5, telemetry_hz: 5,
                 zenoh: {{ mode: "{mode}", listen: ["{listen}"], connect: {connect}, lease_ms: {lease} }},
                 {security} }}"#,
            // Rows of 20, 1.5 m apart: on one line, 200 robots would span 300 m and the
            // farthest would not reach the tour (nor its first barrier) in the measured window.
            x = (((i - 1) % 20) as f64 - 9.5) * 1.5,
            y = -12.0 - ((i - 1) / 20) as f64 * 1.5,
            mode = if clients() { "client" } else { "peer" },
            connect = serde_json::to_string(&if clients() && sites > 1 {
                vec![&site_eps[i % sites], &site_eps[(i + 1) % sites]]
            } else {
                vec![&site_eps[i % sites]]
            })?,
        );
        let path = dir.path(&format!("{id}.json5"));
        std::fs::write(&path, cfg)?;
        if sim_fleet() {
            per_site[i % sites].extend(["--config".to_string(), path.display().to_string()]);
            continue;
        }
        robots.push(Kid(spawn(&["robot", "--config", &path.display().to_string()], &dir.path(&format!("{id}.log")))?));
        if rate > 0 {
            tokio::time::sleep(Duration::from_secs_f64(1.0 / rate as f64)).await;
        }
    }
    if sim_fleet() {
        // One `mrmm sim-fleet` per site, starting its robots at the site's share of the rate.
        let site_rate = if rate == 0 { 0 } else { rate.div_ceil(sites as u64) }.to_string();
        for (s, configs) in per_site.iter().enumerate() {
            let args: Vec<&str> = ["sim-fleet", "--rate", &site_rate].into_iter().chain(configs.iter().map(String::as_str)).collect();
            robots.push(Kid(spawn_with(&args, &dir.path(&format!("fleet{s}.log")), Stdio::piped())?));
        }
        ready_lines(&mut robots, "sim-fleet ready", Duration::from_secs(600))?;
    } else {
        ready_lines(&mut robots, "robot ready", Duration::from_secs(300))?;
    }
    let up = t0.elapsed().as_secs_f64();
    let op = (!insecure).then(|| mrmm_proto::SecuritySection::from_dir(&pki, "op"));
    let client = Client::connect_with(std::slice::from_ref(&ep), op, Duration::from_secs(10)).await.context("operator client")?;
    let live = |v: &[RobotView]| v.iter().filter(|r| r.status != RobotStatus::Lost).count();
    eventually("every robot registered", Duration::from_secs(300), || async {
        let v: Vec<RobotView> = client.query(proto::Key::SystemRobots, None::<&()>).await.ok()?;
        (live(&v) == n).then_some(())
    })
    .await?;
    let registered = t0.elapsed().as_secs_f64();
    // Let start-up work (link set-up, liveliness histories) settle before measuring the idle
    // fleet.
    tokio::time::sleep(Duration::from_secs(5)).await;
    let pids: Vec<u32> = robots.iter().chain(&central).chain(&routers).map(|k| k.0.id()).collect();
    // Per robot: a process's memory over the robots it runs.
    let rss: Vec<f64> = robots.iter().map(|k| rss_mib(k.0.id()) / (n as f64 / robots.len() as f64)).collect();
    let rss_central = rss_mib(central[0].0.id());
    let central_pid = central[0].0.id();
    let ticks0: u64 = pids.iter().map(|p| cpu_ticks(*p)).sum();
    let central0 = cpu_ticks(central_pid);
    let (pk0, w0) = (lo_packets(), Instant::now());
    tokio::time::sleep(Duration::from_secs(10)).await;
    let ticks1: u64 = pids.iter().map(|p| cpu_ticks(*p)).sum();
    let central1 = cpu_ticks(central_pid);
    let window = w0.elapsed().as_secs_f64();
    let hz = USER_HZ;
    let idle_cpu = (ticks1.saturating_sub(ticks0)) as f64 / hz / window * 100.0;
    let idle_central = (central1.saturating_sub(central0)) as f64 / hz / window * 100.0;
    let pkts = (lo_packets().saturating_sub(pk0)) as f64 / window;
    // QUIC links are UDP flows with no per-link socket to count: the TCP links only (the
    // routers' uplinks and plain or TLS fleets).
    let nlinks = match (links(&pids), proto_) {
        (0, "quic") => "UDP".to_string(),
        (n, _) => n.to_string(),
    };

    // One mission of N/2 robots (`--patrol K`: K): from the create to every member moving.
    let half = patrol_size(n);
    let mission = MissionCreate {
        name: "scale".into(),
        recipe: "patrol".into(),
        count: Some(half),
        params: [("waypoints".to_string(), serde_json::json!([[-15, 4], [-6, 14], [5, 17], [15, 9], [11, 1], [0, 0]]))].into(),
        ..Default::default()
    };
    // A ring, not a FIFO: a full FIFO would block the session (and the create's reply) while
    // the create is awaited.
    let telemetry = client
        .session()
        .declare_subscriber(proto::Pattern::AllTelemetry.to_string())
        .with(zenoh::handlers::RingChannel::new(4096))
        .await
        .map_err(|e| anyhow!("{e}"))?;
    let c0 = Instant::now();
    let created: MissionView = match client.query(proto::Key::SystemCmd(proto::SystemCmd::Create), Some(&mission)).await {
        Ok(v) => v,
        Err(e) => {
            let mean = rss.iter().sum::<f64>() / rss.len().max(1) as f64;
            println!("| {n} | {lease} | {up:.1} | {registered:.1} | {mean:.1} | {rss_central:.1} | {idle_cpu:.0} ({idle_central:.0}) | {nlinks} | {pkts:.0} | create failed: {e} | | | | | |");
            client.close().await;
            return Ok(());
        }
    };
    // The second mission: a coverage of the robots left.
    let coverage = MissionCreate {
        name: "scale-coverage".into(),
        recipe: "coverage".into(),
        count: Some(n - half),
        params: [("region".to_string(), serde_json::json!([[-20, -34], [20, -34], [20, -18], [-20, -18]]))].into(),
        ..Default::default()
    };
    let second: Option<MissionView> = match client.query(proto::Key::SystemCmd(proto::SystemCmd::Create), Some(&coverage)).await {
        Ok(v) => Some(v),
        Err(e) => {
            eprintln!("second mission not created: {e}");
            None
        }
    };
    let mut members: BTreeSet<String> = created.robots.iter().map(|r| r.to_string()).collect();
    members.extend(second.iter().flat_map(|m| m.robots.iter().map(|r| r.to_string())));
    let missions = ["scale", "scale-coverage"];
    let mut moving = BTreeSet::new();
    let deadline = c0 + Duration::from_secs(60);
    while moving.len() < members.len() && Instant::now() < deadline {
        let Ok(Ok(s)) = tokio::time::timeout(Duration::from_secs(1), telemetry.recv_async()).await else { continue };
        if let Ok(t) = proto::decode_telemetry(&s.payload().to_bytes()) {
            // Moving, or already at a goal it stood next to (a coverage point by its start): its
            // plan is past the first step.
            let started = t.behaviour != proto::Behaviour::Hold || t.progress.as_ref().is_some_and(|p| p.step > 0);
            if members.contains(t.id.as_str()) && t.mission.as_ref().map(|x| x.as_str()).is_some_and(|m| missions.contains(&m)) && started {
                moving.insert(t.id.to_string());
            }
        }
    }
    let to_moving =
        if moving.len() == members.len() { format!("{:.2}", c0.elapsed().as_secs_f64()) } else { format!("{}/{} in 60 s", moving.len(), members.len()) };
    drop(telemetry);

    // Operator queries while the mission runs.
    let mut rtt = Vec::new();
    let mut failed = 0;
    for _ in 0..100 {
        let q0 = Instant::now();
        match client.query::<Vec<RobotView>>(proto::Key::SystemRobots, None::<&()>).await {
            Ok(_) => rtt.push(q0.elapsed().as_secs_f64() * 1e3),
            Err(e) => {
                failed += 1;
                eprintln!("fleet query failed after {:.1} s: {e}", q0.elapsed().as_secs_f64());
            }
        }
    }
    let failed = if failed > 0 { format!(" ({failed} failed)") } else { String::new() };
    // Barriers: the run's length of the missions at least, then every member's releases from its
    // log; the robots lost meanwhile from the journal.
    tokio::time::sleep(Duration::from_secs(run_secs()).saturating_sub(c0.elapsed())).await;
    let lost = match lost_so_far(&client).await {
        Ok(k) => format!("{k} in {:.0} s", c0.elapsed().as_secs_f64()),
        Err(e) => format!("journal: {e}"),
    };
    let logs: Vec<std::path::PathBuf> = if sim_fleet() {
        (0..sites).map(|s| dir.path(&format!("fleet{s}.log"))).collect()
    } else {
        created.robots.iter().map(|id| dir.path(&format!("{id}.log"))).collect()
    };
    let mut lat = barrier_latencies(&logs, "scale", created.manager.epoch);
    let barriers = if lat.is_empty() {
        "none".to_string()
    } else {
        format!("{:.1} / {:.1} ({} releases)", quantile(&mut lat.clone(), 0.5), quantile(&mut lat, 0.99), lat.len())
    };

    // A member SIGKILLed: time until the mission's status shows a plan without it.
    let victim = created.robots.first().map(|r| r.to_string()).ok_or_else(|| anyhow!("the mission has no robots"))?;
    let status = client
        .session()
        .declare_subscriber(proto::Key::MissionStatus("scale".into()).to_string())
        .with(zenoh::handlers::RingChannel::new(256))
        .await
        .map_err(|e| anyhow!("{e}"))?;
    // The epoch running now (the mission may have replanned since its create).
    let mut epoch = created.manager.epoch;
    let settle = Instant::now() + Duration::from_secs(2);
    while let Ok(Ok(s)) = tokio::time::timeout(settle.saturating_duration_since(Instant::now()), status.recv_async()).await {
        if let Ok(v) = proto::from_json::<MissionView>("status", &s.payload().to_bytes()) {
            epoch = epoch.max(v.manager.epoch);
        }
    }
    let k0 = Instant::now();
    crash(&mut robots, sites, std::slice::from_ref(&victim))?;
    let (replanned, view) = replanned_without(&status, std::slice::from_ref(&victim), epoch, k0).await;
    let replanned = replanned.map_or("not in 30 s".to_string(), |t| format!("{t:.2}"));
    // A tenth of the members left crashed at once: one replan (the burst is debounced), and when.
    let burst = match view {
        Some(before) => {
            let left: Vec<String> = before.robots.iter().map(|r| r.to_string()).collect();
            let victims: Vec<String> = left.iter().take(left.len().div_ceil(10)).cloned().collect();
            let b0 = Instant::now();
            crash(&mut robots, sites, &victims)?;
            match replanned_without(&status, &victims, before.manager.epoch, b0).await {
                (Some(t), Some(after)) => format!("{} crashed: {} replan(s), {t:.2}", victims.len(), after.manager.epoch - before.manager.epoch),
                _ => format!("{} crashed: not replanned in 30 s", victims.len()),
            }
        }
        None => "-".to_string(),
    };
    let mean = rss.iter().sum::<f64>() / rss.len().max(1) as f64;
    let max = rss.iter().copied().fold(0.0, f64::max);
    println!(
        "| {n} | {lease} | {up:.1} | {registered:.1} | {mean:.1} / {max:.1} | {rss_central:.1} | {idle_cpu:.0} ({idle_central:.0}) | {nlinks} | {pkts:.0} | {to_moving} | {:.1} / {:.1}{failed} | {barriers} | {lost} | {replanned} | {burst} |",
        quantile(&mut rtt.clone(), 0.5),
        quantile(&mut rtt, 0.99)
    );
    client.close().await;
    Ok(())
}
