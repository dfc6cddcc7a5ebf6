//! `mrmm planner-service`: planner services (`mrmm/planner/<kind>`) in their own process.

use mrmm_net::net::{self, Mode, DEFAULT_CENTRAL, DEFAULT_LEASE_MS, DEFAULT_MAX_MESSAGE_SIZE};
use mrmm_net::{Mesh, NodeNet};
use mrmm_proto::{Role, Sender};

use super::security::SecurityArgs;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// This service's name (its certificate's id in a secure fleet).
    #[arg(long, default_value = "planner")]
    name: String,
    /// Endpoints to connect to (repeatable).
    #[arg(long, default_value = DEFAULT_CENTRAL)]
    connect: Vec<String>,
    /// Endpoint to listen on (explicit address; port 0 picks one).
    #[arg(long, default_value = "tcp/127.0.0.1:0")]
    listen: Vec<String>,
    #[command(flatten)]
    security: SecurityArgs,
}

pub async fn run(args: Args) -> anyhow::Result<()> {
    mrmm_proto::validate_id(&args.name).map_err(|e| anyhow::anyhow!("--name: {e}"))?;
    let mesh = Mesh::open(&NodeNet {
        mode: Mode::Peer,
        listen: args.listen,
        connect: args.connect,
        lease_ms: DEFAULT_LEASE_MS,
        max_message_size: DEFAULT_MAX_MESSAGE_SIZE,
        security: args.security.section(&args.name),
        me: Some(Sender::new(Role::Planner, args.name.clone())),
        wire_stats: false,
    })
    .await?;
    let session = mesh.session().clone();
    println!("planner-service ready zid={} listening={}", session.zid(), net::listening_endpoints(&session).await.join(","));
    let shutdown = super::shutdown::on_signals()?;
    mrmm_manager::planner_service::serve(mesh, Default::default(), shutdown).await?;
    let _ = session.close().await;
    Ok(())
}
