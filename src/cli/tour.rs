//! `mrmm tour`: a near-optimal closed tour through a TSPLIB instance.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use anyhow::Context;
use mrmm_planner::tsp::{self, Budget};
use mrmm_planner::tsplib;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// TSPLIB file (EUC_2D, CEIL_2D or ATT).
    file: PathBuf,
    /// Wall-clock limit of the search.
    #[arg(long, default_value_t = 1000)]
    time_limit_ms: u64,
    /// Seed of the search's randomness.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Write the tour here in TSPLIB TOUR format.
    #[arg(long)]
    out: Option<PathBuf>,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let text = std::fs::read_to_string(&args.file).with_context(|| format!("cannot read {}", args.file.display()))?;
    let inst = tsplib::parse(&text).with_context(|| args.file.display().to_string())?;
    let t0 = Instant::now();
    let limit = Duration::from_millis(args.time_limit_ms * 98 / 100);
    let stop = || t0.elapsed() >= limit;
    let (tour, stats) = tsp::solve(&inst.instance, &Budget { max_kicks: u64::MAX, stop: Some(&stop), seed: args.seed })?;
    println!("length {}", tour.length);
    eprintln!(
        "{}: {} points, {:.0} ms, start {} → local optimum {} → {} after {} kicks",
        inst.name,
        inst.instance.len(),
        t0.elapsed().as_secs_f64() * 1e3,
        stats.start_length,
        stats.local_length,
        tour.length,
        stats.kicks
    );
    if let Some(out) = args.out {
        let name = if inst.name.is_empty() { "tour" } else { &inst.name };
        std::fs::write(&out, tsplib::write_tour(name, &tour.order, tour.length)).with_context(|| format!("cannot write {}", out.display()))?;
    }
    Ok(())
}
