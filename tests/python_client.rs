//! The operator API from outside, with the ecosystem's own client: eclipse-zenoh 1.10.2 from PyPI
//! (`.ci/run` installs it in a pinned virtual environment), no mrmm code. Over mutual TLS, an
//! operator certificate reads the fleet status and commands a robot; a robot certificate can
//! read but its command never reaches the system manager (central's access control), and the
//! robot stays where it is.

mod common;

use std::path::PathBuf;
use std::process::Command;
use std::time::Duration;

use common::{eventually, fleet_pki, start_secure_central, start_secure_robot, Scratch};
use mrmm_net::client::Client;
use mrmm_proto::{Key, RobotView, SecuritySection};
use serde_json::Value;

/// The pinned Python with eclipse-zenoh: `MRMM_PYTHON`, or the virtual environment `.ci/run` makes.
fn python() -> Option<PathBuf> {
    if let Ok(p) = std::env::var("MRMM_PYTHON") {
        return Some(PathBuf::from(p));
    }
    let home = std::env::var_os("HOME")?;
    let p = PathBuf::from(home).join(".cache/mrmm/venv/bin/python");
    p.exists().then_some(p)
}

fn run(py: &PathBuf, ep: &str, pki: &std::path::Path, who: &str, robot: &str) -> anyhow::Result<Value> {
    let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/py/operator_client.py");
    let f = |n: &str| pki.join(n).display().to_string();
    let out = Command::new(py).arg(script).args([ep, &f("ca.crt"), &f(&format!("{who}.crt")), &f(&format!("{who}.key")), robot]).output()?;
    anyhow::ensure!(out.status.success(), "python client as {who}: {}", String::from_utf8_lossy(&out.stderr));
    let line = String::from_utf8_lossy(&out.stdout);
    Ok(serde_json::from_str(line.trim())?)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_plain_zenoh_client_with_an_operator_certificate_commands_and_a_robot_one_does_not() -> anyhow::Result<()> {
    let Some(py) = python() else {
        anyhow::ensure!(std::env::var("CI").as_deref() != Ok("true"), "no Python with eclipse-zenoh under CI: .ci/run installs it");
        println!("SKIPPED: no Python with eclipse-zenoh (run .ci/run once, or set MRMM_PYTHON)");
        return Ok(());
    };
    let dir = Scratch::new("python");
    let pki = fleet_pki(&dir, 1)?;
    let (_central, ep) = start_secure_central(&dir, &pki)?;
    let _r1 = start_secure_robot(&dir, &pki, "r1", &ep, 2.0)?;
    let op = Client::connect_with(std::slice::from_ref(&ep), Some(SecuritySection::from_dir(&pki, "op")), Duration::from_secs(5)).await?;
    common::wait_robots(&op, 1).await?;

    // A robot's certificate: it reads, but its command is dropped by central.
    let rogue = run(&py, &ep, &pki, "r9", "r1")?;
    println!("as robot r9: {rogue}");
    assert_eq!(rogue["status"]["robots_total"], 1, "{rogue}");
    assert!(rogue["goto"].is_null(), "a robot certificate commanded through the operator API: {rogue}");
    let pose = |v: Vec<RobotView>| v.into_iter().find(|r| r.id == "r1").and_then(|r| r.pose);
    let before = pose(op.query(Key::SystemRobots, None::<&()>).await?).ok_or_else(|| anyhow::anyhow!("no pose"))?;
    assert!((before.x - 2.0).abs() < 0.1, "r1 moved: {before:?}");

    // The operator's: it reads and commands.
    let operator = run(&py, &ep, &pki, "op", "r1")?;
    println!("as operator op: {operator}");
    assert_eq!(operator["status"]["robots_total"], 1, "{operator}");
    assert_eq!(operator["goto"]["ok"], true, "{operator}");
    // An error is read by its code: a goto for a robot that does not exist is `not_found`, and the
    // client branched on that (not on the words).
    assert_eq!(operator["unknown"]["code"], "not_found", "{operator}");
    assert_eq!(operator["unknown"]["then"], "check the name", "{operator}");
    eventually("r1 driving to the operator's goto", Duration::from_secs(10), || async {
        let p = pose(op.query(Key::SystemRobots, None::<&()>).await.ok()?)?;
        ((p.x - before.x).abs() + (p.y - before.y).abs() > 0.05).then_some(())
    })
    .await?;
    // zenoh-cli (the ecosystem's command line, PyPI's `zenoh-cli`) with the same certificate:
    // the fleet's status, as the docs show it (docs/api.md, "Secure fleet").
    let cli = py.with_file_name("zenoh");
    let f = |n: &str| format!("\"{}\"", pki.join(n).display());
    let cfg = [
        "scouting/multicast/enabled:false".to_string(),
        format!("transport/link/tls/root_ca_certificate:{}", f("ca.crt")),
        format!("transport/link/tls/connect_certificate:{}", f("op.crt")),
        format!("transport/link/tls/connect_private_key:{}", f("op.key")),
        "transport/link/tls/enable_mtls:true".to_string(),
        "transport/link/tls/verify_name_on_connect:false".to_string(),
    ];
    let mut zenoh_cli = Command::new(&cli);
    zenoh_cli.args(["--mode", "client", "--connect", &ep]);
    for c in &cfg {
        zenoh_cli.args(["--cfg", c]);
    }
    let status_key = Key::SystemStatus.to_string();
    let out = zenoh_cli.args(["get", "--decoder", "json", "-s", &status_key]).output()?;
    let said = String::from_utf8_lossy(&out.stdout);
    println!("zenoh-cli: {said}");
    let status: Value = serde_json::from_str(said.lines().next().unwrap_or_default())
        .map_err(|e| anyhow::anyhow!("zenoh-cli said {said:?} ({e}); stderr: {}", String::from_utf8_lossy(&out.stderr)))?;
    assert_eq!(status["robots_total"], 1, "{status}");
    op.close().await;
    Ok(())
}

/// Issue 50: `mrmm pki` wrote Ed25519 keys as PKCS#8 v2, which OpenSSL 3.0 ("unsupported") and
/// Python's `cryptography` ("extra data") refuse. Its keys are now v1: `openssl pkey` reads one,
/// and a Python client with nothing but `cryptography` and eclipse-zenoh seals a message with a
/// robot's key that a fleet node (`mrmm tap`, checking seals as every node does) proves as that
/// robot's; the same seal made with another key is refused.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn standard_tools_read_the_fleets_keys_and_a_python_client_seals_with_them() -> anyhow::Result<()> {
    let Some(py) = python() else {
        anyhow::ensure!(std::env::var("CI").as_deref() != Ok("true"), "no Python with eclipse-zenoh under CI: .ci/run installs it");
        println!("SKIPPED: no Python with eclipse-zenoh (run .ci/run once, or set MRMM_PYTHON)");
        return Ok(());
    };
    let dir = Scratch::new("python-seal");
    let pki = fleet_pki(&dir, 1)?;
    let f = |n: &str| pki.join(n).display().to_string();
    let openssl = Command::new("openssl").args(["pkey", "-in", &f("r1.key"), "-noout", "-text"]).output();
    match openssl {
        Ok(out) => anyhow::ensure!(
            out.status.success() && String::from_utf8_lossy(&out.stdout).contains("ED25519"),
            "openssl pkey: {}",
            String::from_utf8_lossy(&out.stderr)
        ),
        Err(e) => anyhow::ensure!(std::env::var("CI").as_deref() != Ok("true"), "no openssl under CI: {e}"),
    }
    let (_central, ep) = start_secure_central(&dir, &pki)?;
    let (_tap, lines) = common::start_lines(
        &[],
        "tap",
        &["tap", "sealtest/**", "--connect", &ep, "--pki", &pki.display().to_string(), "--as", "op", "--duration", "60"],
        &dir.path("tap.log"),
        "{\"tap\"",
        Duration::from_secs(20),
    )?;
    let seal = |signing: &str, payload: &str| -> anyhow::Result<Value> {
        let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/py/seal_client.py");
        let args = [&ep, &f("ca.crt"), &f("r1.crt"), &f("r1.key"), "robot", "r1", "sealtest/hello", payload, &f(signing)];
        let out = Command::new(&py).arg(script).args(args).output()?;
        anyhow::ensure!(out.status.success(), "seal_client.py: {}", String::from_utf8_lossy(&out.stderr));
        Ok(serde_json::from_str(String::from_utf8_lossy(&out.stdout).trim())?)
    };
    // The Python client publishes once, just after it linked: a put that left before the tap's
    // subscription reached it is lost, so it is sent again (three times in 15 s at most).
    let heard = |signing: &str, payload: &str| -> anyhow::Result<Value> {
        for _ in 0..3 {
            println!("{}", seal(signing, &format!(r#"{{"say": "{payload}"}}"#))?);
            let deadline = std::time::Instant::now() + Duration::from_secs(5);
            while let Ok(line) = lines.recv_timeout(deadline.saturating_duration_since(std::time::Instant::now())) {
                let v: Value = serde_json::from_str(&line)?;
                if v["payload"]["say"] == payload {
                    return Ok(v);
                }
            }
        }
        anyhow::bail!("the tap never showed {payload}")
    };
    let v = heard("r1.key", "signed")?;
    assert_eq!(v["from"], "robot:r1", "the Python seal proves r1: {v}");
    // r1's link and certificate, the seal signed with another node's key: refused.
    let v = heard("op.key", "forged")?;
    assert!(v["from"].is_null(), "a seal signed with another key is refused: {v}");
    Ok(())
}
