//! `mrmm console`: serves the browser console on loopback and prints its URL (with the access
//! token) on stdout.

use std::net::SocketAddr;
use std::time::Duration;

use mrmm_net::client::Client;
use mrmm_net::net::DEFAULT_CENTRAL;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Where the console listens: a loopback address (port 0 picks a free port).
    #[arg(long, default_value = "127.0.0.1:8080")]
    listen: SocketAddr,
    /// Tool config (JSON5: `connect`, `security`); default: the file `MRMM_TOOL_CONFIG` names.
    #[arg(long)]
    config: Option<std::path::PathBuf>,
    /// Central endpoint (repeatable; default: the tool config's, else tcp/127.0.0.1:7447).
    #[arg(long)]
    connect: Vec<String>,
    #[command(flatten)]
    security: super::security::SecurityArgs,
    /// How long to wait for central's answers.
    #[arg(long, default_value_t = 3000)]
    timeout_ms: u64,
    /// Stop after this many seconds.
    #[arg(long)]
    duration: Option<f64>,
}

pub async fn run(args: Args) -> anyhow::Result<()> {
    anyhow::ensure!(args.listen.ip().is_loopback(), "--listen {}: the console listens on loopback only (127.0.0.1 or [::1])", args.listen);
    let tool = super::security::ToolConfig::load(args.config.as_deref())?;
    let connect = tool.connect(&args.connect, DEFAULT_CENTRAL);
    let client = Client::connect_with(&connect, tool.security(&args.security, "operator"), Duration::from_millis(args.timeout_ms)).await?;
    let listener = tokio::net::TcpListener::bind(args.listen).await.map_err(|e| anyhow::anyhow!("--listen {}: {e}", args.listen))?;
    let addr = listener.local_addr()?;
    let token = mrmm_console::new_token()?;
    let shutdown = super::shutdown::on_signals()?;
    super::shutdown::cancel_after(&shutdown, args.duration)?;
    println!("mrmm console: http://{addr}/#token={token}");
    mrmm_console::run(client, listener, token, shutdown).await?;
    Ok(())
}
