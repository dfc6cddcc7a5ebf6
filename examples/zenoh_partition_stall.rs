//! Minimal reproduction of a Zenoh stall in partitions (docs/zenoh.md), with bare sessions:
//! a router publishes a timestamp every 50 ms; each peer prints, every second, the worst delay it
//! saw. Run by `examples/zenoh_partition_stall.sh` (root: it makes two network namespaces joined by
//! a veth pair, puts the router and one peer in A, N peers in B, cuts the link for 16 s).
//!
//! Seen on this machine (zenoh 1.10.2) with Zenoh's default TCP linger (10 s): one second after
//! the cut, the router's publications to the peer on its own side stopped and arrived 10.0–10.2 s
//! late, in one burst. The cause is the linger (docs/zenoh.md): closing the dead links blocked a
//! Zenoh runtime thread in close(2). mrmm builds Zenoh with `TCP_LINGER_TIMEOUT=0`
//! (`.cargo/config.toml`): 1–4 ms. `RLOG=zenoh=debug` on the script logs the router and the A peer.
//!
//! `zenoh_partition_stall router <listen>` | `zenoh_partition_stall peer <listen> <connect>`
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use mrmm_net::net::{self, Mode};

fn now_ms() -> u64 {
    SystemTime::now().duration_since(UNIX_EPOCH).map_or(0, |d| d.as_millis() as u64)
}

#[tokio::main(flavor = "multi_thread", worker_threads = 2)]
async fn main() -> anyhow::Result<()> {
    if std::env::var_os("RUST_LOG").is_some() {
        tracing_subscriber::fmt().with_env_filter(tracing_subscriber::EnvFilter::from_default_env()).with_writer(std::io::stderr).init();
    }
    let a: Vec<String> = std::env::args().skip(1).collect();
    let (mode, listen) = (a[0].as_str(), a[1].clone());
    if mode == "router" {
        let s = net::open(net::zenoh_config(Mode::Router, &[listen], &[], 1000)?).await?;
        let _l = if std::env::var_os("NOLIV").is_none() {
            Some(s.liveliness().declare_subscriber("stall/alive/*").history(true).await.map_err(|e| anyhow::anyhow!("{e}"))?)
        } else {
            None
        };
        loop {
            s.put("stall/ping", now_ms().to_string()).await.map_err(|e| anyhow::anyhow!("{e}"))?;
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
    }
    let mut c = net::zenoh_config(Mode::Peer, &[listen], &[a[2].clone()], 1000)?;
    if let Ok(ms) = std::env::var("OPEN_TIMEOUT") {
        c.insert_json5("transport/unicast/open_timeout", &ms).map_err(|e| anyhow::anyhow!("{e}"))?;
    }
    if let Ok(t) = std::env::var("GOSSIP_TARGET") {
        c.insert_json5("scouting/gossip/target", &t).map_err(|e| anyhow::anyhow!("{e}"))?;
    }
    if std::env::var_os("NOGOSSIP").is_some() {
        c.insert_json5("scouting/gossip/enabled", "false").map_err(|e| anyhow::anyhow!("{e}"))?;
    }
    let s = net::open(c).await?;
    let me = s.zid().to_string();
    let _t = if std::env::var_os("NOLIV").is_none() {
        Some(s.liveliness().declare_token(format!("stall/alive/{me}")).await.map_err(|e| anyhow::anyhow!("{e}"))?)
    } else {
        None
    };
    let sub = s.declare_subscriber("stall/ping").await.map_err(|e| anyhow::anyhow!("{e}"))?;
    let mut worst = 0u64;
    let mut last_print = now_ms();
    loop {
        if let Ok(Ok(smp)) = tokio::time::timeout(Duration::from_millis(200), sub.recv_async()).await {
            let sent: u64 = String::from_utf8_lossy(&smp.payload().to_bytes()).parse().unwrap_or(0);
            worst = worst.max(now_ms().saturating_sub(sent));
        }
        if now_ms() - last_print >= 1000 {
            println!("{} worst delay {} ms", now_ms() % 100_000, worst);
            worst = 0;
            last_print = now_ms();
        }
    }
}
