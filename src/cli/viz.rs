//! `mrmm viz`: the live fleet view in Rerun (a viewer, a spawned viewer, or an `.rrd` file).

use std::path::PathBuf;

use mrmm_net::net::{Mode, DEFAULT_CENTRAL, DEFAULT_LEASE_MS, DEFAULT_MAX_MESSAGE_SIZE};

use mrmm_net::{Mesh, NodeNet};
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
    /// Central endpoint (repeatable; default: the tool config's, else tcp/127.0.0.1:7447).
    #[arg(long)]
    central: Vec<String>,
    /// Tool config (JSON5: `connect`, `security`); default: the file `MRMM_TOOL_CONFIG` names.
    #[arg(long)]
    config: Option<PathBuf>,
    #[command(flatten)]
    security: super::security::SecurityArgs,
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
    let tool = super::security::ToolConfig::load(args.config.as_deref())?;
    let security = tool.security(&args.security, "operator");
    let listen = vec![if security.is_some() { "quic/127.0.0.1:0" } else { "tcp/127.0.0.1:0" }.to_string()];
    let n = NodeNet {
        mode: Mode::Peer,
        listen,
        connect: tool.connect(&args.central, DEFAULT_CENTRAL),
        lease_ms: DEFAULT_LEASE_MS,
        max_message_size: DEFAULT_MAX_MESSAGE_SIZE,
        security,
        me: None,
        wire_stats: false,
    };
    let (config, sealer, verifier) = mrmm_net::mesh::prepare(&n)?;
    let session = mrmm_net::net::open(config).await?;
    let mesh = Mesh::from_parts(session.clone(), sealer, verifier);
    let shutdown = super::shutdown::on_signals()?;
    super::shutdown::cancel_after(&shutdown, args.duration)?;
    mrmm_viz::run(mesh, sink(args.connect, args.save, args.spawn), shutdown).await?;
    let _ = session.close().await;
    Ok(())
}
