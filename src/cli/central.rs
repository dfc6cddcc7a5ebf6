//! `mrmm central`: the router and system manager.

use std::path::PathBuf;

use mrmm_manager::central::{self, CentralConfig};
use tokio::sync::oneshot;

use super::security::SecurityArgs;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// JSON5 config file (listen, lease_ms, query_timeout_ms).
    #[arg(long)]
    config: Option<PathBuf>,
    /// Endpoint to listen on (repeatable); overrides the config. Port 0 picks a free port.
    #[arg(long)]
    listen: Vec<String>,
    #[command(flatten)]
    security: SecurityArgs,
    /// An operator allowed to command the fleet (the id of an operator certificate; repeatable);
    /// with --pki or --ca, overrides the config's `security.operators`.
    #[arg(long)]
    operator: Vec<String>,
    /// Where central keeps its journal; overrides the config's `state_dir`. Default: the
    /// per-user data directory, `$XDG_DATA_HOME/mrmm/central` (`~/.local/share/mrmm/central`).
    #[arg(long)]
    state_dir: Option<PathBuf>,
    /// Count messages on the wire per kind, readable by the mesh through the admin space
    /// (experiments only); overrides the config's `wire_stats`.
    #[arg(long)]
    wire_stats: bool,
    /// A map missions may plan on, NAME=FILE (repeatable; a Nav2 map's YAML, a patrolling_sim
    /// .graph or an Open-RMF navigation graph); added to the config's `maps`.
    #[arg(long = "map", value_name = "NAME=FILE")]
    maps: Vec<String>,
    /// A grid map (by name) whose robots drive their plans without traffic, on no lanes
    /// (repeatable); added to the config's `no_lanes`.
    #[arg(long = "no-lanes", value_name = "NAME")]
    no_lanes: Vec<String>,
    /// The floor plan a graph map (by name) is drawn on, NAME=FILE (a Nav2 map's YAML in the
    /// graph's frame; repeatable): lanes are marked passing where it has room for two robots
    /// side by side; added to the config's `floor_plans`.
    #[arg(long = "floor-plan", value_name = "NAME=FILE")]
    floor_plans: Vec<String>,
}

/// The per-user data directory central keeps its journal in when nothing else is said.
pub fn default_state_dir() -> anyhow::Result<PathBuf> {
    let base = match std::env::var_os("XDG_DATA_HOME").filter(|v| !v.is_empty()) {
        Some(d) => PathBuf::from(d),
        None => match std::env::var_os("HOME").filter(|v| !v.is_empty()) {
            Some(h) => PathBuf::from(h).join(".local").join("share"),
            None => anyhow::bail!("--state-dir: no HOME or XDG_DATA_HOME to find the per-user data directory; give --state-dir DIR"),
        },
    };
    Ok(base.join("mrmm").join("central"))
}

pub async fn run(args: Args) -> anyhow::Result<()> {
    let mut cfg = match &args.config {
        Some(p) => CentralConfig::load(p)?,
        None => CentralConfig::default(),
    };
    if !args.listen.is_empty() {
        cfg.listen = args.listen;
    }
    if let Some(mut sec) = args.security.section("central") {
        sec.operators = if args.operator.is_empty() { cfg.security.as_ref().map(|s| s.operators.clone()).unwrap_or_default() } else { args.operator };
        cfg.security = Some(sec);
    } else if !args.operator.is_empty() {
        anyhow::bail!("--operator: needs certificates (--pki DIR, or --ca/--cert/--key, or a `security` section)");
    }
    if args.wire_stats {
        cfg.wire_stats = true;
    }
    for m in &args.maps {
        let (name, file) = m.split_once('=').ok_or_else(|| anyhow::anyhow!("--map {m:?}: expected NAME=FILE"))?;
        cfg.maps.insert(name.to_string(), PathBuf::from(file));
    }
    for m in &args.floor_plans {
        let (name, file) = m.split_once('=').ok_or_else(|| anyhow::anyhow!("--floor-plan {m:?}: expected NAME=FILE"))?;
        cfg.floor_plans.insert(name.to_string(), PathBuf::from(file));
    }
    cfg.no_lanes.extend(args.no_lanes);
    if let Some(d) = args.state_dir {
        cfg.state_dir = Some(d);
    }
    if cfg.state_dir.is_none() {
        cfg.state_dir = Some(default_state_dir()?);
    }
    cfg.validate().map_err(|e| anyhow::anyhow!("central config: {e}"))?;
    let shutdown = super::shutdown::on_signals()?;
    let (tx, rx) = oneshot::channel();
    let task = tokio::spawn(central::run(cfg, shutdown, Some(tx)));
    if let Ok(r) = rx.await {
        // One line on stdout that scripts and tests can wait for.
        println!("central ready zid={} listening={}", r.zid, r.endpoints.join(","));
    }
    task.await??;
    Ok(())
}
