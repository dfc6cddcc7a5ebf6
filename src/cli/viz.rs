//! `mrmm viz`: the live fleet view in Rerun (a viewer, a spawned viewer, or an `.rrd` file).

use std::path::PathBuf;
use std::time::Duration;

use mrmm_proto::net::{self, Mode, DEFAULT_CENTRAL, DEFAULT_LEASE_MS};
use mrmm_viz::Sink;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Stream to a running Rerun viewer, e.g. rerun+http://127.0.0.1:9876/proxy.
    #[arg(long, group = "sink")]
    connect: Option<String>,
    /// Record to an .rrd file (open it later with `rerun FILE.rrd`).
    #[arg(long, group = "sink")]
    save: Option<PathBuf>,
    /// Spawn a Rerun viewer (needs `rerun` on PATH).
    #[arg(long, group = "sink")]
    spawn: bool,
    /// Central endpoint (repeatable).
    #[arg(long, default_value = DEFAULT_CENTRAL)]
    central: Vec<String>,
    /// Stop after this many seconds.
    #[arg(long)]
    duration: Option<f64>,
}

/// Picks the sink from the flags: `--connect`, `--save` or `--spawn` (default: the local viewer).
pub fn sink(connect: Option<String>, save: Option<PathBuf>, spawn: bool) -> Sink {
    match (connect, save, spawn) {
        (_, Some(p), _) => Sink::Save(p),
        (_, _, true) => Sink::Spawn,
        (Some(url), _, _) => Sink::Connect(url),
        (None, None, false) => Sink::Connect("rerun+http://127.0.0.1:9876/proxy".into()),
    }
}

pub async fn run(args: Args) -> anyhow::Result<()> {
    net::validate_endpoints("--central", &args.central).map_err(anyhow::Error::msg)?;
    let session = net::open(net::zenoh_config(Mode::Peer, &["tcp/127.0.0.1:0".into()], &args.central, DEFAULT_LEASE_MS)?).await?;
    let shutdown = super::shutdown::on_signals()?;
    if let Some(d) = args.duration {
        anyhow::ensure!(d.is_finite() && d > 0.0, "--duration: must be a positive number of seconds");
        let s = shutdown.clone();
        tokio::spawn(async move {
            tokio::time::sleep(Duration::from_secs_f64(d)).await;
            s.cancel();
        });
    }
    mrmm_viz::run(session.clone(), sink(args.connect, args.save, args.spawn), shutdown).await?;
    let _ = session.close().await;
    Ok(())
}
