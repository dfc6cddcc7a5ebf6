//! `mrmm sim-fleet`: many simulated robots in one process — each its own robot (identity, Zenoh
//! session, liveliness, mission host and chain state), all on one runtime, so one computer can
//! simulate hundreds of them. Robots are crashed and started again one by one from stdin.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::time::Duration;

use anyhow::{anyhow, bail};
use mrmm_peer::config::{BodySection, RobotConfig};
use tokio::signal::unix::{signal, SignalKind};
use tokio::sync::oneshot;
use tokio::task::JoinSet;
use tokio_util::sync::CancellationToken;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Robot config (repeatable): one robot per file. With --robots, the one file is a template.
    #[arg(long = "config", required = true)]
    configs: Vec<PathBuf>,
    /// Run this many robots from the one --config: ids <id>1 … <id>N (the template's id is the
    /// prefix), start poses on a grid from the template's start, chain state in
    /// <state_dir>/<id>, certificates <id>.crt and <id>.key beside the template's.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=10_000))]
    robots: Option<u32>,
    /// Grid spacing of the start poses --robots makes, metres.
    #[arg(long, default_value_t = 1.5)]
    spacing: f64,
    /// Robots started per second (0: all at once). Every robot opens a link to each robot of its
    /// clique; a burst of hundreds of handshakes starves the leases.
    #[arg(long, default_value_t = 20)]
    rate: u32,
    /// Override every robot's endpoints to connect to (repeatable).
    #[arg(long)]
    connect: Vec<String>,
    /// Fleet PKI directory: every robot uses DIR/ca.crt and its own DIR/<id>.crt, DIR/<id>.key.
    #[arg(long, value_name = "DIR")]
    pki: Option<PathBuf>,
}

pub async fn run(args: Args) -> anyhow::Result<()> {
    let configs = configs(&args)?;
    let shutdown = super::shutdown::on_signals()?;
    let mut fleet = Fleet { configs: configs.iter().map(|c| (c.id.clone(), c.clone())).collect(), ..Fleet::default() };
    let (ready_tx, mut ready_rx) = tokio::sync::mpsc::unbounded_channel();
    // Started gradually, each robot on its own task: a slow one does not hold up the others.
    let pace = (args.rate > 0).then(|| Duration::from_secs_f64(1.0 / f64::from(args.rate)));
    let mut to_start = configs.into_iter();
    let mut ticker = tokio::time::interval(pace.unwrap_or(Duration::from_millis(1)));
    let total = fleet.configs.len();
    let mut ready = 0;
    let mut stdin = stdin_lines();
    let mut usr1 = signal(SignalKind::user_defined1())?;
    loop {
        tokio::select! {
            _ = shutdown.cancelled() => break,
            _ = ticker.tick(), if to_start.len() > 0 => {
                let batch = if pace.is_some() { 1 } else { to_start.len() };
                for cfg in to_start.by_ref().take(batch) {
                    fleet.spawn(cfg, &shutdown, &ready_tx);
                }
            }
            Some(id) = ready_rx.recv() => {
                ready += 1;
                if ready == total {
                    println!("sim-fleet ready robots={total}");
                }
                tracing::debug!(robot = %id, "ready");
            }
            Some(done) = fleet.tasks.join_next() => {
                let (id, result) = done.map_err(|e| anyhow!("robot task: {e}"))?;
                fleet.running.remove(&id);
                match result {
                    // Not all of them up yet: a robot that cannot start stops start-up.
                    Err(e) if ready < total => {
                        shutdown.cancel();
                        fleet.stop_all().await;
                        bail!("robot {id}: {e:#}");
                    }
                    Err(e) => tracing::warn!(robot = %id, "stopped: {e:#}"),
                    Ok(()) => {}
                }
            }
            Some(line) = stdin.recv() => fleet.command(&line, &shutdown, &ready_tx),
            _ = usr1.recv() => {
                let last = fleet.alive().next_back().map(String::from);
                if let Some(id) = last {
                    fleet.kill(&id);
                }
            }
        }
    }
    fleet.stop_all().await;
    Ok(())
}

/// Lines of stdin, read on a thread of their own (Tokio's stdin would hold up the runtime's
/// shutdown while a read blocks).
fn stdin_lines() -> tokio::sync::mpsc::Receiver<String> {
    let (tx, rx) = tokio::sync::mpsc::channel(64);
    std::thread::spawn(move || {
        for line in std::io::stdin().lines() {
            let Ok(line) = line else { break };
            if tx.blocking_send(line).is_err() {
                break;
            }
        }
    });
    rx
}

/// The robots the flags describe, validated; ids unique.
fn configs(args: &Args) -> anyhow::Result<Vec<RobotConfig>> {
    // Each robot's config with the file it came from (named in its errors).
    let (mut configs, files): (Vec<RobotConfig>, Vec<&PathBuf>) = match args.robots {
        Some(n) => {
            let [template] = args.configs.as_slice() else { bail!("--robots takes one --config, the template (got {})", args.configs.len()) };
            anyhow::ensure!(args.spacing.is_finite() && args.spacing > 0.0, "--spacing: must be a positive number of metres (got {})", args.spacing);
            let cfg = RobotConfig::read(template)?;
            expand(&cfg, n as usize, args.spacing).into_iter().map(|c| (c, template)).unzip()
        }
        None => args
            .configs
            .iter()
            .map(|p| RobotConfig::read(p).map(|c| (c, p)).map_err(anyhow::Error::from))
            .collect::<anyhow::Result<Vec<_>>>()?
            .into_iter()
            .unzip(),
    };
    let overridden = args.robots.is_some() || !args.connect.is_empty() || args.pki.is_some();
    let how = if overridden { " (with command-line overrides)" } else { "" };
    let mut seen = std::collections::BTreeSet::new();
    let mut ports = BTreeMap::new();
    for (cfg, file) in configs.iter_mut().zip(files) {
        if !args.connect.is_empty() {
            cfg.zenoh.connect = args.connect.clone();
        }
        if let Some(dir) = &args.pki {
            cfg.security = Some(mrmm_proto::SecuritySection::from_dir(dir, &cfg.id));
        }
        if matches!(cfg.body, BodySection::Ros2(_)) {
            bail!("robot {}: sim-fleet runs simulated bodies only; run a ROS 2 robot with `mrmm robot`", cfg.id);
        }
        anyhow::ensure!(seen.insert(cfg.id.clone()), "robot {}: two configs give this id; every robot needs its own", cfg.id);
        for ep in cfg.zenoh.listen.iter().filter(|e| !e.ends_with(":0")) {
            if let Some(other) = ports.insert(ep.clone(), cfg.id.clone()) {
                bail!("robot {}: zenoh.listen {ep} is robot {other}'s too: give each robot its own port, or port 0", cfg.id);
            }
        }
        cfg.validate().map_err(|e| anyhow!("{}: robot {}{how}: {e}", file.display(), cfg.id))?;
    }
    Ok(configs)
}

/// `n` robots from `template`: ids `<id>1 … <id>n`, start poses on a square grid of `spacing`
/// metres from the template's start, each its own chain state directory and certificate.
fn expand(template: &RobotConfig, n: usize, spacing: f64) -> Vec<RobotConfig> {
    let cols = (n as f64).sqrt().ceil().max(1.0) as usize;
    (0..n)
        .map(|k| {
            let mut cfg = template.clone();
            cfg.id = format!("{}{}", template.id, k + 1);
            cfg.start.x += (k % cols) as f64 * spacing;
            cfg.start.y += (k / cols) as f64 * spacing;
            if let Some(dir) = &template.state_dir {
                cfg.state_dir = Some(dir.join(&cfg.id));
            }
            cfg.security = cfg.security.map(|sec| sec.for_name(&cfg.id));
            cfg
        })
        .collect()
}

/// A line of stdin: what to do with which robots.
#[derive(Debug, PartialEq, Eq)]
enum Order {
    /// Crash these robots (their sessions close at once; their tasks stop where they are).
    Kill(Vec<String>),
    /// Start these robots again (with the config they started with).
    Start(Vec<String>),
    /// Print the robots running.
    List,
}

fn parse(line: &str) -> Result<Option<Order>, String> {
    let mut words = line.split_whitespace();
    let Some(verb) = words.next() else { return Ok(None) };
    let ids: Vec<String> = words.map(String::from).collect();
    match verb {
        "kill" | "start" if ids.is_empty() => Err(format!("{verb}: name the robots (e.g. `{verb} r3 r7`)")),
        "kill" => Ok(Some(Order::Kill(ids))),
        "start" => Ok(Some(Order::Start(ids))),
        "list" => Ok(Some(Order::List)),
        other => Err(format!("unknown command {other:?}: kill ID…, start ID…, list")),
    }
}

/// The process's robots.
#[derive(Default)]
struct Fleet {
    configs: BTreeMap<String, RobotConfig>,
    /// Robots running, each with what crashes it (none: crashed, still closing).
    running: BTreeMap<String, Option<oneshot::Sender<()>>>,
    tasks: JoinSet<(String, anyhow::Result<()>)>,
}

impl Fleet {
    fn spawn(&mut self, cfg: RobotConfig, shutdown: &CancellationToken, ready: &tokio::sync::mpsc::UnboundedSender<String>) {
        let (kill_tx, kill_rx) = oneshot::channel();
        let id = cfg.id.clone();
        self.running.insert(id.clone(), Some(kill_tx));
        let (shutdown, ready) = (shutdown.clone(), ready.clone());
        self.tasks.spawn(async move {
            let result = one(cfg, shutdown, kill_rx, ready).await;
            (id, result)
        });
    }

    fn command(&mut self, line: &str, shutdown: &CancellationToken, ready: &tokio::sync::mpsc::UnboundedSender<String>) {
        match parse(line) {
            Ok(None) => {}
            Ok(Some(Order::Kill(ids))) => ids.iter().for_each(|id| self.kill(id)),
            Ok(Some(Order::Start(ids))) => {
                for id in ids {
                    match self.configs.get(&id) {
                        _ if self.running.contains_key(&id) => eprintln!("sim-fleet: robot {id} is running or still stopping"),
                        Some(cfg) => self.spawn(cfg.clone(), shutdown, ready),
                        None => eprintln!("sim-fleet: no robot {id} in this fleet"),
                    }
                }
            }
            Ok(Some(Order::List)) => println!("running ids={}", self.alive().collect::<Vec<_>>().join(",")),
            Err(e) => eprintln!("sim-fleet: {e}"),
        }
    }

    /// The robots running (not crashed).
    fn alive(&self) -> impl DoubleEndedIterator<Item = &str> {
        self.running.iter().filter(|(_, k)| k.is_some()).map(|(id, _)| id.as_str())
    }

    fn kill(&mut self, id: &str) {
        match self.running.get_mut(id).and_then(Option::take) {
            Some(kill) => {
                let _ = kill.send(());
            }
            None => eprintln!("sim-fleet: robot {id} is not running"),
        }
    }

    /// Waits for every robot to stop (after the shutdown token was cancelled).
    async fn stop_all(&mut self) {
        let grace = tokio::time::timeout(Duration::from_secs(10), async { while self.tasks.join_next().await.is_some() {} }).await;
        if grace.is_err() {
            tracing::warn!("robots still stopping after 10 s: dropped");
            self.tasks.abort_all();
        }
    }
}

/// One robot from start to stop (or crash).
async fn one(
    cfg: RobotConfig,
    shutdown: CancellationToken,
    kill: oneshot::Receiver<()>,
    ready: tokio::sync::mpsc::UnboundedSender<String>,
) -> anyhow::Result<()> {
    let id = cfg.id.clone();
    let mut started = mrmm_node::robot::start(cfg, shutdown).await?;
    started.announce();
    if started.ready.is_some() {
        let _ = ready.send(id.clone());
    }
    let crashed = tokio::select! {
        r = started.finished() => Some(r),
        Ok(()) = kill => None,
    };
    match crashed {
        // Crashed on the operator's order (`mrmm op crash`): as from stdin; `start` brings it back.
        Some(Err(e)) if e.crashed() => {
            println!("robot crashed id={id}");
            Ok(())
        }
        Some(r) => Ok(r?),
        None => {
            started.kill().await;
            println!("robot killed id={id}");
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_template_makes_robots_of_their_own() {
        let text = r#"{ id: "r", type: "ground", kinematics: { max_speed: 1, max_turn_rate: 1 }, start: { x: 10, y: -2 },
            state_dir: "/s", security: { ca: "/p/ca.crt", cert: "/p/r.crt", key: "/p/r.key" },
            zenoh: { listen: ["quic/127.0.0.1:0"], connect: ["quic/127.0.0.1:7447"] } }"#;
        let cfg = RobotConfig::from_json5("template", text).expect("valid");
        let robots = expand(&cfg, 5, 2.0);
        let ids: Vec<&str> = robots.iter().map(|r| r.id.as_str()).collect();
        assert_eq!(ids, ["r1", "r2", "r3", "r4", "r5"]);
        // A 3-wide grid: r4 starts on the second row.
        assert_eq!((robots[3].start.x, robots[3].start.y), (10.0, 0.0));
        assert_eq!((robots[2].start.x, robots[2].start.y), (14.0, -2.0));
        assert_eq!(robots[4].state_dir.as_deref(), Some(std::path::Path::new("/s/r5")));
        let sec = robots[4].security.as_ref().expect("security kept");
        assert_eq!((sec.cert.to_str(), sec.key.to_str(), sec.ca.to_str()), (Some("/p/r5.crt"), Some("/p/r5.key"), Some("/p/ca.crt")));
    }

    #[test]
    fn stdin_orders_parse_and_a_bad_one_says_what_is_allowed() {
        assert_eq!(parse("kill r1 r2"), Ok(Some(Order::Kill(vec!["r1".into(), "r2".into()]))));
        assert_eq!(parse("  start r3 "), Ok(Some(Order::Start(vec!["r3".into()]))));
        assert_eq!(parse("list"), Ok(Some(Order::List)));
        assert_eq!(parse("   "), Ok(None));
        assert!(parse("kill").unwrap_err().contains("name the robots"));
        assert!(parse("explode r1").unwrap_err().contains("kill ID…, start ID…, list"));
    }
}
