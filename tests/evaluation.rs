//! `mrmm experiment` in a tiny configuration (2 sizes, 2 rounds, 2 environment scales), so that
//! the evaluation does not rot: every experiment runs on real processes, writes its rows, its
//! figure and the summary, and the numbers are those of a patrol (idleness near L/(n·v), more
//! robots less idle, more messages with more robots).

mod common;

use std::collections::BTreeMap;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::{Scratch, EXE};

#[test]
fn every_experiment_runs_tiny_and_writes_rows_figures_and_summary() -> anyhow::Result<()> {
    let dir = Scratch::new("evaluation");
    let out = dir.path("results");
    let mut child = Command::new(EXE)
        .args(["experiment", "all", "--sizes", "2,4", "--extract", "2", "--rounds", "2", "--scales", "1,2", "--time-scale", "10", "--out"])
        .arg(&out)
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(dir.path("experiment.log"))?)
        .spawn()?;
    let deadline = Instant::now() + Duration::from_secs(600);
    let status = loop {
        if let Some(s) = child.try_wait()? {
            break s;
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            anyhow::bail!("experiment still running after 600 s");
        }
        std::thread::sleep(Duration::from_millis(200));
    };
    let log = std::fs::read_to_string(dir.path("experiment.log")).unwrap_or_default();
    anyhow::ensure!(status.success(), "experiment failed: {log}");

    let csv = std::fs::read_to_string(out.join("results.csv"))?;
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap_or_default().split(',').collect();
    let rows: Vec<BTreeMap<&str, &str>> = lines.map(|l| header.iter().copied().zip(l.split(',')).collect()).collect();
    let num = |r: &BTreeMap<&str, &str>, k: &str| -> f64 { r.get(k).and_then(|v| v.parse().ok()).unwrap_or(f64::NAN) };
    let labels: Vec<String> = rows.iter().map(|r| format!("{}:{}:{}", r["experiment"], r["label"], r["env_scale"])).collect();
    assert_eq!(
        labels,
        [
            "messages:2:1",
            "messages:4→2:1",
            "idleness:2:1",
            "idleness:4:1",
            "timescale:2:1",
            "environment:2:1",
            "environment:4:1",
            "environment:2:2",
            "environment:4:2"
        ],
        "{csv}"
    );
    for r in &rows {
        let (idle, bound) = (num(r, "avg_idleness_s"), num(r, "bound_s"));
        assert!(num(r, "msgs_total") > 0.0 && num(r, "sync_points") > 0.0, "{r:?}");
        if r["extracted"] == "0" {
            // Idleness is the time no robot is within a waypoint's 1.5 m: a little under the
            // point-visit bound plus what the barriers cost. Counting one robot's pass twice (or
            // a robot waiting at a waypoint once a second) puts it far below.
            assert!((0.8..1.4).contains(&(idle / bound)), "idleness {idle} s against the bound {bound} s: {r:?}");
        }
    }
    let get = |e: &str, label: &str, scale: &str| rows.iter().find(|r| r["experiment"] == e && r["label"] == label && r["env_scale"] == scale);
    let (two, four) = (get("idleness", "2", "1").expect("row"), get("idleness", "4", "1").expect("row"));
    assert!(num(four, "avg_idleness_s") < num(two, "avg_idleness_s"), "four robots less idle than two: {csv}");
    assert!(num(four, "msgs_sync") > num(two, "msgs_sync"), "more robots, more barrier arrivals: {csv}");
    let (small, big) = (get("environment", "2", "1").expect("row"), get("environment", "2", "2").expect("row"));
    assert!(num(big, "tour_m") > 1.9 * num(small, "tour_m"), "the environment is scaled: {csv}");

    for f in ["messages.png", "idleness.png", "environment.png"] {
        let png = std::fs::read(out.join(f))?;
        assert!(png.len() > 10_000 && &png[1..4] == b"PNG", "{f}: {} bytes", png.len());
    }
    let summary = std::fs::read_to_string(out.join("summary.md"))?;
    for part in ["![messages.png](messages.png)", "## The paper's claims", "Fig. 4", "Fig. 5", "Fig. 6", "Time scaling", "Machine:"] {
        assert!(summary.contains(part), "summary.md lacks {part:?}:\n{summary}");
    }
    Ok(())
}
