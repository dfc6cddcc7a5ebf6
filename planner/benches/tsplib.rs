//! TSPLIB benchmark: every instance in `tests/data/tsplib/` solved with a wall-clock limit per
//! instance; prints length, excess over the known optimum and time, then the mean excess.
//!
//! `cargo bench -p mrmm-planner --bench tsplib [-- TIME_MS [SEED]]` (default 1000 ms, seed 1).

use std::path::PathBuf;
use std::time::{Duration, Instant};

use mrmm_planner::tsp::{self, Budget};
use mrmm_planner::tsplib;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with("--")).collect();
    let limit_ms: u64 = args.first().and_then(|s| s.parse().ok()).unwrap_or(1000);
    let seed: u64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(1);
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/tsplib");
    let optima = match std::fs::read_to_string(dir.join("optima.txt")) {
        Ok(t) => t,
        Err(e) => {
            eprintln!("cannot read {}: {e}", dir.join("optima.txt").display());
            std::process::exit(1);
        }
    };
    let mut rows = Vec::new();
    println!("| instance | n | optimum | length | excess % | time ms | kicks |");
    println!("|---|---:|---:|---:|---:|---:|---:|");
    for line in optima.lines().filter(|l| !l.starts_with('#') && !l.trim().is_empty()) {
        let mut it = line.split_whitespace();
        let (Some(name), Some(opt)) = (it.next(), it.next().and_then(|v| v.parse::<f64>().ok())) else { continue };
        let text = match std::fs::read_to_string(dir.join(format!("{name}.tsp"))) {
            Ok(t) => t,
            Err(e) => {
                eprintln!("{name}: {e}");
                continue;
            }
        };
        let inst = match tsplib::parse(&text) {
            Ok(i) => i.instance,
            Err(e) => {
                eprintln!("{name}: {e}");
                continue;
            }
        };
        let t0 = Instant::now();
        // Stop a little early so that construction + search + the final copy stay within the limit.
        let limit = Duration::from_millis(limit_ms * 98 / 100);
        let stop = || t0.elapsed() >= limit;
        let (tour, stats) = match tsp::solve(&inst, &Budget { max_kicks: u64::MAX, stop: Some(&stop), seed }) {
            Ok(r) => r,
            Err(e) => {
                eprintln!("{name}: {e}");
                continue;
            }
        };
        let ms = t0.elapsed().as_secs_f64() * 1000.0;
        assert!(tsp::is_permutation(&tour.order, inst.len()));
        let excess = (tour.length / opt - 1.0) * 100.0;
        println!("| {name} | {} | {opt} | {} | {excess:.2} | {ms:.0} | {} |", inst.len(), tour.length, stats.kicks);
        rows.push((excess, ms));
    }
    let mean = rows.iter().map(|r| r.0).sum::<f64>() / rows.len().max(1) as f64;
    let worst_ms = rows.iter().map(|r| r.1).fold(0.0, f64::max);
    println!("\nmean excess {mean:.3} % over {} instances; slowest solve {worst_ms:.0} ms (limit {limit_ms} ms, seed {seed})", rows.len());
}
