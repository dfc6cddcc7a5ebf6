//! The fleet view recorded: `mrmm demo --rrd` for a short run, with one robot killed on the way,
//! writes a Rerun recording whose entities include every robot, the missions' map and scalars,
//! and the advice log with the agent's critical "robot lost" entry. Decoded with Rerun's own
//! decoder.

mod common;

use std::collections::BTreeMap;
use std::process::Command;
use std::time::{Duration, Instant};

use common::{start, Scratch};
use rerun::external::re_log_encoding::DecoderApp;
use rerun::log::{Chunk, LogMsg};

#[test]
fn demo_records_robots_missions_and_advice() -> anyhow::Result<()> {
    let dir = Scratch::new("rrd");
    let rrd = dir.path("fleet.rrd");
    let rrd_s = rrd.display().to_string();
    let mut demo = start(
        "demo",
        &["demo", "--robots", "4", "--duration", "14", "--listen", "tcp/127.0.0.1:0", "--time-scale", "5", "--rrd", &rrd_s],
        &dir.path("demo.log"),
        "mrmm demo: central on",
        Duration::from_secs(30),
    )?;
    // Kill robot r2 once the missions run (its config lives in the demo's scratch directory).
    std::thread::sleep(Duration::from_secs(6));
    let pattern = format!("mrmm-demo-{}/r2.json5", demo.pid());
    let st = Command::new("pkill").args(["-9", "-f", &pattern]).status()?;
    anyhow::ensure!(st.success(), "could not kill r2 ({pattern})");
    let t = Instant::now();
    let status = loop {
        if let Some(s) = demo.child.try_wait()? {
            break s;
        }
        anyhow::ensure!(t.elapsed() < Duration::from_secs(40), "demo did not end");
        std::thread::sleep(Duration::from_millis(100));
    };
    assert!(status.success(), "demo exit status {status}");

    let file = std::io::BufReader::new(std::fs::File::open(&rrd)?);
    let mut rows: BTreeMap<String, usize> = BTreeMap::new();
    for msg in DecoderApp::decode_lazy(file) {
        if let LogMsg::ArrowMsg(_, arrow) = msg? {
            let chunk = Chunk::from_arrow_msg(&arrow)?;
            *rows.entry(chunk.entity_path().to_string()).or_default() += chunk.num_rows();
        }
    }
    let has = |p: &str| rows.get(p).copied().unwrap_or(0);
    for r in 1..=4 {
        assert!(has(&format!("/fleet/robots/r{r}")) > 0, "robot r{r} missing: {:?}", rows.keys().collect::<Vec<_>>());
        assert!(has(&format!("/fleet/robots/r{r}/trail")) > 0);
    }
    assert!(has("/fleet/missions/patrol-1/tour") > 0, "{:?}", rows.keys().collect::<Vec<_>>());
    assert!(has("/fleet/missions/coverage-1/points") > 0);
    assert!(has("/advice") > 0, "no advice logged: {:?}", rows.keys().collect::<Vec<_>>());
    assert!(has("/events/teams") > 0 && has("/events/sync") > 0);
    assert!(rows.keys().any(|k| k.starts_with("/metrics/patrol-1/")));
    Ok(())
}
