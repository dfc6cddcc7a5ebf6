//! `mrmm vda5050`: the VDA 5050 gateway — every vehicle on the MQTT broker joins the fleet as a
//! robot of its own (config file first, flags override).

use std::path::PathBuf;

use anyhow::anyhow;
use mrmm_node::vda5050::GatewayConfig;
use mrmm_peer::config::RobotConfig;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// JSON5 gateway config (broker, interface, map, the vehicles' robot config, ids).
    #[arg(long)]
    config: PathBuf,
    /// Override the broker: mqtt://host:port, or mqtts://host:port (TLS: `tls` in the config).
    #[arg(long)]
    broker: Option<String>,
    /// Override the topics' interface name (`uagv`).
    #[arg(long)]
    interface: Option<String>,
    /// Override the topics' major version (`v2`).
    #[arg(long)]
    version: Option<String>,
    /// Override the endpoints the vehicles' robots connect to (repeatable).
    #[arg(long)]
    connect: Vec<String>,
    /// Fleet PKI directory: each vehicle's robot uses DIR/ca.crt and DIR/<robot id>.crt, .key.
    #[arg(long, value_name = "DIR")]
    pki: Option<PathBuf>,
}

pub async fn run(args: Args) -> anyhow::Result<()> {
    let file = args.config.display().to_string();
    let mut cfg = GatewayConfig::read(&args.config).map_err(|e| anyhow!(e))?;
    let overridden = args.broker.is_some() || args.interface.is_some() || args.version.is_some() || !args.connect.is_empty() || args.pki.is_some();
    let how = if overridden { " (with command-line overrides)" } else { "" };
    if let Some(b) = args.broker {
        cfg.broker = b;
    }
    if let Some(i) = args.interface {
        cfg.interface = i;
    }
    if let Some(v) = args.version {
        cfg.version = v;
    }
    cfg.validate().map_err(|e| anyhow!("{file}{how}: {e}"))?;
    let mut template = RobotConfig::read(&cfg.robot)?;
    if !args.connect.is_empty() {
        template.zenoh.connect = args.connect;
    }
    if let Some(dir) = &args.pki {
        template.security = Some(mrmm_proto::SecuritySection::from_dir(dir, &template.id));
    }
    template.validate().map_err(|e| anyhow!("{}{how}: {e}", cfg.robot.display()))?;
    let shutdown = super::shutdown::on_signals()?;
    Ok(mrmm_node::vda5050::run(cfg, template, shutdown).await?)
}
