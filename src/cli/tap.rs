//! `mrmm tap`: prints everything published on a key expression as JSON lines — telemetry decoded,
//! JSON payloads as they are — to watch the bus from any node (a peer linking to the nodes given).

use std::io::Write;
use std::time::{Duration, Instant};

use mrmm_net::net::{Mode, DEFAULT_CENTRAL, DEFAULT_LEASE_MS, DEFAULT_MAX_MESSAGE_SIZE};
use mrmm_net::{Mesh, NodeNet};
use mrmm_proto::{self as proto, Key};
use serde_json::{json, Value};

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Key expression to subscribe to, e.g. 'mrmm/missions/*/status' or 'mrmm/**'.
    key: String,
    /// Tool config (JSON5: `connect`, `security`); default: the file `MRMM_TOOL_CONFIG` names.
    #[arg(long)]
    config: Option<std::path::PathBuf>,
    /// Nodes to link to (repeatable): central and/or robots (default: the tool config's, else
    /// tcp/127.0.0.1:7447).
    #[arg(long)]
    connect: Vec<String>,
    #[command(flatten)]
    security: super::security::SecurityArgs,
    /// Endpoint to listen on (explicit address; port 0 picks one; default: tcp/127.0.0.1:0, or
    /// quic/127.0.0.1:0 with certificates).
    #[arg(long)]
    listen: Vec<String>,
    /// Stop after this many seconds.
    #[arg(long)]
    duration: Option<f64>,
}

/// A sample as one JSON value: telemetry decoded, JSON parsed (unpacked first if compressed),
/// anything else by size; `from` is its proven sender (`null` when its seal is refused).
fn line(t: f64, key: &str, bytes: &[u8], from: Option<String>) -> Value {
    let payload = match Key::parse(key) {
        Some(Key::RobotTelemetry(_)) => proto::decode_telemetry(bytes).ok().and_then(|t| serde_json::to_value(t).ok()),
        _ => proto::from_json::<Value>(key, bytes).ok(),
    };
    json!({"t": t, "key": key, "bytes": bytes.len(), "from": from, "payload": payload})
}

pub async fn run(args: Args) -> anyhow::Result<()> {
    if let Some(d) = args.duration {
        anyhow::ensure!(d.is_finite() && d > 0.0, "--duration: must be a positive number of seconds");
    }
    let tool = super::security::ToolConfig::load(args.config.as_deref())?;
    let security = tool.security(&args.security, "operator");
    let listen =
        if args.listen.is_empty() { vec![if security.is_some() { "quic/127.0.0.1:0" } else { "tcp/127.0.0.1:0" }.to_string()] } else { args.listen.clone() };
    let n = NodeNet {
        mode: Mode::Peer,
        listen,
        connect: tool.connect(&args.connect, DEFAULT_CENTRAL),
        lease_ms: DEFAULT_LEASE_MS,
        max_message_size: DEFAULT_MAX_MESSAGE_SIZE,
        security,
        me: None,
        wire_stats: false,
    };
    let (config, sealer, verifier) = mrmm_net::mesh::prepare(&n)?;
    let session = mrmm_net::net::open(config).await?;
    let mesh = Mesh::from_parts(session.clone(), sealer, verifier);
    let sub = session.declare_subscriber(args.key.as_str()).await.map_err(|e| anyhow::anyhow!("--key {:?}: {e}", args.key))?;
    let shutdown = super::shutdown::on_signals()?;
    let t0 = Instant::now();
    let until = args.duration.map(Duration::from_secs_f64);
    println!("{}", json!({"tap": args.key, "zid": session.zid().to_string()}));
    loop {
        let left = until.map(|u| u.saturating_sub(t0.elapsed()));
        if left.is_some_and(|l| l.is_zero()) {
            break;
        }
        let sleep = tokio::time::sleep(left.unwrap_or(Duration::from_secs(3600)));
        tokio::select! {
            _ = shutdown.cancelled() => break,
            _ = sleep => {}
            s = sub.recv_async() => {
                let Ok(s) = s else { break };
                // An observer: a message tagged for others shows its certificate's node.
                let from = mesh.verifier().observed_sender(s.key_expr().as_str(), &s.payload().to_bytes(), s.attachment().map(|a| a.to_bytes()).as_deref(), mrmm_net::mesh::now_ms()).ok().map(|s| s.to_string());
                let l = line(t0.elapsed().as_secs_f64(), s.key_expr().as_str(), &s.payload().to_bytes(), from);
                let mut out = std::io::stdout().lock();
                writeln!(out, "{l}")?;
                out.flush()?;
            }
        }
    }
    let _ = session.close().await;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_decode_what_they_can() {
        let v = line(1.0, "x/y", br#"{"a": 1}"#, Some("robot:r1".into()));
        assert_eq!((v["payload"]["a"].clone(), v["from"].clone()), (json!(1), json!("robot:r1")));
        let v = line(1.0, "x/y", b"\xff\x00", None);
        assert_eq!((v["payload"].clone(), v["bytes"].clone()), (Value::Null, json!(2)));
    }
}
