//! `mrmm tap`: prints everything published on a key expression as JSON lines — telemetry decoded,
//! JSON payloads as they are — to watch the bus from any node (a peer linking to the nodes given).

use std::io::Write;
use std::time::{Duration, Instant};

use mrmm_proto::net::{self, Mode, DEFAULT_CENTRAL, DEFAULT_LEASE_MS};
use mrmm_proto::{self as proto, Key};
use serde_json::{json, Value};

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Key expression to subscribe to, e.g. 'mrmm/missions/*/status' or 'mrmm/**'.
    key: String,
    /// Nodes to link to (repeatable): central and/or robots.
    #[arg(long, default_value = DEFAULT_CENTRAL)]
    connect: Vec<String>,
    /// Endpoint to listen on (explicit address; port 0 picks one).
    #[arg(long, default_value = "tcp/127.0.0.1:0")]
    listen: Vec<String>,
    /// Stop after this many seconds.
    #[arg(long)]
    duration: Option<f64>,
}

/// A sample as one JSON value: telemetry decoded, JSON parsed, anything else by size.
fn line(t: f64, key: &str, bytes: &[u8]) -> Value {
    let payload = match Key::parse(key) {
        Some(Key::RobotTelemetry(_)) => proto::decode_telemetry(bytes).ok().and_then(|t| serde_json::to_value(t).ok()),
        _ => serde_json::from_slice::<Value>(bytes).ok(),
    };
    json!({"t": t, "key": key, "bytes": bytes.len(), "payload": payload})
}

pub async fn run(args: Args) -> anyhow::Result<()> {
    net::validate_endpoints("--connect", &args.connect).map_err(anyhow::Error::msg)?;
    net::validate_endpoints("--listen", &args.listen).map_err(anyhow::Error::msg)?;
    if let Some(d) = args.duration {
        anyhow::ensure!(d.is_finite() && d > 0.0, "--duration: must be a positive number of seconds");
    }
    let session = net::open(net::zenoh_config(Mode::Peer, &args.listen, &args.connect, DEFAULT_LEASE_MS)?).await?;
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
                let l = line(t0.elapsed().as_secs_f64(), s.key_expr().as_str(), &s.payload().to_bytes());
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
        let v = line(1.0, "x/y", br#"{"a": 1}"#);
        assert_eq!(v["payload"]["a"], 1);
        let v = line(1.0, "x/y", b"\xff\x00");
        assert_eq!((v["payload"].clone(), v["bytes"].clone()), (Value::Null, json!(2)));
    }
}
