//! Barrier release latency with every peer in **its own process**, as robots are deployed. The
//! bench re-runs itself as N children (one Zenoh peer session each, linked by gossip through a
//! router in the parent). Barrier k starts at a common wall-clock time; each peer arrives within
//! 2 ms of it, publishes once on `mrmm/team/<team>/sync/…` and runs the robots' `Barrier`. The
//! latency of a peer is its release time minus the publication time of the barrier's last
//! arrival (all clocks are this machine's wall clock). Half the barriers with the router up, half
//! after the parent closed it. Like robots, a peer re-publishes its arrival every 0.5 s while it
//! waits (a late link may have missed the first one).
//!
//! With `--secure`, as deployed on a shared network: a fleet PKI is made for the run, every link is
//! mutual TLS, the router is central (with its access control), every peer is a robot with its
//! own certificate that seals its arrivals and checks every arrival it hears (a robot may only
//! arrive as itself) — the robots' own `Mesh`.
//!
//! `cargo bench --bench barrier_procs [-- N… [--rounds R] [--secure]]` (default 5 20 50 peers,
//! 100 barriers).

use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use mrmm_core::robot::barrier::Barrier;
use mrmm_net::net::{self, Mode};
use mrmm_net::security::pki;
use mrmm_net::{Mesh, NodeNet};
use mrmm_proto::{self as proto, Role, SecuritySection, Sender, SyncArrival};
use rand::{Rng, SeedableRng};

const TEAM: &str = "bench";
/// Time between two barriers.
const PERIOD_MS: u64 = 100;

fn now_ns() -> u64 {
    SystemTime::now().duration_since(UNIX_EPOCH).map_or(0, |d| d.as_nanos() as u64)
}

async fn sleep_until_ns(t: u64) {
    let now = now_ns();
    if t > now {
        tokio::time::sleep(Duration::from_nanos(t - now)).await;
    }
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let rt = tokio::runtime::Builder::new_multi_thread().worker_threads(2).enable_all().build()?;
    if args.first().map(String::as_str) == Some("--child") {
        return rt.block_on(child(&args[1..]));
    }
    let rounds: u64 = args.iter().position(|a| a == "--rounds").and_then(|i| args.get(i + 1)).and_then(|v| v.parse().ok()).unwrap_or(100);
    let mut sizes: Vec<usize> = args.iter().filter_map(|a| a.parse().ok()).filter(|&n: &usize| n >= 2 && n as u64 != rounds).collect();
    if sizes.is_empty() {
        sizes = vec![5, 20, 50];
    }
    let secure = args.iter().any(|a| a == "--secure");
    let pki_dir = secure.then(|| std::env::temp_dir().join(format!("mrmm-bench-barrier-{}", std::process::id())));
    if let Some(d) = &pki_dir {
        std::fs::create_dir_all(d)?;
        pki::init(d)?;
        pki::issue(d, Role::Central, "central", &[], 1)?;
        for i in 0..sizes.iter().copied().max().unwrap_or(2) {
            pki::issue(d, Role::Robot, &format!("p{i}"), &[], 1)?;
        }
    }
    println!("| peers (processes) | router | barriers | p50 ms | p99 ms | max ms |");
    println!("|---:|---|---:|---:|---:|---:|");
    let mut result = Ok(());
    for n in sizes {
        result = rt.block_on(parent(n, rounds, pki_dir.as_deref()));
        if result.is_err() {
            break;
        }
    }
    if let Some(d) = &pki_dir {
        let _ = std::fs::remove_dir_all(d);
    }
    result
}

/// A node's mesh: secure with `name`'s certificate from `pki`, else plain TCP.
async fn mesh(pki: Option<&std::path::Path>, mode: Mode, me: Sender, connect: Vec<String>) -> anyhow::Result<Mesh> {
    let scheme = if pki.is_some() { "quic" } else { "tcp" };
    let net = NodeNet {
        mode,
        listen: vec![format!("{scheme}/127.0.0.1:0")],
        connect,
        lease_ms: 1000,
        max_message_size: mrmm_net::net::DEFAULT_MAX_MESSAGE_SIZE,
        security: pki.map(|d| SecuritySection::from_dir(d, &me.id)),
        me: Some(me),
        wire_stats: false,
    };
    Ok(Mesh::open(&net).await?)
}

async fn parent(n: usize, rounds: u64, pki: Option<&std::path::Path>) -> anyhow::Result<()> {
    let router = mesh(pki, Mode::Router, Sender::new(Role::Central, "central"), vec![]).await?;
    let ep = net::listening_endpoints(router.session()).await.join(",");
    // Every pair of peers links directly (gossip); on 2 cores 50 processes need a while.
    let t0 = now_ns() + 4_000_000_000 + n as u64 * 400_000_000;
    let t_down = t0 + rounds * PERIOD_MS * 1_000_000 + 1_000_000_000;
    let exe = std::env::current_exe()?;
    let mut children = Vec::new();
    for i in 0..n {
        let child = Command::new(&exe)
            .args(["--child", &i.to_string(), &n.to_string(), &rounds.to_string(), &t0.to_string(), &t_down.to_string(), &ep])
            .args(pki.map(|d| d.display().to_string()))
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()?;
        children.push(child);
    }
    // Close the router between the two halves.
    sleep_until_ns(t_down - 500_000_000).await;
    router.close().await;
    // (peer, barrier) → (arrival, release)
    let mut rows: Vec<(usize, u64, u64, u64)> = Vec::new();
    for mut c in children {
        let out = c.stdout.take().ok_or_else(|| anyhow::anyhow!("no stdout"))?;
        for line in BufReader::new(out).lines().map_while(Result::ok) {
            let f: Vec<u64> = line.split_whitespace().skip(1).filter_map(|v| v.parse().ok()).collect();
            if line.starts_with("R ") && f.len() == 4 {
                rows.push((f[0] as usize, f[1], f[2], f[3]));
            } else if line.starts_with("E ") {
                anyhow::bail!("child: {line}");
            }
        }
        c.wait()?;
    }
    for (phase, range) in [("up", 0..rounds), ("down", rounds..2 * rounds)] {
        let mut lat = Vec::new();
        for k in range {
            let at: Vec<&(usize, u64, u64, u64)> = rows.iter().filter(|r| r.1 == k).collect();
            if at.len() < n {
                anyhow::bail!("{n} peers, router {phase}: barrier {k} released by {}/{n} peers", at.len());
            }
            let last = at.iter().map(|r| r.2).max().unwrap_or(0);
            lat.extend(at.iter().map(|r| r.3.saturating_sub(last) as f64 / 1e6));
        }
        lat.sort_by(f64::total_cmp);
        let q = |f: f64| lat[((lat.len() - 1) as f64 * f).round() as usize];
        println!("| {n} | {phase} | {rounds} | {:.2} | {:.2} | {:.2} |", q(0.5), q(0.99), lat[lat.len() - 1]);
    }
    Ok(())
}

/// One peer: `--child i n rounds t0 t_down router_ep [pki_dir]`.
async fn child(a: &[String]) -> anyhow::Result<()> {
    let num = |k: usize| a.get(k).and_then(|v| v.parse::<u64>().ok()).ok_or_else(|| anyhow::anyhow!("bad child args {a:?}"));
    let (i, n, rounds, t0, t_down) = (num(0)? as usize, num(1)? as usize, num(2)?, num(3)?, num(4)?);
    let router: Vec<String> = a.get(5).map(|s| s.split(',').map(String::from).collect()).unwrap_or_default();
    let members: Vec<String> = (0..n).map(|j| format!("p{j}")).collect();
    let me = members[i].clone();
    let pki = a.get(6).map(std::path::PathBuf::from);
    let m = mesh(pki.as_deref(), Mode::Peer, Sender::new(Role::Robot, &me), router).await?;
    let session = m.session().clone();
    // As robots: teammates' arrivals only (the own one is counted before it is published).
    let sub = session
        .declare_subscriber(proto::Pattern::TeamSync(TEAM.to_string()).to_string())
        .allowed_origin(zenoh::sample::Locality::Remote)
        .await
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let tokens = session
        .liveliness()
        .declare_subscriber(proto::Pattern::TeamMembers(TEAM.into()).to_string())
        .history(true)
        .await
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let _token = session
        .liveliness()
        .declare_token(proto::Key::TeamMember { subteam: format!("{TEAM}/all"), robot: me.clone().into() }.to_string())
        .await
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let mut seen = std::collections::BTreeSet::new();
    while seen.len() < n {
        let t = tokio::time::timeout(Duration::from_secs(30), tokens.recv_async()).await;
        match t {
            Ok(Ok(t)) => {
                if let Some(proto::Key::TeamMember { robot: id, .. }) = proto::Key::parse(t.key_expr().as_str()) {
                    seen.insert(id.to_string());
                }
            }
            _ => {
                println!("E {me}: only {} of {n} members visible", seen.len());
                return Ok(());
            }
        }
    }
    if now_ns() > t0 {
        println!("E {me}: ready too late");
        return Ok(());
    }
    let mut barrier = Barrier::new(&me, 1, &members.iter().map(Into::into).collect::<Vec<_>>());
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(i as u64);
    for k in 0..2 * rounds {
        let start = if k < rounds { t0 + k * PERIOD_MS * 1_000_000 } else { t_down + (k - rounds) * PERIOD_MS * 1_000_000 };
        sleep_until_ns(start + rng.gen_range(0..2_000_000)).await;
        let point = k as u32;
        let a = SyncArrival { robot: me.clone().into(), epoch: 1, point, round: 0 };
        barrier.arrival(&a);
        let arrived = now_ns();
        m.put(&proto::Key::TeamSync { team: TEAM.into(), point, round: 0 }.to_string(), proto::to_json(&a)?, zenoh::bytes::Encoding::APPLICATION_JSON).await;
        // As the robots' executor: re-publish every 0.5 s while waiting.
        let mut waited = 0;
        while !barrier.released(point, 0) {
            match tokio::time::timeout(Duration::from_millis(500), sub.recv_async()).await {
                Ok(Ok(s)) => {
                    // As robots do: sealed by the robot it names, or dropped.
                    let Some(from) = m.sender_of("sync arrival", &s) else { continue };
                    if let Ok(a) = proto::from_json::<SyncArrival>("arrival", &s.payload().to_bytes()) {
                        if from.is(Role::Robot, a.robot.as_str()) {
                            barrier.arrival(&a);
                        }
                    }
                }
                _ => {
                    waited += 1;
                    if waited > 20 {
                        println!("E {me}: barrier {k} not released in 10 s");
                        return Ok(());
                    }
                    m.put(
                        &proto::Key::TeamSync { team: TEAM.into(), point, round: 0 }.to_string(),
                        proto::to_json(&a)?,
                        zenoh::bytes::Encoding::APPLICATION_JSON,
                    )
                    .await;
                }
            }
        }
        println!("R {i} {k} {arrived} {}", now_ns());
    }
    let _ = session.close().await;
    Ok(())
}
