//! Test harness: real `mrmm` processes on loopback, killed on drop, and waiting helpers.
#![allow(dead_code)]

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Context};

pub mod measure;
pub mod netns;
pub mod standin;

pub const EXE: &str = env!("CARGO_BIN_EXE_mrmm");

/// A running `mrmm` process; SIGKILLed when dropped.
pub struct Proc {
    pub name: String,
    pub child: Child,
    pub ready: String,
}

impl Proc {
    pub fn pid(&self) -> i32 {
        self.child.id() as i32
    }
    pub fn signal(&self, sig: &str) -> anyhow::Result<()> {
        let st = Command::new("kill").args([&format!("-{sig}"), &self.pid().to_string()]).status()?;
        if !st.success() {
            bail!("kill -{sig} {} failed", self.name);
        }
        Ok(())
    }
    /// SIGKILL and reap.
    pub fn kill(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
    /// The value of `key=` in the ready line.
    pub fn field(&self, key: &str) -> Option<String> {
        self.ready.split_whitespace().find_map(|w| w.strip_prefix(key)?.strip_prefix('=').map(str::to_string))
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        let _ = Command::new("kill").args(["-CONT", &self.pid().to_string()]).stderr(Stdio::null()).status();
        self.kill();
    }
}

/// A scratch directory for configs and logs, removed on drop.
pub struct Scratch(pub PathBuf);

impl Scratch {
    pub fn new(tag: &str) -> Self {
        let n = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_nanos()).unwrap_or(0);
        let p = std::env::temp_dir().join(format!("mrmm-test-{tag}-{}-{n}", std::process::id()));
        std::fs::create_dir_all(&p).expect("scratch dir");
        Scratch(p)
    }
    pub fn path(&self, name: &str) -> PathBuf {
        self.0.join(name)
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        if !std::thread::panicking() && std::env::var_os("MRMM_KEEP_LOGS").is_none() {
            let _ = std::fs::remove_dir_all(&self.0);
        } else {
            eprintln!("logs kept in {}", self.0.display());
        }
    }
}

/// Starts `mrmm <args>` with stderr to `log` and waits for a stdout line starting with `prefix`.
pub fn start(name: &str, args: &[&str], log: &Path, prefix: &str, timeout: Duration) -> anyhow::Result<Proc> {
    start_wrapped(&[], name, args, log, prefix, timeout)
}

/// Like [`start`], with `mrmm` run through `wrapper` (e.g. `ip netns exec <ns>`).
pub fn start_wrapped(wrapper: &[&str], name: &str, args: &[&str], log: &Path, prefix: &str, timeout: Duration) -> anyhow::Result<Proc> {
    start_lines(wrapper, name, args, log, prefix, timeout).map(|(p, _)| p)
}

/// Like [`start_wrapped`], and returns the process's further stdout lines as they come.
pub fn start_lines(wrapper: &[&str], name: &str, args: &[&str], log: &Path, prefix: &str, timeout: Duration) -> anyhow::Result<(Proc, mpsc::Receiver<String>)> {
    spawn_lines(wrapper, name, args, log, prefix, timeout, Stdio::null())
}

/// Like [`start_lines`], with the process's stdin to write to.
pub fn start_piped(
    name: &str,
    args: &[&str],
    log: &Path,
    prefix: &str,
    timeout: Duration,
) -> anyhow::Result<(Proc, std::process::ChildStdin, mpsc::Receiver<String>)> {
    let (mut p, rx) = spawn_lines(&[], name, args, log, prefix, timeout, Stdio::piped())?;
    let stdin = p.child.stdin.take().ok_or_else(|| anyhow!("no stdin"))?;
    Ok((p, stdin, rx))
}

fn spawn_lines(
    wrapper: &[&str],
    name: &str,
    args: &[&str],
    log: &Path,
    prefix: &str,
    timeout: Duration,
    stdin: Stdio,
) -> anyhow::Result<(Proc, mpsc::Receiver<String>)> {
    let log_file = std::fs::File::create(log)?;
    let (program, pre): (&str, Vec<&str>) = match wrapper.split_first() {
        Some((p, rest)) => (p, rest.iter().copied().chain([EXE]).collect()),
        None => (EXE, vec![]),
    };
    let mut child = Command::new(program)
        .args(pre)
        .args(args)
        .env("RUST_LOG", std::env::var("MRMM_TEST_LOG").unwrap_or_else(|_| "info,zenoh=warn,mrmm_core::mission::chain=debug,mrmm_manager::host=trace".into()))
        // Central's default state dir is per user: each test has its own (a central restarted in
        // a test finds its journal there).
        .env("XDG_DATA_HOME", log.parent().unwrap_or(Path::new(".")).join("data"))
        .stdin(stdin)
        .stdout(Stdio::piped())
        .stderr(log_file)
        .spawn()
        .with_context(|| format!("spawn {name}"))?;
    let out = child.stdout.take().ok_or_else(|| anyhow!("no stdout"))?;
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(out).lines().map_while(Result::ok) {
            let _ = tx.send(line);
        }
    });
    let deadline = Instant::now() + timeout;
    let mut proc = Proc { name: name.to_string(), child, ready: String::new() };
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        match rx.recv_timeout(left) {
            Ok(line) if line.starts_with(prefix) => {
                proc.ready = line;
                return Ok((proc, rx));
            }
            Ok(_) => continue,
            Err(_) => {
                let log = std::fs::read_to_string(log).unwrap_or_default();
                bail!("{name} not ready within {timeout:?}; log:\n{log}");
            }
        }
    }
}

/// The remote addresses of the established TCP connections of process `pid`, read with `ss`
/// (inside network namespace `ns` if given).
pub fn tcp_peers(ns: Option<&str>, pid: i32) -> anyhow::Result<Vec<String>> {
    let mut cmd = match ns {
        Some(ns) => {
            let mut c = Command::new("ip");
            c.args(["netns", "exec", ns, "ss"]);
            c
        }
        None => Command::new("ss"),
    };
    let out = cmd.args(["-Htnp", "state", "established"]).output().context("ss")?;
    anyhow::ensure!(out.status.success(), "ss: {}", String::from_utf8_lossy(&out.stderr).trim());
    let text = String::from_utf8_lossy(&out.stdout);
    let tag = format!("pid={pid},");
    Ok(text.lines().filter(|l| l.contains(&tag)).filter_map(|l| l.split_whitespace().nth(3).map(String::from)).collect())
}

/// Starts central on a free loopback port; returns it and its endpoint.
pub fn start_central(dir: &Scratch) -> anyhow::Result<(Proc, String)> {
    let p = start("central", &["central", "--listen", "tcp/127.0.0.1:0"], &dir.path("central.log"), "central ready", Duration::from_secs(20))?;
    let ep = p.field("listening").and_then(|l| l.split(',').next().map(str::to_string)).ok_or_else(|| anyhow!("no endpoint in {:?}", p.ready))?;
    Ok((p, ep))
}

/// Writes a robot config and starts the robot (time scale 5).
pub fn start_robot(dir: &Scratch, id: &str, central: &str, x: f64, y: f64) -> anyhow::Result<Proc> {
    start_robot_scaled(dir, id, central, x, y, 5.0)
}

/// Writes a robot config and starts the robot.
pub fn start_robot_scaled(dir: &Scratch, id: &str, central: &str, x: f64, y: f64, time_scale: f64) -> anyhow::Result<Proc> {
    start_robot_with(dir, id, &[central.to_string()], x, y, time_scale)
}

/// Writes a robot config connecting to `connect` (central and/or peers) and starts the robot.
pub fn start_robot_with(dir: &Scratch, id: &str, connect: &[String], x: f64, y: f64, time_scale: f64) -> anyhow::Result<Proc> {
    let path = robot_config(dir, id, connect, x, y, time_scale)?.display().to_string();
    start(id, &["robot", "--config", &path], &dir.path(&format!("{id}.log")), "robot ready", Duration::from_secs(20))
}

/// Writes robot `id`'s config (`<scratch>/<id>.json5`) and returns its path.
pub fn robot_config(dir: &Scratch, id: &str, connect: &[String], x: f64, y: f64, time_scale: f64) -> anyhow::Result<PathBuf> {
    let connect = serde_json::to_string(connect)?;
    let cfg = format!(
        r#"{{ id: "{id}", type: "ground", capabilities: ["camera"],
             kinematics: {{ max_speed: 1.0, max_turn_rate: 2.0 }},
             start: {{ x: {x}, y: {y} }}, time_scale: {time_scale}, telemetry_hz: 10,
             zenoh: {{ listen: ["tcp/127.0.0.1:0"], connect: {connect}, lease_ms: 1000 }} }}"#
    );
    let path = dir.path(&format!("{id}.json5"));
    std::fs::write(&path, cfg)?;
    Ok(path)
}

/// Re-evaluates `f` every 50 ms until it returns `Some`, or fails after `timeout`.
pub async fn eventually<T, F, Fut>(what: &str, timeout: Duration, mut f: F) -> anyhow::Result<T>
where
    F: FnMut() -> Fut,
    Fut: std::future::Future<Output = Option<T>>,
{
    let deadline = Instant::now() + timeout;
    loop {
        if let Some(v) = f().await {
            return Ok(v);
        }
        if Instant::now() >= deadline {
            bail!("timed out after {timeout:?} waiting for {what}");
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

/// Starts `mrmm demo <args>` and returns it with the central endpoint from its first line.
/// Starts `mrmm demo` with `args`; returns it, central's endpoint and the operator's
/// certificate (the demo is secure unless `--insecure` is among `args`).
pub fn start_demo(dir: &Scratch, args: &[&str]) -> anyhow::Result<(Proc, String, Option<mrmm_proto::SecuritySection>)> {
    start_demo_lines(dir, args).map(|(p, ep, s, _)| (p, ep, s))
}

/// [`start_demo`], with the demo's further stdout lines as they come.
#[allow(clippy::type_complexity)]
pub fn start_demo_lines(dir: &Scratch, args: &[&str]) -> anyhow::Result<(Proc, String, Option<mrmm_proto::SecuritySection>, mpsc::Receiver<String>)> {
    let mut all = vec!["demo"];
    all.extend_from_slice(args);
    let (demo, lines) = start_lines(&[], "demo", &all, &dir.path("demo.log"), "mrmm demo: central on", Duration::from_secs(30))?;
    let ep = demo
        .ready
        .split_whitespace()
        .find(|w| w.starts_with("tcp/") || w.starts_with("tls/") || w.starts_with("quic/"))
        .map(|w| w.trim_end_matches(';').to_string())
        .ok_or_else(|| anyhow!("no endpoint in {:?}", demo.ready))?;
    // `export MRMM_TOOL_CONFIG=<file>`: the operator tools' config, with the certificate.
    let tool = demo.ready.split_whitespace().find_map(|w| w.strip_prefix("MRMM_TOOL_CONFIG=")).map(std::path::PathBuf::from);
    let security = match tool {
        Some(path) => {
            #[derive(serde::Deserialize)]
            struct Tool {
                security: Option<mrmm_proto::SecuritySection>,
            }
            let tool: Tool = mrmm_proto::config::load_json5(&path)?;
            tool.security
        }
        None => None,
    };
    Ok((demo, ep, security, lines))
}

/// One raw HTTP/1.1 request to `addr` naming it as `host`, with an optional bearer token: the
/// status code and the body.
pub fn http(addr: &str, method: &str, path: &str, host: &str, token: Option<&str>, body: &str) -> anyhow::Result<(u16, String)> {
    use std::io::{Read, Write};
    let mut s = std::net::TcpStream::connect(addr)?;
    s.set_read_timeout(Some(Duration::from_secs(10)))?;
    let auth = token.map(|t| format!("Authorization: Bearer {t}\r\n")).unwrap_or_default();
    write!(
        s,
        "{method} {path} HTTP/1.1\r\nHost: {host}\r\n{auth}Content-Type: application/json\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{body}",
        body.len()
    )?;
    let mut out = String::new();
    s.read_to_string(&mut out)?;
    let code = out.split_whitespace().nth(1).and_then(|c| c.parse().ok()).ok_or_else(|| anyhow!("no status in {out:?}"))?;
    let body = out.split_once("\r\n\r\n").map(|(_, b)| b.to_string()).unwrap_or_default();
    Ok((code, body))
}

/// Waits until `n` robots are registered and have reported a pose.
pub async fn wait_robots(client: &mrmm_net::client::Client, n: usize) -> anyhow::Result<Vec<mrmm_proto::RobotView>> {
    eventually(&format!("{n} registered robots"), Duration::from_secs(15), || async {
        let v: Vec<mrmm_proto::RobotView> = client.query(mrmm_proto::Key::SystemRobots, None::<&()>).await.ok()?;
        (v.len() == n && v.iter().all(|r| r.pose.is_some())).then_some(v)
    })
    .await
}

/// Waits for advice `id` to be raised on `mrmm/agent/advice/live`.
pub async fn wait_raised(
    live: &zenoh::pubsub::Subscriber<zenoh::handlers::FifoChannelHandler<zenoh::sample::Sample>>,
    id: &str,
    timeout: Duration,
) -> anyhow::Result<mrmm_proto::Advice> {
    let deadline = Instant::now() + timeout;
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        anyhow::ensure!(!left.is_zero(), "no advice {id} within {timeout:?}");
        let Ok(Ok(s)) = tokio::time::timeout(left, live.recv_async()).await else { continue };
        if let Ok(mrmm_proto::AdviceEvent::Raised(a)) = mrmm_proto::from_json("advice", &s.payload().to_bytes()) {
            if a.id == id {
                return Ok(a);
            }
        }
    }
}

/// Waits for a process to exit and returns its status.
pub async fn wait_exit(p: &mut Proc, timeout: Duration) -> anyhow::Result<std::process::ExitStatus> {
    let t = Instant::now();
    loop {
        if let Some(s) = p.child.try_wait()? {
            return Ok(s);
        }
        anyhow::ensure!(t.elapsed() < timeout, "{} did not exit within {timeout:?}", p.name);
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

/// Robots `r1..=rn` at time scale 10, started in a row at y = -3 (fast patrols for tests).
pub fn start_robots(dir: &Scratch, central: &str, n: usize) -> anyhow::Result<Vec<Proc>> {
    (1..=n).map(|i| start_robot_scaled(dir, &format!("r{i}"), central, i as f64 * 2.0, -3.0, 10.0)).collect()
}

/// A patrol of `count` robots on a 10 m square, optionally on mission host `host`.
pub fn square_patrol(count: usize, host: Option<&str>) -> mrmm_proto::MissionCreate {
    mrmm_proto::MissionCreate {
        name: "p".into(),
        recipe: "patrol".into(),
        count: Some(count),
        host: host.map(Into::into),
        params: [("waypoints".to_string(), serde_json::json!([[0, 0], [10, 0], [10, 10], [0, 10]]))].into(),
        ..Default::default()
    }
}

/// Starts `mrmm mission-host --name <name>` connected to `central`.
pub fn start_host(dir: &Scratch, name: &str, central: &str) -> anyhow::Result<Proc> {
    start(name, &["mission-host", "--name", name, "--connect", central], &dir.path(&format!("{name}.log")), "mission-host ready", Duration::from_secs(20))
}

/// A fleet PKI in `dir/pki`: the CA, `central`, operator `op`, robots `r1..=rn`, and a robot `r9`
/// (a rogue: a valid robot certificate of a robot not in the fleet's missions).
pub fn fleet_pki(dir: &Scratch, robots: usize) -> anyhow::Result<PathBuf> {
    use mrmm_net::security::pki;
    use mrmm_proto::Role;
    let p = dir.path("pki");
    pki::init(&p)?;
    pki::issue(&p, Role::Central, "central", &[], 2)?;
    pki::issue(&p, Role::Operator, "op", &[], 2)?;
    for i in 1..=robots {
        pki::issue(&p, Role::Robot, &format!("r{i}"), &[], 2)?;
    }
    pki::issue(&p, Role::Robot, "r9", &[], 2)?;
    Ok(p)
}

/// A secure session of node `name` of `pki` (its certificate, over QUIC), linked to `connect`:
/// what a node — or an attacker holding that certificate — opens.
pub async fn secure_node(pki: &Path, name: &str, connect: Vec<String>) -> anyhow::Result<mrmm_net::Mesh> {
    use mrmm_net::net::{Mode, DEFAULT_LEASE_MS, DEFAULT_MAX_MESSAGE_SIZE};
    let n = mrmm_net::NodeNet {
        mode: Mode::Peer,
        listen: vec!["quic/127.0.0.1:0".into()],
        connect,
        lease_ms: DEFAULT_LEASE_MS,
        max_message_size: DEFAULT_MAX_MESSAGE_SIZE,
        security: Some(mrmm_proto::SecuritySection::from_dir(pki, name)),
        me: None,
        wire_stats: false,
    };
    Ok(mrmm_net::Mesh::open(&n).await?)
}

/// Starts central over mutual TLS (Zenoh's QUIC link) with the certificates of `pki`; operator
/// `op` may command.
pub fn start_secure_central(dir: &Scratch, pki: &Path) -> anyhow::Result<(Proc, String)> {
    let pki = pki.display().to_string();
    let p = start(
        "central",
        &["central", "--listen", "quic/127.0.0.1:0", "--pki", &pki, "--operator", "op"],
        &dir.path("central.log"),
        "central ready",
        Duration::from_secs(20),
    )?;
    let ep = p.field("listening").and_then(|l| l.split(',').next().map(str::to_string)).ok_or_else(|| anyhow!("no endpoint in {:?}", p.ready))?;
    Ok((p, ep))
}

/// Starts robot `id` over mutual TLS (QUIC, time scale 10), its certificate from `pki`.
pub fn start_secure_robot(dir: &Scratch, pki: &Path, id: &str, central: &str, x: f64) -> anyhow::Result<Proc> {
    start_secure_robot_at(dir, pki, id, central, (x, -3.0), 10.0)
}

/// Robot `id` of the fleet `pki` at `(x, y)`, running `time_scale` times real time, linked to
/// central at `central` over QUIC.
pub fn start_secure_robot_at(dir: &Scratch, pki: &Path, id: &str, central: &str, (x, y): (f64, f64), time_scale: f64) -> anyhow::Result<Proc> {
    let f = |name: &str| serde_json::to_string(&pki.join(name).display().to_string()).unwrap_or_default();
    let cfg = format!(
        r#"{{ id: "{id}", type: "ground", kinematics: {{ max_speed: 1.0, max_turn_rate: 2.0 }},
             start: {{ x: {x}, y: {y} }}, time_scale: {time_scale}, telemetry_hz: 10,
             zenoh: {{ listen: ["quic/127.0.0.1:0"], connect: ["{central}"], lease_ms: 1000 }},
             security: {{ ca: {}, cert: {}, key: {} }} }}"#,
        f("ca.crt"),
        f(&format!("{id}.crt")),
        f(&format!("{id}.key"))
    );
    let path = dir.path(&format!("{id}.json5"));
    std::fs::write(&path, cfg)?;
    let path = path.display().to_string();
    start(id, &["robot", "--config", &path], &dir.path(&format!("{id}.log")), "robot ready", Duration::from_secs(20))
}

/// Every entry of central's journal, page by page.
pub async fn journal(c: &mrmm_net::client::Client) -> anyhow::Result<Vec<mrmm_proto::JournalEntry>> {
    let mut since = 0;
    let mut all = Vec::new();
    loop {
        let page: mrmm_proto::JournalPage = c.query(format!("{}?since={since}", mrmm_proto::Key::SystemJournal), None::<&()>).await?;
        all.extend(page.entries);
        if !page.more {
            return Ok(all);
        }
        since = page.next;
    }
}
