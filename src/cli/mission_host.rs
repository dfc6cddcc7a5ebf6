//! `mrmm mission-host`: a mission host (runs mission managers) in its own process.

use mrmm_net::net::{self, Mode, DEFAULT_CENTRAL, DEFAULT_LEASE_MS, DEFAULT_MAX_MESSAGE_SIZE};
use mrmm_net::{Mesh, NodeNet};
use mrmm_proto::{Role, Sender};

use super::security::SecurityArgs;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Host name: missions are started on it with `"host": NAME`.
    #[arg(long)]
    name: String,
    /// Endpoints to connect to (repeatable).
    #[arg(long, default_value = DEFAULT_CENTRAL)]
    connect: Vec<String>,
    /// Endpoint to listen on (explicit address; port 0 picks one).
    #[arg(long, default_value = "tcp/127.0.0.1:0")]
    listen: Vec<String>,
    /// Keep the chain state (vote promises, replicated mission state) in this directory, so a
    /// restart never forgets what this host promised or acknowledged. Without it the host is
    /// stateless: a restart loses what it replicated.
    #[arg(long)]
    state_dir: Option<std::path::PathBuf>,
    #[command(flatten)]
    security: SecurityArgs,
}

pub async fn run(args: Args) -> anyhow::Result<()> {
    mrmm_proto::validate_id(&args.name).map_err(|e| anyhow::anyhow!("--name: {e}"))?;
    // Opened before anything else: a state dir another process uses, or a damaged one, stops
    // start-up with one line.
    let stored = match &args.state_dir {
        Some(dir) => Some(mrmm_manager::host::store::Store::open(dir).map_err(|e| anyhow::anyhow!("--state-dir: {e}"))?),
        None => None,
    };
    let mesh = Mesh::open(&NodeNet {
        mode: Mode::Peer,
        listen: args.listen,
        connect: args.connect,
        lease_ms: DEFAULT_LEASE_MS,
        max_message_size: DEFAULT_MAX_MESSAGE_SIZE,
        security: args.security.section(&args.name),
        me: Some(Sender::new(Role::Host, args.name.clone())),
        wire_stats: false,
    })
    .await?;
    let session = mesh.session().clone();
    println!("mission-host ready name={} zid={} listening={}", args.name, session.zid(), net::listening_endpoints(&session).await.join(","));
    let shutdown = super::shutdown::on_signals()?;
    mrmm_manager::host::serve(mesh, args.name, None, stored, Default::default(), shutdown).await?;
    let _ = session.close().await;
    Ok(())
}
