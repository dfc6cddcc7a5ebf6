//! Barrier release latency: N Zenoh peers on loopback (each its own session, linked by gossip
//! through a router), each running the robots' `Barrier` over `mrmm/team/<team>/sync/...`.
//! For every barrier the peers arrive a few milliseconds apart; the latency of a peer is the time
//! from the last arrival's publication to that peer's release. Measured with the router up, then
//! again after the router is closed (direct peer links only).
//!
//! `cargo bench --bench barrier [-- N… [--rounds R]]` (default: 5 20 50 peers, 40 barriers each).

use std::sync::Arc;
use std::time::{Duration, Instant};

use mrmm_core::robot::barrier::Barrier;
use mrmm_net::net::{self, Mode};
use mrmm_proto::{self as proto, SyncArrival};
use rand::{Rng, SeedableRng};
use tokio::sync::{mpsc, Barrier as Gate};

const TEAM: &str = "bench";

struct Peer {
    session: zenoh::Session,
    /// Tell the peer to arrive at barrier `point`.
    arrive: mpsc::UnboundedSender<u32>,
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let rounds: u32 = args.iter().position(|a| a == "--rounds").and_then(|i| args.get(i + 1)).and_then(|v| v.parse().ok()).unwrap_or(40);
    let mut sizes: Vec<usize> = args.iter().filter_map(|a| a.parse().ok()).filter(|&n: &usize| n >= 2 && n != rounds as usize).collect();
    if sizes.is_empty() {
        sizes = vec![5, 20, 50];
    }
    let rt = tokio::runtime::Builder::new_multi_thread().enable_all().build()?;
    println!("| peers | router | barriers | p50 ms | p99 ms | max ms |");
    println!("|---:|---|---:|---:|---:|---:|");
    for n in sizes {
        rt.block_on(run(n, rounds))?;
    }
    Ok(())
}

async fn run(n: usize, rounds: u32) -> anyhow::Result<()> {
    let router = net::open(net::zenoh_config(Mode::Router, &["tcp/127.0.0.1:0".into()], &[], 1000)?).await?;
    let router_ep = net::listening_endpoints(&router).await;
    let (tx, mut rx) = mpsc::unbounded_channel::<(u32, Instant)>();
    let ready = Arc::new(Gate::new(n + 1));
    let members: Vec<String> = (0..n).map(|i| format!("p{i}")).collect();
    let mut peers = Vec::new();
    for i in 0..n {
        let session = net::open(net::zenoh_config(Mode::Peer, &["tcp/127.0.0.1:0".into()], &router_ep, 1000)?).await?;
        let (arrive, mut orders) = mpsc::unbounded_channel::<u32>();
        let (s, tx, ready, members) = (session.clone(), tx.clone(), ready.clone(), members.clone());
        tokio::spawn(async move {
            let me = members[i].clone();
            let sub = s.declare_subscriber(proto::Pattern::TeamSync(TEAM.to_string()).to_string()).await.expect("subscriber");
            let tokens = s.liveliness().declare_subscriber(proto::Pattern::TeamMembers(TEAM.into()).to_string()).history(true).await.expect("liveliness");
            let _token = s
                .liveliness()
                .declare_token(proto::Key::TeamMember { subteam: format!("{TEAM}/all"), robot: me.clone().into() }.to_string())
                .await
                .expect("token");
            // Wait until every member's token is visible.
            let mut seen = std::collections::BTreeSet::new();
            while seen.len() < members.len() {
                if let Ok(t) = tokens.recv_async().await {
                    if let Some(proto::Key::TeamMember { robot: id, .. }) = proto::Key::parse(t.key_expr().as_str()) {
                        seen.insert(id.to_string());
                    }
                }
            }
            ready.wait().await;
            let mut barrier = Barrier::new(&me, 1, &members.iter().map(Into::into).collect::<Vec<_>>());
            let mut waiting: Option<u32> = None;
            loop {
                tokio::select! {
                    o = orders.recv() => {
                        let Some(point) = o else { break };
                        let a = SyncArrival { robot: me.clone().into(), epoch: 1, point, round: 0 };
                        barrier.arrival(&a);
                        let bytes = proto::to_json(&a).expect("json");
                        let _ = s.put(proto::Key::TeamSync { team: TEAM.into(), point, round: 0 }.to_string(), bytes).await;
                        waiting = Some(point);
                    }
                    smp = sub.recv_async() => {
                        let Ok(smp) = smp else { break };
                        if let Ok(a) = proto::from_json::<SyncArrival>("arrival", &smp.payload().to_bytes()) {
                            barrier.arrival(&a);
                        }
                    }
                }
                if let Some(p) = waiting {
                    if barrier.released(p, 0) {
                        waiting = None;
                        let _ = tx.send((p, Instant::now()));
                    }
                }
            }
        });
        peers.push(Peer { session, arrive });
    }
    ready.wait().await;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(n as u64);
    for phase in ["up", "down"] {
        if phase == "down" {
            router.close().await.map_err(|e| anyhow::anyhow!("{e}"))?;
            tokio::time::sleep(Duration::from_millis(500)).await;
        }
        let mut lat = Vec::new();
        for k in 0..rounds {
            let point = k + if phase == "down" { rounds } else { 0 };
            let mut last = Instant::now();
            for p in &peers {
                tokio::time::sleep(Duration::from_micros(rng.gen_range(0..2000))).await;
                last = Instant::now();
                let _ = p.arrive.send(point);
            }
            let mut released = 0;
            while released < n {
                let Ok(Some((p, at))) = tokio::time::timeout(Duration::from_secs(10), rx.recv()).await else {
                    anyhow::bail!("{n} peers, router {phase}: barrier {point} not released within 10 s ({released}/{n})");
                };
                if p == point {
                    released += 1;
                    lat.push(at.saturating_duration_since(last).as_secs_f64() * 1e3);
                }
            }
        }
        lat.sort_by(f64::total_cmp);
        let q = |f: f64| lat[((lat.len() - 1) as f64 * f).round() as usize];
        println!("| {n} | {phase} | {rounds} | {:.2} | {:.2} | {:.2} |", q(0.5), q(0.99), lat[lat.len() - 1]);
    }
    for p in peers {
        let _ = p.session.close().await;
    }
    Ok(())
}
