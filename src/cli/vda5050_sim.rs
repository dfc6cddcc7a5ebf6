//! `mrmm vda5050-sim`: simulated VDA 5050 vehicles, on an MQTT broker of their own (embedded,
//! for the demo and the benchmarks) or on the one given.

use std::net::SocketAddr;

use anyhow::anyhow;
use mrmm_node::vda5050::config::Broker;
use mrmm_node::vda5050::sim::{SimFleet, SimSpec};
use mrmm_vda5050::{Topics, VehicleId};

#[derive(Debug, clap::Args)]
pub struct Args {
    /// How many vehicles: serial numbers agv1 … agvN.
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(1..=1000))]
    vehicles: u32,
    /// Use this broker (mqtt://host:port) instead of starting one.
    #[arg(long, conflicts_with = "listen")]
    broker: Option<String>,
    /// Where the embedded broker listens (loopback; port 0: a free one, said in the ready line).
    #[arg(long, default_value = "127.0.0.1:1883")]
    listen: SocketAddr,
    /// The vehicles' manufacturer (the topics' third level).
    #[arg(long, default_value = "mrmm")]
    manufacturer: String,
    /// The map the vehicles report their position on (`mapId`).
    #[arg(long, default_value = "mrmm")]
    map_id: String,
    /// Where vehicle i starts, `x,y` (repeat for each; default: a row along y = -16).
    #[arg(long = "at", value_parser = point, allow_hyphen_values = true)]
    at: Vec<(f64, f64)>,
    /// Top speed, m/s.
    #[arg(long, default_value_t = 1.0)]
    speed: f64,
}

fn point(s: &str) -> Result<(f64, f64), String> {
    let (x, y) = s.split_once(',').ok_or_else(|| format!("{s:?}: give x,y"))?;
    let num = |v: &str| v.trim().parse::<f64>().ok().filter(|v| v.is_finite()).ok_or_else(|| format!("{s:?}: {v:?} is not a number"));
    Ok((num(x)?, num(y)?))
}

pub async fn run(args: Args) -> anyhow::Result<()> {
    if !(args.speed.is_finite() && args.speed > 0.0 && args.speed <= mrmm_proto::MAX_SPEED) {
        return Err(anyhow!("--speed: a top speed in (0, {}] m/s (got {})", mrmm_proto::MAX_SPEED, args.speed));
    }
    let n = args.vehicles as usize;
    if !args.at.is_empty() && args.at.len() != n {
        return Err(anyhow!("--at: {} positions for {n} vehicles", args.at.len()));
    }
    let broker = match &args.broker {
        Some(b) => match Broker::parse(b).map_err(|e| anyhow!("--{e}"))? {
            b if b.tls => return Err(anyhow!("--broker: {:?}: the simulated vehicles speak mqtt:// only", b.url())),
            b => b,
        },
        None => {
            let at = mrmm_node::vda5050::broker::start(args.listen)?;
            Broker { host: at.ip().to_string(), port: at.port(), tls: false }
        }
    };
    let mut vehicles = Vec::with_capacity(n);
    for i in 0..n {
        let vehicle = VehicleId::new(&args.manufacturer, &format!("agv{}", i + 1)).map_err(|e| anyhow!("--manufacturer: {e}"))?;
        let (x, y) = args.at.get(i).copied().unwrap_or(((i as f64 - (n as f64 - 1.0) / 2.0) * 1.5, -16.0));
        vehicles.push(SimSpec { vehicle, start: (x, y, 0.0), speed_max: args.speed });
    }
    let fleet = SimFleet { broker, topics: Topics::default(), map_id: args.map_id, vehicles };
    let shutdown = super::shutdown::on_signals()?;
    Ok(mrmm_node::vda5050::sim::run(fleet, shutdown).await?)
}
