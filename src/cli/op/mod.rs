//! `mrmm op`: operator commands; thin clients of the system manager's keys.

pub mod journal;
pub mod mission;
mod robot;
mod traffic;

use std::time::Duration;

use mrmm_net::client::Client;
use mrmm_net::net::DEFAULT_CENTRAL;
use mrmm_proto::{self as proto, Advice, RobotView, SystemStatus};
use serde_json::Value;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Tool config (JSON5: `connect`, `security`); default: the file `MRMM_TOOL_CONFIG` names.
    #[arg(long)]
    config: Option<std::path::PathBuf>,
    /// Central endpoint (repeatable; default: the tool config's, else tcp/127.0.0.1:7447).
    #[arg(long)]
    connect: Vec<String>,
    #[command(flatten)]
    security: super::security::SecurityArgs,
    /// Print the raw JSON answer instead of a table.
    #[arg(long)]
    json: bool,
    /// How long to wait for an answer.
    #[arg(long, default_value_t = 3000)]
    timeout_ms: u64,
    #[command(subcommand)]
    what: What,
}

#[derive(Debug, clap::Subcommand)]
enum What {
    /// The fleet table (`mrmm/system/robots`).
    Robots,
    /// One robot (`mrmm/system/robots/<id>`).
    Robot { id: String },
    /// Fleet summary (`mrmm/system/status`).
    Status,
    #[command(flatten)]
    Order(robot::Order),
    /// Missions: create, terminate, list, show, marginal.
    #[command(subcommand)]
    Mission(mission::Mission),
    /// The missions table (same as `mission list`).
    Missions,
    /// The maps missions may plan on: name, format, size, content hash (`mrmm/system/maps`).
    Maps,
    /// Traffic on the graph maps: each robot's route, how far it got and may go, what it holds,
    /// whom it waits for and since when, blocked or not (`mrmm/system/traffic`).
    Traffic {
        /// Only this map (its name, or the start of its hash).
        map: Option<String>,
        /// Take this lost robot off the lanes instead (`mrmm/system/cmd/traffic/clear`): all it
        /// held is freed for the robots waiting for it. Only once it is really gone from there.
        #[arg(long, value_name = "ROBOT")]
        clear: Option<String>,
    },
    /// The advising agent's standing advice, most urgent first (`mrmm/agent/advice`).
    Advice,
    /// Central's journal: commands, membership changes, losses, takeovers, replans
    /// (`mrmm/system/journal?since=SEQ`).
    Journal {
        /// Only entries after this sequence number.
        #[arg(long, default_value_t = 0)]
        since: u64,
    },
    /// Live console: fleet, missions and advice, redrawn in place every second (Ctrl-C stops).
    Watch {
        /// Stop after this many seconds.
        #[arg(long)]
        duration: Option<f64>,
    },
}

pub async fn run(args: Args) -> anyhow::Result<()> {
    let tool = super::security::ToolConfig::load(args.config.as_deref())?;
    let connect = tool.connect(&args.connect, DEFAULT_CENTRAL);
    let client = Client::connect_with(&connect, tool.security(&args.security, "operator"), Duration::from_millis(args.timeout_ms)).await?;
    let result = exec(&client, args.what, args.json).await;
    client.close().await;
    result.map_err(with_code)
}

/// Central's error with its code after its words (`unknown robot "r9" [not_found]`), so that a
/// script reading the tool's output can tell "no such thing" from "try again".
fn with_code(e: anyhow::Error) -> anyhow::Error {
    match e.downcast_ref::<proto::ProtoError>() {
        Some(proto::ProtoError::Query(proto::QueryError::Remote(r))) => match r.code {
            Some(code) => anyhow::anyhow!("{} [{}]", r.error, code.as_str()),
            None => e,
        },
        _ => e,
    }
}

async fn exec(client: &Client, what: What, json: bool) -> anyhow::Result<()> {
    let none = None::<&()>;
    match what {
        What::Robots => {
            let v: Value = client.query(proto::Key::SystemRobots, none).await?;
            if json {
                return print_json(&v);
            }
            let views: Vec<RobotView> = serde_json::from_value(v)?;
            print!("{}", super::table::robots(&views));
        }
        What::Robot { id } => {
            let v: Value = client.query(proto::Key::SystemRobot(id.into()), none).await?;
            if json {
                return print_json(&v);
            }
            let view: RobotView = serde_json::from_value(v)?;
            print!("{}", super::table::robots(&[view]));
        }
        What::Status => {
            let v: Value = client.query(proto::Key::SystemStatus, none).await?;
            if json {
                return print_json(&v);
            }
            let s: SystemStatus = serde_json::from_value(v)?;
            println!("central {}  up {:.0} s", s.node, s.uptime_s);
            println!("robots  {} total: {} idle, {} busy, {} lost", s.robots_total, s.idle, s.busy, s.lost);
        }
        What::Order(o) => robot::exec(client, o, json).await?,
        What::Mission(m) => mission::exec(client, m, json).await?,
        What::Missions => mission::exec(client, mission::Mission::List, json).await?,
        What::Maps => {
            let v: Value = client.query(proto::Key::SystemMaps, none).await?;
            if json {
                return print_json(&v);
            }
            let maps: Vec<proto::MapInfo> = serde_json::from_value(v)?;
            print!("{}", super::table::maps(&maps));
        }
        What::Traffic { clear: Some(robot), .. } => traffic::clear(client, &robot, json).await?,
        What::Traffic { map, clear: None } => traffic::exec(client, map, json).await?,
        What::Advice => {
            let v: Value = client.query(proto::Key::AgentAdvice, none).await?;
            if json {
                return print_json(&v);
            }
            let advice: Vec<Advice> = serde_json::from_value(v)?;
            print!("{}", advice_lines(&advice));
        }
        What::Journal { since } => journal::exec(client, since, json).await?,
        What::Watch { duration } => watch(client, duration).await?,
    }
    Ok(())
}

/// Advice as lines: level, reason, and the suggested command under it.
fn advice_lines(advice: &[Advice]) -> String {
    if advice.is_empty() {
        return "no advice\n".into();
    }
    let mut out = String::new();
    for a in advice {
        let level = serde_json::to_value(a.priority).ok().and_then(|p| p.as_str().map(str::to_uppercase)).unwrap_or_default();
        out.push_str(&format!("{level:<8} {}\n", a.reason));
        if let Some(s) = &a.suggestion {
            out.push_str(&format!("         → {s}\n"));
        }
    }
    out
}

/// The live console.
async fn watch(client: &Client, duration: Option<f64>) -> anyhow::Result<()> {
    use std::io::{IsTerminal, Write};
    let start = std::time::Instant::now();
    let tty = std::io::stdout().is_terminal();
    let shutdown = super::shutdown::on_signals()?;
    let mut tick = tokio::time::interval(Duration::from_secs(1));
    loop {
        tokio::select! {
            _ = shutdown.cancelled() => break,
            _ = tick.tick() => {}
        }
        if duration.is_some_and(|d| start.elapsed().as_secs_f64() >= d) {
            break;
        }
        let none = None::<&()>;
        let robots: Vec<RobotView> = client.query(proto::Key::SystemRobots, none).await.unwrap_or_default();
        let missions: Vec<proto::MissionView> = client.query(proto::Key::SystemMissions, none).await.unwrap_or_default();
        let advice: Vec<Advice> = client.query(proto::Key::AgentAdvice, none).await.unwrap_or_default();
        let mut out = String::new();
        if tty {
            out.push_str("\x1b[H\x1b[2J");
        }
        out.push_str(&format!(
            "mrmm watch  t={:.0}s  robots {}  missions {}  advice {}  (Ctrl-C to stop)\n\n",
            start.elapsed().as_secs_f64(),
            robots.len(),
            missions.len(),
            advice.len()
        ));
        out.push_str(&super::table::robots(&robots));
        out.push('\n');
        out.push_str(&mission::table(&missions));
        out.push('\n');
        out.push_str(&advice_lines(&advice));
        out.push('\n');
        let mut stdout = std::io::stdout().lock();
        stdout.write_all(out.as_bytes())?;
        stdout.flush()?;
    }
    Ok(())
}

pub fn print_json(v: &Value) -> anyhow::Result<()> {
    println!("{}", serde_json::to_string_pretty(v)?);
    Ok(())
}
