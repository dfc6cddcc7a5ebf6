//! `mrmm planner-service`: planner services (`mrmm/planner/<kind>`) in their own process.

use mrmm_proto::net::{self, Mode, DEFAULT_CENTRAL, DEFAULT_LEASE_MS};

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Endpoints to connect to (repeatable).
    #[arg(long, default_value = DEFAULT_CENTRAL)]
    connect: Vec<String>,
    /// Endpoint to listen on (explicit address; port 0 picks one).
    #[arg(long, default_value = "tcp/127.0.0.1:0")]
    listen: Vec<String>,
}

pub async fn run(args: Args) -> anyhow::Result<()> {
    net::validate_endpoints("--connect", &args.connect).map_err(anyhow::Error::msg)?;
    net::validate_endpoints("--listen", &args.listen).map_err(anyhow::Error::msg)?;
    let session = net::open(net::zenoh_config(Mode::Peer, &args.listen, &args.connect, DEFAULT_LEASE_MS)?).await?;
    println!("planner-service ready zid={} listening={}", session.zid(), net::listening_endpoints(&session).await.join(","));
    let shutdown = super::shutdown::on_signals()?;
    mrmm_manager::planner_service::serve(session.clone(), shutdown).await?;
    let _ = session.close().await;
    Ok(())
}
